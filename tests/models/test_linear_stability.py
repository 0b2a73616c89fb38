"""Stability of the ``linear`` model (docs/linear.md, "Stability"): the monodromy of a run's
last recorded cycle (flights' Jacobians and generalised saltation matrices,
``models/linear/tangent.py``), its 2N multipliers and the 2N Lyapunov exponents.

Checked against what does not share its code:

- the ``flow`` model's stability pass (its closed-form flight matrix and law (5)'s
  saltation) on Fig. 6(a)'s system written as a linear scene, from the same starts;
- the ``two_particle`` model's (law (74)'s saltation, 4x4) on Fig. 19's orbits written as a
  linear scene of two coordinates and two contacts;
- finite differences of the first-return map, each run by the pure-numpy event loop
  (``models/linear/simulate.py``: numpy's expm, the halving search) and numpy flights;
- the bouncing ball's period-one orbit, whose impact map is linearised in closed form here;
- determinants: Liouville for a flight, r^2 for an impact (derived in tangent.py).
"""

import math
import os
import tomllib

import numpy as np
import pytest

import cornerbif
from cornerbif import stability as S
from cornerbif.models.linear import declare
from cornerbif.models.linear import tangent as LT
from cornerbif.models.linear.batch import system_arrays
from cornerbif.models.linear.flight import augmented, expm, flight
from cornerbif.models.linear.kernel import run_system
from cornerbif.models.linear.simulate import simulate as numpy_run

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _table(name):
    return tomllib.load(open(os.path.join(ROOT, "configs", f"{name}.toml"), "rb"))["system"]


def _system(table, values):
    system, bad = declare.read_system(_with(table, values))
    assert not bad, bad
    return system


def _with(table, values):
    for path, v in values.items():
        table = declare.with_value(table, path, v)
    return table


def _mu(res):
    return np.asarray(res["mu_re"]) + 1j * np.asarray(res["mu_im"])


def _paired(got, want):
    """The largest distance from a multiplier of ``got`` to its nearest in ``want``, both
    ways (multisets of a few eigenvalues, conjugate pairs in either order)."""
    return max(max(np.min(np.abs(want - g)) for g in got), max(np.min(np.abs(got - w))
                                                              for w in want))


# ---------------------------------------------------------------- the paper's flow
def test_fig06a_as_a_linear_scene_has_the_flows_multipliers():
    """configs/fig06a_linear.toml against configs/fig06a.toml (the flow model), from the
    same 6 starts at 45 values of kappa (the grid of test_linear_paper_scenes.py, 500
    transient and 100 recorded impacts): every run has the flow's stability status, cycle
    duration and exponent window, and its two multipliers equal the flow's to 1e-9.

    Why 1e-9: the two kernels' recorded impacts agree to 1e-10 (test_linear_paper_scenes.py:
    at most 2.6e-11 on this grid); a multiplier is a smooth function of them, magnified by the
    saltation's 1/w- and the cycle's length (up to 14 impacts here).  Measured: 7.2e-12.
    The exponents' sum is exact in both ((2 n log r) / window: det S = r^2) and agrees to
    1e-12 (measured 2.7e-15); each exponent alone is a finite-window estimate from each
    model's own start basis (the flow's (0.6, 0.8), the linear model's
    ``stability.generic_basis``), equal only to within the window's convergence: measured
    1.2e-3 apart here, each within 3.4e-3 of log|mu| / T (multipliers 0.048 and 0.040: the
    basis aligns like 0.84^cycles)."""
    flow = tomllib.load(open(os.path.join(ROOT, "configs", "fig06a.toml"), "rb"))["system"]
    rng = np.random.default_rng(7)
    u0, v0 = rng.uniform(0.5, 20.0, 6), rng.uniform(-20.0, 20.0, 6)
    grid = np.linspace(-0.02, 0.002, 45)
    f = cornerbif.simulate(u0[:, None], v0[:, None], model="flow", transient=500, record=100,
                           keep=["impacts", "stability"], **{**flow, "kappa": grid[None, :]})
    lin = cornerbif.simulate(model="linear", table=_table("fig06a_linear"), x0=u0[:, None],
                             v_x0=v0[:, None], transient=500, record=100,
                             keep=["impacts", "stability"], **{"contact.R.kappa": grid[None, :]})
    assert lin["mu_re"].shape == f["mu_re"].shape == (6, 45, 2)
    for k in ("stability_status", "lyapunov_status", "impacts_per_cycle"):
        np.testing.assert_array_equal(lin[k], f[k], err_msg=k)
    ok = np.asarray(f["stability_status"]) == S.OK
    assert ok.sum() >= 200 and (np.asarray(f["impacts_per_cycle"])[ok] > 1).sum() >= 100
    np.testing.assert_allclose(_mu(lin)[ok], _mu(f)[ok], rtol=0, atol=1e-9)
    for k in ("cycle_duration", "lyapunov_window"):
        np.testing.assert_allclose(lin[k][ok], f[k][ok], rtol=0, atol=1e-9, err_msg=k)
    np.testing.assert_allclose(lin["lyapunov"].sum(-1)[ok], f["lyapunov"].sum(-1)[ok], rtol=0,
                               atol=1e-12)
    assert np.abs(lin["lyapunov"] - f["lyapunov"])[ok].max() < 5e-3


