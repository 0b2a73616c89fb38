"""The normal-form figures (paper Figs 9, 10, 11) from the shipped scenes, at reduced counts.

Expected values and their sources:
- Fig. 9: the regions of (56) are where the flow's first corner cluster is alpha, beta or
  gamma (section 4); measured: >= 99.5 % of starts with a0 > 2 get the same letter, the
  rest sit within 0.15 of Sigma_2 (a0 = 2 + 4/r, eq 41), where the flow's grazing
  transition has its square-root form (section 4.5) instead of the map's jump.
- Fig. 10: A0 of the flow equals the linear maps' (34), (37), (52) to O(epsilon^2) away
  from the switching lines (measured 3.7e-3 at distance > 0.3 in a0 at omega1 = -0.001).
- Fig. 11: near kappa_beta (eq 68) flow and map settle on the same (beta^N alpha) /
  (beta^N gamma) word, and the flow's section points lie within 1e-2 of the map's.
"""

from pathlib import Path

import h5py
import numpy as np
import pytest

from cornerbif import config
from cornerbif import plot_normal_form as nf
from cornerbif.models.flow import normal_form as FN
from cornerbif.models.map2d import normal_form as MN
from cornerbif.plot import figure
from cornerbif.plot_data import PlotData
from cornerbif.sweep import run_sweep

CONFIGS = Path(__file__).resolve().parents[2] / "configs"


def _run(tmp_path, name, **sets):
    text = (CONFIGS / f"{name}.toml").read_text()
    scene = config.loads(text, overrides=[f"{k.replace('__', '.')}={v}" for k, v in sets.items()])
    out = str(tmp_path / f"{name}.h5")
    run_sweep(scene, out)
    return out


def test_fig09_flow_regions_match_the_maps_regions(tmp_path):
    pf = _run(tmp_path, "fig09_flow", initial__count=3000)
    pm = _run(tmp_path, "fig09_map", initial__count=3000)
    f, m = PlotData(pf), PlotData(pm)
    np.testing.assert_array_equal(f.initial["u"], m.initial["u"])   # same starts (same seed)
    a = f.initial["u"].ravel()
    b = f.initial["v"].ravel()
    n = a.size
    lf = FN.flow_regions(f.data["impacts/t"].reshape(n, -1),
                         f.data["impacts/corner_offset"].reshape(n, -1), 1.999)
    lm = MN.map_regions(a, b, -0.001, -0.01, 0.8)
    sel = a > 2.0
    assert set(lm[sel]) == {"a", "b", "g"}
    assert np.mean(lf[sel] == lm[sel]) >= 0.995
    assert np.all(np.abs(a[sel & (lf != lm)] - (2 + 4 / 0.8)) < 0.15)
    out = figure([pf, pm], str(tmp_path / "fig09.png"))
    assert Path(out).stat().st_size > 10_000


def test_fig10_flow_return_map_is_the_linear_map_away_from_the_lines(tmp_path):
    pf = _run(tmp_path, "fig10a", initial__count=800)
    pm = _run(tmp_path, "fig10b", initial__count=800)
    a0, A = nf.return_values(PlotData(pf))
    a0m, Am = nf.return_values(PlotData(pm))
    np.testing.assert_array_equal(a0, a0m)
    # the map file's A0 is the map itself: x1 = P(x0) (maps2d.step)
    np.testing.assert_allclose(Am, nf.map_return_line(-0.001, -0.01, 0.8, -0.007, a0m), rtol=1e-14)
    s1 = (-0.01 + 0.007) / (0.25 * np.pi * -0.001)      # Sigma_1 on b1 = -0.007: a0 = 3.82
    far = (np.abs(a0 - s1) > 0.3) & (np.abs(a0 - 7.0) > 0.3)
    assert np.isfinite(A).all()
    assert np.max(np.abs(A - Am)[far]) < 5e-3
    # the beta branch jumps at Sigma_1 in both: A0 = r a0 + 3.6 (34) against 2 - ... (52)
    just_below, just_above = a0[(a0 < s1) & (a0 > s1 - 0.3)], a0[(a0 > s1) & (a0 < s1 + 0.3)]
    assert just_below.size and just_above.size
    figure([pf, pm], str(tmp_path / "fig10.png"))


@pytest.mark.parametrize("name, letter, period", [("fig11a", "a", 16), ("fig11b", "g", 39)])
def test_fig11_flow_and_map_share_the_near_homoclinic_orbit(tmp_path, name, letter, period):
    pm = _run(tmp_path, name)
    pf = _run(tmp_path, name + "_flow")
    with h5py.File(pm) as m, h5py.File(pf) as f:
        wm, wf = m["symbols"][0].decode(), f["symbols"][0].decode()
        assert wm == wf == letter + "b" * (period - 1) or \
            wm == wf == "b" * (period - 1) + letter
        assert m["period"][0] == f["period"][0] == period
        fu, fv = f["section/u"][0], f["section/v"][0]
        ok = np.isfinite(fu)
        pts_f = np.column_stack([fu[ok], fv[ok]])[-2 * period:]
        pts_m = np.column_stack([m["section/u"][0], m["section/v"][0]])[-2 * period:]
    d = np.min(np.linalg.norm(pts_f[:, None] - pts_m[None], axis=-1), axis=1)
    assert d.max() < 1e-2
    figure([pm, pf], str(tmp_path / f"{name}.png"))


def test_chart_counts_the_coexisting_fixed_points_of_the_hysteresis_wedge(tmp_path):
    # omega = 2.001: for kappa_CC < kappa < kappa_C (eqs 17, 11: 0.0031 < kappa < 0.0141) both
    # fixed points x_alpha* and x_beta* are admissible (section 5.2: c_alpha < 0 < c_beta), so
    # the chart must count 2 attractors there; below kappa_CC only beta's: 1.
    from cornerbif import theory as th
    from cornerbif.plot_diagram import coexisting_words
    text = (CONFIGS / "chart_map2d.toml").read_text()
    scene = config.loads(text, overrides=["sweep.omega.start=2.001", "sweep.omega.stop=2.001",
                                          "sweep.omega.num=1", "sweep.kappa.start=-0.01",
                                          "sweep.kappa.stop=0.008", "sweep.kappa.num=2",
                                          "initial.count=16"])
    out = str(tmp_path / "c.h5")
    run_sweep(scene, out)
    d = PlotData(out)
    n = coexisting_words(d.symbols)
    assert th.c_alpha(0.001, 0.008, 0.8) < 0 < th.c_beta(0.001, 0.008, 0.8)
    assert th.c_alpha(0.001, -0.01, 0.8) > 0 < th.c_beta(0.001, -0.01, 0.8)
    assert n[0, 1] == 2 and set(d.symbols[0, 1]) - {""} == {"a", "b"}
    assert n[0, 0] == 1 and set(d.symbols[0, 0]) == {"b"}
    figure([out], str(tmp_path / "c.png"))


@pytest.mark.parametrize("edit, needle", [
    (["run.transient=5"], "run.transient = 0"),
    (["system.obstacle=\"sine\""], "obstacle 'rectified_sine'"),
    (["sweep.kappa.values=[-0.01, -0.009]"], "without sweep axes"),
])
def test_normal_form_plot_kinds_refuse_scenes_they_cannot_draw(edit, needle):
    with pytest.raises(config.SceneError) as e:
        config.loads((CONFIGS / "fig10a.toml").read_text(), overrides=edit)
    assert needle in str(e.value)
