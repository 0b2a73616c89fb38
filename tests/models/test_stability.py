"""Floquet multipliers of the flow (cornerbif/stability.py, docs/stability.md).

Each formula against something independent of it: the flight matrix against scipy's
matrix exponential, the saltation against the bouncing ball's closed form and det = r^2,
a cycle's determinant against exp(-2 sigma T) r^(2N), and the multipliers against a
central-difference Jacobian of the section map computed by the kernel itself (the
event location and law (5) as the sweep runs them, nothing of stability.py).
"""

import math
import os

import numpy as np
import pytest
from scipy.linalg import expm

import cornerbif
from cornerbif import stability as S
from cornerbif.models.flow import packed as P
from cornerbif.models.flow import tangent as FT
from cornerbif.numerics import saltation as SAL
from cornerbif.numerics.oscillator import derive
from cornerbif.obstacles import dispatch as OB


@pytest.mark.parametrize("sigma,k", [(0.0, 1.0), (0.1, 1.0), (1.0, 1.0), (1.7, 1.0),
                                     (0.0, 0.0), (0.3, 0.0), (0.05, 2.5), (3.0, 0.5)])
@pytest.mark.parametrize("tau", [0.0, 0.3, 2.0, 7.5, 400.0])
def test_flight_matrix_is_the_matrix_exponential(sigma, k, tau):
    """exp(A tau), A = [[0, 1], [-k^2, -2 sigma]]: under-, critically and over-damped, and
    the free particle; against scipy.linalg.expm to 1e-12 (relative to the largest entry)."""
    want = expm(np.array([[0.0, 1.0], [-k * k, -2.0 * sigma]]) * tau)
    got = np.array(SAL.flight_matrix(sigma, k, tau)).reshape(2, 2)
    assert np.abs(got - want).max() <= 1e-12 * max(1.0, np.abs(want).max())
    # Liouville: det = exp(-2 sigma tau), up to the cancellation of forming a det from
    # entries (over-damped, long tau: entries ~0.1 and det ~1e-11)
    assert abs(np.linalg.det(got) - math.exp(-2 * sigma * tau)) <= 1e-14 * max(
        1.0, np.abs(got).max()) ** 2 + 1e-12 * math.exp(-2 * sigma * tau)


def test_saltation_of_the_bouncing_ball():
    """Fixed wall (z' = z'' = 0), sigma = 0, gravity a- = -g: [[-r, 0], [(1 + r) g/|v-|, -r]]
    (the bouncing ball's saltation), det r^2."""
    r, g, v = 0.7, 9.81, -3.0
    s = np.array(SAL.impact_saltation(r, 0.0, v, -g, 0.0)).reshape(2, 2)
    assert np.allclose(s, [[-r, 0.0], [(1 + r) * g / abs(v), -r]], rtol=1e-15)
    assert math.isclose(np.linalg.det(s), r * r, rel_tol=1e-15)


def _orbit(omega, kappa=0.0, u0=5.0, v0=0.0, **system):
    res = cornerbif.simulate([u0], [v0], omega=omega, kappa=kappa, transient=600, record=40,
                             **system)
    assert res["status"][0] == 0
    prm = P.pack(dict(omega=omega, kappa=kappa, **system), "rectified_sine", 1e-12, 1e-6,
                 1e6, None)
    return res, prm


def _section_fd(omega, x, sections, h=1e-6, **system):
    """Central differences of the kernel's section map x(nT) -> x((n + sections) T)."""
    def F(y):
        r = cornerbif.simulate([y[0]], [y[1]], omega=omega, kappa=0.0, transient=0,
                               record=4 * sections + 4, **system)
        return np.array([r["su"][0][sections - 1], r["sv"][0][sections - 1]])
    return np.column_stack([(F(x + h * e) - F(x - h * e)) / (2 * h) for e in np.eye(2)])


