"""The event loop of a linear vibro-impact system, jitted (issue 33): ``run`` with the arrays
``prepare`` builds, per item of a sweep by ``batch.run_batch``.  Flights are exact (y' = A y
on the augmented state, flight.py); events are certified.

**Chunks.**  Time goes in chunks of H = 1 / |A| (from each impact).  On a chunk from p, a
contact's flight gap is a polynomial:
a . x(p + s) = sum_k b_k (s / H)^k, b_k = c (A H)^k y(p) / k! (``gap_poly``, k < 24; the
tail beyond is below e / 20! of |c| |y| for the derivatives up to the fourth, under the
sum's rounding).  The gap g = a . x - z is that polynomial minus the obstacle's own formula
on each of its smooth pieces within the chunk, searched in turn (``obstacles.dispatch``;
each piece named by its index, so that at a corner z' is that piece's own).

**The search** (``first_event``) is the flow kernel's certified step, ``roots.bracket``: from
a point with g and its first three derivatives it steps by the first root of the concave
lower quadratic, so no root is skipped, and it brackets and polishes a transversal root to
``tol``.  Its bounds over the chunk: the flight part's d-th derivative (d = 2, 3, 4) is at
most N_d |y(p)|, with N_d >= max over s in [0, H] of |c A^d expm(A s)| (``flight_bounds``,
once per system), plus the piece's bounds of z's derivatives.  A chunk's first step reads g
and its derivatives off the polynomial's first coefficients; a chunk that the first step
proves free costs four dot products.  Where 60 steps do not settle (a slow approach to a
near-graze), the halving of ``search`` takes over from there (the method of events.py: the
Taylor bound of |g''|, no root where the concave lower bound stays positive, left half
first).

**Flights of any length** (``advance``): E_0 = expm(A H) for whole chunks, the ladder E_k =
expm(A H / 2^k), k <= 12 (``ladder``: Taylor series to the term 20, |A H / 2^k| <= 1), for
the first 12 binary digits of the rest, and the last part (|A| d <= 2^-12) by its series
to order 5.  The loop multiplies matrices by vectors and nothing else.

At an event: the earliest over the contacts (ties within ``tol``: the contacts' order).  An
event where the contact moves away (w >= 0: a graze, or a gap left below zero by the last
impact's resolution) is no impact: the contact is free for the leaving rule's step w / B
(within its piece and a chunk) while the others are searched on from there.  A contact
found with g <= 0 and g' > 0 at a chunk's start (just after its impact) is free until
g' / B (B >= |g''| on the chunk).  Time is counted as the last event's time plus whole
chunks (summed chunk by chunk it would drift by a rounding of t each: 1e-7 by t = 1e4 at
|A| = 1e4; tests/models/test_linear_kernel.py).

Obstacles are evaluated by ``obstacles.dispatch`` on each contact's packed row (the flow's
kinds, beta of either sign; a cam profile not yet).  The certification is exact
arithmetic's: flights drift by rounding (about 1e-12 over 80 chunks, measured), and a dip
shallower than that drift is decided by rounding; time is absolute, so past t ~ 1e4 impact
times are resolved to ulp(t) rather than ``tol``.  The time budget ends the run.

**Sticking** (docs/linear.md, "Sticking"): a rebound w+ <= ``chatter`` on a contact that can
be held (``soft`` -2: law "impact", a fixed obstacle, no soft stops) whose contact force after
the law with r = 0 presses (``held_force`` > 0) is recorded as an impact with v+ that held
velocity, the state put on the contact (``snap``), and the loop goes on in mode 1 + i (the
held flight, ``flight.held``; ``mode_arrays``), where contact i's rows are its force's: its
root with a negative rate is the release (not recorded), after which the contact is free for
``release_step``.  An impact elsewhere while held releases it.  Any other chatter (a contact
that cannot be held, a force <= 0, a second contact while one is held) ends the run
(CHATTERS), as does the budget spent while held (stuck: the file's STUCK).

**Soft stops** (law "spring", fixed obstacles; docs/linear.md, "Soft stops"): each set of
them acting is a mode with a flight of its own (K + k a a^T, C + c a a^T, k kappa a), whose
arrays ``prepare`` stacks by mode (``mode_arrays``: "Es", "As", ... indexed by the mode's
bits); ``run`` takes the stacks and the loop binds the arrays of the mode that acts.  Inside
a soft stop its gap rows and obstacle are those of -g, so its exit is found by the same
certified search as any event.  At an entry or exit nothing jumps: the mode switches, the
contacts' free steps are cleared (their bounds were the other flight's), and an entry is
recorded as an impact with v+ = v- (no chatter test); an exit is not recorded.  Without soft
stops there is one mode, the flight's own arrays: the loop's arithmetic is the same as
before, bit for bit.

With the two-particle model's words (``[system] words``: ``run``'s ``counted`` and
``corners``) only one contact's impacts count and are recorded, each with its offset to the
other's impacts, settled on-line by the two-particle kernel's rule (``analysis``).
"""

from __future__ import annotations

import math

import numpy as np

from ..._jit import STOPPED, jit, jit_inline, stop_requested
from ...analysis import close_corner_offsets, offset_to_previous, settle_corner_offsets
from ...numerics.roots import FAIL, FOUND, bracket
from ...numerics.roots import NONE as ROOT_NONE
from ...obstacles.dispatch import (
    NDERIVED,
    piece_at,
    piece_length,
    piece_start,
    z_state,
    zpp_range,
    zppp_max,
    zpppp_max,
)
from ..flow.params import BETA, KAPPA, NPARAM
from .events import TAYLOR_TERMS, ContactObstacle
from .flight import augmented, forcing_state, held, holdable, soft_contacts

