"""The two-particle model through scenes, sweep and file (paper section 6)."""

import h5py
import numpy as np
from click.testing import CliRunner

import cornerbif
from cornerbif import config
from cornerbif.cli import main

SCENE = """
[scene]
name = "tp"
model = "two_particle"
[system]
mu = 1000.0
[sweep]
omega0 = { values = [1.9999, 2.0005] }
[initial]
count = 3
[run]
transient = 200
record = 40
[output]
keep = ["impacts", "section", "wall_impacts"]
"""


def test_scene_sweep_and_file(tmp_path):
    p = tmp_path / "tp.toml"
    p.write_text(SCENE)
    out = tmp_path / "tp.h5"
    r = CliRunner().invoke(main, ["sweep", str(p), "-o", str(out)])
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        z, u = f["initial/z"][...], f["initial/u"][...]
        assert (z > 0.0).all() and (u >= z).all()        # w(0) = kappa = 0 < z <= u
        assert f["wall_impacts/t"].shape == (2, 3, 40)
        assert f["section/z"].shape == (2, 3, 40)
        # above omega0_C = 1.99975 the simple orbit: one u-z impact just after each w-z impact
        assert set(f["symbols"][...].astype(str).ravel()) == {"b"}
    assert CliRunner().invoke(main, ["plot", str(out), "-o", str(tmp_path / "tp.png")]).exit_code == 0


def test_mu_inf_and_bad_keys():
    sc = config.loads(SCENE.replace("mu = 1000.0", "mu = inf"))
    assert sc.system["mu"] == float("inf")
    for bad, needle in (("mu = -1.0", "system.mu"), ("mu = nan", "system.mu"),
                        ("mu = 1000.0\nomega = 2.0", "system.omega: unknown key"),
                        ("mu = 1000.0\nr1 = 1.5", "system.r1")):
        try:
            config.loads(SCENE.replace("mu = 1000.0", bad))
        except config.SceneError as e:
            assert needle in str(e), str(e)
        else:
            raise AssertionError(bad)


def test_corner_bifurcation_located_to_1e_minus_7():
    """mu = 1000, r1 = r2 = 0.8, omega1 = 1.001, omega2 = 1 (Fig. 19): the simple orbit 'b'
    (one u-z impact just after each w-z impact) ends at omega0_C; the paper reads 1.99975 off
    its diagram.  Bisection on omega0, following the orbit from omega0 = 1.9999, to 1e-9."""
    r = cornerbif.simulate(1.0, 0.0, 10.0, 0.0, transient=1000, record=60, omega0=1.9999,
                           model="two_particle")
    assert r["symbols"][0] == "b"
    x0 = r["final"][0]

    def is_b(w):
        q = cornerbif.simulate(*x0, transient=1500, record=80, omega0=w, model="two_particle")
        return q["symbols"][0] == "b"

    lo, hi = 1.9997, 1.9999
    assert not is_b(lo) and is_b(hi)
    while hi - lo > 1e-9:
        m = 0.5 * (lo + hi)
        if is_b(m):
            hi = m
        else:
            lo = m
    assert abs(hi - 1.99975) < 1e-5          # the paper's printed value, to its precision
    assert hi - lo < 1e-7
    # below it the period-adding structure: a beta^N gamma orbit just below omega0_C
    q = cornerbif.simulate(*x0, transient=3000, record=200, omega0=lo - 2e-6, model="two_particle")
    w = q["symbols"][0]
    assert w and w.endswith("g") and set(w[:-1]) == {"b"} and len(w) > 5, w


def test_equal_masses_mu_1():
    """mu = 1 (equal masses, the far end of the mass range): every z-u impact conserves
    momentum y + v and reverses the relative velocity by r2 (eq 74), and the run ends OK."""
    r = cornerbif.simulate(1.0, 0.0, 6.0, -2.0, transient=50, record=80, omega0=2.0, mu=1.0,
                           model="two_particle")
    assert r["status"][0] == 0
    ok = np.isfinite(r["t"][0])
    yi, yo, vi, vo = (r[k][0][ok] for k in ("y_in", "y_out", "v_in", "v_out"))
    assert np.allclose(yi + vi, yo + vo, atol=1e-12 * (1 + np.abs(vi).max()))
    assert np.allclose(vo - yo, -0.8 * (vi - yi), atol=1e-12 * (1 + np.abs(vi).max()))
