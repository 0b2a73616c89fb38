"""Event-driven kernel of the ``two_particle`` model (section 6; eqs 5, 72-74).

A wall w = kappa + beta sin(omega0 t) (eq 72), a heavy particle z and a light one u (eq 73,
optionally damped and forced as eq 4), w <= z <= u; w-z impacts by law (5), z-u impacts by
the mass-ratio law (74).  ``run_one`` integrates one item (modes FREE, WALL, PAIR, ALL;
the certified Sturm search of ``first_root``), ``run_batch`` fans out over items and
``run_tables`` checks, packs and allocates (for a scene: the model's ``run_items``).  Time
and flights, the event location, simultaneous impacts, chattering and sticking, the corner
offsets and the output layout are described in docs/kernels.md.
"""

import math

import numpy as np

from ... import status as S
from ..._jit import POLL_EVERY, STOPPED, count_done, items_kernel, jit, jit_inline, stop_requested
from ...analysis import close_corner_offsets, offset_to_previous, settle_corner_offsets
from ...numerics.impact import restitution
from ...numerics.oscillator import deriv_bound, homogeneous, particular
from ...numerics.oscillator import derive as osc_derive
from ...numerics.roots import FAIL, FOUND, MAXIT, NONE, quad_first_root
from ...obstacles.dispatch import D_REGIME, D_WD, D_X, D_Y, NDERIVED, SINE
from ..flow import packed as FP
from . import packed as P
from .packed import mass_ratio_impact

# --- output columns -------------------------------------------------------------------
ZU_T, ZU_U, ZU_VIN, ZU_VOUT, ZU_YIN, ZU_YOUT, ZU_OFF = 0, 1, 2, 3, 4, 5, 6
NZU = 7
WZ_T, WZ_Z, WZ_YIN, WZ_YOUT = 0, 1, 2, 3
NWZ = 4
SEC_T, SEC_Z, SEC_Y, SEC_U, SEC_V = 0, 1, 2, 3, 4
NSEC = 5

# --- modes ------------------------------------------------------------------------------
FREE = 0   # both particles fly
WALL = 1   # z stuck on the wall, u flies
PAIR = 2   # u stuck on z, the pair flies
ALL = 3    # z = u = w

# --- searched functions -----------------------------------------------------------------
K_GW = 0   # x - w, x harmonic of frequency a2 from (a0, a1)
K_GP = 1   # u - z, z from (a0, a1) with omega1, u from (a2, a3) with omega2
K_WF = 2   # a2 (a0 + a1 sin(omega0 t)): a wall-borne contact force
K_HM = 3   # a3 x, x harmonic of frequency a2 from (a0, a1)

# --- events -------------------------------------------------------------------------------
EV_SECTION = 0
EV_WZ = 1
EV_ZU = 2
EV_REL_Z = 3       # WALL -> FREE
EV_REL_PAIR = 4    # PAIR -> FREE
EV_REL_U = 5       # ALL -> WALL
EV_REL_STACK = 6   # ALL -> PAIR

# --- derived constants (``derive``) ----------------------------------------------------
C_W1SQ = 0
C_W2SQ = 1
C_OM = 2      # combined frequency Omega of a stuck pair
C_OMSQ = 3
C_D21 = 4     # omega2^2 - omega1^2
C_N1A = 5     # N1 = w'' + omega1^2 w = N1A + N1B sin(omega0 t)
C_N1B = 6
C_N2A = 7     # N2 = w'' + omega2^2 w
C_N2B = 8
C_N12A = 9    # N12 = w'' + Omega^2 w
C_N12B = 10
C_Q = 11      # wall periods per section
C_EXACT = 12  # 1 when the section is a whole number of wall periods
C_MUI = 13    # 1/(1 + mu)   (0 for mu = inf)
C_MUF = 14    # mu/(1 + mu)  (1 for mu = inf)
C_SMOOTH = 15  # 1: no damping and no forcing (eq 73 exactly): the undamped fast path
C_HZERO = 16   # 1: the pair's contact force lambda2 vanishes identically
NC = 17

# --- oscillator rows (``flow`` parameter vectors for ``numerics.oscillator``) -------------
RZ = 0    # z: sigma1, omega1, F1 cos(Omega1 t + phi1)
RU = 1    # u: sigma2, omega2, F2 cos(Omega2 t + phi2)
RP = 2    # stuck pair: Sigma, Omega, forcing mu F1/(mu + 1) at Omega1
RPB = 3   # the stuck pair's second forcing F2/(mu + 1) at Omega2
NROW = 4


@jit
def derive(p):
    """Per-point constants of one run."""
    c = np.zeros(NC)
    w0 = p[P.OMEGA0]
    w1s = p[P.OMEGA1] * p[P.OMEGA1]
    w2s = p[P.OMEGA2] * p[P.OMEGA2]
    mu = p[P.MU]
    kap = p[P.KAPPA]
    be = p[P.BETA]
    mui = 1.0 / (1.0 + mu)
    c[C_MUI] = mui
    c[C_MUF] = 1.0 / (1.0 + 1.0 / mu)
    c[C_W1SQ] = w1s
    c[C_W2SQ] = w2s
    oms = w1s + (w2s - w1s) * mui
    c[C_OMSQ] = oms
    c[C_OM] = math.sqrt(oms)
    c[C_D21] = w2s - w1s
    c[C_N1A] = w1s * kap
    c[C_N1B] = be * (w1s - w0 * w0)
    c[C_N2A] = w2s * kap
    c[C_N2B] = be * (w2s - w0 * w0)
    c[C_N12A] = oms * kap
    c[C_N12B] = be * (oms - w0 * w0)
    q = w0 * p[P.SECTION] / (2.0 * math.pi)
    qi = math.floor(q + 0.5)
    c[C_Q] = q
    c[C_EXACT] = 1.0 if (qi >= 1.0 and abs(q - qi) <= 1e-9 * q) else 0.0
    smooth = (p[P.SIGMA1] == 0.0 and p[P.SIGMA2] == 0.0 and p[P.F1] == 0.0
              and p[P.F2] == 0.0)
    c[C_SMOOTH] = 1.0 if smooth else 0.0
    same_f = (p[P.F1] == p[P.F2] and (p[P.F1] == 0.0 or (p[P.OMF1] == p[P.OMF2]
                                                          and p[P.PHI1] == p[P.PHI2])))
    c[C_HZERO] = 1.0 if (w1s == w2s and p[P.SIGMA1] == p[P.SIGMA2] and same_f) else 0.0
    return c


@jit
def constants_tuple(c):
    """The per-point constants of ``derive`` as a tuple of NC floats."""
    return (c[0], c[1], c[2], c[3], c[4], c[5], c[6], c[7], c[8], c[9], c[10], c[11], c[12],
            c[13], c[14], c[15], c[16])


