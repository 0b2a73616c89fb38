"""Status codes that say the right thing (issue 15): sticking for good ends STUCK at once,
and the time budget follows the physics (a fast obstacle does not end a run NO_IMPACT).

Each case asserts its status and a number from an independent argument: the resting state
on the wall, the closed-form free flight, the slow reference of tests/naive.py, a
brute-force root search of the closed forms.
"""

import math

import naive
import numpy as np
from scipy.optimize import brentq

import cornerbif
from cornerbif import status as S
from cornerbif.models.flow import packed as P
from cornerbif.numerics.oscillator import budget_pieces, derive

HUGE = 10 ** 15   # a budget no run may spend: the run must end by itself


def flow(*start, **kw):
    return cornerbif.simulate(*start, model="flow", **kw)


def tp(*start, **kw):
    return cornerbif.simulate(*start, model="two_particle", **kw)


# ---- 1. sticking for good (flow) ------------------------------------------------------------

def test_particle_at_rest_on_a_flat_wall_is_stuck_with_its_state():
    # z = kappa = 1, k = 1: the spring presses the particle on the wall with N = k^2 kappa = 1
    # for all time (no corner, no forcing).  Before: each stuck corner counted as an event,
    # the run ended MAX_EVENTS; with these budgets it would never end
    r = flow(1.0, 0.0, beta=0.0, kappa=1.0, transient=0, record=4, max_events=HUGE,
             max_periods=HUGE)
    assert r["status"][0] == S.STUCK
    np.testing.assert_array_equal(r["final"][0], [1.0, 0.0])     # u = kappa, v = 0
    np.testing.assert_array_equal(r["su"][0], [1.0] * 4)         # every section: at rest
    np.testing.assert_array_equal(r["sv"][0], [0.0] * 4)


def test_inelastic_drop_on_a_flat_wall_sticks_at_the_closed_form_time():
    # u = 2 cos t meets z = 1 at t = pi/3 with v = -2 sin(pi/3) = -sqrt(3); r = 0 sticks
    r = flow(2.0, 0.0, beta=0.0, kappa=1.0, r=0.0, transient=0, record=3, max_events=HUGE,
             max_periods=HUGE)
    assert r["status"][0] == S.STUCK
    assert abs(r["t"][0, 0] - math.pi / 3) < 1e-11
    assert abs(r["v_in"][0, 0] + math.sqrt(3.0)) < 1e-10
    assert np.isnan(r["t"][0, 1])
    np.testing.assert_array_equal(r["final"][0], [1.0, 0.0])


def test_chattering_drop_ends_stuck_not_max_events():
    # r = 0.5: the impact sequence is summed (chatter), then the particle rests for good;
    # the requested 300 impacts never come
    r = flow(2.0, 0.0, beta=0.0, kappa=1.0, r=0.5, transient=300, record=5)
    assert r["status"][0] == S.STUCK
    np.testing.assert_array_equal(r["final"][0], [1.0, 0.0])


def test_stuck_on_a_sine_obstacle_whose_contact_force_stays_positive():
    # sine (no corners), k = 1, omega = 1.5, kappa = 2, beta = 0.5:
    # N = k^2 kappa + beta (k^2 - omega^2) sin >= 2 - 0.5 * 1.25 > 0.  At the sections
    # (t = n 2 pi/omega) z = kappa, z' = beta omega
    r = flow(3.0, 0.0, obstacle="sine", beta=0.5, kappa=2.0, omega=1.5, r=0.0, transient=0,
             record=4, max_events=HUGE, max_periods=HUGE)
    assert r["status"][0] == S.STUCK
    np.testing.assert_allclose(r["final"][0], [2.0, 0.75], rtol=0, atol=1e-15)
    np.testing.assert_allclose(r["su"][0], 2.0, rtol=0, atol=1e-15)


def test_a_contact_force_that_changes_sign_releases():
    # F = 2 > k^2 kappa = 1: N = 1 - 2 cos(3 t) turns negative, the particle leaves again
    r = flow(2.0, 0.0, beta=0.0, kappa=1.0, r=0.0, F=2.0, Omega=3.0, transient=0, record=5)
    assert r["status"][0] == S.OK
    assert np.all(np.isfinite(r["t"][0]))


# ---- 2. the time budget at a fast obstacle (flow) ---------------------------------------------

