"""The two-particle model of section 6 (eqs 5, 72-74): laws, limits, events, contracts.

Every test states the value it expects and where that value comes from.
"""

import math

import numba
import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import cornerbif
from cornerbif import simulate
from cornerbif import status as S
from cornerbif.models.two_particle import kernel as K
from cornerbif.models.two_particle import packed as P
from cornerbif.models.two_particle.packed import mass_ratio_impact
from cornerbif.numerics.impact import restitution

FIG19 = dict(omega1=1.001, omega2=1.0, mu=1000.0, r1=0.8, r2=0.8, kappa=0.0, beta=1.0)


def _wall(p, t):
    return p["kappa"] + p["beta"] * np.sin(p["omega0"] * t)


# ------------------------------------------------------------------ the impact law (74)
def test_law74_matches_the_paper_matrix_and_mu_inf_is_law5():
    """(74) as printed: y+ = ((mu - r) y + (1 + r) v)/(1 + mu),
    v+ = (mu (1 + r) y + (1 - r mu) v)/(1 + mu); mu = inf is law (5) bit for bit."""
    for mu, r, y, v in [(1.0, 0.8, 0.3, -2.0), (1000.0, 0.5, 1.7, -0.2), (3.0, 0.0, -1.0, -4.0),
                        (10.0, 1.0, 2.0, 0.5)]:
        yo, vo = mass_ratio_impact(y, v, mu, r)
        assert yo == pytest.approx(((mu - r) * y + (1 + r) * v) / (1 + mu), rel=1e-14, abs=1e-14)
        assert vo == pytest.approx((mu * (1 + r) * y + (1 - r * mu) * v) / (1 + mu), rel=1e-13,
                                   abs=1e-13)
    for r, y, v in [(0.8, 0.3, -2.0), (0.0, 1.0, -1.0), (1.0, -0.5, -3.0)]:
        yo, vo = mass_ratio_impact(y, v, math.inf, r)
        assert yo == y
        assert vo == restitution(v, y, r) == (1 + r) * y - r * v


@settings(max_examples=300, deadline=None)
@given(y=st.floats(-50, 50), v=st.floats(-50, 50), mu=st.floats(0.01, 1e9),
       r=st.floats(0.0, 1.0))
@example(y=-2.0, v=0.01, mu=0.01, r=0.01)
def test_law74_conserves_momentum_and_reverses_relative_velocity(y, v, mu, r):
    """(74) by construction: mu y + v is conserved and v+ - y+ = -r (v- - y-), to rounding.

    Rounding is relative to every quantity the law computes, including its increment
    d = (1 + r)(v- - y-) (models.two_particle.packed.mass_ratio_impact): v+ = (v- - d) + d/(1 + mu)
    carries ~1 ulp of |d| even where v-, v+ are small (found: y = -2, v = 0.01, mu = r = 0.01
    gives 4.4e-16 against a scale of 0.04 without |d|)."""
    yo, vo = mass_ratio_impact(y, v, mu, r)
    d = (1 + r) * abs(v - y)
    scale = mu * (abs(y) + abs(yo)) + abs(v) + abs(vo) + d + 1e-300
    assert abs(mu * (yo - y) + (vo - v)) <= 1e-14 * scale
    assert abs((vo - yo) + r * (v - y)) <= 1e-14 * (abs(v) + abs(y) + abs(vo) + abs(yo) + d
                                                    + 1e-300)