@jit
def oscillators(p, c):
    """Rows of ``flow`` parameter vectors (and their derived constants) for z, u and the
    stuck pair, so every flight is the closed form of ``numerics.oscillator`` (eq 4).

    A stuck pair obeys (M + m) z'' = M (f1 - 2 sigma1 z' - omega1^2 z)
    + m (f2 - 2 sigma2 z' - omega2^2 z): damping Sigma = (mu sigma1 + sigma2)/(mu + 1),
    frequency Omega^2 = (mu omega1^2 + omega2^2)/(mu + 1), forcing mu f1/(mu + 1)
    (row RP) plus f2/(mu + 1) (row RPB).  Q[RZ, K] = omega1, Q[RU, K] = omega2 and
    Q[RP, K] = Omega exactly, so the undamped path is unchanged bit for bit.
    """
    Q = np.zeros((NROW, FP.NPARAM))
    D = np.zeros((NROW, NDERIVED))
    mui = c[C_MUI]
    muf = c[C_MUF]
    for r in range(NROW):
        Q[r, FP.OMEGA] = p[P.OMEGA0]
        Q[r, FP.OBSTACLE] = SINE           # a smooth row: the oscillator alone
        Q[r, FP.F_OMEGA] = 1.0
    Q[RZ, FP.SIGMA] = p[P.SIGMA1]
    Q[RZ, FP.K] = p[P.OMEGA1]
    Q[RZ, FP.F_AMP] = p[P.F1]
    Q[RZ, FP.F_OMEGA] = p[P.OMF1]
    Q[RU, FP.SIGMA] = p[P.SIGMA2]
    Q[RU, FP.K] = p[P.OMEGA2]
    Q[RU, FP.F_AMP] = p[P.F2]
    Q[RU, FP.F_OMEGA] = p[P.OMF2]
    sig_p = p[P.SIGMA1] + (p[P.SIGMA2] - p[P.SIGMA1]) * mui
    Q[RP, FP.SIGMA] = sig_p
    Q[RP, FP.K] = c[C_OM]
    Q[RPB, FP.SIGMA] = sig_p
    Q[RPB, FP.K] = c[C_OM]
    Q[RP, FP.F_AMP] = p[P.F1] * muf
    Q[RP, FP.F_OMEGA] = p[P.OMF1]
    Q[RPB, FP.F_AMP] = p[P.F2] * mui
    Q[RPB, FP.F_OMEGA] = p[P.OMF2]
    forcing_phases(p, Q, np.int64(0))
    for r in range(NROW):
        d = osc_derive(Q[r])
        for k in range(NDERIVED):      # element by element: a row assignment compiles numba's
            D[r, k] = d[k]             # shape-mismatch message (3 s of the first compile)
    return Q, D


@jit
def forcing_phases(p, Q, n):
    """Forcing phases phi + Omega n S (mod 2 pi) at the start of section n (time is local)."""
    Sp = p[P.SECTION]
    x = n * (p[P.OMF1] * Sp / (2.0 * math.pi))
    a = p[P.PHI1] + 2.0 * math.pi * (x - math.floor(x))
    x = n * (p[P.OMF2] * Sp / (2.0 * math.pi))
    b = p[P.PHI2] + 2.0 * math.pi * (x - math.floor(x))
    Q[RZ, FP.F_PHI] = a
    Q[RP, FP.F_PHI] = a
    Q[RU, FP.F_PHI] = b
    Q[RPB, FP.F_PHI] = b


@jit
def _harmonic(Q, r, t):
    F = Q[r, FP.F_AMP]
    if F == 0.0:
        return 0.0, 0.0, 0.0, 0.0
    W = Q[r, FP.F_OMEGA]
    th = W * t + Q[r, FP.F_PHI]
    cs = math.cos(th)
    sn = math.sin(th)
    return F * cs, -F * W * sn, -F * W * W * cs, F * W * W * W * sn


@jit
def fdrv(Q, r, t):
    """Forcing of row r (both harmonics for the pair) and its first three derivatives."""
    f0, f1, f2, f3 = _harmonic(Q, r, t)
    if r == RP:
        g0, g1, g2, g3 = _harmonic(Q, RPB, t)
        return f0 + g0, f1 + g1, f2 + g2, f3 + g3
    return f0, f1, f2, f3


@jit
def fsize(Q, r, n):
    """Bound of the n-th derivative of row r's forcing: the sum of |F| Omega^n."""
    b = abs(Q[r, FP.F_AMP]) * Q[r, FP.F_OMEGA] ** n
    if r == RP:
        b += abs(Q[RPB, FP.F_AMP]) * Q[RPB, FP.F_OMEGA] ** n
    return b


@jit
def part(Q, D, r, t):
    """Particular solution of row r at local time t (both harmonics for the pair)."""
    x, v = particular(Q[r], D[r], t)
    if r == RP:
        x2, v2 = particular(Q[RPB], D[RPB], t)
        x += x2
        v += v2
    return x, v


@jit
def fly(c, Q, D, r, tau_ref, x0, v0, s):
    """Closed-form flight of row r: (x, x') a time s after the state (x0, v0) at local
    time tau_ref.  Undamped and unforced (eq 73) it is ``harm``; otherwise the closed
    forms of ``numerics.oscillator`` (homogeneous part carried, particular part added)."""
    if c[C_SMOOTH] == 1.0:
        return harm(x0, v0, Q[r, FP.K], s)
    xp0, vp0 = part(Q, D, r, tau_ref)
    xh, vh = homogeneous(Q[r], D[r], x0 - xp0, v0 - vp0, s)
    xp, vp = part(Q, D, r, tau_ref + s)
    return xh + xp, vh + vp


@jit
def accel(Q, r, x, v, t):
    """Second and third derivatives of row r at (x, v, t): a = -2 sigma v - k^2 x + f(t)
    (eq 4), j = -2 sigma a - k^2 v + f'(t)."""
    sig = Q[r, FP.SIGMA]
    k2 = Q[r, FP.K] * Q[r, FP.K]
    f0, f1, _, _ = fdrv(Q, r, t)
    a = -2.0 * sig * v - k2 * x + f0
    return a, -2.0 * sig * a - k2 * v + f1


@jit
def dbound(Q, D, r, tau_ref, x0, v0, n):
    """Bound of the n-th derivative of row r over its whole flight from (x0, v0) at tau_ref
    (``oscillator.deriv_bound``, plus the pair's second particular solution)."""
    xp0, vp0 = part(Q, D, r, tau_ref)
    b = deriv_bound(Q[r], D[r], x0 - xp0, v0 - vp0, n)
    if r == RP and Q[RPB, FP.F_AMP] != 0.0:
        b += math.sqrt(D[RPB, D_X] ** 2 + D[RPB, D_Y] ** 2) * Q[RPB, FP.F_OMEGA] ** n
    return b


@jit
def wall_force(p, Q, r, tau, ph):
    """Contact force per unit mass carrying a stuck row r along the wall, with two
    derivatives: N = w'' + 2 sigma w' + k^2 w - f(t) (eq 4 with x = w, eq 72)."""
    w0 = p[P.OMEGA0]
    b = p[P.BETA]
    th = w0 * tau + ph
    sn = math.sin(th)
    cs = math.cos(th)
    sig = Q[r, FP.SIGMA]
    k2 = Q[r, FP.K] * Q[r, FP.K]
    f0, f1, f2, _ = fdrv(Q, r, tau)
    w = p[P.KAPPA] + b * sn
    w1 = b * w0 * cs
    w2 = -b * w0 * w0 * sn
    w3 = -w0 * w0 * w1
    w4 = -w0 * w0 * w2
    return (w2 + 2.0 * sig * w1 + k2 * w - f0, w3 + 2.0 * sig * w2 + k2 * w1 - f1,
            w4 + 2.0 * sig * w3 + k2 * w2 - f2)


@jit
def wall_force_bounds(p, Q, r):
    """Bounds of |N''| and |N'''| of ``wall_force`` (row r)."""
    w0 = p[P.OMEGA0]
    k2 = Q[r, FP.K] * Q[r, FP.K]
    a = abs(p[P.BETA]) * (w0 * w0 + 2.0 * Q[r, FP.SIGMA] * w0 + k2)
    return a * w0 * w0 + fsize(Q, r, 2), a * w0 * w0 * w0 + fsize(Q, r, 3)


@jit
def pair_force(c, p, Q, x, xv, xa, xj, tau):
    """h = 2 (sigma2 - sigma1) z' + (omega2^2 - omega1^2) z + f1 - f2 and two derivatives,
    at (z, z', z'', z''') and local time tau.

    With u = z stuck, m u'' = -m (2 sigma2 u' + omega2^2 u - f2) + lambda2 and the pair's
    equation (``oscillators``) give lambda2/m = mu/(mu + 1) h; undamped and unforced,
    h = (omega2^2 - omega1^2) z (module docstring).  Along free flights h is also the
    forcing of the gap: g2'' + 2 sigma2 g2' + omega2^2 g2 = -h.
    """
    ds = 2.0 * (p[P.SIGMA2] - p[P.SIGMA1])
    d21 = c[C_D21]
    g0, g1, g2, _ = fdrv(Q, RU, tau)
    h0, h1, h2, _ = fdrv(Q, RZ, tau)
    return (ds * xv + d21 * x + (h0 - g0), ds * xa + d21 * xv + (h1 - g1),
            ds * xj + d21 * xa + (h2 - g2))