LEVELS = 52                 # ``search``'s deepest halving: H / 2^52 resolves a chunk to its bit
LADDER_BITS = 12            # ``advance``: the ladder's first bits, then Taylor's series of A
TAYLOR_FINISH = 5           # ... to this order: (|A| d)^6 / 6! <= 2^-72 / 720 for d <= H 2^-12
POLY_TERMS = 24             # the gap's Taylor polynomial over a chunk (``gap_poly``)
# its tail after 24 terms, for the derivatives d <= 4 over u = s / H <= 1:
# |c| |y| |A|^d u^(24 - d) / (24 - d)! e^u <= |c| |y| H^-d e / 20!
POLY_STEPS = 60             # certified steps on the polynomial before the halving takes over
NONE, IMPACT, GRAZE = 0, 1, 2
STEPS_OUT = 3               # ``first_event``: its step budget spent
OK, CHATTERS, BUDGET, ESCAPED, NONFINITE = 0, 1, 2, 3, 4
SWITCH = -3                 # ``_flights``: a switch of mode (never a run's status)
STOP_POLL = 4096            # obstacle pieces walked within a chunk between looks at the stop flag


def prepare(system, t0, x0, v0):
    """The arrays of ``run`` for one system and start: a dict (module docstring).  The
    flight's part (``flight_arrays``) is computed once for systems that differ only in
    their contacts' obstacles and laws (a sweep of kappa, beta, omega or r).  With soft
    stops, the arrays of each set of them acting (``mode_arrays``)."""
    flight = _memo_flight(system, 0)
    nc = len(system.contacts)
    rows = np.zeros((nc, NPARAM))
    ds = np.zeros((nc, NDERIVED))
    for i, c in enumerate(system.contacts):
        ob = ContactObstacle(c.obstacle, c.kappa, c.beta, c.omega)
        rows[i], ds[i] = ob.row, ob.d
    y0 = np.concatenate([np.asarray(x0, float), np.asarray(v0, float),
                         forcing_state(system, t0)])
    return {**flight, **mode_arrays(system, flight, rows, ds), "rows": rows, "ds": ds,
            "gaps": np.array([c.gap for c in system.contacts], float),
            "r": np.array([c.r for c in system.contacts], float), "y0": y0,
            "t0": float(t0), "n": system.n}


def _memo_flight(system, active):
    """``flight_arrays`` of the flight with the soft stops ``active`` acting (0: none), each
    acting contact's gap searched from inside (its sign turned: ``flight_arrays``),
    remembered in FLIGHT_MEMO."""
    A = augmented(system, active)
    signs = _signs(system, active)
    gaps = np.array([c.gap for c in system.contacts], float)
    key = (A.tobytes(), A.shape, gaps.tobytes(), system.mass.tobytes()) + \
        ((signs.tobytes(),) if active else ())
    flight = FLIGHT_MEMO.get(key)
    if flight is None:
        flight = flight_arrays(system, A, gaps, signs if active else None)
        if len(FLIGHT_MEMO) >= FLIGHT_MEMO_SIZE:
            FLIGHT_MEMO.pop(next(iter(FLIGHT_MEMO)))
        FLIGHT_MEMO[key] = flight
    return flight


def _signs(system, active):
    """(nc,) -1 for each soft stop acting in ``active`` (its gap g < 0: the search is on
    -g, whose root is the stop's exit), +1 for the others."""
    signs = np.ones(len(system.contacts))
    for b, i in enumerate(soft_contacts(system)):
        if active >> b & 1:
            signs[i] = -1.0
    return signs


def mode_arrays(system, flight, rows, ds):
    """The arrays of ``run`` per set of soft stops acting (a mode: bit b for soft stop b of
    ``flight.soft_contacts``; 2^(soft stops) modes, mode 0 none, whose arrays are
    ``flight``'s, ``rows``' and ``ds``'): "Es", "As", "Hs", "normAs", "cAm", "cAsm", "Nm",
    "rowsm", "dsm" (stacked by mode) and "soft" (nc,), each contact's bit (-1: law
    "impact").  In mode ``act`` an acting soft stop's gap rows (c A^k) and its obstacle
    (z = -kappa) are those of -g = -a . x + kappa: the search for its exit is the search
    for a root of -g from above, the same certified search as for an impact."""
    soft = soft_contacts(system)
    bits = np.full(len(system.contacts), -1, np.int64)
    for b, i in enumerate(soft):
        bits[i] = b
    flights, rowsm, dsm = [flight], [rows], [ds]
    can_hold = holdable(system)
    if any(can_hold):
        # sticking (docs/linear.md, "Sticking"): mode 1 + i holds contact i, its "gap" rows
        # those of its contact force (``flight.held``) against z = 0; -2 marks it holdable
        still = ContactObstacle("fixed", 0.0)
        for i in range(len(system.contacts)):
            if can_hold[i]:
                f = _memo_held(system, i)
                if f is not None:
                    bits[i] = -2
                    flights.append(f)
                    r, d = rows.copy(), ds.copy()
                    r[i], d[i] = still.row, still.d
                    rowsm.append(r)
                    dsm.append(d)
                    continue
            flights.append(flight)
            rowsm.append(rows)
            dsm.append(ds)
    for act in range(1, 1 << len(soft)):
        flights.append(_memo_flight(system, act))
        r, d = rows.copy(), ds.copy()
        for b, i in enumerate(soft):
            if act >> b & 1:
                c = system.contacts[i]
                ob = ContactObstacle(c.obstacle, -c.kappa, c.beta, c.omega)
                r[i], d[i] = ob.row, ob.d
        rowsm.append(r)
        dsm.append(d)
    out = {new: np.stack([np.asarray(f[old], float) for f in flights]) for new, old in
           (("Es", "E"), ("As", "A"), ("Hs", "H"), ("normAs", "normA"), ("cAm", "cA"),
            ("cAsm", "cAs"), ("Nm", "N"))}
    return {**out, "rowsm": np.stack(rowsm), "dsm": np.stack(dsm), "soft": bits}


def _memo_held(system, i):
    """``flight_arrays`` of the flight with contact i held (``flight.held``), contact i's rows
    those of its contact force; None where nothing ever presses it."""
    A, row = held(system, i)
    if row is None:
        return None
    gaps = np.array([c.gap for c in system.contacts], float)
    key = (A.tobytes(), A.shape, gaps.tobytes(), system.mass.tobytes(), "held", i)
    flight = FLIGHT_MEMO.get(key)
    if flight is None:
        flight = flight_arrays(system, A, gaps, None, {i: row})
        if len(FLIGHT_MEMO) >= FLIGHT_MEMO_SIZE:
            FLIGHT_MEMO.pop(next(iter(FLIGHT_MEMO)))
        FLIGHT_MEMO[key] = flight
    return flight