# ------------------------------------------------------------------ (a) mu -> inf
def test_huge_mass_ratio_reduces_to_law5_along_a_run():
    """mu = 1e12: at every z-u impact v+ = (1 + r2) y- - r2 v- (law 5) and y+ = y-, both up
    to the mass-ratio term (1 + r2)|v- - y-|/(1 + mu) (<= 3.3e-10 here, where u moves at
    up to ~170 against y <= 18) plus rounding (section 6.1:
    (74) -> (5) as mu -> inf).  The run also tracks the mu = inf run."""
    kw = dict(FIG19, mu=1e12, omega0=2.0)
    a = cornerbif.simulate(5.0, 0.0, 8.0, 0.0, transient=0, record=60, **kw, model="two_particle")
    assert a["status"][0] == S.OK
    yi, yo, vi, vo = a["y_in"][0], a["y_out"][0], a["v_in"][0], a["v_out"][0]
    term = 1.8 * np.abs(vi - yi) / (1 + 1e12)
    law5 = (1 + 0.8) * yi - 0.8 * vi
    eps = np.finfo(float).eps
    assert (np.abs(vo - law5) <= term + 8 * eps * np.abs(vi)).all()
    assert (np.abs(yo - yi) <= term + 4 * eps * np.abs(yi)).all()
    b = cornerbif.simulate(5.0, 0.0, 8.0, 0.0, transient=0, record=60, **dict(kw, mu=math.inf),
                           model="two_particle")
    assert (b["y_out"] == b["y_in"]).all()                 # z untouched by u when mu = inf
    assert np.abs(a["t"] - b["t"]).max() < 1e-8
    assert np.abs(a["v_in"] - b["v_in"]).max() < 1e-7


# ------------------------------------------------------------------ (b) the flow model
@pytest.mark.parametrize("omega, u0, v0, r", [(2.5, 3.0, 0.0, 0.8), (1.7, 2.0, 1.0, 0.8),
                                              (2.1, 5.0, -1.0, 0.5)])
def test_rectified_sine_heavy_particle_matches_flow(omega, u0, v0, r):
    """Fixed wall w = 0 (beta = kappa = 0), r1 = 1, omega1 = omega and z(0) = 0,
    y(0) = omega: z(t) = |sin(omega t)| exactly (a free arc sin(omega t) reflected
    elastically at every zero).  With mu = inf, u (omega2 = k = 1) then sees exactly
    the obstacle of eq (8) with kappa = 0, beta = 1, so its impacts must equal the
    ``flow`` kernel's to ~1e-9 (both locate events to tol = 1e-12)."""
    a = cornerbif.simulate(0.0, omega, u0, v0, transient=0, record=20, omega0=omega,
                              omega1=omega, omega2=1.0, mu=math.inf, r1=1.0, r2=r,
                              kappa=0.0, beta=0.0, model="two_particle")
    b = simulate(u0, v0, transient=0, record=20, obstacle="rectified_sine", omega=omega,
                 kappa=0.0, beta=1.0, r=r)
    assert a["status"][0] == S.OK and b["status"][0] == S.OK
    assert np.abs(a["t"] - b["t"]).max() < 1e-9
    assert np.abs(a["u"] - b["u"]).max() < 1e-9
    assert np.abs(a["v_in"] - b["v_in"]).max() < 1e-9
    assert np.abs(a["v_out"] - b["v_out"]).max() < 1e-9
    # the corners of eq (8) are the w-z impacts: at k pi/omega with y -omega -> +omega
    nw = np.isfinite(a["wz_t"][0]).sum()
    k = np.arange(1, nw + 1)
    assert np.abs(a["wz_t"][0, :nw] - k * math.pi / omega).max() < 1e-9
    assert np.abs(a["wz_y_in"][0, :nw] + omega).max() < 1e-9
    assert np.abs(a["wz_y_out"][0, :nw] - omega).max() < 1e-9
    # the offsets too, except before the first w-z impact (flow counts t = 0 as a corner)
    late = a["t"][0] > 0.5 * math.pi / omega
    assert np.abs(a["corner_offset"][0, late] - b["corner_offset"][0, late]).max() < 1e-9


# ------------------------------------------------------------------ (c) along runs
def _random_points(n, seed):
    rng = np.random.default_rng(seed)
    prm = dict(omega0=rng.uniform(0.3, 3, n), omega1=rng.uniform(0.3, 3, n),
               omega2=rng.uniform(0.3, 3, n),
               mu=rng.choice([1.0, 3.0, 10.0, 1000.0, math.inf], n),
               r1=rng.choice([0.0, 0.3, 0.8, 1.0], n), r2=rng.choice([0.0, 0.3, 0.8, 1.0], n),
               kappa=rng.uniform(-1, 1, n), beta=rng.uniform(0, 2, n))
    z0 = prm["kappa"] + rng.choice([0.0, 0.5, 3.0], n)
    u0 = z0 + rng.choice([0.0, 0.5, 3.0], n)
    return prm, z0, rng.uniform(-3, 3, n), u0, rng.uniform(-3, 3, n)


