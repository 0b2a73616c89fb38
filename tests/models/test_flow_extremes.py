"""Numerical extremes of the flow kernel, each with its expected outcome stated: impacts a
hair from a corner event against extended precision, exactly at a corner and one ulp
either side, impacts closer than 1e-10, sticking and chattering against their closed
forms, long periods, energy on a fixed wall, huge parameters, and the properties of
every recorded impact."""

import math

import mpmath as mp
import naive
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cornerbif import simulate, theory
from cornerbif import status as S


def test_elastic_impacts_on_a_fixed_wall_conserve_energy():
    """r = 1, sigma = 0, a fixed wall (beta = 0, z = kappa): u^2 + v^2 is conserved by the
    flight (u'' = -u) and by law (5) (v -> -v); over 1e4 impacts it must stay to 1e-10."""
    res = simulate([3.0, 7.5], [1.0, -4.0], transient=0, record=10000, obstacle="rectified_sine",
                   omega=2.0, kappa=-1.0, beta=0.0, r=1.0)
    assert (res["status"] == S.OK).all()
    e0 = np.array([3.0 ** 2 + 1.0, 7.5 ** 2 + 16.0])
    e = res["u"] ** 2 + res["v_in"] ** 2
    assert np.abs(e / e0[:, None] - 1).max() < 1e-10
    assert np.allclose(res["v_out"], -res["v_in"], rtol=0, atol=1e-12)


def test_huge_kappa_below_means_no_impact_and_huge_beta_runs():
    """kappa far below the flight (amplitude ~ 5) never meets the particle: NO_IMPACT within
    the time budget; a huge beta still ends with a status."""
    res = simulate(3.0, 4.0, transient=10, record=10, omega=2.0, kappa=-1e6, r=0.8,
                   max_periods=200)
    assert res["status"][0] == S.NO_IMPACT
    res = simulate(2e6, 0.0, transient=10, record=10, omega=2.0, kappa=0.0, beta=1e6, r=0.8,
                   escape=1e12, max_periods=500)
    assert res["status"][0] in (S.OK, S.STUCK, S.NO_IMPACT, S.MAX_EVENTS)


@pytest.mark.parametrize("d", [1e-9, -1e-9])
def test_omega_and_kappa_a_hair_from_the_corner_event(d):
    """omega - 2 = kappa = +-1e-9: the single-impact orbit u = b|sin| of eq (6) hits within
    ~1e-9 of the corners, on the side eq (10) predicts, and the flow matches the slow
    reference (tests/naive.py, brentq to 1e-15) on its first impacts."""
    w, k = 2.0 + d, d
    res = simulate(18.0, 0.0, transient=0, record=6, omega=w, kappa=k, r=0.8)
    ref = naive.naive_impacts("rectified_sine", w, k, 1.0, 0.8, 18.0, 0.0, 6)
    assert np.allclose(res["t"][0], ref[:, 0], atol=1e-11, rtol=0)
    off = res["corner_offset"][0]
    assert np.abs(off).max() < 1e-6


@pytest.mark.slow
@settings(max_examples=60, deadline=None)
@given(w=st.floats(0.6, 4.0), kap=st.floats(-0.5, 0.5), r=st.floats(0.05, 1.0),
       u0=st.floats(0.0, 15.0), v0=st.floats(-15.0, 15.0),
       obstacle=st.sampled_from(["rectified_sine", "sine", "triangle"]))
def test_properties_of_every_recorded_impact(w, kap, r, u0, v0, obstacle):
    """Random parameters and states: impact times increase, every impact obeys law (5) with
    the slope of its side of the corner to rounding, the impact lies on the obstacle, and the
    section states lie on or above it."""
    u0 = max(u0, kap) + 0.01
    res = simulate(u0, v0, transient=0, record=40, obstacle=obstacle, omega=w, kappa=kap, r=r,
                   max_periods=400, escape=1e9)
    t = res["t"][0]
    ok = np.isfinite(t)
    t = t[ok]
    # non-decreasing (the kernel orders events by piece and local time; absolute times are
    # derived from them and may differ by rounding at a corner: 1e-15 relative)
    assert (np.diff(t) >= -1e-15 * np.maximum(1.0, np.abs(t[1:]))).all()
    # law (5) with the one-sided slope on the impact's side
    for i in np.flatnonzero(ok):
        ti = res["t"][0, i]
        off = res["corner_offset"][0, i]
        # the one-sided slope on the impact's side of its nearest corner
        if obstacle == "sine":
            zp = naive.z_slope(obstacle, ti, w, kap, 1.0, w, w)
        elif obstacle == "rectified_sine":
            zp = math.copysign(w * math.cos(w * abs(off)), 1.0 if off >= 0 else -1.0)
        else:
            zp = w if off >= 0 else -w
        z = naive.z_obstacle(obstacle, ti, w, kap, 1.0, w, w)
        vin, vout = res["v_in"][0, i], res["v_out"][0, i]
        scale = 1.0 + abs(vin) + abs(zp)
        if off == 0.0 and obstacle != "sine":
            # exactly at the corner z' has two values: the law holds with one of them (the
            # kernel takes the piece it found the impact on; the offset's zero has no side).
            # Found by this test: the triangle at omega = 4, r = 0.25 from (0.01, 0), whose
            # impacts converge onto the corner and reach it exactly at the 23rd
            assert min(abs(vout - ((1 + r) * s - r * vin)) for s in (zp, -zp)) < 1e-9 * scale
            assert abs(res["u"][0, i] - z) < 1e-9 * scale
            continue
        assert abs(vout - ((1 + r) * zp - r * vin)) < 1e-9 * scale
        assert abs(res["u"][0, i] - z) < 1e-9 * scale
    su = res["su"][0]
    # sections at t = nT (or the paper's phase): u >= z there (z at a corner is kappa)
    fin = np.isfinite(su)
    assert (su[fin] >= kap - 1e-9).all()