def _two_particle_table(p):
    """Fig. 19's two particles (section 6) as a linear scene: z of mass 1 (z'' + 2 sigma1 z' +
    omega1^2 z = 0) above the wall w = kappa + beta sin(omega0 t) (contact W: the gap z - w,
    law (5) with r1), and a second coordinate (the model's u, named ``q``: ``u`` is the
    impacts' own dataset) of mass 1/mu above z (contact U: the gap q - z, law (74) with r2)."""
    mu = p["mu"]
    return {"dofs": ["z", "q"], "mass": [1.0, 1.0 / mu],
            "stiffness": [p["omega1"] ** 2, p["omega2"] ** 2 / mu],
            "damping": [2.0 * p.get("sigma1", 0.0), 2.0 * p.get("sigma2", 0.0) / mu],
            "contact": [{"name": "W", "gap": {"z": 1.0}, "obstacle": "sine",
                         "kappa": p["kappa"], "beta": p["beta"], "omega": p["omega0"],
                         "r": p["r1"]},
                        {"name": "U", "gap": {"z": -1.0, "q": 1.0}, "r": p["r2"]}]}


def test_fig19_as_a_linear_scene_has_the_two_particle_models_multipliers():
    """Fig. 19's cycles of periods 1, 3 and 13 (the last with a w-z and a z-u impact 3e-7
    apart in time), a damped one and mu = 3 (tests/models/test_fd_reference_two_particle.py's
    orbits, started on them): the linear scene's four multipliers equal the two-particle
    model's (its own 4x4 saltations of laws (5) and (74), in its state (z, y, u, v); the
    linear state is (z, q, z', q'): the same eigenvalues) to 1e-10, with the same cycle
    duration (its period in wall periods; its cycle counts both contacts' impacts).
    Measured: at most 3.7e-13.  The exponents' sums agree to 1e-12."""
    import sys
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from test_fd_reference_two_particle import ATTRACTORS, P13
    for name, (p, _, P, x0, kinds) in {**ATTRACTORS, "P13": P13}.items():
        tp = cornerbif.simulate(*x0, model="two_particle", transient=4, record=60,
                                keep=["stability"], **p)
        lin = cornerbif.simulate(model="linear", table=_two_particle_table(p), z0=x0[0],
                                 v_z0=x0[1], q0=x0[2], v_q0=x0[3], transient=8, record=120,
                                 keep=["stability"])
        assert lin["stability_status"][0] == tp["stability_status"][0] == S.OK, name
        assert lin["period"][0] == tp["period"][0] == P
        assert lin["impacts_per_cycle"][0] == len(kinds.replace(" ", "")), name
        assert math.isclose(lin["cycle_duration"][0], tp["cycle_duration"][0], rel_tol=1e-12)
        assert _paired(_mu(lin)[0], _mu(tp)[0]) < 1e-10, (name, _mu(lin), _mu(tp))
        assert abs(lin["lyapunov"][0].sum() - tp["lyapunov"][0].sum()) < 1e-12, name