def test_every_zu_impact_conserves_momentum_and_reverses_relative_velocity():
    """Seeded random parameters and states (mu from 1 to inf, r from 0 to 1): at every
    recorded z-u impact M y + m v is conserved (finite mu) and v+ - y+ = -r2 (v- - y-),
    to rounding (law 74)."""
    prm, z0, y0, u0, v0 = _random_points(120, 11)
    a = cornerbif.simulate(z0, y0, u0, v0, transient=0, record=150, **prm, model="two_particle")
    mu = prm["mu"][:, None] * np.ones_like(a["t"])
    r2 = prm["r2"][:, None]
    yi, yo, vi, vo = a["y_in"], a["y_out"], a["v_in"], a["v_out"]
    ok = np.isfinite(a["t"])
    assert ok.sum() > 5000
    fin = ok & np.isfinite(mu)
    scale = mu[fin] * (np.abs(yi[fin]) + np.abs(yo[fin])) + np.abs(vi[fin]) + np.abs(vo[fin])
    assert (np.abs(mu[fin] * (yo[fin] - yi[fin]) + (vo[fin] - vi[fin])) <= 1e-14 * scale).all()
    inf = ok & ~np.isfinite(mu)
    assert (yo[inf] == yi[inf]).all()
    rel = np.abs((vo - yo) + r2 * (vi - yi))[ok]
    assert (rel <= 1e-13 * (np.abs(vi) + np.abs(yi) + 1.0)[ok]).all()
    # and every run ended with a status of the table within its budgets
    assert set(np.unique(a["status"])) <= set(S.NAMES)


# ------------------------------------------------------------------ (d) the order w <= z <= u
def test_order_is_never_violated():
    """Dense sections (every 0.05, not a multiple of the wall period, so the section
    phase bookkeeping is exercised) of random runs: w <= z <= u to 1e-9 (positions
    are exact between events; snapping moves them by at most tol * speed)."""
    prm, z0, y0, u0, v0 = _random_points(80, 5)
    a = cornerbif.simulate(z0, y0, u0, v0, transient=0, record=600, section_period=0.05,
                              **prm, model="two_particle")
    w = prm["kappa"][:, None] + prm["beta"][:, None] * np.sin(prm["omega0"][:, None] * a["st"])
    assert np.isfinite(a["st"]).sum() > 20000
    assert np.nanmin(a["sz"] - w) > -1e-9
    assert np.nanmin(a["su"] - a["sz"]) > -1e-9
    wt = prm["kappa"][:, None] + prm["beta"][:, None] * np.sin(prm["omega0"][:, None] * a["t"])
    assert np.nanmin(a["u"] - wt) > -1e-9


def _replay(p, ic, a, t_end):
    """Slow check: rebuild both free flights from the recorded events (sorted by time;
    at equal times w-z before z-u, the documented policy) and sample the gaps densely.
    Valid for runs without sticking."""
    ev = [(t, 0, z, yo, 0.0) for t, z, yo in zip(a["wz_t"][0], a["wz_z"][0], a["wz_y_out"][0])
          if np.isfinite(t)]
    ev += [(t, 1, u, yo, vo) for t, u, yo, vo in zip(a["t"][0], a["u"][0], a["y_out"][0],
                                                       a["v_out"][0]) if np.isfinite(t)]
    ev.sort(key=lambda e: (e[0], e[1]))
    zr = (0.0, ic[0], ic[1])
    ur = (0.0, ic[2], ic[3])
    w1, w2 = p["omega1"], p["omega2"]

    def fl(ref, w, t):
        t0, x, v = ref
        return x * np.cos(w * (t - t0)) + v / w * np.sin(w * (t - t0))

    worst = np.inf
    t_prev = 0.0
    for t, kind, x, yo, vo in ev:
        if t > t_end:
            break
        ts = np.linspace(t_prev, t, max(3, int((t - t_prev) / 1e-3)))[1:-1]
        if ts.size:
            z = fl(zr, w1, ts)
            worst = min(worst, (z - _wall(p, ts)).min(), (fl(ur, w2, ts) - z).min())
        # the event happens where the replayed gap closes
        if kind == 0:
            assert abs(fl(zr, w1, t) - x) < 1e-8
            zr = (t, x, yo)
        else:
            assert abs(fl(ur, w2, t) - x) < 1e-8 and abs(fl(zr, w1, t) - x) < 1e-8
            zr = (t, x, yo)
            ur = (t, x, vo)
        t_prev = t
    return worst


