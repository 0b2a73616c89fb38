"""The flow model against the paper's closed forms and the slow reference (tests/naive.py)."""

import math

import naive
import numba
import numpy as np
import pytest

from cornerbif import simulate, theory
from cornerbif import status as S

R = 0.8


def test_smooth_wall_resonant_orbit_eq6():
    """Smooth wall sin(2t), r = 0.8: every start converges to u = b|sin t| with
    b = 2(1 + r)/(1 - r) = 18 (eq 6): impact velocities -18 -> +18 to 1e-9."""
    rng = np.random.default_rng(3)
    n = 16
    res = simulate(rng.uniform(0.05, 20, n), rng.uniform(-20, 20, n), transient=500, record=20,
                   obstacle="sine", omega=2.0, kappa=0.0, beta=1.0, r=R)
    b = theory.resonant_amplitude(R)
    assert b == pytest.approx(18.0)
    assert (res["status"] == S.OK).all()
    assert np.abs(res["v_in"] + b).max() < 1e-9
    assert np.abs(res["v_out"] - b).max() < 1e-9
    # impacts at t = n pi where z = 0: u = 0 and period one (one impact per forcing period)
    assert np.abs(res["u"]).max() < 1e-9
    assert (res["period"] == 1).all()


def test_single_impact_orbit_satisfies_periodicity_eq10():
    """Below kappa_C the single-impact orbit of period T = 2 pi/omega satisfies the exact form of
    eq (10): z(tau) = (1 + r)/(1 - r) z'(tau) cot(T/2), with the true obstacle height and slope."""
    w = 1.999
    res = simulate([5.0, 12.0, 2.0], [3.0, -4.0, 9.0], transient=600, record=10,
                   omega=w, kappa=-0.02, r=R)
    assert (res["symbols"] == "b").all() and (res["period"] == 1).all()
    T = 2 * math.pi / w
    off = res["corner_offset"][:, -1]
    z = -0.02 + np.sin(w * off)
    zp = w * np.cos(w * off)
    assert np.allclose(res["u"][:, -1], z, atol=1e-13)
    assert np.allclose(z, (1 + R) / (1 - R) * zp / math.tan(T / 2), atol=1e-11)
    # successive impacts one period T apart
    assert np.allclose(np.diff(res["t"], axis=1), T, atol=1e-9)


def _is_single_impact(kappa, w=1.999):
    res = simulate([5.0, 15.0], [0.0, 10.0], transient=1500, record=120, omega=w, kappa=kappa, r=R)
    return bool(((res["period"] == 1) & (res["symbols"] == "b")).all())


@pytest.mark.slow
def test_kappa_C_located_by_bisection_on_the_flow():
    """omega = 1.999, r = 0.8: the single-impact orbit stops at kappa_C = -0.014137 (eq 11,
    section 3.3.3).  Bisection on kappa with the full flow as judge, not the formula."""
    lo, hi = -0.0145, -0.0138
    assert _is_single_impact(lo) and not _is_single_impact(hi)
    for _ in range(20):
        mid = 0.5 * (lo + hi)
        if _is_single_impact(mid):
            lo = mid
        else:
            hi = mid
    kc = theory.kappa_C(1.999, R)
    assert kc == pytest.approx(-0.014137, abs=5e-7)   # the paper's printed value
    assert abs(lo - kc) < 2e-9, (lo, kc)


@pytest.mark.parametrize("kappa, word", [
    (-0.014, "b" * 24 + "g"),                      # section 3.3.3: the period-25 orbit of Fig. 6(d)
    (-0.0127, "b" * 11 + "g"),                     # Fig. 17(a): beta^11 gamma
    (-0.0128, "b" * 12 + "g" + "b" * 11 + "g"),    # Fig. 17(b): beta^11 gamma beta^12 gamma
])
def test_period_adding_words(kappa, word):
    res = simulate([5.0, 11.0, 17.0], [1.0, -6.0, 12.0], transient=1500, record=150,
                   omega=1.999, kappa=kappa, r=R)
    assert (res["status"] == S.OK).all()
    assert list(res["symbols"]) == [word] * 3
    assert (res["period"] == len(word)).all()
    assert (res["impacts_per_cycle"] == len(word)).all()


