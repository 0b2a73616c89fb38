"""Self-tests of the finite-difference Jacobian reference ``tests/fd_reference.py``.

The reference must be trustworthy before it is used to test cornerbif's
stability code, so every expected number here comes from a closed form
(matrix exponential, Liouville's formula, saltation matrices written out
below), never from cornerbif (not imported) nor from fd_reference itself.

Closed forms used
-----------------
Flight: x = (u, v), x' = A x + (0, F cos(Omega t + phi)), A = [[0, 1], [-k^2, -2 sigma]],
so d x(t0 + tau) / d x(t0) = expm(A tau) and (Liouville) det = exp(tr(A) tau) =
exp(-2 sigma tau).

Impact at t* (u = z(t*)), relative approach velocity w = v- - z'(t*) < 0.  Perturb
the pre-impact state at the fixed time t* by (du, dv).  The impact time moves by
dt* = -du / w (from u + du + v- dt* = z + z' dt*).  The post-impact state at
t* + dt* is (z + z' dt*, (1 + r) (z' + z'' dt*) - r (v- + dv + a- dt*)); flying it
back to the fixed time t* subtracts (v+, a+) dt*.  With v+ - z' = -r w this gives
the saltation matrix

    S = [[-r, 0], [(a+ + r a- - (1 + r) z'') / w, -r]],   det S = r^2,

a± = -2 sigma v± - k^2 z + F cos(Omega t* + phi) the accelerations just before /
after.  Hence over a window of length T with N transversal impacts (none at a
corner, none grazing) det J = r^(2N) exp(-2 sigma T): the flight times add up to
T whatever the obstacle.  For z = kappa + beta |sin(omega t)| and for
z = kappa + beta sin(omega t), z'' = -omega^2 (z - kappa) away from corners; for
the triangle z'' = 0.
"""

import math
import os
import sys

import numpy as np
import pytest
from scipy.linalg import expm

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import fd_reference as fr  # noqa: E402
from naive import naive_impacts, z_slope  # noqa: E402

PI = math.pi


def flight_matrix(tau, sigma, k):
    return expm(np.array([[0.0, 1.0], [-k * k, -2.0 * sigma]]) * tau)


def closed_form_jacobian(obstacle, omega, kappa, beta, r, u0, v0, t0, duration, sigma=0.0,
                         k=1.0, F=0.0, Omega=1.0, phi=0.0, theta1=None, theta2=None):
    """expm(A tau_N) S_N ... S_1 expm(A tau_0) from the impacts of ``naive_impacts``
    (impact times and velocities only) and the saltation matrix derived above."""
    t1 = t0 + duration
    imp = naive_impacts(obstacle, omega, kappa, beta, r, u0, v0, 10_000, t0=t0, sigma=sigma,
                        k=k, F=F, Omega=Omega, phi=phi, theta1=theta1, theta2=theta2,
                        t_max=t1)
    M = np.eye(2)
    t_prev = t0
    for ts, zs, v_in, v_out in imp:
        M = flight_matrix(ts - t_prev, sigma, k) @ M
        zp = z_slope(obstacle, ts, omega, kappa, beta, theta1=theta1, theta2=theta2)
        # triangle: piecewise linear; (rectified) sine: z'' = -omega^2 (z - kappa)
        zpp = 0.0 if obstacle == "triangle" else -omega * omega * (zs - kappa)
        forcing = F * math.cos(Omega * ts + phi)
        a_in = -2.0 * sigma * v_in - k * k * zs + forcing
        a_out = -2.0 * sigma * v_out - k * k * zs + forcing
        S = np.array([[-r, 0.0], [(a_out + r * a_in - (1.0 + r) * zpp) / (v_in - zp), -r]])
        M = S @ M
        t_prev = ts
    return flight_matrix(t1 - t_prev, sigma, k) @ M, len(imp)


def assert_estimate_honest(J, J_exact, err):
    """The returned error estimate bounds the true error (10x margin, plus 1e-13 for
    the rounding of the closed form itself)."""
    assert np.all(np.abs(J - J_exact) <= 10.0 * err + 1e-13), (np.abs(J - J_exact), err)


