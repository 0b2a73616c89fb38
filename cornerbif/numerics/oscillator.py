"""The oscillator u'' + 2 sigma u' + k^2 u = f(t), f = F cos(Omega t + phi) (eq 4).

Free flight is exact (closed form) in every regime, so all numerical error of
the engine lives in event location (docs/guarantees.md).  The state is split as
u = u_h + u_p: u_p is the particular solution of the harmonic forcing, u_h the
homogeneous part carried from the flight's reference point.
"""

import math

import numpy as np

from .._jit import jit, jit_inline
from ..models.flow import packed as P
from ..obstacles.dispatch import (
    D_HALF,
    D_IK,
    D_IWD,
    D_L0,
    D_L1,
    D_LAM1,
    D_LAM2,
    D_NPP,
    D_PERIOD,
    D_REGIME,
    D_STURM0,
    D_STURM1,
    D_UPP_PART,
    D_WD,
    D_X,
    D_Y,
    NDERIVED,
    contact_npp,
    cycle_np,
    piece_lengths,
    profile_cycle,
    sturm_floors,
)


@jit
def derive(p):
    """Per-point constants: piece lengths, damping regime, particular solution, bounds
    (the obstacle's own quantities come from ``obstacles.dispatch``)."""
    d = np.zeros(NDERIVED)
    d[D_L0], d[D_L1], d[D_PERIOD] = piece_lengths(p)
    profile_cycle(p, d)
    sig = p[P.SIGMA]
    k = p[P.K]
    if sig < k:
        d[D_REGIME] = 0.0
        d[D_WD] = math.sqrt(k * k - sig * sig)
        d[D_IWD] = 1.0 / d[D_WD]
    elif sig == k:
        d[D_REGIME] = 1.0
    else:
        d[D_REGIME] = 2.0
        q = math.sqrt(sig * sig - k * k)
        d[D_LAM1] = -sig + q
        d[D_LAM2] = -sig - q
    F = p[P.F_AMP]
    W = p[P.F_OMEGA]
    if F != 0.0:
        a = k * k - W * W
        b = 2.0 * sig * W
        den = a * a + b * b
        d[D_X] = F * a / den
        d[D_Y] = F * b / den
        d[D_UPP_PART] = W * W * math.sqrt(d[D_X] ** 2 + d[D_Y] ** 2)
    # bound of |N''| with N = z'' + 2 sigma z' + k^2 z - f (contact force while stuck)
    d[D_NPP] = contact_npp(p, abs(F) * W * W)
    # the floors of the Sturm comparison of the free undamped gap (flow.sturm_clear)
    if k > 0.0:
        d[D_STURM0], d[D_STURM1] = sturm_floors(p, d)
        d[D_IK] = 1.0 / k
        d[D_HALF] = math.pi / k
    return d


MAX_BUDGET = 2 ** 62   # the largest piece budget (int64 with room to count past it)


@jit
def time_scale(p):
    """The oscillator's own time scale (eq 4): its natural period 2 pi / k (k > 0), else
    the forcing's period 2 pi / Omega (F != 0), else 0 (a free particle has none)."""
    if p[P.K] > 0.0:
        return 2.0 * math.pi / p[P.K]
    if p[P.F_AMP] != 0.0:
        return 2.0 * math.pi / p[P.F_OMEGA]
    return 0.0


@jit
def budget_pieces(p, d, pieces):
    """The time budget of a run in obstacle pieces (``run.max_periods``).

    ``pieces`` = 4 max_periods (``FlowModel.int_settings``) counts the budget at the
    obstacle's time scale: 4 pieces, 2 D_PERIOD of time, per unit.  Each unit lasts the
    slower of that and the oscillator's ``time_scale``: when the obstacle is fast (omega
    large against k) a flight between impacts spans many pieces, and the budget grows by
    time_scale / (2 D_PERIOD) (rounded up, at most MAX_BUDGET).  Where the obstacle is the
    slower (omega <= 2k for sine and rectified_sine, omega <= k for triangle) it is
    ``pieces``, as before.
    """
    n = cycle_np(d)
    if n > 2:
        # a profile of n pieces: 2 D_PERIOD hold 2 n pieces, not 4
        pieces = np.int64(min(pieces * (n / 2.0), float(MAX_BUDGET)))
    scale = time_scale(p) / (2.0 * d[D_PERIOD])
    if not scale > 1.0:
        return pieces
    x = math.ceil(pieces * scale)
    if x >= MAX_BUDGET:
        return np.int64(MAX_BUDGET)
    return np.int64(x)


