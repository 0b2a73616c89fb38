"""Cam profiles: any periodic, continuous, piecewise obstacle (``obstacle = "profile"``).

The obstacle is z(t) = kappa + beta g(omega t): a lift g of the cam angle theta = omega t,
periodic with ``period`` (an angle, default 2 pi), given as pieces over one period.  On
piece m, of angular span S_m, with local angle phi = theta - theta_m in [0, S_m],

    g(phi) = c_0 + c_1 phi + ... + c_7 phi^7 + a sin(n phi) + b cos(n phi),

so z' = beta omega g', z'' = beta omega^2 g'', ...  A scene gives the pieces as
polynomials (``poly = [c0, c1, ...]``), sinusoids (``sine = [a, b, n]``, with an
optional ``poly``), or standard cam motion laws over a rise h (``law = ...``, ``rise =
h``; the piece starts where the previous one ends):

========================  ==============================================  ==========
law                        g(phi) - g(0), x = phi / S                      velocity at ends
========================  ==============================================  ==========
``dwell``                  0                                               0
``constant_velocity``      h x                                             h / S (corners)
``parabolic``              2 h x^2 (x < 1/2), h (1 - 2 (1 - x)^2) (two pieces)  0
``simple_harmonic``        h (1 - cos(pi x)) / 2                           0
``cycloidal``              h (x - sin(2 pi x) / (2 pi))                    0, accel. 0
``polynomial_345``         h (10 x^3 - 15 x^4 + 6 x^5)                     0, accel. 0
========================  ==============================================  ==========

The obstacle must be continuous: a jump in height between two pieces (or across the end
of the period) is refused, naming the piece.  A jump in slope is a corner (the paper's
corner events; cluster symbols are taken with respect to the nearest corner); a profile
without corners behaves as the smooth wall of section 2.2 (symbols ``x``).  ``corners =
[i, ...]`` names the pieces whose start counts as a corner instead (the built-in triangle
counts its valleys only, not its peaks).

The packed layout (``models/flow/params.py``: ``PROFILE_*``) holds, per piece, its span, its
coefficients and certified bounds of g, g'', |g'''| and |g''''| on the piece (Bernstein
enclosures of the polynomial plus the sinusoid's amplitude), which the certified event
search and the Sturm comparison of the kernels read (``obstacles/dispatch.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..model import KEY_CHARS, Obstacle, cut, is_number, shown
from ..models.flow import slots as P

MAX_PIECES = 8        # pieces per period (the packed vector's room; docs/cams.md)
MAX_DEGREE = 7
# The ranges in which the certified bounds and the kernels stay finite and meaningful
# (docs/cams.md, "Limits"); each refusal names its key, its value and the range, and why:
# the period, an angle of omega t (2 pi one revolution, 360 written in degrees); outside,
# rescale omega: the same obstacle in time, with the pieces' powers phi^7 within float64
MIN_PERIOD, MAX_PERIOD = 1e-3, 1e4
# a piece's span as a share of the period: a shorter piece is a step rather than a shape
# (a law's coefficients grow as rise / span^5), and the spans' sum is checked to 1e-12 of
# the period, which a piece of 1e-12 would pass unseen
MIN_SPAN_SHARE = 1e-6
# the lift g in units of beta (scale beta for a larger obstacle): a law's rise, a
# sinusoid's a and b; within it (and MIN_SPAN_SHARE, MAX_TURN) the enclosures of the
# derivatives up to the fourth (divided by span^4, or times n^4) stay far inside float64
MAX_LIFT = 1e6
# ... and of the enclosure of g on a piece: ten times that, since heights add up over the
# pieces (8 rises of MAX_LIFT) and an enclosure exceeds the lift (a cycloid's by 1/(2 pi))
MAX_ENCLOSURE = 10 * MAX_LIFT
# n times the span: the radians a sinusoid piece turns through; the kernels evaluate
# sin(n phi), whose argument float64 rounds to 1e-16 of it (1e-10 rad at 1e6), and its
# bounds grow as n^4
MAX_TURN = 1e6
# what float64 holds: the certified bounds in time (beta omega^j |g^(j)|), the Sturm floors
# and the pieces' lengths in time must stay below it (``scale_problem``)
FLOAT_MAX = 1.7976931348623157e308
LAWS = ("dwell", "constant_velocity", "parabolic", "simple_harmonic", "cycloidal",
        "polynomial_345")
KEYS = ("span", "poly", "sine", "law", "rise")
# relative tolerance of the continuity check (heights at a joint) and of a corner (slopes)
JOINT_TOL = 1e-9


class ProfileError(ValueError):
    """A profile that cannot be an obstacle; ``problems`` lists every reason (key named)."""

    def __init__(self, problems):
        super().__init__("; ".join(problems))
        self.problems = list(problems)


@dataclass(frozen=True)
class Piece:
    """One smooth piece: g(phi) = poly(phi) + a sin(n phi) + b cos(n phi), phi in [0, span]."""

    span: float
    poly: tuple          # c_0 .. c_7 (zero-padded)
    a: float = 0.0
    b: float = 0.0
    n: float = 0.0

    def derivative(self, phi, order=0):
        """d^order g / d phi^order at phi (a float or an array)."""
        phi = np.asarray(phi, float)
        c = np.polynomial.polynomial.polyder(np.array(self.poly), order) if order else \
            np.array(self.poly)
        out = np.polynomial.polynomial.polyval(phi, c) if c.size else np.zeros_like(phi)
        if self.n != 0.0 and (self.a != 0.0 or self.b != 0.0):
            n = self.n
            s, co = np.sin(n * phi), np.cos(n * phi)
            # d^k/dphi^k of a sin + b cos cycles with period 4
            seq = [(self.a * s + self.b * co), n * (self.a * co - self.b * s),
                   -n * n * (self.a * s + self.b * co), -n ** 3 * (self.a * co - self.b * s)]
            out = out + seq[order % 4] * (n ** (order - order % 4) if order >= 4 else 1.0)
        elif order == 0 and self.b != 0.0:
            out = out + self.b
        return out


@dataclass(frozen=True)
class Profile:
    """A checked cam profile: its period (an angle), pieces and corners."""

    period: float
    pieces: tuple
    corners: tuple       # per piece: whether its start (a joint) is a corner (slope jump)

    @property
    def has_corners(self) -> bool:
        return any(self.corners)

    def starts(self):
        """The angle at which each piece starts."""
        return np.concatenate([[0.0], np.cumsum([p.span for p in self.pieces])[:-1]])

    def lift(self, theta, order=0):
        """d^order g / d theta^order at angles theta (any real), piece by piece."""
        th = np.mod(np.asarray(theta, float), self.period)
        starts = self.starts()
        m = np.clip(np.searchsorted(starts, th, side="right") - 1, 0, len(self.pieces) - 1)
        out = np.empty(th.shape)
        for k, pc in enumerate(self.pieces):
            sel = m == k
            if np.any(sel):
                out[sel] = pc.derivative(th[sel] - starts[k], order)
        return out


# ------------------------------------------------------------------ reading a scene's table
def _num(x):
    """A finite number (an int too large for a float64 is not one)."""
    return is_number(x) and math.isfinite(float(x))


def _law(law, span, rise, start):
    """The pieces of a motion law of rise h over span S starting at height ``start``."""
    h, S = float(rise), float(span)
    c = [0.0] * (MAX_DEGREE + 1)
    c[0] = start
    if law == "dwell":
        return [Piece(S, tuple(c))]
    if law == "constant_velocity":
        c[1] = h / S
        return [Piece(S, tuple(c))]
    if law == "polynomial_345":
        c[3], c[4], c[5] = 10 * h / S ** 3, -15 * h / S ** 4, 6 * h / S ** 5
        return [Piece(S, tuple(c))]
    if law == "simple_harmonic":
        c[0] = start + h / 2
        return [Piece(S, tuple(c), a=0.0, b=-h / 2, n=math.pi / S)]
    if law == "cycloidal":
        c[1] = h / S
        return [Piece(S, tuple(c), a=-h / (2 * math.pi), b=0.0, n=2 * math.pi / S)]
    if law == "parabolic":
        half = S / 2
        first = list(c)
        first[2] = 2 * h / S ** 2                 # 2 h x^2 with x = phi / S
        second = [0.0] * (MAX_DEGREE + 1)         # h (1 - 2 (1 - x)^2) from x = 1/2
        # in the second half's local angle psi = phi - S/2: x = 1/2 + psi / S
        second[0] = start + h / 2
        second[1] = 2 * h / S
        second[2] = -2 * h / S ** 2
        return [Piece(half, tuple(first)), Piece(half, tuple(second))]
    raise AssertionError(law)


def read(table, key="system.profile") -> Profile:
    """A scene's ``[system.profile]`` table -> a checked ``Profile``; ``ProfileError``
    lists every problem, each naming its key (``system.profile.pieces[2].poly``), its value
    and what is allowed: every number finite and within the ranges in which the certified
    bounds and the kernels stay finite and meaningful (MIN_PERIOD..MAX_PERIOD,
    MIN_SPAN_SHARE, MAX_LIFT, MAX_TURN, MAX_PIECES, MAX_DEGREE).  Each piece is read by
    ``_read_piece``; the pieces must cover the period, and meet without a jump
    (``_joints``, which finds the corners)."""
    problems = []
    if not isinstance(table, dict):
        raise ProfileError([f"{key}: {shown(table)} must be a table with period and pieces"])
    unknown = [k for k in table if k not in ("period", "pieces", "corners")]
    for k in unknown:
        problems.append(f"{key}.{cut(k, KEY_CHARS)}: unknown key; allowed: period, pieces, corners")
    period = table.get("period", 2 * math.pi)
    if not (_num(period) and MIN_PERIOD <= period <= MAX_PERIOD):
        problems.append(f"{key}.period: {shown(period)} must be a number in [{MIN_PERIOD:g}, "
                        f"{MAX_PERIOD:g}]: an angle, radians of omega t (2 pi one revolution); "
                        "for a period outside it rescale omega, which gives the same obstacle "
                        "in time")
        period = None                   # the spans are checked against no period
    else:
        period = float(period)
    raw = table.get("pieces")
    if not isinstance(raw, list) or not raw:
        raise ProfileError(problems + [f"{key}.pieces: {shown(raw)} must be a non-empty list of "
                                       "pieces (tables with span and poly, sine or law)"])
    if len(raw) > MAX_PIECES:
        raise ProfileError(problems + [f"{key}.pieces: {len(raw)} smooth pieces at least (a "
                                       f"parabolic law counts two); at most {MAX_PIECES} per "
                                       "period (the packed vector's room)"])
    pieces = []
    height = 0.0
    for i, pc in enumerate(raw):
        new = _read_piece(f"{key}.pieces[{i}]", pc, period, height, problems)
        if new is None:
            continue
        for p in new:
            pieces.append((i, p))
        last = new[-1]
        height = float(last.derivative(last.span))
    if problems:
        raise ProfileError(problems)
    if len(pieces) > MAX_PIECES:
        raise ProfileError([f"{key}.pieces: {len(pieces)} smooth pieces (a parabolic law "
                            f"counts two); at most {MAX_PIECES}"])
    total = sum(p.span for _, p in pieces)
    if abs(total - period) > 1e-12 * period:
        raise ProfileError([f"{key}.pieces: the spans add up to {total!r}, not the period "
                            f"{period!r}: the pieces must cover one period exactly"])
    corners = _joints(key, pieces, _chosen_corners(table, key, raw, pieces), problems)
    if problems:
        raise ProfileError(problems)
    return Profile(period, tuple(p for _, p in pieces), tuple(corners))


def _read_piece(k, pc, period, height, problems):
    """The smooth pieces (one, two for a parabolic law) of the table ``pc`` at key ``k``,
    starting at ``height`` (a law's start), or None after adding its problems: a span
    within [MIN_SPAN_SHARE, 1] times the ``period`` (None: the period's own problem stands),
    then a law of LAWS and its rise (``_law``), or poly and sine coefficients, each within
    its limits, and certified bounds that stay finite and within MAX_ENCLOSURE
    (``_lift_problem``)."""
    if not isinstance(pc, dict):
        problems.append(f"{k}: {shown(pc)} must be a table")
        return None
    for x in pc:
        if x not in KEYS:
            problems.append(f"{k}.{cut(x, KEY_CHARS)}: unknown key; allowed: {', '.join(KEYS)}")
    span = pc.get("span")
    if not _num(span) or span <= 0:
        problems.append(f"{k}.span: {shown(span)} must be a positive number (an angle)")
        return None
    span = float(span)
    if period is not None and not MIN_SPAN_SHARE * period <= span <= period:
        problems.append(f"{k}.span: {span!r} must be within [{MIN_SPAN_SHARE:g}, 1] times "
                        f"the period {period!r}: a shorter piece is a step rather than a "
                        "shape (a law's coefficients grow as rise / span^5)")
        return None
    if period is None and not MIN_SPAN_SHARE * MIN_PERIOD <= span <= MAX_PERIOD:
        return None                     # no period to compare with: its problem stands
    new = (_law_pieces(k, pc, span, height, problems) if "law" in pc
           else _poly_piece(k, pc, span, problems))
    if new is None:
        return None
    lifts = [_lift_problem(p) for p in new]
    if any(lifts):
        problems.append(f"{k}: {next(x for x in lifts if x)}")
        return None
    return new


def _law_pieces(k, pc, span, height, problems):
    """The pieces of a motion law (``law``, ``rise``) over ``span`` from ``height``, or None
    after adding its problem."""
    law = pc["law"]
    if law not in LAWS:
        problems.append(f"{k}.law: {shown(law)} is not a motion law; allowed: "
                        + ", ".join(LAWS))
        return None
    if "poly" in pc or "sine" in pc:
        problems.append(f"{k}: give a law or poly/sine, not both")
        return None
    rise = pc.get("rise", 0.0)
    if not (_num(rise) and abs(rise) <= MAX_LIFT):
        problems.append(f"{k}.rise: {shown(rise)} must be a number within "
                        f"+-{MAX_LIFT:g} (the lift, in units of beta: scale beta for a "
                        "larger one)")
        return None
    if law == "dwell" and rise != 0.0:
        problems.append(f"{k}.rise: {rise!r} but a dwell does not rise")
        return None
    return _law(law, span, rise, height)


def _poly_piece(k, pc, span, problems):
    """The one piece of a polynomial (``poly``, degree at most MAX_DEGREE) and a sinusoid
    (``sine`` = [a, b, n]: a and b within MAX_LIFT, n times the span within MAX_TURN), or
    None after adding its problem."""
    if "rise" in pc:
        problems.append(f"{k}.rise: only a law takes a rise")
    poly = pc.get("poly", [0.0])
    if isinstance(poly, list) and len(poly) > MAX_DEGREE + 1:
        problems.append(f"{k}.poly: degree {len(poly) - 1} is past the limit "
                        f"{MAX_DEGREE}")
        return None
    if (not isinstance(poly, list) or not poly or not all(_num(c) for c in poly)):
        problems.append(f"{k}.poly: {shown(poly)} must be a list of finite coefficients "
                        "c0, c1, ... (in the local angle)")
        return None
    a = b = n = 0.0
    if "sine" in pc:
        sn = pc["sine"]
        if not (isinstance(sn, list) and len(sn) == 3 and all(_num(x) for x in sn)):
            problems.append(f"{k}.sine: {shown(sn)} must be [a, b, n]: a sin(n phi) + "
                            "b cos(n phi), finite")
            return None
        a, b, n = (float(x) for x in sn)
        if max(abs(a), abs(b)) > MAX_LIFT:
            problems.append(f"{k}.sine: {shown(sn)}: a and b must be within "
                            f"+-{MAX_LIFT:g} (the lift, in units of beta: scale beta "
                            "for a larger one)")
            return None
        if abs(n) * span > MAX_TURN:
            problems.append(f"{k}.sine: n = {n!r} over the span {span!r} turns "
                            f"{abs(n) * span:.3g} radians; at most {MAX_TURN:g} (sin(n "
                            "phi) is evaluated to 1e-16 of its argument, and its "
                            "bounds grow as n^4)")
            return None
    c = [float(x) for x in poly] + [0.0] * (MAX_DEGREE + 1 - len(poly))
    return [Piece(span, tuple(c), a, b, n)]


def _chosen_corners(table, key, raw, pieces):
    """``corners = [i, ...]``: the pieces (indices of the table's list) whose start counts as
    a corner, as positions in ``pieces`` (a law's first piece); None when not given (the
    joints where the slope jumps are the corners)."""
    chosen = table.get("corners")
    if chosen is None:
        return None
    if not (isinstance(chosen, list) and len(chosen) <= len(raw)
            and all(isinstance(c, int) and not isinstance(c, bool) and 0 <= c < len(raw)
                    for c in chosen)
            and len(set(chosen)) == len(chosen)):
        raise ProfileError([f"{key}.corners: {shown(chosen)} must be a list of piece "
                            f"indices 0..{len(raw) - 1}, each at most once (the pieces "
                            "whose start is a corner)"])
    first = {}
    for m, (i, _) in enumerate(pieces):
        first.setdefault(i, m)
    return {first[c] for c in chosen}


def _joints(key, pieces, chosen, problems):
    """Whether each piece's start is a corner (``chosen``, else where the slope jumps by more
    than JOINT_TOL), at every joint, the period's end included; a jump in height there is a
    problem (an obstacle must be continuous)."""
    corners = []
    for m, (i, pc) in enumerate(pieces):
        prev_i, prev = pieces[m - 1]
        z_end = float(prev.derivative(prev.span))
        z_start = float(pc.derivative(0.0))
        scale = 1.0 + max(abs(z_end), abs(z_start))
        if abs(z_end - z_start) > JOINT_TOL * scale:
            where = (f"the end of piece {prev_i} and the start of piece {i}"
                     if m else f"the end of the period (piece {prev_i}) and its start "
                               f"(piece {i})")
            problems.append(f"{key}.pieces[{i}]: the obstacle jumps from {z_end!r} to "
                            f"{z_start!r} between {where}; an obstacle must be continuous")
        s_end = float(prev.derivative(prev.span, 1))
        s_start = float(pc.derivative(0.0, 1))
        if chosen is None:
            corners.append(abs(s_end - s_start) > JOINT_TOL * (1.0 + max(abs(s_end),
                                                                          abs(s_start))))
        else:
            corners.append(m in chosen)
    return corners


def _lift_problem(piece) -> str | None:
    """A piece whose certified bounds (``bounds``) are not finite or whose lift leaves
    +-MAX_ENCLOSURE, as the end of a problem (None when it is within both)."""
    with np.errstate(all="ignore"):
        b = bounds(piece)
    if not all(math.isfinite(x) for x in b):
        return ("its certified bounds of g and its derivatives overflow float64; give smaller "
                "coefficients")
    lift = max(abs(b[0]), abs(b[1]))
    if lift > MAX_ENCLOSURE:
        return (f"the lift reaches {lift:.6g} on this piece (its certified enclosure, from the "
                f"height the pieces before leave); at most {MAX_ENCLOSURE:g} in units of beta: "
                "scale beta for a larger obstacle")
    return None


def scale_problem(profile: Profile, omega: float, beta: float, k: float, kappa: float,
                  sigma: float = 0.0):
    """What of the kernels' numbers a profile at (omega, beta, k, kappa, sigma) would make
    non-finite, as (parameter, why) or None: the period in time (period / omega), the
    certified bounds in time of the second to fourth derivatives of z (beta omega^j times
    the largest bound of the j-th derivative of g over the pieces), the bound of the
    contact force's N'' and the Sturm floors.  Each is read from the row the kernels are
    given (``params.pack``: the pieces' bounds, Sturm bounds and floors) or computed as the
    obstacle's own functions compute them (``obstacle.profile_g2_abs``, ``_profile_max``,
    ``npp_bound``; in Python, ``row_bound`` and ``npp_bound`` here: checking a scene
    loads no numba and compiles nothing).  Each grows with |omega|, beta, sigma and k (a
    floor also as 1 / k^2), so a scene checks its extremes."""
    with np.errstate(all="ignore"):
        w = np.float64(abs(omega))
        if not math.isfinite(np.float64(profile.period) / w):
            return "omega", f"the period in time, {profile.period!r} / omega, overflows float64"
        row = np.zeros(P.NPARAM_PROFILE)
        row[P.OMEGA], row[P.BETA], row[P.K], row[P.KAPPA], row[P.SIGMA] = w, beta, k, kappa, sigma
        pack_profile(row, profile)
        b = row[P.BETA]
        G = (row_bound(row, P.PC_G2_LO, P.PC_G2_HI), row_bound(row, P.PC_G3),
             row_bound(row, P.PC_G4))                     # g'', g''', g''''
        for j, g in zip((2, 3, 4), G):
            if not (math.isfinite(b * w ** j) and math.isfinite(b * w ** j * g)):
                top = (FLOAT_MAX / 1e3 / (b * max(g, 1.0))) ** (1.0 / j) if b > 0 else 0.0
                return "omega", (f"the certified bound of z's derivative {j}, beta omega^{j} "
                                 f"max|g^({j})| (beta {beta!r}, max|g^({j})| {g:.6g}), overflows "
                                 f"float64; omega at most about {top:.3g} with this beta")
        if not math.isfinite(npp_bound(b, w, row[P.SIGMA], row[P.K], *G)):
            name = "sigma" if not math.isfinite(2.0 * row[P.SIGMA] * w * G[1]) else "k"
            return name, ("the bound of the contact force's second derivative, beta omega^2 "
                          "(omega^2 G4 + 2 sigma omega G3 + k^2 G2), overflows float64")
        for m in range(len(profile.pieces)):
            o = P.PROFILE0 + m * P.PIECE_STRIDE
            if not (math.isfinite(row[o + P.PC_STURM]) and math.isfinite(row[o + P.PC_FLOOR])):
                return "k", (f"the Sturm comparison's floor of a piece, -kappa - beta (k^2 g + "
                             f"omega^2 g'')_max / k^2 (k {k!r}, omega {omega!r}), overflows "
                             "float64")
    return None


# ------------------------------------------------------------------ certified bounds
def _bernstein_range(c, span):
    """Lower and upper bounds of the polynomial sum c_i x^i on [0, span]: the least and the
    largest of its Bernstein coefficients (an enclosure), widened by the rounding of the
    conversion."""
    c = np.asarray(c, float)
    d = c.size - 1
    if d <= 0:
        v = float(c[0]) if c.size else 0.0
        return v, v
    # scale to [0, 1]: c_i span^i
    a = c * span ** np.arange(d + 1)
    b = np.array([sum(math.comb(k, i) / math.comb(d, i) * a[i] for i in range(k + 1))
                  for k in range(d + 1)])
    pad = 1e-13 * (np.abs(a).sum() + 1e-300)
    return float(b.min() - pad), float(b.max() + pad)


def sinusoid_range(a, b, n, span):
    """Least and largest of a sin(n phi) + b cos(n phi) over phi in [0, span], exact (its
    ends and the crests inside), widened by rounding."""
    if n == 0.0 or (a == 0.0 and b == 0.0):
        return b, b
    amp = math.hypot(a, b)
    psi = math.atan2(b, a)                 # a sin x + b cos x = amp sin(x + psi)
    x0, x1 = sorted((psi, n * span + psi))
    vals = [amp * math.sin(x0), amp * math.sin(x1)]
    for crest, v in ((math.pi / 2, amp), (-math.pi / 2, -amp)):
        m = math.ceil((x0 - crest) / (2 * math.pi))
        if crest + 2 * math.pi * m <= x1:
            vals.append(v)
    pad = 1e-14 * amp * (1.0 + abs(x1))
    return min(vals) - pad, max(vals) + pad


def bounds(piece: Piece):
    """Certified bounds on the piece: least and largest g, least and largest second
    derivative, largest magnitudes of the third and fourth (all in the angle): the
    Bernstein enclosure of the polynomial plus the sinusoid's exact range."""
    poly = np.polynomial.polynomial
    c = np.array(piece.poly)
    out = []
    amp = math.hypot(piece.a, piece.b)
    n = abs(piece.n)
    sin_on = n != 0.0 and amp != 0.0
    for order in (0, 2):
        lo, hi = _bernstein_range(poly.polyder(c, order) if order else c, piece.span)
        slo, shi = sinusoid_range(piece.a, piece.b, piece.n, piece.span)
        if order:       # the sinusoid's second derivative is -n^2 times itself
            slo, shi = -n * n * shi, -n * n * slo
        lo, hi = lo + slo, hi + shi
        out += [lo, hi]
    for order in (3, 4):
        lo, hi = _bernstein_range(poly.polyder(c, order), piece.span)
        m = max(abs(lo), abs(hi))
        if sin_on:
            m += amp * n ** order
        out.append(m)
    return tuple(out)


# ------------------------------------------------------------------ the follower's jump
def contact_force_min(profile: Profile, omega, kappa, beta, k, force, sigma=0.0, n=20001):
    """The least contact force N = z'' + 2 sigma z' + k^2 z - f over a cam revolution of a
    follower riding the cam (u = z), f = ``force`` constant (Omega = 0: the spring's
    preload), on a grid of ``n`` angles per period and at every joint."""
    th = np.unique(np.concatenate([np.linspace(0.0, profile.period, n), profile.starts(),
                                   profile.starts() + 1e-12]))
    g, g1, g2 = (profile.lift(th, o) for o in (0, 1, 2))
    N = beta * omega ** 2 * g2 + 2 * sigma * beta * omega * g1 + k * k * (kappa + beta * g) \
        - force
    return float(N.min())


def jump_speed(profile: Profile, kappa, beta, k, force, sigma=0.0, r=0.0, hi=1e3):
    """The cam speed omega above which a follower riding the cam leaves it somewhere in
    the revolution (the contact force N of ``contact_force_min`` turns negative): the
    classic follower jump.  0 when it leaves at any speed: the slope drops at a joint (a
    launch), or rises there with r > 0 (the cam strikes the follower, which bounces off),
    or N <= 0 already at rest.  None when it never leaves below ``hi``.  Every joint whose
    slope jumps counts, named as a corner or not.  Bisection to 1e-10 relative."""
    if beta == 0.0:                        # a flat wall: N = k^2 kappa - F at every speed
        return None if k * k * kappa - force > 0.0 else 0.0
    for m, pc in enumerate(profile.pieces):
        prev = profile.pieces[m - 1]
        s_end = float(prev.derivative(prev.span, 1))
        s_start = float(pc.derivative(0.0, 1))
        jump = s_start - s_end
        if abs(jump) > JOINT_TOL * (1.0 + max(abs(s_end), abs(s_start))):
            if jump < 0.0 or r > 0.0:
                return 0.0
    if contact_force_min(profile, 0.0, kappa, beta, k, force, sigma) <= 0.0:
        return 0.0
    if contact_force_min(profile, hi, kappa, beta, k, force, sigma) >= 0.0:
        return None
    lo, up = 0.0, hi
    while up - lo > 1e-10 * up:
        mid = 0.5 * (lo + up)
        if contact_force_min(profile, mid, kappa, beta, k, force, sigma) < 0.0:
            up = mid
        else:
            lo = mid
    return up


def sturm_bound(piece: Piece, k, omega):
    """A certified upper bound of k^2 g + omega^2 g'' on the piece (g'' in the angle): the
    floor of the Sturm comparison of the free undamped gap is f_min = -k^2 kappa - beta
    times it (``obstacle.profile_sturm_floor``).  The sinusoid's share is exact,
    (k^2 - omega^2 n^2) times its range; the polynomial's a Bernstein enclosure."""
    poly = np.polynomial.polynomial
    c = np.array(piece.poly)
    h = poly.polyadd(k * k * c, omega * omega * poly.polyder(c, 2))
    _, hi = _bernstein_range(h, piece.span)
    q = k * k - omega * omega * piece.n ** 2
    slo, shi = sinusoid_range(piece.a, piece.b, piece.n, piece.span)
    return hi + max(q * slo, q * shi)


def pack_profile(p, profile):
    """Write a checked ``Profile`` (obstacles/profile.py) into the PROFILE_* slots of ``p``."""
    p[P.PROFILE_NP] = len(profile.pieces)
    p[P.PROFILE_PERIOD] = profile.period
    p[P.PROFILE_CORNERS] = 1.0 if profile.has_corners else 0.0
    start = 0.0
    for m, pc in enumerate(profile.pieces):
        o = P.PROFILE0 + m * P.PIECE_STRIDE
        p[o + P.PC_SPAN] = pc.span
        p[o + P.PC_C0:o + P.PC_C0 + 8] = pc.poly
        p[o + P.PC_A], p[o + P.PC_B], p[o + P.PC_N] = pc.a, pc.b, pc.n
        p[o + P.PC_G_LO:o + P.PC_G4 + 1] = bounds(pc)
        p[o + P.PC_CORNER] = 1.0 if profile.corners[m] else 0.0
        p[o + P.PC_START] = start
        p[o + P.PC_STURM] = sturm_bound(pc, p[P.K], p[P.OMEGA])
        p[o + P.PC_LEN] = pc.span / p[P.OMEGA]
        p[o + P.PC_T0] = start / p[P.OMEGA]
        if p[P.K] > 0.0:
            p[o + P.PC_FLOOR] = -p[P.KAPPA] - p[P.BETA] * p[o + P.PC_STURM] / (p[P.K] * p[P.K])
        nz = np.flatnonzero(np.array(pc.poly))
        p[o + P.PC_DEG] = nz[-1] if nz.size else 0
        start += pc.span


def heights_at_zero(rows):
    """z(0) = kappa + beta g(0) per packed profile row (``pack_profile``), in numpy: the
    kernels' ``dispatch._profile_state`` on piece 0 at tau = 0, operation for operation, so
    equal to their ``z_state`` bit for bit (tests/obstacles/test_profiles.py).  A sweep's
    first call then needs no jitted heights kernel before its kernel (benchmarks/README.md,
    "First compiles")."""
    rows = np.asarray(rows, dtype=float)
    c = rows[:, P.PROFILE0 + P.PC_C0:P.PROFILE0 + P.PC_C0 + 8]
    deg = rows[:, P.PROFILE0 + P.PC_DEG].astype(np.int64)
    x = rows[:, P.OMEGA] * 0.0                      # x = omega tau at tau = 0
    n_rows = np.arange(rows.shape[0])
    g = c[n_rows, deg]
    for i in range(6, -1, -1):                      # Horner from each piece's degree down
        g = np.where(i < deg, g * x + c[:, i], g)
    a = rows[:, P.PROFILE0 + P.PC_A]
    b = rows[:, P.PROFILE0 + P.PC_B]
    nx = rows[:, P.PROFILE0 + P.PC_N] * x
    g = np.where((a != 0.0) | (b != 0.0), g + (a * np.sin(nx) + b * np.cos(nx)), g)
    return rows[:, P.KAPPA] + rows[:, P.BETA] * g


# --- a profile's bounds, read from its packed row as obstacles/dispatch.py's jitted functions
# read them, in Python: ``scale_problem`` checks a scene with these, loading no numba
# (tests/scenes/test_validate_imports.py checks that both give the same numbers)
def row_bound(row, *slots):
    """The largest |row[o + slot]| over the pieces o of a profile's packed row (``pack``)
    and the ``slots`` given: ``obstacle._profile_max(row, slot)`` for one slot,
    ``obstacle.profile_g2_abs(row)`` for PC_G2_LO and PC_G2_HI."""
    n = np.int64(row[P.PROFILE_NP])
    m = 0.0
    for i in range(n):
        o = P.PROFILE0 + i * P.PIECE_STRIDE
        for slot in slots:
            m = max(m, abs(row[o + slot]))
    return m


def npp_bound(beta, w, sigma, k, g2, g3, g4):
    """``obstacle.npp_bound``: beta omega^2 (omega^2 g4 + 2 sigma omega g3 + k^2 g2), the
    bound of the contact force's |N''| less the forcing's share."""
    return beta * w * w * (w * w * g4 + 2.0 * sigma * w * g3 + k * k * g2)


# ------------------------------------------------------------------ the kind
class CamProfile(Obstacle):
    """``obstacle = "profile"``: a cam profile given by the scene's ``[system.profile]``
    table, whose period, pieces and corners are the table's own."""

    def period(self, omega, table=None):
        return table.period / omega

    def pieces_per_period(self, table=None):
        return len(table.pieces)

    def section_period(self, omega, table=None):
        """The profile's own period (its section is one turn of the cam)."""
        return self.period(omega, table)

    def read_tables(self, system, w):
        """``[system.profile]`` read and checked (``read``) into ``w.obstacle_table``; what was read,
        as the scene records it, into ``w.obstacle_tables``."""
        table = system.get("profile")
        if table is None:
            w.problems.append("system.profile: obstacle = \"profile\" needs a "
                              "[system.profile] table (period, pieces; docs/cams.md)")
            return
        try:
            w.obstacle_table = read(table)
        except ProfileError as e:
            w.problems += e.problems
            return
        record = {"period": float(table.get("period", w.obstacle_table.period)),
                  "pieces": table["pieces"]}
        if "corners" in table:
            record["corners"] = table["corners"]
        w.obstacle_tables["profile"] = record

    def check_scales(self, w, axes):
        """The profile at the scene's extreme omega, beta, k and kappa (swept or fixed): a
        problem, naming the parameter's key and value, where the kernels' numbers would not
        be finite (``scale_problem``: lengths in time, certified bounds, Sturm floors)."""
        swept = {a.name: a.values for a in axes}

        def values(name):
            v = swept.get(name, [w.system.get(name)])
            return [x for x in v if x is not None and math.isfinite(x)] or [0.0]
        for omega in {min(values("omega")), max(values("omega"))}:
            for k in {min(values("k")), max(values("k"))}:
                for kappa in {min(values("kappa")), max(values("kappa"))}:
                    beta = max(values("beta"))
                    if omega <= 0.0:
                        continue
                    sigma = max(values("sigma"))
                    found = scale_problem(w.obstacle_table, omega, beta, k, kappa, sigma)
                    if found:
                        name, why = found
                        value = {"omega": omega, "beta": beta, "k": k, "sigma": sigma}[name]
                        key = f"sweep.{name}" if name in swept else f"system.{name}"
                        w.problems.append(f"{key}: {value!r} with this cam profile: {why} (the "
                                          "kernels' numbers must stay finite)")
                        return

    def pack_rows(self, rows, values, table=None):
        for row in rows:
            pack_profile(row, table)

    def top(self, ctx):
        """kappa + beta max g."""
        prof = getattr(ctx, "obstacle_table", None)
        if prof is None:
            return None
        th = np.linspace(0.0, prof.period, 4097)
        return max(ctx.values_list("kappa")) + max(ctx.values_list("beta")) * float(
            prof.lift(th).max())

    def height_at_zero(self, ctx, kappa):
        prof = getattr(ctx, "obstacle_table", None)
        if prof is None:
            return kappa, "kappa"
        g0 = float(prof.lift(0.0))
        return (kappa + max(b * g0 for b in ctx.values_list("beta")),
                f"kappa + beta g(0), g(0) = {g0!r},")

    def start_heights(self, rows):
        return heights_at_zero(rows)

    def corner_at_start(self, row, j):
        """The joint's own flag (``pack_profile``: PC_CORNER of piece j mod the pieces)."""
        n = int(row[P.PROFILE_NP])
        return bool(row[P.PROFILE0 + (int(j) % n) * P.PIECE_STRIDE + P.PC_CORNER] != 0.0)

    def has_corners(self, table=None):
        return table.has_corners

    def corner_places(self, rows, ids, has):
        """The piece whose start is the corner (its id), counted on from the first piece
        (m = id mod its pieces per period): its place is the number of corners among pieces
        0 .. m less one."""
        n = rows[:, P.PROFILE_NP].astype(np.int64)
        flags = rows[:, P.PROFILE0 + P.PC_CORNER::P.PIECE_STRIDE] != 0.0
        ordinal = np.cumsum(flags, axis=1) - 1
        m = np.where(has, ids, 0) % n[:, None]
        return np.take_along_axis(ordinal, m, axis=1)

    def marks(self, ax, axes, values, system):
        """Swept in omega with a constant force (Omega = 0: a follower's spring preload): the
        jump speed above which a follower riding the cam leaves it (``jump_speed``), a
        vertical line."""
        if not axes or axes[0] != "omega" or system.get("Omega", 1.0) != 0.0:
            return []
        prof = read(system["profile"])
        force = system.get("F", 0.0) * math.cos(system.get("phi", 0.0))
        w = jump_speed(prof, system.get("kappa", 0.0), system.get("beta", 1.0),
                       system.get("k", 1.0), force, system.get("sigma", 0.0),
                       system.get("r", 0.8))
        x = values["omega"]
        if w == 0.0:
            return [ax.text(0.99, 0.99, "no jump speed: the follower leaves the cam at every "
                            "speed (a corner launches or strikes it)",
                            transform=ax.transAxes, ha="right", va="top", fontsize=7,
                            color="0.3")]
        if w is None or not (x.min() <= w <= x.max()):
            return []
        return [ax.axvline(w, color="tab:red", lw=0.8, ls="--",
                           label=rf"jump speed $\omega_j$ = {w:.6g}")]

    def speed(self, values, table=None):
        """beta omega max |g'|."""
        th = np.linspace(0.0, table.period, 1025)
        return float(values["beta"]) * float(values["omega"]) * float(
            np.abs(table.lift(th, 1)).max())


# period, pieces and corners are the scene's profile's (docs/cams.md); the flow's orbit problem
# reads them from the packed row (its pieces, ``corner_at_start``)
OBSTACLE = CamProfile("profile", 3, "kappa + beta g(omega t), g a cam profile of polynomial and "
                      "sinusoidal pieces ([system.profile])", period_pi=2, pieces=1, corners=True,
                      tables=("profile",), own_kernel=True)
