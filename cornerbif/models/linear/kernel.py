"""The event loop of a linear vibro-impact system, jitted (issue 33; not yet a model's kernel:
``run`` is called with the arrays ``prepare`` builds).  The method of ``events.py`` and
``simulate.py``, with no matrix exponential inside the loop:

**A ladder of flights.**  Every interval the certified search looks at is a dyadic part of a
chunk of length H = 1 / |A|: [p + i H / 2^k, p + (i + 1) H / 2^k].  So the flights it needs
are E_k = expm(A H / 2^k), k = 0 .. LEVELS, computed once per system (``prepare``, by
``flight.expm``); the state at the right half's start is E_(k+1) y at the left's.  A flight
of any length L = H (m + f) is E_0^m times the E_k of f's binary digits (``advance``): 52
digits resolve f to the last bit, so the loop multiplies matrices by vectors and nothing
else.

**The search** (per contact, per chunk [p, q], q - p <= H, inside one smooth piece of every
contact's obstacle) is ``events._search``'s halving on the ladder: the Taylor bound of |g''|
with its remainder, no root where the concave lower bound stays positive, the left half
first.  The chunk's dyadic intervals may pass q (the piece's end): there the piece's own
formula is continued, whose |z''| stays within the sinusoid's beta omega^2 (a triangle's
0), so a proof of no root holds on [a, q]; a sign change past q is not an event of the
piece (the next chunk's piece decides).  A root resolved to an interval of width ``tol``:
an impact at its right end; a touch whose ends are both above zero: a graze, applied as an
impact when the relative velocity there approaches (w- < 0).  An event where the contact
moves away (w >= 0: a graze, or a gap left below zero by the last impact's resolution) is
no impact: the loop steps past it by the leaving rule's free step w / B.

Obstacles are evaluated by ``obstacles.dispatch`` on each contact's packed row (the flow's
kinds; a cam profile not yet).  Simultaneous events: the earliest, ties (events within
``tol`` of each other) in the order of the contacts.  The certification is exact
arithmetic's: the ladder's products drift by rounding (about 1e-12 over 80 chunks, measured),
and a dip shallower than that drift is decided by rounding; time is absolute, so past
t ~ 1e4 impact times are resolved to ulp(t) rather than ``tol``.  Chattering (a rebound
w+ <= ``chatter``) ends the run (CHATTERS), as do soft stops (not here) and the time
budget.
"""

from __future__ import annotations

import math

import numpy as np

from ..._jit import STOPPED, jit, stop_requested
from ...obstacles.dispatch import NDERIVED, piece_at, piece_length, piece_start, z_state, zpp_range
from ..flow.params import NPARAM
from .events import TAYLOR_TERMS, ContactObstacle
from .flight import augmented, expm, forcing_state

LEVELS = 52                 # the ladder E_0 .. E_LEVELS: H / 2^52 resolves a chunk to its bit
NONE, IMPACT, GRAZE = 0, 1, 2
OK, CHATTERS, BUDGET, ESCAPED, NONFINITE = 0, 1, 2, 3, 4


def prepare(system, t0, x0, v0):
    """The arrays of ``run`` for one system and start: a dict (module docstring)."""
    A = augmented(system)
    m = A.shape[0]
    normA = float(np.linalg.norm(A, 2))
    H = 1.0 / max(normA, 1e-300)
    E = np.empty((LEVELS + 1, m, m))
    for k in range(LEVELS + 1):
        E[k] = expm(A * (H / 2.0 ** k))
    nc = len(system.contacts)
    cA = np.zeros((nc, TAYLOR_TERMS + 3, m))
    rows = np.zeros((nc, NPARAM))
    ds = np.zeros((nc, NDERIVED))
    D = np.zeros((nc, system.n))
    for i, c in enumerate(system.contacts):
        row = np.zeros(m)
        row[:system.n] = c.gap
        for k in range(TAYLOR_TERMS + 3):
            cA[i, k] = row
            row = row @ A
        ob = ContactObstacle(c.obstacle, c.kappa, c.beta, c.omega)
        rows[i], ds[i] = ob.row, ob.d
        D[i] = np.linalg.solve(system.mass, c.gap)
    y0 = np.concatenate([np.asarray(x0, float), np.asarray(v0, float),
                         forcing_state(system, t0)])
    return {"E": E, "H": H, "normA": normA, "cA": cA,
            "normc": np.array([np.linalg.norm(c.gap) for c in system.contacts]),
            "rows": rows, "ds": ds, "gaps": np.array([c.gap for c in system.contacts], float),
            "D": D, "r": np.array([c.r for c in system.contacts], float), "y0": y0,
            "t0": float(t0), "n": system.n}


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