# the flight's arrays of the last systems prepared (``prepare``), by their matrix A, gaps
# and mass matrix: a sweep of a contact's numbers prepares its flight once
FLIGHT_MEMO: dict = {}
FLIGHT_MEMO_SIZE = 16


def flight_arrays(system, A, gaps, signs=None, rows=None):
    """The arrays of ``run`` that depend on the flight alone (A, its ladder, the gaps'
    series and bounds, M^-1 a): a dict, shared by the systems ``prepare`` finds equal
    (never written to: ``run`` and ``batch.run_batch`` only read them).  ``signs`` (nc,):
    each contact's gap rows taken with that sign (-1: an acting soft stop, ``mode_arrays``);
    ``rows``: {contact: a row of the augmented state} searched instead of its gap (a held
    contact's force, of norm |a|: ``flight.held``)."""
    m = A.shape[0]
    normA = float(np.linalg.norm(A, 2))
    H = 1.0 / max(normA, 1e-300)
    E = ladder(A, H)
    nc = len(system.contacts)
    cA = np.zeros((nc, TAYLOR_TERMS + 3, m))
    cAs = np.zeros((nc, POLY_TERMS, m))
    D = np.zeros((nc, system.n))
    for i, c in enumerate(system.contacts):
        a = c.gap if signs is None else signs[i] * c.gap
        row = np.zeros(m)
        row[:system.n] = a
        if rows is not None and i in rows:
            row = np.array(rows[i], float)
        first = row.copy()
        for k in range(TAYLOR_TERMS + 3):
            cA[i, k] = row
            row = row @ A
        row = first
        for k in range(POLY_TERMS):          # c (A H)^k / k!: each of norm <= |c| / k!
            cAs[i, k] = row
            row = row @ (A * H) / (k + 1)
        D[i] = np.linalg.solve(system.mass, c.gap)
    N = np.array([flight_bounds(cA[i, 0], A, E, H, normA) for i in range(nc)]).reshape(nc, 3)
    return {"E": E, "A": A, "H": H, "normA": normA, "cA": cA, "cAs": cAs, "N": N,
            "normc": np.array([np.linalg.norm(c.gap) for c in system.contacts]), "D": D}


@jit
def copy_to(dst, src, n):
    """dst[:n] = src[:n], element by element: an array assignment compiles numba's
    shape-mismatch message (2 s of the loop's first compile)."""
    for i in range(n):
        dst[i] = src[i]


@jit
def matvec(E, k, y, out):
    """out = E[k] y."""
    m = y.shape[0]
    for i in range(m):
        s = 0.0
        for j in range(m):
            s += E[k, i, j] * y[j]
        out[i] = s


@jit_inline
def advance(E, A, H, y, length, tmp, tmp2):
    """y <- the state ``length`` later: E_0^floor(length / H), the E_k of the first
    LADDER_BITS binary digits of the rest, and the last part d < H 2^-LADDER_BITS by
    ``short_flight`` (exact to rounding).  The products are written out here: as calls,
    twice the time for a system of one mass (measured)."""
    if length < 0.0:
        raise ValueError("advance: a flight of negative length")
    m = y.shape[0]
    x = length / H
    whole = int(math.floor(x))
    f = x - whole
    for _ in range(whole):
        for i in range(m):
            acc = 0.0
            for jj in range(m):
                acc += E[0, i, jj] * y[jj]
            tmp[i] = acc
        for i in range(m):
            y[i] = tmp[i]
    for k in range(1, LADDER_BITS + 1):
        if f == 0.0:
            break
        f *= 2.0
        if f >= 1.0:
            for i in range(m):
                acc = 0.0
                for jj in range(m):
                    acc += E[k, i, jj] * y[jj]
                tmp[i] = acc
            for i in range(m):
                y[i] = tmp[i]
            f -= 1.0
    d = f * H / 2.0 ** LADDER_BITS
    if d > 0.0:
        short_flight(A, y, d, tmp, tmp2)


@jit_inline
def short_flight(A, y, d, tmp, tmp2):
    """y <- the state d later, for |A| d <= 2^-LADDER_BITS: the series y + d A (y + d/2 A
    (y + ...)) to order TAYLOR_FINISH (its remainder below 2^-72 / 720 of |y|)."""
    m = y.shape[0]
    for i in range(m):
        tmp2[i] = y[i]
    for k in range(TAYLOR_FINISH, 0, -1):
        c = d / k
        for i in range(m):
            acc = 0.0
            for jj in range(m):
                acc += A[i, jj] * tmp2[jj]
            tmp[i] = acc
        for i in range(m):
            tmp2[i] = y[i] + c * tmp[i]
    for i in range(m):
        y[i] = tmp2[i]


@jit
def ladder(A, H):
    """The flights E_k = expm(A H / 2^k), k = 0 .. LADDER_BITS, each by its Taylor series
    to the term 20 (|A H / 2^k| <= 1: the remainder is below e / 21! < 6e-20 of the norm,
    under rounding; checked against flight.expm in tests/models/test_linear_kernel.py)."""
    m = A.shape[0]
    E = np.zeros((LADDER_BITS + 1, m, m))
    term = np.empty((m, m))
    nxt = np.empty((m, m))
    for k in range(LADDER_BITS + 1):
        h = H / 2.0 ** k
        for i in range(m):
            for jj in range(m):
                term[i, jj] = 1.0 if i == jj else 0.0
        for n in range(1, 21):
            for i in range(m):
                for jj in range(m):
                    E[k, i, jj] += term[i, jj]
            for i in range(m):
                for jj in range(m):
                    acc = 0.0
                    for q in range(m):
                        acc += term[i, q] * A[q, jj]
                    nxt[i, jj] = acc * h / n
            term, nxt = nxt, term
        for i in range(m):
            for jj in range(m):
                E[k, i, jj] += term[i, jj]
    return E


