"""Self-tests of the naive reference simulator ``tests/naive.py``.

Every expected number below comes from a closed formula or from an
independent solve (scipy ``solve_ivp`` / ``fsolve`` / ``brentq`` written out
here), never from the simulator itself.
"""

import math
import os
import sys

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq, fsolve

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import naive  # noqa: E402
from naive import free_flight, naive_gap_min, naive_impacts, z_obstacle, z_slope  # noqa: E402


# ---------------------------------------------------------------------------
# building blocks
# ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    "sigma,k,F,Omega,phi",
    [
        (0.0, 1.0, 0.0, 1.0, 0.0),  # paper's unforced undamped case
        (0.1, 1.0, 0.7, 1.9, 0.3),  # underdamped, forced
        (1.3, 1.3, 0.5, 0.8, -1.0),  # critically damped
        (2.0, 1.0, 0.5, 1.2, 2.0),  # overdamped
        (0.0, 1.5, 0.4, 1.5, 0.2),  # undamped resonance k == Omega
    ],
)
def test_free_flight_matches_solve_ivp(sigma, k, F, Omega, phi):
    """Closed-form flight vs. a tight numerical integration of the ODE."""
    t0, u0, v0 = 0.7, 0.4, -1.1

    def rhs(t, y):
        return [y[1], F * math.cos(Omega * t + phi) - 2 * sigma * y[1] - k * k * y[0]]

    ts = np.linspace(t0, t0 + 6.0, 25)
    sol = solve_ivp(rhs, (t0, ts[-1]), [u0, v0], t_eval=ts, method="DOP853",
                    rtol=1e-13, atol=1e-14)
    u, v = free_flight(ts, t0, u0, v0, sigma=sigma, k=k, F=F, Omega=Omega, phi=phi)
    np.testing.assert_allclose(u, sol.y[0], rtol=0, atol=1e-10)
    np.testing.assert_allclose(v, sol.y[1], rtol=0, atol=1e-10)
    # the initial condition is reproduced
    assert free_flight(t0, t0, u0, v0, sigma=sigma, k=k, F=F, Omega=Omega, phi=phi) == \
        pytest.approx((u0, v0), abs=1e-15)


def test_obstacle_shapes_and_one_sided_slopes():
    om, kap, beta = 1.7, -0.3, 0.8
    t = np.linspace(0.0, 9.0, 101)
    np.testing.assert_allclose(z_obstacle("rectified_sine", t, om, kap, beta),
                               kap + beta * np.abs(np.sin(om * t)), atol=1e-14)
    np.testing.assert_allclose(z_obstacle("sine", t, om, kap, beta),
                               kap + beta * np.sin(om * t), atol=1e-14)
    # rectified sine corner: right derivative +beta*omega (left one is -beta*omega)
    for j in range(4):
        tc = j * math.pi / om
        assert z_slope("rectified_sine", tc, om, kap, beta) == pytest.approx(beta * om, abs=1e-12)
        if j:
            assert z_slope("rectified_sine", tc - 1e-6, om, kap, beta) == \
                pytest.approx(-beta * om, abs=1e-5)
        assert z_obstacle("rectified_sine", tc, om, kap, beta) == pytest.approx(kap, abs=1e-14)
    # triangle: P = pi/omega, valley kappa at n*P, peak at n*P + tp
    th1, th2 = 1.0, 2.5
    P = math.pi / om
    tp = th1 * P / (th1 + th2)
    for n in range(3):
        assert z_obstacle("triangle", n * P, om, kap, theta1=th1, theta2=th2) == pytest.approx(kap)
        assert z_obstacle("triangle", n * P + tp, om, kap, theta1=th1, theta2=th2) == \
            pytest.approx(kap + th2 * tp)
        assert z_slope("triangle", n * P, om, kap, theta1=th1, theta2=th2) == th2
        assert z_slope("triangle", n * P + tp, om, kap, theta1=th1, theta2=th2) == -th1
        assert z_slope("triangle", n * P + 0.5 * tp, om, kap, theta1=th1, theta2=th2) == th2
        assert z_obstacle("triangle", n * P + tp + 0.25 * (P - tp), om, kap, theta1=th1,
                          theta2=th2) == pytest.approx(kap + th2 * tp - th1 * 0.25 * (P - tp))


