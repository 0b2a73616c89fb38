"""Obstacles z(t) of the ``flow`` model, piece by piece (eqs 7, 8; section 2.2).

Every per-obstacle quantity of the kernels lives here, the only module that reads the
obstacle code ``P.OBSTACLE``: the piece lengths (``piece_lengths``), the height and its
derivatives (``z_state``; ``sine_amp``, ``sine_part`` for sinusoidal pieces), the bounds
of the certified searches (``zpp_range``, ``zppp_max``, ``zpppp_max``, ``contact_npp``,
``sturm_floors``, ``contact_floor``), the nearest corner of an event (``corner_of``) and
the per-run switches of the flow kernel (``cycle_lag``, ``sinusoidal``).  A new obstacle adds a
branch to each of them, and its Python declaration (name, code, period, pieces per
period) in ``models/params.py``; docs/kernels.md says what each must return.

Time is kept as a piece index ``j`` and a local time ``tau`` in [0, L_j]
(DESIGN 2b): precision stays at rounding level over long runs, and a corner is
always exactly at a piece boundary.

* ``rectified_sine`` (eq 8): pieces of length pi/omega, each a corner
  (slope jumps from -beta omega to +beta omega); z = kappa + beta sin(omega tau).
* ``sine`` (section 2.2): split at half periods (no corner: the slope is
  continuous), z = kappa + (-1)^j beta sin(omega tau).
* ``triangle`` (eq 7 made periodic, period P = pi/omega): a valley corner at
  every t = nP where z = kappa, slope +theta2 up to the peak at
  tau_p = theta1 P / (theta1 + theta2), slope -theta1 back down.
"""

import math

from .._jit import jit
from . import params as P

# derived per-point quantities (filled once per run by ``derive``)
D_L0 = 0        # length of even pieces
D_L1 = 1        # length of odd pieces
D_PERIOD = 2    # L0 + L1
D_REGIME = 3    # oscillator: 0 under-, 1 critically, 2 over-damped
D_WD = 4        # damped frequency sqrt(k^2 - sigma^2)
D_LAM1 = 5      # over-damped exponents
D_LAM2 = 6
D_X = 7         # particular solution X cos(Omega t + phi) + Y sin(Omega t + phi)
D_Y = 8
D_UPP_PART = 9  # bound of |u_p''|
D_NPP = 10      # bound of |N''| (contact force, second derivative)
D_STURM0 = 11   # f_min / k^2 on even pieces (Sturm comparison, see flow.sturm_clear)
D_STURM1 = 12   # f_min / k^2 on odd pieces
D_IK = 13       # 1 / k
D_HALF = 14     # pi / k: how far the Sturm comparison reaches
D_IWD = 15      # 1 / w_d (under-damped)
NDERIVED = 16


@jit
def derived_tuple(d):
    """The derived constants as a tuple of NDERIVED floats (a value: no reference counting
    in the kernels' calls, see ``params.as_tuple``)."""
    return (d[0], d[1], d[2], d[3], d[4], d[5], d[6], d[7], d[8], d[9], d[10], d[11], d[12],
            d[13], d[14], d[15])


@jit
def piece_lengths(p):
    """(L0, L1, L0 + L1): the lengths of the even and the odd pieces, and of a pair."""
    w = p[P.OMEGA]
    if p[P.OBSTACLE] == P.TRIANGLE:
        per = math.pi / w
        t1 = p[P.THETA1]
        t2 = p[P.THETA2]
        return t1 * per / (t1 + t2), t2 * per / (t1 + t2), per
    return math.pi / w, math.pi / w, 2.0 * math.pi / w


@jit
def contact_npp(p, f2):
    """Bound of |N''|, N = z'' + 2 sigma z' + k^2 z - f the contact force while stuck,
    given f2 >= |f''| (the forcing's share): a bound of |z'''' + 2 sigma z''' + k^2 z''|
    plus f2."""
    if p[P.OBSTACLE] == P.TRIANGLE:
        return f2
    w = p[P.OMEGA]
    k = p[P.K]
    return w * w * p[P.BETA] * (abs(k * k - w * w) + 2.0 * p[P.SIGMA] * w) + f2


@jit
def sturm_floors(p, d):
    """f_min / k^2 on the even and on the odd pieces (k > 0; ``d`` holds the piece
    lengths): the floor of the Sturm comparison of the free undamped gap
    (``flow.sturm_clear``), g'' + k^2 g = -k^2 z - z'' =: f(tau) >= f_min on each piece.

    rectified_sine: f_min = -k^2 kappa + min(0, beta (omega^2 - k^2)); sine: the same with
    beta reversed on the odd pieces; triangle (z'' = 0): -k^2 max z = -k^2 (kappa +
    theta2 L0).
    """
    kap = p[P.KAPPA]
    ob = p[P.OBSTACLE]
    if ob == P.TRIANGLE:
        f = -(kap + p[P.THETA2] * d[D_L0])
        return f, f
    k = p[P.K]
    w = p[P.OMEGA]
    a = p[P.BETA] * (w * w - k * k) / (k * k)
    return -kap + min(0.0, a), -kap + min(0.0, -a if ob == P.SINE else a)