def test_hysteresis_two_coexisting_period_one_orbits():
    """omega = 2.001 > 2 and kappa_CC < kappa < kappa_C: the single-impact (beta) and the
    double-impact (alpha) period-one orbits coexist (eqs 13, 19; Fig. 7b).  Starts at the
    section values a of eqs (12) and (16) (b = 0) land on each."""
    w, kap = 2.001, 0.008
    assert theory.kappa_CC(w, R) < kap < theory.kappa_C(w, R)
    s = math.sin(math.pi / w)
    a_single = w * (1 + R) / (1 - R) / s          # eq (12)
    a_double = w * (1 + R) ** 2 / (1 + R * R) / s  # eq (16)
    res = simulate([a_single, a_double], [0.0, 0.0], transient=1000, record=40, omega=w,
                   kappa=kap, r=R)
    assert list(res["symbols"]) == ["b", "a"]
    # outside the overlap only one of them exists
    below = simulate([a_single, a_double], [0.0, 0.0], transient=1000, record=40, omega=w,
                     kappa=0.0, r=R)
    assert list(below["symbols"]) == ["b", "b"]
    above = simulate([a_single, a_double], [0.0, 0.0], transient=1000, record=40, omega=w,
                     kappa=0.02, r=R)
    assert list(above["symbols"]) == ["a", "a"]


def _flight_back(t_impact, z_imp, v_imp, t0=0.0):
    """State at t0 of the free flight u'' + u = 0 that reaches (z_imp, v_imp) at t_impact."""
    return naive.free_flight(t0, t_impact, z_imp, v_imp)


@pytest.mark.parametrize("delta", [3e-6, 1e-6, -1e-6, -3e-6, 1e-8, -1e-8])
def test_impact_near_corner_lands_on_the_correct_side(delta):
    """An impact delta from the corner t1 = pi/omega is found at offset delta (to 1e-11),
    on the side of delta, with the slope of that side in law (5)."""
    w, kap = 1.999, 0.0
    t1 = math.pi / w
    ti = t1 + delta
    zi = naive.z_obstacle("rectified_sine", ti, w, kap)
    u0, v0 = _flight_back(ti, zi, -12.0)
    gmin, _ = naive.naive_gap_min("rectified_sine", w, kap, 1.0, u0, v0, 0.0, ti - 1e-4)
    assert gmin > 0
    res = simulate(u0, v0, transient=0, record=3, omega=w, kappa=kap, r=R)
    assert res["corner_offset"][0, 0] == pytest.approx(delta, abs=1e-11)
    slope = w if delta > 0 else -w
    assert res["v_out"][0, 0] == pytest.approx((1 + R) * slope + R * 12.0, abs=1e-9)


@pytest.mark.parametrize("eps", [1e-3, 1e-5, 1e-7, 1e-9, 1e-12, -1e-12, -1e-9, -1e-7, -1e-5, -1e-3])
def test_grazing_family_matches_exhaustive_search(eps):
    """A flight whose lowest point u = -R touches the top of an obstacle hump (z = kappa + beta)
    with a gap of eps: a miss for eps > 0, an impact for eps < 0.  With kappa = -5 the flight
    u = R cos(t - psi) can meet the obstacle only near its lowest points, so the first impact
    (if any) is the graze; the exhaustive search of tests/naive.py agrees."""
    w, kap, beta = 1.999, -5.0, 1.0
    tg = 1.5 * math.pi / w                  # top of the second hump
    R_ = -(kap + beta + eps)                # lowest point -R = kappa + beta + eps
    psi = tg - math.pi
    u0, v0 = R_ * math.cos(psi), R_ * math.sin(psi)
    res = simulate(u0, v0, transient=0, record=3, omega=w, kappa=kap, beta=beta, r=R,
                   chatter=1e-12, max_periods=200)
    gmin, tmin = naive.naive_gap_min("rectified_sine", w, kap, beta, u0, v0, 0.0, tg + 1.0)
    assert gmin == pytest.approx(eps, abs=1e-14)
    if eps > 0:
        # no impact near the tangency: the first impact, if any, is a full period later
        assert not (np.abs(res["t"][0] - tg) < 1.0).any()
        if abs(eps) >= 1e-9:
            ref = naive.naive_impacts("rectified_sine", w, kap, beta, R, u0, v0, 1, dt=2e-4,
                                      t_max=tg + 2.0)
            assert len(ref) == 0
    else:
        depth = math.sqrt(2 * -eps / (1 + beta * w * w))   # half-width of the dip below z
        assert abs(res["t"][0, 0] - tg) <= depth + 1e-9
        if abs(eps) >= 1e-9:
            ref = naive.naive_impacts("rectified_sine", w, kap, beta, R, u0, v0, 1, dt=2e-4)
            assert res["t"][0, 0] == pytest.approx(ref[0, 0], abs=1e-9)