def test_start_below_obstacle_rejected():
    with pytest.raises(ValueError):
        naive_impacts("sine", 2.0, 0.0, 1.0, 0.8, 0.5, 0.0, 3, t0=math.pi / 4)  # z = 1


# ---------------------------------------------------------------------------
# (1) known periodic orbit for the smooth sine wall
# ---------------------------------------------------------------------------
def test_sine_wall_periodic_orbit_eq6():
    """Paper eq (6): with omega=2, kappa=0, beta=1, r=0.8 the orbit
    u(t) = b|sin t|, b = beta*omega*(1+r)/(1-r) = 18, is periodic.

    Check of the closed form: at t = n*pi, u = 0 = z, z' = 2, v_in = -18 and
    v_out = (1+r)*2 - r*(-18) = 18; between impacts 18|sin t| > sin(2t).
    Started on it at t0 = pi/2 (u0 = 18, v0 = 0) the simulator must give
    impacts at t = n*pi with v_in = -18, v_out = +18."""
    r = 0.8
    b = 2.0 * (1 + r) / (1 - r)
    assert b == pytest.approx(18.0)
    imp = naive_impacts("sine", 2.0, 0.0, 1.0, r, b, 0.0, 12, t0=math.pi / 2)
    assert imp.shape == (12, 4)
    n = np.arange(1, 13)
    np.testing.assert_allclose(imp[:, 0], n * math.pi, rtol=0, atol=1e-9)
    np.testing.assert_allclose(imp[:, 1], 0.0, rtol=0, atol=1e-9)
    np.testing.assert_allclose(imp[:, 2], -b, rtol=0, atol=1e-9)
    np.testing.assert_allclose(imp[:, 3], b, rtol=0, atol=1e-9)


# ---------------------------------------------------------------------------
# (2) single-impact period-T orbit of the rectified sine, eq (10)
# ---------------------------------------------------------------------------
def _expected_single_impact_orbit(om, kap, beta, r):
    """Independent solve of the exact periodicity conditions.

    Unknowns (x, v_in, v_out), impact at tau = P + x just after the corner
    P = pi/omega (|sin| has period P, so the orbit near any other corner is the
    same one shifted by a multiple of P).  With T = 2*pi/omega and the
    undamped unforced flight u(t) = z cos(t-tau) + v_out sin(t-tau):
        z(tau) cos T + v_out sin T = z(tau + T)      (return to the obstacle)
       -z(tau) sin T + v_out cos T = v_in            (arrival velocity)
        v_out = (1+r) z'(tau) - r v_in               (impact law)
    solved with fsolve, starting from the linearised eq (10):
        kappa + theta2 x = theta2 (1+r)/(1-r) cot(T/2),  theta2 = beta*omega.
    Cross-checked with the equivalent reduced scalar equation
        z(tau) = (1+r)/(1-r) z'(tau) cot(T/2)  (brentq)."""
    T = 2 * math.pi / om
    P = math.pi / om
    th2 = beta * om

    def z(t):
        return kap + beta * abs(math.sin(om * t))

    def zp_right(x):  # slope just after the corner P, 0 < x < P
        return beta * om * math.cos(om * x)

    def eqs(p):
        x, vin, vout = p
        tau = P + x
        return [z(tau) * math.cos(T) + vout * math.sin(T) - z(tau + T),
                -z(tau) * math.sin(T) + vout * math.cos(T) - vin,
                vout - ((1 + r) * zp_right(x) - r * vin)]

    cot = 1.0 / math.tan(T / 2)
    x_lin = (th2 * (1 + r) / (1 - r) * cot - kap) / th2  # eq (10)
    guess = [x_lin, -th2 * (1 + r) / (1 - r), th2 * (1 + r) / (1 - r)]
    sol, info, ier, msg = fsolve(eqs, guess, xtol=1e-14, full_output=True)
    assert ier == 1, msg
    assert max(abs(e) for e in eqs(sol)) < 1e-11

    def reduced(x):
        return (kap + beta * math.sin(om * x)) - (1 + r) / (1 - r) * zp_right(x) * cot

    x_red = brentq(reduced, 0.0, P / 2, xtol=1e-15)
    assert sol[0] == pytest.approx(x_red, abs=1e-12)
    return sol[0], sol[1], sol[2], x_lin


