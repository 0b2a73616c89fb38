"""The pieces of the flow kernel's event search that trade work for speed, each against a
slower computation of the same thing.

* ``small_sincos`` (Taylor series) against libm;
* ``roots.quad_positive`` (no square root) against ``roots.quad_first_root``;
* ``first_impact_free`` (state carried by small-angle rotation) against ``first_root`` on
  the gap evaluated by the closed forms at every point;
* the Sturm certificate right after an impact against a dense sampling of the gap.
"""

import math

import numpy as np
import pytest

from cornerbif.models.flow import kernel as F
from cornerbif.models.flow import packed as P
from cornerbif.numerics.oscillator import SMALL_ANGLE, derive, small_sincos, upp_bound
from cornerbif.numerics.roots import FOUND, NONE, quad_first_root, quad_positive
from cornerbif.obstacles.dispatch import derived_tuple, zpp_range, zppp_max


def _point(omega, kappa, r=0.8, obstacle="rectified_sine", beta=1.0, k=1.0):
    row = P.pack({"omega": omega, "kappa": kappa, "beta": beta, "r": r, "k": k}, obstacle,
                 1e-12, 1e-6, 1e6, None)
    return P.as_tuple(row), derived_tuple(derive(row))


def test_small_sincos_matches_libm():
    """Taylor remainders are below 1e-21 for |x| <= SMALL_ANGLE (docstring): what is left is
    the rounding of the polynomial, within 2 ulp of libm's correctly rounded values."""
    x = np.linspace(-SMALL_ANGLE, SMALL_ANGLE, 20001)
    x = np.concatenate([x, [1e-300, -1e-17, 3e-9, SMALL_ANGLE]])
    for xi in x:
        s, c = small_sincos(xi)
        assert abs(s - math.sin(xi)) <= 2 * math.ulp(math.sin(xi)) + 1e-300
        assert abs(c - math.cos(xi)) <= 2 * math.ulp(1.0)


