"""Certified first-root search (DESIGN 2: never miss an impact, grazing ones included).

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

from .._jit import jit

NONE = 0
FOUND = 1
FAIL = -1
STEP = 2      # ``bracket``: no decision yet, move on
MAXIT = 400


@jit
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


@jit
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


@jit
def bracket(f, fp, fpp, fppp, first, rest, lo2, hi2, m3, m4, tol, H_hint):
    """One step of the certified search from a point with f, f', f'' (module docstring).

    ``lo2 <= f'' <= hi2`` on the whole rest of the piece (length ``rest``); ``m3 >=
    |f'''|`` (inf if unknown) tightens those bounds locally: on [s, s + H], f'' lies
    within f''(s) +- m3 H.  H is 1.25 times the root predicted with the exact
    curvature, so near a transversal root the bracket closes at third order.  With
    f''' = ``fppp`` here and ``m4 >= |f''''|`` (inf if unknown), f'' also lies
    within f''(s) + f''' x +- m4 x^2 / 2: tighter where f''' is small.
    ``first`` ignores f <= 0 here (the point just after an impact, g = 0, g' > 0).

    Returns (code, h): FOUND with the root at +h, NONE (no root in the rest), FAIL
    (f is not a number), or STEP with the certified step h to the next point.
    """
    if not (f == f):
        return FAIL, 0.0, math.inf
    if not first and f <= 0.0:
        return FOUND, 0.0, math.inf
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
        lo_loc = max(lo2, fpp - m3 * H)
        hi_loc = min(hi2, fpp + m3 * H)
        if m4 < math.inf:
            e = 0.5 * m4 * H * H
            lo_loc = max(lo_loc, fpp + min(0.0, fppp * H) - e)
            hi_loc = min(hi_loc, fpp + max(0.0, fppp * H) + e)
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
