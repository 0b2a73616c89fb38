"""Tests of the section 3.3-5 closed forms in cornerbif.theory.

Each test names the equation its expected value comes from.  Where the printed
equation is wrong (see "Discrepancies with the printed equations" in
cornerbif.models.map2d.maps), the corrected form is tested and the printed one is shown
to disagree with the independent check.
"""

import math

import numpy as np
import pytest
from naive import free_flight, naive_impacts

from cornerbif import theory as th

W1, R = -0.001, 0.8
PARAMS = [(-0.001, -0.0127, 0.8), (-0.001, 0.0, 0.8), (0.02, -0.01, 0.5), (-0.03, 0.02, 0.3),
          (0.0, 0.0, 0.9)]


def flow_map(a, b, omega, kappa, r, dt=1e-4):
    """Exact Poincare map (u(0), u'(0)) -> (u(T), u'(T)), T = 2 pi/omega (reference simulator)."""
    T = 2 * math.pi / omega
    imp = naive_impacts("rectified_sine", omega, kappa, 1.0, r, a, b, 20, t0=0.0, dt=dt, t_max=T)
    imp = imp[imp[:, 0] < T] if len(imp) else imp
    if len(imp) == 0:
        return free_flight(T, 0.0, a, b), 0
    t, u, _vin, vout = imp[-1]
    return free_flight(T, t, u, vout), len(imp)


# ---------------------------------------------------------------------------
# maps and fixed points, eqs (57)-(65)
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("w1, k1, r", PARAMS)
@pytest.mark.parametrize("name", ["alpha", "beta", "gamma"])
def test_fixed_point_closed_forms_equal_eq61(name, w1, k1, r):
    # (61): x* = (I - Q)^{-1} P by np.linalg.solve, against the closed forms (63)-(65)
    Q, P = th.map_matrices(name, w1, k1, r)
    want = np.linalg.solve(np.eye(2) - Q, P)
    got = th.fixed_point(name, w1, k1, r)
    np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-15)
    a_star = {"alpha": 2 * (1 + r) ** 2 / (1 + r * r), "beta": 2 * (1 + r) / (1 - r),
              "gamma": -2 * (1 + r) / (1 - r)}[name]
    assert got[0] == pytest.approx(a_star, rel=1e-14)
    assert th.kappa_dot(name, w1, r) == pytest.approx(math.pi * w1 * a_star / 4, rel=1e-14)  # (62)


def test_printed_P_alpha_is_not_the_fixed_point_of_eq63():
    # The printed (58) gives a* = 2 (1+r^2)/(1+r^2) = 2, not (63) 2(1+r)^2/(1+r^2) = 3.9512 (r=0.8)
    Q, P = th.map_matrices("alpha", W1, 0.0, R, variant="printed")
    assert np.linalg.solve(np.eye(2) - Q, P)[0] == pytest.approx(2.0)
    assert th.fixed_point("alpha", W1, 0.0, R)[0] == pytest.approx(2 * 1.8 ** 2 / 1.64)
    Qd, _ = th.map_matrices("alpha", W1, 0.0, R)
    np.testing.assert_array_equal(Q, Qd)  # Q_alpha (57) agrees; only P_alpha differs


def test_local_maps_agree_with_the_flow_and_printed_P_alpha_does_not():
    # Leading-order check of (34)-(35), (37)-(38), (52)-(53) against the reference
    # simulator at eps = 1e-3: omega = 2 - eps, kappa = -3 eps, x = (a0, b1), u'(0) = eps b1.
    eps, w1, k1 = 1e-3, -1.0, -3.0
    cases = [("alpha", 5.0, -5.0, 2), ("alpha", 4.0, -6.0, 2), ("beta", 3.0, 1.0, 1),
             ("gamma", 9.0, -2.0, 1)]
    for name, a0, b1, n_imp in cases:
        (A, B), n = flow_map(a0, eps * b1, 2 + eps * w1, eps * k1, R)
        assert n == n_imp
        Q, P = th.map_matrices(name, w1, k1, R)
        lin = Q @ [a0, b1] + P
        assert abs(A - lin[0]) < 1e-2 and abs(B / eps - lin[1]) < 1e-2   # O(eps) apart (measured <= 5.7e-3)
        if name == "alpha":
            Qp, Pp = th.map_matrices(name, w1, k1, R, variant="printed")
            lin_p = Qp @ [a0, b1] + Pp
            assert abs(A - lin_p[0]) > 3.0 and abs(B / eps - lin_p[1]) > 2.5  # O(1) apart