@jit
def forces_at(c, p, Q, tau, ph, sn):
    """Wall-borne contact forces N1 (z), N2 (u), N12 (stuck pair) at local time tau."""
    if c[C_SMOOTH] == 1.0:
        return forces(c, sn)
    n1, _, _ = wall_force(p, Q, RZ, tau, ph)
    n2, _, _ = wall_force(p, Q, RU, tau, ph)
    n12, _, _ = wall_force(p, Q, RP, tau, ph)
    return n1, n2, n12


@jit
def pforce(c, p, Q, tau, z, y):
    """Contact force of u on z (h of ``pair_force``) with the pair at (z, y)."""
    if c[C_SMOOTH] == 1.0:
        return c[C_D21] * z
    a, j = accel(Q, RP, z, y, tau)
    h, _, _ = pair_force(c, p, Q, z, y, a, j, tau)
    return h


@jit
def halfp(c, Q, D, r):
    """Window after a release of row r over which the freed gap stays >= 0 while the
    force separating it keeps its sign: pi/omega_d, where the impulse response
    e^{-sigma s} sin(omega_d s)/omega_d of g'' + 2 sigma g' + k^2 g is >= 0 (critical
    or over-damping: >= 0 for all s; pi/k is used)."""
    if c[C_SMOOTH] == 1.0 or D[r, D_REGIME] != 0.0:
        return math.pi / Q[r, FP.K]
    return math.pi / D[r, D_WD]


@jit
def section_phase(c, n):
    """Wall phase omega0 n S (mod 2 pi) at the start of section n (0 for whole periods)."""
    if c[C_EXACT] == 1.0:
        return 0.0
    x = n * c[C_Q]
    return 2.0 * math.pi * (x - math.floor(x))


@jit
def harm(x0, v0, f, s):
    """Harmonic flight x'' + f^2 x = 0: (x, x') a time s after (x0, v0)."""
    cs = math.cos(f * s)
    sn = math.sin(f * s)
    return x0 * cs + (v0 / f) * sn, v0 * cs - x0 * f * sn


@jit
def wall(p, tau, ph):
    """w, w', w'' and sin(omega0 t) at local time tau of a section with phase ph (eq 72)."""
    w0 = p[P.OMEGA0]
    th = w0 * tau + ph
    sn = math.sin(th)
    cs = math.cos(th)
    b = p[P.BETA]
    return p[P.KAPPA] + b * sn, b * w0 * cs, -b * w0 * w0 * sn, sn


@jit
def forces(c, sn):
    """Wall-borne contact forces per unit mass: N1, N2, N12 at sin(omega0 t) = sn."""
    return (c[C_N1A] + c[C_N1B] * sn, c[C_N2A] + c[C_N2B] * sn, c[C_N12A] + c[C_N12B] * sn)


# --- the undamped search's constants (``search_constants``): a tuple of 7 floats ---------
X_W0 = 0      # omega0
X_W1 = 1      # omega1
X_W2 = 2      # omega2
X_OM = 3      # Omega, the stuck pair's frequency
X_BETA = 4
X_KAPPA = 5
X_D21 = 6     # omega2^2 - omega1^2


@jit
def search_constants(p, c):
    """The constants the undamped searches read (X_*), as a tuple: a call passes these 7
    values, not the whole parameter and constant tuples."""
    return (p[P.OMEGA0], p[P.OMEGA1], p[P.OMEGA2], c[C_OM], p[P.BETA], p[P.KAPPA], c[C_D21])


@jit_inline
def freq(x, r):
    """Undamped frequency of row r: omega1 (RZ), omega2 (RU), Omega (RP), as Q[r, K] of
    ``oscillators`` (x: ``search_constants``)."""
    if r == RZ:
        return x[X_W1]
    if r == RU:
        return x[X_W2]
    return x[X_OM]


@jit_inline
def evaluate(kind, x, ph, tau_ref, a0, a1, a2, a3, s):
    """Value f, slope f' and forcing F = f'' + f0^2 f of the searched function at s,
    undamped and unforced, with f0 the frequency of ``kind_bounds`` (the Sturm
    comparison of the module docstring); with damping or forcing see ``_evaluate_g``.
    x: ``search_constants``.
    """
    if kind == K_GP:
        z, y = harm(a0, a1, x[X_W1], s)
        u, v = harm(a2, a3, x[X_W2], s)
        return u - z, v - y, -x[X_D21] * z
    if kind == K_HM:
        xh, v = harm(a0, a1, freq(x, int(a2)), s)
        return a3 * xh, a3 * v, 0.0
    w0 = x[X_W0]
    th = w0 * (tau_ref + s) + ph
    sn = math.sin(th)
    cs = math.cos(th)
    if kind == K_WF:
        return a2 * (a0 + a1 * sn), a2 * a1 * w0 * cs, a2 * a0 * w0 * w0
    # K_GW
    f = freq(x, int(a2))
    xh, v = harm(a0, a1, f, s)
    b = x[X_BETA]
    w = x[X_KAPPA] + b * sn
    wp = b * w0 * cs
    return xh - w, v - wp, -f * f * x[X_KAPPA] - b * (f * f - w0 * w0) * sn


@jit
def _evaluate_g(kind, p, c, Q, D, ph, tau_ref, a0, a1, a2, a3, s):
    """(f, f', f'') of the searched function with damping or forcing (eq 4 per row).

    K_GW: x - w, x on row a2; K_GP: u - z; K_WF: a2 N of ``wall_force`` (row a3);
    K_HM: a3 h of ``pair_force`` along the flight of row a2.
    """
    t = tau_ref + s
    if kind == K_GP:
        z, y = fly(c, Q, D, RZ, tau_ref, a0, a1, s)
        u, v = fly(c, Q, D, RU, tau_ref, a2, a3, s)
        az, _ = accel(Q, RZ, z, y, t)
        au, _ = accel(Q, RU, u, v, t)
        return u - z, v - y, au - az
    if kind == K_WF:
        n0, n1, n2 = wall_force(p, Q, int(a3), t, ph)
        return a2 * n0, a2 * n1, a2 * n2
    r = int(a2)
    x, v = fly(c, Q, D, r, tau_ref, a0, a1, s)
    a, j = accel(Q, r, x, v, t)
    if kind == K_HM:
        h0, h1, h2 = pair_force(c, p, Q, x, v, a, j, t)
        return a3 * h0, a3 * h1, a3 * h2
    w, wp, wpp, _ = wall(p, t, ph)
    return x - w, v - wp, a - wpp


@jit_inline
def kind_bounds(kind, x, a0, a1, a2, a3):
    """(f0, F_min, F_max, m1) of the searched function over the whole flight, undamped
    and unforced (module docstring; x: ``search_constants``); with damping or forcing see
    ``_kind_bounds_g``."""
    w0 = x[X_W0]
    if kind == K_GP:
        w1 = x[X_W1]
        az = math.sqrt(a0 * a0 + (a1 / w1) ** 2)
        q = abs(x[X_D21]) * az
        return x[X_W2], -q, q, q * w1
    if kind == K_HM:
        return freq(x, int(a2)), 0.0, 0.0, 0.0
    if kind == K_WF:
        F = a2 * a0 * w0 * w0
        return w0, F, F, 0.0
    f = freq(x, int(a2))
    q = abs(x[X_BETA] * (f * f - w0 * w0))
    base = -f * f * x[X_KAPPA]
    return f, base - q, base + q, q * w0