def test_rectified_sine_single_impact_orbit_eq10():
    """omega=1.999, kappa=-0.02, beta=1, r=0.8: from a generic start the
    motion converges to the single-impact orbit of period T = 2 pi/omega
    (one impact every second corner).  Its impact offset from the nearest
    corner, ((t + P/2) mod P) - P/2 with P = pi/omega, and its v_in, v_out
    must equal the independent solve in _expected_single_impact_orbit to
    1e-8.  (The brief's 't mod T - pi/omega' is the same number when the
    orbit locks to the odd corners; from this start it locks to the even
    ones, which by the P-periodicity of |sin| is the same orbit.)"""
    om, kap, beta, r = 1.999, -0.02, 1.0, 0.8
    T, P = 2 * math.pi / om, math.pi / om
    x_ex, vin_ex, vout_ex, x_lin = _expected_single_impact_orbit(om, kap, beta, r)
    # the linearised eq (10) is close (the |sin| curvature is O(x^2))
    assert x_ex == pytest.approx(x_lin, abs=1e-6)
    assert x_ex > 0  # impact just after the corner, as assumed

    imp = naive_impacts("rectified_sine", om, kap, beta, r, 1.0, 0.0, 250, t0=0.3)
    assert imp.shape == (250, 4)
    tail = imp[-20:]
    np.testing.assert_allclose(np.diff(tail[:, 0]), T, rtol=0, atol=1e-9)
    off = np.mod(tail[:, 0] + P / 2, P) - P / 2
    np.testing.assert_allclose(off, x_ex, rtol=0, atol=1e-8)
    np.testing.assert_allclose(tail[:, 2], vin_ex, rtol=0, atol=1e-8)
    np.testing.assert_allclose(tail[:, 3], vout_ex, rtol=0, atol=1e-8)
    np.testing.assert_allclose(tail[:, 1], kap + beta * np.sin(om * x_ex), rtol=0, atol=1e-10)


# ---------------------------------------------------------------------------
# (3) grazing: +1e-7 -> no impact, -1e-7 -> impact
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("dt", [1e-3, 3e-2])
def test_grazing_flat_wall(dt):
    """Flat wall (beta=0), u = cos t from (0, 1, 0): min u = -1 at t = pi.
    kappa = -1 - 1e-7: gap min +1e-7, no impact.  kappa = -1 + 1e-7: impact
    where cos t* = -1 + 1e-7, i.e. t* = pi - 2 arcsin(sqrt(1e-7/2)), with
    v_in = -sin t*.  The incursion (width ~9e-4) is narrower than dt=3e-2
    and contains no grid point (corners j*pi/1.3), so only the
    local-minimum search can find it."""
    eps, om = 1e-7, 1.3
    gmin, tmin = naive_gap_min("rectified_sine", om, -1 - eps, 0.0, 1.0, 0.0, 0.0, 2 * math.pi,
                               dt=dt)
    assert gmin == pytest.approx(eps, abs=1e-13)
    assert tmin == pytest.approx(math.pi, abs=1e-6)

    imp, status = naive_impacts("rectified_sine", om, -1 - eps, 0.0, 0.8, 1.0, 0.0, 1,
                                dt=dt, t_max=2 * math.pi, return_status=True)
    assert imp.shape == (0, 4) and status == "t_max"

    imp = naive_impacts("rectified_sine", om, -1 + eps, 0.0, 0.8, 1.0, 0.0, 1, dt=dt,
                        t_max=2 * math.pi)
    t_star = math.pi - 2 * math.asin(math.sqrt(eps / 2))
    assert imp.shape == (1, 4)
    assert imp[0, 0] == pytest.approx(t_star, abs=1e-11)
    assert imp[0, 1] == pytest.approx(-1 + eps, abs=1e-15)
    assert imp[0, 2] == pytest.approx(-math.sin(t_star), abs=1e-11)
    assert imp[0, 3] == pytest.approx(-0.8 * imp[0, 2], abs=1e-15)  # wall at rest


