"""Symbolic dynamics of recorded impacts: clusters, symbols, period (docs/guarantees.md).

Impacts are grouped by their nearest corner into clusters (corners without
impacts are skipped).  A cluster is

* ``b`` (beta, section 4.2): one impact just after the corner,
* ``g`` (gamma, section 4.3): one impact just before it,
* ``a`` (alpha, section 4.4): two impacts straddling it,
* ``x``: anything else (and every cluster of a smooth obstacle).

The period of an attractor is the smallest p such that cluster i and cluster
i + p agree (symbol, number of impacts, corner offsets and impact velocities
to ``period_tol``, and the same corner step) over the whole recorded window,
which must hold at least two cycles.  Near omega = 2 a cluster is one iterate of
the paper's Poincare map, so its "period-25" orbit has period 25.  The cycle's
word is rotated to its lexicographically smallest form (``smallest_rotation``, shared
with ``maps2d``).  The winding number (section 5.4) is the share of ``g`` clusters in the
word (``winding_number``, the package's one: it also reads the run-length words of
``parse_word``).  Those words and the comparison of attractors are Python, in
``cornerbif.cycles`` (re-exported here); this module holds the jitted passes.
"""

import math

import numpy as np

from ._jit import items_kernel, jit
from .cycles import (  # noqa: F401 (the Python side, loaded without numba: imported from here as before)
    MAX_WORD_LETTERS,
    MAX_WORD_TEXT,
    SIGNATURE,
    WORD_SHOWN,
    cycle_signature,
    distinct_attractors,
    parse_word,
    run_length,
    winding_number,
    words,
)

A, B, G, X = ord("a"), ord("b"), ord("g"), ord("x")


# ------------------------------------------------------------ corners of a second contact
# The two-particle model's corners (section 6): its u-z impacts are grouped about its w-z
# impacts, the w-z impacts playing the part of the obstacle's corners.  A u-z impact takes
# the offset to the previous w-z impact unless the next one is strictly nearer (then a
# negative offset to it), with the corner's number among all the run's w-z impacts; the
# offset is settled on-line as the w-z impacts come (the two-particle kernel, and a linear
# scene's ``[system] words``: docs/linear.md).  One rule, these three functions.


@jit
def offset_to_previous(has_previous, since_previous, previous):
    """(offset, corner) of an impact when it happens: ``since_previous`` after the previous
    corner impact (number ``previous``), if there was one; else (+inf, -1), pending: the
    next corner impact decides (``settle_corner_offsets``)."""
    if has_previous:
        return since_previous, previous
    return math.inf, np.int64(-1)


@jit
def settle_corner_offsets(off, corner, t, lo, hi, t_corner, between, k):
    """At corner impact number ``k``, at time ``t_corner`` and ``between`` after the previous
    corner impact: the impacts ``lo .. hi - 1`` since that one (times ``t``, offsets ``off``
    and corners ``corner``, in place) take this corner where it is strictly nearer than the
    previous one (offset -(between - off) < 0), or where they had none (+inf: t - t_corner)."""
    for i in range(lo, hi):
        if off[i] == math.inf:
            off[i] = t[i] - t_corner
            corner[i] = k
        else:
            dn = between - off[i]
            if dn < off[i]:
                off[i] = -dn
                corner[i] = k


@jit
def close_corner_offsets(off, corner, lo, hi):
    """At a run's end: the impacts ``lo .. hi - 1`` still waiting for a next corner impact
    keep their offset to the previous one; those with none (+inf) get NaN and corner -1."""
    for i in range(lo, hi):
        if off[i] == math.inf:
            off[i] = math.nan
            corner[i] = -1


@jit
def smallest_rotation(w, lo, p):
    """The start r (0 <= r < p) of the lexicographically smallest rotation of the word
    w[lo:lo + p] (integer letter codes; the first of equal rotations)."""
    best = 0
    for rot in range(1, p):
        for q in range(p):
            x = w[lo + (rot + q) % p]
            y = w[lo + (best + q) % p]
            if x != y:
                if x < y:
                    best = rot
                break
    return best