@jit
def flight_bounds(c, A, E, H, normA):
    """N[d - 2] >= max over s in [0, H] of |c A^d expm(A s)| (2-norms), d = 2, 3, 4: so that
    |g^(d)| <= N[d - 2] |y| along a flight of length <= H from the state y, for the flight
    part of the gap g = c . y - z.  On each eighth [s_i, s_i + H/8] (s_i = i H / 8, expm(A
    s_i) = E_3^i): c A^d expm(A (s_i + r)) = sum_k c A^(d+k) E_3^i r^k / k!, whose norm is
    at most sum_(k < 16) |c A^(d+k) E_3^i| (H/8)^k / k! plus the tail's |c A^(d+16)|
    |E_3^i|_F (H/8)^16 / 16! e^(|A| H / 8), times 1 + 1e-9 for the rounding of the
    products (where the spectrum is real and dominant the sum is the maximum itself, and
    the maximum comes within 1 - 8e-13 of the bound with a factor 1 + 1e-12).  About
    e^(1/8) of the true maximum for a rotation, where the series of |c A^(d+k) y| about the
    chunk's start gives e."""
    m = A.shape[0]
    N = np.zeros(3)
    P = np.eye(m)
    u = np.empty(m)
    row = np.empty(m)
    sig = H / 8.0
    for _ in range(8):
        pf = 0.0
        for a in range(m):
            for b in range(m):
                pf += P[a, b] * P[a, b]
        pf = math.sqrt(pf)
        for d in range(2, 5):
            for a in range(m):
                u[a] = c[a]
            for _ in range(d):
                _row_times(u, A, row)
                copy_to(u, row, m)
            total = 0.0
            fact = 1.0
            for k in range(16):
                _row_times(u, P, row)
                nr = 0.0
                for a in range(m):
                    nr += row[a] * row[a]
                total += math.sqrt(nr) * fact
                fact *= sig / (k + 1)
                _row_times(u, A, row)
                copy_to(u, row, m)
            nu = 0.0
            for a in range(m):
                nu += u[a] * u[a]
            total += math.sqrt(nu) * pf * fact * math.exp(normA * sig)
            N[d - 2] = max(N[d - 2], total * (1.0 + 1e-9))
        P = P @ E[3]
    return N


@jit
def _row_times(u, M, out):
    """out = u M (a row vector times a matrix)."""
    m = u.shape[0]
    for b in range(m):
        acc = 0.0
        for a in range(m):
            acc += u[a] * M[a, b]
        out[b] = acc


@jit_inline
def contact_tuples(r, d, i):
    """Contact i's obstacle as the tuples the obstacle functions take: its packed row
    (``flow.packed.as_tuple``'s 18 floats) and its derived row (``dispatch.derived_tuple``'s
    16), read off the stacked arrays ``r``, ``d`` without making a view of a row: a view's
    reference counting is atomic, and took half the loop's time where each chunk made
    them (measured with perf; tests/models/test_linear_kernel.py checks these tuples are
    those functions')."""
    return ((r[i, 0], r[i, 1], r[i, 2], r[i, 3], r[i, 4], r[i, 5], r[i, 6], r[i, 7], r[i, 8],
             r[i, 9], r[i, 10], r[i, 11], r[i, 12], r[i, 13], r[i, 14], r[i, 15], r[i, 16],
             r[i, 17]),
            (d[i, 0], d[i, 1], d[i, 2], d[i, 3], d[i, 4], d[i, 5], d[i, 6], d[i, 7], d[i, 8],
             d[i, 9], d[i, 10], d[i, 11], d[i, 12], d[i, 13], d[i, 14], d[i, 15]))


@jit
def gap_at(cA, i, y, row, d, j, t):
    """Contact i's gap and its rate at time t on its obstacle's piece j, from the state y."""
    gy = 0.0
    gpy = 0.0
    for k in range(y.shape[0]):
        gy += cA[i, 0, k] * y[k]
        gpy += cA[i, 1, k] * y[k]
    z, zp, _, _ = z_state(row, j, t - piece_start(d, j))
    return gy - z, gpy - zp


@jit
def bound2(cA, i, y, h, normc, normA, zpp):
    """A bound of |g''| over [p, p + h] from the state y at p (events.py's series with its
    remainder)."""
    J = cA.shape[1] - 2
    total = 0.0
    fact = 1.0                  # h^jj / jj!
    fa = 1.0                    # (|A| h)^jj / jj!
    for jj in range(J):
        s = 0.0
        for k in range(y.shape[0]):
            s += cA[i, jj + 2, k] * y[k]
        total += abs(s) * fact
        fact *= h / (jj + 1)
        fa *= normA * h / (jj + 1)
    ny = 0.0
    for k in range(y.shape[0]):
        ny += y[k] * y[k]
    # |c| |A|^(J+2) |y| h^J / J! e^(|A| h), as |A|^2 (|A| h)^J / J! (no overflow of |A|^(J+2))
    rem = normc * normA * normA * math.sqrt(ny) * fa * math.exp(normA * h)
    return total + rem + zpp


@jit
def piece_zpp(row, j):
    lo, hi = zpp_range(row, j)
    return max(abs(lo), abs(hi), abs(row[2]) * row[0] * row[0])