@pytest.mark.parametrize("d", [1e-9, -1e-9])
def test_corner_event_against_extended_precision(d):
    """omega - 2 = kappa = d = +-1e-9, start (u, v) = (18, 0) at t = 0: the first impact lies
    within ~1e-9 of the corner t1 = pi/omega.  Its time (40-digit mpmath root of
    18 cos t = kappa + |sin(omega t)| on the piece where the root lies) and its side of the
    corner must come out of the kernel to 1e-13."""
    mp.mp.dps = 40
    w, k = mp.mpf(2) + mp.mpf(d), mp.mpf(d)
    t1 = mp.pi / w

    def g_before(t):
        return 18 * mp.cos(t) - k - mp.sin(w * t)          # piece [0, t1]

    def g_after(t):
        return 18 * mp.cos(t) - k + mp.sin(w * t)          # piece [t1, 2 t1]: |sin| = -sin

    if g_before(t1) <= 0:                                      # the root is before the corner
        root = mp.findroot(g_before, t1)
    else:
        root = mp.findroot(g_after, t1)
    res = simulate(18.0, 0.0, transient=0, record=2, omega=2.0 + d, kappa=d, r=0.8)
    assert abs(res["t"][0, 0] - float(root)) < 1e-13
    off = float(root - t1)
    assert abs(off) < 2e-9
    assert np.sign(res["corner_offset"][0, 0]) == np.sign(off)


@pytest.mark.parametrize("shift", [0, 1, -1])
def test_impact_exactly_at_a_corner_and_one_ulp_either_side(shift):
    """A flight built to meet the obstacle exactly at the corner t1 (and one ulp either side):
    one event, never two; an impact at offset >= 0 uses the slope after the corner (+omega),
    one at offset < 0 the slope before it (-omega), by law (5)."""
    w, kap, r = 1.999, 0.0, 0.8
    t1 = math.pi / w
    ti = t1
    for _ in range(abs(shift)):
        ti = math.nextafter(ti, math.inf if shift > 0 else -math.inf)
    u0, v0 = naive.free_flight(0.0, ti, kap, -12.0)
    res = simulate(u0, v0, transient=0, record=3, omega=w, kappa=kap, r=r)
    t = res["t"][0]
    assert abs(t[0] - t1) < 1e-12
    assert t[1] - t[0] > 0.5                     # no second event at the corner
    off = res["corner_offset"][0, 0]
    slope = w if off >= 0 else -w
    assert res["v_out"][0, 0] == pytest.approx((1 + r) * slope + r * 12.0, abs=1e-9)
    if shift == 0:
        assert off >= 0                          # exactly at the corner: the beta rule


def test_two_impacts_closer_than_1e_minus_10():
    """An impact 1e-11 before the corner at v- = -3 leaves at v+ = (1 + r)(-2) + 3r = -1.2,
    slower than the obstacle after the corner (+2): a second impact follows ~2.5e-12 after
    the corner (linear motion over 1e-11: gap (-1.2 + 2) 1e-11 closed at relative speed 3.2).
    Both are found, in order, as an alpha pair with v+ = (1 + r) 2 + 1.2 r = 4.56."""
    w, kap, r = 2.0, 0.0, 0.8
    t1 = math.pi / w
    ti = t1 - 1e-11
    zi = naive.z_obstacle("rectified_sine", ti, w, kap)
    u0, v0 = naive.free_flight(0.0, ti, zi, -3.0)
    res = simulate(u0, v0, transient=0, record=4, omega=w, kappa=kap, r=r, chatter=1e-12)
    t, off = res["t"][0], res["corner_offset"][0]
    assert off[0] == pytest.approx(-1e-11, abs=1e-13)
    assert 0 < t[1] - t[0] < 1e-10
    assert off[1] == pytest.approx(0.8e-11 / 3.2, abs=2e-13)
    assert res["v_out"][0, 0] == pytest.approx(-1.2, abs=1e-9)
    assert res["v_out"][0, 1] == pytest.approx(4.56, abs=1e-9)