@jit
def particular(p, d, t):
    """Particular solution (u_p, u_p') at absolute time t."""
    if p[P.F_AMP] == 0.0:
        return 0.0, 0.0
    W = p[P.F_OMEGA]
    th = W * t + p[P.F_PHI]
    c = math.cos(th)
    s = math.sin(th)
    return d[D_X] * c + d[D_Y] * s, W * (d[D_Y] * c - d[D_X] * s)


@jit
def forcing(p, t):
    """f(t) = F cos(Omega t + phi) (eq 4)."""
    if p[P.F_AMP] == 0.0:
        return 0.0
    return p[P.F_AMP] * math.cos(p[P.F_OMEGA] * t + p[P.F_PHI])


@jit
def acceleration(p, t, u, v):
    """u'' = f(t) - 2 sigma u' - k^2 u in free flight (eq 4)."""
    return forcing(p, t) - 2.0 * p[P.SIGMA] * v - p[P.K] * p[P.K] * u


SMALL_ANGLE = 0.25   # |x| up to which small_sincos is used: its remainder is below 1e-21


@jit_inline
def small_sincos(x):
    """(sin x, cos x) for |x| <= SMALL_ANGLE by their Taylor series.

    For |x| <= 1e-3 (most steps of a search near its root) the series stop at x^5 and
    x^6 (remainders below x^7/7! < 2e-25 and x^8/8! < 3e-29); otherwise at x^13 and x^14
    (below x^15/15! < 7.2e-22 and x^16/16! < 1.2e-23 at SMALL_ANGLE): far below the
    rounding of the result, in a few multiply-adds instead of a libm call.
    """
    t = x * x
    if t <= 1e-6:
        return (x * (1.0 + t * (-1.0 / 6.0 + t * (1.0 / 120.0))),
                1.0 + t * (-0.5 + t * (1.0 / 24.0 + t * (-1.0 / 720.0))))
    sn = x * (1.0 + t * (-1.0 / 6.0 + t * (1.0 / 120.0 + t * (-1.0 / 5040.0 + t * (
        1.0 / 362880.0 + t * (-1.0 / 39916800.0 + t * (1.0 / 6227020800.0)))))))
    c = 1.0 + t * (-0.5 + t * (1.0 / 24.0 + t * (-1.0 / 720.0 + t * (1.0 / 40320.0 + t * (
        -1.0 / 3628800.0 + t * (1.0 / 479001600.0 + t * (-1.0 / 87178291200.0)))))))
    return sn, c


@jit
def rotate(p, d, uh0, vh0, c, sn):
    """Under-damped flight without its decay factor: (u_h, u_h') e^{sigma s} a time s after
    (uh0, vh0), given c = cos(w_d s) and sn = sin(w_d s) (exact for sigma = 0)."""
    sig = p[P.SIGMA]
    wd = d[D_WD]
    A = uh0
    B = (vh0 + sig * uh0) * d[D_IWD]
    return A * c + B * sn, (B * wd - sig * A) * c - (A * wd + sig * B) * sn


@jit
def homogeneous(p, d, uh0, vh0, s):
    """Homogeneous flight: (u_h, u_h') a time s after the state (uh0, vh0)."""
    sig = p[P.SIGMA]
    reg = d[D_REGIME]
    if reg == 0.0:
        wd = d[D_WD]
        u, v = rotate(p, d, uh0, vh0, math.cos(wd * s), math.sin(wd * s))
        if sig != 0.0:
            e = math.exp(-sig * s)
            u *= e
            v *= e
        return u, v
    if reg == 1.0:
        A = uh0
        B = vh0 + sig * uh0
        e = math.exp(-sig * s)
        return e * (A + B * s), e * (B - sig * (A + B * s))
    l1 = d[D_LAM1]
    l2 = d[D_LAM2]
    c1 = (vh0 - l2 * uh0) / (l1 - l2)
    c2 = uh0 - c1
    e1 = math.exp(l1 * s)
    e2 = math.exp(l2 * s)
    return c1 * e1 + c2 * e2, l1 * c1 * e1 + l2 * c2 * e2