@pytest.mark.parametrize("w1, k1, r", PARAMS)
def test_compatibility_quantities_section_5_2(w1, k1, r):
    # c_beta = 2/(1-r)(kappa_beta - kappa1), c_alpha = 2/(1+r^2)(kappa_alpha - kappa1):
    # direct C x* - kappa1 agrees (section 5.2)
    assert th.c_beta(w1, k1, r) == pytest.approx(th.compatibility("beta", w1, k1, r), abs=1e-15)
    assert th.c_alpha(w1, k1, r) == pytest.approx(th.compatibility("alpha", w1, k1, r), abs=1e-15)


def test_corner_lines_linearise_eqs_11_and_17():
    # (68)-(69): theta_beta omega1, theta_alpha omega1; at omega = 1.999, r = 0.8 they are
    # -0.0141372 and -0.0031033, the paper's kappa_C = -0.014137, kappa_CC = -0.003103
    kb, ka = th.corner_lines(W1, R)
    assert kb == pytest.approx(-0.014137, abs=5e-7) and ka == pytest.approx(-0.003103, abs=5e-7)
    assert kb == pytest.approx(th.kappa_dot("beta", W1, R), rel=1e-15)
    assert ka == pytest.approx(th.kappa_dot("alpha", W1, R), rel=1e-15)
    for w1 in (1e-4, -1e-4):
        assert th.kappa_C(2 + w1, R) / th.corner_lines(w1, R)[0] == pytest.approx(1, abs=1e-3)
        assert th.kappa_CC(2 + w1, R) / th.corner_lines(w1, R)[1] == pytest.approx(1, abs=1e-3)


def test_homoclinic_images_section_5_4():
    # at kappa1 = kappa_beta: x_beta* = (2(1+r)/(1-r), 0) on Sigma_1;
    # gamma image: x** = (2(1+r)(2r-1)/(1-r), -pi omega1 (1+r)) (printed), and
    # C x** - kappa_beta = -2 pi omega1 (1+r)  (printed: (pi omega1/2)(1+r)(r^2+r-2)/(1-r))
    kb = th.kappa_dot("beta", W1, R)
    xs = th.fixed_point("beta", W1, kb, R)
    assert xs[1] == pytest.approx(0, abs=1e-18)
    Q, P = th.map_matrices("gamma", W1, kb, R)
    x2 = Q @ xs + P
    np.testing.assert_allclose(x2, [2 * 1.8 * 0.6 / 0.2, -math.pi * W1 * 1.8], rtol=1e-12)
    assert math.pi * W1 / 4 * x2[0] + x2[1] - kb == pytest.approx(-2 * math.pi * W1 * 1.8, rel=1e-10)
    # alpha image with the derived (52)-(53): (2(1+r)(1-2r^2)/(1-r), -r^2 pi omega1 (1+r)/(1-r)),
    # C x** - kappa_beta = -2 pi omega1 r^2 (1+r)/(1-r)  (r = 0.5, alpha case r < phi)
    r = 0.5
    kb = th.kappa_dot("beta", W1, r)
    xs = th.fixed_point("beta", W1, kb, r)
    Q, P = th.map_matrices("alpha", W1, kb, r)
    x2 = Q @ xs + P
    np.testing.assert_allclose(x2, [2 * 1.5 * 0.5 / 0.5, -0.25 * math.pi * W1 * 1.5 / 0.5], rtol=1e-12)
    assert (math.pi * W1 / 4 * x2[0] + x2[1] - kb
            == pytest.approx(-2 * math.pi * W1 * 0.25 * 1.5 / 0.5, rel=1e-10))


def test_trapping_interval_section_5_4():
    # kappa1 = kappa_beta + delta: beta maps (a_beta*, delta) on Sigma_1 to (a_beta*, -delta)
    delta = 1e-3
    k1 = th.kappa_dot("beta", W1, R) + delta
    a = th.fixed_point("beta", W1, k1, R)[0]
    Q, P = th.map_matrices("beta", W1, k1, R)
    np.testing.assert_allclose(Q @ [a, delta] + P, [a, -delta], rtol=1e-12, atol=1e-16)


# ---------------------------------------------------------------------------
# section 3.3: eqs (10)-(19)
# ---------------------------------------------------------------------------
def test_single_impact_orbit_at_the_corner_eq_12():
    omega = 1.999
    kC = th.kappa_C(omega, R)
    for exact in (False, True):
        a, b, tau = th.single_impact_orbit(omega, kC, R, exact=exact)
        assert tau == pytest.approx(math.pi / omega, abs=1e-12)
        assert b == pytest.approx(0, abs=1e-12)
        assert a == pytest.approx(omega * 1.8 / 0.2 / math.sin(math.pi / omega), rel=1e-12)  # (12)
        assert all(math.isnan(v) for v in th.single_impact_orbit(omega, kC + 1e-3, R, exact=exact))
    # eq (10) with the corner approximation (7): tau - t0 = (kappa_C - kappa)/theta2
    a, b, tau = th.single_impact_orbit(omega, -0.02, R, beta=1.3)
    assert tau - math.pi / omega == pytest.approx((th.kappa_C(omega, R, 1.3) + 0.02) / (1.3 * omega))


