"""The corner normal form against the full flow (section 5 against sections 2-3).

With epsilon = 1 the map's iterates (a_n, b_n) are the flow's section values
(u, v)(nT) at the paper's section (the corners between clusters).  Expected:
the same words, and b_n within 1e-6 of the flow's (measured ~2e-7 at worst on
Fig. 16's kappa range, docs/discrepancies.md).
"""

import numpy as np
import pytest

from cornerbif import config
from cornerbif import engine as sw
from cornerbif.analysis import words

SCENE = """
[scene]
name = "cmp"
model = "{model}"
[system]
omega = 1.999
r = 0.8
[sweep]
kappa = {{ values = [-0.0141, -0.014, -0.0135, -0.0128, -0.0127, -0.012] }}
[initial]
count = 2
seed = 3
u = [{ulo}, 20.0]
v = [{vlo}, {vhi}]
[run]
transient = 3000
record = 240
[output]
keep = ["section"]
"""


def _run(model):
    text = SCENE.format(model=model, ulo=14.0 if model == "map2d" else 0.0,
                        vlo=-0.02 if model == "map2d" else -20.0,
                        vhi=0.02 if model == "map2d" else 20.0)
    scene = config.loads(text)
    idx = [(i,) for i in range(scene.shape[0])]
    params = sw.pack_points(scene, idx)
    kap = np.full(len(idx), -np.inf) if model == "map2d" else np.array(scene.axes[0].values)
    ics = sw.draw_initial(scene, np.arange(len(idx)), kap)
    ics = ics.reshape(-1, ics.shape[-1])
    prm = np.repeat(params, scene.n_ic, axis=0)
    out, st, final, period, ipc, sym = sw.run_items(prm, ics, sw.int_settings(scene), scene)
    return out, st, period, words(sym)


def test_map_words_and_b_iterates_match_the_flow():
    fo, fst, fper, fwords = _run("flow")
    mo, mst, mper, mwords = _run("map2d")
    assert (fst == 0).all() and (mst == 0).all()
    assert list(fwords) == list(mwords)
    assert list(fwords[2:4]) == ["b" * 24 + "g"] * 2          # kappa = -0.014: period 25
    for i in range(len(fwords)):
        p = fper[i]
        fb = np.sort(np.unique(np.round(fo["sv"][i][-2 * p:], 10)))
        mb = np.sort(np.unique(np.round(mo["sv"][i][-2 * p:], 10)))
        assert fb.size == mb.size == p, (i, fb.size, mb.size)
        assert np.abs(fb - mb).max() < 1e-6, (i, np.abs(fb - mb).max())


def _flow_word(k, w=1.999, r=0.8, record=240):
    from cornerbif import simulate
    res = simulate([16.0, 18.5], [0.0, 0.0], transient=4000, record=record, omega=w, kappa=k, r=r)
    s = set(res["symbols"])
    return s.pop() if len(s) == 1 else ""


@pytest.mark.slow
@pytest.mark.parametrize("N", [5, 12, 24, 36])
def test_beta_N_gamma_plateau_ends_agree_map_and_flow(N):
    """omega = 1.999, r = 0.8: the kappa interval of the (beta^N gamma) orbit of the maps
    (theory.word_interval, exact for the piecewise-linear map) and the plateau of the full
    flow (bisection on kappa with the flow as judge) agree to 1e-7 (measured: <= 1.2e-8)."""
    from cornerbif import theory
    from cornerbif.plateaus import refine_edge
    word = "b" * N + "g"
    lo, hi = theory.word_interval(word, -0.001, 0.8)
    mid = 0.5 * (lo + hi)
    assert _flow_word(mid) == word
    width = hi - lo
    flo = refine_edge(_flow_word, mid, lo - width, word, 1e-10)
    fhi = refine_edge(_flow_word, mid, hi + width, word, 1e-10)
    assert abs(flo - lo) < 1e-7 and abs(fhi - hi) < 1e-7, (flo - lo, fhi - hi)


def test_period_grows_without_bound_near_kappa_C():
    """kappa - kappa_C = 1e-7: the flow resolves a beta^N gamma orbit with N >= 60 (section 5.4:
    N ~ log(delta)/log(r))."""
    from cornerbif import theory
    kc = theory.kappa_C(1.999, 0.8)
    w = _flow_word(kc + 1e-7, record=400)
    assert w == "b" * (len(w) - 1) + "g" and len(w) - 1 >= 60, w
