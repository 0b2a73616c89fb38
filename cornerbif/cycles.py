"""The Python side of the cycle analysis: symbol words, coexisting attractors, and the names
of a cycle's signature.

``cornerbif.analysis`` holds the jitted detection (``detect_cycle``: clusters, symbols,
period; ``cycle_signatures``) and re-exports everything here.  This module loads no numba,
so that checking a scene (a ``[continue]`` seed word, ``parse_word``) or reading a file
(``SIGNATURE``) loads no kernel.
"""

import math
import re

import numpy as np

from .model import cut


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
# 14 s on 2 cores (numpy), so a branch of such a word takes hours and a longer
# one does not finish.  The paper's longest cycles (the period-adding cascade near
# omega = 2) have about 75 clusters.  A word is refused from its repeat counts, before it
# is expanded (a count of 1e20 is never multiplied out).
MAX_WORD_LETTERS = 1000
# the longest text of a word (spaces, '^' and counts included)
MAX_WORD_TEXT = 10 * MAX_WORD_LETTERS
# the characters of a word a message quotes (``model.cut``)
WORD_SHOWN = 40


def parse_word(word: str, allow_x: bool = False, alphabet: str | None = None) -> str:
    """Expand a symbol word: 'bbbg', 'b11 g b12 g', 'b^11 g', 'β^3γ' -> plain letters a/b/g
    (and x, the cluster of a smooth obstacle, with ``allow_x``).

    ``alphabet``: the word's letters where they are not the corner clusters' (a linear
    system's contacts' names, ``Model.seed_letters``): those letters alone, case kept (no
    Greek letters, no lower-casing; ``allow_x`` does not apply).  Parentheses are ignored;
    an exponent applies to the letter before it.  A word longer than ``MAX_WORD_LETTERS``
    letters (or ``MAX_WORD_TEXT`` characters) is refused with ValueError from its counts,
    without being expanded.
    """
    s = str(word)
    if len(s) > MAX_WORD_TEXT:
        raise ValueError(f"word {cut(s, WORD_SHOWN, quote=True)} is {len(s)} characters long; "
                         f"a word is written in at most {MAX_WORD_TEXT} (cycles of at most "
                         f"{MAX_WORD_LETTERS} letters)")
    s = s.replace("(", " ").replace(")", " ")
    if alphabet is None:
        s = s.lower()
        token = _TOKEN_X if allow_x else _TOKEN
        letters = "a, b, g" + (", x" if allow_x else "")
    else:
        if not alphabet:
            raise ValueError(f"word {cut(word, WORD_SHOWN, quote=True)}: no letters to read it in")
        token = re.compile(r"\s*([" + re.escape(alphabet) + r"])\s*(?:\^?\s*(\d+))?\s*")
        letters = ", ".join(alphabet)
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
# the columns of a cycle's signature (``analysis.cycle_signature_one``)
SIGNATURE = ("mean_a", "mean_b", "min_a", "max_a", "min_b", "max_b")


def series_signature(a, b) -> np.ndarray:
    """The signature (SIGNATURE) of two series over one cycle, or over a chaotic
    attractor's cloud: what ``analysis.cycle_signature_one`` computes in the kernel."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    return np.array([a.mean(), b.mean(), a.min(), a.max(), b.min(), b.max()])


def series_point(a, b) -> tuple:
    """The table's point of a cycle (or cloud): (a, b) where b is largest."""
    k = int(np.argmax(b))
    return float(a[k]), float(b[k])
