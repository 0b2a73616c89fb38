"""Certified first events of a linear system's flight: the first time a contact's
gap g = a . x - z(t) reaches zero, with a proof that none comes earlier.

Along a flight from the augmented state y0 (flight.py: y' = A y, exact), the gap of a
contact is g(s) = c . expm(A s) y0 - z(t0 + s), c = (a, 0, 0), and its derivatives are
g^(k) = c A^k expm(A s) y0 - z^(k).  On an interval [p, p + h] inside one smooth piece of
the obstacle, with y = y(p):

* **a bound on |g''|**: c A^2 expm(A s) y = sum_j (c A^(j+2) y) s^j / j!, so for s <= h
      |g''| <= sum_(j < J) |c A^(j+2) y| h^j / j!
               + |c| |A|^(J+2) |y| h^J / J! e^(|A| h) + max |z''| on the piece
  (|.| the 2-norms; h <= 1 / |A| keeps the remainder small);
* **no root** where the concave lower bound g(p) + g'(p) s - B s^2 / 2 stays positive on
  [0, h]: it is smallest at an end, so g(p) > 0 and g(p) + g'(p) h - B h^2 / 2 > 0 prove it;
* otherwise the interval is **halved**, left half first, so the first root is in the first
  interval found with g <= 0 at its right end (all before it proven free), resolved by the
  same halving to ``tol``.

A flight that only grazes the obstacle (its gap's minimum dips below zero by less than the
halving resolves) ends in intervals of width ``tol`` whose ends are both positive: there the
gap's minimum is at least -(|g'| tol + B tol^2 / 2), and the search reports a **graze**
(kind GRAZE) at that interval, the kernel's "impact at zero relative velocity".

**The obstacle** is one of cornerbif's obstacle kinds, evaluated by their own code
(``obstacles.dispatch``: pieces, z and its derivatives, the bounds of z'' per piece) on a
packed row of the kind (``ContactObstacle``).  The search goes piece by piece, each piece
named by its index, so that at a corner, or at a time rounded across one, z' is that
piece's own (a piece taken from the time itself would, at a time rounded across a rectified
sine's corner, take the other piece's slope, and lose impacts:
tests/models/test_linear_events.py).

Pure numpy around the jitted obstacle functions, with the kernel's method
(tests/models/test_linear_events.py checks it against sampling on random systems).
"""

from __future__ import annotations

import math

import numpy as np

from ...numerics.oscillator import derive
from ...obstacles import STILL
from ...obstacles.dispatch import piece_at, piece_length, piece_start, z_state, zpp_range
from ..flow.params import pack
from .declare import FIXED
from .flight import expm

NONE, IMPACT, GRAZE = 0, 1, 2
TAYLOR_TERMS = 10           # J: the terms of the g'' bound's series before its remainder


class ContactObstacle:
    """A contact's obstacle z = kappa + beta shape(omega t) of an obstacle ``kind`` of
    cornerbif.obstacles ("fixed": z = kappa, packed as the kind ``obstacles.STILL`` with
    beta = 0), as a packed row of that kind, evaluated by ``obstacles.dispatch``."""

    def __init__(self, kind, kappa, beta=0.0, omega=1.0):
        if kind == FIXED:
            kind, beta, omega = STILL, 0.0, 1.0
        self.row = pack({"omega": omega, "kappa": kappa, "beta": beta}, kind, 1e-12, 1e-6, 1e6,
                        None)
        self.d = derive(self.row)

    def pieces(self, t0, t1):
        """(piece index, start, end) of the smooth pieces covering [t0, t1], in order."""
        j, _ = piece_at(self.d, t0)
        a = t0
        while a < t1:
            b = min(t1, piece_start(self.d, j) + piece_length(self.d, j))
            if b > a:
                yield j, a, b
            a = max(a, b)
            j += 1

    def piece_at(self, t):
        """The piece index and local time of time t."""
        return piece_at(self.d, t)

    def state(self, j, t):
        """z, z' on piece j at time t."""
        z, zp, _, _ = z_state(self.row, j, t - piece_start(self.d, j))
        return z, zp

    def zpp_bound(self, j):
        """A bound of |z''| on piece j."""
        lo, hi = zpp_range(self.row, j)
        return max(abs(lo), abs(hi))