def test_fast_obstacle_impacts_match_the_reference_within_the_default_budget():
    # omega = 1000: before, the budget (4 (50 * 6 + 1000) pieces of pi/1000, 16.3 time units)
    # ended the run NO_IMPACT before the 6th impact at t = 17.07
    r = flow(5.0, 0.0, omega=1000.0, kappa=0.0, r=0.8, transient=0, record=6)
    assert r["status"][0] == S.OK
    ref = naive.naive_impacts("rectified_sine", 1000.0, 0.0, 1.0, 0.8, 5.0, 0.0, 6, dt=2e-5,
                              t_max=25.0)
    assert ref.shape == (6, 4)
    np.testing.assert_allclose(r["t"][0], ref[:, 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(r["v_out"][0], ref[:, 3], rtol=1e-9)
    # each impact is the first root of the closed-form flight from the previous one
    t_prev, u_prev, v_prev = 0.0, 5.0, 0.0
    for t_i, u_i, v_out in zip(r["t"][0], r["u"][0], r["v_out"][0]):
        def gap(t, t0=t_prev, u0=u_prev, v0=v_prev):
            s = t - t0
            return u0 * math.cos(s) + v0 * math.sin(s) - abs(math.sin(1000.0 * t))
        ts = np.linspace(t_prev, t_i, 200001)[1:]
        g = np.array([gap(x) for x in ts[:-1:10]])
        assert np.all(g > 0.0)                     # no earlier contact (brute force)
        root = brentq(gap, t_i - 1e-6, t_i + 1e-9, xtol=1e-15)
        assert abs(root - t_i) < 1e-9
        t_prev, u_prev, v_prev = t_i, u_i, v_out


def test_fast_obstacles_of_every_kind_reach_their_impacts():
    for obstacle in ("sine", "triangle"):
        r = flow(5.0, 0.0, obstacle=obstacle, omega=1000.0, kappa=0.0, transient=10, record=10)
        assert r["status"][0] == S.OK, obstacle


def test_a_flight_below_nothing_still_ends_no_impact():
    r = flow(1.0, 0.0, omega=1000.0, kappa=-100.0, transient=0, record=2, max_periods=20)
    assert r["status"][0] == S.NO_IMPACT


def test_the_budget_is_unchanged_where_the_obstacle_is_the_slower():
    for obstacle, omega, k, want in (("rectified_sine", 2.0, 1.0, 4000),
                                     ("triangle", 1.0, 1.0, 4000),
                                     ("rectified_sine", 1000.0, 1.0, 2_000_000)):
        p = P.pack({"omega": omega, "k": k}, obstacle, 1e-12, 1e-6, 1e6, None)
        got = budget_pieces(p, derive(p), np.int64(4000))
        assert abs(got - want) <= 1, (obstacle, omega, got)


# ---- 3. two_particle --------------------------------------------------------------------------

def test_stack_at_rest_on_a_flat_wall_is_stuck_at_once():
    # z = u = w = kappa = 1: N12 = Omega^2 kappa > 0, N2 = omega2^2 kappa > 0 for all time.
    # Before: STUCK only after max_periods sections (with this budget: never)
    r = tp(1.0, 0.0, 1.0, 0.0, beta=0.0, kappa=1.0, transient=0, record=4, max_events=HUGE,
           max_periods=HUGE)
    assert r["status"][0] == S.STUCK
    np.testing.assert_array_equal(r["final"][0], [1.0, 0.0, 1.0, 0.0])
    np.testing.assert_array_equal(r["sz"][0], [1.0] * 4)
    np.testing.assert_array_equal(r["su"][0], [1.0] * 4)


def test_inelastic_pair_drop_on_a_flat_wall_is_stuck():
    r = tp(1.5, 0.0, 2.0, 0.0, beta=0.0, kappa=1.0, r1=0.0, r2=0.0, transient=0, record=4,
           max_events=HUGE, max_periods=HUGE)
    assert r["status"][0] == S.STUCK
    np.testing.assert_array_equal(r["final"][0], [1.0, 0.0, 1.0, 0.0])


def test_fast_wall_two_particles_reach_their_impacts():
    # omega0 = 1000: before, max_periods counted sections of 2 pi/1000 and the run ended
    # NO_IMPACT.  The first w-z impact is the first root of 5 cos(1.001 t) = sin(1000 t)
    r = tp(5.0, 0.0, 6.0, 0.0, omega0=1000.0, kappa=0.0, transient=10, record=10)
    assert r["status"][0] == S.OK
    t_wz = r["wz_t"][0]
    r0 = tp(5.0, 0.0, 6.0, 0.0, omega0=1000.0, kappa=0.0, transient=0, record=2)
    t1 = r0["wz_t"][0, 0]

    def g(t):
        return 5.0 * np.cos(1.001 * t) - np.sin(1000.0 * t)
    ts = np.linspace(0.0, 1.5, 1_500_001)
    i = int(np.argmax(g(ts) <= 0.0))
    root = brentq(g, ts[i - 1], ts[i], xtol=1e-15)
    assert abs(t1 - root) < 1e-9
    assert np.all(np.isfinite(t_wz[:1]))
