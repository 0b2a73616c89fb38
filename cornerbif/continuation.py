"""Periodic orbits of any itinerary, stable or not, and their continuation through corner
events (docs/continuation.md).

A periodic orbit of the ``flow`` model is a closed chain of impacts: impact i lies on the
obstacle's piece j_i at local time tau_i and leaves it with velocity v_i (law 5); the
exact free flight (eq 4) from it meets the obstacle at impact i + 1; the chain closes after
m obstacle periods.  The unknowns X = (tau_0, v_0, tau_1, v_1, ...) solve 2N equations

    u_f(t_(i+1)) - z(t_(i+1)) = 0,   v_(i+1) - (1 + r) z'(t_(i+1)) + r v_f(t_(i+1)) = 0,

(x_f the flight from impact i), whose Jacobian is written in closed form
(``FlowOrbit.jacobian``): the flight matrix of ``stability.flight_matrix`` and the vector
field at both ends.  Nothing asks the orbit to be stable: Newton's method finds saddles
as well as attractors, and the itinerary (the pieces j_i) fixes on which side of each corner
every impact lies, so an orbit can be followed up to the parameter where one of its
impacts reaches a corner (tau_i -> 0 or L), and past it on the side where the orbit of the
new itinerary exists.

``continue_branch`` is pseudo-arclength continuation in one numeric scene parameter with
adaptive steps; along the branch it watches the distance of every impact to its corners,
the smallest gap of every flight to the obstacle (grazing: an impact is born), the
relative velocity of every impact (a zero-velocity impact), and the Floquet multipliers
(fold: det(J - I) = 0; period doubling: det(J + I) = 0; torus: a complex pair on the unit
circle), and locates each sign change by the secant method on the arclength.  Every point
it keeps passes the admissibility test (``admissible``), and every branch says why each of
its ends stopped (``stop_reason``).

``run_to_file`` is ``cornerbif continue``: the output locked and its fate decided before
any work (``plan_output``, as ``cornerbif sweep`` decides), the seeds found with the kernel
under a stop flag (an interrupt ends it within about a second), each branch and curve
written to the partial file as soon as it is finished (with the state to go on from), and
``resume`` completing it bitwise as an uninterrupted run.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time
from dataclasses import dataclass, field

import numpy as np

from .models.flow import packed as P
from .models.flow.params import OBSTACLES
from .numerics.oscillator import acceleration, derive, particular
from .numerics.saltation import flight_matrix, impact_saltation
from .obstacles.dispatch import corner_of, piece_start, z_state
from .outputs import CONTINUATION_FORMAT
from .stability import multipliers

NEWTON_TOL = 1e-12     # |residual| (scaled) at which Newton stops
NEWTON_MAX = 30
GAP_SAMPLES = 48       # samples per flight in the grazing monitor


class OrbitError(RuntimeError):
    """Newton did not converge to an orbit of the itinerary."""


def central_d_param(residual, X, lam):
    """dR/dparam by central differences (the parameter enters through packed rows)."""
    h = 1e-6 * max(1.0, abs(lam))
    return (residual(X, lam + h) - residual(X, lam - h)) / (2.0 * h)


def central_jacobian(residual, X, lam):
    """dR/dX by central differences, column by column (steps relative to each unknown)."""
    Jm = np.empty((len(residual(X, lam)), len(X)))
    for c in range(len(X)):
        h = 1e-7 * max(1.0, abs(X[c]))
        e = np.zeros(len(X))
        e[c] = h
        Jm[:, c] = (residual(X + e, lam) - residual(X - e, lam)) / (2.0 * h)
    return Jm


def cached(cache, key, build, limit=64):
    """cache[key], built by ``build()`` the first time; the cache is emptied past
    ``limit`` entries (a continuation visits a few parameter values at a time)."""
    if key not in cache:
        if len(cache) > limit:
            cache.clear()
        cache[key] = build()
    return cache[key]


# ------------------------------------------------------------------ the flow's orbit
@dataclass
class FlowOrbit:
    """The periodic-orbit problem of one itinerary of the ``flow`` model.

    ``values``: the scene's [system] values (named, as ``params.pack`` takes them) with
    ``param`` the one continued; ``obstacle``; ``pieces``: the piece j_i of each impact of
    one cycle (nondecreasing, within one cycle); ``m``: obstacle periods per cycle.
    """

    values: dict
    obstacle: str
    param: str
    pieces: np.ndarray
    m: int
    tol: float = 1e-12
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def n(self) -> int:
        return len(self.pieces)

    def packed(self, lam):
        """(p, d): the packed parameter row at param = lam and its derived constants."""
        def build():
            vals = dict(self.values)
            vals[self.param] = float(lam)
            p = P.pack(vals, self.obstacle, self.tol, 1e-6, 1e6, None, 0.0)
            return p, derive(p)
        return cached(self._cache, float(lam), build)

    def duration(self, lam) -> float:
        p, d = self.packed(lam)
        return self.m * (piece_start(d, 2) - piece_start(d, 0))

    def times(self, X, lam):
        """Absolute impact times t_i = start of piece j_i + tau_i."""
        _, d = self.packed(lam)
        return np.array([piece_start(d, int(j)) for j in self.pieces]) + X[0::2]

    def _flight(self, p, d, t0, z0, v0, t1):
        """The free flight from (z0, v0) at t0 to t1: (u, v, M)."""
        M = flight_matrix(p[P.SIGMA], p[P.K], t1 - t0)
        up0, vp0 = particular(p, d, t0)
        up1, vp1 = particular(p, d, t1)
        du, dv = z0 - up0, v0 - vp0
        return (up1 + M[0] * du + M[1] * dv, vp1 + M[2] * du + M[3] * dv, M)

    def residual(self, X, lam):
        p, d = self.packed(lam)
        r = p[P.R]
        N = self.n
        t = self.times(X, lam)
        D = self.duration(lam)
        R = np.empty(2 * N)
        for i in range(N):
            n = (i + 1) % N
            tn = t[n] + (D if n == 0 else 0.0)
            zi = z_state(p, int(self.pieces[i]), X[2 * i])
            zn = z_state(p, int(self.pieces[n]), X[2 * n])
            uf, vf, _ = self._flight(p, d, t[i], zi[0], X[2 * i + 1], tn)
            R[2 * i] = uf - zn[0]
            R[2 * i + 1] = X[2 * n + 1] - (1.0 + r) * zn[1] + r * vf
        return R

    def jacobian(self, X, lam):
        """dR/dX in closed form: with x_f = x_p(t') + M (x_i - x_p(t_i)), x_i = (z(t_i), v_i),
        dx_f/dtau_i = M ((z'(t_i), 0) - F(t_i, x_i)), dx_f/dv_i = M e2,
        dx_f/dtau_(i+1) = F(t', x_f), F = (v, f(t) - 2 sigma v - k^2 u) (eq 4)."""
        p, d = self.packed(lam)
        r = p[P.R]
        N = self.n
        t = self.times(X, lam)
        D = self.duration(lam)
        Jm = np.zeros((2 * N, 2 * N))
        for i in range(N):
            n = (i + 1) % N
            tn = t[n] + (D if n == 0 else 0.0)
            zi, zpi, _, _ = z_state(p, int(self.pieces[i]), X[2 * i])
            zn, zpn, zppn, _ = z_state(p, int(self.pieces[n]), X[2 * n])
            vi = X[2 * i + 1]
            uf, vf, M = self._flight(p, d, t[i], zi, vi, tn)
            ai = acceleration(p, t[i], zi, vi)
            af = acceleration(p, tn, uf, vf)
            g0, g1 = zpi - vi, -ai
            dti = (M[0] * g0 + M[1] * g1, M[2] * g0 + M[3] * g1)
            Jm[2 * i, 2 * i] += dti[0]
            Jm[2 * i, 2 * i + 1] += M[1]
            Jm[2 * i, 2 * n] += vf - zpn
            Jm[2 * i + 1, 2 * i] += r * dti[1]
            Jm[2 * i + 1, 2 * i + 1] += r * M[3]
            Jm[2 * i + 1, 2 * n] += -(1.0 + r) * zppn + r * af
            Jm[2 * i + 1, 2 * n + 1] += 1.0
        return Jm

    def d_param(self, X, lam):
        return central_d_param(self.residual, X, lam)

    # --- what the orbit is -------------------------------------------------------------
    def impacts(self, X, lam):
        """Per impact of one cycle: t, u, v_in, v_out, the relative velocity w- (< 0 for a
        real impact), the corner index and the signed corner offset (corner_of)."""
        p, d = self.packed(lam)
        N = self.n
        t = self.times(X, lam)
        D = self.duration(lam)
        out = {k: np.empty(N) for k in ("t", "u", "v_in", "v_out", "w", "offset")}
        out["corner"] = np.empty(N, np.int64)
        for i in range(N):
            n = (i + 1) % N
            tn = t[n] + (D if n == 0 else 0.0)
            zi = z_state(p, int(self.pieces[i]), X[2 * i])
            zn = z_state(p, int(self.pieces[n]), X[2 * n])
            _, vf, _ = self._flight(p, d, t[i], zi[0], X[2 * i + 1], tn)
            out["v_in"][n] = vf
            out["w"][n] = vf - zn[1]
            out["t"][i] = t[i]
            out["u"][i] = zi[0]
            out["v_out"][i] = X[2 * i + 1]
            c, off = corner_of(p, d, int(self.pieces[i]), X[2 * i])
            out["corner"][i] = c
            out["offset"][i] = off
        return out

    def monodromy(self, X, lam):
        """J = prod S_i M_i over the cycle (stability's flight and saltation matrices, the
        obstacle's slope and curvature on each impact's own piece: one-sided at a corner)."""
        p, d = self.packed(lam)
        r, sig, k = p[P.R], p[P.SIGMA], p[P.K]
        imp = self.impacts(X, lam)
        N = self.n
        D = self.duration(lam)
        J = np.eye(2)
        for i in range(N):
            n = (i + 1) % N
            tn = imp["t"][n] + (D if n == 0 else 0.0)
            M = np.array(flight_matrix(sig, k, tn - imp["t"][i])).reshape(2, 2)
            _, zp, zpp, _ = z_state(p, int(self.pieces[n]), X[2 * n])
            acc = acceleration(p, tn, imp["u"][n], imp["v_in"][n])
            S = np.array(impact_saltation(r, sig, imp["w"][n], acc, zpp)).reshape(2, 2)
            J = S @ M @ J
        return J

    def floquet(self, X, lam):
        J = self.monodromy(X, lam)
        re1, im1, re2, im2 = multipliers(J[0, 0], J[0, 1], J[1, 0], J[1, 1])
        return np.array([complex(re1, im1), complex(re2, im2)]), J

    def corner_distances(self, X, lam):
        """Per impact, the signed distance in time to the corner on its side of the piece
        (tau_i for the corner at the piece's start, L_j - tau_i for the one at its end,
        whichever is nearer): negative once the impact has crossed it."""
        p, d = self.packed(lam)
        out = np.empty(self.n)
        if not OBSTACLES[self.obstacle].corners:
            out[:] = np.inf          # piece ends are no corners: reindex() crosses them
            return out
        for i, j in enumerate(self.pieces):
            L = piece_start(d, int(j) + 1) - piece_start(d, int(j))
            tau = X[2 * i]
            out[i] = tau if tau < 0.5 * L else L - tau
        return out

    def reindex(self, X, lam):
        """On an obstacle without corners (``sine``), an impact that left its piece is put
        on the piece it now lies on (a piece end there is bookkeeping, not a corner):
        (problem, X), a new problem where a piece changed."""
        if OBSTACLES[self.obstacle].corners:
            return self, X
        p, d = self.packed(lam)
        X = X.copy()
        pieces = self.pieces.copy()
        for i in range(self.n):
            j = int(pieces[i])
            while X[2 * i] < 0.0:
                X[2 * i] += piece_start(d, j) - piece_start(d, j - 1)
                j -= 1
            while X[2 * i] >= piece_start(d, j + 1) - piece_start(d, j):
                X[2 * i] -= piece_start(d, j + 1) - piece_start(d, j)
                j += 1
            pieces[i] = j
        if np.array_equal(pieces, self.pieces):
            return self, X
        new = FlowOrbit(self.values, self.obstacle, self.param, pieces, self.m, self.tol)
        new._cache = self._cache
        return new, X

    def smallest_gap(self, X, lam):
        """The smallest gap u - z over the interior of every flight (sampled, then refined
        by a parabola through the smallest sample): negative where the flight crosses the
        obstacle (an impact the itinerary does not have), zero at a grazing."""
        p, d = self.packed(lam)
        imp = self.impacts(X, lam)
        N = self.n
        D = self.duration(lam)
        per = piece_start(d, 2) - piece_start(d, 0)
        L0 = piece_start(d, 1) - piece_start(d, 0)
        best = math.inf
        for i in range(N):
            n = (i + 1) % N
            t0 = imp["t"][i]
            t1 = imp["t"][n] + (D if n == 0 else 0.0)
            s = np.linspace(0.0, 1.0, GAP_SAMPLES + 2)[1:-1]
            g = np.array([self._gap(p, d, t0, imp["u"][i], imp["v_out"][i],
                                    t0 + x * (t1 - t0), per, L0) for x in s])
            q = int(np.argmin(g))
            gq = g[q]
            if 0 < q < len(s) - 1:
                a, b, c = g[q - 1], g[q], g[q + 1]
                den = a - 2 * b + c
                if den > 0:
                    x = s[q] + 0.5 * (a - c) / den * (s[1] - s[0])
                    gq = min(gq, self._gap(p, d, t0, imp["u"][i], imp["v_out"][i],
                                           t0 + x * (t1 - t0), per, L0))
            best = min(best, gq)
        return best

    def _gap(self, p, d, t0, u0, v0, t, per, L0):
        uf, _, _ = self._flight(p, d, t0, u0, v0, t)
        q = math.floor(t / per)
        x = t - q * per
        j = 2 * int(q) + (1 if x >= L0 else 0)
        z = z_state(p, j, t - piece_start(d, j))[0]
        return uf - z

    # --- what every orbit problem provides (FlowOrbit, MapOrbit) -----------------------
    def word(self, X, lam):
        return word_of(self, X, lam)

    def itinerary(self) -> str:
        """The pieces of the cycle's impacts and the periods per cycle, as text."""
        return f"pieces {list(map(int, self.pieces))}, {self.m} obstacle period(s)"

    def admissible(self, X, lam):
        return admissible(self, X, lam)

    def across(self, q, X, lam):
        return across_corner(self, q, X, lam)

    def store(self, X, lam, section):
        """What the continuation file keeps of the orbit at one point (docs/continuation.md):
        the cycle's impacts, the section state, the cycle's duration."""
        imp = self.impacts(X, lam)
        p, d = self.packed(lam)
        if section is None and self.obstacle in P.AUTO_SECTION:
            # the kernel's section (flow.watch_for_cycle): the corners of the parity
            # opposite to the first impact's corner, between the impact clusters
            pps = P.section_pieces(self.obstacle, p[P.OMEGA], None)
            c0 = int(imp["corner"][0])
            phase = (c0 + pps // 2) % pps
            j = c0 + 1
            while (j - phase) % pps != 0:
                j += 1
            u, v = section_state(self, X, lam, None, at=piece_start(d, j))
        else:
            T = section or 2.0 * math.pi / p[P.OMEGA]
            u, v = section_state(self, X, lam, T)
        return {"impact_t": imp["t"], "impact_u": imp["u"], "impact_v_in": imp["v_in"],
                "impact_v_out": imp["v_out"], "section_u": u, "section_v": v,
                "cycle_duration": self.duration(lam)}


# ------------------------------------------------------------------ the maps' orbit
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

    @property
    def n(self) -> int:
        return len(self.letters)

    def _args(self, lam):
        vals = dict(self.values)
        vals[self.param] = float(lam)
        return vals["omega"] - 2.0, vals["kappa"], vals["r"]

    def _matrices(self, lam):
        from .theory import map_matrices
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
        from .analysis import smallest_rotation
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

    def store(self, X, lam, section):
        return {"section_u": X[0::2].copy(), "section_v": X[1::2].copy(),
                "cycle_duration": float(self.n)}


def map_seed(values, param, word):
    """A MapOrbit and its exact orbit (``theory.word_orbit``) for a word."""
    from .analysis import parse_word
    from .theory import word_orbit
    letters = parse_word(word)
    prob = MapOrbit(dict(values), param, letters)
    w1, k1, r = prob._args(values[param])
    x, _ = word_orbit(letters, w1, k1, r)
    return prob, x.reshape(-1).copy()


# ------------------------------------------------------------------ two particles' orbit
@dataclass
class TwoParticleOrbit:
    """The periodic orbit of the ``two_particle`` model (section 6) as a closed chain of
    events: event k is a w-z impact ("W": law 5 with r1 on the wall, eq 72) or a z-u
    impact ("U": law 74); the unknowns per event are its time t_k and the state
    x_k+ = (z, y, u, v) just after it; both particles fly in closed form between events
    (``stability.flight_matrix`` and the oscillator rows of ``models.two_particle.kernel``).
    Per event five equations: its gap vanishes at t_k for the state the flight brings,
    and the state after it is the impact law of that state.  The cycle closes after m wall
    periods.  The Jacobian is by central differences (the chain is short: 5 unknowns per
    event).  A corner collision is two consecutive events meeting in time (a w-z and a
    z-u impact: this system's corner); across it the two swap.
    """

    values: dict
    param: str
    kinds: str          # "W" / "U" per event of one cycle, in time order
    m: int
    obstacle: str = "two_particle"
    _cache: dict = field(default_factory=dict, repr=False)

    @property
    def n(self) -> int:
        return len(self.kinds)

    def packed(self, lam):
        from .models.two_particle import kernel as TK
        from .models.two_particle import packed as TPM
        def build():
            vals = dict(self.values)
            vals[self.param] = float(lam)
            p = TPM.pack(vals)
            return (p, *TK.oscillators(p, TK.derive(p)))
        return cached(self._cache, float(lam), build)

    def duration(self, lam) -> float:
        from .models.two_particle import packed as TPM
        p, _, _ = self.packed(lam)
        return self.m * 2.0 * math.pi / p[TPM.OMEGA0]

    def _fly(self, lam, t0, x, t1):
        """Both particles' free flights from state x at t0 to t1."""
        from .models.two_particle import kernel as TK
        from .models.two_particle import packed as TPM
        p, Q, D = self.packed(lam)
        out = np.empty(4)
        for off, row, s, k in ((0, TK.RZ, p[TPM.SIGMA1], p[TPM.OMEGA1]),
                               (2, TK.RU, p[TPM.SIGMA2], p[TPM.OMEGA2])):
            M = flight_matrix(s, k, t1 - t0)
            a0, b0 = particular(Q[row], D[row], t0)
            a1, b1 = particular(Q[row], D[row], t1)
            du, dv = x[off] - a0, x[off + 1] - b0
            out[off] = a1 + M[0] * du + M[1] * dv
            out[off + 1] = b1 + M[2] * du + M[3] * dv
        return out

    def _arrival(self, X, lam, k):
        """(t_k, the state just before event k) from event k - 1's state after it."""
        N = self.n
        j = (k - 1) % N
        tk = X[5 * k] + (self.duration(lam) if k == 0 else 0.0)
        return tk, self._fly(lam, X[5 * j], X[5 * j + 1:5 * j + 5], tk)

    def _law(self, lam, kind, t, xm):
        """(gap, the state just after the event) for an event of ``kind`` at t."""
        from .models.two_particle import kernel as TK
        from .models.two_particle import packed as TPM
        p, _, _ = self.packed(lam)
        z, y, u, v = xm
        if kind == "W":
            w, wp, _, _ = TK.wall(p, t, 0.0)
            return z - w, np.array([z, (1.0 + p[TPM.R1]) * wp - p[TPM.R1] * y, u, v])
        y2, v2 = TPM.mass_ratio_impact(y, v, p[TPM.MU], p[TPM.R2])
        return u - z, np.array([z, y2, u, v2])

    def residual(self, X, lam):
        N = self.n
        R = np.empty(5 * N)
        for k in range(N):
            t, xm = self._arrival(X, lam, k)
            g, xp = self._law(lam, self.kinds[k], t, xm)
            R[5 * k] = g
            R[5 * k + 1:5 * k + 5] = X[5 * k + 1:5 * k + 5] - xp
        return R

    def jacobian(self, X, lam):
        return central_jacobian(self.residual, X, lam)

    def d_param(self, X, lam):
        return central_d_param(self.residual, X, lam)

    def tables(self, X, lam):
        """The orbit as the kernel's tables over two cycles (z-u rows:
        t, u, v_in, v_out, y_in, y_out, offset; w-z rows: t, z, y_in, y_out), for
        ``stability.two_particle_steps``."""
        N = self.n
        D = self.duration(lam)
        zu, wz = [], []
        for rep in range(2):
            for k in range(N):
                t, xm = self._arrival(X, lam, k)
                t = X[5 * k] + rep * D
                xp = X[5 * k + 1:5 * k + 5]
                if self.kinds[k] == "U":
                    zu.append([t, xm[0], xm[3], xp[3], xm[1], xp[1], 0.0])
                else:
                    wz.append([t, xm[0], xm[1], xp[1]])
        # a NaN row: the table is not full (stability.two_particle_steps' TABLE_FULL test)
        wz.append([math.nan] * 4)
        return np.array(zu), np.array(wz).reshape(-1, 4)

    def impacts(self, X, lam):
        """Per event: its time and the relative velocity of its approach (< 0)."""
        w = np.empty(self.n)
        for k in range(self.n):
            t, xm = self._arrival(X, lam, k)
            if self.kinds[k] == "W":
                from .models.two_particle import kernel as TK
                p, _, _ = self.packed(lam)
                w[k] = xm[1] - TK.wall(p, t, 0.0)[1]
            else:
                w[k] = xm[3] - xm[1]
        return {"w": w, "t": X[0::5].copy()}

    def floquet(self, X, lam):
        from .models.two_particle.tangent import two_particle_steps
        from .stability import OK, sorted_eigenvalues
        p, _, _ = self.packed(lam)
        zu, wz = self.tables(X, lam)
        n_zu = self.kinds.count("U")
        if n_zu == 0:
            nan = np.full(4, np.nan + 0j)
            return nan, np.full((4, 4), np.nan)
        G, _, st = two_particle_steps(p, np.ascontiguousarray(zu), np.ascontiguousarray(wz),
                                      0, n_zu)
        J = np.eye(4)
        for g in G:
            J = g @ J
        if st != OK:
            J[:] = np.nan
        return sorted_eigenvalues(J[None])[0], J

    def corner_distances(self, X, lam):
        """Per event, the time to the next event (a w-z and a z-u impact meeting: the
        system's corner; any two events meeting change the itinerary)."""
        t = X[0::5]
        D = self.duration(lam)
        gaps = np.append(np.diff(t), t[0] + D - t[-1])
        # two events of one kind meet only through a zero approach velocity (chatter or a
        # graze, its own event), not at this system's corner
        same = np.array([self.kinds[k] == self.kinds[(k + 1) % self.n]
                         for k in range(self.n)])
        gaps[same] = np.inf
        return gaps

    def smallest_gap(self, X, lam):
        """The smallest of both gaps z - w and u - z over the interior of every flight."""
        from .models.two_particle import kernel as TK
        p, _, _ = self.packed(lam)
        N = self.n
        D = self.duration(lam)
        best = math.inf
        for k in range(N):
            t0 = X[5 * k]
            t1 = X[5 * ((k + 1) % N)] + (D if k == N - 1 else 0.0)
            x0 = X[5 * k + 1:5 * k + 5]
            for s in np.linspace(0.0, 1.0, GAP_SAMPLES + 2)[1:-1]:
                t = t0 + s * (t1 - t0)
                x = self._fly(lam, t0, x0, t)
                best = min(best, x[0] - TK.wall(p, t, 0.0)[0], x[2] - x[0])
        return best

    def reindex(self, X, lam):
        return self, X

    def word(self, X, lam):
        """The itinerary: W and U in time order, grouped by wall period."""
        return self.kinds

    def itinerary(self) -> str:
        return f"events {self.kinds}, {self.m} wall period(s)"

    def admissible(self, X, lam):
        return admissible(self, X, lam)

    def across(self, q, X, lam):
        """Events q and q + 1 swap their order (the z-u impact passes the w-z impact)."""
        N = self.n
        r = (q + 1) % N
        kinds = list(self.kinds)
        kinds[q], kinds[r] = kinds[r], kinds[q]
        Xn = X.copy()
        # the guess: the two impact laws in the new order on the state the flight brings
        tq, xm = self._arrival(X, lam, q)
        tr = X[5 * r] + (self.duration(lam) if r == 0 else 0.0)
        _, first = self._law(lam, kinds[q], tr, self._fly(lam, tq, xm, tr))
        _, second = self._law(lam, kinds[r], tq, first)
        Xn[5 * q], Xn[5 * q + 1:5 * q + 5] = tr, first
        Xn[5 * r], Xn[5 * r + 1:5 * r + 5] = tq, second
        if r == 0:      # the last event passes the first one of the next cycle
            D = self.duration(lam)
            Xn[5 * q] = tr
            Xn[0] = tq - D
        new = TwoParticleOrbit(self.values, self.param, "".join(kinds), self.m)
        new._cache = self._cache
        return new, Xn

    def store(self, X, lam, section):
        zu, _ = self.tables(X, lam)
        n_zu = self.kinds.count("U")
        zu = zu.reshape(-1, 7)
        return {"impact_t": zu[:n_zu, 0], "impact_u": zu[:n_zu, 1],
                "impact_v_in": zu[:n_zu, 2], "impact_v_out": zu[:n_zu, 3],
                "event_t": X[0::5].copy(), "cycle_duration": self.duration(lam)}


def two_particle_seed(values, param, x_section, ipc):
    """A TwoParticleOrbit and its solved unknowns from a state at a section time (the
    system has the wall's period, so it is a state at t = 0): one cycle of ``ipc`` z-u
    impacts run by the kernel from it, with the w-z impacts between."""
    from .models.two_particle import packed as TPM
    from .models.two_particle.kernel import simulate_two_particle
    kw = {k: v for k, v in values.items() if k in TPM.NAMES}
    for F, W in (("F1", "Omega1"), ("F2", "Omega2")):
        if kw.get(F, 0.0) != 0.0:
            ratio = kw.get(W, 1.0) / kw["omega0"]
            if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio) or round(ratio) < 1:
                raise OrbitError(f"{F} != 0 with {W}/omega0 = {ratio!r} not a whole number: "
                                 "the seed's section state (t = n 2 pi/omega0) would not be "
                                 "a state at t = 0, nor the forcing periodic with the wall")
    r = simulate_two_particle(*x_section, transient=0, record=ipc + 2, **kw)
    zu_t = np.ravel(r["t"])
    n = int(np.isfinite(zu_t).sum())
    if n < ipc + 1:
        raise OrbitError("the run from the section state has no cycle")
    t0, t1 = zu_t[0], zu_t[ipc]
    T = 2.0 * math.pi / values["omega0"]
    m = int(round((t1 - t0) / T))
    ev = []
    for i in range(ipc):
        ev.append((zu_t[i], 1, "U", [np.ravel(r["u"])[i], np.ravel(r["y_out"])[i],
                                     np.ravel(r["u"])[i], np.ravel(r["v_out"])[i]]))
    wz_t = np.ravel(r["wz_t"])
    for j in range(int(np.isfinite(wz_t).sum())):
        if t0 < wz_t[j] < t1:
            ev.append((wz_t[j], 0, "W", [np.ravel(r["wz_z"])[j], np.ravel(r["wz_y_out"])[j],
                                         math.nan, math.nan]))
    ev.sort(key=lambda e: (e[0], e[1]))
    prob = TwoParticleOrbit(dict(values), param, "".join(e[2] for e in ev), m)
    lam = float(values[param])
    # times within the first cycle: a periodic orbit's system has the cycle's period, and
    # small times keep the unknowns' scale (d t / d omega0 grows with t)
    shift = math.floor(ev[0][0] / prob.duration(lam)) * prob.duration(lam)
    ev = [(t - shift, o, kind, x) for t, o, kind, x in ev]
    X = np.empty(5 * len(ev))
    last_u = None
    for k, (t, _, kind, x) in enumerate(ev):
        X[5 * k] = t
        if kind == "U":
            last_u = (t, x)
            X[5 * k + 1:5 * k + 5] = x
        else:
            # u and v at a w-z impact: the flight of u from the z-u impact before it
            tu, xu = last_u
            fl = prob._fly(lam, tu, np.array(xu), t)
            X[5 * k + 1:5 * k + 5] = [x[0], x[1], fl[2], fl[3]]
    return prob, newton(prob, X, lam)


# ------------------------------------------------------------------ Newton
def newton(problem, X, lam):
    """Newton on R(X, lam) = 0 at fixed lam; OrbitError if it does not converge."""
    X = np.array(X, float)
    for _ in range(NEWTON_MAX):
        R = problem.residual(X, lam)
        if not np.all(np.isfinite(R)):
            raise OrbitError("the residual is not finite")
        scale = 1.0 + np.abs(X).max()
        if np.abs(R).max() <= NEWTON_TOL * scale:
            return X
        dX = np.linalg.solve(problem.jacobian(X, lam), -R)
        X = X + dX
        if np.abs(dX).max() <= 1e-15 * scale:
            return X
    R = problem.residual(X, lam)
    if np.abs(R).max() <= 1e-9 * (1.0 + np.abs(X).max()):
        return X
    raise OrbitError(f"Newton did not converge (residual {np.abs(R).max():.3g})")


def seed_from_run(values, obstacle, param, t, v_out, corner_offset, ipc, tol=1e-12):
    """A FlowOrbit and its solved X from one run's record (``cornerbif.simulate`` or a
    sweep file: its last complete cycle of ``ipc`` impacts)."""
    n = int(np.isfinite(t).sum())
    if ipc <= 0 or n < ipc + 1:
        raise OrbitError("the run has no cycle to seed from")
    first = n - 1 - ipc
    prob = FlowOrbit(dict(values), obstacle, param, np.zeros(ipc, np.int64), 1, tol)
    lam = float(values[param])
    p, d = prob.packed(lam)
    per = piece_start(d, 2) - piece_start(d, 0)
    L0 = piece_start(d, 1) - piece_start(d, 0)
    dur = t[first + ipc] - t[first]
    m = int(round(dur / per))
    if p[P.F_AMP] != 0.0:
        cycles = p[P.F_OMEGA] * m * per / (2.0 * math.pi)
        if abs(cycles - round(cycles)) > 1e-9 * max(1.0, cycles):
            raise OrbitError(f"the forcing's period 2 pi/Omega does not divide the cycle's "
                             f"{m} obstacle period(s): no periodic orbit to continue")
        per = m * per      # the system's period: shift times by whole cycles only
    t0 = math.floor(t[first + 1] / per) * per
    pieces = np.empty(ipc, np.int64)
    X = np.empty(2 * ipc)
    for q in range(ipc):
        tt = t[first + 1 + q] - t0
        k = math.floor(tt / per)
        x = tt - k * per
        j = 2 * k + (1 if x >= L0 else 0)
        tau = tt - piece_start(d, j)
        # an impact recorded at a corner lies on the side its offset says
        L = piece_start(d, j + 1) - piece_start(d, j)
        off = corner_offset[first + 1 + q]
        if off == off and off < 0 and tau < 0.5 * L and obstacle == "rectified_sine":
            j -= 1
            tau += L
        pieces[q] = j
        X[2 * q] = tau
        X[2 * q + 1] = v_out[first + 1 + q]
    prob.pieces = pieces
    prob.m = m
    return prob, newton(prob, X, lam)


def seed_from_word(values, obstacle, param, word, tol=1e-12, cycles=6):
    """A FlowOrbit of a cluster word (``a``, ``b``, ``g`` letters, e.g. "b^5 g", "ab"),
    stable or not, near (omega, kappa) = (2, 0) on the rectified sine: the kernel is run
    from the 2D maps' orbit of the word (``theory.word_orbit``: (a0, b1) = (u, u')(0) at
    the section corner, epsilon = 1) for a few cycles without transient, the first run of
    clusters spelling the word (up to rotation) gives the pieces and the first guess, and
    Newton finds the flow's orbit.  OrbitError when the run does not spell it."""
    import cornerbif

    from .analysis import parse_word
    from .theory import word_orbit
    if obstacle != "rectified_sine":
        raise OrbitError(f"a word seeds an orbit on the rectified sine only (eq 8), not "
                         f"{obstacle!r}")
    letters = parse_word(word)
    x, _ = word_orbit(letters, values["omega"] - 2.0, values["kappa"], values["r"])
    sys_ = {k: v for k, v in values.items() if k in P.INDEX}
    rec = cycles * (2 * len(letters) + 2)
    res = cornerbif.simulate([x[0, 0]], [x[0, 1]], obstacle=obstacle, transient=0,
                             record=rec, **sys_)
    t, off = res["t"][0], res["corner_offset"][0]
    n = int(np.isfinite(t).sum())
    L = math.pi / values["omega"]
    corner = np.rint((t[:n] - off[:n]) / L).astype(int)
    # clusters: (first impact, count, symbol)
    clusters = []
    for i in range(n):
        if clusters and corner[i] == corner[clusters[-1][0]]:
            clusters[-1][1] += 1
        else:
            clusters.append([i, 1])
    sym = []
    for i0, c in clusters:
        if c == 1:
            sym.append("b" if off[i0] >= 0 else "g")
        elif c == 2 and off[i0] < 0 <= off[i0 + 1]:
            sym.append("a")
        else:
            sym.append("x")
    K = len(letters)
    rotations = {letters[k:] + letters[:k] for k in range(K)}
    for s in range(1, len(clusters) - K):
        if "".join(sym[s:s + K]) in rotations:
            first = clusters[s][0]
            nxt = clusters[s + K][0]
            ipc = nxt - first
            tt = np.concatenate([[t[first - 1]], t[first:nxt + 1]])
            vv = np.concatenate([[res["v_out"][0][first - 1]], res["v_out"][0][first:nxt + 1]])
            oo = np.concatenate([[off[first - 1]], off[first:nxt + 1]])
            return seed_from_run(values, obstacle, param, tt, vv, oo, ipc, tol)
    raise OrbitError(f"the run from the maps' orbit of {word!r} does not spell it "
                     f"(clusters {''.join(sym)})")


# ------------------------------------------------------------------ pseudo-arclength
EVENTS = ("corner", "grazing", "zero_velocity", "fold", "period_doubling", "torus")

@dataclass
class Point:
    lam: float
    X: np.ndarray
    mu: np.ndarray
    monitors: dict
    problem: object = None     # the itinerary X refers to (pieces change on a smooth obstacle)
    admissible: bool = True    # the admissibility check's outcome (``admissible``)
    margin: float = math.nan   # its smallest margin (``_margins``; >= -ADMISSIBLE_TOL: passes)


@dataclass
class Event:
    kind: str          # corner, grazing, zero_velocity, fold, period_doubling, torus, end
    lam: float
    X: np.ndarray
    detail: str = ""
    problem: object = None


def _monitors(problem, X, lam):
    if hasattr(problem, "orbit"):        # a curve of events: watch the orbit on it
        problem, X = problem.orbit(X, lam)
    with np.errstate(invalid="ignore"):  # an orbit past an ending event: NaN multipliers
        return _watch(problem, X, lam)


def _watch(problem, X, lam):
    mu, J = problem.floquet(X, lam)
    imp = problem.impacts(X, lam)
    return {
        "corner": problem.corner_distances(X, lam),
        "grazing": np.array([problem.smallest_gap(X, lam)]),
        "zero_velocity": np.array([-imp["w"].max()]),
        "fold": np.array([np.linalg.det(J - np.eye(len(J)))]),
        "period_doubling": np.array([np.linalg.det(J + np.eye(len(J)))]),
        # a pair with mu_i mu_j = 1 (the bialternate product's determinant, det J - 1 in
        # two dimensions): a complex pair on the unit circle; a real pair (a neutral
        # saddle) is dropped by _events_between
        "torus": np.array([_pairs_on_circle(mu)]),
    }, mu


def _pairs_on_circle(mu):
    """prod over pairs i < j of (mu_i mu_j - 1): real (the multipliers of a real matrix),
    zero when a pair multiplies to 1."""
    out = 1.0 + 0j
    for i in range(len(mu)):
        for j in range(i + 1, len(mu)):
            out *= mu[i] * mu[j] - 1.0
    return float(out.real)


def _wdot(W, a, b):
    """The weighted inner product sum W_i^2 a_i b_i of the continuation's arclength."""
    return float(np.sum(W * W * a * b))


def _tangent(problem, X, lam, prev=None, W=None):
    """The null vector of [dR/dX, dR/dlam], of unit weighted length, oriented along
    ``prev``."""
    A = np.hstack([problem.jacobian(X, lam), problem.d_param(X, lam)[:, None]])
    _, _, vt = np.linalg.svd(A)
    T = vt[-1]
    W = np.ones_like(T) if W is None else W
    if prev is not None and _wdot(W, T, prev) < 0:
        T = -T
    return T / math.sqrt(_wdot(W, T, T))


def _correct(problem, Y0, T, s, base, W):
    """Newton on (R(Y) = 0, <T, Y - base>_W = s) from the predictor Y0."""
    Y = Y0.copy()
    n = len(Y) - 1
    row = W * W * T
    for _ in range(NEWTON_MAX):
        X, lam = Y[:n], Y[n]
        R = problem.residual(X, lam)
        h = row @ (Y - base) - s
        F = np.append(R, h)
        if not np.all(np.isfinite(F)):
            raise OrbitError("not finite")
        if np.abs(F).max() <= NEWTON_TOL * (1.0 + np.abs(Y).max()):
            return Y
        A = np.vstack([np.hstack([problem.jacobian(X, lam),
                                  problem.d_param(X, lam)[:, None]]), row])
        dY = np.linalg.solve(A, -F)
        Y = Y + dY
        if np.abs(dY).max() <= 1e-15 * (1.0 + np.abs(Y).max()):
            return Y
    raise OrbitError("the corrector did not converge")


def _locate(problem, Ya, T, s_lo, s_hi, f_lo, f_hi, fun, W):
    """The arclength s in (s_lo, s_hi) where fun(Y(s)) changes sign (Illinois secant)."""
    side = 0
    Y = None
    for _ in range(80):
        s = s_hi - f_hi * (s_hi - s_lo) / (f_hi - f_lo) if f_hi != f_lo else 0.5 * (s_lo + s_hi)
        if not (min(s_lo, s_hi) < s < max(s_lo, s_hi)):
            s = 0.5 * (s_lo + s_hi)
        try:
            Y = _correct(problem, Ya + s * T, T, s, Ya, W)
        except (OrbitError, np.linalg.LinAlgError):
            s = 0.5 * (s_lo + s_hi)
            try:
                Y = _correct(problem, Ya + s * T, T, s, Ya, W)
            except (OrbitError, np.linalg.LinAlgError):
                if Y is None:
                    raise
                break         # the best located point so far
        f = fun(Y)
        if f == 0.0 or abs(s_hi - s_lo) <= 1e-15 * (1.0 + abs(s)):
            break
        if (f > 0) == (f_hi > 0):
            s_hi, f_hi = s, f
            if side == 1:
                f_lo *= 0.5
            side = 1
        else:
            s_lo, f_lo = s, f
            if side == -1:
                f_hi *= 0.5
            side = -1
        if abs(s_hi - s_lo) <= 1e-14 * max(1.0, abs(s)):
            break
    return Y


def continue_branch(problem, X0, lam0, lam_range, direction=1.0, T0=None, ds=1e-3,
                    ds_min=1e-9, ds_max=None, max_steps=2000, events=EVENTS, log=None):
    """Pseudo-arclength continuation of the orbit (X0, lam0) within param in ``lam_range``.

    The arclength is weighted: the parameter by the range's width, each unknown by
    1 + its size at the start, so that ``ds`` (``ds_min``, ``ds_max``) are parameter
    steps where the branch moves mostly in the parameter, whatever the unknowns' scales
    (impact velocities of 100 beside times of 1).  The first step goes along ``T0`` (a
    tangent) if given, else the way ``direction`` (+1, -1) moves the parameter.  Returns
    (points, events): the accepted points (Point: param, X, multipliers, monitors, the
    admissibility check's outcome) and the located events (Event).  The branch ends at the
    range's end, at an event that ends this itinerary's orbit as the flow's (corner,
    grazing, zero_velocity: its located point is the branch's last; located whether
    ``events`` lists it or not, since past it the solution is no orbit of the flow), where a
    point is not admissible though no test function said so (the branch ends at its last
    admissible point), when the step falls below ``ds_min``, when the step budget runs out,
    or when a step fails (Newton, a singular matrix): the last event, of kind "end" where
    none of the named ones, always says why.  Every point returned is admissible
    (``admissible``); OrbitError if the start is not.
    """
    n = len(X0)
    lo, hi = lam_range
    width = hi - lo
    ds_max = ds_max or 50 * ds
    W = np.append(1.0 / (1.0 + np.abs(np.asarray(X0, float))), 1.0 / width)
    h, h_min, h_max = ds / width, ds_min / width, ds_max / width
    Y = np.append(np.asarray(X0, float), lam0)
    mon, mu = _monitors(problem, Y[:n], Y[n])
    ok, margin = _point_admissible(problem, Y[:n], Y[n], mon)
    if not ok:
        raise OrbitError(f"the orbit is not admissible at the branch's start "
                         f"({_why_not(problem, Y[:n], Y[n])})")
    points = [Point(lam0, Y[:n].copy(), mu, mon, problem, ok, margin)]
    found = []
    T = _tangent(problem, Y[:n], Y[n], T0, W)
    if T0 is None and T[n] * direction < 0:
        T = -T
    if (lam0 <= lo and T[n] < 0) or (lam0 >= hi and T[n] > 0):
        found.append(Event("end", lam0, Y[:n].copy(), "the end of the range", problem))
        return points, found
    failure = ""
    for step in range(max_steps + 1):
        if step == max_steps:
            found.append(Event("end", Y[n], Y[:n].copy(),
                               f"the step budget ({max_steps} steps) ran out", problem))
            break
        try:
            Yn = _correct(problem, Y + h * T, T, h, Y, W)
            jump = Yn - (Y + h * T)
            if math.sqrt(_wdot(W, jump, jump)) > h:
                raise OrbitError("the corrector jumped away from the predictor")
        except (OrbitError, np.linalg.LinAlgError) as e:
            failure = str(e) or type(e).__name__
            h *= 0.5
            if h < h_min:
                found.append(Event("end", Y[n], Y[:n].copy(),
                                   f"the step fell below ds_min ({ds_min:.3g}; the last "
                                   f"attempt: {failure})", problem))
                break
            continue
        before, kept = len(found), len(points)
        try:
            problem, Y, T, mon, h, stop = _advance(problem, Y, Yn, T, mon, h, h_max, lo, hi,
                                                   events, found, points, n, W)
        except (OrbitError, np.linalg.LinAlgError, ArithmeticError, ValueError) as e:
            # a step that cannot be completed (the monitors, an event's location or the next
            # tangent failed): the branch ends at its last complete point, saying so
            if len(points) == kept:
                del found[before:]       # located beyond the last complete point
            last = points[-1]
            found.append(Event("end", last.lam, last.X.copy(),
                               f"the continuation failed after this point "
                               f"({str(e) or type(e).__name__})", last.problem))
            break
        if stop:
            break
        if log:
            log(Y[n])
    return points, found


def _advance(problem, Y, Yn, T, mon, h, h_max, lo, hi, events, found, points, n, W):
    """One accepted step of ``continue_branch`` from Y to the corrected Yn: the range's end,
    the events between, the admissibility of Yn, the next tangent and step.  Returns
    (problem, Y, T, monitors, h, stop): the problem is another where an impact changed
    piece on a smooth obstacle (``reindex``)."""
    out = Yn[n] > hi or Yn[n] < lo
    if out:
        edge = hi if Yn[n] > hi else lo

        def sfun(Yv, edge=edge):
            return Yv[n] - edge
        Yn = _locate(problem, Y, T, 0.0, h, sfun(Y), sfun(Yn), sfun, W)
    mon_n, mu_n = _monitors(problem, Yn[:n], Yn[n])
    before = len(found)
    ended = _events_between(problem, Y, Yn, T, mon, mon_n, events, found, n, W)
    if ended:
        e = found[-1]
        m_e, mu_e = _monitors(problem, e.X, e.lam)
        ok_e, margin_e = _point_admissible(problem, e.X, e.lam, m_e)
        if ok_e:
            points.append(Point(e.lam, e.X.copy(), mu_e, m_e, problem, ok_e, margin_e))
            return problem, Y, T, mon, h, True
        # the located end is not an orbit of the flow either: the branch ends before it
        del found[before:]
        found.append(Event("end", Y[n], Y[:n].copy(),
                           f"its orbit stops being one of the flow within the next step "
                           f"({_why_not(problem, e.X, e.lam)} at the located {e.kind}, "
                           f"{e.lam:.12g}): the branch ends at its last admissible point",
                           problem))
        return problem, Y, T, mon, h, True
    ok_n, margin_n = _point_admissible(problem, Yn[:n], Yn[n], mon_n)
    if not ok_n:
        # no test function changed sign (through a pole, or a non-finite value), yet the
        # next point is no orbit of the flow: it is not stored, and the branch ends here
        del found[before:]
        found.append(Event("end", Y[n], Y[:n].copy(),
                           f"its orbit stops being one of the flow within the next step (at "
                           f"{Yn[n]:.12g}: {_why_not(problem, Yn[:n], Yn[n])}): the branch "
                           "ends at its last admissible point", problem))
        return problem, Y, T, mon, h, True
    points.append(Point(Yn[n], Yn[:n].copy(), mu_n, mon_n, problem, ok_n, margin_n))
    if out:
        found.append(Event("end", Yn[n], Yn[:n].copy(), "the end of the range", problem))
        return problem, Yn, T, mon_n, h, True
    problem, Yn[:n] = problem.reindex(Yn[:n], Yn[n])
    Tn = _tangent(problem, Yn[:n], Yn[n], T, W)
    # adapt: grow where the tangent turns little
    turn = math.acos(max(-1.0, min(1.0, _wdot(W, T, Tn))))
    h = min(h_max, h * (1.5 if turn < 0.05 else 1.0 if turn < 0.2 else 0.5))
    return problem, Yn, Tn, mon_n, h, False


@dataclass
class Branch:
    problem: FlowOrbit
    points: list
    events: list
    word: str = ""
    origin: str = ""
    stops: list = None        # the events where it stopped (None: its last event)

    def ends(self) -> list:
        """The events at which the branch stopped: the last of each way it was continued."""
        return self.stops if self.stops is not None else self.events[-1:]


def across_corner(problem, q, X, lam):
    """The itinerary with impact q moved to the other side of the corner it reached (the
    neighbouring piece, local time shifted by that piece's length): the problem and X."""
    p, d = problem.packed(lam)
    j = int(problem.pieces[q])
    X = X.copy()
    L = piece_start(d, j + 1) - piece_start(d, j)
    pieces = problem.pieces.copy()
    if X[2 * q] < 0.5 * L:
        Lm = piece_start(d, j) - piece_start(d, j - 1)
        pieces[q] = j - 1
        X[2 * q] += Lm
    else:
        pieces[q] = j + 1
        X[2 * q] -= L
    new = FlowOrbit(problem.values, problem.obstacle, problem.param, pieces, problem.m,
                    problem.tol)
    return new, X


MAX_BRANCHES = 6      # branches continued each way from a seed (``follow``)


def follow(problem, X0, lam0, lam_range, direction=1.0, switch=True,
           max_branches=MAX_BRANCHES, **kw):
    """Continue from (X0, lam0) and, at every corner collision, on along the branch of
    the new itinerary (the impact on the other side of its corner) where it exists:
    the tangent of the new itinerary at the collision, oriented so that the impact
    moves into its new piece, says whether the new branch goes on in the same direction
    (a persistence: the word changes) or turns back (a nonsmooth fold: the two branches
    end together).  Returns the branches in order (breadth first, at most
    ``max_branches``; ``follow_step`` is one of them)."""
    out = []
    todo = [(problem, X0, lam0, None, "start")]
    while todo and len(out) < max_branches:
        prob, X, lam, T0, origin = todo.pop(0)
        br, more = follow_step(prob, X, lam, T0, origin, lam_range, direction, switch,
                               room=max_branches - len(out) - 1 - len(todo), **kw)
        out.append(br)
        todo += more
    return out


def follow_step(prob, X, lam, T0, origin, lam_range, direction=1.0, switch=True,
                room=MAX_BRANCHES, **kw):
    """One branch of ``follow``: continue (X, lam) of ``prob`` (along the tangent ``T0``,
    or the way ``direction`` moves the parameter) and, where it ends at a corner
    collision and ``switch``, solve the other side's itinerary there.  Returns (the
    Branch, the branches to continue from it: (problem, X, param, tangent, origin) each).
    ``room``: how many more branches ``follow`` continues; those beyond are said in the
    corner collision's detail and not returned."""
    try:
        pts, evs = continue_branch(prob, X, lam, lam_range, direction, T0, **kw)
    except (OrbitError, np.linalg.LinAlgError, ArithmeticError, ValueError) as e:
        X = np.asarray(X, float).copy()
        try:
            mon, mu = _monitors(prob, X, lam)
            ok, margin = _point_admissible(prob, X, lam, mon)
        except (OrbitError, np.linalg.LinAlgError, ArithmeticError, ValueError):
            mon, mu, ok, margin = {}, np.full(2, complex(math.nan, math.nan)), True, math.nan
        pts = [Point(lam, X, mu, mon, prob, ok, margin)]
        evs = [Event("end", lam, X, f"the continuation failed ({e})", prob)]
    br = Branch(prob, pts, evs, prob.word(pts[0].X, pts[0].lam), origin)
    last = evs[-1] if evs else None
    if not (switch and last is not None and last.kind == "corner"):
        return br, []
    more = []
    q = int(last.detail.split(";")[0].split()[-1])
    new, Xs = last.problem.across(q, last.X, last.lam)
    n = len(Xs)
    try:
        Xn = newton(new, Xs, last.lam)
        T = _tangent(new, Xn, last.lam)
    except (OrbitError, np.linalg.LinAlgError) as e:
        last.detail += f"; no orbit of the other side's itinerary ({e})"
        return br, more
    ok, why = new.admissible(Xn, last.lam)
    if not ok:
        last.detail += (f"; the other side's itinerary has no admissible orbit there "
                        f"({why}): the orbit ends at the corner collision")
        return br, more
    word = new.word(Xn, last.lam)
    if np.abs(Xn - Xs).max() > 1e-6 * (1.0 + np.abs(Xs).max()):
        # the map jumps at the corner (the one-sided slopes differ): the other side's
        # orbit is another orbit, not this one going on; follow it both ways
        last.detail += (f"; the map jumps there: the other side's itinerary has the "
                        f"orbit {word!r}, continued both ways")
        origin = (f"the orbit {word!r} on the other side of the corner collision of "
                  f"{q} at {new.param} = {last.lam!r} (a jump)")
        more.append((new, Xn, last.lam, T, origin))
        more.append((new, Xn, last.lam, -T, origin))
    else:
        # a continuous crossing: the orbit goes on, into the new side (the distance of
        # point q to its corner must grow)
        eps = 1e-7 * (1.0 + np.abs(Xn).max())
        Y = np.append(Xn, last.lam)
        d_plus = new.corner_distances((Y + eps * T)[:n], (Y + eps * T)[n])[q]
        d_minus = new.corner_distances((Y - eps * T)[:n], (Y - eps * T)[n])[q]
        if d_minus > d_plus:
            T = -T
        came = pts[-1].lam - pts[-2].lam if len(pts) > 1 else direction
        kind = "persists" if T[n] * came > 0 else "turns back (nonsmooth fold)"
        last.detail += f"; the orbit crosses continuously and {kind} as {word!r}"
        more.append((new, Xn, last.lam, T, f"corner collision of {q} at "
                                           f"{new.param} = {last.lam!r}: {kind}"))
    if len(more) > max(room, 0):
        dropped = len(more) - max(room, 0)
        last.detail += (f"; {'it is' if dropped == len(more) else 'one way is'} not "
                        f"continued (at most {MAX_BRANCHES} branches each way from a seed)")
        more = more[:max(room, 0)]
    return br, more


ADMISSIBLE_TOL = 1e-9


def _margins(cd, gap, w_max, scale):
    """The three margins of the admissibility test, each >= -tol for an orbit of the flow:
    the smallest distance of an impact to its corner (time), the smallest gap of a flight
    to the obstacle and minus the largest arrival velocity w- (both relative to the
    orbit's scale, 1 + its largest unknown)."""
    cd = np.asarray(cd, float)
    return (float(cd.min()) if cd.size else math.inf, float(gap) / scale,
            -float(w_max) / scale)


def admissible(problem, X, lam, tol=ADMISSIBLE_TOL):
    """Whether the orbit is one of the flow: every impact on its own piece (corner
    distances >= -tol), every flight above the obstacle (smallest gap >= -tol) and every
    impact arriving from above (w- < tol).  Returns (ok, reason)."""
    scale = 1.0 + np.abs(X).max()
    cd = problem.corner_distances(X, lam)
    g = problem.smallest_gap(X, lam)
    w = problem.impacts(X, lam)["w"]
    m_cd, m_gap, m_w = _margins(cd, g, w.max(), scale)
    if m_cd < -tol:
        return False, f"impact {int(np.argmin(cd))} beyond its corner by {-cd.min():.3g}"
    if m_gap < -tol:
        return False, f"a flight crosses the obstacle (gap {g:.3g})"
    if m_w < -tol:
        return False, f"impact {int(np.argmax(w))} arrives from below (w- = {w.max():.3g})"
    return True, ""


def _orbit_of(problem, X, lam):
    """(orbit problem, its X) of a point: a curve of events (CornerCurve, FoldCurve) holds
    an orbit of the flow at each of its points."""
    return problem.orbit(X, lam) if hasattr(problem, "orbit") else (problem, X)


def _point_admissible(problem, X, lam, mon, tol=ADMISSIBLE_TOL):
    """(ok, margin): the admissibility test (``admissible``) of a point from the monitors
    already computed there (``_monitors``: the corner distances, the smallest gap and the
    largest arrival velocity), without computing them again."""
    prob, Xo = _orbit_of(problem, X, lam)
    m = _margins(mon["corner"], mon["grazing"][0], -mon["zero_velocity"][0],
                 1.0 + np.abs(Xo).max())
    if any(math.isnan(x) for x in m):
        return False, math.nan
    margin = min(m)
    return bool(margin >= -tol), margin


def _why_not(problem, X, lam):
    """Why a point is not admissible, in the orbit problem's own words."""
    try:
        prob, Xo = _orbit_of(problem, X, lam)
        ok, why = prob.admissible(Xo, lam)
        return why or "a test function is not finite"
    except (OrbitError, np.linalg.LinAlgError, ArithmeticError, ValueError) as e:
        return f"it cannot be evaluated: {e}"


def word_of(problem, X, lam, cycles=4):
    """The orbit's word in the engine's symbols (``analysis.detect_cycle`` on ``cycles``
    repetitions of its impacts: clusters by nearest corner, a, b, g)."""
    from .analysis import detect_cycles, words
    imp = problem.impacts(X, lam)
    N = problem.n
    p, d = problem.packed(lam)
    D = problem.duration(lam)
    per_corners = round(D / (piece_start(d, 1) - piece_start(d, 0)))
    if problem.obstacle != "rectified_sine":
        per_corners = problem.m
    reps = cycles * N + 2
    t = np.full((1, reps), np.nan)
    vin = np.full((1, reps), np.nan)
    off = np.full((1, reps), np.nan)
    corner = np.zeros((1, reps), np.int64)
    for c in range(reps):
        i, k = c % N, c // N
        t[0, c] = imp["t"][i] + k * D
        vin[0, c] = imp["v_in"][i]
        off[0, c] = imp["offset"][i]
        corner[0, c] = imp["corner"][i] + k * per_corners
    per = np.zeros(1, np.int64)
    ipc = np.zeros(1, np.int64)
    sym = np.zeros((1, reps), np.uint8)
    cornered = np.array([problem.obstacle != "sine"])
    detect_cycles(t, vin, off, corner, cornered, 1e-9, per, ipc, sym)
    return str(words(sym)[0])


ENDING = ("corner", "grazing", "zero_velocity")
# what each ending event does to the orbit, for the branch's end (``stop_reason``)
ENDING_WORDS = {"corner": "a corner collision: impact {q} reaches its corner",
                "grazing": "a grazing: a flight touches the obstacle (an impact is born)",
                "zero_velocity": "a zero-velocity impact: an impact arrives with the "
                                 "obstacle's velocity"}


def _events_between(problem, Ya, Yb, T, ma, mb, kinds, found, n, W):
    """Locate every sign change of a watched test function between two points; append
    the events in arclength order.  Returns True when one of them ends the branch (its
    located point becomes the branch's last).  The ending kinds (``ENDING``) are watched
    whether ``kinds`` lists them or not: past them the solution is no orbit of the flow.
    One that ``kinds`` leaves out ends the branch as an event of kind "end" saying what it
    was (it is then neither reported as its kind nor switched across)."""
    hits = []
    s_b = _wdot(W, T, Yb - Ya)
    watched = tuple(kinds)
    for kind in watched + tuple(k for k in ENDING if k not in watched):
        a, b = ma[kind], mb[kind]
        for q in range(len(a)):
            if (abs(a[q]) > 1e-12 and (a[q] > 0) != (b[q] > 0) and np.isfinite(a[q])
                    and np.isfinite(b[q])):
                def fun(Y, kind=kind, q=q):
                    return _monitors(problem, Y[:n], Y[n])[0][kind][q]
                Y = _locate(problem, Ya, T, 0.0, s_b, a[q], b[q], fun, W)
                if not abs(fun(Y)) <= 1e-6 * max(1.0, abs(a[q]), abs(b[q])):
                    continue      # a sign change through a pole (multipliers blowing up)
                hits.append((_wdot(W, T, Y - Ya), kind, q, Y))
    hits.sort(key=lambda h: h[0])
    for _, kind, q, Y in hits:
        if kind == "torus" and problem.floquet(Y[:n], Y[n])[0][0].imag == 0.0:
            continue          # det J = 1 with real multipliers: a neutral saddle
        if kind in ENDING and kind != "corner" and hasattr(problem, "corner_distances"):
            # a grazing or a zero-velocity impact exactly at a corner is a corner collision
            # (two impacts straddling a corner merge there: the alpha orbit at kappa_CC)
            cd = np.abs(problem.corner_distances(Y[:n], Y[n]))
            if cd.min() <= 1e-9:
                kind, q = "corner", int(np.argmin(cd))
        if kind in ENDING and kind not in watched:
            found.append(Event("end", Y[n], Y[:n].copy(),
                               ENDING_WORDS[kind].format(q=q) + f" (continue.events does "
                               f"not list {kind!r}: located as the branch's end, not as an "
                               "event, and not continued across)", problem))
            return True
        detail = f"impact {q}" if kind == "corner" else ""
        found.append(Event(kind, Y[n], Y[:n].copy(), detail, problem))
        if kind in ENDING:
            return True
    return False


# ------------------------------------------------------------------ two parameters
def with_value(base, name, value):
    """The orbit problem ``base`` with the (other) parameter ``name`` at ``value``: the
    problems of a curve's second parameter, kept in the base's cache."""
    def build():
        return dataclasses.replace(base, values=dict(base.values) | {name: float(value)},
                                   _cache={})
    return cached(base._cache, (name, float(value)), build, limit=256)


@dataclass
class CornerCurve:
    """The corner collision of impact ``q`` as a curve in two parameters: impact q held
    at its corner (tau_q = 0 at its piece's start, or L at its end) and ``param2`` free;
    continued in the base problem's parameter.  X' is X with tau_q replaced by param2.
    """

    base: FlowOrbit
    q: int
    at_end: bool
    param2: str

    @property
    def n(self) -> int:
        return self.base.n

    def _split(self, Xc, lam):
        p, d = self.base.packed(lam)
        X = Xc.copy()
        j = int(self.base.pieces[self.q])
        X[2 * self.q] = (piece_start(d, j + 1) - piece_start(d, j)) if self.at_end else 0.0
        return X, Xc[2 * self.q]

    def _problem(self, lam2):
        return with_value(self.base, self.param2, lam2)

    def residual(self, Xc, lam):
        X, lam2 = self._split(Xc, lam)
        return self._problem(lam2).residual(X, lam)

    def jacobian(self, Xc, lam):
        X, lam2 = self._split(Xc, lam)
        Jm = self._problem(lam2).jacobian(X, lam)
        h = 1e-6 * max(1.0, abs(lam2))
        Jm[:, 2 * self.q] = (self._problem(lam2 + h).residual(X, lam)
                             - self._problem(lam2 - h).residual(X, lam)) / (2.0 * h)
        return Jm

    def d_param(self, Xc, lam):
        """dR/dparam of the curve's own residual: with the impact held at the end of its
        piece, tau_q = L(param) moves with the parameter too."""
        return central_d_param(self.residual, Xc, lam)

    def orbit(self, Xc, lam):
        """(problem at param2, X) of the point of the curve."""
        X, lam2 = self._split(Xc, lam)
        return self._problem(lam2), X

    def reindex(self, Xc, lam):
        return self, Xc


@dataclass
class FoldCurve:
    """A fold (a multiplier at +1) as a curve in two parameters: the orbit's equations
    and det(J - I) = 0 (J the monodromy), with ``param2`` free (the last unknown of X'),
    continued in the base problem's parameter; the Jacobian by central differences."""

    base: object
    param2: str

    @property
    def n(self) -> int:
        return self.base.n

    def _problem(self, lam2):
        return with_value(self.base, self.param2, lam2)

    def residual(self, Xc, lam):
        prob = self._problem(Xc[-1])
        X = Xc[:-1]
        _, J = prob.floquet(X, lam)
        return np.append(prob.residual(X, lam), np.linalg.det(J - np.eye(len(J))))

    def jacobian(self, Xc, lam):
        return central_jacobian(self.residual, Xc, lam)

    def d_param(self, Xc, lam):
        return central_d_param(self.residual, Xc, lam)

    def orbit(self, Xc, lam):
        return self._problem(Xc[-1]), Xc[:-1]

    def reindex(self, Xc, lam):
        return self, Xc


def fold_curve(event, param, lam_range, direction=1.0, ds=1e-3, **kw):
    """Continue a located fold (an Event of kind "fold" in ``event.problem.param``) in
    the plane of that parameter and ``param``: (param values, fold parameter values)."""
    prob = event.problem
    if not isinstance(prob, FlowOrbit):
        raise OrbitError(f"fold curves are continued for the flow model, not for "
                         f"{type(prob).__name__}")
    base_vals = dict(prob.values)
    base_vals[prob.param] = event.lam
    base = dataclasses.replace(prob, values=base_vals, param=param, _cache={})
    curve = FoldCurve(base, prob.param)
    Xc = np.append(event.X, event.lam)
    lam0 = float(prob.values[param])
    Xc = newton(curve, Xc, lam0)
    pts, evs = continue_branch(curve, Xc, lam0, lam_range, direction, ds=ds, events=ENDING,
                               **kw)
    return (np.array([pt.lam for pt in pts]), np.array([pt.X[-1] for pt in pts]), curve, pts,
            evs)


def corner_curve(event, param, lam_range, direction=1.0, ds=1e-3, **kw):
    """Continue a located corner collision (an Event of kind "corner" of a branch in
    ``event.problem.param``) in the plane of that parameter and ``param``: returns the
    curve's points as arrays (param values, event parameter values)."""
    prob = event.problem
    if not isinstance(prob, FlowOrbit):
        raise OrbitError(f"corner curves are continued for the flow model, not for "
                         f"{type(prob).__name__}")
    q = int(event.detail.split(";")[0].split()[-1])
    p, d = prob.packed(event.lam)
    j = int(prob.pieces[q])
    L = piece_start(d, j + 1) - piece_start(d, j)
    at_end = event.X[2 * q] > 0.5 * L
    base_vals = dict(prob.values)
    base_vals[prob.param] = event.lam
    base = FlowOrbit(base_vals, prob.obstacle, param, prob.pieces.copy(), prob.m, prob.tol)
    curve = CornerCurve(base, q, at_end, prob.param)
    Xc = event.X.copy()
    Xc[2 * q] = event.lam
    lam0 = float(prob.values[param])
    Xc = newton(curve, Xc, lam0)
    # the orbit along the curve must stay one of the flow: the other impacts' corners, the
    # flights' gaps and the impact velocities end the curve (the held impact's own corner
    # distance is 0 throughout and never changes sign)
    pts, evs = continue_branch(curve, Xc, lam0, lam_range, direction, ds=ds,
                               events=ENDING, **kw)
    return (np.array([pt.lam for pt in pts]), np.array([pt.X[2 * q] for pt in pts]),
            curve, pts, evs)


def section_state(problem, X, lam, section, at=None):
    """The state (u, v) at the first section time n * section at or after the cycle's
    first impact, or at the time ``at`` (the flight from the last impact before it)."""
    p, d = problem.packed(lam)
    imp = problem.impacts(X, lam)
    D = problem.duration(lam)
    ts = at if at is not None else math.ceil(imp["t"][0] / section) * section
    t = np.append(imp["t"], imp["t"][0] + D)
    i = int(np.searchsorted(t, ts, side="right")) - 1
    i = min(max(i, 0), problem.n - 1)
    u, v, _ = problem._flight(p, d, imp["t"][i], imp["u"][i], imp["v_out"][i], ts)
    return u, v


# ------------------------------------------------------------------ a scene's continuation
FORMAT = CONTINUATION_FORMAT         # the root attribute ``format`` (``outputs``)
FORMAT_VERSION = 1
# the version of the resume state a partial file keeps (``resume/state``, JSON)
STATE_VERSION = 1


@dataclass
class Result:
    """What ``cornerbif continue`` found: the branches, their events, the corner curves."""

    scene: object
    branches: list
    curves: list = field(default_factory=list)     # (event index, param, param2 arrays)
    seeds: list = field(default_factory=list)      # the words found at the start


def _matches(word: str, seed: str) -> bool:
    """Whether a cycle word is the seed word up to rotation."""
    from .analysis import parse_word
    s = parse_word(seed, allow_x=True)
    return len(s) == len(word) and s in word + word


def _seed_file_error(scene, what):
    """The refusal of ``[continue] seed_file`` (bad input: exit 2, before any work)."""
    from .errors import SweepError
    c = scene.cont
    return SweepError(f"continue.seed_file: {c['seed_file']}: {what}; a seed file is a finished "
                      f"sweep (cornerbif sweep) of model {scene.model!r} over "
                      f"{c['parameter']!r} alone, with this scene's [system]")


def seeds_from_file(scene):
    """The runs of a sweep file (``[continue] seed_file``) at its grid value nearest the
    continuation's start: (word, run dict keyed as the model's run_items outputs) per
    distinct attractor.  The file must be a regular file, a sweep (not a continuation),
    of this model, sweeping the continued parameter alone, with this [system], done at
    that grid point, and keep what the model's seed reads (the impacts for flow, the
    section for two_particle); every other file is refused before any work (SweepError,
    exit 2), naming the key, the path and what is wrong."""
    import stat

    from .analysis import distinct_attractors
    from .errors import SweepError
    from .io import FileFormatError, check_readable
    from .outputs import is_kind, reason
    path = scene.cont["seed_file"]
    try:
        st = os.stat(path)
    except (OSError, ValueError) as e:
        raise _seed_file_error(scene, f"cannot be read ({reason(e) if isinstance(e, OSError) else e})"
                               ) from None
    if stat.S_ISDIR(st.st_mode):
        raise _seed_file_error(scene, "is a directory")
    if not stat.S_ISREG(st.st_mode):
        raise _seed_file_error(scene, "is not a regular file (a device, a pipe or a socket)")
    if is_kind(path, "continuation"):
        raise _seed_file_error(scene, "is a continuation file (cornerbif continue), not a sweep")
    try:
        f = check_readable(path)
    except FileFormatError as e:
        raise _seed_file_error(scene, str(e).removeprefix(f"{path}: ")) from None
    except OSError as e:
        raise _seed_file_error(scene, f"cannot be read ({reason(e)})") from None
    try:
        with f:
            run_all, period, words, at = _seed_runs(scene, f)
    except SweepError:
        raise
    except Exception as e:  # noqa: BLE001 - a file crafted past check_readable: say so
        from .model import cut
        raise _seed_file_error(scene, f"cannot be read as a sweep ({type(e).__name__}: "
                                      f"{cut(e)}): damaged, or not written by cornerbif"
                               ) from None
    series = ([(run_all["u"][None], "impacts"), (run_all["v_in"][None], "impacts")]
              if "u" in run_all else
              [(run_all["su"][None], "section"), (run_all["sv"][None], "section")]
              if "su" in run_all else [])
    labels, count = distinct_attractors(period[None], run_all["ipc"][None], words[None],
                                        series, 100.0 * scene.period_tol)
    found = []
    for k in range(int(count[0])):
        i = int(np.nonzero(labels[0] == k)[0][0])
        found.append((str(words[i]), {key: a[i] for key, a in run_all.items()}))
    return found, at


def _seed_runs(scene, f):
    """The runs of an open sweep file at its grid value nearest continue.start: (runs by
    the model's output names, periods, words, that grid value); SweepError where the file
    cannot seed this scene."""
    import tomllib

    from .config import sweep_items
    c = scene.cont
    name = c["parameter"]
    model = f.attrs.get("model", "")
    if model != scene.model:
        raise _seed_file_error(scene, f"is a sweep of model {model!r}, the scene's is "
                                      f"{scene.model!r}")
    theirs_doc = tomllib.loads(str(f.attrs["scene"]))
    axes = [k for k, _ in sweep_items(theirs_doc.get("sweep", {}))]
    if axes != [name] or name not in f or f[name].ndim != 1 or f["period"].ndim != 2:
        raise _seed_file_error(scene, f"sweeps {', '.join(map(repr, axes)) or 'nothing'}, "
                                      f"not {name!r} alone")
    theirs = theirs_doc.get("system", {})
    ours = {k: v for k, v in scene.system.items() if v is not None}
    if "obstacle" in scene.spec.system_extra:
        ours["obstacle"] = scene.obstacle
    for k in sorted(set(ours) | set(theirs)):
        if k != name and k != "section_period" and theirs.get(k) != ours.get(k):
            raise _seed_file_error(scene, f"was swept with system.{k} = {theirs.get(k)!r}, "
                                          f"the scene has {ours.get(k)!r}")
    x = f[name][...]
    if not np.all(np.isfinite(x)):
        raise _seed_file_error(scene, f"its {name!r} values are not all finite")
    g = int(np.argmin(np.abs(x - c["start"])))
    lo, hi = c["range"]
    if not lo <= float(x[g]) <= hi:
        raise _seed_file_error(scene, f"its grid value nearest continue.start, {name} = "
                                      f"{float(x[g])!r}, is outside continue.range {[lo, hi]}")
    if not f["done"][g]:
        raise _seed_file_error(scene, f"its grid point {name} = {float(x[g])!r} (the nearest "
                                      "continue.start) is not done: complete the sweep first "
                                      "(cornerbif sweep --resume)")
    run_all = {"ipc": f["impacts_per_cycle"][g].astype(np.int64)}
    for fld in scene.spec.fields(tuple(scene.spec.observables)):
        if fld.name in f and fld.axis is None:
            run_all[fld.source] = f[fld.name][g]
    need = scene.spec.seed_observable
    if need and not all(fld.source in run_all for fld in scene.spec.observables[need]):
        raise _seed_file_error(scene, f"does not keep {need!r}, which a {scene.model} seed "
                                      f"reads (sweep it with output.keep containing {need!r})")
    return run_all, f["period"][g], f["symbols"][g].astype(str), float(x[g])


def find_seeds(scene, control=None):
    """The distinct attractors reached from the scene's starts at the continuation's start
    (the kernel and ``analysis.distinct_attractors``): a list of (word, one run's record:
    the model's outputs of that run and "ipc", its impacts per cycle).  ``control``
    (``_jit.Control``): the kernel polls its stop flag (``engine.with_control``) and, told
    to stop, returns within milliseconds, raising ``KernelStopped``."""
    from . import engine
    from .analysis import distinct_attractors, words
    c = scene.cont
    run_scene = dataclasses.replace(scene, keep=("impacts",), stop="none",
                                    system=dict(scene.system) | {c["parameter"]: c["start"]})
    spec = scene.spec
    row = spec.pack_values(run_scene.system, run_scene)
    params = np.repeat(row[None], scene.n_ic, axis=0)
    ics = engine.draw_initial(run_scene, np.zeros(1, np.int64),
                              spec.wall_at_start(params[:1]), params[:1]).reshape(scene.n_ic, -1)
    ints = engine.with_control(run_scene, spec.int_settings(run_scene), control)
    out, _, _, period, ipc, sym = spec.run_items(params, np.ascontiguousarray(ics), ints,
                                                 run_scene)
    w = words(sym)
    series = ([(out["u"][None], "impacts"), (out["v_in"][None], "impacts")]
              if np.isfinite(out["u"]).any() else
              [(out["su"][None], "section"), (out["sv"][None], "section")])
    labels, count = distinct_attractors(period[None], ipc[None], w[None], series,
                                        100.0 * scene.period_tol)
    found = []
    for k in range(int(count[0])):
        i = int(np.nonzero(labels[0] == k)[0][0])
        found.append((str(w[i]), {key: a[i] for key, a in out.items()} | {"ipc": int(ipc[i])}))
    seeds = c["seed"] if isinstance(c["seed"], list) else [c["seed"]]
    if "all" not in seeds:
        found = [f for f in found if any(_matches(f[0], s) for s in seeds)]
    return found


# ------------------------------------------------------------------ the run, unit by unit
# A scene's continuation is a sequence of units, each written to the partial file as soon
# as it is finished: the main branch of each seed (both ways from the start), the branches
# switched to at its corner collisions (breadth first, the down way then the up way, as
# ``follow``), then each two-parameter curve.  Beside the finished units the partial file
# keeps the state to go on from (``resume/state``: the seeds, the branches still to
# continue and the events whose curves are still to continue, every number as written
# by Python, which reads back to the same bits), so --resume continues exactly what an
# uninterrupted run would have.

def _problem_doc(prob) -> dict:
    """An orbit problem as plain data (the resume state), ``_problem_from``'s inverse."""
    base = {"values": {k: v for k, v in prob.values.items()}, "param": prob.param}
    if isinstance(prob, FlowOrbit):
        return base | {"type": "flow", "obstacle": prob.obstacle,
                       "pieces": [int(j) for j in prob.pieces], "m": int(prob.m),
                       "tol": float(prob.tol)}
    if isinstance(prob, MapOrbit):
        return base | {"type": "map2d", "letters": prob.letters, "obstacle": prob.obstacle}
    if isinstance(prob, TwoParticleOrbit):
        return base | {"type": "two_particle", "kinds": prob.kinds, "m": int(prob.m)}
    raise TypeError(f"no resume state for {type(prob).__name__}")


def _problem_from(doc):
    """The orbit problem of ``_problem_doc``'s data."""
    values, param = dict(doc["values"]), str(doc["param"])
    if doc["type"] == "flow":
        return FlowOrbit(values, str(doc["obstacle"]), param,
                         np.array(doc["pieces"], np.int64), int(doc["m"]), float(doc["tol"]))
    if doc["type"] == "map2d":
        return MapOrbit(values, param, str(doc["letters"]), str(doc["obstacle"]))
    if doc["type"] == "two_particle":
        return TwoParticleOrbit(values, param, str(doc["kinds"]), int(doc["m"]))
    raise ValueError(f"unknown orbit problem {doc['type']!r}")


def _array(x):
    return np.asarray(x, float).tolist()


def _item_doc(item) -> dict:
    """A branch still to continue (``follow_step``'s (problem, X, param, tangent, origin))."""
    prob, X, lam, T0, origin = item
    return {"problem": _problem_doc(prob), "X": _array(X), "lam": float(lam),
            "T0": None if T0 is None else _array(T0), "origin": str(origin)}


def _item_from(doc):
    return (_problem_from(doc["problem"]), np.array(doc["X"], float), float(doc["lam"]),
            None if doc["T0"] is None else np.array(doc["T0"], float), str(doc["origin"]))


def _event_doc(b, e) -> dict:
    """A located corner collision or fold of branch b whose curve is still to continue."""
    return {"branch": int(b), "kind": e.kind, "lam": float(e.lam), "X": _array(e.X),
            "detail": e.detail, "problem": _problem_doc(e.problem)}


def _seed_stage(scene, log):
    """The work before the first branch: the attractors at the start (the scene's starts
    run by the kernel, or ``seed_file``'s runs), the seed words no start reached solved
    directly, each seed's orbit solved and checked admissible (a seed that cannot be is
    said and skipped).  Returns the run's state (``_units``) holding the seeds.

    It runs in a thread of its own (``local.run_interruptibly``) with the kernel under a
    stop flag (``find_seeds``), so that SIGINT and SIGTERM end it within about a second
    whatever the scene (at omega = 1e9 the starts' runs take minutes): the interrupt is
    raised here, as ``KeyboardInterrupt``, with nothing written."""
    from ._jit import Control
    from .local import run_interruptibly
    control = Control()
    state = run_interruptibly(lambda: _seeds(scene, log, control), control)
    if state is None:                   # the kernel was told to stop (``KernelStopped``)
        raise KeyboardInterrupt
    return state


def _seeds(scene, log, control):
    """``_seed_stage``'s work, the kernel under ``control``."""
    c = scene.cont
    values = {k: v for k, v in scene.system.items() if v is not None}
    start = c["start"]
    wanted = c["seed"] if isinstance(c["seed"], list) else [c["seed"]]
    if "seed_file" in c:
        found, at = seeds_from_file(scene)
        if at != start:
            log(f"seeds from {c['seed_file']} at {c['parameter']} = {at!r} (the grid value "
                f"nearest continue.start)")
            start = at
        if "all" not in wanted:
            found = [f for f in found if any(_matches(f[0], s) for s in wanted)]
    else:
        found = find_seeds(scene, control)
    values[c["parameter"]] = start
    for s in wanted:
        if s != "all" and not any(_matches(f[0], s) for f in found):
            # not an attractor from these starts: the orbit of the word itself, stable or not
            found.append((s, {"word_seed": True}))
    if not found:
        log(f"no attractor {'with word ' + repr(c['seed']) + ' ' if c['seed'] != 'all' else ''}"
            f"was found from the {scene.n_ic} starts at {c['parameter']} = {start!r}")
    seeds = []
    for word, run in found:
        try:
            if run.get("word_seed"):
                prob, X = scene.spec.word_seed(values, scene, c["parameter"], word)
            else:
                prob, X = scene.spec.orbit_seed(values, scene, c["parameter"], word, run)
            ok, why = prob.admissible(X, start)
            if not ok:
                raise OrbitError(f"its orbit is not admissible at the start ({why})")
        except (OrbitError, NotImplementedError, np.linalg.LinAlgError, ArithmeticError,
                ValueError) as e:
            log(f"seed {word!r}: {e}")
            continue
        seeds.append({"word": word, "problem": _problem_doc(prob), "X": _array(X)})
    return {"version": STATE_VERSION, "start": float(start),
            "seeds_found": [f[0] for f in found], "seeds": seeds, "seed": 0,
            "phase": "main", "queues": {"down": [], "up": []}, "counts": {"down": 0, "up": 0},
            "branches": 0, "curve_jobs": [], "curve_next": 0}


def _units(scene, state, log):
    """The continuation from ``state`` on, one finished unit at a time: yields
    ("branch", (index, Branch)) and ("curve", the curve or None where it failed both
    ways), each once ``state`` says it is done, so that the state saved with a unit goes
    on right after it.  Every problem, unknown and tangent is taken from the state's
    plain data, in a run never interrupted as in a resumed one: both compute the same
    numbers, bit for bit."""
    c = scene.cont
    rng = tuple(c["range"])
    kw = dict(ds=c["ds"], ds_min=c["ds_min"], ds_max=c["ds_max"], events=tuple(c["events"]))
    switch = c["switch"]
    start = state["start"]
    seeds = state["seeds"]
    while state["seed"] < len(seeds):
        sd = seeds[state["seed"]]
        phase = state["phase"]
        if phase == "main":
            prob, X = _problem_from(sd["problem"]), np.array(sd["X"], float)
            up, up_more = follow_step(prob, X, start, None, "start", rng, 1.0, switch,
                                      room=MAX_BRANCHES - 1, **kw)
            down, down_more = follow_step(prob, X, start, None, "start", rng, -1.0, switch,
                                          room=MAX_BRANCHES - 1, **kw)
            word = sd["word"]
            main = Branch(prob, down.points[::-1] + up.points[1:],
                          down.events[::-1] + up.events, word,
                          f"the attractor {word!r} at {c['parameter']} = {start!r}",
                          stops=[down.events[-1], up.events[-1]])
            state["queues"] = {"down": [_item_doc(m) for m in down_more],
                               "up": [_item_doc(m) for m in up_more]}
            state["counts"] = {"down": 1, "up": 1}
            state["phase"] = "down"
            yield "branch", _branch_done(scene, state, main)
            continue
        queue = state["queues"][phase]
        if queue and state["counts"][phase] < MAX_BRANCHES:
            item = _item_from(queue.pop(0))
            state["counts"][phase] += 1
            br, more = follow_step(*item, rng, -1.0 if phase == "down" else 1.0, switch,
                                   room=MAX_BRANCHES - state["counts"][phase] - len(queue),
                                   **kw)
            queue += [_item_doc(m) for m in more]
            yield "branch", _branch_done(scene, state, br)
            continue
        if phase == "down":
            state["phase"] = "up"
        else:
            state.update(seed=state["seed"] + 1, phase="main",
                         queues={"down": [], "up": []}, counts={"down": 0, "up": 0})
    state["phase"] = "curves"
    while state["curve_next"] < len(state["curve_jobs"]):
        curve = _curve(scene, state["curve_jobs"][state["curve_next"]], log)
        state["curve_next"] += 1
        yield "curve", curve
    state["phase"] = "done"


def _branch_done(scene, state, br):
    """Number a finished branch and queue the curves of its corner collisions and folds
    (``[continue] curve``): (index, branch)."""
    b = state["branches"]
    state["branches"] += 1
    if "curve" in scene.cont:
        state["curve_jobs"] += [_event_doc(b, e) for e in br.events
                                if e.kind in ("corner", "fold")]
    return b, br


def _curve(scene, job, log):
    """A located corner collision or fold (``_event_doc``) continued both ways in the
    second parameter: (branch, param, what, param2 values, param values, kind, ends), or
    None where it failed both ways (said in the log)."""
    c = scene.cont
    e = Event(job["kind"], float(job["lam"]), np.array(job["X"], float), job["detail"],
              _problem_from(job["problem"]))
    b = job["branch"]
    follow_curve = corner_curve if e.kind == "corner" else fold_curve
    what = e.detail.split(";")[0] if e.kind == "corner" else "fold"
    parts, ends = [], []
    for direction in (1.0, -1.0):
        try:
            x2, x1, _, _, evs = follow_curve(
                e, c["curve"], tuple(c["curve_range"]), direction,
                ds=abs(c["curve_range"][1] - c["curve_range"][0]) / 100.0)
            parts.append((x2, x1))
            ends += [f"{v.kind} at {c['curve']} = {v.lam:.10g}"
                     + (f" ({v.detail})" if v.detail else "") for v in evs]
        except (OrbitError, np.linalg.LinAlgError, ArithmeticError, ValueError) as err:
            ends.append(f"failed: {err}")
            log(f"{e.kind} curve of branch {b} at {e.lam!r}: {err}")
    if not parts:
        return None
    x2 = np.concatenate([p[0][::-1] for p in parts[1:]] + [parts[0][0]])
    x1 = np.concatenate([p[1][::-1] for p in parts[1:]] + [parts[0][1]])
    return (b, e.lam, what, x2, x1, e.kind, "; ".join(ends))


def _curve_line(curve, scene) -> str:
    """What the console says of a finished curve."""
    b, _, what, x2, _, kind, ends = curve
    return (f"{kind} curve of branch {b} ({what}): {len(x2)} points over "
            f"{scene.cont['curve']} in [{x2.min():.6g}, {x2.max():.6g}]; ends: {ends}")


def stop_reason(e, param, switch=True) -> str:
    """Why a branch stopped at ``e``, its last event one way, in words: the range's end,
    the step budget, the step below ds_min, a failed step, a corner collision (continued
    across it, or why not), a grazing, a zero-velocity impact, or where its orbit stops
    being admissible."""
    if e.kind == "end":
        why = e.detail
    elif e.kind == "corner":
        why = f"a corner collision of {e.detail}"
        if not switch:
            why += "; not continued across it (continue.switch = false)"
    elif e.kind in ENDING_WORDS:
        why = ENDING_WORDS[e.kind] + ": the orbit of this itinerary ends there"
    else:
        why = e.kind
    return f"{param} = {e.lam:.12g}: {why}"


def _branch_lines(b, br, scene) -> str:
    """What the console says of a finished branch: its word, range, points, events, and
    why each of its ends stopped."""
    c = scene.cont
    p = c["parameter"]
    lams = [pt.lam for pt in br.points]
    stable = sum(bool(np.all(np.abs(pt.mu) < 1.0)) for pt in br.points)
    ends = br.ends()
    inner = [e for e in br.events if not any(e is s for s in ends)]
    lines = [f"branch {b}: {br.word or '?'} over {p} in [{min(lams):.10g}, {max(lams):.10g}], "
             f"{len(br.points)} points ({stable} stable); events: "
             + (", ".join(f"{e.kind} at {e.lam:.12g}" for e in inner) or "none")]
    lines += [f"  stopped at {stop_reason(e, p, c['switch'])}" for e in ends]
    return "\n".join(lines)


# ------------------------------------------------------------------ the file
def _branch_record(br, scene) -> dict:
    """What the file keeps of a branch (docs/continuation.md, "The file"): its datasets,
    its attributes and its events' rows."""
    c = scene.cont
    section = scene.section_period
    pts = br.points
    mu = np.array([pt.mu for pt in pts])
    rows = [pt.problem.store(pt.X, pt.lam, section) for pt in pts]
    data = {"param": np.array([pt.lam for pt in pts])}
    for key in rows[0]:
        data[key] = np.array([r_[key] for r_ in rows])
    data["multiplier_re"] = mu.real
    data["multiplier_im"] = mu.imag
    with np.errstate(invalid="ignore"):
        data["stable"] = (np.abs(mu).max(axis=1) < 1.0).astype(np.uint8)
    data["admissible"] = np.array([pt.admissible for pt in pts], np.uint8)
    data["admissibility_margin"] = np.array([pt.margin for pt in pts], float)
    attrs = dict(word=br.word, origin=br.origin, points_per_cycle=pts[0].problem.n,
                 itinerary=pts[0].problem.itinerary(),
                 stops=[stop_reason(e, c["parameter"], c["switch"]) for e in br.ends()])
    events = []
    for e in br.events:
        got = e.problem.store(e.X, e.lam, section)
        # each event's state, as the branch stores it (the smallest over the cycle's
        # impacts where there are several)
        events.append((e.kind, float(e.lam), e.detail,
                       {k: float(np.min(v)) for k, v in got.items()}))
    return {"data": data, "attrs": attrs, "events": events}


def _curve_record(curve, scene) -> dict:
    c = scene.cont
    b, lam, what, x2, x1, kind, ends = curve
    return {"param": x2, "event_param": x1,
            "attrs": dict(kind=kind, branch=b, at=lam, what=what, param_name=c["curve"],
                          event_param_name=c["parameter"], ends=ends)}


def _image(scene, head, branches, curves, state=None) -> bytes:
    """The continuation file, whole, as bytes (HDF5 in memory: a failed write of them to
    disk is an OSError of Python's, never a broken HDF5 state): the finished file, or with
    ``state`` a partial one that --resume goes on from.  ``head``: the root attributes
    ``created``, ``seeds``, ``command`` (the command line that made it; optional) and, when
    finished, ``completed``."""
    import json

    import h5py

    from . import __version__
    c = scene.cont
    with h5py.File("continuation.h5", "w", driver="core", backing_store=False) as f:
        f.attrs.update(format=FORMAT, format_version=FORMAT_VERSION, scene=scene.text,
                       model=scene.model, obstacle=scene.obstacle, parameter=c["parameter"],
                       cornerbif_version=__version__, created=head["created"],
                       seeds=head["seeds"], command=head.get("command", ""))
        for b, rec in enumerate(branches):
            g = f.create_group(f"branches/{b:03d}")
            for key, v in rec["data"].items():
                g[key] = v
            g["param"].attrs["name"] = c["parameter"]
            g.attrs.update(rec["attrs"])
        rows = [(b, *e) for b, rec in enumerate(branches) for e in rec["events"]]
        ev = f.create_group("events")
        ev["branch"] = np.array([r[0] for r in rows], np.int32)
        ev["kind"] = np.array([r[1] for r in rows], dtype=h5py.string_dtype())
        ev["param"] = np.array([r[2] for r in rows], float)
        ev["detail"] = np.array([r[3] for r in rows], dtype=h5py.string_dtype())
        for key in sorted({k for r in rows for k in r[4]}):
            ev[key] = np.array([r[4].get(key, math.nan) for r in rows], float)
        for k, rec in enumerate(curves):
            g = f.create_group(f"curves/{k:03d}")
            g["param"] = rec["param"]
            g["param"].attrs["name"] = c["curve"]
            g["event_param"] = rec["event_param"]
            g["event_param"].attrs["name"] = c["parameter"]
            g.attrs.update(rec["attrs"])
        if state is None:
            f.attrs["completed"] = head["completed"]
        else:
            f["resume/state"] = json.dumps(state)
        f.flush()
        return f.id.get_file_image()


def _load(path):
    """A continuation file (finished or partial) as its records: (root attributes,
    branches, curves, resume state or None), each record as ``_branch_record`` and
    ``_curve_record`` make it (the numbers read back bit for bit)."""
    import json

    import h5py
    with h5py.File(path, "r", locking=False) as f:
        attrs = {k: _plain(v) for k, v in f.attrs.items()}
        names = sorted(f["branches"]) if "branches" in f else []
        ev = f["events"]
        extra = [k for k in ev if k not in ("branch", "kind", "param", "detail")]
        cols = {k: ev[k][...] for k in ev}
        events = [[] for _ in names]
        for i in range(cols["param"].shape[0]):
            events[int(cols["branch"][i])].append(
                (_plain(cols["kind"][i]), float(cols["param"][i]), _plain(cols["detail"][i]),
                 {k: float(cols[k][i]) for k in extra}))
        branches = []
        for name, evs in zip(names, events):
            g = f["branches"][name]
            branches.append({"data": {k: g[k][...] for k in g},
                             "attrs": {k: _plain(v) for k, v in g.attrs.items()},
                             "events": evs})
        curves = []
        for name in sorted(f["curves"]) if "curves" in f else []:
            g = f["curves"][name]
            curves.append({"param": g["param"][...], "event_param": g["event_param"][...],
                           "attrs": {k: _plain(v) for k, v in g.attrs.items()}})
        state = json.loads(_plain(f["resume/state"][()])) if "resume/state" in f else None
    return attrs, branches, curves, state


def _plain(v):
    """An HDF5 value as Python: bytes as str, arrays of strings as lists of str."""
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.ndarray) and v.dtype.kind in "OSU":
        return [_plain(x) for x in v.tolist()]
    return v


def _write_bytes(path, image, kept):
    """Write ``image`` to ``path`` whole or not at all (``outputs.replacing``: a temporary
    name, flushed to disk, renamed), with SIGINT and SIGTERM deferred until it is done; a
    full disk or a file-size limit is ``WriteFailed`` naming the file and what is ``kept``."""
    from . import outputs
    with outputs.signals_deferred():
        with outputs.replacing(path, kept) as tmp:
            with open(tmp, "wb") as fh:
                fh.write(image)
                fh.flush()
                os.fsync(fh.fileno())


def write(res, path):
    """The continuation file of a ``Result`` (HDF5, docs/continuation.md): one group per
    branch, the events table, the curves; written whole or not at all."""
    now = time.strftime("%Y-%m-%dT%H:%M:%S")
    head = {"created": now, "completed": now, "seeds": ", ".join(res.seeds)}
    _write_bytes(str(path), _image(res.scene, head,
                                   [_branch_record(b, res.scene) for b in res.branches],
                                   [_curve_record(cv, res.scene) for cv in res.curves]),
                 "the previous file, if any, is unchanged")
    return path


def read(path):
    """A continuation file (finished, or the partial file of an interrupted run) as plain
    Python: {"parameter", "scene", "attrs", "branches": [dict], "events": [dict],
    "curves": [dict]}; ValueError for a file that is not one."""
    try:
        attrs, branches, curves, _ = _load(path)
    except (OSError, KeyError, ValueError, IndexError, TypeError) as e:
        raise ValueError(f"{path}: not a readable cornerbif continuation file ({e})") from None
    if attrs.get("format") != FORMAT:
        raise ValueError(f"{path}: not a cornerbif continuation file")
    out = {"parameter": str(attrs["parameter"]), "scene": str(attrs["scene"]),
           "attrs": attrs, "branches": [], "events": [], "curves": []}
    for b, rec in enumerate(branches):
        out["branches"].append(dict(rec["data"]) | rec["attrs"])
        for kind, lam, detail, extra in rec["events"]:
            out["events"].append({"branch": b, "kind": kind, "param": lam, "detail": detail}
                                 | extra)
    for rec in curves:
        out["curves"].append({"param": rec["param"], "event_param": rec["event_param"]}
                             | rec["attrs"])
    return out


# ------------------------------------------------------------------ the command
def run_scene(scene, log=print):
    """Seed, continue both ways, switch at corners, continue located corner collisions in
    the second parameter: the ``Result`` of a scene's ``[continue]``, in memory
    (``run_to_file`` writes it as it goes)."""
    state = _seed_stage(scene, log)
    res = Result(scene, [], seeds=list(state["seeds_found"]))
    for kind, unit in _units(scene, state, log):
        if kind == "branch":
            res.branches.append(unit[1])
            log(_branch_lines(*unit, scene))
        elif unit is not None:
            res.curves.append(unit)
            log(_curve_line(unit, scene))
    return res


def run_to_file(scene, out_path, *, resume=False, overwrite=False, log=print, inputs=(),
                command="") -> str | None:
    """Run a scene's ``[continue]`` to ``out_path``, writing each branch and each curve to
    ``out_path.partial`` as soon as it is finished; return ``out_path``, or None when
    ``resume`` finds it already finished from this scene (``[plot]`` aside; ``log`` is
    told so).

    Before any work: no file written beside the output (its partial file, its lock, their
    temporaries) may be one of ``inputs`` or ``continue.seed_file``; the output's lock
    ``out_path.lock`` is taken (``outputs.output_lock``: another command writing it is
    refused); then ``plan_output`` decides, as ``cornerbif sweep`` does, whether there is
    nothing to do, a partial file to resume or a run to start, and refuses what it must.
    Each unit rewrites the partial file whole through ``outputs.replacing`` (a new HDF5
    file under a temporary name, renamed): every state on disk is a complete, readable
    file, even after SIGKILL.  ``resume`` goes on from the partial file of the same scene
    and completes the file bit for bit as an uninterrupted run (every dataset; the times
    aside).  ``command``: the command line, kept in the file (root attribute ``command``,
    as a sweep's); a resumed file keeps the one it was started with.

    Interrupted (SIGINT, SIGTERM; within about a second while the seeds are found too):
    ``SweepInterrupted`` saying what was kept where.  A full disk or a file-size limit:
    ``WriteFailed``, the same.  Bad input: ``SweepError``.
    """
    from . import outputs
    from .errors import SweepError
    out_path = str(out_path)
    log = _quiet_on_closed(log)
    if not scene.cont:
        raise SweepError(f"scene {scene.name!r} has no [continue] table (parameter, range, "
                         "...: docs/continuation.md)")
    _inputs(scene, out_path, inputs)       # before the lock: its file is never an input
    with outputs.output_lock(out_path):
        plan = plan_output(scene, out_path, resume, overwrite, inputs, locked=True)
        if plan == "done":
            partial = out_path + ".partial"
            left = _partial_state(partial, scene)[0] == "ours"
            if left:
                os.remove(partial)          # this scene's too: the output holds all of it
            log(f"{out_path} is already complete (finished {_finished(out_path)[1]} from this "
                "scene); nothing to do" + (f" (removed {partial}, an interrupted run of the "
                                           "same scene)" if left else ""))
            return None
        return _run_locked(scene, out_path, plan, log, command)


def plan_output(scene, out_path, resume, overwrite, inputs=(), locked=False) -> str:
    """What ``cornerbif continue`` will do with its output, decided before any work (and
    before anything is said), as ``sweep.plan_output`` decides a sweep's: "done"
    (``resume`` of an output finished from this scene, ``[plot]`` aside: nothing to do, so
    that a script may always pass --resume), "resume" (the partial file of this scene to
    complete; with ``overwrite`` also where it waits behind another scene's finished
    output, which it then replaces) or "start".  ``SweepError`` for what it must refuse:
    the output or a file beside it being an input, an existing output without
    ``overwrite`` or not a continuation file, an output another command is writing (unless
    ``locked``: this process holds the lock), a partial file that is not a continuation's
    (never removed), and another scene's or a damaged partial file without ``overwrite``
    (never removed by --resume, which completes only this scene's)."""
    from . import outputs
    from .config import same_run, scene_difference
    from .errors import SweepError
    named = _inputs(scene, out_path, inputs)
    if not locked:
        outputs.check_unlocked(out_path)
    partial = out_path + ".partial"
    what, got = _partial_state(partial, scene)
    if what == "foreign":
        raise SweepError(f"{partial}: is in the way ({got}); remove it yourself, or name "
                         "another output")
    tmp = outputs.temporary_name(partial)
    if os.path.lexists(tmp) and (os.path.islink(tmp) or not os.path.isfile(tmp)):
        raise SweepError(f"{tmp}: is in the way of the partial file's rewrites (a link, a "
                         "directory or a device); remove it yourself, or name another output")
    if resume and not overwrite and os.path.lexists(out_path):
        outputs.check_output(out_path, True, named, kind="continuation")
        text, completed = _finished(out_path)
        if completed and same_run(text, scene.text):
            return "done"
        whose = ("is a finished continuation of another scene" if completed else
                 "exists and is not a finished continuation (it cannot be read, or was never "
                 "completed)")
        if what == "ours":
            raise SweepError(f"{out_path} {whose} and {partial} holds an interrupted "
                             "continuation of this scene: pass --resume --overwrite to complete "
                             f"it (it then replaces {out_path}), or name another output")
        diff = f" ({scene_difference(text, scene.text)})" if completed else ""
        raise SweepError(f"{out_path} {whose}{diff}; --resume completes only this scene's "
                         "continuation: pass --overwrite to replace it, or name another output")
    outputs.check_output(out_path, overwrite, named, kind="continuation")
    if what in ("none", "empty"):
        return "start"
    if what == "ours" and resume:
        return "resume"
    if overwrite and not resume:
        return "start"
    if what == "ours":
        _, branches, curves, _ = got
        raise SweepError(f"{partial} holds an interrupted continuation of this scene: "
                         f"{_kept(partial, (len(branches), len(curves)))}; pass --resume to "
                         "complete it, or --overwrite to start again")
    again = "--overwrite (without --resume)" if resume else "--overwrite"
    if what == "other":
        raise SweepError(f"{partial} holds an interrupted continuation of another scene ({got}); "
                         "--resume completes only the same scene's ([plot] aside): run it with "
                         f"that scene, or pass {again} to start again")
    raise SweepError(f"{partial} cannot be resumed ({got}); pass {again} to start again")


def _inputs(scene, out_path, inputs) -> list:
    """The command's inputs named (``outputs._named``; ``continue.seed_file`` too), once the
    output's folder and name are checked (``outputs.check_directory``,
    ``check_name_length``) and no file written beside the output (its partial file, its
    lock, their temporaries) is one of them."""
    from . import outputs
    from .errors import SweepError
    outputs.check_name_length(out_path, outputs.check_directory(out_path))
    named = list(outputs._named(inputs))
    if "seed_file" in scene.cont:
        named.append(("continue.seed_file", scene.cont["seed_file"]))
    partial = out_path + ".partial"
    for side in (partial, out_path + ".lock", outputs.temporary_name(partial)):
        for what, p in named:
            if outputs.same_file(side, p):
                raise SweepError(f"-o {out_path}: {side}, which this command writes beside "
                                 f"it, is {what}; name another output")
    return named


def _quiet_on_closed(log):
    """``log`` that falls silent once its stream is closed (a console piped to ``head``):
    what cannot be shown never stops the work, nor loses it."""
    closed = []

    def say(msg):
        if not closed:
            try:
                log(msg)
            except OSError:
                closed.append(True)
    return say


def _finished(path) -> tuple:
    """(scene text, completion time) of an existing continuation file; the time is '' when
    it was never completed or cannot be read."""
    import h5py
    try:
        with h5py.File(path, "r", locking=False) as f:
            return (str(_plain(f.attrs.get("scene", ""))),
                    str(_plain(f.attrs.get("completed", ""))))
    except Exception:  # noqa: BLE001 - damaged or crafted: not a finished file
        return "", ""


def _partial_state(partial, scene):
    """What the partial file beside an output holds: ("none"), ("empty"), ("foreign", why:
    not a regular file, or not a continuation's), ("damaged", why), ("other", what differs)
    or ("ours", records) where records are ``_load``'s (attrs, branches, curves, state)."""
    from . import outputs
    from .config import scene_difference
    if not os.path.lexists(partial):
        return "none", None
    kind = "a symbolic link" if os.path.islink(partial) else outputs.not_a_regular_file(partial)
    if kind:
        return "foreign", f"it is {kind}"
    if os.path.getsize(partial) == 0:
        return "empty", None
    if outputs.hdf5_format(partial) != FORMAT:
        return "foreign", "it is not a cornerbif continuation's partial file"
    try:
        loaded = _load(partial)
        attrs, branches, curves, state = loaded
        diff = scene_difference(attrs.get("scene", ""), scene.text)
        if diff:
            return "other", diff
        if state is None and not attrs.get("completed"):
            raise ValueError("it holds no resume state")
        if state is not None and (state.get("version") != STATE_VERSION
                                  or state["branches"] != len(branches)):
            raise ValueError("its resume state does not match its branches")
    except Exception as e:  # noqa: BLE001 - crafted or damaged: said, never a traceback
        from .model import cut
        return "damaged", f"{type(e).__name__}: {cut(e)}"
    return "ours", loaded


def _finished_units(done) -> str:
    """'2 finished branches and 1 curve' of ``done`` = (branches, curves)."""
    nb, nc = done
    return (f"{nb} finished branch{'es' if nb != 1 else ''}"
            + (f" and {nc} curve{'s' if nc != 1 else ''}" if nc else ""))


def _kept(partial, done) -> str:
    """What is on disk, for a message: ``done`` = (branches, curves) in the partial file,
    or None when there is none."""
    if done is None:
        return "nothing was kept (no branch had finished)"
    one = done[0] == 1 and not done[1]
    return f"the {_finished_units(done)} {'is' if one else 'are'} kept in {partial}"


def _run_locked(scene, out_path, plan, log, command):
    """``run_to_file`` once the output is locked and ``plan_output`` said "resume" or
    "start": the partial file resumed (``_resumed``) or started afresh (``_started``), its
    units written (``_write_units``), the file renamed to ``out_path``."""
    from . import outputs
    partial = out_path + ".partial"
    tmp = outputs.temporary_name(partial)
    if os.path.isfile(tmp) and not os.path.islink(tmp):
        os.remove(tmp)              # a partial file's rewrite cut by a kill: never whole
    if plan == "resume":
        head, branches, curves, state = _resumed(scene, partial, log)
        done = (len(branches), len(curves))
    else:
        if os.path.lexists(partial):
            os.remove(partial)      # plan_output: empty, or to start again (--overwrite)
        state = _started(scene, log)
        head = {"created": time.strftime("%Y-%m-%dT%H:%M:%S"),
                "seeds": ", ".join(state["seeds_found"]), "command": command}
        branches, curves, done = [], [], None
    if state is not None:
        done = _write_units(scene, partial, head, branches, curves, state, done, log)
    _rename(partial, out_path, done)
    nev = sum(len(b["events"]) for b in branches)
    log(f"wrote {out_path}: {len(branches)} branches, {nev} events, {len(curves)} curves")
    return out_path


def _resumed(scene, partial, log):
    """The partial file of this scene as ``_write_units`` goes on from it: (head, branches,
    curves, state); state None when it is finished (killed before its rename)."""
    attrs, branches, curves, state = _partial_state(partial, scene)[1]
    head = {"created": attrs.get("created", ""), "seeds": attrs.get("seeds", ""),
            "command": attrs.get("command", "")}
    if state is None:
        log(f"{partial} is complete; finishing it")
    else:
        log(f"resuming {partial}: {_finished_units((len(branches), len(curves)))} before")
    return head, branches, curves, state


def _started(scene, log):
    """The state of a new run: its seeds (``_seed_stage``), said; an interrupt meanwhile is
    ``SweepInterrupted`` (nothing is written yet), no seed at all a ``Fault``."""
    from .errors import Fault, SweepInterrupted
    try:
        state = _seed_stage(scene, log)
    except KeyboardInterrupt:
        raise SweepInterrupted("interrupted while the seeds were found; nothing was kept; "
                               "run the same command again") from None
    if not state["seeds"]:
        raise Fault("no branch to continue (see above): nothing written")
    c = scene.cont
    log(f"continuing {len(state['seeds'])} seed(s) in {c['parameter']} over "
        f"{c['range']} from {state['start']!r}: "
        + ", ".join(repr(s["word"]) for s in state["seeds"]))
    return state


def _write_units(scene, partial, head, branches, curves, state, done, log):
    """Continue from ``state``, rewriting the partial file whole after each finished unit
    (the unit and the state after it, in one file) and, at the end, as a finished file;
    return ``done`` = (branches, curves) on disk.  An interrupt waits for a write under
    way and is ``SweepInterrupted`` saying what is kept; a failed write is ``WriteFailed``
    (``outputs.replacing``), an exhausted memory a ``Fault``, the same."""
    from . import outputs
    from .errors import Fault, SweepError, SweepInterrupted
    again = "run the same command with --resume to complete it"
    room = "free space (or raise the file-size limit) and " + again
    try:
        for kind, unit in _units(scene, state, log):
            if kind == "branch":
                branches.append(_branch_record(unit[1], scene))
                line = _branch_lines(*unit, scene)
            else:
                line = None if unit is None else _curve_line(unit, scene)
                if unit is not None:
                    curves.append(_curve_record(unit, scene))
            with outputs.signals_deferred():    # what is said kept is what is on disk
                _write_bytes(partial, _image(scene, head, branches, curves, state),
                             f"{_kept(partial, done)}; {room}")
                done = (len(branches), len(curves))
            if line:
                log(line)               # said once it is on disk
        head["completed"] = time.strftime("%Y-%m-%dT%H:%M:%S")
        _write_bytes(partial, _image(scene, head, branches, curves),
                     f"{_kept(partial, done)}; {room}")
    except KeyboardInterrupt:
        raise SweepInterrupted(f"interrupted; {_kept(partial, done)}; "
                               + (again if done else "run the same command again")) from None
    except MemoryError:
        raise Fault(f"out of memory while continuing; {_kept(partial, done)}") from None
    except SweepError:
        raise
    except Exception:
        log(f"stopped by an unexpected error; {_kept(partial, done)}")
        raise                       # a bug: ``cli.Commands`` says so, in its one message
    return done


def _rename(partial, out_path, done):
    """The finished partial file becomes ``out_path`` (one atomic rename, signals deferred:
    an interrupt raised once it is done finds the output whole, and the run ends as done)."""
    from . import outputs
    from .errors import WriteFailed
    try:
        with outputs.signals_deferred():
            os.replace(partial, out_path)
    except KeyboardInterrupt:
        outputs.note_late_interrupt()   # the rename was done: nothing is left to keep
    except OSError as e:
        raise WriteFailed(f"renaming {partial} to {out_path} failed ({outputs.reason(e)}); "
                          f"{_kept(partial, done)}; run the same command with --resume to "
                          "finish it") from None
