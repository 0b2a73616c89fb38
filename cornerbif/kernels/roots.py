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