@jit
def upp_bound(p, d, uh0, vh0):
    """Bounds of |u''| and |u'''| over the whole future flight from (uh0, vh0), and its size
    (the amplitude R under-damped, |u_h| + |v_h| otherwise) for the escape test.

    Under-damped: u_h = R e^{-sigma s} cos(w_d s - psi), and each derivative
    multiplies the envelope by at most k, so |u_h''| <= R k^2, |u_h'''| <= R k^3;
    critically damped (u_h = e^{-sigma s}(A + B s)): |u_h''| <= sigma^2 |A| + 2 sigma |B|,
    |u_h'''| <= sigma^3 |A| + 3 sigma^2 |B|; over-damped: sum of |c_i| |l_i|^n.
    The particular solution adds Omega^n |(X, Y)|.
    """
    sig = p[P.SIGMA]
    reg = d[D_REGIME]
    if reg == 0.0:
        B = (vh0 + sig * uh0) * d[D_IWD]
        amp = math.sqrt(uh0 * uh0 + B * B)
        k = p[P.K]
        hb = amp * k * k
        hb3 = hb * k
        size = amp
    elif reg == 1.0:
        B = vh0 + sig * uh0
        hb = sig * sig * abs(uh0) + 2.0 * sig * abs(B)
        hb3 = sig * sig * sig * abs(uh0) + 3.0 * sig * sig * abs(B)
        size = abs(uh0) + abs(vh0)
    else:
        l1 = d[D_LAM1]
        l2 = d[D_LAM2]
        c1 = (vh0 - l2 * uh0) / (l1 - l2)
        c2 = uh0 - c1
        hb = abs(c1) * l1 * l1 + abs(c2) * l2 * l2
        hb3 = abs(c1) * abs(l1) ** 3 + abs(c2) * abs(l2) ** 3
        size = abs(uh0) + abs(vh0)
    W = p[P.F_OMEGA]
    return hb + d[D_UPP_PART], hb3 + d[D_UPP_PART] * W, size


@jit
def deriv_bound(p, d, uh0, vh0, n):
    """Bound of |u^(n)| (n >= 0) over the whole future flight from the homogeneous state
    (uh0, vh0), harmonic forcing included (eq 4; used by ``two_particle``).

    Under-damped: u_h = R e^{-sigma s} cos(w_d s - psi) and each derivative multiplies
    the envelope by at most k: |u_h^(n)| <= R k^n.  Critically damped,
    u_h^(n) = (-sigma)^n e^{-x} (A + (B/sigma)(x - n)) with x = sigma s, and
    max_x |x - n| e^{-x} is n for n >= 1 (at x = 0) and 1/e for n = 0:
    |u_h^(n)| <= sigma^n |A| + n sigma^(n-1) |B| (n >= 1), |A| + |B|/(e sigma) (n = 0).
    Over-damped: sum of |c_i| |l_i|^n.  The particular solution adds Omega^n |(X, Y)|.
    """
    sig = p[P.SIGMA]
    reg = d[D_REGIME]
    if reg == 0.0:
        B = (vh0 + sig * uh0) * d[D_IWD]
        hb = math.sqrt(uh0 * uh0 + B * B) * p[P.K] ** n
    elif reg == 1.0:
        B = vh0 + sig * uh0
        if n == 0:
            hb = abs(uh0) + abs(B) / (math.e * sig)
        else:
            hb = sig ** n * abs(uh0) + n * sig ** (n - 1) * abs(B)
    else:
        l1 = d[D_LAM1]
        l2 = d[D_LAM2]
        c1 = (vh0 - l2 * uh0) / (l1 - l2)
        c2 = uh0 - c1
        hb = abs(c1) * abs(l1) ** n + abs(c2) * abs(l2) ** n
    if p[P.F_AMP] == 0.0:
        return hb
    return hb + math.sqrt(d[D_X] ** 2 + d[D_Y] ** 2) * p[P.F_OMEGA] ** n