def test_grazing_moving_sine_wall_with_forcing():
    """Damped forced flight over a sine wall.  The gap minimum for kappa=0
    is located by naive_gap_min and confirmed by brute-force dense sampling
    (2e6 points, 1e-12 accuracy); shifting kappa by g_min -/+ 1e-7 gives a
    flight grazing at +1e-7 (no impact) or -1e-7 (impact near the minimiser).
    A coarse dt=2e-2 is used so detection relies on the local-minimum
    search, not on a grid sign change."""
    par = dict(sigma=0.05, k=1.0, F=0.6, Omega=1.3, phi=0.4)
    om, beta = 1.5, 0.5
    t0, t1, u0, v0 = 0.0, 4.0, 2.0, 0.0
    gmin, tmin = naive_gap_min("sine", om, 0.0, beta, u0, v0, t0, t1, **par)
    assert t0 + 0.1 < tmin < t1 - 0.1  # an interior smooth minimum

    ts = np.linspace(t0, t1, 2_000_001)
    u, _ = free_flight(ts, t0, u0, v0, **par)
    gd = u - beta * np.sin(om * ts)
    assert gmin <= gd.min() + 1e-15 and gmin == pytest.approx(gd.min(), abs=1e-12)

    eps = 1e-7
    kw = dict(t0=t0, dt=2e-2, t_max=t1, return_status=True, **par)
    imp, status = naive_impacts("sine", om, gmin - eps, beta, 0.8, u0, v0, 1, **kw)
    assert imp.shape == (0, 4) and status == "t_max"
    imp, status = naive_impacts("sine", om, gmin + eps, beta, 0.8, u0, v0, 1, **kw)
    assert imp.shape == (1, 4) and status == "n_impacts"
    assert abs(imp[0, 0] - tmin) < 1e-3
    u_s, v_s = free_flight(imp[0, 0], t0, u0, v0, **par)
    z_s = gmin + eps + beta * math.sin(om * imp[0, 0])
    assert u_s - z_s == pytest.approx(0.0, abs=1e-14)
    assert imp[0, 2] == pytest.approx(v_s, abs=1e-14)
    assert imp[0, 2] - beta * om * math.cos(om * imp[0, 0]) < 0  # approaching


def test_grazing_at_triangle_peak_corner():
    """Triangle wall, omega=1, theta1=1, theta2=2: peak at tp = pi/3 with
    height zp = 2*pi/3.  The flight u = a cos(t - tp) has u' = 0 at the peak,
    so (|u'| < theta on [tp-0.5, tp+0.5]) the gap minimum is the corner value
    a - zp, where the gap has a kink, not a smooth minimum.  a = zp + 1e-7:
    no impact; a = zp - 1e-7: impact on the rising flank at
    t* = tp - 1e-7/theta2 (+O(1e-15) from the curvature of u).  A coarse
    dt = 5e-2 shows that the corner is sampled exactly."""
    om, th1, th2, eps = 1.0, 1.0, 2.0, 1e-7
    tp = th1 * math.pi / (th1 + th2)
    zpk = th2 * tp
    t0 = tp - 0.5
    common = dict(theta1=th1, theta2=th2)
    for a, expect in ((zpk + eps, 0), (zpk - eps, 1)):
        u0, v0 = a * math.cos(t0 - tp), -a * math.sin(t0 - tp)
        gmin, tmin = naive_gap_min("triangle", om, 0.0, 0.0, u0, v0, t0, tp + 0.5, **common)
        assert gmin == pytest.approx(a - zpk, abs=1e-14)
        assert tmin == pytest.approx(tp, abs=1e-15)
        imp, status = naive_impacts("triangle", om, 0.0, 0.0, 0.8, u0, v0, 1, t0=t0, dt=5e-2,
                                    t_max=tp + 0.5, return_status=True, **common)
        assert imp.shape == (expect, 4)
        if expect:
            assert imp[0, 0] == pytest.approx(tp - eps / th2, abs=1e-12)
            v_in = -a * math.sin(imp[0, 0] - tp)
            assert imp[0, 2] == pytest.approx(v_in, abs=1e-13)
            assert imp[0, 3] == pytest.approx((1 + 0.8) * th2 - 0.8 * v_in, abs=1e-13)


