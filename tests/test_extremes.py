"""Numerical extremes and properties of single impacts (reliability issue)."""

import math

import naive
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cornerbif import simulate
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
        assert abs(vout - ((1 + r) * zp - r * vin)) < 1e-9 * scale
        assert abs(res["u"][0, i] - z) < 1e-9 * scale
    su = res["su"][0]
    # sections at t = nT (or the paper's phase): u >= z there (z at a corner is kappa)
    fin = np.isfinite(su)
    assert (su[fin] >= kap - 1e-9).all()
