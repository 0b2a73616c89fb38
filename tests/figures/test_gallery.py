"""Time series rebuilt from stored impacts, attractor counting, and the gallery command."""

import json
import os
import shutil
import tomllib

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from cornerbif import analysis, config, gallery, registry, run_sweep, simulate, theory
from cornerbif.cli import main
from cornerbif.models.flow import timeseries as trajectory
from cornerbif.plot_data import PlotData

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CONFIGS = os.path.join(ROOT, "configs")


def _flight_setup(obstacle, **vals):
    v = {k: p.default for k, p in registry.get("flow").params.items()}
    v.update(vals)
    return trajectory.pack(v, obstacle)


# ---------------------------------------------------------------- time series
@pytest.mark.parametrize("kappa", [0.0, -0.014, -0.0128])
def test_rebuilt_flight_meets_obstacle_at_next_impact(kappa):
    """The free flight from each stored impact (closed form, eq 4) reaches z (eq 8) at the
    next stored impact: the miss is event tolerance (1e-12) times the impact speed (< 20),
    so below 1e-9; and between impacts it never goes below z (no impact was skipped)."""
    u0 = np.linspace(2.0, 15.0, 6)
    v0 = np.linspace(-9.0, 11.0, 6)
    res = simulate(u0, v0, transient=300, record=60, omega=1.999, kappa=kappa, r=0.8)
    p, d = _flight_setup("rectified_sine", omega=1.999, kappa=kappa, r=0.8)
    for i in range(len(u0)):
        t, u, vo = res["t"][i], res["u"][i], res["v_out"][i]
        assert np.isfinite(t).sum() == 60
        err = trajectory.meet_error(p, d, t, u, vo)
        assert np.nanmax(err) < 1e-9, (i, np.nanmax(err))
        s, us, zs = trajectory.rebuild(p, d, t, u, vo, t[0], t[-1], samples_per_unit=50)
        assert np.nanmin(us - zs) > -1e-9


def test_rebuilt_flight_detects_a_wrong_impact():
    """The check can fail: a stored height off by du = 1e-6 misses the next impact by
    |du cos s| (u'' + u = 0, flight time s), far above the 1e-9 of a correct record."""
    res = simulate([10.0], [3.0], transient=200, record=20, omega=1.999, kappa=0.0, r=0.8)
    p, d = _flight_setup("rectified_sine", omega=1.999, kappa=0.0, r=0.8)
    t, u, vo = res["t"][0], res["u"][0].copy(), res["v_out"][0]
    du = 1e-6
    for i in range(len(t) - 1):
        s = t[i + 1] - t[i]
        if abs(np.cos(s)) > 0.5:
            break
    u[i] += du
    err = trajectory.meet_error(p, d, t, u, vo)
    assert err[i] == pytest.approx(du * abs(np.cos(s)), abs=1e-10)
    assert err[i] > 1e-7 and np.nanmax(np.delete(err, i)) < 1e-9


def test_resonant_orbit_eq6():
    """Smooth wall z = sin 2t, r = 0.8: the attractor is u = 2(1+r)/(1-r)|sin t| = 18|sin t|
    (eq 6); the rebuilt time series matches it to 1e-7 over four periods."""
    r = 0.8
    res = simulate([5.0], [1.0], transient=500, record=20, obstacle="sine", omega=2.0,
                   kappa=0.0, r=r)
    p, d = _flight_setup("sine", omega=2.0, kappa=0.0, r=r)
    t, u, vo = res["t"][0], res["u"][0], res["v_out"][0]
    s, us, zs = trajectory.rebuild(p, d, t, u, vo, t[0], t[4])
    b = theory.resonant_amplitude(r)
    assert b == pytest.approx(18.0)
    assert np.max(np.abs(us - b * np.abs(np.sin(s)))) < 1e-7
    assert np.allclose(np.diff(t[:5]), np.pi, atol=1e-9)   # one impact per pi


# ---------------------------------------------------------------- attractors
def test_distinct_attractors_synthetic():
    """Shifts of one cycle are one attractor; other values, another; no cycle: -1."""
    cyc = np.array([1.0, 2.0, 3.0])
    rec = 9
    a = np.tile(cyc, 3)                       # cycle 1 2 3
    b = np.roll(a, 1)                         # the same cycle, shifted by one impact
    c = np.tile(cyc + 0.5, 3)                 # another cycle with the same word
    nan = np.full(rec, np.nan)
    vals = np.stack([a, b, c, nan, a + 1e-9])[None]          # one grid point, 5 starts
    period = np.array([[3, 3, 3, 0, 3]])
    ipc = period.copy()
    sym = np.array([["bbg", "bbg", "bbg", "", "bbg"]], dtype=object)
    labels, count = analysis.distinct_attractors(period, ipc, sym, [(vals, "impacts")], 1e-6)
    assert count.tolist() == [2]
    assert labels.tolist() == [[0, 0, 1, -1, 0]]
    # the same values under another word are another attractor
    sym2 = sym.copy()
    sym2[0, 1] = "bgb"
    labels, count = analysis.distinct_attractors(period, ipc, sym2, [(vals, "impacts")], 1e-6)
    assert count.tolist() == [3]