def test_r0_sticks_at_once_and_is_kicked_at_every_corner():
    """r = 0, slow obstacle (omega = 0.5, kappa = 0.05: contact force N = kappa + beta (1 - omega^2) sin > 0):
    after the first impact the particle sticks at once; from then on every impact is the
    corner kick of law (5): offset 0, v- = -beta omega, v+ = +beta omega."""
    res = simulate(3.0, 0.0, transient=0, record=8, omega=0.5, kappa=0.05, r=0.0)
    assert res["status"][0] == S.OK
    assert np.allclose(res["corner_offset"][0, 1:], 0.0, atol=0)
    assert np.allclose(res["v_in"][0, 1:], -0.5, atol=1e-12)
    assert np.allclose(res["v_out"][0, 1:], 0.5, atol=1e-12)


@pytest.mark.parametrize("r", [0.3, 0.5, 0.8, 0.95])
def test_chattering_converges_to_the_predicted_accumulation_time(r):
    """A flat wall z = kappa = 0.5 (beta = 0) with u'' = -u: a flight leaving the wall at
    relative speed w returns after 2 atan(w/kappa) at speed w (energy), so the impact times of
    the chattering sequence are t_n = t_0 + sum_{i<n} 2 atan(r^(i+1) w_0/kappa) and accumulate
    at t_acc = t_0 + sum_i 2 atan(r^(i+1) w_0 / kappa).  The recorded impacts follow that
    sequence to 1e-9 (up to 400 impacts, each located to run.tol = 1e-12); the kernel sums the
    rest once the relative speed is below run.chatter = 1e-9, a tail of at most
    2 chatter/(kappa (1 - r)); then the particle sticks (N = kappa > 0) and the run ends STUCK."""
    kap = 0.5
    res = simulate(1.0, 0.0, transient=0, record=600, omega=1.0, kappa=kap, beta=0.0, r=r,
                   chatter=1e-9, max_periods=60)
    assert res["status"][0] == S.STUCK
    t = res["t"][0]
    m = int(np.isfinite(t).sum())
    assert m >= 10
    w0 = -res["v_in"][0, 0]                                  # first arrival speed
    i = np.arange(1, 4000)
    steps = 2 * np.arctan(r ** i * w0 / kap)
    pred = t[0] + np.concatenate([[0.0], np.cumsum(steps)])
    assert np.allclose(t[:m], pred[:m], atol=1e-9, rtol=0)
    t_acc = t[0] + steps.sum()
    assert t[m - 1] <= t_acc + 1e-9
    assert t_acc - t[m - 1] < 2 * 1e-9 / (kap * (1 - r)) * 1.05 + 1e-9    # the summed tail


def test_release_from_sticking_at_the_analytic_time():
    """omega = 0.5, kappa = -0.3, beta = 1, r = 0: the particle lands (t ~ 1.4) where the contact
    force N = kappa + beta (1 - omega^2) sin(omega t) > 0 and sticks; it is released where N
    falls to 0, omega t_rel = pi - asin(-kappa/(beta (1 - omega^2))).  Its next impact must be
    the one of a free flight from (z, z')(t_rel): the slow reference from that state agrees
    to 1e-9."""
    w, kap = 0.5, -0.3
    t_rel = (math.pi - math.asin(-kap / (1 - w * w))) / w
    res = simulate(2.0, 0.0, transient=0, record=3, omega=w, kappa=kap, r=0.0)
    assert res["t"][0, 0] < t_rel
    z = kap + math.sin(w * t_rel)
    zp = w * math.cos(w * t_rel)
    ref = naive.naive_impacts("rectified_sine", w, kap, 1.0, 0.0, z + 1e-12, zp, 1, t0=t_rel)
    assert res["t"][0, 1] == pytest.approx(ref[0, 0], abs=1e-8)
    assert res["v_in"][0, 1] == pytest.approx(ref[0, 2], abs=1e-7)


def test_periods_of_several_hundred_are_identified():
    """r = 0.95 just above kappa_C: N ~ log(delta)/log(r) grows to hundreds (section 5.4); the
    flow's cycle is beta^N gamma with N >= 200, and its period N + 1 is identified."""
    w, r = 1.999, 0.95
    kc = theory.kappa_C(w, r)
    res = simulate(theory.resonant_amplitude(r) * 1.0, 0.0, transient=6000, record=1200,
                   omega=w, kappa=kc + 1e-9, r=r)
    word = res["symbols"][0]
    assert word == "b" * (len(word) - 1) + "g", word[:20]
    assert len(word) - 1 >= 200
    assert res["period"][0] == len(word)