@pytest.mark.parametrize("p", [dict(FIG19, omega0=1.9995),
                               dict(omega0=2.7, omega1=1.3, omega2=0.9, mu=5.0, r1=0.7, r2=0.6,
                                    kappa=0.2, beta=0.8)])
def test_no_impact_is_missed_against_a_dense_replay(p):
    """Between recorded events both replayed gaps stay >= 0 (to rounding) on a 1e-3 grid,
    and each event lies where its gap closes (1e-8): no impact was skipped.  The first
    scene is Fig. 19's complex regime, with z-u impacts within 1e-4 of w-z impacts."""
    ic = (3.0, 1.0, 6.0, -2.0)
    a = cornerbif.simulate(*ic, transient=0, record=500, **p, model="two_particle")
    assert a["status"][0] == S.OK
    worst = _replay(p, ic, a, np.nanmax(a["t"][0]))
    assert worst > -1e-9


# ------------------------------------------------------------------ (e) triple impacts
def _first_events(z0, y0, u0, v0, **kw):
    p = dict(FIG19, omega0=2.0)
    p.update(kw)
    return cornerbif.simulate(z0, y0, u0, v0, transient=0, record=3, max_events=2000, **p,
                              model="two_particle")


def test_exact_triple_impact_resolves_wz_then_zu():
    """w = z = u = 0 at t = 0 (kappa = 0), wall speed w' = 2, y = -1, v = -3 (both
    contacts closing).  Policy: law (5) first, y: -1 -> 1.8 * 2 + 0.8 = 4.4; then
    law (74) at the same time with y = 4.4, v = -3; z then leaves the wall
    (4.3867 > 2), so no third impact.  The z-u impact has offset 0 to w-z impact 0."""
    a = _first_events(0.0, -1.0, 0.0, -3.0)
    assert a["status"][0] == S.OK
    assert a["wz_t"][0, 0] == 0.0
    assert a["wz_y_in"][0, 0] == -1.0
    assert a["wz_y_out"][0, 0] == pytest.approx(4.4, abs=1e-15)
    assert a["t"][0, 0] == 0.0
    assert a["y_in"][0, 0] == a["wz_y_out"][0, 0]
    yo, vo = mass_ratio_impact(4.4, -3.0, 1000.0, 0.8)
    assert a["y_out"][0, 0] == pytest.approx(yo, abs=1e-14)
    assert a["v_out"][0, 0] == pytest.approx(vo, abs=1e-14)
    assert a["corner_offset"][0, 0] == 0.0 and a["corner"][0, 0] == 0
    # the next w-z impact is a later one (no duplicate at t = 0)
    assert a["wz_t"][0, 1] > 0.1


@pytest.mark.parametrize("z0, u0", [(0.0, np.nextafter(0.0, 1.0)),
                                    (np.nextafter(0.0, 1.0), np.nextafter(0.0, 1.0)),
                                    (np.nextafter(0.0, 1.0), 2 * np.nextafter(0.0, 1.0))])
def test_triple_impact_one_ulp_off_gives_the_same_outcome(z0, u0):
    """Gaps of one ulp close within tol of each other: the same documented sequence
    (w-z, then z-u at the same time) and the same velocities as the exact triple impact,
    deterministic from run to run."""
    ref = _first_events(0.0, -1.0, 0.0, -3.0)
    a = _first_events(z0, -1.0, u0, -3.0)
    b = _first_events(z0, -1.0, u0, -3.0)
    for k in a:
        if k != "symbols":
            np.testing.assert_array_equal(a[k], b[k])
    assert a["status"][0] == S.OK
    for k in ("t", "v_in", "v_out", "y_in", "y_out", "wz_t", "wz_y_in", "wz_y_out"):
        np.testing.assert_allclose(a[k][0, :3], ref[k][0, :3], atol=1e-12, rtol=0)