@jit
def advance(E, H, y, length, tmp):
    """y <- the state ``length`` later: E_0^floor(length / H), then the E_k of the binary
    digits of the rest (module docstring)."""
    if length < 0.0:
        raise ValueError("advance: a flight of negative length")
    x = length / H
    whole = int(math.floor(x))
    f = x - whole
    for _ in range(whole):
        matvec(E, 0, y, tmp)
        copy_to(y, tmp, y.shape[0])
    for k in range(1, E.shape[0]):
        f *= 2.0
        if f >= 1.0:
            matvec(E, k, y, tmp)
            copy_to(y, tmp, y.shape[0])
            f -= 1.0


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
def search(E, H, cA, i, normc, normA, row, d, j, p, yp, q, tol, st_a, st_k, st_y, tmp):
    """The first event of contact i in [p, q] (q - p <= H) on its piece j from the state yp
    at p: (kind, time, state there in tmp)."""
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
            advance(E, H, tmp, b - a, st_y[top + 1])
            gb, _ = gap_at(cA, i, tmp, row, d, j, b)
            if gb <= 0.0:
                return IMPACT, b
            if b < q:
                copy_to(tmp, ya, ya.shape[0])
                return GRAZE, a
            continue
        # the right half under the left
        matvec(E, k + 1, ya, tmp)
        top += 1
        st_a[top] = a + h / 2.0
        st_k[top] = k + 1
        copy_to(st_y[top], tmp, tmp.shape[0])
        top += 1
        st_a[top] = a
        st_k[top] = k + 1
        copy_to(st_y[top], ya, ya.shape[0])
    return NONE, math.inf