def test_fig05_three_coexisting_orbits(tmp_path):
    """Paper section 3.2 / Fig. 5: at omega = 1.999, kappa = 0 three periodic orbits
    coexist, of period one, two and three (words a, ab, abg: the paper's I, II, III)."""
    scene = config.load(os.path.join(CONFIGS, "fig05.toml"))
    out = run_sweep(scene, str(tmp_path / "fig05.h5"))
    d = PlotData(out)
    labels, count = d.attractors()
    assert int(count) == 3
    firsts = [int(np.nonzero(labels == k)[0][0]) for k in range(3)]
    assert [int(d.period[i]) for i in firsts] == [1, 2, 3]
    assert [str(d.symbols[i]) for i in firsts] == ["a", "ab", "abg"]
    # every start's rebuilt flight meets z at its next impact
    p, dd = _flight_setup("rectified_sine", omega=1.999, kappa=0.0, r=0.8)
    with h5py.File(out) as f:
        for i in firsts:
            t, u, vo = (f[f"impacts/{k}"][i] for k in ("t", "u", "v_out"))
            assert np.nanmax(trajectory.meet_error(p, dd, t, u, vo)) < 1e-9


# ---------------------------------------------------------------- scene keys
def test_plot_keys_validated():
    text = open(os.path.join(CONFIGS, "fig05.toml")).read()
    with pytest.raises(config.SceneError) as e:
        config.loads(text, ["plot.kind=timeserie", "plot.ic=[70]", "plot.cycles=0"])
    msg = "\n".join(e.value.problems)
    assert "plot.kind: 'timeserie' is not a plot kind (did you mean 'timeseries'?)" in msg
    assert "plot.ic: [70]" in msg and "0..63" in msg
    assert "plot.cycles: 0" in msg


# ---------------------------------------------------------------- the gallery command
SMOKE_SET = ("fig05", "fig07a", "fig07b_up", "fig07b_down", "fig16a", "fig16b", "fig06b",
             "chart_map2d")


@pytest.mark.slow
def test_gallery_smoke_and_reuse(tmp_path):
    """Smoke run of a subset: every figure drawn; a second run reuses every sweep; a
    changed [plot] table still reuses, a changed [run] sweeps that scene again."""
    cfg = tmp_path / "configs"
    cfg.mkdir()
    for s in SMOKE_SET:
        shutil.copy(os.path.join(CONFIGS, f"{s}.toml"), cfg)
    out, data = tmp_path / "gallery", tmp_path / "data"
    recs = gallery.run(str(cfg), str(out), str(data), smoke=True, echo=lambda *a: None)
    names = sorted(r["figure"] for r in recs)
    assert names == ["chart_map2d", "fig05", "fig06b", "fig07a", "fig07b", "fig16"]
    for r in recs:
        assert os.path.getsize(r["png"]) > 10_000
        assert all(s["action"] == "swept" for s in r["scenes"].values())
    with h5py.File(data / "fig06b.h5") as f:
        assert f["kappa"].shape == (3,) and f["status"].shape == (3, 3)
    recs = gallery.run(str(cfg), str(out), str(data), smoke=True, echo=lambda *a: None)
    assert {s["action"] for r in recs for s in r["scenes"].values()} == {"reused"}
    p = cfg / "fig06b.toml"
    p.write_text(p.read_text().replace("ylim = [-0.0145, -0.0120]", "ylim = [-0.0145, -0.0121]"))
    p = cfg / "fig07a.toml"
    p.write_text(p.read_text().replace("transient = 0", "transient = 1"))
    recs = gallery.run(str(cfg), str(out), str(data), smoke=True, only=("fig06b", "fig07a"),
                       echo=lambda *a: None)
    acts = {s: v["action"] for r in recs for s, v in r["scenes"].items()}
    assert acts == {"fig06b": "reused", "fig07a": "swept"}


def test_gallery_cli(tmp_path):
    cfg = tmp_path / "configs"
    cfg.mkdir()
    shutil.copy(os.path.join(CONFIGS, "fig07a.toml"), cfg)
    r = CliRunner().invoke(main, ["gallery", "--configs", str(cfg), "--out", str(tmp_path / "g"),
                                  "--data", str(tmp_path / "d"), "--smoke"])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "g" / "fig07a.png").exists()
    run = json.loads((tmp_path / "g" / "gallery_run.json").read_text())
    assert run["runs"][0]["smoke"] and run["figures"][0]["figure"] == "fig07a"
    r = CliRunner().invoke(main, ["gallery", "--configs", str(cfg), "--out", str(tmp_path / "g"),
                                  "--data", str(tmp_path / "d"), "--only", "fig99"])
    assert r.exit_code == 2 and "fig99" in r.output


@pytest.mark.slow
def test_a_smoke_branches_figure_has_attractors_to_follow(tmp_path):
    """A scene drawn as its branches is explained (``cornerbif explain``) before its figure,
    which needs an attractor in the file.  At the smoke's 40-impact transient Fig. 6(a)'s runs
    (omega = 1.999, r = 0.8: an approach at about 0.8^n) had reached no cycle, explain was
    refused and the smoke gallery stopped there; its smoke transient is now
    gallery.SMOKE_EXPLAINED_TRANSIENT, and every smoke run of the scene reaches its cycle."""
    cfg = tmp_path / "configs"
    cfg.mkdir()
    shutil.copy(os.path.join(CONFIGS, "fig06a_explained.toml"), cfg)
    raw = tomllib.loads((cfg / "fig06a_explained.toml").read_text())
    assert gallery.smoke_raw(raw)["run"]["transient"] == gallery.SMOKE_EXPLAINED_TRANSIENT
    recs = gallery.run(str(cfg), str(tmp_path / "g"), str(tmp_path / "d"), smoke=True,
                       echo=lambda *a: None)
    assert [r["figure"] for r in recs] == ["fig06a_explained"]
    with h5py.File(tmp_path / "d" / "fig06a_explained.h5") as f:
        assert (f["period"][...] > 0).all() and len(f["branches/word"]) >= 2