@jit
def search(E, A, H, cA, i, normc, normA, row, d, j, p, yp, q, tol, st_a, st_k, st_y, tmp, tmp2):
    """The first event of contact i in [p, q] (q - p <= H) on its piece j from the state yp
    at p, by halving on the ladder (module docstring): (kind, time, state there in tmp).
    The loop's fallback where ``first_event``'s certified steps do not settle."""
    zpp = piece_zpp(row, j)
    top = 0
    st_a[0] = p
    st_k[0] = 0
    copy_to(st_y[0], yp, yp.shape[0])
    while top >= 0:
        a = st_a[top]
        k = st_k[top]
        ya = st_y[top].copy()
        top -= 1
        if a >= q:
            continue
        h = H / 2.0 ** k
        ga, g1 = gap_at(cA, i, ya, row, d, j, a)
        B = bound2(cA, i, ya, h, normc, normA, zpp)
        if min(ga, ga + g1 * h - B * h * h / 2.0) > 0.0:
            continue
        if ga <= 0.0:
            copy_to(tmp, ya, ya.shape[0])
            return IMPACT, a
        if h <= tol or k == LEVELS:
            # as fine as asked: the right end's sign (at q where the interval passes it)
            b = min(a + h, q)
            copy_to(tmp, ya, ya.shape[0])
            advance(E, A, H, tmp, b - a, st_y[top + 1], tmp2)
            gb, _ = gap_at(cA, i, tmp, row, d, j, b)
            if gb <= 0.0:
                return IMPACT, b
            if b < q:
                copy_to(tmp, ya, ya.shape[0])
                return GRAZE, a
            continue
        # the right half under the left (past the ladder's levels: the short flight's series)
        if k + 1 < E.shape[0]:
            matvec(E, k + 1, ya, tmp)
        else:
            copy_to(tmp, ya, ya.shape[0])
            short_flight(A, tmp, h / 2.0, st_y[top + 1], tmp2)
        top += 1
        st_a[top] = a + h / 2.0
        st_k[top] = k + 1
        copy_to(st_y[top], tmp, tmp.shape[0])
        top += 1
        st_a[top] = a
        st_k[top] = k + 1
        copy_to(st_y[top], ya, ya.shape[0])
    return NONE, math.inf


@jit_inline
def gap_poly(cAs, i, y, b):
    """b[k] = c (A H)^k y / k!: contact i's flight gap a . x(p + s) = sum_k b[k] (s / H)^k
    over a chunk from the state y at p (s <= H; its tail: the module docstring)."""
    for k in range(cAs.shape[1]):
        acc = 0.0
        for jj in range(y.shape[0]):
            acc += cAs[i, k, jj] * y[jj]
        b[k] = acc


@jit_inline
def poly_tuple(b):
    """The POLY_TERMS coefficients b as a tuple: a value, which the search's many steps
    read with no reference counting (an array passed to a function with a loop keeps its
    atomic incref and decref, measured with perf)."""
    return (b[0], b[1], b[2], b[3], b[4], b[5], b[6], b[7], b[8], b[9], b[10], b[11], b[12], b[13],
            b[14], b[15], b[16], b[17], b[18], b[19], b[20], b[21], b[22], b[23])


@jit_inline
def poly_derivs(bt, u):
    """The polynomial sum_k bt[k] u^k and its first three derivatives in u, by Horner."""
    p0 = p1 = p2 = p3 = 0.0
    for k in range(len(bt) - 1, -1, -1):
        p3 = p3 * u + p2
        p2 = p2 * u + p1
        p1 = p1 * u + p0
        p0 = p0 * u + bt[k]
    return p0, p1, 2.0 * p2, 6.0 * p3


@jit_inline
def first_event(bt, H, B2, B3, B4, row, d, j, p, s0, L, tol):
    """The first root of a contact's gap g(s) = P(s / H) - z(p + s) on [s0, L] (a chunk from
    p, L <= H, within the obstacle's piece j; P the polynomial of the coefficients ``bt``,
    ``gap_poly`` of the state at p, as ``poly_tuple``): the
    certified steps of ``roots.bracket`` on g and its derivatives up to the third at each
    point, with bounds over the chunk of g'' (lo2, hi2), of |g'''| and of |g''''|: the
    flight part's B2, B3, B4 (``flight_bounds`` times |y(p)|) and the piece's bounds of
    z's derivatives.  Returns (code, s): roots.FOUND with the event at s, roots.NONE (no
    root), roots.FAIL (a value not a number), or STEPS_OUT after POLY_STEPS steps (the
    caller halves instead)."""
    h2 = H * H
    zlo, zhi = zpp_range(row, j)
    lo2 = -B2 - zhi
    hi2 = B2 - zlo
    m3 = B3 + zppp_max(row)
    m4 = B4 + zpppp_max(row)
    start = piece_start(d, j)
    s = s0
    for _ in range(POLY_STEPS):
        if s == 0.0:            # the chunk's start: the coefficients are the derivatives
            g, g1, g2, g3 = bt[0], bt[1], 2.0 * bt[2], 6.0 * bt[3]
        else:
            g, g1, g2, g3 = poly_derivs(bt, s / H)
        if row[BETA] == 0.0:        # z = kappa (a fixed stop): no formula to evaluate
            z, zp, zpp, zppp = row[KAPPA], 0.0, 0.0, 0.0
        else:
            z, zp, zpp, zppp = z_state(row, j, p + s - start)
        code, h, _ = bracket(g - z, g1 / H - zp, g2 / h2 - zpp, g3 / (h2 * H) - zppp, False,
                             L - s, lo2, hi2, m3, m4, tol, -1.0)
        if code == ROOT_NONE:
            return ROOT_NONE, L
        if code == FOUND or code == FAIL:
            return code, s + h
        s += h
        if s >= L:
            return ROOT_NONE, L
    return STEPS_OUT, s


@jit_inline
def state_norm(y, n, escape):
    """(OK, |y|) for the augmented state y; (NONFINITE, 0) where a coordinate or velocity is
    not a number, (ESCAPED, 0) where one is past ``escape`` in size."""
    for k in range(2 * n):
        a = abs(y[k])
        if not (a == a):
            return NONFINITE, 0.0
        if a > escape:
            return ESCAPED, 0.0
    ny = 0.0
    for k in range(y.shape[0]):
        ny += y[k] * y[k]
    return OK, math.sqrt(ny)