class Gap:
    """The gap of one contact along one flight: A (the augmented matrix), y0 at t0, the
    contact's c = (a, 0, ...) and its ``ContactObstacle``."""

    def __init__(self, A, y0, t0, a, obstacle):
        self.A, self.y0, self.t0 = A, np.asarray(y0, float), t0
        self.c = np.zeros(A.shape[0])
        self.c[:len(a)] = a
        self.obstacle = obstacle
        self.normA = np.linalg.norm(A, 2)
        rows = [self.c]
        for _ in range(TAYLOR_TERMS + 2):
            rows.append(rows[-1] @ A)
        self.cA = np.array(rows)           # c A^k, k = 0 .. J + 2
        self.normc = np.linalg.norm(self.c)

    def state(self, s):
        return expm(self.A * s) @ self.y0

    def value(self, s, j, y=None):
        """g, g' at t0 + s on the obstacle's piece j (``y`` the state there when known)."""
        y = self.state(s) if y is None else y
        z, zp = self.obstacle.state(j, self.t0 + s)
        return self.cA[0] @ y - z, self.cA[1] @ y - zp

    def bound2(self, y, h, j):
        """A bound on |g''| over [p, p + h] on piece j from the state y at p (module
        docstring)."""
        J = TAYLOR_TERMS
        terms = np.abs(self.cA[2:J + 2] @ y)
        fact = np.array([h ** i / math.factorial(i) for i in range(J)])
        nA = self.normA
        # |c| |A|^(J+2) |y| h^J / J! e^(|A| h), as |A|^2 (|A| h)^J / J! (no overflow)
        rem = self.normc * nA * nA * np.linalg.norm(y) * (nA * h) ** J / math.factorial(J) \
            * math.exp(nA * h)
        return float(terms @ fact + rem + self.obstacle.zpp_bound(j))

    def bound4(self, y, h):
        """A bound on the gap's fourth derivative over [p, p + h] from the state y at p, for
        a fixed obstacle (the series of ``bound2`` from c A^4: J - 2 terms, then the
        remainder)."""
        J = TAYLOR_TERMS - 2
        terms = np.abs(self.cA[4:J + 4] @ y)
        fact = np.array([h ** i / math.factorial(i) for i in range(J)])
        nA = self.normA
        rem = self.normc * nA ** 4 * np.linalg.norm(y) * (nA * h) ** J / math.factorial(J) \
            * math.exp(nA * h)
        return float(terms @ fact + rem)


def first_event(gap, length, tol=1e-12):
    """``first_event_piece`` without the piece: (kind, s)."""
    kind, s, _ = first_event_piece(gap, length, tol)
    return kind, s


def first_event_piece(gap, length, tol=1e-12):
    """The first s in (0, length] where ``gap`` reaches zero: (kind, s, j), kind IMPACT (a
    sign change, resolved to ``tol``), GRAZE (a touch within the resolution ``tol``) or NONE
    (none, proven), j the obstacle's piece it lies on (whose slope an impact there takes).
    The gap at s = 0 is the start's (>= 0: just after an impact it is 0)."""
    hmax = 1.0 / max(gap.normA, 1e-300)
    for j, lo, hi in gap.obstacle.pieces(gap.t0, gap.t0 + length):
        p = lo - gap.t0
        while p < hi - gap.t0:
            q = min(hi - gap.t0, p + hmax)
            # every chunk starts as a flight may: on the obstacle and leaving it (an impact
            # resolved to tol just before a piece's end leaves the gap up to |w| tol below
            # zero at the next piece's start)
            found = _search(gap, p, q, tol, True, j)
            if found is not None:
                return found + (j,)
            p = q
    return NONE, math.inf, -1


def _search(gap, p, q, tol, start, j):
    """Depth-first halving of [p, q] (module docstring): the first event in it, or None.
    ``start``: p is the flight's start, where the gap may be 0 (just after an impact);
    ``j``: the obstacle's piece that [p, q] lies on."""
    stack = [(p, q)]
    if start:
        y = gap.state(p)
        g0, g1 = gap.value(p, j, y)
        if g0 <= 0.0:
            if g1 <= 0.0:
                return IMPACT, p              # on the obstacle and not leaving it
            # leaving it: g >= g' s - B s^2 / 2 > 0 on (0, 2 g' / B); from g' / B on, the
            # gap is at least g'^2 / (2 B) > 0, and the search goes on as anywhere else
            B = gap.bound2(y, q - p, j)
            stack = [(min(q, p + g1 / B), q)] if p + g1 / B < q else []
    while stack:
        a, b = stack.pop()
        ya = gap.state(a)
        ga, g1 = gap.value(a, j, ya)
        h = b - a
        B = gap.bound2(ya, h, j)
        if min(ga, ga + g1 * h - B * h * h / 2.0) > 0.0:
            continue                          # proven: no root in [a, b]
        if ga <= 0.0:                         # (only where a start below zero is given)
            return IMPACT, a
        gb, _ = gap.value(b, j)
        if h <= tol:
            # [a, b] is as fine as asked: a sign change is the impact, else a graze
            return (IMPACT, b) if gb <= 0.0 else (GRAZE, a)
        stack.append((a + h / 2.0, b))        # the right half after the left
        stack.append((a, a + h / 2.0))
    return None
