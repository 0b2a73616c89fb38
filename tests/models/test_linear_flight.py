"""Exact flights and the impact law of a linear system (cornerbif/models/linear/flight.py,
impact.py; issue 33), against computations that share nothing with them: scipy's expm,
closed forms of the single oscillator (free fall, resonance, the damped forced response),
scipy's solve_ivp at tight tolerance for coupled systems, conservation laws, and the
paper's laws (5) and (74) as the kernels implement them."""

import math

import numpy as np
import pytest
import scipy.integrate
import scipy.linalg
from hypothesis import given, settings
from hypothesis import strategies as st

from cornerbif.models.linear.flight import expm, flight
from cornerbif.models.linear.impact import newton_impact
from cornerbif.models.linear.system import Forcing, LinearSystem
from cornerbif.models.two_particle.packed import mass_ratio_impact
from cornerbif.numerics.impact import restitution


def _one(k=1.0, c=0.0, m=1.0, forcing=()):
    return LinearSystem(("u",), np.array([[m]]), np.array([[k]]), np.array([[c]]),
                        tuple(forcing))


@pytest.mark.parametrize("A", [
    np.array([[0.0, 1.0], [0.0, 0.0]]),                         # a free particle (Jordan)
    np.array([[0.0, 1.0], [-1.0, 0.0]]) * 40.0,                  # a fast rotation (scaled)
    np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]]),
    np.diag([-30.0, 0.5, 2.0]) + np.triu(np.ones((3, 3)), 1),
])
def test_expm_equals_scipy_on_hard_matrices(A):
    """Nilpotent, rotating, defective and stiff matrices: scipy.linalg.expm (Al-Mohy and
    Higham's algorithm, written separately) to 1e-13 relative."""
    np.testing.assert_allclose(expm(A), scipy.linalg.expm(A), rtol=1e-13, atol=1e-13)


@settings(max_examples=60, deadline=None)
@given(st.integers(1, 14), st.integers(0, 2**31 - 1), st.floats(1e-3, 50.0))
def test_expm_equals_scipy_on_random_matrices(n, seed, scale):
    """Random n x n matrices of norm up to 50: to 1e-11 of the result's norm (each
    algorithm's backward error of about 1e-16, times the exponential's relative condition
    number, of the order of ||A||: measured up to 1.04e-12 at ||A|| = 9)."""
    A = np.random.default_rng(seed).standard_normal((n, n))
    A *= scale / max(np.linalg.norm(A, 1), 1e-300)
    want = scipy.linalg.expm(A)
    assert np.linalg.norm(expm(A) - want) <= 1e-11 * max(1.0, np.linalg.norm(want))


def test_free_fall_is_the_parabola():
    """K = 0, a constant force -g: x = x0 + v0 h - g h^2 / 2, v = v0 - g h (a rigid-body
    mode: A is not diagonalisable)."""
    g = 9.81
    s = _one(k=0.0, forcing=[Forcing(0, -g)])
    x, v = flight(s, 3.0, [2.0], [5.0], 0.7)
    assert math.isclose(x[0], 2.0 + 5.0 * 0.7 - g * 0.7 ** 2 / 2, rel_tol=1e-14)
    assert math.isclose(v[0], 5.0 - g * 0.7, rel_tol=1e-14)


def test_forcing_at_resonance_grows_like_t_sin_t():
    """u'' + u = cos t from rest: u = t sin(t) / 2, u' = (sin t + t cos t) / 2 (a double
    pair of eigenvalues +-i), over 40 periods."""
    s = _one(forcing=[Forcing(0, 1.0, 1.0, 0.0)])
    t = 40 * 2 * math.pi + 1.3
    x, v = flight(s, 0.0, [0.0], [0.0], t)
    assert math.isclose(x[0], t * math.sin(t) / 2, rel_tol=1e-11)
    assert math.isclose(v[0], (math.sin(t) + t * math.cos(t)) / 2, rel_tol=1e-11)


def test_damped_forced_oscillator_closed_form():
    """u'' + 2 sigma u' + k^2 u = F cos(Omega t + phi): the steady response P cos(Omega t
    + phi - delta), |P| = F / sqrt((k^2 - Omega^2)^2 + (2 sigma Omega)^2), plus the free
    decay of what is left, written out here; from t0 = 1.1 over h = 2.9."""
    sig, k, F, Om, phi = 0.1, 1.3, 0.7, 2.1, 0.4
    s = _one(k=k * k, c=2 * sig, forcing=[Forcing(0, F, Om, phi)])
    t0, h, x0, v0 = 1.1, 2.9, 0.3, -0.8
    amp = F / math.hypot(k * k - Om * Om, 2 * sig * Om)
    dl = math.atan2(2 * sig * Om, k * k - Om * Om)

    def part(t):
        return (amp * math.cos(Om * t + phi - dl), -amp * Om * math.sin(Om * t + phi - dl))

    wd = math.sqrt(k * k - sig * sig)
    p0, q0 = part(t0)
    a, b = x0 - p0, v0 - q0              # the free part at t0: a cos + (b + sig a)/wd sin
    e = math.exp(-sig * h)
    uh = e * (a * math.cos(wd * h) + (b + sig * a) / wd * math.sin(wd * h))
    vh = e * (b * math.cos(wd * h) - (sig * b + k * k * a) / wd * math.sin(wd * h))
    p1, q1 = part(t0 + h)
    x, v = flight(s, t0, [x0], [v0], h)
    assert math.isclose(x[0], uh + p1, rel_tol=1e-12)
    assert math.isclose(v[0], vh + q1, rel_tol=1e-12)


