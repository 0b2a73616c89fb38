"""The periodic-orbit problem of the local maps alpha, beta, gamma (eqs 56-60,
docs/continuation.md): a cycle of a word as the fixed point of the composed maps, its
multipliers from the maps' linear parts (eq 57), and its seed from the exact cycle of a word
(``map_seed``, ``theory.word_orbit``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...continuation import ADMISSIBLE_TOL, central_d_param
from ...stability import multipliers


@dataclass
class MapOrbit:
    """The periodic orbit of a word of the local maps alpha, beta, gamma (eqs 56-60):
    x_(i+1) = Q_i x_i + P_i over the word's letters, x = (a0, b1), each point in the
    region its letter names.  The maps are affine, so the orbit is exact (one linear
    solve, ``theory.word_orbit``); its corner collision is a point reaching a switching
    line (Sigma_1: C x = kappa1, Sigma_2: a = E, eqs 56, 60)."""

    values: dict
    param: str
    letters: str
    obstacle: str = "map"
    _cache: dict = field(default_factory=dict, repr=False)

    def to_doc(self) -> dict:
        """The problem as plain data (a partial file's resume state), ``from_doc``'s inverse."""
        return {"values": dict(self.values), "param": self.param, "type": "map2d",
                "letters": self.letters, "obstacle": self.obstacle}

    @classmethod
    def from_doc(cls, doc):
        return cls(dict(doc["values"]), str(doc["param"]), str(doc["letters"]),
                   str(doc["obstacle"]))

    @property
    def n(self) -> int:
        return len(self.letters)

    def _args(self, lam):
        vals = dict(self.values)
        vals[self.param] = float(lam)
        return vals["omega"] - 2.0, vals["kappa"], vals["r"]

    def _matrices(self, lam):
        from ...theory import map_matrices  # start-up: loads numba
        w1, k1, r = self._args(lam)
        return [map_matrices(ch, w1, k1, r) for ch in self.letters]

    def residual(self, X, lam):
        N = self.n
        R = np.empty(2 * N)
        for i, (Q, Pv) in enumerate(self._matrices(lam)):
            nxt = (i + 1) % N
            R[2 * nxt:2 * nxt + 2] = X[2 * nxt:2 * nxt + 2] - (Q @ X[2 * i:2 * i + 2] + Pv)
        return R

    def jacobian(self, X, lam):
        N = self.n
        Jm = np.zeros((2 * N, 2 * N))
        for i, (Q, _) in enumerate(self._matrices(lam)):
            nxt = (i + 1) % N
            Jm[2 * nxt:2 * nxt + 2, 2 * nxt:2 * nxt + 2] += np.eye(2)
            Jm[2 * nxt:2 * nxt + 2, 2 * i:2 * i + 2] -= Q
        return Jm

    def d_param(self, X, lam):
        return central_d_param(self.residual, X, lam)

    def floquet(self, X, lam):
        J = np.eye(2)
        for Q, _ in self._matrices(lam):
            J = Q @ J
        re1, im1, re2, im2 = multipliers(J[0, 0], J[0, 1], J[1, 0], J[1, 1])
        return np.array([complex(re1, im1), complex(re2, im2)]), J

    def corner_distances(self, X, lam):
        """Per point, its signed distance (in the region's own measure) to the switching
        lines bounding its letter's region: C x - kappa1 for beta; min(kappa1 - C x,
        E - a) for alpha; min(kappa1 - C x, a - E) for gamma (eqs 56, 60)."""
        w1, k1, r = self._args(lam)
        E = 2.0 + 4.0 / r
        out = np.empty(self.n)
        for i, ch in enumerate(self.letters):
            a, b = X[2 * i], X[2 * i + 1]
            c = 0.25 * math.pi * w1 * a + b - k1
            out[i] = c if ch == "b" else min(-c, E - a) if ch == "a" else min(-c, a - E)
        return out

    def smallest_gap(self, X, lam):
        return math.inf          # no flights

    def impacts(self, X, lam):
        return {"w": -np.ones(self.n)}   # no impact velocities to vanish

    def reindex(self, X, lam):
        return self, X

    def word(self, X, lam):
        from ...analysis import smallest_rotation  # start-up: loads numba
        codes = np.frombuffer(self.letters.encode(), np.uint8).copy()
        k = smallest_rotation(codes, 0, len(codes))
        return self.letters[k:] + self.letters[:k]

    def itinerary(self) -> str:
        return f"letters {self.letters}"

    def admissible(self, X, lam):
        cd = self.corner_distances(X, lam)
        if cd.min() < -ADMISSIBLE_TOL:
            i = int(np.argmin(cd))
            return False, f"point {i} ({self.letters[i]}) outside its region by {-cd.min():.3g}"
        return True, ""

    def across(self, q, X, lam):
        """The word with point q's letter the one of the region beyond the switching line
        it reached: Sigma_1 (C x = kappa1) between beta and alpha or gamma (by a < E),
        Sigma_2 (a = E) between alpha and gamma."""
        w1, k1, r = self._args(lam)
        E = 2.0 + 4.0 / r
        a, b = X[2 * q], X[2 * q + 1]
        c = 0.25 * math.pi * w1 * a + b - k1
        ch = self.letters[q]
        if ch == "b":
            new = "a" if a < E else "g"
        elif abs(c) <= abs(a - E):
            new = "b"
        else:
            new = "g" if ch == "a" else "a"
        letters = self.letters[:q] + new + self.letters[q + 1:]
        X = X.copy()
        # a word repeating a shorter one ("aa") is that one's orbit
        for k in range(1, len(letters)):
            if len(letters) % k == 0 and letters == letters[:k] * (len(letters) // k):
                letters, X = letters[:k], X[:2 * k]
                break
        return MapOrbit(self.values, self.param, letters), X

    def cycle_series(self, X, lam):
        """The attractor table's series over one cycle (the map model's ``cycle``): the
        iterates a_n and b_n."""
        return X[0::2].copy(), X[1::2].copy()

    def store(self, X, lam, section):
        return {"section_u": X[0::2].copy(), "section_v": X[1::2].copy(),
                "cycle_duration": float(self.n)}


def map_seed(values, param, word):
    """A MapOrbit and its exact orbit (``theory.word_orbit``) for a word."""
    from ...analysis import parse_word  # start-up: loads numba
    from ...theory import word_orbit  # start-up: loads numba
    letters = parse_word(word)
    prob = MapOrbit(dict(values), param, letters)
    w1, k1, r = prob._args(values[param])
    x, _ = word_orbit(letters, w1, k1, r)
    return prob, x.reshape(-1).copy()
