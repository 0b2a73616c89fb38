"""Certified first-root search (never miss an impact, grazing ones included: docs/guarantees.md).

A function f (the gap g = u - z, or the contact force N) is smooth on a piece,
and bounds lo2 <= f'' <= hi2 hold on the whole rest of the piece.  From a point
with f >= 0,

    f(s + h) >= f + f' h + lo2 h^2 / 2,

so no root lies before the first positive root h_lo of that quadratic: a step
of h_lo cannot skip a root, however shallow.  The upper quadratic
f + f' h + hi2 h^2 / 2 >= f(s + h) gives, when it has a root h_up, a certified
root in [h_lo, h_up].  Stepping to s + h_lo is a one-sided Newton iteration:
the bracket closes quadratically near a transversal root, and the search stops
when it is narrower than ``tol`` (the event-time tolerance).

Tolerance rule (documented in docs/guarantees.md): when a certified step is
shorter than ``tol`` the function is within tolerance of touching zero; if it
is still decreasing (f' < 0) or curving down (f'' < 0) that is a root (a
grazing contact), otherwise the search moves on by ``tol``.
"""

import math

from .._jit import jit, jit_inline

NONE = 0
FOUND = 1
FAIL = -1
STEP = 2      # ``bracket``: no decision yet, move on
MAXIT = 400


@jit_inline
def quad_first_root(f, fp, a):
    """First positive root of f + fp h + a h^2 / 2 (f >= 0), or inf if none."""
    if f < 0.0:
        f = 0.0
    if a < 0.0:
        disc = fp * fp - 2.0 * a * f
        sq = math.sqrt(disc)
        if fp >= 0.0:
            return (fp + sq) / (-a)
        return 2.0 * f / (sq - fp)
    if a == 0.0:
        if fp < 0.0:
            return f / (-fp)
        return math.inf
    if fp >= 0.0:
        return math.inf
    disc = fp * fp - 2.0 * a * f
    if disc < 0.0:
        return math.inf
    return 2.0 * f / (math.sqrt(disc) - fp)


@jit_inline
def quad_positive(f, fp, a, L):
    """Whether f + fp h + a h^2 / 2 (f >= 0; f < 0 read as 0) stays >= 0 on [0, L]: the
    test ``quad_first_root(f, fp, a) >= L`` without a square root or a division."""
    if f < 0.0:
        f = 0.0
    if f + L * (fp + 0.5 * a * L) < 0.0:
        return False
    if a <= 0.0 or fp >= 0.0 or fp <= -a * L:
        return True       # the minimum over [0, L] is at an end
    return fp * fp - 2.0 * a * f < 0.0     # the vertex inside: it must stay above 0


@jit_inline
def polish(f, fp, fpp, fppp, m4, rest, tol):
    """A root within ``tol`` from the Taylor polynomial of degree 3, where it is close.

    With T(x) = f + f' x + f'' x^2/2 + f''' x^3/6 and |f''''| <= m4, Taylor's formula
    puts f(s + x) within T(x) -+ m4 x^4 / 24.  From a point with f > 0 > f' whose root
    is near (y = f / -f' so small that m4 y^4 < 3 |f'| tol: the remainder is far below
    |f'| tol), the root x* of T, by series reversion
    x* = y + p y^2 + (t + 2 p^2) y^3 + 5 p (t + p^2) y^4 + O(y^5) with p = f''/(-2 f'),
    t = f'''/(-6 f'), is bracketed by a = x* - q and b = x* + q, with q = 4 R / |f'| +
    tol / 1000 (R = m4 (x* + tol)^4 / 24 bounds the remainder; 2 q <= tol is required):
    f(s + a) >= T(a) - R > 0, f(s + b) <= T(b) + R <= 0, and the lower
    bound T(x) - m4 x^4/24 is decreasing on [0, b] (its slope is at most
    f' + max(0, f'') b + max(0, f''') b^2/2 < 0), so it stays above its positive value at
    a on the whole of [0, a]: no root before a, one in [a, b].  One division, no square
    root; each check that fails (far root, slope not clearly negative, a series not
    accurate enough) returns False and the caller takes a certified step instead.

    Returns (ok, a, b).
    """
    f2 = f * f
    fp2 = fp * fp
    if not (m4 * f2 * f2 < -3.0 * fp2 * fp2 * fp * tol):
        return False, 0.0, 0.0
    c2 = 0.5 * fpp
    c3 = fppp / 6.0
    ir = -1.0 / fp
    y = f * ir
    p = c2 * ir
    t = c3 * ir
    p2 = p * p
    x = y + y * y * (p + y * ((t + 2.0 * p2) + y * 5.0 * p * (t + p2)))
    xb = x + tol
    r4 = m4 * xb * xb * xb * xb / 24.0     # >= the remainder on [0, x + tol]
    # the margin the certificate needs (T falls by about |f'| q over q), and room for the
    # series' truncation; as tight as that allows, not tol: a bracket always tol / 4 early
    # would bias every impact the same way (on an elastic fixed wall, energy drifted by
    # 1.5e-9 over 1e4 impacts)
    q = 4.0 * r4 * ir + 1e-3 * tol
    a = x - q
    b = x + q
    if not (a >= 0.0 and b <= rest and 2.0 * q <= tol
            and fp + max(0.0, fpp) * b + max(0.0, fppp) * 0.5 * b * b < 0.0):
        return False, 0.0, 0.0
    if f + a * (fp + a * (c2 + a * c3)) - r4 > 0.0 and f + b * (fp + b * (c2 + b * c3)) + r4 <= 0.0:
        return True, a, b
    return False, 0.0, 0.0