def test_constructed_midflight_triple_impact():
    """A triple point built backwards from t = 0.4 (z = u = w(0.4), y = w' - 1.5,
    v = y - 2): the kernel meets it as a near-simultaneous pair (rounding), takes
    the w-z impact first and uses its outgoing y in the z-u impact at the same time."""
    p = dict(FIG19, omega0=2.0)
    T = 0.4
    wT = math.sin(2 * T)
    wpT = 2 * math.cos(2 * T)
    yT, vT = wpT - 1.5, wpT - 3.5
    z0, y0 = K.harm(wT, yT, p["omega1"], -T)
    u0, v0 = K.harm(wT, vT, p["omega2"], -T)
    assert 0.0 <= z0 <= u0
    a = cornerbif.simulate(z0, y0, u0, v0, transient=0, record=3, max_events=2000, **p, model="two_particle")
    assert a["status"][0] == S.OK
    assert abs(a["wz_t"][0, 0] - T) < 1e-9 and abs(a["t"][0, 0] - T) < 1e-9
    assert a["t"][0, 0] == a["wz_t"][0, 0]
    assert a["y_in"][0, 0] == a["wz_y_out"][0, 0]
    assert a["wz_y_out"][0, 0] == pytest.approx(1.8 * wpT - 0.8 * yT, abs=1e-9)


# ------------------------------------------------------------------ (f) threads
def test_results_do_not_depend_on_the_thread_count():
    """The same batch with 1 and 2 threads gives bitwise-equal arrays."""
    prm, z0, y0, u0, v0 = _random_points(48, 23)
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        a = cornerbif.simulate(z0, y0, u0, v0, transient=20, record=40, **prm, model="two_particle")
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        b = cornerbif.simulate(z0, y0, u0, v0, transient=20, record=40, **prm, model="two_particle")
    finally:
        numba.set_num_threads(old)
    for k in a:
        if a[k].dtype == object:
            assert (a[k] == b[k]).all()
        else:
            np.testing.assert_array_equal(a[k], b[k])


# ------------------------------------------------------------------ (g) Fig. 19
def test_fig19_corner_bifurcation_near_omega_C():
    """Fig. 19 (mu = 1000, r1 = r2 = 0.8, omega1 = 1.001, omega2 = 1, kappa = 0, beta = 1):
    the paper reports simple dynamics for omega0 > omega_C = 1.99975 and a period-adding
    cascade below.  Measured here: the period-1 orbit 'b' (one z-u impact just after
    each w-z impact) for omega0 >= 1.99976, its offset shrinking linearly to 0 at
    omega0 = 1.9997525 (extrapolated; the paper's 1.99975 to its 5 decimals), and
    words b^k g below (k = 8 at 1.9997; k >= 10 at 1.99974, where several coexist)."""
    ws = np.array([1.9997, 1.99974, 1.99976, 1.99978, 1.9998, 1.99985])
    a = cornerbif.simulate(np.array([5.0, 3.0])[None], 0.0, np.array([8.0, 12.0])[None],
                              np.array([0.0, 4.0])[None], transient=6000, record=300,
                              omega0=ws[:, None], **FIG19, model="two_particle")
    assert (a["status"] == S.OK).all()
    assert (a["symbols"][0] == "bbbbbbbbg").all()        # the only attractor seen from 16 starts
    for word in a["symbols"][1]:                          # b^k g, k >= 10 (attractors coexist here)
        assert set(word[:-1]) == {"b"} and word[-1] == "g" and len(word) >= 11
    assert (a["period"][2:] == 1).all() and (a["symbols"][2:] == "b").all()
    off = a["corner_offset"][2:, 0, -1]
    assert (off > 0).all()
    slope, icpt = np.polyfit(ws[2:], off, 1)
    assert -icpt / slope == pytest.approx(1.99975, abs=5e-6)


