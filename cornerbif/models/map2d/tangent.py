"""Tangent dynamics of the local maps alpha, beta, gamma (eqs 56-60, docs/stability.md): the
products of the maps' linear parts (eq 57) (``map_cycle_multipliers``) and their exact
exponents (``map_lyapunov``), for every item by ``batch_map_stability``.
"""

import math

from ..._jit import items_kernel, jit, stop_requested
from ...stability import NO_CYCLE, NO_WINDOW, OK, log_or_minus_inf, multipliers, store


@jit
def map_cycle_multipliers(omega1, r, regions, period):
    """The multipliers of the last ``period`` recorded steps of the local maps (eqs 56-60):
    the eigenvalues of the product of their linear parts s [[1, 0], [h, 1]], h = pi omega1/2,
    s = r (beta, gamma), -r^2 (alpha) (eq 57; ``theory.map_matrices``), the later steps on
    the left: (re1, im1, re2, im2, period, status)."""
    nan = math.nan
    n = regions.shape[0]
    if period <= 0 or period > n:
        return nan, nan, nan, nan, nan, NO_CYCLE
    h = 0.5 * math.pi * omega1
    a, b, c, d = 1.0, 0.0, 0.0, 1.0
    for i in range(n - period, n):
        g = regions[i]
        if g < 0:
            return nan, nan, nan, nan, nan, NO_CYCLE
        s = map_slope(g, r)
        a, b, c, d = s * a, s * b, s * (h * a + c), s * (h * b + d)
    re1, im1, re2, im2 = multipliers(a, b, c, d)
    return re1, im1, re2, im2, float(period), OK


@jit
def map_slope(region, r):
    """The factor s of a map's linear part s [[1, 0], [h, 1]] (eq 57): -r^2 for alpha
    (region 0), r for beta and gamma."""
    return -r * r if region == 0 else r


@jit
def map_lyapunov(r, regions):
    """The Lyapunov spectrum (per iterate) of the local maps over the recorded steps (the
    finite ones: a region < 0 marks an iterate that was not): (lambda1, lambda2, number of
    steps, status).

    Every linear part s [[1, 0], [h, 1]] (eq 57) maps e2 = (0, 1) to s e2: the maps share
    the invariant direction e2, so with the Gram-Schmidt basis started at (e2, e1) the
    first vector stays e2 and every step's R = diag(|s|, |s|) exactly.  Both exponents are
    the mean of log|s| over the window (log r for beta and gamma, 2 log r for alpha), with
    no warm-up: on a cycle, log|mu| / period for its double multiplier s^period (a
    Jordan block: a generic start basis would converge only like log(N)/N)."""
    n = 0
    total = 0.0
    while n < regions.shape[0] and regions[n] >= 0:
        total += log_or_minus_inf(abs(map_slope(regions[n], r)))
        n += 1
    if n == 0:
        return math.nan, math.nan, math.nan, NO_WINDOW
    lam = total / n
    return lam, lam, float(n), OK


@items_kernel
def batch_map_stability(k0, k1, params, regions, period, o_re, o_im, o_dur, o_status, o_lam, o_win,
                        o_lstatus, control=0):
    """``map_cycle_multipliers`` and ``map_lyapunov`` for every item (row of ``params`` =
    [omega1, kappa1, r]); ``control`` as for ``batch_stability``."""
    for i in range(k0, k1):
        if stop_requested(control):
            continue
        store(i, map_cycle_multipliers(params[i, 0], params[i, 2], regions[i], period[i]),
              map_lyapunov(params[i, 2], regions[i]),
              o_re, o_im, o_dur, o_status, o_lam, o_win, o_lstatus)