# ---------------------------------------------------------------- finite differences
def _return_map(system, t0, y, t1, contacts):
    """The state (x, v) at t1 of the pure-numpy run (``simulate.py``) from y = (x, v) at t0
    through the impacts on ``contacts`` (their names, in order; the run must make exactly
    those), then the numpy flight (``flight.flight``: its own expm) from the last one."""
    n = system.n
    imps, why = numpy_run(system, y[:n], y[n:], t0, len(contacts))
    assert [i.contact for i in imps] == list(contacts), (why, [i.contact for i in imps])
    assert imps[-1].t < t1
    x, v = flight(system, imps[-1].t, imps[-1].x, imps[-1].v_out, t1 - imps[-1].t)
    return np.concatenate([x, v])


def _fd_multipliers(system, res, i, eps):
    """The eigenvalues of the central-difference Jacobian of the map over one cycle of run
    ``i`` of ``cornerbif.simulate``'s result ``res``, taken in the middle of the flight after
    the first impact of its last recorded cycle (the flight ``flight.flight``): from there,
    one cycle's impacts and the rest of the cycle's duration.  The monodromy from just after
    that impact is this map conjugated by the half flight: the same eigenvalues."""
    n = system.n
    t = np.asarray(res["t"][i])
    nrec = int(np.isfinite(t).sum())
    q = int(res["impacts_per_cycle"][i])
    k = nrec - 1 - q
    x = np.array([res[f"x_{d}"][i][k] for d in system.dofs])
    v = np.array([res[f"v_{d}"][i][k] for d in system.dofs])
    h = 0.5 * (t[k + 1] - t[k])
    xm, vm = flight(system, t[k], x, v, h)
    y0 = np.concatenate([xm, vm])
    t0, t1 = t[k] + h, t[k] + h + (t[nrec - 1] - t[k])
    names = [system.contacts[c].name for c in np.asarray(res["contact"][i])[k + 1:nrec]]
    J = np.empty((2 * n, 2 * n))
    for j in range(2 * n):
        e = np.zeros(2 * n)
        e[j] = eps
        J[:, j] = (_return_map(system, t0, y0 + e, t1, names)
                   - _return_map(system, t0, y0 - e, t1, names)) / (2 * eps)
    return np.linalg.eigvals(J)


FD_CASES = {
    # scene: (its swept number, the value, the cycle's word, starts)
    "two_stops": ("forcing.0.Omega", 1.6, "LR", 16),
    "impact_damper": ("forcing.0.Omega", 1.45, "LR", 16),
    "bouncing_ball": ("contact.T.beta", 0.036, "T", 48),
}


@pytest.mark.parametrize("scene", sorted(FD_CASES))
def test_multipliers_are_the_finite_difference_return_maps(scene):
    """The oscillator between two stops (its symmetric motion LR at Omega = 1.6), the impact
    damper (LR at Omega = 1.45: 4 multipliers) and the bouncing ball (period one at
    Gamma = 1.30): the multipliers equal the eigenvalues of a central-difference Jacobian of
    the map over one cycle (eps = 1e-5, each run by the pure-numpy event loop, which resolves
    its impact times to 1e-12: a rounding of about 1e-12 / eps = 1e-7 of each entry; the
    truncation eps^2 |f'''| is below it) to 1e-6.  Measured: 2.5e-8 (two stops), 5.3e-9
    (damper), 7.9e-9 (ball); with eps = 1e-4 (truncation) and 1e-6 (rounding) about 1e-7."""
    path, value, word, count = FD_CASES[scene]
    table = _table(scene)
    system = _system(table, {path: value})
    rng = np.random.default_rng(5)
    starts = {f"{d}0": rng.uniform(-0.4, 0.4, count) for d in system.dofs}
    starts |= {f"v_{d}0": rng.uniform(-0.5, 0.5, count) for d in system.dofs}
    if scene == "bouncing_ball":
        starts["x0"] = rng.uniform(0.2, 0.5, count)
    res = cornerbif.simulate(model="linear", table=table, transient=300, record=12,
                             keep=["impacts", "stability"], **starts, **{path: value})
    runs = np.flatnonzero((res["symbols"] == word) & (res["period"] == 1)
                          & (res["stability_status"] == S.OK))
    assert runs.size >= 2, (res["symbols"], res["status"])
    for i in runs[:2]:
        fd = _fd_multipliers(system, res, i, 1e-5)
        got = _mu(res)[i]
        assert got.shape == (2 * system.n,)
        assert _paired(got, fd) < 1e-6, (got, fd)