def test_quad_positive_is_the_root_test_without_square_root():
    """quad_positive(f, fp, a, L) == (quad_first_root(f, fp, a) >= L) on random quadratics,
    except within rounding of the boundary (where either answer is certified)."""
    rng = np.random.default_rng(7)
    n = 200000
    f = np.abs(rng.normal(size=n)) * 10.0 ** rng.uniform(-12, 1, n)
    f[: n // 10] = 0.0                                  # the point just after an impact
    fp = rng.normal(size=n) * 10.0 ** rng.uniform(-6, 1, n)
    a = rng.normal(size=n) * 10.0 ** rng.uniform(-3, 2, n)
    a[n // 10: n // 5] = 0.0
    L = 10.0 ** rng.uniform(-6, 0.5, n)
    differ = 0
    for i in range(n):
        fast = quad_positive(f[i], fp[i], a[i], L[i])
        slow = quad_first_root(f[i], fp[i], a[i]) >= L[i]
        if fast != slow:
            qL = f[i] + L[i] * (fp[i] + 0.5 * a[i] * L[i])
            scale = f[i] + abs(fp[i]) * L[i] + abs(a[i]) * L[i] ** 2
            disc = fp[i] ** 2 - 2 * a[i] * f[i]
            assert abs(qL) <= 1e-14 * scale or abs(disc) <= 1e-13 * fp[i] ** 2, (
                f[i], fp[i], a[i], L[i])
            differ += 1
    assert differ <= n * 1e-4


def _flight(p, d, rng):
    """A random flight state on piece 0, above the obstacle: (tau_ref, uh, vh)."""
    while True:
        tau = rng.uniform(0.0, 0.9 * d[0])
        zr, zp = F.sine_part(p, 0, tau)
        u = p[P.KAPPA] + zr + abs(rng.normal()) * 10.0 ** rng.uniform(-9, 0.5)
        v = rng.normal() * 3.0
        return tau, u, v


@pytest.mark.parametrize("omega,kappa", [(2.1, 0.0), (1.999, -0.01), (1.5, 0.3), (2.5, -1.0),
                                          (0.7, 0.2)])
def test_free_search_agrees_with_closed_form_search(omega, kappa):
    """first_impact_free (state carried by small-angle rotation) and first_root (gap
    evaluated by the closed forms at every point) find the same first impact: same
    decision, times within the event tolerance 1e-12, and the carried state at the root
    equals the closed form there to 1e-13."""
    p, d = _point(omega, kappa)
    rng = np.random.default_rng(11)
    tol = 1e-12
    found = sturm_starts = 0
    for _ in range(400):
        tau, uh, vh = _flight(p, d, rng)
        rest = d[0] - tau
        bu, bu3, _ = upp_bound(p, d, uh, vh)
        zlo, zhi = zpp_range(p, 0)
        args = (p, d, 0, tau, uh, vh, 0.0, rest, -bu - zhi, bu - zlo, bu3 + zppp_max(p), tol,
                False)
        m4 = bu3 * p[P.K] + zppp_max(p) * p[P.OMEGA]       # bound of |g''''|
        start = F.free_start(p, d, 0, tau, uh, vh, 0.0, math.nan)
        fargs = args[:7] + start + args[7:11] + (m4,) + args[11:]
        c1, s1, u, v, z, zp, zpp = F.first_impact_free(*fargs)
        c2, s2 = F.first_root(F.GAP, *args)
        assert c1 == c2
        if c1 == FOUND:
            found += 1
            assert abs(s1 - s2) <= tol
            ue, ve = F.homogeneous(p, d, uh, vh, s1)
            zr, zpe = F.sine_part(p, 0, tau + s1)
            assert abs(u - ue) <= 1e-13 * (1 + abs(ue))
            assert abs(v - ve) <= 1e-13 * (1 + abs(ve))
            assert abs(z - (p[P.KAPPA] + zr)) <= 1e-13 * (1 + abs(z))
            assert abs(zp - zpe) <= 1e-13 * (1 + abs(zpe))
        else:
            assert c1 == NONE and s1 == rest
        # from the Sturm root, the first point's rotation from its half-angle tangent
        zr, zpr = F.sine_part(p, 0, tau)
        s0, _, _, _, t0 = F.sturm_clear(p, d, 0, uh - p[P.KAPPA] - zr, vh - zpr, rest, 1.0,
                                        0.0, False, False)
        if t0 == t0:
            sturm_starts += 1
            a0 = args[:6] + (s0,)
            start = F.free_start(p, d, 0, tau, uh, vh, s0, t0)
            c3, s3, u3, v3, *_ = F.first_impact_free(*a0, *start, *fargs[11:])
            c4, s4 = F.first_root(F.GAP, *a0, *args[7:])
            assert c3 == c4 == c1
            if c3 == FOUND:
                assert abs(s3 - s4) <= tol and abs(s3 - s1) <= tol
                ue, ve = F.homogeneous(p, d, uh, vh, s3)
                assert abs(u3 - ue) <= 1e-13 * (1 + abs(ue))
                assert abs(v3 - ve) <= 1e-13 * (1 + abs(ve))
    assert found >= 40
    assert sturm_starts >= 20


@pytest.mark.parametrize("omega,kappa", [(2.1, 0.0), (1.5, -0.3), (1.0, 0.0), (3.0, -2.0),
                                          (1.999, 0.01), (0.8, 0.0)])
def test_sturm_certificate_right_after_an_impact(omega, kappa):
    """Right after an impact (g = 0 < g') the Sturm comparison clears a length over which
    the gap, sampled densely from the closed forms, stays positive; for kappa <= 0 and
    omega >= k (g'' + k^2 g >= 0 on the piece) that length is the whole rest of the piece."""
    p, d = _point(omega, kappa)
    rng = np.random.default_rng(5)
    L = d[0]
    for _ in range(300):
        tau = rng.uniform(0.0, L)
        zr, zp = F.sine_part(p, 0, tau)
        z = p[P.KAPPA] + zr
        w_out = 10.0 ** rng.uniform(-6, 1)                 # relative velocity after impact
        rest = L - tau
        clear = F.sturm_clear(p, d, 0, 0.0, w_out, rest, 1.0, 0.0, False, False)[0]
        if kappa <= 0.0 and omega >= 1.0:
            assert clear == rest
        if clear <= 0.0:
            continue
        s = np.linspace(0.0, clear, 2001)[1:]
        # exact flight from (z, z' + w_out), k = 1, sigma = 0: u = z cos s + v sin s
        u = z * np.cos(s) + (zp + w_out) * np.sin(s)
        g = u - (p[P.KAPPA] + np.sin(omega * (tau + s)))
        scale = 1e-12 * (1.0 + abs(z) + abs(zp) + w_out)
        assert g.min() > -scale, (tau, w_out, clear)


@pytest.mark.parametrize("omega,kappa", [(2.1, 0.0), (1.999, -0.01), (1.5, 0.3), (2.5, -1.0),
                                          (0.7, 0.2)])
def test_grid_start_lies_before_the_sturm_root(omega, kappa):
    """A flight from a corner starts its search at the phase grid's point before the Sturm
    root: at most the root (no root skipped), less than one cell before it, and the state
    there (rotated by the grid's table values) equals the closed forms to 1e-13."""
    p, d = _point(omega, kappa)
    grid = F.phase_grid(p, d)
    cell = d[0] / F.PHASE_GRID
    rng = np.random.default_rng(3)
    zr0, zp0 = F.sine_part(p, 0, 0.0)
    starts = 0
    for _ in range(2000):
        uh = p[P.KAPPA] + zr0 + abs(rng.normal()) * 10.0 ** rng.uniform(-9, 1)
        vh = rng.normal() * 10.0 ** rng.uniform(-3, 1)
        g0, gp0 = uh - p[P.KAPPA] - zr0, vh - zp0
        s1, _, _, _, t = F.sturm_clear(p, d, 0, g0, gp0, d[0], 1.0, 0.0, False, False)
        s_t, _, _, _, t2 = F.sturm_clear(p, d, 0, g0, gp0, d[0], 1.0, 0.0, False, True)
        if t != t:
            continue                        # no Sturm root inside the piece
        if s_t >= 0.0:
            continue                        # the t-only call cleared the whole reach
        assert t2 == t
        starts += 1
        tau_m, u, v, zr, zp = F.grid_start(p, d, 0, uh, vh, grid, t)
        assert tau_m <= s1 and s1 - tau_m < cell * (1 + 1e-12)
        ue, ve = F.homogeneous(p, d, uh, vh, tau_m)
        ze, zpe = F.sine_part(p, 0, tau_m)
        assert abs(u - ue) <= 1e-13 * (1 + abs(ue)) and abs(v - ve) <= 1e-13 * (1 + abs(ve))
        assert abs(zr - ze) <= 1e-14 and abs(zp - zpe) <= 1e-13
    assert starts >= 200


def test_polish_brackets_the_root_of_the_gap():
    """roots.polish, on gaps near a transversal root, returns [a, b] no wider than tol with
    g(a) > 0 >= g(b) and g > 0 on [0, a] (dense sampling of the closed forms), or declines."""
    from cornerbif.numerics.roots import polish
    p, d = _point(2.1, 0.0)
    rng = np.random.default_rng(9)
    k2, w2, tol = 1.0, 2.1 ** 2, 1e-12
    accepted = 0
    for _ in range(3000):
        tau, uh, vh = _flight(p, d, rng)
        rest = d[0] - tau
        bu, bu3, _ = upp_bound(p, d, uh, vh)
        m4 = bu3 * p[P.K] + zppp_max(p) * p[P.OMEGA]
        # the exact first root on the rest of the piece, by the closed-form search
        bu2 = zpp_range(p, 0)
        code, s = F.first_root(F.GAP, p, d, 0, tau, uh, vh, 0.0, rest, -bu - bu2[1],
                               bu - bu2[0], bu3 + zppp_max(p), 1e-15, False)
        if code != FOUND or s < 1e-9:
            continue
        # a point shortly before it, where polish applies
        x = s * 10.0 ** rng.uniform(-6, -2)
        u, v = F.homogeneous(p, d, uh, vh, s - x)
        zr, zp = F.sine_part(p, 0, tau + s - x)
        f, fp = u - p[P.KAPPA] - zr, v - zp
        ok, a, b = polish(f, fp, w2 * zr - k2 * u, w2 * zp - k2 * v, m4, rest - (s - x), tol)
        if not ok:
            continue
        accepted += 1
        assert 0.0 <= b - a <= tol
        assert abs((s - x + a) - s) <= 2e-12
        ga = F.evaluate(F.GAP, p, d, 0, tau, uh, vh, s - x + a)[0]
        assert ga > -1e-14
    assert accepted >= 500