@pytest.mark.parametrize("omega,system", [(1.5, {}), (2.3, {}), (1.5, {"sigma": 0.05}),
                                          (2.3, {"sigma": 0.02, "k": 1.2})])
def test_multipliers_of_beta_orbits_match_the_section_map(omega, system):
    """Period-1 orbits of Fig. 4(c)'s family (one impact a cycle): the cycle's multipliers,
    raised to the cycles per section period T = 2 pi/omega, are the eigenvalues of the
    central-difference Jacobian of the kernel's own section map (error of the differences
    ~1e-9), and the monodromy's determinant is exp(-2 sigma T_cycle) r^(2N) to 1e-12."""
    res, prm = _orbit(omega, **system)
    n = int(res["impacts_per_cycle"][0])
    out = FT.cycle_multipliers(prm, res["t"][0], res["u"][0], res["v_in"][0], res["v_out"][0],
                              res["corner_offset"][0], 0, n)
    assert out["status"] == "ok"
    assert math.isclose(np.linalg.det(out["jacobian"]), out["det_closed_form"], rel_tol=1e-12)
    T = 2 * math.pi / omega
    per_section = round(T / out["duration"])
    assert abs(per_section * out["duration"] - T) < 1e-9
    x = np.array([res["su"][0][10], res["sv"][0][10]])
    fd = np.linalg.eigvals(_section_fd(omega, x, 1, **system))
    want = sorted(fd, key=lambda z: (abs(z), z.imag))
    got = sorted(out["multipliers"] ** per_section, key=lambda z: (abs(z), z.imag))
    assert np.allclose(got, want, atol=1e-7), (got, want)


def test_the_multipliers_do_not_depend_on_the_impact_the_cycle_starts_from():
    """A two-cluster cycle (the alpha-alpha orbit at omega = 1.8, 4 impacts): the
    monodromies from each of its impacts are similar matrices: same multipliers."""
    res, prm = _orbit(1.8)
    n = int(res["impacts_per_cycle"][0])
    mus = [FT.cycle_multipliers(prm, res["t"][0], res["u"][0], res["v_in"][0],
                               res["v_out"][0], res["corner_offset"][0], f, n)["multipliers"]
           for f in range(n)]
    for m in mus[1:]:
        assert np.allclose(m, mus[0], rtol=1e-9)


def test_a_grazing_impact_gives_no_multipliers():
    """A record whose impact 1 is reached by the free flight from impact 0 (k = 1, no
    forcing: u = u0 cos t + v0 sin t) with exactly the obstacle's velocity: w- = 0."""
    prm = P.pack(dict(omega=2.0, kappa=0.0), "rectified_sine", 1e-12, 1e-6, 1e6, None)
    zp, _ = OB.obstacle_at_offset(prm, derive(prm), 1.0, 0.3)
    v0 = zp / np.cos(1.0)
    t = np.array([0.0, 1.0, 2.0])
    u = np.array([0.0, v0 * np.sin(1.0), 0.0])
    v_in = np.array([-1.0, v0 * np.cos(1.0), -1.0])
    v_out = np.array([v0, 0.0, 0.0])
    off = np.array([0.3, 0.3, 0.3])
    out = FT.cycle_multipliers(prm, t, u, v_in, v_out, off, 0, 1)
    assert out["status"].startswith("grazing") and np.isnan(out["jacobian"]).all()


# ---------------------------------------------------------------- against the slow reference
def _fd_multipliers(omega, kappa, res, n, system):
    """Eigenvalues of the independent finite-difference Jacobian (tests/fd_reference.py,
    built on tests/naive.py) of the time map over one cycle, started mid-flight after the
    cycle's first impact."""
    import fd_reference as FD
    import naive
    t, u, v = res["t"][0], res["u"][0], res["v_out"][0]
    i = 3
    t0 = 0.5 * (t[i] + t[i + 1])
    kw = {k: system[k] for k in ("sigma", "k", "F", "Omega", "phi") if k in system}
    u0, v0 = naive.free_flight(t0, t[i], u[i], v[i], **kw)
    J, err = FD.fd_jacobian("rectified_sine", omega, kappa, 1.0, 0.8, u0, v0, t0,
                            t[i + n] - t[i], **kw)
    return np.linalg.eigvals(J), err