@pytest.mark.parametrize("obstacle", ["rectified_sine", "sine", "triangle"])
def test_random_flights_match_exhaustive_search(obstacle):
    """Random parameters and starts: the first 15 impacts agree with tests/naive.py to 1e-8."""
    rng = np.random.default_rng({"rectified_sine": 1, "sine": 2, "triangle": 3}[obstacle])
    for _ in range(8):
        w = rng.uniform(1.5, 2.5)
        kap = rng.uniform(-0.05, 0.05)
        u0 = rng.uniform(max(kap, 0) + 0.01, 20)
        v0 = rng.uniform(-20, 20)
        res = simulate(u0, v0, transient=0, record=15, obstacle=obstacle, omega=w, kappa=kap,
                       r=R, chatter=1e-12)
        ref = naive.naive_impacts(obstacle, w, kap, 1.0, R, u0, v0, 15, theta1=w, theta2=w)
        m = len(ref)
        assert m >= 5
        assert np.allclose(res["t"][0, :m], ref[:, 0], atol=1e-8, rtol=0), (w, kap, u0, v0)


def test_damped_forced_flight_matches_reference():
    """sigma > 0 and harmonic forcing (eq 4) in all three damping regimes."""
    for sigma, k in ((0.1, 1.0), (1.0, 1.0), (2.0, 1.0)):
        res = simulate(6.0, 1.0, transient=0, record=6, obstacle="sine", omega=1.7, kappa=-0.5,
                       r=0.9, sigma=sigma, k=k, F=0.7, Omega=1.3, phi=0.2, chatter=1e-12)
        ref = naive.naive_impacts("sine", 1.7, -0.5, 1.0, 0.9, 6.0, 1.0, 6, sigma=sigma, k=k,
                                  F=0.7, Omega=1.3, phi=0.2)
        m = len(ref)
        assert m >= 1
        assert np.allclose(res["t"][0, :m], ref[:, 0], atol=1e-8), (sigma, k)


def test_start_below_obstacle_is_a_status():
    res = simulate(-1.0, 0.0, transient=0, record=3, omega=2.0, kappa=0.0)
    assert res["status"][0] == S.BELOW_OBSTACLE


@pytest.mark.parametrize("r", [0.0, 1.0, 1 - 1e-9, 0.3, 0.95])
def test_extreme_restitution_ends_with_a_status(r):
    """r = 0 sticks at once, r = 1 may pump energy: every run ends with a status, in bounded work."""
    rng = np.random.default_rng(5)
    res = simulate(rng.uniform(0.1, 20, 8), rng.uniform(-20, 20, 8), transient=200, record=50,
                   omega=np.linspace(0.5, 3.0, 8), kappa=0.0, r=r, max_periods=2000)
    assert set(np.unique(res["status"])) <= {S.OK, S.STUCK, S.ESCAPED, S.NO_IMPACT, S.MAX_EVENTS}


def test_chattering_ends_in_bounded_work():
    """Slow obstacle (omega = 0.5 < 1): the particle chatters and sticks on every hump;
    the sequences are summed and the runs complete."""
    res = simulate(np.linspace(0.5, 5, 6), np.zeros(6), transient=100, record=50, omega=0.5,
                   kappa=0.0, r=0.5)
    assert (res["status"] == S.OK).all()
    # the sticking phases end in corner kicks at the corners: impacts at offset 0
    assert np.isclose(res["corner_offset"], 0.0, atol=1e-12).any()


def test_results_identical_with_one_and_two_threads():
    rng = np.random.default_rng(11)
    n = 64
    args = (rng.uniform(0.1, 20, n), rng.uniform(-20, 20, n))
    kw = dict(transient=100, record=30, omega=np.linspace(1.9, 2.1, n), kappa=-0.005, r=R)
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        a = simulate(*args, **kw)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        b = simulate(*args, **kw)
    finally:
        numba.set_num_threads(old)
    for k in ("t", "u", "v_in", "v_out", "corner_offset", "su", "sv", "status", "period"):
        assert np.array_equal(a[k], b[k], equal_nan=True), k
    assert (a["symbols"] == b["symbols"]).all()


def test_simulate_checks_every_element_of_an_array_parameter():
    """simulate() broadcasts arrays of parameters; each value is validated as a scene's would
    be (r in [0, 1]; no undamped exact resonance F != 0, sigma = 0, Omega = k of eq 4), not
    only the first."""
    from cornerbif import simulate
    from cornerbif.config import SceneError
    with pytest.raises(SceneError, match="system.r: 1.5"):
        simulate(u0=[5.0, 5.0], v0=[1.0, 1.0], transient=2, record=2, omega=1.999, kappa=-2.0,
                 r=[0.5, 1.5])
    with pytest.raises(SceneError, match="resonance"):
        simulate(u0=[5.0, 5.0], v0=[1.0, 1.0], transient=2, record=2, omega=1.999, kappa=-2.0,
                 F=0.5, Omega=[0.9, 1.0])
