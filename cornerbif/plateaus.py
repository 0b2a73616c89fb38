"""Plateaus of a one-axis sweep: maximal parameter intervals with one word (section 5.4).

A grid point's word is the word all its starts agree on ('' otherwise).  The
plateau ends read off the grid are only as good as its spacing; ``refine``
bisects on the parameter with the model itself as judge, so each end is known
to ``tol`` whatever the grid.
"""

from __future__ import annotations

import numpy as np


def point_words(symbols: np.ndarray) -> list:
    """One word per grid point: the common word of its starts, '' if they differ or none."""
    out = []
    for row in np.atleast_2d(symbols):
        s = {w.decode() if isinstance(w, bytes) else str(w) for w in row}
        out.append(s.pop() if len(s) == 1 else "")
    return out


def plateaus(values, words):
    """Maximal runs of one non-empty word: list of (word, i_first, i_last)."""
    out = []
    i = 0
    n = len(words)
    while i < n:
        j = i
        while j + 1 < n and words[j + 1] == words[i]:
            j += 1
        if words[i]:
            out.append((words[i], i, j))
        i = j + 1
    return out


def refine_edge(word_at, x_in, x_out, word, tol):
    """Bisection for the end of ``word``'s plateau between x_in (has it) and x_out (has not)."""
    while abs(x_out - x_in) > tol:
        mid = 0.5 * (x_in + x_out)
        if word_at(mid) == word:
            x_in = mid
        else:
            x_out = mid
    return 0.5 * (x_in + x_out)


def refine(word_at, values, words, tol=1e-10, min_points=1):
    """Plateaus with both ends refined: list of (word, lo, hi).

    ``word_at(x)`` runs the model at parameter x and returns the attractor's
    word.  An end at the edge of the grid is left at the grid value.
    """
    values = np.asarray(values, float)
    out = []
    for word, i, j in plateaus(values, words):
        if j - i + 1 < min_points:
            continue
        lo = values[i] if i == 0 else refine_edge(word_at, values[i], values[i - 1], word, tol)
        hi = values[j] if j == len(values) - 1 else refine_edge(word_at, values[j], values[j + 1],
                                                                  word, tol)
        out.append((word, lo, hi))
    return out
