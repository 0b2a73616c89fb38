"""Sticking after chatter in the linear model (docs/linear.md, "Sticking"): a contact that
chatters to rest on a fixed stop is held (g = 0, g' = 0, the accelerations projected) while its
contact force lam = -a^T M^-1 (F - K x - C x') / (a^T M^-1 a) is >= 0, and released where lam
turns negative; the numpy reference (simulate.py) and the kernel against closed forms, against
each other and against scipy's solve_ivp with the held contact treated event by event."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from cornerbif.models.linear.flight import held
from cornerbif.models.linear.kernel import CHATTERS, OK, run_system
from cornerbif.models.linear.simulate import simulate
from cornerbif.models.linear.system import Contact, Forcing, LinearSystem


def _ball(g=1.0, F=2.0, W=1.0, phi=math.pi, r=0.0, k=0.0, c=0.0):
    """x'' + c x' + k x = -g + F cos(W t + phi) above a fixed stop x >= 0."""
    return LinearSystem(dofs=("x",), mass=np.eye(1), stiffness=np.array([[k]]),
                        damping=np.array([[c]]),
                        forcing=(Forcing(0, -g), Forcing(0, F, W, phi)),
                        contacts=(Contact("T", np.array([1.0]), "fixed", 0.0, r=r),))


def test_the_contact_force_is_the_constrained_motions():
    """flight.held: lam = row . y is, up to its positive scale, -a^T M^-1 f / (a^T M^-1 a), and
    the held flight keeps a . x'' = 0 (a two-mass system, a gap on their difference)."""
    s = LinearSystem(dofs=("x", "y"), mass=np.diag([1.0, 0.5]),
                     stiffness=np.array([[2.0, -1.0], [-1.0, 1.0]]), damping=0.1 * np.eye(2),
                     forcing=(Forcing(0, -1.0), Forcing(1, 0.7, 1.3, 0.2)),
                     contacts=(Contact("R", np.array([-1.0, 1.0]), "fixed", -0.4, r=0.5),))
    Ah, row = held(s, 0)
    rng = np.random.default_rng(3)
    a = s.contacts[0].gap
    Minv = np.linalg.inv(s.mass)
    ratios = []
    for _ in range(5):
        x, v = rng.normal(size=2), rng.normal(size=2)
        th = rng.uniform(0, 2 * np.pi)
        y = np.concatenate([x, v, [math.cos(th), math.sin(th), 1.0]])
        f = np.array([-1.0, 0.7 * math.cos(th)]) - s.stiffness @ x - s.damping @ v
        lam = -(a @ Minv @ f) / (a @ Minv @ a)
        ratios.append(row @ y / lam)
        acc = (Ah @ y)[2:4]
        assert abs(a @ acc) < 1e-13
        # the constrained law: M x'' = f + lam a
        assert np.allclose(s.mass @ acc, f + lam * a, atol=1e-13)
    assert ratios[0] > 0.0 and np.allclose(ratios, ratios[0], rtol=1e-12)
    assert np.linalg.norm(row) == pytest.approx(np.linalg.norm(a), rel=1e-15)


def _closed_form(g, F, W, phi, h):
    """The forced ball with r = 0 (every impact chatters: it sticks at once), derived here:
    in flight x'' = -g + F cos(W t + phi), so from (x0, 0) at t0 (theta0 = W t0 + phi)
    x = x0 - g s^2 / 2 + (F / W^2)(cos theta0 - cos theta) - (F / W) sin theta0 s; held on
    x = 0 while lam = g - F cos theta >= 0: released where cos theta = g / F with cos rising,
    theta = 2 pi k - arccos(g / F).  Returns the first two impacts (t, v-) and the release."""
    def x(t, t0, x0):
        th0, th = W * t0 + phi, W * t + phi
        s = t - t0
        return x0 - g * s * s / 2 + F / W ** 2 * (math.cos(th0) - math.cos(th)) - F / W * math.sin(th0) * s

    def v(t, t0):
        return -g * (t - t0) + F / W * (math.sin(W * t + phi) - math.sin(W * t0 + phi))

    t1 = brentq(x, 1e-9, 5.0, args=(0.0, h), xtol=1e-16)
    k = math.ceil((W * t1 + phi + math.acos(g / F)) / (2 * math.pi))
    tr = (2 * math.pi * k - math.acos(g / F) - phi) / W
    # the next landing: the first root of x after the release (x ~ s^3 at first)
    grid = tr + np.linspace(1e-3, 12.0, 12000)
    vals = [x(t, tr, 0.0) for t in grid]
    i = next(i for i in range(1, len(vals)) if vals[i] < 0.0)
    t2 = brentq(x, grid[i - 1], grid[i], args=(tr, 0.0), xtol=1e-16)
    return (t1, v(t1, 0.0)), tr, (t2, v(t2, tr))