@pytest.mark.parametrize("omega,kappa,system", [
    (2.3, 0.0, {}), (1.8, 0.0, {}), (2.3, 0.0, {"sigma": 0.03}),
    # harmonic forcing at the obstacle's frequency (period 2 pi/omega: two humps)
    (2.3, 0.0, {"sigma": 0.03, "F": 0.3, "Omega": 2.3, "phi": 0.4}),
    # the single-impact orbit a distance 1e-6 below its corner collision kappa_C (eq 11):
    # its impact lies 5e-7 after the corner (impacts/corner_offset)
    (1.999, "kappa_C - 1e-6", {}), (2.001, "kappa_C - 1e-6", {}),
])
def test_multipliers_match_the_slow_reference(omega, kappa, system):
    """The multipliers equal the eigenvalues of tests/fd_reference.py's Jacobian (central
    differences with step control through the exhaustive simulator tests/naive.py, no code
    of cornerbif) to 1e-6, on stable cycles of one and of four impacts, damped and not,
    forced (the acceleration a- of the saltation holds f(t)), and on cycles whose impact
    lies within 1e-6 of a corner."""
    from cornerbif import theory
    start = {}
    if isinstance(kappa, str):
        kappa = theory.kappa_C(omega, 0.8) - 1e-6
        a, b, _ = theory.single_impact_orbit(omega, kappa, 0.8, exact=True)
        start = {"u0": a, "v0": b}
    res, prm = _orbit(omega, kappa, **start, **system)
    n = int(res["impacts_per_cycle"][0])
    if start:
        assert 0 < res["corner_offset"][0][3] < 1e-6
    out = FT.cycle_multipliers(prm, res["t"][0], res["u"][0], res["v_in"][0], res["v_out"][0],
                              res["corner_offset"][0], 3, n)
    fd, err = _fd_multipliers(omega, kappa, res, n, system)
    key = lambda z: (round(abs(z), 9), z.imag)       # noqa: E731
    got, want = sorted(out["multipliers"], key=key), sorted(fd, key=key)
    assert np.allclose(got, want, atol=1e-6), (got, want, err)