def test_a_coupled_system_is_the_finite_difference_jacobian_entry_by_entry():
    """The whole Jacobian, not only its eigenvalues, on a system with every term of the
    saltation: three coordinates, a full mass matrix, a damping with a gyroscopic part
    (C - C^T != 0), a harmonic force, a gap along (1, -0.5, 0.3) against a moving sine and a
    fixed stop on another.  From the middle of a flight t_a to the middle of a flight t_b
    six impacts later, the central differences of the numpy run (eps = 1e-5) equal
    Phi(t_b - t_l) J Phi(t_f - t_a), J the kernel's product from just after the first
    impact t_f to just after the last t_l (``tangent.cycle_monodromy``), the half flights'
    Phi from numpy's expm of the augmented matrix, to 1e-6 of the largest entry (16).
    Measured: 5.4e-8 (4.5e-7 with eps = 1e-6, where the impact times' 1e-12 dominates)."""
    from cornerbif.models.linear.system import Contact, Forcing, LinearSystem
    M = np.array([[2.0, 0.3, 0.1], [0.3, 1.0, 0.2], [0.1, 0.2, 1.5]])
    K = np.array([[3.0, -1.0, 0.0], [-1.0, 2.0, -0.5], [0.0, -0.5, 1.0]])
    C = np.array([[0.1, 0.3, 0.0], [-0.3, 0.05, 0.1], [0.0, -0.1, 0.08]])
    system = LinearSystem(("a", "b", "c"), M, K, C, (Forcing(1, 0.8, 1.3, 0.4),),
                          (Contact("S", np.array([1.0, -0.5, 0.3]), "sine", -0.6, 0.2, 2.1,
                                   r=0.7),
                           Contact("F", np.array([0.0, -1.0, 0.0]), "fixed", -0.8, r=0.9)))
    st, rec = run_system(system, 0.0, [0.4, 0.2, -0.1], [0.5, -0.3, 0.2], 10)
    assert len(rec["t"]) == 10 and set(rec["contact"]) == {"S", "F"}, rec["contact"]
    first, count = 2, 6
    out = LT.cycle_monodromy(system, rec, first, count)
    assert out["status"] == S.OK
    t = rec["t"]
    n = system.n
    ha = 0.5 * (t[first + 1] - t[first])
    hb = 0.5 * (t[first + count + 1] - t[first + count])
    xa, va = flight(system, t[first], rec["x"][first], rec["v_out"][first], ha)
    y0 = np.concatenate([xa, va])
    names = rec["contact"][first + 1:first + count + 1]
    J = np.empty((2 * n, 2 * n))
    for j in range(2 * n):
        e = np.zeros(2 * n)
        e[j] = 1e-5
        J[:, j] = (_return_map(system, t[first] + ha, y0 + e, t[first + count] + hb, names)
                   - _return_map(system, t[first] + ha, y0 - e, t[first + count] + hb,
                                 names)) / 2e-5
    A = augmented(system)
    phi_a, phi_b = (expm(A * h)[:2 * n, :2 * n] for h in (ha, hb))
    want = phi_b @ out["jacobian"] @ np.linalg.inv(phi_a)
    assert np.abs(J - want).max() < 1e-6 * np.abs(want).max(), np.abs(J - want).max()