def test_single_impact_orbit_exact_is_a_fixed_point_of_the_flow():
    omega, kappa = 1.999, -0.03   # kappa < kappa_C = -0.0141: beta orbit, impact after t0
    a, b, tau = th.single_impact_orbit(omega, kappa, R, exact=True)
    (A, B), n = flow_map(a, b, omega, kappa, R)
    assert n == 1 and tau > math.pi / omega
    assert A == pytest.approx(a, abs=1e-9) and B == pytest.approx(b, abs=1e-9)
    a1, b1, tau1 = th.single_impact_orbit(omega, kappa, R)  # corner approximation: close
    assert abs(tau1 - tau) < 1e-5 and abs(a1 - a) < 5e-3   # measured 1.2e-6, 2.3e-3


def _double_impact_4x4(omega, tm, tp, r, th1, th2):
    """kappa from the first four equations of section 3.3.2 (unknowns a, b, kappa, v)."""
    T = 2 * math.pi / omega
    t0 = T / 2
    M = np.array([[math.cos(tm), math.sin(tm), -1, 0],
                  [math.cos(tp - T), math.sin(tp - T), -1, 0],
                  [-r * math.sin(tm), r * math.cos(tm), 0, 1],       # v + th1 = -r(v_in + th1)
                  [-math.sin(tp - T), math.cos(tp - T), 0, r]])      # v_out - th2 = -r(v - th2)
    rhs = [th1 * (t0 - tm), th2 * (tp - t0), -(1 + r) * th1, (1 + r) * th2]
    return np.linalg.solve(M, rhs)[2]


def test_double_impact_kappa_eq_14_corrected_sign():
    rng = np.random.default_rng(1)
    for _ in range(20):
        omega = rng.uniform(1.9, 2.1)
        t0 = math.pi / omega
        r = rng.uniform(0.3, 0.95)
        th1, th2 = rng.uniform(1, 3, 2)
        tm, tp = t0 - 0.05 * rng.random(), t0 + 0.05 * rng.random()
        want = _double_impact_4x4(omega, tm, tp, r, th1, th2)
        assert th.double_impact_kappa(omega, tm, tp, r, th1, th2) == pytest.approx(want, rel=1e-9, abs=1e-12)
        printed = th.double_impact_kappa(omega, tm, tp, r, th1, th2, variant="printed")
        if (t0 - tm) + (tp - t0) > 0.01:
            assert abs(printed - want) > 1e-3   # the printed "+" sign of (14) is wrong
    # corner limit tau- = tau+ = t0: kappa_CC, eq (17)
    for omega in (1.999, 2.001, 1.8):
        t0 = math.pi / omega
        assert th.double_impact_kappa(omega, t0, t0, R, omega, omega) == pytest.approx(
            th.kappa_CC(omega, R), rel=1e-12)


# ---------------------------------------------------------------------------
# words, cycles, period adding (sections 5.3-5.4)
# ---------------------------------------------------------------------------
def test_parse_word_and_winding_number():
    assert th.parse_word("b11 g b12 g") == "b" * 11 + "g" + "b" * 12 + "g"
    assert th.parse_word("b^11 g") == "b" * 11 + "g"
    assert th.parse_word("(\u03b2^3\u03b3)") == "bbbg"
    assert th.parse_word("abg") == "abg"
    with pytest.raises(ValueError):
        th.parse_word("bxg")
    with pytest.raises(ValueError):
        th.parse_word("  ")
    assert th.winding_number("b^11 g") == pytest.approx(1 / 12)                 # W = 1/(N+1)
    assert th.winding_number("b12 g b11 g") == pytest.approx(2 / 25)           # 2/(2N+3), N = 11


@pytest.mark.parametrize("word, kappa", [("b^11 g", -0.0127), ("b^12 g b^11 g", -0.0128),
                                         ("b^24 g", -0.014)])