# ---------------------------------------------------------------------------
# cross-check of a full impact sequence against an event-driven solve_ivp
# ---------------------------------------------------------------------------
def _ivp_impacts(om, kap, beta, r, u0, v0, n, sigma, k, F, Omega, phi):
    """Independent simulator for the smooth sine wall: DOP853 + event on
    g = u - kappa - beta sin(omega t) crossing downward, Newton law, restart."""
    def rhs(t, y):
        return [y[1], F * math.cos(Omega * t + phi) - 2 * sigma * y[1] - k * k * y[0]]

    def gap(t, y):
        return y[0] - kap - beta * math.sin(om * t)
    gap.terminal, gap.direction = True, -1

    t, y, out = 0.0, [u0, v0], []
    while len(out) < n:
        sol = solve_ivp(rhs, (t, t + 100.0), y, method="DOP853", events=gap,
                        rtol=1e-13, atol=1e-14)
        te, ye = sol.t_events[0][0], sol.y_events[0][0]
        zp = beta * om * math.cos(om * te)
        vout = (1 + r) * zp - r * ye[1]
        out.append((te, kap + beta * math.sin(om * te), ye[1], vout))
        t, y = te, [kap + beta * math.sin(om * te), vout]
    return np.array(out)


def test_impact_sequence_matches_event_driven_solve_ivp():
    par = dict(sigma=0.05, k=1.0, F=0.8, Omega=1.5, phi=0.3)
    om, kap, beta, r = 1.5, 0.0, 0.5, 0.7
    ref = _ivp_impacts(om, kap, beta, r, 2.0, 0.0, 6, **par)
    imp = naive_impacts("sine", om, kap, beta, r, 2.0, 0.0, 6, **par)
    assert imp.shape == (6, 4)
    np.testing.assert_allclose(imp, ref, rtol=0, atol=1e-8)


def test_chatter_stop():
    """Flat wall (beta=0) at kappa=0.5 with k=1, F=0: near the wall the
    restoring force -u ~ -0.5 acts like gravity, a bouncing ball.  The
    undamped flight is time-reversible, so v_in(n+1) = -v_out(n) = r v_in(n):
    velocities decay geometrically (Zeno) and the simulator must stop with
    status 'chatter', every recorded impact having |v_in| >= 1e-9."""
    r = 0.5
    imp, status = naive_impacts("rectified_sine", 1.0, 0.5, 0.0, r, 1.0, 0.0, 500,
                                t_max=20.0, return_status=True)
    assert status == "chatter"
    assert 25 < len(imp) < 40  # 0.866 * 0.5**n < 1e-9  <=>  n >= 30
    assert np.all(np.abs(imp[:, 2]) >= naive.CHATTER_VELOCITY)
    assert imp[0, 2] == pytest.approx(-math.sqrt(0.75), abs=1e-13)  # cos t = 0.5
    ratios = imp[1:10, 2] / imp[:9, 2]
    np.testing.assert_allclose(ratios, r, rtol=1e-6)