@jit
def run(Es, As, Hs, normAs, cAm, cAsm, Nm, normc, rowsm, dsm, gaps, D, r, soft, y0, t0, n, skip, count,
        tol, chatter, escape, t_max, control, o_t, o_c, o_x, o_vin, o_vout, o_y, counted, corners, period,
        o_off, o_corner):
    """Up to ``count`` impacts from y0 at t0 (module docstring), the first ``skip`` not
    recorded (a transient), the others into the outputs; the state after the last impact
    into ``o_y`` ((x, v): 2n): (status, impacts recorded).  A coordinate or velocity past
    ``escape`` in size ends the run (ESCAPED), one not a number (NONFINITE), as a start that
    is either.  Under a sweep's ``control`` (``_jit.Control``; 0: none) told to stop:
    (STOPPED, 0), its outputs incomplete.

    The two-particle model's words (``[system] words``; ``counted`` >= 0, else -1): only the
    impacts on contact ``counted`` count, ``skip`` and ``count`` of them, and only they are
    recorded, each with its offset to the impacts on contact ``corners`` into ``o_off`` and
    the corner's number into ``o_corner`` (``analysis.offset_to_previous``,
    ``settle_corner_offsets``: the two-particle kernel's rule).  After the last counted
    impact the run goes on to the next corner impact, which settles the last offsets, at
    most to the second multiple of ``period`` (the system's period, when > 0) after it, as
    the two-particle kernel goes on at most two sections; it then ends OK whatever ends it
    (the offsets still pending keep the previous corner's: ``close_corner_offsets``).

    The loop: each mode's events are ``_flights``'s, called with that mode's arrays as its
    arguments (bound once per mode) and returning at a switch of mode.  Rebound inside the
    loop at each switch, the arrays cost the loop 15 % of its throughput where nothing
    switches, and the search written as functions taking arrays another 25 % (their
    reference counting at every call; docs/linear.md, "What remains").  One compiled level
    between the sweep's batch and ``_flights``: each level links its callees' code in and
    optimises it again (their compile time)."""
    m = y0.shape[0]
    nc = gaps.shape[0]
    y = y0.copy()
    act = _initial_mode(gaps, rowsm, soft, y, n)      # the soft stops acting (mode_arrays)
    can_hold = False        # holdable contacts (soft -2): modes 1 + i hold contact i
    for i in range(nc):
        can_hold = can_hold or soft[i] == -2
    hold = -1               # the contact held (-1: none)
    free_until = np.full(nc, -math.inf)   # a contact moving away from an event: free until
    copy_to(o_y, y, 2 * n)
    tmp = np.empty(m)
    tmp2 = np.empty(m)
    yp = np.empty(m)
    b = np.empty(cAsm.shape[2])
    st_a = np.empty(2 * LEVELS + 4)
    st_k = np.empty(2 * LEVELS + 4, np.int64)
    st_y = np.empty((2 * LEVELS + 4, m))
    t = t0
    impacts = 0            # with ``counted`` >= 0: the impacts on that contact
    # the two-particle words: corner impacts so far, the last one's time, the recorded ones
    # waiting for the next (pend_lo .. pend_hi - 1); done: past the last counted impact
    n_corner, t_corner, pend_lo, pend_hi, done = 0, 0.0, 0, 0, False
    while True:
        (st, kept, t, t_max, impacts, act, hold, n_corner, t_corner, pend_lo, pend_hi, done,
         released) = _flights(Es[act], As[act], Hs[act], normAs[act], cAm[act], cAsm[act], Nm[act], normc,
                              rowsm[act], dsm[act], cAm, rowsm[0], gaps, D, r, soft, can_hold, act, hold,
                              y, t, n, skip, count, impacts, tol, chatter, escape, t_max, control, o_t,
                              o_c, o_x, o_vin, o_vout, o_y, counted, corners, period, o_off, o_corner,
                              n_corner, t_corner, pend_lo, pend_hi, done, free_until, tmp, tmp2, yp, b,
                              st_a, st_k, st_y)
        if st != SWITCH:
            break
        if released >= 0:
            # released (the contact force turned negative): the free flight again, the
            # contact free while its gap is at least g^(3) s^3 / 12 > 0 (``release_step``)
            _, ny = state_norm(y, n, escape)
            free_until[released] = t + release_step(cAm[act], Nm[act], released, y, ny, Hs[act], tol)
    if counted >= 0 and st != STOPPED:
        if corners >= 0:
            close_corner_offsets(o_off, o_corner, 0, kept)
        if kept == count - skip:
            st = OK
    return st, kept