# ------------------------------------------------------------------ statuses and contracts
def test_bad_starts_and_parameters_get_a_status_or_an_error():
    """Start below the wall or u below z: BELOW_OBSTACLE; NaN state: NONFINITE; NaN or
    out-of-range parameters are rejected by ``pack`` before any kernel runs."""
    kw = dict(FIG19, omega0=2.0)
    a = cornerbif.simulate([-0.1, 1.0, np.nan], 0.0, [1.0, 0.5, 1.0], 0.0, record=5, **kw,
                           model="two_particle")
    assert list(a["status"]) == [S.BELOW_OBSTACLE, S.BELOW_OBSTACLE, S.NONFINITE]
    for bad in (dict(mu=np.nan), dict(r1=1.5), dict(omega1=0.0), dict(mu=0.0)):
        with pytest.raises(ValueError):
            P.pack(dict(kw, **bad))


def test_chattering_ends_in_sticking_and_a_status():
    """kappa = 1, beta = 0.1, omega0 = 0.5, omega1 = omega2 = 1: N1 = w'' + w =
    1 + 0.075 sin(0.5 t) > 0, and N2 = N12 = N1 > 0 for all t, so both particles chatter down,
    stick (z on w, then u on z) and never leave: the run must end STUCK within its
    budgets, with the final section state on the wall (z = u = w, y = v = w')."""
    p = dict(omega0=0.5, omega1=1.0, omega2=1.0, mu=10.0, r1=0.5, r2=0.5, kappa=1.0, beta=0.1)
    a = cornerbif.simulate(2.0, 0.0, 3.0, 0.0, transient=0, record=1000, max_periods=200, **p,
                           model="two_particle")
    assert a["status"][0] == S.STUCK
    z, y, u, v = a["final"][0]
    t = 200 * 2 * math.pi / 0.5
    w = 1.0 + 0.1 * math.sin(0.5 * t)
    assert z == pytest.approx(w, abs=1e-9) and u == pytest.approx(w, abs=1e-9)
    assert y == pytest.approx(v, abs=1e-12)


def test_stuck_pair_is_released_where_the_contact_force_changes_sign():
    """omega1 = 1, omega2 = 2, mu = inf, wall out of reach (kappa = -10, beta = 0): u
    chatters onto z and sticks while lambda2 ~ (omega2^2 - omega1^2) z > 0, i.e. while
    z > 0, and leaves where z crosses 0 (module docstring, mode PAIR).  On sections every
    0.05: every stuck sample (u = z) has z > 0, and each stuck stretch ends within one
    sample step of z = 0 (the next sample has z < 0)."""
    p = dict(omega0=1.0, omega1=1.0, omega2=2.0, mu=math.inf, r1=0.8, r2=0.5, kappa=-10.0,
             beta=0.0)
    a = cornerbif.simulate(1.0, 0.0, 1.5, 0.0, transient=0, record=2000, max_periods=2000,
                              section_period=0.05, **p, model="two_particle")
    assert a["status"][0] in (S.OK, S.NO_IMPACT)       # NO_IMPACT: the time budget ran out
    su, sz = a["su"][0], a["sz"][0]
    stuck = su == sz
    assert stuck.sum() > 50
    assert sz[stuck].min() > 0.0
    ends = np.where(stuck[:-1] & ~stuck[1:])[0]
    assert ends.size >= 2
    assert (sz[ends + 1] < 0.0).all() and (sz[ends] < 0.05 * 1.0 + 1e-12).all()
    assert np.nanmin(su - sz) > -1e-12


def test_section_choice_does_not_change_the_impacts():
    """The section only observes: a section period of 0.37 (not a multiple of the wall
    period) gives the same z-u impacts as the default 2 pi/omega0, to 1e-9."""
    kw = dict(FIG19, omega0=1.9995)
    a = cornerbif.simulate(3.0, 1.0, 6.0, -2.0, transient=0, record=100, **kw, model="two_particle")
    b = cornerbif.simulate(3.0, 1.0, 6.0, -2.0, transient=0, record=100, section_period=0.37,
                              **kw, model="two_particle")
    assert np.abs(a["t"] - b["t"]).max() < 1e-9
    assert np.abs(a["v_out"] - b["v_out"]).max() < 1e-9


def test_kernels_compile_one_signature():
    """Each hot kernel compiled exactly one signature (no odd dtype slipped through)."""
    cornerbif.simulate(3.0, 1.0, 6.0, -2.0, record=5, omega0=2.0, model="two_particle")
    assert len(K.run_batch.signatures) == 1
    assert len(K.run_one.signatures) <= 1