# ---------------------------------------------------------------------------
# no impact: J = expm(A tau)
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("sigma", [0.3, 1.0, 1.7], ids=["under", "critical", "over"])
def test_no_impact_jacobian_is_flight_matrix(sigma):
    # obstacle at kappa = -100 is never reached (|u| stays O(1) for this forced flight)
    tau = 2.5
    J, err, info = fr.fd_jacobian("sine", 1.0, -100.0, 0.5, 0.8, 0.3, -0.2, 0.7, tau,
                                  sigma=sigma, k=1.0, F=0.4, Omega=1.3, full_output=True)
    assert info["n_impacts"] == 0
    E = flight_matrix(tau, sigma, 1.0)  # expected: exp(A tau), closed form
    np.testing.assert_allclose(J, E, rtol=0, atol=1e-7 * np.abs(E).max())
    assert_estimate_honest(J, E, err)
    # Liouville: det = exp(-2 sigma tau)
    assert np.linalg.det(J) == pytest.approx(math.exp(-2.0 * sigma * tau), rel=1e-7)


# ---------------------------------------------------------------------------
# flat wall z = kappa ("sine" with beta = 0), damped and forced
# ---------------------------------------------------------------------------
FLAT = dict(obstacle="sine", omega=1.0, kappa=-0.2, beta=0.0, r=0.7)
FLAT_FLIGHT = dict(sigma=0.1, k=1.0, F=0.6, Omega=1.3, phi=0.0)


@pytest.mark.parametrize("duration,n_expected", [(2.0, 0), (4.0, 1), (8.0, 2)])
def test_flat_wall_determinant(duration, n_expected):
    # n_expected: impacts of this trajectory at t = 2.534, 7.599 (checked via state_at)
    st = fr.state_at(*FLAT.values(), 0.5, 0.0, 0.0, duration, **FLAT_FLIGHT)
    assert st.n_impacts == n_expected
    J, err = fr.fd_jacobian(*FLAT.values(), 0.5, 0.0, 0.0, duration, **FLAT_FLIGHT)
    r, sigma = FLAT["r"], FLAT_FLIGHT["sigma"]
    expected = r ** (2 * n_expected) * math.exp(-2.0 * sigma * duration)  # r^2N e^{-2 sigma T}
    assert np.linalg.det(J) == pytest.approx(expected, rel=1e-6)


def test_flat_wall_full_jacobian_matches_saltation_product():
    J, err = fr.fd_jacobian(*FLAT.values(), 0.5, 0.0, 0.0, 8.0, **FLAT_FLIGHT)
    M, n = closed_form_jacobian(*FLAT.values(), 0.5, 0.0, 0.0, 8.0, **FLAT_FLIGHT)
    assert n == 2
    np.testing.assert_allclose(J, M, rtol=0, atol=1e-7 * np.abs(M).max())
    assert_estimate_honest(J, M, err)


# ---------------------------------------------------------------------------
# moving obstacle z = kappa + |sin(2 t)|, r = 0.8, sigma = 0, k = 1
# ---------------------------------------------------------------------------
RS = dict(obstacle="rectified_sine", omega=2.0, beta=1.0, r=0.8)


@pytest.fixture(scope="module")
def settled_orbit():
    """kappa = -0.5: the attractor is a period-pi orbit with one impact per period,
    at phase omega t = pi/6 (mod pi) where v_out = -v_in = 9 sqrt(3): symmetric
    orbit, v_out = (1 + r) z' + r v_out with z' = 2 cos(pi/6)."""
    kappa = -0.5
    t0 = 100 * PI
    u, v = fr.settle(RS["obstacle"], RS["omega"], kappa, RS["beta"], RS["r"], 0.0, 0.0,
                     100, PI)
    return kappa, t0, u, v