def test_word_orbits_of_figs_6_and_17_admissible(word, kappa):
    # the attractors found by iterating the map (tests/models/test_maps2d.py) are admissible cycles
    x, ok = th.word_orbit(word, W1, kappa, R)
    assert ok and x.shape == (len(th.parse_word(word)), 2)
    assert not th.word_orbit(word, W1, -0.02, R)[1]        # beta fixed point regime instead
    assert not th.word_orbit(word, W1, -0.005, R)[1]
    lo, hi = th.word_interval(word, W1, R)
    assert lo < kappa < hi
    assert th.word_orbit(word, W1, lo + 1e-4 * (hi - lo), R)[1]
    assert not th.word_orbit(word, W1, lo - 1e-4 * (hi - lo), R)[1]
    assert not th.word_orbit(word, W1, hi + 1e-4 * (hi - lo), R)[1]


def test_word_orbit_fixed_point_and_section_5_3_2_cycles():
    np.testing.assert_allclose(th.word_orbit("b", W1, -0.02, R)[0][0],
                               th.fixed_point("beta", W1, -0.02, R), rtol=1e-13)
    r = R
    # (alpha beta) and (alpha beta gamma) a-values with the derived (52):
    x, ok = th.word_orbit("ab", W1, 0.0, r)
    np.testing.assert_allclose(x[:, 0], 2 * np.array([1 + r + r * r, 1 + r - r * r]) / (1 - r + r * r))
    assert ok
    x, ok = th.word_orbit("abg", W1, 0.0, r)
    np.testing.assert_allclose(x[:, 0], 2 * np.array([r**4 + 2 * r**3 + 2 * r * r - 1,
                                                      1 + 2 * r + 2 * r * r - r**4,
                                                      1 + 2 * r + 2 * r * r + 2 * r**3 + r**4]) / (1 + r**4))
    assert ok
    # section 5.3.2: (alpha), (alpha beta), (alpha beta gamma) all exist for kappa1 = 0, omega1 < 0.
    # With the printed (58) the three-cycle has the printed a-values and is NOT admissible.
    assert th.word_orbit("a", W1, 0.0, r)[1]
    xp, okp = th.word_orbit("abg", W1, 0.0, r, variant="printed")
    np.testing.assert_allclose(xp[:, 0], 2 * np.array([r**4 + 2 * r * r - 1, 1 + 2 * r * r - r**4,
                                                       1 + 2 * r + 2 * r**3 + r**4]) / (1 + r**4))
    assert not okp
    # the (alpha) cycle is admissible exactly for kappa1 > theta_alpha omega1 (eq 69)
    lo, hi = th.word_interval("a", W1, r)
    assert lo == pytest.approx(th.corner_lines(W1, r)[1], rel=1e-12) and hi == math.inf


def test_period_adding_estimate_section_5_4():
    kb = th.kappa_dot("beta", W1, R)
    for order in (1, 2):
        # the intervals tile: N(delta) is constant on [delta_{N+1}, delta_N)
        for N in range(6, 40):
            lo, hi = th.period_adding_interval(N, W1, R, order)
            assert th.period_adding_N(lo * (1 + 1e-9), W1, R, order) == N
            assert th.period_adding_N(hi * (1 - 1e-9), W1, R, order) == N
        lo40, _ = th.period_adding_interval(40, W1, R, order)
        lo39, _ = th.period_adding_interval(39, W1, R, order)
        assert lo40 / lo39 == pytest.approx(R * 40 / 39 if order == 1 else R * 41 / 40)  # -> r
    # against the exact intervals of the map (word_interval): the ratio -> 1 as N grows,
    # like 1/N at order 1 and 1/N^2 at order 2 (measured: 1.258/1.153 at N = 11, 1.035/1.002 at N = 30)
    for N, tol1, tol2 in [(11, 0.3, 0.17), (30, 0.04, 0.003)]:
        lo, hi = th.word_interval(f"b^{N} g", W1, R)
        e1 = th.period_adding_interval(N, W1, R, 1)
        e2 = th.period_adding_interval(N, W1, R, 2)
        assert 1 < (lo - kb) / e1[0] < 1 + tol1 and 1 < (hi - kb) / e1[1] < 1 + tol1
        assert 1 < (lo - kb) / e2[0] < 1 + tol2 and 1 < (hi - kb) / e2[1] < 1 + tol2
    # at kappa = -0.014 (Fig. 6(d), period 25 = beta^24 gamma) both orders give N = 24
    assert th.period_adding_N(-0.014 - kb, W1, R, 1) == 24
    assert th.period_adding_N(-0.014 - kb, W1, R, 2) == 24
    with pytest.raises(ValueError):
        th.period_adding_N(-1e-3, W1, R)
    with pytest.raises(ValueError):
        th.period_adding_N(1e-3, 0.001, R)