def _random_system(seed, n, forced=True):
    rng = np.random.default_rng(seed)
    L = rng.standard_normal((n, n))
    M = L @ L.T + n * np.eye(n)
    R = rng.standard_normal((n, n))
    K = R @ R.T
    C = 0.05 * (K + np.eye(n))
    f = (Forcing(int(rng.integers(n)), 0.8, 1.7, 0.3), Forcing(0, -0.2)) if forced else ()
    return LinearSystem(tuple(f"x{i}" for i in range(n)), M, K, C, f), rng


@pytest.mark.parametrize("n", [2, 4, 6])
def test_coupled_forced_flight_equals_a_tight_ode_solution(n):
    """A random coupled damped system with a harmonic and a constant force: the flight over
    h = 5 against scipy's DOP853 at rtol 1e-13 (an independent integration), to 1e-9."""
    s, rng = _random_system(n, n)
    x0, v0 = rng.standard_normal(n), rng.standard_normal(n)
    Minv = np.linalg.inv(s.mass)

    def rhs(t, y):
        f = np.zeros(n)
        for fo in s.forcing:
            f[fo.on] += fo.F * math.cos(fo.Omega * t + fo.phi)
        return np.concatenate([y[n:], Minv @ (f - s.stiffness @ y[:n] - s.damping @ y[n:])])

    sol = scipy.integrate.solve_ivp(rhs, (0.4, 5.4), np.concatenate([x0, v0]), method="DOP853",
                                    rtol=1e-13, atol=1e-13)
    x, v = flight(s, 0.4, x0, v0, 5.0)
    np.testing.assert_allclose(np.concatenate([x, v]), sol.y[:, -1], rtol=1e-9, atol=1e-9)


def test_flights_compose_and_conserve_energy_when_undamped():
    """Undamped and unforced: v.Mv/2 + x.Kx/2 is conserved (to 1e-12) and two flights of
    h1 and h2 are one of h1 + h2 (to 1e-12)."""
    s, rng = _random_system(7, 4, forced=False)
    s = LinearSystem(s.dofs, s.mass, s.stiffness, np.zeros((4, 4)))
    x0, v0 = rng.standard_normal(4), rng.standard_normal(4)

    def energy(x, v):
        return 0.5 * v @ s.mass @ v + 0.5 * x @ s.stiffness @ x

    x1, v1 = flight(s, 0.0, x0, v0, 3.7)
    x2, v2 = flight(s, 3.7, x1, v1, 8.1)
    x3, v3 = flight(s, 0.0, x0, v0, 11.8)
    assert math.isclose(energy(x2, v2), energy(x0, v0), rel_tol=1e-12)
    np.testing.assert_allclose(np.concatenate([x2, v2]), np.concatenate([x3, v3]),
                               rtol=1e-11, atol=1e-12)


@settings(max_examples=200, deadline=None)
@given(st.floats(0.01, 100.0), st.floats(-50.0, 50.0), st.floats(-50.0, 50.0),
       st.floats(0.0, 1.0))
def test_one_mass_is_law_5(m, v, zp, r):
    """N = 1, a = 1: v+ = (1 + r) z' - r v- (``numerics.impact.restitution``), to rounding."""
    got = newton_impact([[m]], [1.0], [v], zp, r)[0]
    assert math.isclose(got, restitution(v, zp, r), rel_tol=1e-12, abs_tol=1e-12)


@settings(max_examples=200, deadline=None)
@given(st.floats(0.01, 1e4), st.floats(-50.0, 50.0), st.floats(-50.0, 50.0),
       st.floats(0.0, 1.0))
def test_two_masses_are_law_74(mu, y, v, r):
    """z of mass 1 and u of mass 1/mu, the gap u - z (a = (-1, 1), a fixed frame: z' of
    the obstacle 0): equal to law (74) as the two-particle kernel applies it
    (``mass_ratio_impact``), to 1e-10 of the velocities' scale."""
    got = newton_impact(np.diag([1.0, 1.0 / mu]), [-1.0, 1.0], [y, v], 0.0, r)
    want = mass_ratio_impact(y, v, mu, r)
    scale = 1.0 + abs(y) + abs(v)
    assert abs(got[0] - want[0]) <= 1e-10 * scale and abs(got[1] - want[1]) <= 1e-10 * scale


def test_impact_keeps_what_it_must():
    """A random 4-mass system, a random contact: w+ = -r w-, q . M v unchanged for q . a = 0,
    and with r = 1 against a fixed obstacle the kinetic energy unchanged (1e-12)."""
    s, rng = _random_system(11, 4, forced=False)
    a = rng.standard_normal(4)
    v = rng.standard_normal(4)
    r = 0.6
    vp = newton_impact(s.mass, a, v, 0.3, r)
    assert math.isclose(a @ vp - 0.3, -r * (a @ v - 0.3), rel_tol=1e-12)
    q = rng.standard_normal(4)
    q -= (q @ a) / (a @ a) * a
    assert math.isclose(q @ s.mass @ vp, q @ s.mass @ v, rel_tol=1e-12, abs_tol=1e-12)
    v1 = newton_impact(s.mass, a, v, 0.0, 1.0)
    assert math.isclose(v1 @ s.mass @ v1, v @ s.mass @ v, rel_tol=1e-12)