@jit
def _flights(E, A, H, normA, cA, cAs, N, normc, rows, ds, cAm, rows0, gaps, D, r, soft, can_hold, act, hold,
             y, t, n, skip, count, impacts, tol, chatter, escape, t_max, control, o_t, o_c, o_x, o_vin,
             o_vout, o_y, counted, corners, period, o_off, o_corner, n_corner, t_corner, pend_lo, pend_hi,
             done, free_until, tmp, tmp2, yp, b, st_a, st_k, st_y):
    """The events of mode ``act``'s flight (its arrays E .. ds), from the state y at t: up to
    the run's end, (status, impacts recorded, ...), or up to a switch of mode, (SWITCH, 0,
    ...), with the loop's state (t, t_max, impacts, act, hold, the words' counters) and the
    contact just released (-1: none) for ``run`` to go on.  The search over each contact's
    pieces is written out here, not called: a call passing arrays costs their reference
    counting (``run``)."""
    m = y.shape[0]
    nc = gaps.shape[0]
    words = counted >= 0
    # time as t_base + k H: the chunks' flights are E_0 exactly, and time summed chunk by
    # chunk would drift by a rounding of t each (module docstring)
    t_base = t
    k_chunks = 0
    while impacts < count or (done and pend_hi > pend_lo):
        if stop_requested(control):
            return STOPPED, 0, t, t_max, impacts, act, hold, n_corner, t_corner, pend_lo, pend_hi, done, -1
        if t > t_max:
            return ((BUDGET if hold < 0 else CHATTERS), max(0, impacts - skip), t, t_max, impacts, act, hold,
                    n_corner, t_corner, pend_lo, pend_hi, done, -1)
        status, ny = state_norm(y, n, escape)
        if status != OK:
            return (status, max(0, impacts - skip), t, t_max, impacts, act, hold, n_corner, t_corner,
                    pend_lo, pend_hi, done, -1)
        # the chunk (H, or to t_max): each contact's pieces searched on its flight's polynomial,
        # the earliest event (ties: the contacts' order)
        L = min(H, t_max - t)
        best = math.inf
        bi = -1
        bj = 0
        for i in range(nc):
            # the contact's obstacle as the tuples the obstacle functions take (values: an
            # array argument's atomic reference counting took half the loop's time, measured
            # with perf, as it took a fifth of the flow kernel's: params.as_tuple)
            row, d = contact_tuples(rows, ds, i)
            j, _ = piece_at(d, t)
            # at a piece's end, t rounds into either piece: the one that goes on past t
            while piece_start(d, j) + piece_length(d, j) <= t:
                j += 1
            gap_poly(cAs, i, y, b)
            bt = poly_tuple(b)
            z, zp, _, _ = z_state(row, j, t - piece_start(d, j))
            g0 = bt[0] - z
            g1 = bt[1] / H - zp
            s0 = 0.0
            if free_until[i] > t:
                s0 = free_until[i] - t      # moving away from an event (below)
            elif g0 <= 0.0:
                if g1 <= 0.0:
                    if 0.0 < best:
                        best, bi, bj = 0.0, i, j
                    continue
                # leaving the obstacle: free until g' / B at least (events.py), within the
                # piece (its end is a corner, where z' jumps)
                s0 = min(g1 / (N[i, 0] * ny + piece_zpp(row, j)),
                         piece_start(d, j) + piece_length(d, j) - t)
            end = min(L, best)       # a later contact's event must come before the best
            # contact i's first event in [s0, end], walking its obstacle's pieces from j
            code = ROOT_NONE
            s = end
            walked = 0
            while s0 < end:
                walked += 1
                if walked % STOP_POLL == 0 and stop_requested(control):
                    # a fast obstacle: many pieces within one chunk
                    return (STOPPED, 0, t, t_max, impacts, act, hold, n_corner, t_corner, pend_lo, pend_hi,
                            done, -1)
                pe = piece_start(d, j) + piece_length(d, j) - t
                if pe <= s0:
                    j += 1
                    continue
                seg = min(end, pe)
                code, s = first_event(bt, H, N[i, 0] * ny, N[i, 1] * ny, N[i, 2] * ny, row, d, j,
                                      t, s0, seg, tol)
                if code == STEPS_OUT:
                    # a slow approach (a near-graze): halving on the ladder from there
                    copy_to(yp, y, m)
                    advance(E, A, H, yp, s, tmp, tmp2)
                    kind, te = search(E, A, H, cA, i, normc[i], normA, row, d, j, t + s,
                                      yp, t + seg, tol, st_a, st_k, st_y, tmp, tmp2)
                    code, s = (FOUND, te - t) if kind != NONE else (ROOT_NONE, seg)
                if code != ROOT_NONE:
                    break
                s0 = seg
                j += 1
            if code == FAIL:
                return (NONFINITE, max(0, impacts - skip), t, t_max, impacts, act, hold, n_corner, t_corner,
                        pend_lo, pend_hi, done, -1)
            if code == FOUND and s < best:
                best, bi, bj = s, i, j
        if bi < 0:
            if L < H:       # no event before the budget's end
                return ((BUDGET if hold < 0 else CHATTERS), max(0, impacts - skip), t, t_max, impacts, act,
                        hold, n_corner, t_corner, pend_lo, pend_hi, done, -1)
            # on by the chunk's flight E_0 (written out: a call with arrays costs their atomic
            # reference counting, measured with perf)
            for k in range(m):
                acc = 0.0
                for jj in range(m):
                    acc += E[0, k, jj] * y[jj]
                tmp[k] = acc
            for k in range(m):
                y[k] = tmp[k]
            k_chunks += 1
            t = t_base + k_chunks * H
            continue
        te = t + best
        advance(E, A, H, y, best, tmp, tmp2)
        j = bj
        row, d = contact_tuples(rows, ds, bi)
        _, zp, _, _ = z_state(row, j, te - piece_start(d, j))
        w = 0.0
        for k in range(n):
            w += gaps[bi, k] * y[n + k]
        w -= zp
        sb = soft[bi]
        if sb >= 0 and (act >> sb) & 1 == 1:
            w = -w              # inside a soft stop: its exit is the root of -g (mode_arrays)
        if bi == hold:
            w = 0.0             # held: the contact force's rate (its rows: mode_arrays)
            for k in range(m):
                w += cA[bi, 1, k] * y[k]
        t = te
        t_base = te
        k_chunks = 0
        if w >= 0.0:
            # moving away (a graze, or a gap left slightly below zero by the last impact's
            # resolution): no impact.  The contact is free for the leaving rule's step (within
            # its piece, where z' jumps at the end, and within a chunk, where the bound holds);
            # the loop goes on from here, every other contact searched from here as always
            B = bound2(cA, bi, y, H, normc[bi], normA, piece_zpp(row, j))
            free_until[bi] = te + max(2.0 * tol, min(w / B, H, piece_start(d, j) +
                                                     piece_length(d, j) - te))
            continue
        if bi == hold:
            # released (the contact force turns negative): the free flight again (``run``)
            free_until[:] = -math.inf
            return SWITCH, 0, t, t_max, impacts, 0, -1, n_corner, t_corner, pend_lo, pend_hi, done, bi
        switched = False
        rr = r[bi]
        if sb >= 0:
            # a soft stop entered or left: the state goes on (no jump), the flight switches
            act ^= 1 << sb
            free_until[:] = -math.inf
            if (act >> sb) & 1 == 0:    # an exit: not recorded
                return (SWITCH, 0, t, t_max, impacts, act, hold, n_corner, t_corner, pend_lo, pend_hi, done,
                        -1)
            switched = True
            w = 0.0             # an entry: recorded as an impact with v+ = v-
        elif sb < 0 and -r[bi] * w <= chatter:
            # chattering to rest: held where it can be (not while another is held) and its
            # contact force after the law with r = 0 presses (docs/linear.md, "Sticking")
            if sb == -2 and hold < 0 and held_force(cAm, gaps, D, bi, y, n, w) > 0.0:
                rr = 0.0
                hold = bi
                snap(y, n, gaps, D, bi, rows0[bi, KAPPA])
        elif hold >= 0:
            hold = -1           # an impact elsewhere releases the held contact
        if can_hold and (act > 0) != (hold >= 0) or (hold >= 0 and act != 1 + hold):
            act = 1 + hold
            free_until[:] = -math.inf
            switched = True
        counts = not words or (bi == counted and not done)
        kept = impacts - skip if counts else -1
        # the generalised Newton law at contact bi (``impact.newton_impact``; restitution rr),
        # recorded as impact number ``kept`` (not when < 0); written out (``_flights``)
        ad = 0.0
        for k in range(n):
            ad += gaps[bi, k] * D[bi, k]
        for k in range(n):
            if kept >= 0:
                o_vin[kept, k] = y[n + k]
            y[n + k] -= (1.0 + rr) * w * D[bi, k] / ad
            if kept >= 0:
                o_vout[kept, k] = y[n + k]
                o_x[kept, k] = y[k]
        if kept >= 0:
            o_t[kept] = te
            o_c[kept] = bi
        # the velocities changed: every contact's free step (a graze's, a release's) was
        # bounded on the flight before, and is searched again from here
        free_until[:] = -math.inf
        if words:
            n_corner, t_corner, pend_lo, pend_hi = _corners(bi, kept, te, corners, n_corner,
                                                            t_corner, pend_lo, pend_hi, o_t,
                                                            o_off, o_corner)
        impacts += 1 if counts else 0
        if done and pend_hi == pend_lo:
            break
        if not done:
            copy_to(o_y, y, 2 * n)
            if words and impacts == count:
                done = True
                if period > 0.0:        # at most to the second multiple of the period after
                    t_max = min(t_max, (math.floor(te / period) + 2.0) * period)
        if sb < 0 and -r[bi] * w <= chatter and hold != bi:
            return (CHATTERS, max(0, min(impacts, count) - skip), t, t_max, impacts, act, hold, n_corner,
                    t_corner, pend_lo, pend_hi, done, -1)
        if switched:
            return SWITCH, 0, t, t_max, impacts, act, hold, n_corner, t_corner, pend_lo, pend_hi, done, -1
    return (OK, max(0, impacts - skip), t, t_max, impacts, act, hold, n_corner, t_corner, pend_lo, pend_hi,
            done, -1)


