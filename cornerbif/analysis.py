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
