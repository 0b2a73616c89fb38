"""Closed forms of the paper (section 3.3): corner curves and simple periodic orbits.

All formulas are written for the obstacle z = kappa + beta |sin(omega t)|
(eq 8), for which t0 = pi/omega, T = 2 pi/omega and theta1 = theta2 = beta omega.
"""

from __future__ import annotations

import math


def kappa_C(omega: float, r: float, beta: float = 1.0) -> float:
    """Corner bifurcation of the single-impact period-T orbit, eqs (10)-(11).

    kappa_C = theta2 (1 + r)/(1 - r) cot(pi/omega) with theta2 = beta omega
    (eq 11 is the case beta = 1).  The orbit exists for kappa < kappa_C (eq 13).
    """
    return beta * omega * (1.0 + r) / (1.0 - r) / math.tan(math.pi / omega)


def kappa_CC(omega: float, r: float, beta: float = 1.0) -> float:
    """Corner bifurcation of the double-impact period-T orbit, eqs (15)-(17).

    kappa_CC = (theta2 + r theta1)(1 + r)/(1 + r^2) cot(pi/omega); with
    theta1 = theta2 = beta omega this is beta omega (1 + r)^2/(1 + r^2) cot(pi/omega).
    The orbit exists for kappa > kappa_CC (eq 19).
    """
    return beta * omega * (1.0 + r) ** 2 / (1.0 + r * r) / math.tan(math.pi / omega)


def _solve_omega(fun, kappa, lo, hi, iters=200):
    """Bisection for fun(omega) = kappa on [lo, hi] (fun is monotone there)."""
    flo = fun(lo) - kappa
    fhi = fun(hi) - kappa
    if flo == 0:
        return lo
    if fhi == 0:
        return hi
    if flo * fhi > 0:
        return math.nan
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        fm = fun(mid) - kappa
        if fm == 0 or hi - lo < 1e-15 * max(1.0, abs(mid)):
            return mid
        if (fm < 0) == (flo < 0):
            lo, flo = mid, fm
        else:
            hi = mid
    return 0.5 * (lo + hi)


def omega_C(kappa: float, r: float, beta: float = 1.0, lo: float = 1.0 + 1e-9,
            hi: float = 3.0) -> float:
    """omega_C(kappa): eq (11) solved for omega on (lo, hi) by bisection."""
    return _solve_omega(lambda w: kappa_C(w, r, beta), kappa, lo, hi)


def omega_CC(kappa: float, r: float, beta: float = 1.0, lo: float = 1.0 + 1e-9,
             hi: float = 3.0) -> float:
    """omega_CC(kappa): eq (17) solved for omega on (lo, hi) by bisection."""
    return _solve_omega(lambda w: kappa_CC(w, r, beta), kappa, lo, hi)


def resonant_amplitude(r: float, beta: float = 1.0) -> float:
    """b = 2 beta (1 + r)/(1 - r): the orbit u = b |sin t| of the smooth wall at omega = 2, eq (6)."""
    return 2.0 * beta * (1.0 + r) / (1.0 - r)