@jit_inline
def _initial_mode(gaps, rowsm, soft, y, n):
    """The mode of a start: each soft stop whose gap a . x - kappa is below zero acts."""
    act = 0
    for i in range(gaps.shape[0]):
        if soft[i] >= 0:
            g = -rowsm[0, i, KAPPA]
            for k in range(n):
                g += gaps[i, k] * y[k]
            if g < 0.0:
                act |= 1 << soft[i]
    return act


@jit_inline
def held_force(cAm, gaps, D, i, y, n, w):
    """Contact i's force (``flight.held``, scaled) just after the law with r = 0 at an impact
    of w- = ``w``: v+ = v - w M^-1 a / (a^T M^-1 a), read by the held mode's rows."""
    ad = 0.0
    for k in range(n):
        ad += gaps[i, k] * D[i, k]
    lam = 0.0
    for k in range(y.shape[0]):
        lam += cAm[1 + i, i, 0, k] * y[k]
    for k in range(n):
        lam -= cAm[1 + i, i, 0, n + k] * w * D[i, k] / ad
    return lam


@jit_inline
def snap(y, n, gaps, D, i, kappa):
    """Puts the state on contact i: x <- x - g M^-1 a / (a^T M^-1 a), g = a . x - kappa (the
    smallest move in M's metric; within the event's resolution)."""
    ad = 0.0
    g = -kappa
    for k in range(n):
        ad += gaps[i, k] * D[i, k]
        g += gaps[i, k] * y[k]
    for k in range(n):
        y[k] -= g * D[i, k] / ad


@jit_inline
def release_step(cA, N, i, y, ny, H, tol):
    """After a release (g, g', g'' are 0): g >= g3 s^3 / 6 - B4 s^4 / 24 >= g3 s^3 / 12 > 0
    for s <= 2 g3 / B4, g3 = g^(3) (the free flight's rows), B4 = N_4 |y| over a chunk."""
    g3 = 0.0
    for k in range(y.shape[0]):
        g3 += cA[i, 3, k] * y[k]
    if g3 <= 0.0:
        return 2.0 * tol
    return max(2.0 * tol, min(H, 2.0 * g3 / (N[i, 2] * ny)))


@jit_inline
def _corners(bi, kept, te, corners, n_corner, t_corner, pend_lo, pend_hi, o_t, o_off, o_corner):
    """The two-particle words at an impact on contact ``bi`` at ``te`` (recorded as number
    ``kept``, not when < 0): a recorded impact's offset to the previous corner impact (pending
    till the next: ``analysis.offset_to_previous``), a corner impact's settling of those
    pending (``analysis.settle_corner_offsets``).  Returns (corner impacts so far, the last
    one's time, the pending impacts' range)."""
    if kept >= 0 and corners >= 0:
        o_off[kept], o_corner[kept] = offset_to_previous(n_corner > 0, te - t_corner, n_corner - 1)
        if pend_hi == pend_lo:
            pend_lo = kept
        pend_hi = kept + 1
    if bi == corners:
        settle_corner_offsets(o_off, o_corner, o_t, pend_lo, pend_hi, te, te - t_corner, n_corner)
        return n_corner + 1, te, 0, 0
    return n_corner, t_corner, pend_lo, pend_hi


def run_system(system, t0, x0, v0, count, tol=1e-12, chatter=1e-6, t_max=1e4, escape=1e6):
    """``run`` for one system and start: (status, dict of the recorded impacts: t, contact
    (names), x, v_in, v_out)."""
    a = prepare(system, t0, x0, v0)
    n = system.n
    o_t = np.full(count, np.nan)
    o_c = np.full(count, -1, np.int64)
    o_x, o_vin, o_vout = (np.full((count, n), np.nan) for _ in range(3))
    st, k = run(a["Es"], a["As"], a["Hs"], a["normAs"], a["cAm"], a["cAsm"], a["Nm"], a["normc"],
                a["rowsm"], a["dsm"], a["gaps"], a["D"], a["r"], a["soft"], a["y0"], a["t0"], n, 0, count,
                tol, chatter, escape, t_max, 0, o_t, o_c, o_x, o_vin, o_vout, np.empty(2 * n), -1, -1, 0.0,
                np.empty(0), np.empty(0, np.int64))
    names = [system.contacts[i].name for i in o_c[:k]]
    return st, {"t": o_t[:k], "contact": names, "x": o_x[:k], "v_in": o_vin[:k],
                "v_out": o_vout[:k]}