# ---------------------------------------------------------------- the bouncing ball
def test_the_bouncing_balls_multipliers_are_the_closed_form():
    """The ball (unit mass, g = 1) on the table z = beta sin(omega t) (configs/
    bouncing_ball.toml: omega = 6, r = 0.5), its period-one orbit (one impact per table
    period T; docs/linear.md: v+ = g T / 2, z'(t*) = g T (1 - r) / (2 (1 + r))).  Its impact
    map (t_k, v_k) -> (t_k+1, v_k+1) (v after the impact), linearised here: the flight
    z(t_k) + v_k tau - g tau^2 / 2 = z(t_k + tau) gives
    dt_k+1 = dt_k + (T / q) dv_k, q = z' + g T / 2 = g T / (1 + r) (the approach speed), and
    the law v_k+1 = (1 + r) z'(t_k+1) - r (v_k - g tau) gives
    dv_k+1 = (1 + r) z'' dt_k + (((1 + r) z'' + r g) T / q - r) dv_k, so

        J = [[1, T/q], [(1 + r) z'', ((1 + r) z'' + r g) T/q - r]],
        det J = r g T / q - r = r^2,  tr J = 1 + r^2 + (1 + r)^2 z'' / g,

    z'' = -beta omega^2 sin(omega t*) = -beta omega^2 sqrt(1 - c^2) on the stable orbit
    (c = pi (1 - r) / ((1 + r) Gamma)).  Its eigenvalues are the monodromy's (the map just
    after an impact over one period is the impact map conjugated): equal to 1e-9 at
    Gamma = 1.12 and 1.30 (a complex pair, of modulus r) and 1.48 (a real pair, -0.763 and
    -0.328).  Measured: 1.2e-12.  The exponents: their sum exactly 2 log r / T (to 1e-12);
    each is log|mu| / T, to 1e-9 for the real pair (measured 6e-12 over the 100 recorded
    impacts), and for a complex pair only to log cond(P) / window (docs/stability.md,
    "Lyapunov exponents": P its eigenvectors' matrix): asserted as 1 / window (measured
    0.51 / window and 0.15 / window)."""
    g, omega, r = 1.0, 6.0, 0.5
    T = 2 * math.pi / omega
    rng = np.random.default_rng(3)
    x0, v0 = rng.uniform(0.2, 0.5, 48), rng.uniform(-0.5, 0.5, 48)
    for beta in (0.031, 0.036, 0.041):                 # Gamma = 1.12, 1.30, 1.48
        res = cornerbif.simulate(x0, v0, model="linear", table=_table("bouncing_ball"),
                                 transient=300, record=100, keep=["stability"],
                                 **{"contact.T.beta": beta})
        one = np.flatnonzero(res["period"] == 1)
        assert one.size >= 2
        gamma = beta * omega ** 2 / g
        c = math.pi * (1 - r) / ((1 + r) * gamma)
        zpp = -beta * omega ** 2 * math.sqrt(1 - c * c)
        tr, det = 1 + r * r + (1 + r) ** 2 * zpp / g, r * r
        want = np.roots([1.0, -tr, det])
        exponents = np.sort(np.log(np.abs(want)))[::-1] / T
        complex_pair = tr * tr < 4 * det
        assert complex_pair == (beta < 0.04)
        for i in one:
            assert res["stability_status"][i] == S.OK
            assert _paired(_mu(res)[i], want) < 1e-9, (_mu(res)[i], want)
            lam = res["lyapunov"][i]
            assert abs(lam.sum() - 2 * math.log(r) / T) < 1e-12
            bound = 1.0 / res["lyapunov_window"][i] if complex_pair else 1e-9
            assert np.abs(lam - exponents).max() < bound, (lam, exponents)