@pytest.mark.parametrize("g,F,W", [(1.0, 2.0, 1.0), (0.5, 1.5, 2.0)])
def test_release_and_the_flight_after_it_have_the_closed_form(g, F, W):
    """The forced ball of ``_closed_form`` with r = 0: the release time and the next landing
    (time and speed) equal the closed form to 1e-10, in the numpy run and the kernel."""
    phi = math.pi
    s = _ball(g, F, W, phi)
    (t1, v1), tr, (t2, v2) = _closed_form(g, F, W, phi, 0.1)
    releases = []
    out, why = simulate(s, [0.1], [0.0], 0.0, 2, horizon=50.0, releases=releases)
    assert why == "ok"
    assert releases[0].t == pytest.approx(tr, abs=1e-10)
    assert [o.t for o in out] == pytest.approx([t1, t2], abs=1e-10)
    assert [o.v_in[0] for o in out] == pytest.approx([v1, v2], abs=1e-10)
    assert [o.v_out[0] for o in out] == [0.0, 0.0]           # held: v+ = 0 along the gap
    st, d = run_system(s, 0.0, [0.1], [0.0], 2, t_max=50.0)
    assert st == OK
    assert d["t"] == pytest.approx([t1, t2], abs=1e-10)
    assert d["v_in"][:, 0] == pytest.approx([v1, v2], abs=1e-10)
    assert np.all(d["v_out"] == 0.0)


def test_a_ball_on_a_fixed_table_sticks_for_good():
    """A ball under gravity (x'' = -1) with r = 0.5 dropped from 0.5 chatters to rest: its
    impacts at t_k of the geometric sequence (w_0 = -1, each rebound r times the last, flights
    2 r^k / g), then held for good: the run ends STUCK (CHATTERS) at the budget, not at the
    chatter."""
    s = LinearSystem(dofs=("x",), mass=np.eye(1), stiffness=np.zeros((1, 1)),
                     damping=np.zeros((1, 1)), forcing=(Forcing(0, -1.0),),
                     contacts=(Contact("T", np.array([1.0]), "fixed", 0.0, r=0.5),))
    st, d = run_system(s, 0.0, [0.5], [0.0], 40, t_max=20.0)
    assert st == CHATTERS
    n = len(d["t"])
    # impact k (from 0) has w- = -r^k and rebound r^(k + 1): r^20 <= 1e-6, so the 20th is held
    assert n == 20
    expected = 1.0 + np.concatenate([[0.0], np.cumsum([2 * 0.5 ** k for k in range(1, n)])])
    assert d["t"] == pytest.approx(expected, abs=1e-9)
    assert d["v_out"][-1, 0] == 0.0
    assert d["x"][-1, 0] == 0.0
    out, why = simulate(s, [0.5], [0.0], 0.0, 40, horizon=20.0)
    assert why.startswith("held on contact T")
    assert [o.t for o in out] == pytest.approx(expected, abs=1e-10)


def _random_chatterer(rng):
    """N = 1-3 masses, weak coupling springs and damping, gravity and a harmonic force on x0
    above a fixed stop x0 >= 0, and on some a second stop (x1 <= 0.6 or x1 - x0 >= -1)."""
    n = int(rng.integers(1, 4))
    mass = np.diag(rng.uniform(0.5, 2.0, n))
    B = rng.normal(size=(n, n)) * 0.3
    K = B @ B.T
    C = 0.05 * np.eye(n)
    forcing = (Forcing(0, -1.0), Forcing(0, float(rng.uniform(1.2, 2.0)), float(rng.uniform(0.6, 1.4)),
                                         float(rng.uniform(0, 2 * np.pi))))
    contacts = [Contact("A", np.eye(n)[0], "fixed", 0.0, r=float(rng.uniform(0.2, 0.5)))]
    if n > 1 and rng.random() < 0.5:
        contacts.append(Contact("B", -np.eye(n)[1], "fixed", -0.6, r=0.7))
    elif n > 1:
        contacts.append(Contact("B", np.eye(n)[1] - np.eye(n)[0], "fixed", -1.0, r=0.7))
    return LinearSystem(dofs=tuple(f"x{i}" for i in range(n)), mass=mass, stiffness=K, damping=C,
                        forcing=forcing, contacts=tuple(contacts))