# ---------------------------------------------------------------- in a sweep's file
def test_a_sweep_keeping_stability_stores_each_runs_multipliers(tmp_path):
    """`output.keep = ["impacts", "stability"]`: stability/ datasets with their scales
    (readable by xarray), each run's multipliers those of its last recorded cycle as
    cycle_multipliers computes them from the same file's impacts; a scene that does not
    ask keeps none."""
    import h5py
    from click.testing import CliRunner

    from cornerbif.cli import main
    out = tmp_path / "s.h5"
    scene = os.path.join(os.path.dirname(__file__), "..", "..", "configs", "fig04c.toml")
    r = CliRunner().invoke(main, ["sweep", scene, "-o", str(out),
                                  "--no-progress", "--set", "sweep.omega.num=12",
                                  "--set", "initial.count=2",
                                  "--set", 'output.keep=["impacts", "stability"]'])
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        om = f["omega"][...]
        st = f["stability/status"][...]
        assert st.shape == (12, 2) and (st >= 0).all()
        mre, mim = f["stability/multiplier_re"][...], f["stability/multiplier_im"][...]
        for i in range(12):
            for j in range(2):
                t = f["impacts/t"][i, j]
                n = int(f["impacts_per_cycle"][i, j])
                if st[i, j] != S.OK:
                    continue
                last = int(np.isfinite(t).sum()) - 1 - n
                prm = P.pack(dict(omega=float(om[i]), kappa=0.0), "rectified_sine", 1e-12,
                             1e-6, 1e6, None)
                want = FT.cycle_multipliers(prm, t, f["impacts/u"][i, j], f["impacts/v_in"][i, j],
                                           f["impacts/v_out"][i, j],
                                           f["impacts/corner_offset"][i, j], last, n)
                got = mre[i, j] + 1j * mim[i, j]
                assert np.allclose(got, want["multipliers"], rtol=1e-12, atol=1e-15)
        # the exponents: those run_lyapunov computes from the same file's record
        lam, lst = f["stability/lyapunov"][...], f["stability/lyapunov_status"][...]
        assert (lst == S.OK).sum() >= 20
        for i in range(12):
            for j in range(2):
                prm = P.pack(dict(omega=float(om[i]), kappa=0.0), "rectified_sine", 1e-12,
                             1e-6, 1e6, None)
                want = FT.run_lyapunov(prm, f["impacts/t"][i, j], f["impacts/u"][i, j],
                                      f["impacts/v_in"][i, j], f["impacts/v_out"][i, j],
                                      f["impacts/corner_offset"][i, j],
                                      int(f["impacts_per_cycle"][i, j]), S.WARMUP_SHARE)
                assert lst[i, j] == want[3]
                assert np.array_equal(lam[i, j], want[:2], equal_nan=True)
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    ds = xr.open_dataset(out, engine="h5netcdf", group="stability")
    assert ds["multiplier_re"].dims == ("omega", "ic", "multiplier")
    assert ds["lyapunov"].dims == ("omega", "ic", "exponent")
    assert ds["lyapunov_window"].dims == ("omega", "ic")
    plain = tmp_path / "plain.toml"          # no [output] keep: every observable but opt-ins
    plain.write_text('[scene]\nname = "plain"\nmodel = "flow"\n[initial]\ncount = 1\n'
                     '[run]\ntransient = 10\nrecord = 10\n')
    r = CliRunner().invoke(main, ["sweep", str(plain), "-o", str(tmp_path / "n.h5"),
                                  "--no-progress"])
    assert r.exit_code == 0, r.output
    with h5py.File(tmp_path / "n.h5") as f:
        assert "impacts" in f and "section" in f and "stability" not in f


# ---------------------------------------------------------------- the maps alpha, beta, gamma
def test_map2d_multipliers_are_those_of_the_words_linear_parts(tmp_path):
    """A map2d sweep keeping stability over the corner range (omega = 1.999): each cycle's
    Jacobian is the product of the linear parts Q of its word (theory.map_matrices, eq 57);
    trace and determinant of that product equal the stored multipliers' sum and product to
    1e-12 relative, and since every Q is s [[1, 0], [h, 1]] the product is
    prod(s) [[1, 0], [n h, 1]]: a double multiplier prod(s) = r^(#b + #g) (-r^2)^(#a),
    found to rounding (1e-13: the product is triangular, so its eigenvalues are its
    diagonal and no square root of rounding enters, as it would for a defective pair
    from trace and determinant)."""
    import h5py
    from click.testing import CliRunner

    from cornerbif import theory
    from cornerbif.cli import main
    scene = tmp_path / "m.toml"
    scene.write_text('[scene]\nname = "m"\nmodel = "map2d"\n[system]\nomega = 1.999\n'
                     '[sweep]\nkappa = { start = -0.0141, stop = -0.004, num = 25 }\n'
                     '[initial]\ncount = 3\n[run]\ntransient = 2000\nrecord = 200\n'
                     '[output]\nkeep = ["section", "stability"]\n')
    out = tmp_path / "m.h5"
    r = CliRunner().invoke(main, ["sweep", str(scene), "-o", str(out), "--no-progress"])
    assert r.exit_code == 0, r.output
    seen = set()
    with h5py.File(out) as f:
        kap = f["kappa"][...]
        st = f["stability/status"][...]
        mu = f["stability/multiplier_re"][...] + 1j * f["stability/multiplier_im"][...]
        words = f["symbols"][...]
        assert (st == S.OK).sum() > 60
        for i, j in zip(*np.nonzero(st == S.OK)):
            w = words[i, j].decode()
            Q = np.eye(2)
            for ch in w:         # any rotation of the word: the same trace and determinant
                Q = theory.map_matrices(ch, 1.999 - 2.0, float(kap[i]), 0.8)[0] @ Q
            m = mu[i, j]
            assert math.isclose((m[0] + m[1]).real, np.trace(Q), rel_tol=1e-12)
            assert math.isclose((m[0] * m[1]).real, np.linalg.det(Q), rel_tol=1e-12)
            s = 0.8 ** (w.count("b") + w.count("g")) * (-0.64) ** w.count("a")
            assert m[0].imag == m[1].imag == 0.0
            assert math.isclose(m[0].real, s, rel_tol=1e-13)
            assert math.isclose(m[1].real, s, rel_tol=1e-13)
            assert f["stability/cycle_duration"][i, j] == len(w)
            seen.add(w)
    assert len(seen) >= 3, seen