# ---------------------------------------------------------------- determinants
def test_each_steps_determinant_and_the_monodromys_are_the_closed_forms():
    """det Phi(h) = exp(-tr(M^-1 C) h) (Liouville: tr A_y = -tr(M^-1 C)) for every flight,
    det S = r^2 for every impact (tangent.py: S is block triangular with both diagonal blocks
    I - (1 + r) m a^T, of determinant 1 - (1 + r) = -r), each to 1e-12 relative, and the
    product of the steps' determinants equals the monodromy's over 8 impacts to 1e-10 (the
    closed form exp(-tr(M^-1 C) duration) prod r_c^2 too), on the impact damper (two
    coordinates, damped and forced, r = 0.6) and a three-coordinate system with a full mass
    matrix and gyroscopic damping against a sine and a fixed stop.  Measured: 1.6e-14
    (flights), 4.4e-16 (impacts), 1.8e-11 (the coupled system's monodromy against the
    product: its determinant's rounding), 1.3e-14 (the damper's)."""
    from cornerbif.models.linear.system import Contact, Forcing, LinearSystem
    M = np.array([[2.0, 0.3, 0.1], [0.3, 1.0, 0.2], [0.1, 0.2, 1.5]])
    coupled = LinearSystem(
        ("a", "b", "c"), M, np.array([[3.0, -1.0, 0.0], [-1.0, 2.0, -0.5], [0.0, -0.5, 1.0]]),
        np.array([[0.1, 0.3, 0.0], [-0.3, 0.05, 0.1], [0.0, -0.1, 0.08]]),
        (Forcing(1, 0.8, 1.3, 0.4),),
        (Contact("S", np.array([1.0, -0.5, 0.3]), "sine", -0.6, 0.2, 2.1, r=0.7),
         Contact("F", np.array([0.0, -1.0, 0.0]), "fixed", -0.8, r=0.9)))
    damper = _system(_table("impact_damper"), {"forcing.0.Omega": 1.45})
    for system, x0, v0 in ((coupled, [0.4, 0.2, -0.1], [0.5, -0.3, 0.2]),
                           (damper, [0.1, -0.2], [0.3, 0.0])):
        _, rec = run_system(system, 0.0, x0, v0, 12)
        assert len(rec["t"]) == 12
        a = system_arrays([system])
        trace = float(np.trace(np.linalg.solve(system.mass, system.damping)))
        names = [c.name for c in system.contacts]
        c = np.array([names.index(k) for k in rec["contact"]])
        n = system.n
        y = np.empty(a["A"].shape[1])
        product = 1.0
        for k in range(3, 11):
            h = rec["t"][k] - rec["t"][k - 1]
            dphi = np.linalg.det(LT.flight_jacobian(a["E"][0], a["A"][0], a["H"][0], h, n))
            assert math.isclose(dphi, math.exp(-trace * h), rel_tol=1e-12), (dphi, h)
            Sk, st = LT.impact_saltation_at(LT.system_tuple(a), 0, rec["t"][k], c[k],
                                            rec["x"][k], rec["v_in"][k], rec["v_out"][k], y)
            assert st == S.OK
            rc = system.contacts[c[k]].r
            assert math.isclose(np.linalg.det(Sk), rc * rc, rel_tol=1e-12)
            product *= dphi * np.linalg.det(Sk)
        out = LT.cycle_monodromy(system, rec, 2, 8)
        det = np.linalg.det(out["jacobian"])
        assert math.isclose(det, product, rel_tol=1e-10), (det, product)
        assert math.isclose(det, out["det_closed_form"], rel_tol=1e-10)


def test_one_mass_saltation_is_the_flows_law_5():
    """N = 1, M = 1, a = 1, C = 2 sigma: S is the flow's [[-r, 0], [(1 + r) ((a- - z'')/w-
    + 2 sigma), -r]] (``numerics.saltation.impact_saltation``) exactly; with M = 2, a = 3 the
    same after scaling (m = M^-1 a / (a^T M^-1 a) = 1/a: the gap's own coordinate)."""
    from cornerbif.numerics.saltation import impact_saltation
    A = np.array([[0.0, 1.0], [-1.44, -0.1]])          # k = 1.2, sigma = 0.05
    S1 = LT.saltation(1, np.array([1.0]), np.array([1.0]), 0.8, A, -0.7, -1.3, 0.4)
    want = np.array(impact_saltation(0.8, 0.05, -1.3, -0.7, 0.4)).reshape(2, 2)
    np.testing.assert_allclose(S1, want, rtol=1e-15, atol=1e-15)
    # x = u / 3 with a = 3 (the gap a x = u): S in x is diag(1/3) S_u diag(3)
    A2 = np.array([[0.0, 1.0], [-1.44, -0.1]])
    S3 = LT.saltation(1, np.array([3.0]), np.array([1.5]), 0.8, A2, -0.7, -1.3, 0.4)
    np.testing.assert_allclose(S3, np.diag([1 / 3, 1 / 3]) @ want @ np.diag([3.0, 3.0]),
                               rtol=1e-14, atol=1e-15)


def test_an_impact_at_a_corner_takes_the_side_the_law_used():
    """At a corner of the rectified sine (t_c = pi / omega: slopes -beta omega before it,
    +beta omega after) an impact within CORNER_WINDOW of it gets the slope and curvature of
    the side whose slope its recorded velocities say the law used (z' = (a . v+ + r a . v-)
    / (1 + r)), whichever piece its rounded time falls in; away from a corner, its own
    piece's, whatever the record says."""
    from cornerbif.models.flow.packed import as_tuple
    from cornerbif.models.linear.events import ContactObstacle
    from cornerbif.obstacles.dispatch import derived_tuple
    beta, omega = 0.7, 1.8
    ob = ContactObstacle("rectified_sine", 0.0, beta, omega)
    row, d = as_tuple(ob.row), derived_tuple(ob.d)
    tc = math.pi / omega
    for t in (tc - 4e-16, tc, tc + 4e-16, tc + 1e-10):
        for side in (-1.0, 1.0):
            zp, zpp = LT.obstacle_at_impact(row, d, t, side * beta * omega)
            assert math.isclose(zp, side * beta * omega, rel_tol=1e-9), (t, side, zp)
            assert abs(zpp) < 1e-8
    t = tc + 0.3                                   # on the second hump, clear of the corners
    want = (beta * omega * math.cos(0.3 * omega), -beta * omega ** 2 * math.sin(0.3 * omega))
    for seen in (-5.0, 0.0, 5.0):
        np.testing.assert_allclose(LT.obstacle_at_impact(row, d, t, seen), want, rtol=1e-12)