@jit
def _kind_bounds_g(kind, p, c, Q, D, tau_ref, a0, a1, a2, a3):
    """Bounds (0, -M2, M2, M3) with damping or forcing: M2, M3 bound the second and
    third derivatives over the whole flight (``oscillator.deriv_bound``, wall and
    forcing derivative sizes)."""
    w0 = p[P.OMEGA0]
    if kind == K_GP:
        m2 = dbound(Q, D, RZ, tau_ref, a0, a1, 2) + dbound(Q, D, RU, tau_ref, a2, a3, 2)
        m3 = dbound(Q, D, RZ, tau_ref, a0, a1, 3) + dbound(Q, D, RU, tau_ref, a2, a3, 3)
    elif kind == K_WF:
        m2, m3 = wall_force_bounds(p, Q, int(a3))
    elif kind == K_HM:
        r = int(a2)
        ds = 2.0 * abs(p[P.SIGMA2] - p[P.SIGMA1])
        d21 = abs(c[C_D21])
        m2 = (ds * dbound(Q, D, r, tau_ref, a0, a1, 3)
              + d21 * dbound(Q, D, r, tau_ref, a0, a1, 2) + fsize(Q, RU, 2) + fsize(Q, RZ, 2))
        m3 = (ds * dbound(Q, D, r, tau_ref, a0, a1, 4)
              + d21 * dbound(Q, D, r, tau_ref, a0, a1, 3) + fsize(Q, RU, 3) + fsize(Q, RZ, 3))
    else:
        b = abs(p[P.BETA])
        r = int(a2)
        m2 = dbound(Q, D, r, tau_ref, a0, a1, 2) + b * w0 * w0
        m3 = dbound(Q, D, r, tau_ref, a0, a1, 3) + b * w0 * w0 * w0
    return 0.0, -m2, m2, m3


@jit
def sturm_root(g, gp, f, F):
    """First root in [0, pi/f) of y'' + f^2 y = F, y(0) = g >= 0, y'(0) = gp; inf if none.

    With t = tan(f h/2): y (1 + t^2) = g + 2 (gp/f) t + (2 F/f^2 - g) t^2.  For f = 0
    the limit y = g + gp h + F h^2/2 (``roots.quad_first_root``).
    """
    if g < 0.0:
        g = 0.0
    if f == 0.0:
        return quad_first_root(g, gp, F)
    c = F / (f * f)
    t = quad_first_root(g, 2.0 * gp / f, 2.0 * (2.0 * c - g))
    if t == math.inf:
        return math.inf
    return 2.0 * math.atan(t) / f


@jit_inline
def sturm_t(g, gp2, ff, F):
    """t = tan(f h/2) of ``sturm_root``'s root h, from g >= 0, gp2 = 2 gp/f and ff = f^2
    (f > 0): the same operations, so half_angle(t, f) is sturm_root's value bit for bit."""
    c = F / ff
    return quad_first_root(g, gp2, 2.0 * (2.0 * c - g))


@jit_inline
def atan_floor(t):
    """A lower bound of atan(t) for t >= 0, below libm's rounded value (NaN for NaN): the
    larger of 3 t/(3 + t^2) (atan minus it has the derivative 4 t^4/((1 + t^2)(3 + t^2)^2)
    >= 0) and pi/2 - 1/t (atan(1/t) <= 1/t), less 1e-12 relative.  With it the values
    2 atan(t)/f of ``sturm_root`` are bounded from below by the same rounded operations
    (each monotone), so a test it settles is settled for the exact value too."""
    if t <= 1.37:
        a = 3.0 * t / (3.0 + t * t)
    else:
        a = 1.5707963267948966 - 1.0 / t
    return a * (1.0 - 1e-12)


@jit_inline
def half_angle(t, f):
    """h = 2 atan(t)/f (inf for t = inf), the last step of ``sturm_root``."""
    if t == math.inf:
        return math.inf
    return 2.0 * math.atan(t) / f


@jit
def first_root(kind, x, ph, tau_ref, a0, a1, a2, a3, s0, s_end, tol):
    """Certified first root of ``kind`` on [s0, s_end] (module docstring).

    Returns (code, s): FOUND with the root (lower end of a bracket narrower than
    ``tol``), NONE with s_end, FAIL when the step budget ran out or a value is
    not finite.  At s0 a value f <= 0 counts as a root only when f is moving
    into the contact (f' < 0, or f' = 0 and f'' < 0); otherwise it is the point
    just after an impact or a release and is skipped.
    Undamped and unforced (``evaluate``, ``kind_bounds``; x: ``search_constants``, no
    array is passed; every f0 there is a frequency > 0); with damping or forcing see
    ``first_root_g``.
    """
    if s0 >= s_end:
        return NONE, s_end
    f0, Fmin, Fmax, m1 = kind_bounds(kind, x, a0, a1, a2, a3)
    half = math.pi / f0 if f0 > 0.0 else math.inf
    s = s0
    g, gp, F = evaluate(kind, x, ph, tau_ref, a0, a1, a2, a3, s)
    if not (g == g and gp == gp and F == F):
        return FAIL, s
    if g <= 0.0:
        gpp = F - f0 * f0 * g
        if gp < 0.0 or (gp == 0.0 and gpp < 0.0):
            return FOUND, s
    local = m1 > 0.0
    ff = f0 * f0
    for _ in range(MAXIT):
        rest = s_end - s
        # sturm_root(g, gp, f0, F) = 2 atan(t)/f0 of t = sturm_t(F): the parts common to
        # the roots below are formed once, and an arc tangent is taken only where the
        # value is used, i.e. where the lower bound atan_floor does not settle the test
        # it enters (every step below is the one sturm_root's values take, bit for bit)
        gc = g
        if gc < 0.0:
            gc = 0.0
        gp2 = 2.0 * gp / f0
        t_lo = sturm_t(gc, gp2, ff, Fmin)
        if t_lo != math.inf and half >= rest and 2.0 * atan_floor(t_lo) / f0 >= rest:
            return NONE, s_end        # hlo >= rest for certain
        hlo_raw = half_angle(t_lo, f0)
        hlo = hlo_raw
        if hlo > half:
            hlo = half
        if hlo >= rest:
            return NONE, s_end
        t_up = sturm_t(gc, gp2, ff, Fmax)
        hup = math.inf
        lazy_up = t_up != math.inf     # hup = half_angle(t_up, f0), not taken yet
        if local:
            t_F = sturm_t(gc, gp2, ff, F)
            wide = False
            if t_F != math.inf:
                # H >= Hl: when Hl already puts F -+ m1 H beyond [Fmin, Fmax], the local
                # bounds are the global ones (h1 = hlo, h2 = hup) and H is not needed
                Hl = 1.25 * (2.0 * atan_floor(t_F) / f0)
                if Hl > half:
                    Hl = half
                if Hl > rest:
                    Hl = rest
                wide = Hl > hlo and F - m1 * Hl <= Fmin and F + m1 * Hl >= Fmax
            if not wide:
                H = 1.25 * half_angle(t_F, f0)
                if H > half:
                    H = half
                if H > rest:
                    H = rest
                if H > hlo:
                    Flo = F - m1 * H
                    if Flo < Fmin:
                        Flo = Fmin
                    if Flo == Fmin:
                        h1 = hlo_raw
                    else:
                        h1 = half_angle(sturm_t(gc, gp2, ff, Flo), f0)
                    if h1 >= H:
                        h1 = H            # no root in [s, s + H]
                        if H == rest:
                            return NONE, s_end
                    if h1 > hlo:
                        hlo = h1
                    Fhi = F + m1 * H
                    if Fhi < Fmax:        # Fhi = Fmax: h2 = hup, which stays
                        t2 = sturm_t(gc, gp2, ff, Fhi)
                        if 2.0 * atan_floor(min(t2, t_up)) / f0 - hlo > tol:
                            # hup - hlo > tol for certain, be hup h2 or the global one:
                            # the bracket stays open and neither value is needed
                            hup = math.inf
                            lazy_up = False
                        else:
                            h2 = half_angle(t2, f0)
                            if (h2 <= H and lazy_up
                                    and not t_up - t2 > 1e-15 * (1.0 + t_up * t_up)
                                    and not (h2 - hlo <= tol and h2 <= rest)):
                                # the arc tangents of t2 < t_up may round to either
                                # order, and the order decides the test below
                                hup = half_angle(t_up, f0)
                                lazy_up = False
                            # otherwise h2 <= hup for certain, or both pass the test
                            if h2 <= H and (lazy_up or h2 < hup):
                                hup = h2
                                lazy_up = False
        if lazy_up:
            if 2.0 * atan_floor(t_up) / f0 - hlo > tol:
                hup = math.inf        # hup - hlo > tol for certain
            else:
                hup = half_angle(t_up, f0)
        if hup - hlo <= tol and hup <= rest:
            return FOUND, s + hlo
        if hlo < tol:
            gpp = F - f0 * f0 * g
            if gp < 0.0 or (gpp < 0.0 and gp <= 0.0):
                return FOUND, s + hlo
            s = s + tol
            if s >= s_end:
                return NONE, s_end
        else:
            s = s + hlo
        g, gp, F = evaluate(kind, x, ph, tau_ref, a0, a1, a2, a3, s)
        if not (g == g and gp == gp):
            return FAIL, s
        if g <= 0.0:
            return FOUND, s
    return FAIL, s