def test_settled_orbit_is_period_pi(settled_orbit):
    kappa, t0, u, v = settled_orbit
    st = fr.state_at(RS["obstacle"], RS["omega"], kappa, RS["beta"], RS["r"], u, v, t0,
                     t0 + PI)
    assert st.n_impacts == 1
    assert (st.u, st.v) == pytest.approx((u, v), abs=1e-8)
    imp = naive_impacts(RS["obstacle"], RS["omega"], kappa, RS["beta"], RS["r"], u, v, 1,
                        t0=t0)
    assert imp[0, 3] == pytest.approx(9.0 * math.sqrt(3.0), rel=1e-8)


@pytest.mark.parametrize("n_periods", [1, 2])
def test_settled_orbit_determinant_and_saltation(settled_orbit, n_periods):
    kappa, t0, u, v = settled_orbit
    args = (RS["obstacle"], RS["omega"], kappa, RS["beta"], RS["r"], u, v, t0,
            n_periods * PI)
    J, err, info = fr.fd_jacobian(*args, full_output=True)
    assert info["n_impacts"] == n_periods
    # sigma = 0: det = r^(2N) = 0.8^(2 n_periods)
    assert np.linalg.det(J) == pytest.approx(0.8 ** (2 * n_periods), rel=1e-6)
    M, n = closed_form_jacobian(*args)
    assert n == n_periods
    np.testing.assert_allclose(J, M, rtol=0, atol=1e-7 * np.abs(M).max())
    assert_estimate_honest(J, M, err)


def test_kappa0_transient_determinant():
    # kappa = 0 from (0.5, 0) at t = 0: impacts at 0.253, 3.207, 6.317, i.e. omega t / pi
    # mod 1 = 0.16, 0.04, 0.02: away from the corners, so the map is smooth there
    args = (RS["obstacle"], RS["omega"], 0.0, RS["beta"], RS["r"], 0.5, 0.0, 0.0, 3 * PI)
    J, err, info = fr.fd_jacobian(*args, full_output=True)
    assert info["n_impacts"] == 3
    assert np.linalg.det(J) == pytest.approx(0.8**6, rel=1e-6)  # r^(2N), sigma = 0
    M, _ = closed_form_jacobian(*args)
    np.testing.assert_allclose(J, M, rtol=0, atol=1e-7 * np.abs(M).max())
    assert_estimate_honest(J, M, err)


def test_triangle_determinant_and_saltation():
    # valleys at t = n pi, peaks at n pi + pi/3 (theta1 / (theta1 + theta2) = 1/3); the 4
    # impacts of this window lie at t / pi mod 1 = 0.13, 0.08, 0.03, 0.07: no corner
    kw = dict(sigma=0.05, k=1.0, F=0.5, Omega=0.7, theta1=1.0, theta2=2.0)
    args = ("triangle", 1.0, -0.3, 0.0, 0.75, 0.5, 0.0, 0.0, 12.0)
    J, err, info = fr.fd_jacobian(*args, full_output=True, **kw)
    assert info["n_impacts"] == 4
    expected = 0.75**8 * math.exp(-2.0 * 0.05 * 12.0)  # r^(2N) exp(-2 sigma T)
    assert np.linalg.det(J) == pytest.approx(expected, rel=1e-6)
    M, _ = closed_form_jacobian(*args, **kw)
    np.testing.assert_allclose(J, M, rtol=0, atol=1e-7 * np.abs(M).max())
    assert_estimate_honest(J, M, err)


# ---------------------------------------------------------------------------
# near grazing: accuracy degrades, the error estimate must say so
# ---------------------------------------------------------------------------
def test_near_grazing_estimate_is_honest():
    # flat wall at -0.2, sigma = F = 0, k = 1, from (0, -A): the free flight's minimum is -A,
    # so it penetrates by A - 0.2 = 1e-4; impact velocity -sqrt(A^2 - 0.04) ~ -6.3e-3 and
    # the Jacobian grows like 1/|v_in| (|J| ~ 53 here, vs ~1 away from grazing)
    A = 0.2 + 1e-4
    args = ("sine", 1.0, -0.2, 0.0, 0.7, 0.0, -A, 0.0, 3.0)
    J, err = fr.fd_jacobian(*args)
    M, n = closed_form_jacobian(*args)
    assert n == 1 and np.abs(M).max() > 50.0
    np.testing.assert_allclose(J, M, rtol=0, atol=1e-5 * np.abs(M).max())
    assert_estimate_honest(J, M, err)