@jit_inline
def bracket(f, fp, fpp, fppp, first, rest, lo2, hi2, m3, m4, tol, H_hint):
    """One step of the certified search from a point with f, f', f'' (module docstring).

    ``lo2 <= f'' <= hi2`` on the whole rest of the piece (length ``rest``); ``m3 >=
    |f'''|`` (inf if unknown) tightens those bounds locally: by Taylor's formula with
    integral remainder, f(s + x) = f + f' x + c x^2 / 2 with c within f''(s) +- m3 x / 3
    (the remainder of order 3 is at most m3 x^3 / 6), so on [s, s + H] the quadratics
    with c = f''(s) -+ m3 H / 3 bound f from below and above.  H is 1.25 times the
    root predicted with the exact curvature, so near a transversal root the bracket
    closes at third order.  With f''' = ``fppp`` here and ``m4 >= |f''''|`` (inf if
    unknown), c also lies within f''(s) + f''' x / 3 +- m4 x^2 / 12: tighter where
    f''' is small.
    ``H_hint`` > 0 replaces that prediction (the caller's window from the previous
    step's bracket).  ``roots.polish`` is tried first where m4 is finite.
    ``first`` ignores f <= 0 here (the point just after an impact, g = 0, g' > 0).

    Returns (code, h, hup): FOUND with the root at +h, NONE (no root in the rest), FAIL
    (f is not a number), or STEP with the certified step h to the next point; hup is
    the end of the certified bracket (a root lies before +hup; inf if none is known).
    """
    if not (f == f):
        return FAIL, 0.0, math.inf
    if not first and f <= 0.0:
        return FOUND, 0.0, math.inf
    if m4 < math.inf and f > 0.0 and fp < 0.0:
        ok, a, b = polish(f, fp, fpp, fppp, m4, rest, tol)
        if ok:
            return FOUND, a, b
    if quad_positive(f, fp, lo2, rest):
        return NONE, rest, math.inf
    hup = math.inf
    have_hup = False
    local = False
    if m3 < math.inf:
        if H_hint > 0.0:
            H = H_hint
        else:
            H = 1.25 * quad_first_root(f, fp, fpp)
        if H > rest:
            H = rest
        # the local bounds can only help where the global lower root comes before H
        local = not quad_positive(f, fp, lo2, H)
    if not local:
        hlo = quad_first_root(f, fp, lo2)
    else:
        lo_loc = max(lo2, fpp - m3 * H / 3.0)
        hi_loc = min(hi2, fpp + m3 * H / 3.0)
        if m4 < math.inf:
            e = m4 * H * H / 12.0
            lo_loc = max(lo_loc, fpp + min(0.0, fppp * H) / 3.0 - e)
            hi_loc = min(hi_loc, fpp + max(0.0, fppp * H) / 3.0 + e)
        h1 = quad_first_root(f, fp, lo_loc)
        if h1 >= H:
            h1 = H            # no root in [s, s + H]
            if H == rest:
                return NONE, rest, math.inf
        hlo = h1              # >= the global lower root: lo_loc >= lo2
        h2 = quad_first_root(f, fp, hi_loc)
        if h2 <= H:
            # a curvature bound below hi2 puts the upper quadratic's root no later
            # than that of hi2: the global one is not needed
            hup = h2
            have_hup = True
    if not have_hup:
        hup = quad_first_root(f, fp, hi2)
    if hup - hlo <= tol and hup <= rest:
        return FOUND, hlo, hup
    if hlo < tol:
        if fp < 0.0 or (fpp < 0.0 and fp <= 0.0):
            return FOUND, hlo, hup
        return STEP, tol, hup
    return STEP, hlo, hup


@jit
def bracket_call(f, fp, fpp, fppp, first, rest, lo2, hi2, m3, m4, tol, H_hint):
    """``bracket`` as a plain call, for searches off the hot path (``flow.first_root``, one
    specialisation per searched function): every site that inlines ``bracket`` types and
    compiles it again, so the cold start is shorter with this call (benchmarks/README.md,
    "First compiles")."""
    return bracket(f, fp, fpp, fppp, first, rest, lo2, hi2, m3, m4, tol, H_hint)