@jit
def first_root_g(kind, p, c, Q, D, ph, tau_ref, a0, a1, a2, a3, s0, s_end, tol):
    """``first_root`` with damping or forcing: the same steps with f0 = 0 and the bounds of
    ``_kind_bounds_g`` (the quadratic search of ``roots``), values from ``_evaluate_g``."""
    if s0 >= s_end:
        return NONE, s_end
    f0, Fmin, Fmax, m1 = _kind_bounds_g(kind, p, c, Q, D, tau_ref, a0, a1, a2, a3)
    half = math.pi / f0 if f0 > 0.0 else math.inf
    s = s0
    g, gp, F = _evaluate_g(kind, p, c, Q, D, ph, tau_ref, a0, a1, a2, a3, s)
    if not (g == g and gp == gp and F == F):
        return FAIL, s
    if g <= 0.0:
        gpp = F - f0 * f0 * g
        if gp < 0.0 or (gp == 0.0 and gpp < 0.0):
            return FOUND, s
    local = m1 > 0.0
    for _ in range(MAXIT):
        rest = s_end - s
        hlo = sturm_root(g, gp, f0, Fmin)
        if hlo > half:
            hlo = half
        if hlo >= rest:
            return NONE, s_end
        hup = sturm_root(g, gp, f0, Fmax)
        if local:
            H = 1.25 * sturm_root(g, gp, f0, F)
            if H > half:
                H = half
            if H > rest:
                H = rest
            if H > hlo:
                Flo = F - m1 * H
                if Flo < Fmin:
                    Flo = Fmin
                h1 = sturm_root(g, gp, f0, Flo)
                if h1 >= H:
                    h1 = H            # no root in [s, s + H]
                    if H == rest:
                        return NONE, s_end
                if h1 > hlo:
                    hlo = h1
                Fhi = F + m1 * H
                if Fhi > Fmax:
                    Fhi = Fmax
                h2 = sturm_root(g, gp, f0, Fhi)
                if h2 <= H and h2 < hup:
                    hup = h2
        if hup - hlo <= tol and hup <= rest:
            return FOUND, s + hlo
        if hlo < tol:
            gpp = F - f0 * f0 * g
            if gp < 0.0 or (gpp < 0.0 and gp <= 0.0):
                return FOUND, s + hlo
            s = s + tol
            if s >= s_end:
                return NONE, s_end
        else:
            s = s + hlo
        g, gp, F = _evaluate_g(kind, p, c, Q, D, ph, tau_ref, a0, a1, a2, a3, s)
        if not (g == g and gp == gp):
            return FAIL, s
        if g <= 0.0:
            return FOUND, s
    return FAIL, s


@jit_inline
def state_at(mode, smooth, p, c, Q, D, ph, tau_ref, za, ya, ua, va, s):
    """(z, y, u, v) a time s after the reference of the current mode (``smooth``: undamped
    and unforced, the frequencies from the tuples)."""
    if smooth:
        if mode == FREE:
            z, y = harm(za, ya, p[P.OMEGA1], s)
            u, v = harm(ua, va, p[P.OMEGA2], s)
            return z, y, u, v
        if mode == WALL:
            w, wp, _, _ = wall(p, tau_ref + s, ph)
            u, v = harm(ua, va, p[P.OMEGA2], s)
            return w, wp, u, v
        if mode == PAIR:
            z, y = harm(za, ya, c[C_OM], s)
            return z, y, z, y
        w, wp, _, _ = wall(p, tau_ref + s, ph)
        return w, wp, w, wp
    if mode == FREE:
        z, y = fly(c, Q, D, RZ, tau_ref, za, ya, s)
        u, v = fly(c, Q, D, RU, tau_ref, ua, va, s)
        return z, y, u, v
    if mode == WALL:
        w, wp, _, _ = wall(p, tau_ref + s, ph)
        u, v = fly(c, Q, D, RU, tau_ref, ua, va, s)
        return w, wp, u, v
    if mode == PAIR:
        z, y = fly(c, Q, D, RP, tau_ref, za, ya, s)
        return z, y, z, y
    w, wp, _, _ = wall(p, tau_ref + s, ph)
    return w, wp, w, wp


MAX_BUDGET = 2 ** 62   # the largest section budget (int64 with room to count past it)


@jit
def budget_sections(p, sections):
    """The time budget of a run in sections (``run.max_periods``): ``sections`` units, each
    the slower of the section period S and the slower particle's natural period
    2 pi / min(omega1, omega2) (eq 73).  When the wall is fast (omega0 large, S = 2 pi /
    omega0 by default) a flight between impacts spans many sections, and the budget grows
    by 2 pi / (min(omega1, omega2) S), rounded up (at most MAX_BUDGET)."""
    scale = 2.0 * math.pi / (min(p[P.OMEGA1], p[P.OMEGA2]) * p[P.SECTION])
    if not scale > 1.0:
        return sections
    x = math.ceil(sections * scale)
    if x >= MAX_BUDGET:
        return np.int64(MAX_BUDGET)
    return np.int64(x)


@jit
def stack_floor(c):
    """A certified lower bound over all time of the contact forces that hold the stack
    z = u = w (mode ALL): N12 (the pair on the wall) and N2 (u on z), each A + B sin(omega0 t)
    undamped and unforced (C_SMOOTH), less a relative margin of 1e-12; -inf otherwise.
    Where it is > 0 neither ever changes sign and the wall has no corner: a stack is stuck
    for good."""
    if c[C_SMOOTH] != 1.0:
        return -math.inf
    f12 = c[C_N12A] - abs(c[C_N12B]) - 1e-12 * (abs(c[C_N12A]) + abs(c[C_N12B]))
    f2 = c[C_N2A] - abs(c[C_N2B]) - 1e-12 * (abs(c[C_N2A]) + abs(c[C_N2B]))
    return min(f12, f2)


@jit
def _close(o_zu, o_corner, lo, hi):
    """Offsets still waiting for a next w-z impact: keep the previous one, NaN if none
    (``analysis.close_corner_offsets``)."""
    close_corner_offsets(o_zu[:, ZU_OFF], o_corner, lo, hi)


@jit_inline
def wall_window(c, Q, D, r, na, nb):
    """The window of a gap freed from the wall (a release, or a slow separation while the
    wall does not push): row r's gap to the wall stays >= 0 while its contact force
    N = na + nb sin(omega0 t) < 0, for at most ``halfp``.  Returns the search (kind,
    a0, a1, a2, a3, end) of N's sign change."""
    return K_WF, na, nb, -1.0, float(r), halfp(c, Q, D, r)


@jit_inline
def pair_window(c, Q, D, z, y, hsgn):
    """The window of u freed from z at (z, y): g2 = u - z stays >= 0 while the pair's
    contact force h (``pair_force``) < 0, for at most ``halfp`` of u.  Returns the
    search (kind, a0, a1, a2, a3, end) of h's sign change along z's flight."""
    return K_HM, z, y, float(RZ), -hsgn, halfp(c, Q, D, RU)