@jit
def detect_cycle(t, vin, off, corner, cornered, period_tol, sym_out):
    """Period (clusters), impacts per cycle and the cycle's word of one item.

    ``sym_out`` (uint8) receives the word, zero-padded.  Returns (0, 0) when no
    cycle repeats twice within the window.
    """
    n = 0
    while n < t.shape[0] and t[n] == t[n]:
        n += 1
    sym_out[:] = 0
    if n < 2:
        return 0, 0
    # clusters
    start = np.empty(n, np.int64)
    count = np.zeros(n, np.int64)
    cid = np.empty(n, np.int64)
    sym = np.empty(n, np.uint8)
    nc = 0
    for i in range(n):
        if nc == 0 or corner[i] != cid[nc - 1]:
            start[nc] = i
            cid[nc] = corner[i]
            count[nc] = 0
            nc += 1
        count[nc - 1] += 1
    for c in range(nc):
        s = start[c]
        if not cornered:
            sym[c] = X
        elif count[c] == 1:
            sym[c] = B if off[s] >= 0.0 else G
        elif count[c] == 2 and off[s] < 0.0 and off[s + 1] >= 0.0:
            sym[c] = A
        else:
            sym[c] = X
    # drop the first and last cluster: the window may cut them
    lo = 1
    hi = nc - 1
    m = hi - lo
    for p in range(1, m // 2 + 1):
        ok = True
        step = cid[lo + p] - cid[lo]
        for c in range(lo, hi - p):
            e = c + p
            if sym[c] != sym[e] or count[c] != count[e] or cid[e] - cid[c] != step:
                ok = False
                break
            for q in range(count[c]):
                a = start[c] + q
                b = start[e] + q
                if abs(off[a] - off[b]) > period_tol:
                    ok = False
                    break
                if abs(vin[a] - vin[b]) > period_tol * (1.0 + abs(vin[a])):
                    ok = False
                    break
            if not ok:
                break
        if ok:
            best = smallest_rotation(sym, lo, p)
            ipc = 0
            for q in range(p):
                sym_out[q] = sym[lo + (best + q) % p]
                ipc += count[lo + q]
            return p, ipc
    return 0, 0


@items_kernel
def detect_cycles(k0, k1, t, vin, off, corner, cornered, period_tol, o_period, o_ipc, o_sym):
    """``detect_cycle`` over all items in parallel."""
    for i in range(k0, k1):
        p, ipc = detect_cycle(t[i], vin[i], off[i], corner[i], cornered[i], period_tol, o_sym[i])
        o_period[i] = p
        o_ipc[i] = ipc


# ------------------------------------------------------------ a cycle's signature


@jit
def cycle_signature_one(end, a, b, count, sig_out, point_out):
    """The signature of one run's cycle: over the last ``count`` recorded entries (the
    recorded window ends at the first NaN of ``end``), the mean, least and largest of
    the two series a and b (``SIGNATURE``), unchanged by any shift along the cycle; and
    a point of the cycle: (a, b) at the entry where b is largest (the first of equals).

    NaN where the run has no cycle (``count`` 0) or the window holds fewer entries."""
    sig_out[:] = np.nan
    point_out[:] = np.nan
    n = 0
    while n < end.shape[0] and end[n] == end[n]:
        n += 1
    if count <= 0 or count > n:
        return
    sa = 0.0
    sb = 0.0
    lo_a = np.inf
    hi_a = -np.inf
    lo_b = np.inf
    hi_b = -np.inf
    best = n - count
    for i in range(n - count, n):
        x = a[i]
        y = b[i]
        sa += x
        sb += y
        lo_a = min(lo_a, x)
        hi_a = max(hi_a, x)
        lo_b = min(lo_b, y)
        if y > hi_b:
            hi_b = y
            best = i
    sig_out[0] = sa / count
    sig_out[1] = sb / count
    sig_out[2] = lo_a
    sig_out[3] = hi_a
    sig_out[4] = lo_b
    sig_out[5] = hi_b
    point_out[0] = a[best]
    point_out[1] = b[best]


@items_kernel
def cycle_signatures(k0, k1, end, a, b, count, sig_out, point_out):
    """``cycle_signature_one`` over all items in parallel."""
    for i in range(k0, k1):
        cycle_signature_one(end[i], a[i], b[i], count[i], sig_out[i], point_out[i])


def word_of_impacts(t, v_in, offset, corner, duration, corners_per_cycle, cornered=True,
                    cycles=4, period_tol=1e-9):
    """The word of one cycle of impacts (times ``t``, incoming velocities ``v_in``, corner
    offsets and corner numbers, N each) in the engine's symbols: the cycle repeated
    ``cycles`` times (plus two impacts), each repetition ``duration`` later and its corners
    ``corners_per_cycle`` on, through ``detect_cycles`` as a run's record (the orbit
    problems' ``word``: models/flow/orbit.py, models/linear/orbit.py)."""
    N = len(t)
    reps = cycles * N + 2
    q = np.arange(reps)
    i, k = q % N, q // N
    rt = (np.asarray(t, float)[i] + k * duration).reshape(1, reps)
    rv = np.asarray(v_in, float)[i].reshape(1, reps)
    ro = np.asarray(offset, float)[i].reshape(1, reps)
    rc = (np.asarray(corner, np.int64)[i] + k * corners_per_cycle).reshape(1, reps)
    per = np.zeros(1, np.int64)
    ipc = np.zeros(1, np.int64)
    sym = np.zeros((1, reps), np.uint8)
    detect_cycles(rt, rv, ro, rc, np.array([bool(cornered)]), period_tol, per, ipc, sym)
    return str(words(sym)[0])