def test_a_grazing_impact_gives_no_multipliers_and_says_so():
    """An impact whose relative velocity w- is below GRAZING_TOL of its velocity scale (here
    a recorded impact on the two stops' L made to arrive at -1e-14) has no saltation (its
    g'' / w- diverges): the Jacobian through it is NaN with status GRAZING; the impacts
    before it still give a finite one."""
    system = _system(_table("two_stops"), {"forcing.0.Omega": 1.6})
    _, rec = run_system(system, 0.0, [0.3], [0.2], 8)
    k = rec["contact"].index("L", 3)
    rec = {**rec, "v_in": rec["v_in"].copy(), "v_out": rec["v_out"].copy()}
    rec["v_in"][k], rec["v_out"][k] = -1e-14, 0.8e-14      # a = 1, z' = 0 on L
    out = LT.cycle_monodromy(system, rec, k - 2, 2)
    assert out["status"] == S.GRAZING and np.isnan(out["jacobian"]).all()
    out = LT.cycle_monodromy(system, rec, k - 2, 1)
    assert out["status"] == S.OK and np.isfinite(out["jacobian"]).all()


# ---------------------------------------------------------------- the sweep and its file
def test_a_sweep_keeps_the_stability_datasets_and_plots_by_them(tmp_path):
    """``cornerbif sweep`` of a linear scene keeping "stability" writes stability/ with 2N
    multipliers and exponents (the impact damper: 4), ``cornerbif info`` summarises it and
    ``cornerbif plot`` colours the diagram by the largest |multiplier| ([plot] color_by);
    the file's numbers are simulate's."""
    import h5py
    from click.testing import CliRunner

    from cornerbif.cli import main
    text = open(os.path.join(ROOT, "configs", "impact_damper.toml")).read()
    text = text.replace('keep = ["impacts"]', 'keep = ["impacts", "stability"]')
    text = text.replace('y = "impact_v"', 'y = "impact_v"\ncolor_by = "multiplier"')
    scene = tmp_path / "damper.toml"
    scene.write_text(text)
    out = tmp_path / "damper.h5"
    sets = ["--set", 'sweep."forcing.0.Omega".num=4', "--set", "initial.count=3",
            "--set", "run.transient=200", "--set", "run.record=16"]
    r = CliRunner().invoke(main, ["sweep", str(scene), "-o", str(out), "--no-progress", *sets])
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        assert f["stability/multiplier_re"].shape == (4, 3, 4)
        assert f["stability/lyapunov"].shape == (4, 3, 4)
        status = f["stability/status"][...]
        mu = f["stability/multiplier_re"][...] + 1j * f["stability/multiplier_im"][...]
        starts = {c: f[f"initial/{c}"][...] for c in ("x", "y", "v_x", "v_y")}
        omegas = f["forcing.0.Omega"][...]
        assert f["attractors/multiplier_re"].shape[-1] == 4
    assert (status == S.OK).sum() >= 4
    r = CliRunner().invoke(main, ["info", str(out)])
    assert r.exit_code == 0 and "stability:" in r.output, r.output
    fig = tmp_path / "damper.png"
    r = CliRunner().invoke(main, ["plot", str(out), "-o", str(fig)])
    assert r.exit_code == 0 and fig.exists(), r.output
    res = cornerbif.simulate(model="linear", table=_table("impact_damper"),
                             **{f"{c}0": v for c, v in starts.items()}, transient=200, record=16,
                             keep=["stability"], **{"forcing.0.Omega": omegas[:, None]})
    np.testing.assert_array_equal(res["stability_status"], status)
    np.testing.assert_array_equal(_mu(res), mu)