@jit_inline
def release(ev, p, c, Q, D, ph, tau, tau_ref, se, za, ya, ua, va, hsgn):
    """A release event ev (EV_REL_*) at local time tau = tau_ref + se.

    Returns (mode, z, y, u, v, target, window): the new mode and reference state, and the
    window search of the freed gap (``wall_window``, ``pair_window``) whose result is the
    start of the gap search 1 (z - w) or 2 (u - z) given by target.
    """
    if ev == EV_REL_Z:
        # z leaves the wall: g1 = z - w >= 0 while N1 < 0, for at most pi/omega1
        w, wp, _, _ = wall(p, tau, ph)
        u, v = fly(c, Q, D, RU, tau_ref, ua, va, se)
        return FREE, w, wp, u, v, 1, wall_window(c, Q, D, RZ, c[C_N1A], c[C_N1B])
    if ev == EV_REL_PAIR:
        # u leaves z where (omega2^2 - omega1^2) z turns negative; afterwards
        # g2'' + omega2^2 g2 = -(omega2^2 - omega1^2) z_free >= 0 for a while
        z, y = fly(c, Q, D, RP, tau_ref, za, ya, se)
        return FREE, z, y, z, y, 2, pair_window(c, Q, D, z, y, hsgn)
    w, wp, _, _ = wall(p, tau, ph)
    if ev == EV_REL_U:
        # u leaves the stuck stack: z stays on the wall
        return WALL, za, ya, w, wp, 2, wall_window(c, Q, D, RU, c[C_N2A], c[C_N2B])
    # EV_REL_STACK: the pair leaves the wall together
    return PAIR, w, wp, ua, va, 1, wall_window(c, Q, D, RP, c[C_N12A], c[C_N12B])


@jit_inline
def pair_or_free(c, p, Q, tau, u_stick, z, y_out, v_out, ua, va):
    """After a z-u impact at height z: u stays on z (PAIR, with the pair's common velocity)
    when it is slow enough to stick and z pushes it, else both fly (FREE).  Returns (mode,
    z, y, u, v) of the new reference (u, v unchanged for PAIR)."""
    if u_stick:
        y_pair = c[C_MUF] * y_out + c[C_MUI] * v_out
        if pforce(c, p, Q, tau, z, y_pair) > 0.0:
            return PAIR, z, y_pair, ua, va
    return FREE, z, y_out, z, v_out