@jit
def contact_floor(p):
    """A certified lower bound of the contact force N = z'' + 2 sigma z' + k^2 z - f over
    all future time, for obstacles whose slope never jumps; -inf where it does.

    A particle stuck where this is > 0 stays stuck for good: N never changes sign (no
    release) and no corner kicks it off or drops it.  ``sine`` (no corners) and a flat
    ``rectified_sine`` (beta = 0: z = kappa) qualify; there, with z = kappa + b sin(omega t),
    N = k^2 kappa + b ((k^2 - omega^2) sin + 2 sigma omega cos)(omega t) - F cos(Omega t + phi)
    >= k^2 kappa - beta hypot(k^2 - omega^2, 2 sigma omega) - |F|, less a relative margin of
    1e-12 for the rounding of that sum (a flat wall without forcing: exactly k^2 kappa,
    the N the kernel evaluates).  ``triangle`` (slopes theta1, theta2 > 0) and a
    rectified_sine with beta > 0 have corners: -inf.
    """
    ob = p[P.OBSTACLE]
    b = p[P.BETA]
    if ob == P.TRIANGLE or (ob == P.RECTIFIED_SINE and b != 0.0):
        return -math.inf
    k2 = p[P.K] * p[P.K]
    w = p[P.OMEGA]
    a = k2 * p[P.KAPPA]
    osc = b * math.hypot(k2 - w * w, 2.0 * p[P.SIGMA] * w) + abs(p[P.F_AMP])
    return a - osc - 1e-12 * (abs(a) + osc)


@jit
def cycle_lag(p):
    """Pieces per period of the obstacle: the early stop of the flow kernel
    (``flow.cycle_watch``) looks for a repeating state at multiples of this lag."""
    return 1 if p[P.OBSTACLE] == P.RECTIFIED_SINE else 2


@jit
def sinusoidal(p):
    """Whether every piece is z = kappa + b sin(omega tau), b = ``sine_amp``: then the flow
    kernel's free-flight fast path (``flow.first_impact_free``, its phase grid) applies."""
    return p[P.OBSTACLE] != P.TRIANGLE


@jit
def piece_start(d, j):
    """Absolute time of the start of piece j."""
    return (j // 2) * d[D_PERIOD] + (j % 2) * d[D_L0]


@jit
def piece_at(d, t):
    """Piece index j and local time tau of absolute time t >= 0 (inverse of
    ``piece_start``)."""
    per = d[D_PERIOD]
    m = math.floor(t / per)
    x = t - m * per
    if x >= d[D_L0]:
        return 2 * m + 1, x - d[D_L0]
    return 2 * m, x


@jit
def piece_length(d, j):
    return d[D_L0] if j % 2 == 0 else d[D_L1]


@jit
def z_state(p, j, tau):
    """Obstacle height, slope, curvature and third derivative on piece j at local time tau."""
    ob = p[P.OBSTACLE]
    if ob == P.TRIANGLE:
        if j % 2 == 0:
            return p[P.KAPPA] + p[P.THETA2] * tau, p[P.THETA2], 0.0, 0.0
        L1 = p[P.THETA2] * math.pi / p[P.OMEGA] / (p[P.THETA1] + p[P.THETA2])
        return p[P.KAPPA] + p[P.THETA1] * (L1 - tau), -p[P.THETA1], 0.0, 0.0
    zr, zp = sine_part(p, j, tau)
    w2 = p[P.OMEGA] * p[P.OMEGA]
    return p[P.KAPPA] + zr, zp, -w2 * zr, -w2 * zp


@jit
def sine_amp(p, j):
    """Amplitude b of z - kappa = b sin(omega tau) on piece j of a sinusoidal obstacle:
    beta for rectified_sine, +-beta on the even/odd half periods of sine."""
    if p[P.OBSTACLE] == P.SINE and j % 2 == 1:
        return -p[P.BETA]
    return p[P.BETA]


@jit
def sine_part(p, j, tau):
    """z - kappa and z' on piece j of a sinusoidal obstacle (sine, rectified_sine) at tau."""
    w = p[P.OMEGA]
    b = sine_amp(p, j)
    return b * math.sin(w * tau), b * w * math.cos(w * tau)


@jit
def zpp_range(p, j):
    """Lower and upper bound of z'' on piece j (used by the certified event search)."""
    ob = p[P.OBSTACLE]
    if ob == P.TRIANGLE:
        return 0.0, 0.0
    a = p[P.BETA] * p[P.OMEGA] * p[P.OMEGA]
    if ob == P.SINE and j % 2 == 1:
        return 0.0, a
    return -a, 0.0


@jit
def zppp_max(p):
    """Bound of |z'''| on every piece."""
    if p[P.OBSTACLE] == P.TRIANGLE:
        return 0.0
    return p[P.BETA] * p[P.OMEGA] ** 3


@jit
def zpppp_max(p):
    """Bound of |z''''| on every piece (used by the sinusoidal fast search)."""
    if p[P.OBSTACLE] == P.TRIANGLE:
        return 0.0
    return zppp_max(p) * p[P.OMEGA]


@jit
def corner_of(p, d, j, tau):
    """Nearest valley corner to (j, tau): its index and the signed offset tau - t_corner.

    For ``sine`` (no corners) the "corner" is the nearest start of a forcing
    period; the kernel uses it only to group impacts, and the file stores NaN.
    """
    ob = p[P.OBSTACLE]
    if ob == P.RECTIFIED_SINE:
        L = d[D_L0]
        if tau < 0.5 * L:
            return j, tau
        return j + 1, tau - L
    # sine and triangle: two pieces per period, corners at period starts
    x = tau if j % 2 == 0 else d[D_L0] + tau
    per = d[D_PERIOD]
    if x < 0.5 * per:
        return j // 2, x
    return j // 2 + 1, x - per