# ---------------------------------------------------------------- the flow's limit: the maps
def _ray_errors(side):
    """|mu_flow - mu_map| (largest over the pair) and |tr J_flow - tr J_map| along the ray
    (omega, kappa) = (2 + side eps, -2 eps): the beta orbit (one impact, word 'b') for
    omega > 2, the alpha orbit ('a') for omega < 2, the map2d's cycle of the same word."""
    from cornerbif import theory
    eps = np.array([1e-3, 1e-4, 1e-5, 1e-6])
    d_mu, d_tr = [], []
    for e in eps:
        om, ka = 2.0 + side * e, -2.0 * e
        if side > 0:
            u0, v0 = theory.single_impact_orbit(om, ka, 0.8, exact=True)[:2]
            tr = 200
        else:
            u0, v0, tr = 0.0, 0.0, 3000
        f = cornerbif.simulate([u0], [v0], omega=om, kappa=ka, transient=tr, record=60,
                               keep=["stability"])
        m = cornerbif.simulate([0.0], [0.0], model="map2d", omega=om, kappa=ka,
                               transient=300, record=40, keep=["stability"])
        assert f["symbols"][0] == m["symbols"][0] == ("b" if side > 0 else "a")
        mf = np.sort_complex(f["mu_re"][0] + 1j * f["mu_im"][0])
        mm = np.sort_complex(m["mu_re"][0] + 1j * m["mu_im"][0])
        d_mu.append(np.abs(mf - mm).max())
        d_tr.append(abs(mf.sum() - mm.sum()))
    return eps, np.array(d_mu), np.array(d_tr)


@pytest.mark.parametrize("side", [+1, -1])
def test_flow_multipliers_converge_to_the_maps_on_a_ray(side):
    """As (omega, kappa) -> (2, 0) on a ray the flow's multipliers tend to the local
    maps' double multiplier (r for beta, -r^2 for alpha, eq 57; a Jordan block): the
    eigenvalues to first order in eps (measured |mu_flow - mu_map| = 2.70 eps for beta,
    2.51 eps for alpha: the flow splits the double multiplier into a pair r e^(+-i 3.4 eps)
    and a real pair), the trace to second order (9.1 eps^2, 9.8 eps^2).  Orders fitted on
    eps = 1e-3 .. 1e-6: 1.00 and 2.00 to 0.02."""
    eps, d_mu, d_tr = _ray_errors(side)
    order_mu = np.polyfit(np.log(eps), np.log(d_mu), 1)[0]
    order_tr = np.polyfit(np.log(eps), np.log(d_tr), 1)[0]
    assert abs(order_mu - 1.0) < 0.02 and abs(order_tr - 2.0) < 0.02, (order_mu, order_tr)
    assert np.all(d_mu / eps < 3.0)