@jit
def run_one(p_row, ints, z0, y0, u0, v0, o_zu, o_corner, o_wz, o_sec, final):
    """Integrate one item from (t, z, y, u, v) = (0, z0, y0, u0, v0); fill its rows.

    See the module docstring for the output layout, the event policy and the
    sticking rules.  Returns the status code; ``STOPPED`` (outputs incomplete) when the
    sweep's control (``ints[I_CONTROL]``, ``_jit.Control``) asks it to stop, which it reads
    every POLL_EVERY passes of its loop (each pass crosses a section or meets an event).
    """
    # the parameters and per-point constants as tuples: values, so the many calls below
    # pass them without atomic reference counting
    p = P.as_tuple(p_row)
    c = constants_tuple(derive(p_row))
    Q, D = oscillators(p, c)
    xs = search_constants(p, c)
    smooth = c[C_SMOOTH] == 1.0
    # sign and vanishing of the pair's contact force h (``pair_force``)
    hsgn = (1.0 if c[C_D21] > 0.0 else -1.0) if smooth else 1.0
    hzero = c[C_D21] == 0.0 if smooth else c[C_HZERO] == 1.0
    tol = p[P.TOL]
    chatter = p[P.CHATTER]
    escape = p[P.ESCAPE]
    Sper = p[P.SECTION]
    r1 = p[P.R1]
    r2 = p[P.R2]
    mu = p[P.MU]
    w1 = p[P.OMEGA1]
    w2 = p[P.OMEGA2]
    om = c[C_OM]
    transient = ints[P.I_TRANSIENT]
    record = ints[P.I_RECORD]
    max_events = ints[P.I_MAX_EVENTS]
    max_periods = budget_sections(p, ints[P.I_MAX_PERIODS])
    # the sweep's control (0: none): its stop flag is read every POLL_EVERY passes of the loop
    control = ints[P.I_CONTROL]
    passes = 0
    stack_forever = stack_floor(c) > 0.0
    need = transient + record
    cap_wz = o_wz.shape[0]
    for k in range(4):
        final[k] = math.nan

    if not (z0 == z0 and y0 == y0 and u0 == u0 and v0 == v0) or (
            abs(z0) == math.inf or abs(y0) == math.inf or abs(u0) == math.inf
            or abs(v0) == math.inf):
        return S.NONFINITE
    wstart, _, _, _ = wall(p, 0.0, 0.0)
    if z0 < wstart or u0 < z0:
        return S.BELOW_OBSTACLE

    n = np.int64(0)
    ph, tau_ref = 0.0, 0.0
    mode = FREE
    za, ya, ua, va = z0, y0, u0, v0          # the reference state
    s1s, s2s = 0.0, 0.0
    n_zu, n_wz, n_wz_rec, n_sec = 0, 0, 0, 0
    events, periods, extra = 0, 0, 0
    done = False
    has_w, n_w, tau_w = False, np.int64(0), 0.0
    pend_lo, pend_hi = 0, 0
    win_target = 0        # pending free-gap window search: 1 -> s1s, 2 -> s2s
    win_kind = K_WF
    win_a0, win_a1, win_a2, win_a3, win_end = 0.0, 0.0, 0.0, 0.0, 0.0

    while True:
        passes += 1
        if passes & (POLL_EVERY - 1) == 0 and stop_requested(control):
            return STOPPED
        rest = Sper - tau_ref
        if mode == ALL and stack_forever and not done:
            # ---- the stack stuck for good (``stack_floor``): z = u = w, y = v = w' ----------
            # every section the run would cross holds the wall's state there
            m = n + 1
            w, wp, _, _ = wall(p, 0.0, section_phase(c, m))
            final[0], final[1], final[2], final[3] = w, wp, w, wp
            while n_zu >= transient and n_sec < record:
                w, wp, _, _ = wall(p, 0.0, section_phase(c, m))
                o_sec[n_sec, SEC_T] = m * Sper
                o_sec[n_sec, SEC_Z], o_sec[n_sec, SEC_Y] = w, wp
                o_sec[n_sec, SEC_U], o_sec[n_sec, SEC_V] = w, wp
                n_sec += 1
                m += 1
            _close(o_zu, o_corner, pend_lo, pend_hi)
            return S.STUCK
        # ---- escape and finiteness of the reference state ---------------------------
        if mode == FREE:
            amp = max(math.sqrt(za * za + (ya / w1) ** 2), math.sqrt(ua * ua + (va / w2) ** 2))
        elif mode == WALL:
            amp = math.sqrt(ua * ua + (va / w2) ** 2)
        elif mode == PAIR:
            amp = math.sqrt(za * za + (ya / om) ** 2)
        else:
            amp = 0.0
        if not (amp == amp):
            _close(o_zu, o_corner, pend_lo, pend_hi)
            return S.NONFINITE
        if amp > escape:
            _close(o_zu, o_corner, pend_lo, pend_hi)
            return S.OK if done else S.ESCAPED

        # ---- a pending free-gap window (after a release or a slow separation) -------
        if win_target != 0:
            if smooth:
                code, sb = first_root(win_kind, xs, ph, tau_ref, win_a0, win_a1, win_a2, win_a3,
                                      0.0, win_end, tol)
            else:
                code, sb = first_root_g(win_kind, p, c, Q, D, ph, tau_ref, win_a0, win_a1, win_a2,
                                        win_a3, 0.0, win_end, tol)
            if win_target == 1:
                s1s = sb
            else:
                s2s = sb
            win_target = 0

        # ---- next event: search A on the window, then B up to A's root -------------------
        # FREE: A = z - w, B = u - z (up to A + tol: the triple-impact test)
        # WALL: A = N1 (release of z), B = u - w
        # PAIR: A = (omega2^2 - omega1^2) z (release of u), B = pair - w
        # ALL:  A = N12 (the pair leaves the wall), B = N2 (u leaves)
        ev = EV_SECTION
        se = rest
        simult = False
        if mode == FREE:
            kA, A0, A1, A2, A3, sA = K_GW, za, ya, float(RZ), 0.0, s1s
            kB, B0, B1, B2, B3, sB = K_GP, za, ya, ua, va, s2s
        elif mode == WALL:
            kA, A0, A1, A2, A3, sA = K_WF, c[C_N1A], c[C_N1B], 1.0, 0.0, 0.0
            kB, B0, B1, B2, B3, sB = K_GW, ua, va, float(RU), 0.0, s2s
        elif mode == PAIR:
            kA, A0, A1, A2, A3, sA = K_HM, za, ya, float(RP), hsgn, (rest if hzero else 0.0)
            kB, B0, B1, B2, B3, sB = K_GW, za, ya, float(RP), 0.0, s1s
        else:
            kA, A0, A1, A2, A3, sA = K_WF, c[C_N12A], c[C_N12B], 1.0, float(RP), 0.0
            kB, B0, B1, B2, B3, sB = K_WF, c[C_N2A], c[C_N2B], 1.0, float(RU), 0.0
        if smooth:
            codeA, tA = first_root(kA, xs, ph, tau_ref, A0, A1, A2, A3, sA, rest, tol)
        else:
            codeA, tA = first_root_g(kA, p, c, Q, D, ph, tau_ref, A0, A1, A2, A3, sA, rest, tol)
        limB = rest
        if codeA == FOUND:
            limB = min(tA + tol, rest) if mode == FREE else tA
        if smooth:
            codeB, tB = first_root(kB, xs, ph, tau_ref, B0, B1, B2, B3, sB, limB, tol)
        else:
            codeB, tB = first_root_g(kB, p, c, Q, D, ph, tau_ref, B0, B1, B2, B3, sB, limB, tol)
        fail = codeA == FAIL or codeB == FAIL
        if mode == FREE:
            if codeB == FOUND and (codeA != FOUND or tB < tA - tol):
                ev = EV_ZU
                se = tB
            elif codeA == FOUND:
                ev = EV_WZ
                se = tA
                if codeB == FOUND:
                    simult = True
                    se = min(tA, tB)
        elif codeB == FOUND:
            se = tB
            ev = EV_ZU if mode == WALL else (EV_WZ if mode == PAIR else EV_REL_U)
        elif codeA == FOUND:
            se = tA
            ev = EV_REL_Z if mode == WALL else (EV_REL_PAIR if mode == PAIR else EV_REL_STACK)
        if fail:
            _close(o_zu, o_corner, pend_lo, pend_hi)
            return S.OK if done else S.STEP_LIMIT

        # ---- section crossing -------------------------------------------------------------
        if ev == EV_SECTION:
            z, y, u, v = state_at(mode, smooth, p, c, Q, D, ph, tau_ref, za, ya, ua, va, rest)
            n += 1
            periods += 1
            tau_ref = 0.0
            ph = section_phase(c, n)
            if not smooth:
                forcing_phases(p, Q, n)
            za = z
            ya = y
            ua = u
            va = v
            s1s = max(0.0, s1s - rest)
            s2s = max(0.0, s2s - rest)
            if not done:
                if n_zu >= transient and n_sec < record:
                    o_sec[n_sec, SEC_T] = n * Sper
                    o_sec[n_sec, SEC_Z] = z
                    o_sec[n_sec, SEC_Y] = y
                    o_sec[n_sec, SEC_U] = u
                    o_sec[n_sec, SEC_V] = v
                    n_sec += 1
                final[0] = z
                final[1] = y
                final[2] = u
                final[3] = v
                if periods >= max_periods:
                    _close(o_zu, o_corner, pend_lo, pend_hi)
                    return S.NO_IMPACT if mode == FREE else S.STUCK
            else:
                extra += 1
                if extra >= 2 or periods >= max_periods:
                    _close(o_zu, o_corner, pend_lo, pend_hi)
                    return S.OK
            continue

        tau = tau_ref + se
        events += 1
        if events > max_events:
            _close(o_zu, o_corner, pend_lo, pend_hi)
            return S.OK if done else S.MAX_EVENTS

        # ---- releases -----------------------------------------------------------------------
        if ev >= EV_REL_Z:
            mode, za, ya, ua, va, win_target, win = release(ev, p, c, Q, D, ph, tau, tau_ref, se,
                                                            za, ya, ua, va, hsgn)
            win_kind, win_a0, win_a1, win_a2, win_a3, win_end = win
            tau_ref = tau
            if ev == EV_REL_Z:
                s2s = 0.0
            elif ev == EV_REL_PAIR:
                s1s = 0.0
            continue

        # ---- w-z impact (z free, or a stuck pair) -----------------------------------------
        if ev == EV_WZ:
            z, y, u, v = state_at(mode, smooth, p, c, Q, D, ph, tau_ref, za, ya, ua, va, se)
            w, wp, _, sn = wall(p, tau, ph)
            y_in = y
            y_out = restitution(y_in, wp, r1)
            if not done and n_zu >= transient and n_wz_rec < cap_wz:
                o_wz[n_wz_rec, WZ_T] = n * Sper + tau
                o_wz[n_wz_rec, WZ_Z] = w
                o_wz[n_wz_rec, WZ_YIN] = y_in
                o_wz[n_wz_rec, WZ_YOUT] = y_out
                n_wz_rec += 1
            # settle the offsets of the z-u impacts since the previous w-z impact
            # (the rule: ``analysis.settle_corner_offsets``)
            settle_corner_offsets(o_zu[:, ZU_OFF], o_corner, o_zu[:, ZU_T], pend_lo, pend_hi,
                                  n * Sper + tau, (n - n_w) * Sper + (tau - tau_w), n_wz)
            pend_lo = 0
            pend_hi = 0
            has_w = True
            n_w = n
            tau_w = tau
            n_wz += 1
            if done:
                return S.OK
            u_at = mode == PAIR or simult
            # u within the chattering scale of z (gap <= chatter^2): a collapsing
            # near-triple sequence, summed below when every relative velocity is slow
            u_near = u_at or u - w <= chatter * chatter
            z = w
            if u_at or u < z:
                u = z
            tau_ref = tau
            s1s = 0.0
            s2s = 0.0
            slow_z = y_out - wp <= chatter
            zst = r1 < 1.0 and slow_z
            N1, N2, N12 = forces_at(c, p, Q, tau, ph, sn)
            if (u_near and slow_z and abs(v - wp) <= chatter and (r1 < 1.0 or r2 < 1.0)
                    and N12 > 0.0 and N2 > 0.0):
                mode = ALL
                continue
            if u_at and v - y_out < 0.0 and not (zst and N1 > 0.0 and wp - v <= chatter):
                # triple impact: the z-u impact follows at the same time (policy)
                events += 1
                if events > max_events:
                    _close(o_zu, o_corner, pend_lo, pend_hi)
                    return S.MAX_EVENTS
                mode = FREE
                za = z
                ya = y_out
                ua = u
                va = v
                ev = EV_ZU
                se = 0.0
                tau = tau_ref
            elif zst and N1 > 0.0:
                mode = WALL
                ua = u
                va = v
                continue
            else:
                mode = FREE
                za = z
                ya = y_out
                ua = u
                va = v
                if slow_z and not N1 > 0.0:
                    # z leaves slowly and the wall does not push (N1 <= 0): the gap
                    # stays >= 0 while N1 < 0 (as after a release); search from there,
                    # not through the rounding noise of a gap that opens like s^2
                    win_kind, win_a0, win_a1, win_a2, win_a3, win_end = wall_window(
                        c, Q, D, RZ, c[C_N1A], c[C_N1B])
                    win_target = 1
                continue

        # ---- z-u impact (z free, or z stuck on the wall) -------------------------------
        if ev == EV_ZU:
            z, y, u, v = state_at(mode, smooth, p, c, Q, D, ph, tau_ref, za, ya, ua, va, se)
            w, wp, _, sn = wall(p, tau, ph)
            y_in = y
            v_in = v
            y_out, v_out = mass_ratio_impact(y_in, v_in, mu, r2)
            if not done and n_zu >= transient:
                i = n_zu - transient
                o_zu[i, ZU_T] = n * Sper + tau
                o_zu[i, ZU_U] = z
                o_zu[i, ZU_VIN] = v_in
                o_zu[i, ZU_VOUT] = v_out
                o_zu[i, ZU_YIN] = y_in
                o_zu[i, ZU_YOUT] = y_out
                o_zu[i, ZU_OFF], o_corner[i] = offset_to_previous(
                    has_w, (n - n_w) * Sper + (tau - tau_w), n_wz - 1)
                if pend_hi == pend_lo:
                    pend_lo = i
                pend_hi = i + 1
            n_zu += 1
            if n_zu >= need:
                done = True
            if mu != math.inf or mode != FREE:
                s1s = 0.0
            else:
                s1s = max(0.0, s1s - se)
            s2s = 0.0
            tau_ref = tau
            slow_u = v_out - y_out <= chatter
            u_stick = r2 < 1.0 and slow_u
            N1, N2, N12 = forces_at(c, p, Q, tau, ph, sn)
            if (mode == FREE and z - w <= chatter * chatter and abs(y_out - wp) <= chatter
                    and abs(v_out - wp) <= chatter and (r1 < 1.0 or r2 < 1.0)
                    and N12 > 0.0 and N2 > 0.0):
                # z within the chattering scale of the wall: collapsing near-triple sequence
                mode = ALL
                continue
            if mode == WALL:
                # the wall can dissipate through z when z is movable (mu finite)
                u_stick = slow_u and (r2 < 1.0 or (r1 < 1.0 and mu != math.inf))
                z_ok = mu == math.inf or abs(y_out - wp) <= chatter
                if z_ok and u_stick and N12 > 0.0 and N2 > 0.0:
                    mode = ALL
                elif z_ok and N1 > 0.0:
                    mode = WALL
                    ua = z
                    va = v_out
                    if slow_u and not N2 > 0.0:
                        # u leaves slowly while z does not push it: u - w >= 0 while N2 < 0
                        win_kind, win_a0, win_a1, win_a2, win_a3, win_end = wall_window(
                            c, Q, D, RU, c[C_N2A], c[C_N2B])
                        win_target = 2
                else:
                    mode, za, ya, ua, va = pair_or_free(c, p, Q, tau, u_stick, z, y_out, v_out,
                                                        ua, va)
            else:
                mode, za, ya, ua, va = pair_or_free(c, p, Q, tau, u_stick, z, y_out, v_out, ua, va)
                if mode == FREE:
                    if slow_u and not pforce(c, p, Q, tau, z, y_out) > 0.0:
                        # u leaves slowly while z does not push it: g2'' + omega2^2 g2 =
                        # -(omega2^2 - omega1^2) z >= 0 keeps g2 >= 0 for a while
                        if hzero:
                            s2s = halfp(c, Q, D, RU)
                        else:
                            win_kind, win_a0, win_a1, win_a2, win_a3, win_end = pair_window(
                                c, Q, D, z, y_out, hsgn)
                            win_target = 2
            continue


