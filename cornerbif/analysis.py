"""Symbolic dynamics of recorded impacts: clusters, symbols, period (DESIGN 3).

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
word is rotated to its lexicographically smallest form.  The winding number
(section 5.4) is the share of ``g`` clusters in the word.
"""

import numpy as np
from numba import prange

from ._jit import jit, pjit

A, B, G, X = ord("a"), ord("b"), ord("g"), ord("x")


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
            # smallest rotation of the word sym[lo:lo+p]
            best = 0
            for rot in range(1, p):
                for q in range(p):
                    x = sym[lo + (rot + q) % p]
                    y = sym[lo + (best + q) % p]
                    if x != y:
                        if x < y:
                            best = rot
                        break
            ipc = 0
            for q in range(p):
                sym_out[q] = sym[lo + (best + q) % p]
                ipc += count[lo + q]
            return p, ipc
    return 0, 0


@pjit
def detect_cycles(t, vin, off, corner, cornered, period_tol, o_period, o_ipc, o_sym):
    """``detect_cycle`` over all items in parallel."""
    for i in prange(t.shape[0]):
        p, ipc = detect_cycle(t[i], vin[i], off[i], corner[i], cornered[i], period_tol, o_sym[i])
        o_period[i] = p
        o_ipc[i] = ipc


def words(sym: np.ndarray) -> np.ndarray:
    """uint8 rows (zero-padded) -> numpy array of Python str."""
    w = sym.shape[1] if sym.ndim == 2 else 1
    raw = np.ascontiguousarray(sym).view(f"S{w}").reshape(sym.shape[0])
    return np.array([s.decode("ascii") for s in raw], dtype=object)


def winding_number(word: str) -> float:
    """Share of gamma clusters in a cycle's word (section 5.4); NaN for no cycle."""
    if not word:
        return float("nan")
    return word.count("g") / len(word)


# ------------------------------------------------------------ coexisting attractors
def cycle_signature(period, ipc, values):
    """The recorded values of one cycle, sorted (so any shift of the cycle gives the same).

    ``values`` is a list of 1-D arrays over the record (e.g. impact heights and
    velocities, or the section values of a map); the last complete cycle is
    taken: ``ipc`` entries for impacts, ``period`` for section values (the caller
    passes the matching count).  Returns a 1-D array, or None when too short.
    """
    out = []
    for v, n in values:
        v = v[np.isfinite(v)]
        if n <= 0 or v.size < n:
            return None
        out.append(np.sort(v[-n:]))
    return np.concatenate(out)


def distinct_attractors(period, ipc, symbols, series, tol):
    """Label the distinct cycles among the starts of every grid point.

    Two starts reach the same attractor when their cycles have the same word,
    the same period and impacts per cycle, and the same recorded values over
    one cycle to ``tol`` (relative to 1 + |value|), up to a shift along the
    cycle.  Impact values and the corner offsets are unchanged by a time shift
    of one obstacle period, so the shifted copies of an orbit (the paper's 2n
    equivalent solutions, section 3.2) count as one attractor: they coincide in
    every diagram.

    Parameters
    ----------
    period, ipc : int arrays, shape G + (n_ic,)
    symbols : str array, shape G + (n_ic,)
    series : list of (array G + (n_ic, record), "impacts" | "section")
        the recorded values compared; impacts take ``ipc`` entries per cycle,
        section values ``period``.  An empty list compares words only.
    tol : float

    Returns
    -------
    labels : int array G + (n_ic,)
        0, 1, ... ranks of the distinct attractors at each point, ordered by
        (period, word, mean of the first series); -1 for a start without a cycle.
    count : int array G
        number of distinct attractors (cycles) at each point.
    """
    G = period.shape[:-1]
    n_ic = period.shape[-1]
    per = period.reshape(-1, n_ic)
    ip = ipc.reshape(-1, n_ic)
    sy = symbols.reshape(-1, n_ic)
    ser = [(s.reshape(-1, n_ic, s.shape[-1]), kind) for s, kind in series]
    labels = np.full(per.shape, -1, np.int64)
    count = np.zeros(per.shape[0], np.int64)
    for g in range(per.shape[0]):
        reps = []   # (key, signature, [ics])
        for i in range(n_ic):
            if per[g, i] <= 0:
                continue
            vals = [(s[g, i], ip[g, i] if kind == "impacts" else per[g, i]) for s, kind in ser]
            sig = cycle_signature(per[g, i], ip[g, i], vals) if vals else np.zeros(0)
            if sig is None:
                continue
            key = (int(per[g, i]), int(ip[g, i]), str(sy[g, i]))
            for r in reps:
                if r[0] == key and r[1].shape == sig.shape and np.all(
                        np.abs(r[1] - sig) <= tol * (1.0 + np.abs(r[1]))):
                    r[2].append(i)
                    break
            else:
                reps.append((key, sig, [i]))
        order = sorted(range(len(reps)), key=lambda k: (reps[k][0][0], reps[k][0][2],
                                                          float(np.mean(reps[k][1])) if reps[k][1].size else 0.0))
        for rank, k in enumerate(order):
            labels[g, reps[k][2]] = rank
        count[g] = len(reps)
    return labels.reshape(G + (n_ic,)), count.reshape(G)


def run_length(word: str, tex: bool = False, empty: str = "-") -> str:
    """A cycle word in run-length form: 'bbbg' -> 'b^3 g' (tex: 'b$^{3}$ g')."""
    if not word:
        return empty
    out, i = [], 0
    while i < len(word):
        j = i
        while j < len(word) and word[j] == word[i]:
            j += 1
        n = j - i
        out.append(word[i] + ((f"$^{{{n}}}$" if tex else f"^{n}") if n > 1 else ""))
        i = j
    return " ".join(out)