@jit
def run(E, H, normA, cA, normc, rows, ds, gaps, D, r, y0, t0, n, skip, count, tol, chatter, escape,
        t_max, control, o_t, o_c, o_x, o_vin, o_vout, o_y):
    """Up to ``count`` impacts from y0 at t0 (module docstring), the first ``skip`` not
    recorded (a transient), the others into the outputs; the state after the last impact
    into ``o_y`` ((x, v): 2n): (status, impacts recorded).  A coordinate or velocity past
    ``escape`` in size ends the run (ESCAPED), one not a number (NONFINITE), as a start that
    is either.  Under a sweep's ``control`` (``_jit.Control``; 0: none) told to stop:
    (STOPPED, 0), its outputs incomplete."""
    m = y0.shape[0]
    nc = gaps.shape[0]
    y = y0.copy()
    t = t0
    copy_to(o_y, y, 2 * n)
    tmp = np.empty(m)
    best_y = np.empty(m)
    st_a = np.empty(2 * LEVELS + 4)
    st_k = np.empty(2 * LEVELS + 4, np.int64)
    st_y = np.empty((2 * LEVELS + 4, m))
    js = np.empty(nc, np.int64)
    impacts = 0
    while impacts < count:
        if stop_requested(control):
            return STOPPED, 0
        if t > t_max:
            return BUDGET, max(0, impacts - skip)
        for k in range(2 * n):
            a = abs(y[k])
            if not (a == a):
                return NONFINITE, max(0, impacts - skip)
            if a > escape:
                return ESCAPED, max(0, impacts - skip)
        # the chunk: at most H, inside one piece of every contact's obstacle
        q = t + H
        for i in range(nc):
            j, _ = piece_at(ds[i], t)
            # at a piece's end, t rounds into either piece: the one that goes on past t
            while piece_start(ds[i], j) + piece_length(ds[i], j) <= t:
                j += 1
            js[i] = j
            q = min(q, piece_start(ds[i], j) + piece_length(ds[i], j))
        best = math.inf
        bi = -1
        for i in range(nc):
            p = t
            yp = y.copy()
            g0, g1 = gap_at(cA, i, y, rows[i], ds[i], js[i], t)
            if g0 <= 0.0:
                if g1 <= 0.0:
                    if 0.0 < best:
                        best, bi = 0.0, i
                        copy_to(best_y, y, m)
                    continue
                # leaving the obstacle: free until g' / B at least (events.py)
                B = bound2(cA, i, y, q - t, normc[i], normA, piece_zpp(rows[i], js[i]))
                s = g1 / B
                if t + s >= q:
                    continue
                advance(E, H, yp, s, tmp)
                p = t + s
            kind, te = search(E, H, cA, i, normc[i], normA, rows[i], ds[i], js[i], p, yp, q,
                              tol, st_a, st_k, st_y, tmp)
            if kind != NONE and te - t < best:
                best, bi = te - t, i
                copy_to(best_y, tmp, m)
        if bi < 0:
            advance(E, H, y, q - t, tmp)
            t = q
            continue
        te = t + best                 # (a graze: its interval's start, where best_y is)
        copy_to(y, best_y, m)
        j = js[bi]
        _, zp, _, _ = z_state(rows[bi], j, te - piece_start(ds[bi], j))
        w = 0.0
        for k in range(n):
            w += gaps[bi, k] * y[n + k]
        w -= zp
        if w >= 0.0:
            # moving away (a graze, or a gap left slightly below zero by the last impact's
            # resolution): no impact; on past it by the leaving rule's free step
            B = bound2(cA, bi, y, H, normc[bi], normA, piece_zpp(rows[bi], j))
            s = max(2.0 * tol, w / B)
            advance(E, H, y, s, tmp)
            t = te + s
            continue
        ad = 0.0
        for k in range(n):
            ad += gaps[bi, k] * D[bi, k]
        kept = impacts - skip
        for k in range(n):
            if kept >= 0:
                o_vin[kept, k] = y[n + k]
            y[n + k] -= (1.0 + r[bi]) * w * D[bi, k] / ad
            if kept >= 0:
                o_vout[kept, k] = y[n + k]
                o_x[kept, k] = y[k]
        if kept >= 0:
            o_t[kept] = te
            o_c[kept] = bi
        impacts += 1
        copy_to(o_y, y, 2 * n)
        t = te
        if -r[bi] * w <= chatter:
            return CHATTERS, max(0, impacts - skip)
    return OK, max(0, impacts - skip)


def run_system(system, t0, x0, v0, count, tol=1e-12, chatter=1e-6, t_max=1e4, escape=1e6):
    """``run`` for one system and start: (status, dict of the recorded impacts: t, contact
    (names), x, v_in, v_out)."""
    a = prepare(system, t0, x0, v0)
    n = system.n
    o_t = np.full(count, np.nan)
    o_c = np.full(count, -1, np.int64)
    o_x, o_vin, o_vout = (np.full((count, n), np.nan) for _ in range(3))
    st, k = run(a["E"], a["H"], a["normA"], a["cA"], a["normc"], a["rows"], a["ds"], a["gaps"],
                a["D"], a["r"], a["y0"], a["t0"], n, 0, count, tol, chatter, escape, t_max, 0, o_t, o_c,
                o_x, o_vin, o_vout, np.empty(2 * n))
    names = [system.contacts[i].name for i in o_c[:k]]
    return st, {"t": o_t[:k], "contact": names, "x": o_x[:k], "v_in": o_vin[:k],
                "v_out": o_vout[:k]}
