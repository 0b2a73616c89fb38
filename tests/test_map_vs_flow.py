"""The corner normal form against the full flow (section 5 against sections 2-3).

With epsilon = 1 the map's iterates (a_n, b_n) are the flow's section values
(u, v)(nT) at the paper's section (the corners between clusters).  Expected:
the same words, and b_n within 1e-6 of the flow's (measured ~2e-7 at worst on
Fig. 16's kappa range, docs/discrepancies.md).
"""

import numpy as np
import pytest

from cornerbif import config
from cornerbif import sweep as sw

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
    ics = sw.draw_initial(scene, np.arange(len(idx)), kap).reshape(-1, 2)
    prm = np.repeat(params, scene.n_ic, axis=0)
    out, st, final, period, ipc, sym = sw.run_items(prm, ics, sw.int_settings(scene), scene)
    return out, st, period, sw._words(sym)


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
