"""Obstacles z(t) of the ``flow`` model, piece by piece (eqs 7, 8; section 2.2).

Every per-obstacle quantity of the kernels lives here, the only module that reads the
obstacle code ``P.OBSTACLE``: the piece lengths (``piece_lengths``), the height and its
derivatives (``z_state``; ``sine_amp``, ``sine_part`` for sinusoidal pieces), the bounds
of the certified searches (``zpp_range``, ``zppp_max``, ``zpppp_max``, ``contact_npp``,
``sturm_floors``, ``contact_floor``), the nearest corner of an event (``corner_of``) and
the per-run switches of the flow kernel (``cycle_lag``, ``sinusoidal``).  A new obstacle adds a
branch to each of them, beside its own module (``obstacles/<name>.py``: its declaration and
Python side, registered in ``obstacles.OBSTACLE_MODULES``); docs/kernels.md says what each
must return.

Time is kept as a piece index ``j`` and a local time ``tau`` in [0, L_j]
(docs/kernels.md, "Obstacles"): precision stays at rounding level over long runs, and a corner is
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

import numpy as np
from numba.core import types
from numba.extending import overload

from .._jit import jit, load_f64
from ..models.flow import packed as P
from .profile import OBSTACLE as _profile
from .rectified_sine import OBSTACLE as _rectified_sine
from .sine import OBSTACLE as _sine
from .triangle import OBSTACLE as _triangle

# the obstacle codes the branches below compare, each its kind's (obstacles.OBSTACLE_MODULES)
SINE = _sine.code                      # section 2.2 (smooth, no corners)
RECTIFIED_SINE = _rectified_sine.code  # eq (8), corners at k pi / omega
TRIANGLE = _triangle.code              # eq (7) made periodic with period pi / omega
PROFILE = _profile.code                # a cam profile (obstacles/profile.py)

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
# pieces of the cycle that piece_start, piece_length and the Sturm floors go round: 2 for
# the built-in obstacles (and a profile of one or two pieces: L0, L1, D_STURM0, D_STURM1),
# a profile's pieces per period beyond (the per-piece slots below)
D_NP = 16
D_PL0 = 17      # 8 piece lengths (time)                     } of ``derive``'s array; a
D_PS0 = 25      # 8 piece starts within the period (time)    } profile's derived tuple
D_PSTURM0 = 33  # 8 Sturm floors f_min / k^2                 } reads them from its row
NDERIVED = 41
D_ROW = 17      # in a profile's derived tuple: the address of its packed row


NDERIVED_BUILTIN = 16   # the built-in obstacles' derived tuple: D_L0 .. D_IWD


@jit
def derived_tuple(d):
    """The derived constants of a built-in obstacle as a tuple of NDERIVED_BUILTIN floats (a
    value: no reference counting in the kernels' calls, see ``params.as_tuple``)."""
    return (d[0], d[1], d[2], d[3], d[4], d[5], d[6], d[7], d[8], d[9], d[10], d[11], d[12],
            d[13], d[14], d[15])


@jit
def derived_tuple_profile(d, row):
    """A profile's derived constants: the built-in ones and D_NP, then the address of its
    packed row ``row`` (``D_ROW``), where its per-piece lengths, starts and Sturm floors
    are (PC_LEN, PC_T0, PC_FLOOR; ``cycle_slot``): the kernels' second type.  ``row``
    must be contiguous and outlive the tuple (``params.as_tuple_profile``)."""
    return (d[0], d[1], d[2], d[3], d[4], d[5], d[6], d[7], d[8], d[9], d[10], d[11],
            d[12], d[13], d[14], d[15], d[16], row.ctypes.data)


# ------------------------------------------------------------------ the two tuple types
# The kernels run a built-in obstacle on short tuples of floats (params.as_tuple,
# derived_tuple) and a profile on tuples that end in the address of its packed row
# (as_tuple_profile, derived_tuple_profile): its table is read through the row
# (``profile_slot``, ``cycle_slot``), so no call carries it (the 197-float table passed by
# value in the tuple costs several times more per impact; docs/cams.md).  The profile's code
# is reached through the overloads below: on a short tuple each compiles to a constant (a
# built-in obstacle never reaches it), so the built-in obstacles' code is what it was.
# Outside the kernels (stability, trajectories) the same functions take the arrays.
def _short(x, n):
    return isinstance(x, types.BaseTuple) and len(x) == n


def profile_slot(p, i):
    """Slot i of a profile's packed row (``params.PROFILE0`` on): of the row itself, or
    read through the address a profile's tuple carries (``params.PROFILE_ROW``)."""
    return p[i]


@overload(profile_slot)
def _ov_profile_slot(p, i):
    if isinstance(p, types.Array):
        return lambda p, i: p[i]
    if _short(p, P.NPARAM):
        return lambda p, i: 0.0
    return lambda p, i: load_f64(p[P.PROFILE_ROW], i)


def cycle_slot(d, m, dslot, pcslot):
    """A per-piece constant of piece m of a profile of more than two pieces: slot
    dslot + m of ``derive``'s array (D_PL0, D_PS0, D_PSTURM0), or slot pcslot of piece m
    of the packed row a profile's derived tuple refers to (PC_LEN, PC_T0, PC_FLOOR)."""
    return d[dslot + m]


@overload(cycle_slot)
def _ov_cycle_slot(d, m, dslot, pcslot):
    if isinstance(d, types.Array):
        return lambda d, m, dslot, pcslot: d[dslot + m]
    if _short(d, NDERIVED_BUILTIN):
        return lambda d, m, dslot, pcslot: 0.0
    return lambda d, m, dslot, pcslot: load_f64(d[D_ROW], P.PROFILE0 + m * P.PIECE_STRIDE
                                                + pcslot)


def is_profile(p):
    """Whether the packed parameters are a profile's (``obstacle = "profile"``)."""
    return p[P.OBSTACLE] == PROFILE


@overload(is_profile)
def _is_profile(p):
    if _short(p, P.NPARAM):
        return lambda p: False
    return lambda p: p[P.OBSTACLE] == PROFILE


def cycle_np(d):
    """Pieces of the cycle of ``d`` (``D_NP``): 2 but for a profile of more pieces."""
    return 2 if len(d) == NDERIVED_BUILTIN else int(d[D_NP])


@overload(cycle_np)
def _cycle_np(d):
    if _short(d, NDERIVED_BUILTIN):
        return lambda d: 2
    return lambda d: np.int64(d[D_NP])


@jit
def piece_lengths(p):
    """(L0, L1, L0 + L1): the lengths of the even and the odd pieces, and of a pair (a
    profile of more than two pieces: its first two, and its period; ``profile_pieces``)."""
    w = p[P.OMEGA]
    if p[P.OBSTACLE] == PROFILE:
        n = np.int64(p[P.PROFILE_NP])
        L0 = profile_slot(p, P.PROFILE0 + P.PC_LEN)
        if n == 1:
            return L0, L0, 2.0 * L0
        L1 = profile_slot(p, P.PROFILE0 + P.PIECE_STRIDE + P.PC_LEN)
        return L0, L1, (L0 + L1) if n == 2 else p[P.PROFILE_PERIOD] / w
    if p[P.OBSTACLE] == TRIANGLE:
        per = math.pi / w
        t1 = p[P.THETA1]
        t2 = p[P.THETA2]
        return t1 * per / (t1 + t2), t2 * per / (t1 + t2), per
    return math.pi / w, math.pi / w, 2.0 * math.pi / w


@jit
def profile_piece(p, j):
    """The slot of piece j's data in a profile's packed vector (its piece m = j mod n)."""
    n = np.int64(p[P.PROFILE_NP])
    return P.PROFILE0 + (j % n) * P.PIECE_STRIDE


@jit
def _profile_max(p, slot):
    """The largest of a per-piece bound (slot PC_G3, PC_G4, ...) over the profile's pieces."""
    n = np.int64(p[P.PROFILE_NP])
    m = 0.0
    for i in range(n):
        m = max(m, abs(profile_slot(p, P.PROFILE0 + i * P.PIECE_STRIDE + slot)))
    return m


@jit
def profile_g2_abs(p):
    """The largest |g''| bound over the profile's pieces."""
    n = np.int64(p[P.PROFILE_NP])
    m = 0.0
    for i in range(n):
        o = P.PROFILE0 + i * P.PIECE_STRIDE
        m = max(m, abs(profile_slot(p, o + P.PC_G2_LO)), abs(profile_slot(p, o + P.PC_G2_HI)))
    return m


@jit
def profile_sturm_floor(p, m):
    """f_min / k^2 of the Sturm comparison on profile piece m (k > 0): f = -k^2 z - z''
    = -k^2 kappa - beta (k^2 g + omega^2 g'') >= -k^2 kappa - beta H, H the piece's bound of
    k^2 g + omega^2 g'' packed for this point's k and omega (``profile.sturm_bound``); the
    floor -kappa - beta H / k^2 is packed with it (PC_FLOOR, ``obstacles.profile.pack_profile``)."""
    return profile_slot(p, P.PROFILE0 + m * P.PIECE_STRIDE + P.PC_FLOOR)


@jit
def contact_npp(p, f2):
    """Bound of |N''|, N = z'' + 2 sigma z' + k^2 z - f the contact force while stuck,
    given f2 >= |f''| (the forcing's share): a bound of |z'''' + 2 sigma z''' + k^2 z''|
    plus f2."""
    if p[P.OBSTACLE] == TRIANGLE:
        return f2
    w = p[P.OMEGA]
    k = p[P.K]
    if is_profile(p):
        return profile_npp(p, f2)
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
    if ob == PROFILE:
        n = np.int64(p[P.PROFILE_NP])
        return profile_sturm_floor(p, 0), profile_sturm_floor(p, 1 % n)
    if ob == TRIANGLE:
        f = -(kap + p[P.THETA2] * d[D_L0])
        return f, f
    k = p[P.K]
    w = p[P.OMEGA]
    a = p[P.BETA] * (w * w - k * k) / (k * k)
    return -kap + min(0.0, a), -kap + min(0.0, -a if ob == SINE else a)


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
    if ob == TRIANGLE or ob == PROFILE or (ob == RECTIFIED_SINE and b != 0.0):
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
    if is_profile(p):
        return profile_np(p)
    return 1 if p[P.OBSTACLE] == RECTIFIED_SINE else 2


@jit
def sinusoidal(p):
    """Whether every piece is z = kappa + b sin(omega tau), b = ``sine_amp``: then the flow
    kernel's free-flight fast path (``flow.first_impact_free``, its phase grid) applies."""
    return p[P.OBSTACLE] != TRIANGLE and p[P.OBSTACLE] != PROFILE


@jit
def piece_start(d, j):
    """Absolute time of the start of piece j."""
    n = cycle_np(d)
    if n == 2:
        return (j // 2) * d[D_PERIOD] + (j % 2) * d[D_L0]
    return (j // n) * d[D_PERIOD] + cycle_slot(d, j % n, D_PS0, P.PC_T0)


@jit
def piece_at(d, t):
    """Piece index j and local time tau of absolute time t >= 0 (inverse of
    ``piece_start``)."""
    per = d[D_PERIOD]
    m = math.floor(t / per)
    x = t - m * per
    n = cycle_np(d)
    if n == 2:
        if x >= d[D_L0]:
            return 2 * m + 1, x - d[D_L0]
        return 2 * m, x
    i = n - 1
    while i > 0 and x < cycle_slot(d, i, D_PS0, P.PC_T0):
        i -= 1
    return n * m + i, x - cycle_slot(d, i, D_PS0, P.PC_T0)


@jit
def piece_length(d, j):
    n = cycle_np(d)
    if n == 2:
        return d[D_L0] if j % 2 == 0 else d[D_L1]
    return cycle_slot(d, j % n, D_PL0, P.PC_LEN)


@jit
def sturm_floor(d, j):
    """f_min / k^2 on piece j (``sturm_floors``; a profile's per piece)."""
    n = cycle_np(d)
    if n == 2:
        return d[D_STURM0] if j % 2 == 0 else d[D_STURM1]
    return cycle_slot(d, j % n, D_PSTURM0, P.PC_FLOOR)


@jit
def profile_cycle(p, d):
    """Fill the per-piece slots of ``d`` for a profile of more than two pieces (its
    lengths, starts and Sturm floors); two for every other obstacle."""
    if p[P.OBSTACLE] != PROFILE or p[P.PROFILE_NP] <= 2.0:
        d[D_NP] = 2.0
        return
    n = np.int64(p[P.PROFILE_NP])
    d[D_NP] = n
    for m in range(n):
        o = P.PROFILE0 + m * P.PIECE_STRIDE
        d[D_PL0 + m] = profile_slot(p, o + P.PC_LEN)
        d[D_PS0 + m] = profile_slot(p, o + P.PC_T0)
        d[D_PSTURM0 + m] = profile_slot(p, o + P.PC_FLOOR)


@jit
def z_state(p, j, tau):
    """Obstacle height, slope, curvature and third derivative on piece j at local time tau."""
    ob = p[P.OBSTACLE]
    if is_profile(p):
        return profile_state(p, j, tau)
    if ob == TRIANGLE:
        if j % 2 == 0:
            return p[P.KAPPA] + p[P.THETA2] * tau, p[P.THETA2], 0.0, 0.0
        L1 = p[P.THETA2] * math.pi / p[P.OMEGA] / (p[P.THETA1] + p[P.THETA2])
        return p[P.KAPPA] + p[P.THETA1] * (L1 - tau), -p[P.THETA1], 0.0, 0.0
    zr, zp = sine_part(p, j, tau)
    w2 = p[P.OMEGA] * p[P.OMEGA]
    return p[P.KAPPA] + zr, zp, -w2 * zr, -w2 * zp


@jit
def _profile_state(p, j, tau):
    """z and its first three time derivatives on profile piece j at local time tau:
    z = kappa + beta g(phi),
    phi = omega tau, g a polynomial of degree <= 7 plus a sin(n phi) + b cos(n phi)
    (obstacles/profile.py)."""
    o = profile_piece(p, j)
    w = p[P.OMEGA]
    x = w * tau
    c = o + P.PC_C0
    # Horner for g and its first three derivatives, from the piece's degree down
    deg = np.int64(profile_slot(p, o + P.PC_DEG))
    g = profile_slot(p, c + deg)
    g1 = 0.0
    g2 = 0.0
    g3 = 0.0
    for i in range(deg - 1, -1, -1):
        g3 = g3 * x + g2
        g2 = g2 * x + g1
        g1 = g1 * x + g
        g = g * x + profile_slot(p, c + i)
    g2 *= 2.0
    g3 *= 6.0
    a = profile_slot(p, o + P.PC_A)
    b = profile_slot(p, o + P.PC_B)
    n = profile_slot(p, o + P.PC_N)
    if a != 0.0 or b != 0.0:
        s = math.sin(n * x)
        co = math.cos(n * x)
        e = a * s + b * co
        f = n * (a * co - b * s)
        g += e
        g1 += f
        g2 -= n * n * e
        g3 -= n * n * f
    be = p[P.BETA]
    return (p[P.KAPPA] + be * g, be * w * g1, be * w * w * g2, be * w * w * w * g3)


@jit
def sine_amp(p, j):
    """Amplitude b of z - kappa = b sin(omega tau) on piece j of a sinusoidal obstacle:
    beta for rectified_sine, +-beta on the even/odd half periods of sine."""
    if p[P.OBSTACLE] == SINE and j % 2 == 1:
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
    if ob == TRIANGLE:
        return 0.0, 0.0
    if is_profile(p):
        return profile_zpp_range(p, j)
    a = p[P.BETA] * p[P.OMEGA] * p[P.OMEGA]
    if ob == SINE and j % 2 == 1:
        return min(0.0, a), max(0.0, a)      # (a beta < 0: a linear model's contact)
    return min(-a, 0.0), max(-a, 0.0)


@jit
def zppp_max(p):
    """Bound of |z'''| on every piece."""
    if p[P.OBSTACLE] == TRIANGLE:
        return 0.0
    if is_profile(p):
        return abs(p[P.BETA]) * p[P.OMEGA] ** 3 * profile_bound(p, P.PC_G3)
    return abs(p[P.BETA]) * p[P.OMEGA] ** 3      # (beta of either sign: a linear contact)


@jit
def zpppp_max(p):
    """Bound of |z''''| on every piece (used by the sinusoidal fast search)."""
    if p[P.OBSTACLE] == TRIANGLE:
        return 0.0
    if is_profile(p):
        return abs(p[P.BETA]) * p[P.OMEGA] ** 4 * profile_bound(p, P.PC_G4)
    return zppp_max(p) * p[P.OMEGA]


@jit
def corner_of(p, d, j, tau):
    """Nearest valley corner to (j, tau): its index and the signed offset tau - t_corner.

    For ``sine`` (no corners) the "corner" is the nearest start of a forcing
    period; the kernel uses it only to group impacts, and the file stores NaN.  A
    profile's corners are its joints where the slope jumps (``profile_corner``); one
    without corners is grouped by its periods, as ``sine``.
    """
    ob = p[P.OBSTACLE]
    if ob == RECTIFIED_SINE:
        L = d[D_L0]
        if tau < 0.5 * L:
            return j, tau
        return j + 1, tau - L
    if is_profile(p):
        c, off, found = profile_corner(p, d, j, tau)
        if found:
            return c, off
    # sine and triangle: two pieces per period, corners at period starts
    x = tau if j % 2 == 0 else d[D_L0] + tau
    per = d[D_PERIOD]
    if x < 0.5 * per:
        return j // 2, x
    return j // 2 + 1, x - per


@jit
def _profile_corner(p, d, j, tau):
    """The nearest corner of a profile to (j, tau): the piece index whose start is that
    corner (an increasing number: corner ids of successive periods differ by its pieces
    per period) and the signed offset t - t_corner."""
    # the last corner at or before (j, tau) and the first after it, at most a period away
    n = np.int64(p[P.PROFILE_NP])
    if p[P.PROFILE_CORNERS] == 0.0:
        # no corners: impacts are grouped by the profile's own periods, as the sine's
        per = p[P.PROFILE_PERIOD] / p[P.OMEGA]
        t = piece_start(d, j) + tau
        m = math.floor(t / per)
        x = t - m * per
        if x < 0.5 * per:
            return m, x, True
        return m + 1, x - per, True
    back = j
    while profile_slot(p, profile_piece(p, back) + P.PC_CORNER) == 0.0:
        back -= 1
    ahead = j + 1
    while profile_slot(p, profile_piece(p, ahead) + P.PC_CORNER) == 0.0:
        ahead += 1
    t = piece_start(d, j) + tau
    before = t - piece_start(d, back)
    after = piece_start(d, ahead) - t
    # one- and two-piece profiles go round the two-piece cycle of d: their corner ids
    # count pieces of that cycle, which are the profile's own
    if before <= after or n < 1:
        return back, before, True
    return ahead, -after, True


# ------------------------------------------------------------------ a profile's entry points
@jit
def _profile_zpp_range(p, j):
    o = profile_piece(p, j)
    s = p[P.BETA] * p[P.OMEGA] * p[P.OMEGA]
    return s * profile_slot(p, o + P.PC_G2_LO), s * profile_slot(p, o + P.PC_G2_HI)


@jit
def npp_bound(beta, w, sigma, k, g2, g3, g4):
    """The bound of |z'''' + 2 sigma z''' + k^2 z''| on z = kappa + beta g(omega t) where
    |g''|, |g'''|, |g''''| are at most g2, g3, g4: beta omega^2 (omega^2 g4 + 2 sigma omega
    g3 + k^2 g2), the contact force's |N''| less the forcing's share (``profile_npp``).
    Arithmetic alone: ``profile.scale_problem`` checks a scene with the same in Python
    (``models.flow.params.npp_bound``)."""
    return beta * w * w * (w * w * g4 + 2.0 * sigma * w * g3 + k * k * g2)


@jit
def _profile_npp(p, f2):
    return npp_bound(p[P.BETA], p[P.OMEGA], p[P.SIGMA], p[P.K], profile_g2_abs(p),
                     _profile_max(p, P.PC_G3), _profile_max(p, P.PC_G4)) + f2


def profile_state(p, j, tau):
    """z and its first three time derivatives on profile piece j at local time tau
    (``_profile_state``)."""
    return _profile_state(p, j, tau)


def profile_zpp_range(p, j):
    """Bounds of z'' on profile piece j: beta omega^2 times the packed bounds of g''."""
    return _profile_zpp_range(p, j)


def profile_bound(p, slot):
    """The largest of a per-piece bound (PC_G3, PC_G4) over the profile's pieces."""
    return _profile_max(p, slot)


def profile_npp(p, f2):
    """Bound of |N''| on a profile (contact_npp): beta omega^2 (omega^2 G4 + 2 sigma omega
    G3 + k^2 G2) + f2, G2, G3, G4 the largest bounds of the derivatives of g."""
    return _profile_npp(p, f2)


def profile_np(p):
    """A profile's pieces per period (the early stop's lag, ``cycle_lag``)."""
    return int(p[P.PROFILE_NP])


def profile_corner(p, d, j, tau):
    """The nearest corner of a profile (``_profile_corner``) and whether it has corners."""
    return _profile_corner(p, d, j, tau)


@overload(profile_state)
def _ov_profile_state(p, j, tau):
    if _short(p, P.NPARAM):
        return lambda p, j, tau: (0.0, 0.0, 0.0, 0.0)
    return lambda p, j, tau: _profile_state(p, j, tau)


@overload(profile_zpp_range)
def _ov_profile_zpp_range(p, j):
    if _short(p, P.NPARAM):
        return lambda p, j: (0.0, 0.0)
    return lambda p, j: _profile_zpp_range(p, j)


@overload(profile_bound)
def _ov_profile_bound(p, slot):
    if _short(p, P.NPARAM):
        return lambda p, slot: 0.0
    return lambda p, slot: _profile_max(p, slot)


@overload(profile_npp)
def _ov_profile_npp(p, f2):
    if _short(p, P.NPARAM):
        return lambda p, f2: 0.0
    return lambda p, f2: _profile_npp(p, f2)


@overload(profile_np)
def _ov_profile_np(p):
    if _short(p, P.NPARAM):
        return lambda p: 1
    return lambda p: np.int64(p[P.PROFILE_NP])


@overload(profile_corner)
def _ov_profile_corner(p, d, j, tau):
    if _short(p, P.NPARAM):
        return lambda p, d, j, tau: (j, tau, False)
    return lambda p, d, j, tau: _profile_corner(p, d, j, tau)


@jit
def obstacle_at_offset(p, d, t, offset):
    """(z', z'') of the obstacle at an impact given by its offset to the nearest valley
    corner (``impacts/corner_offset``: t - t_corner, >= 0 after the corner): the slope
    and curvature of the piece the impact lies on, as the kernel's law (5) used them.  A
    profile's impact is placed by its time t (its corners need not start a period); one
    at a joint takes the piece on the offset's side."""
    if p[P.OBSTACLE] == PROFILE:
        j, tau = piece_at(d, t)
        if offset < 0.0 and tau == 0.0:
            j -= 1
            tau = piece_length(d, j)
        _, zp, zpp, _ = z_state(p, j, tau)
        return zp, zpp
    L0, L1, per = piece_lengths(p)
    if p[P.OBSTACLE] == RECTIFIED_SINE:
        j, tau = (0, offset) if offset >= 0.0 else (0, L0 + offset)
    else:
        x = offset if offset >= 0.0 else per + offset
        j, tau = (0, x) if x < L0 else (1, x - L0)
    _, zp, zpp, _ = z_state(p, j, tau)
    return zp, zpp