def test_grazing_raises():
    # penetration 1e-10: the impact appears/disappears under steps down to 1e-10 (relative)
    with pytest.raises(fr.FDStepError, match="nonsmooth"):
        fr.fd_jacobian("sine", 1.0, -0.2, 0.0, 0.7, 0.0, -(0.2 + 1e-10), 0.0, 3.0)


# ---------------------------------------------------------------------------
# nonsmooth windows are refused, not silently differentiated
# ---------------------------------------------------------------------------
def test_corner_impact_raises():
    # kappa = 0 settles onto the orbit with impacts exactly at the corners t = j pi / 2
    # (v_out = -v_in = 18 = 9 * beta * omega): the map is not differentiable there
    kappa = 0.0
    t0 = 100 * PI + PI / 4
    u, v = fr.settle(RS["obstacle"], RS["omega"], kappa, RS["beta"], RS["r"], 1.5, 0.0, 100,
                     PI, t0=PI / 4)
    st = fr.state_at(RS["obstacle"], RS["omega"], kappa, RS["beta"], RS["r"], u, v, t0,
                     t0 + PI)
    assert st.n_impacts == 1
    corner = round(st.impact_times[0] / (PI / 2)) * (PI / 2)
    assert abs(st.impact_times[0] - corner) < 1e-9
    with pytest.raises(fr.FDStepError, match="nonsmooth"):
        fr.fd_jacobian(RS["obstacle"], RS["omega"], kappa, RS["beta"], RS["r"], u, v, t0, PI)


def test_impact_at_window_end():
    st = fr.state_at(*FLAT.values(), 0.5, 0.0, 0.0, 4.0, **FLAT_FLIGHT)
    ts = st.impact_times[0]
    v_in = naive_impacts(*FLAT.values(), 0.5, 0.0, 1, **FLAT_FLIGHT)[0, 2]
    # impact exactly at t1 counts, and the state is the post-impact one (kappa, -r v_in)
    at = fr.state_at(*FLAT.values(), 0.5, 0.0, 0.0, ts, **FLAT_FLIGHT)
    assert at.n_impacts == 1 and at.impact_times[0] == pytest.approx(ts, abs=1e-13)
    assert at.u == pytest.approx(FLAT["kappa"], abs=1e-14)
    assert at.v == pytest.approx(-FLAT["r"] * v_in, rel=1e-14)
    # just before: no impact yet, the pre-impact state (kappa, v_in) up to O(1e-9 * |v_in|)
    before = fr.state_at(*FLAT.values(), 0.5, 0.0, 0.0, ts - 1e-9, **FLAT_FLIGHT)
    assert before.n_impacts == 0
    assert (before.u, before.v) == pytest.approx((FLAT["kappa"], v_in), abs=1e-8)
    # an impact within 1e-12 of t1: no step keeps the impact count, so it must refuse
    for d in (0.0, 1e-12, -1e-12):
        with pytest.raises(fr.FDStepError):
            fr.fd_jacobian(*FLAT.values(), 0.5, 0.0, 0.0, ts + d, **FLAT_FLIGHT)


def test_fixed_step_mode_agrees():
    # h given: a single Richardson pair; must agree with the closed form as well
    J, err = fr.fd_jacobian(*FLAT.values(), 0.5, 0.0, 0.0, 8.0, h=1e-4, **FLAT_FLIGHT)
    M, _ = closed_form_jacobian(*FLAT.values(), 0.5, 0.0, 0.0, 8.0, **FLAT_FLIGHT)
    np.testing.assert_allclose(J, M, rtol=0, atol=1e-7 * np.abs(M).max())
    assert_estimate_honest(J, M, err)
