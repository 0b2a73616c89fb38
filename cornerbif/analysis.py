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
word is rotated to its lexicographically smallest form (``smallest_rotation``, shared
with ``maps2d``).  The winding number (section 5.4) is the share of ``g`` clusters in the
word (``winding_number``, the package's one: it also reads the run-length words of
``parse_word``).
"""

import math
import re

import numpy as np
from numba import prange

from ._jit import jit, pjit
from .model import cut

A, B, G, X = ord("a"), ord("b"), ord("g"), ord("x")


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


_TOKEN = re.compile(r"\s*([abg\u03b1\u03b2\u03b3])\s*(?:\^?\s*(\d+))?\s*")
_TOKEN_X = re.compile(r"\s*([abgx\u03b1\u03b2\u03b3])\s*(?:\^?\s*(\d+))?\s*")
_LETTER = {"\u03b1": "a", "\u03b2": "b", "\u03b3": "g"}
_PLAIN = re.compile(r"[abgx]+")

# The longest word ``parse_word`` expands (letters, after the repeat counts).  A word names
# one cycle of a periodic orbit that ``cornerbif continue`` solves with dense matrices of
# about 2 unknowns per letter (two per impact, alpha has two impacts): Newton and the
# tangent's SVD cost the cube of the length, and an SVD of 2000 unknowns already takes
# 14 s here (numpy, 2 cores, 2026-11), so a branch of such a word takes hours and a longer
# one does not finish.  The paper's longest cycles (the period-adding cascade near
# omega = 2) have about 75 clusters.  A word is refused from its repeat counts, before it
# is expanded (a count of 1e20 is never multiplied out).
MAX_WORD_LETTERS = 1000
# the longest text of a word (spaces, '^' and counts included)
MAX_WORD_TEXT = 10 * MAX_WORD_LETTERS
# the characters of a word a message quotes (``model.cut``)
WORD_SHOWN = 40


def parse_word(word: str, allow_x: bool = False) -> str:
    """Expand a symbol word: 'bbbg', 'b11 g b12 g', 'b^11 g', 'β^3γ' -> plain letters a/b/g
    (and x, the cluster of a smooth obstacle, with ``allow_x``).

    Parentheses are ignored; an exponent applies to the letter before it.  A word longer
    than ``MAX_WORD_LETTERS`` letters (or ``MAX_WORD_TEXT`` characters) is refused with
    ValueError from its counts, without being expanded.
    """
    s = str(word)
    if len(s) > MAX_WORD_TEXT:
        raise ValueError(f"word {cut(s, WORD_SHOWN, quote=True)} is {len(s)} characters long; "
                         f"a word is written in at most {MAX_WORD_TEXT} (cycles of at most "
                         f"{MAX_WORD_LETTERS} letters)")
    s = s.replace("(", " ").replace(")", " ").lower()
    token = _TOKEN_X if allow_x else _TOKEN
    letters = "a, b, g" + (", x" if allow_x else "")
    out = []
    total = 0
    pos = 0
    while pos < len(s):
        if s[pos].isspace():
            pos += 1
            continue
        m = token.match(s, pos)
        if m is None or m.end() == pos:
            raise ValueError(f"word {cut(word, WORD_SHOWN, quote=True)}: cannot read "
                             f"{cut(s[pos:], WORD_SHOWN, quote=True)} (letters {letters}, "
                             "optional ^n)")
        letter = _LETTER.get(m.group(1), m.group(1))
        digits = (m.group(2) or "1").lstrip("0") or "0"
        count = int(digits) if len(digits) <= 6 else MAX_WORD_LETTERS + 1
        total += count
        if total > MAX_WORD_LETTERS:
            raise ValueError(f"word {cut(word, WORD_SHOWN, quote=True)} has more than "
                             f"{MAX_WORD_LETTERS} letters (the longest cycle cornerbif solves: "
                             "its orbit's matrices grow as the square and their solution as "
                             "the cube of the length)")
        out.append(letter * count)
        pos = m.end()
    res = "".join(out)
    if not res:
        raise ValueError(f"word {word!r} is empty")
    return res


def winding_number(word: str) -> float:
    """W = share of gamma clusters in a cycle's word (section 5.4): 1/(N+1) for beta^N
    gamma; NaN for no cycle (an empty word).

    Reads the words of ``detect_cycle`` (letters a, b, g and x) and the run-length forms
    of ``parse_word`` ('b^11 g', 'b11 g b12 g', Greek letters).
    """
    if not word:
        return math.nan
    if _PLAIN.fullmatch(word) is None:
        word = parse_word(word)
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
        order = sorted(range(len(reps)),
                       key=lambda k: (reps[k][0][0], reps[k][0][2],
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


# ------------------------------------------------------------ a cycle's signature
SIGNATURE = ("mean_a", "mean_b", "min_a", "max_a", "min_b", "max_b")


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


@pjit
def cycle_signatures(end, a, b, count, sig_out, point_out):
    """``cycle_signature_one`` over all items in parallel."""
    for i in prange(end.shape[0]):
        cycle_signature_one(end[i], a[i], b[i], count[i], sig_out[i], point_out[i])