@pytest.mark.parametrize("seed", [1, 2, 3, 4])
def test_the_kernel_is_the_numpy_run_through_holds_and_releases(seed):
    """On random systems that chatter to rest (``_random_chatterer``) the kernel and the numpy
    run (numpy's expm, events.py's halving) find the same events: the same contacts in the same
    order, times and velocities to 1e-8, the same holds (v+ = 0 along the gap)."""
    rng = np.random.default_rng(seed)
    s = _random_chatterer(rng)
    x0 = np.zeros(s.n)
    x0[0] = 0.2
    count = 40
    releases = []
    out, _ = simulate(s, x0, np.zeros(s.n), 0.0, count, horizon=60.0, releases=releases)
    st, d = run_system(s, 0.0, x0, np.zeros(s.n), count, t_max=60.0)
    k = min(len(out), len(d["t"]))
    assert abs(len(out) - len(d["t"])) <= 0 or k >= 20
    assert [o.contact for o in out[:k]] == d["contact"][:k]
    assert [o.t for o in out[:k]] == pytest.approx(list(d["t"][:k]), abs=1e-8)
    assert np.allclose([o.v_in for o in out[:k]], d["v_in"][:k], atol=1e-8)
    assert np.allclose([o.v_out for o in out[:k]], d["v_out"][:k], atol=1e-8)
    holds = [i for i, o in enumerate(out[:k]) if o.contact == "A" and o.v_out[0] == 0.0]
    assert holds, "the run never held: not a test of sticking"
    assert releases


def _solve_ivp_run(g, F, W, phi, k, c, h, n_impacts):
    """The forced damped oscillator above a stop (``_ball``) with r = 0, brute force: each
    flight by DOP853 (rtol = atol = 1e-12) with the landing x = 0 as its event; at a landing
    v = 0, held while lam = g - F cos(W t + phi) >= 0 (x = 0, v = 0: the spring and dashpot
    are at rest), its release the root of lam located by brentq.  Returns landings (t, v-)."""
    def rhs(t, y):
        return [y[1], -g + F * math.cos(W * t + phi) - k * y[0] - c * y[1]]

    def land(t, y):
        return y[0]
    land.terminal, land.direction = True, -1
    t, y, out = 0.0, [h, 0.0], []
    while len(out) < n_impacts:
        sol = solve_ivp(rhs, (t, t + 50.0), y, method="DOP853", rtol=1e-12, atol=1e-12,
                        events=land)
        assert sol.t_events[0].size
        t = float(sol.t_events[0][0])
        out.append((t, float(sol.y_events[0][0][1])))

        def lam(s):
            return g - F * math.cos(W * s + phi)
        # held from t while lam >= 0: the release is lam's first sign change after t
        grid = t + np.linspace(0.0, 20.0, 20001)[1:]
        i = next(i for i in range(len(grid)) if lam(grid[i]) < 0.0)
        lo = grid[i - 1] if i else t
        t = brentq(lam, lo, grid[i], xtol=1e-15)
        # off the stop: x = 0, v = 0, the gap's first move up (lam < 0 from here)
        t += 1e-9
        y = [0.0, 0.0]
    return out


@pytest.mark.parametrize("W", [0.8, 1.3])
def test_a_periodic_stick_release_motion_against_solve_ivp(W):
    """x'' + 0.1 x' + 0.5 x = -1 + 2 cos(W t + pi) above x >= 0 with r = 0: it lands, sticks,
    is released and flies, again and again; its landings (times and speeds) by the kernel equal
    solve_ivp's event-driven run (``_solve_ivp_run``) to 1e-7 over eight of them, each held."""
    g, F, phi, k, c = 1.0, 2.0, math.pi, 0.5, 0.1
    s = _ball(g, F, W, phi, r=0.0, k=k, c=c)
    ref = _solve_ivp_run(g, F, W, phi, k, c, 0.1, 8)
    st, d = run_system(s, 0.0, [0.1], [0.0], 8, t_max=200.0)
    assert st == OK
    assert d["t"] == pytest.approx([t for t, _ in ref], abs=1e-7)
    assert d["v_in"][:, 0] == pytest.approx([v for _, v in ref], abs=1e-7)
    assert np.all(d["v_out"] == 0.0)