@items_kernel
def run_batch(k0, k1, params, ints, ics, o_zu, o_corner, o_wz, o_sec, o_status, o_final):
    """Run every item i = (parameter row params[i], initial state ics[i] = (z, y, u, v)).

    Each item writes only its own rows; results do not depend on the thread count.  Under
    a sweep's control (``ints[I_CONTROL]``) each finished item is counted (a run told to stop
    returns ``STOPPED`` and is not).
    """
    for i in range(k0, k1):
        st = run_one(params[i], ints, ics[i, 0], ics[i, 1], ics[i, 2], ics[i, 3], o_zu[i],
                     o_corner[i], o_wz[i], o_sec[i], o_final[i])
        o_status[i] = st
        if st != STOPPED:
            count_done(ints[P.I_CONTROL])


# --------------------------------------------------------------------- Python layer
def run_tables(z0, y0, u0, v0, transient=0, record=100, tol=1e-12, chatter=1e-6, escape=1e6,
               section_period=None, max_events=None, max_periods=None, **params):
    """The kernel alone, without a scene, for one or many initial states at t = 0: what the
    orbit problem's seed runs (``orbit.two_particle_seed``).  From Python the model runs
    through ``cornerbif.simulate(z0, y0, u0, v0, model="two_particle", ...)``, which checks
    a scene, and analyses the runs' cycles too.

    ``params`` are omega0, omega1, omega2, mu, r1, r2, kappa, beta (defaults: the
    paper's Fig. 19 values omega1 = 1.001, omega2 = 1, mu = 1000, r1 = r2 = 0.8,
    kappa = 0, beta = 1; omega0 is required) and the damping and forcing of each
    particle sigma1, sigma2, F1, Omega1, phi1, F2, Omega2, phi2 (default 0, Omega 1), each a
    scalar or an array broadcast against the initial states.  Returns a dict of arrays with shape
    ``shape + (record,)`` for the z-u impacts (t, u, v_in, v_out, y_in, y_out,
    corner_offset, corner), ``shape + (4 record + 8,)`` for the w-z impacts (wz_t, wz_z,
    wz_y_in, wz_y_out; the model's ``wall_capacity``), ``shape + (record,)`` for the sections
    (st, sz, sy, su, sv), and status and final (z, y, u, v).
    """
    # the declared defaults (models.two_particle.packed.PARAMS), omega0 aside
    defaults = {k: p.default for k, p in P.PARAMS.items() if k != "omega0"}
    unknown = set(params) - set(P.NAMES)
    if unknown:
        raise TypeError(f"run_tables() got unknown parameter(s) {sorted(unknown)}")
    if "omega0" not in params:
        raise TypeError("run_tables() needs omega0")
    vals = dict(defaults)
    vals.update(params)
    arrays = {k: np.atleast_1d(np.asarray(v, float)) for k, v in vals.items()}
    ic = [np.atleast_1d(np.asarray(x, float)) for x in (z0, y0, u0, v0)]
    shape = np.broadcast_shapes(*[a.shape for a in ic], *[a.shape for a in arrays.values()])
    n = int(np.prod(shape))
    flat = {k: np.broadcast_to(a, shape).ravel() for k, a in arrays.items()}
    prm = np.empty((n, P.NPARAM))
    for i in range(n):
        prm[i] = P.pack({k: float(a[i]) for k, a in flat.items()}, tol=tol, chatter=chatter,
                        escape=escape, section_period=section_period)
    ics = np.ascontiguousarray(np.stack([np.broadcast_to(a, shape).ravel() for a in ic], -1))
    need = transient + record
    ints = np.zeros(P.NINT, np.int64)
    ints[P.I_TRANSIENT] = transient
    ints[P.I_RECORD] = record
    ints[P.I_MAX_EVENTS] = max_events if max_events is not None else 40 * need + 1000
    ints[P.I_MAX_PERIODS] = max_periods if max_periods is not None else 50 * need + 1000
    cap = 4 * record + 8
    o_zu = np.full((n, record, NZU), np.nan)
    o_corner = np.full((n, record), -1, np.int64)
    o_wz = np.full((n, cap, NWZ), np.nan)
    o_sec = np.full((n, record, NSEC), np.nan)
    st = np.zeros(n, np.int8)
    final = np.full((n, 4), np.nan)
    run_batch(prm, ints, ics, o_zu, o_corner, o_wz, o_sec, st, final)

    def rs(a, k=None):
        if k is None:
            return a.reshape(shape + a.shape[1:])
        return a[..., k].reshape(shape + a.shape[1:2])

    return {
        "t": rs(o_zu, ZU_T), "u": rs(o_zu, ZU_U), "v_in": rs(o_zu, ZU_VIN),
        "v_out": rs(o_zu, ZU_VOUT), "y_in": rs(o_zu, ZU_YIN), "y_out": rs(o_zu, ZU_YOUT),
        "corner_offset": rs(o_zu, ZU_OFF), "corner": rs(o_corner),
        "wz_t": rs(o_wz, WZ_T), "wz_z": rs(o_wz, WZ_Z), "wz_y_in": rs(o_wz, WZ_YIN),
        "wz_y_out": rs(o_wz, WZ_YOUT),
        "st": rs(o_sec, SEC_T), "sz": rs(o_sec, SEC_Z), "sy": rs(o_sec, SEC_Y),
        "su": rs(o_sec, SEC_U), "sv": rs(o_sec, SEC_V),
        "status": st.reshape(shape), "final": final.reshape(shape + (4,)),
    }
