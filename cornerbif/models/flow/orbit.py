"""The periodic-orbit problem of the ``flow`` model (docs/continuation.md).

A periodic orbit is a closed chain of impacts: impact i lies on the obstacle's piece j_i at
local time tau_i and leaves it with velocity v_i (law 5); the exact free flight (eq 4) from it
meets the obstacle at impact i + 1; the chain closes after m obstacle periods.  The unknowns
X = (tau_0, v_0, tau_1, v_1, ...) solve 2N equations

    u_f(t_(i+1)) - z(t_(i+1)) = 0,   v_(i+1) - (1 + r) z'(t_(i+1)) + r v_f(t_(i+1)) = 0,

(x_f the flight from impact i), whose Jacobian is written in closed form
(``FlowOrbit.jacobian``): the flight matrix of ``numerics.saltation.flight_matrix`` and the
vector field at both ends.  The itinerary (the pieces j_i) fixes on which side of each corner
every impact lies, so an orbit can be followed up to the parameter where one of its impacts
reaches a corner (tau_i -> 0 or L), and past it on the side where the orbit of the new
itinerary exists (``across_corner``).  Seeds: from a run's record (``seed_from_run``) or from
a word (``seed_from_word``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from types import SimpleNamespace

import numpy as np

from ...continuation import GAP_SAMPLES, OrbitError, admissible, cached, central_d_param, newton
from ...numerics.oscillator import acceleration, derive, particular
from ...numerics.saltation import flight_matrix, impact_saltation
from ...obstacles.dispatch import corner_of, cycle_np, piece_at, piece_start, z_state
from ...stability import multipliers
from . import packed as P
from .params import OBSTACLES


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
    tables: dict = field(default_factory=dict)   # the kind's own [system] tables (a cam's)
    _cache: dict = field(default_factory=dict, repr=False)

    def table(self):
        """What the obstacle kind reads from its own tables (``Obstacle.read_tables``: a cam's
        ``Profile``), None for a kind without tables."""
        def build():
            w = SimpleNamespace(problems=[], obstacle_table=None, obstacle_tables={})
            OBSTACLES[self.obstacle].read_tables(self.tables, w)
            if w.problems:
                raise OrbitError("; ".join(w.problems))
            return w.obstacle_table
        return cached(self._cache, "table", build) if self.tables else None

    def cycle_pieces(self, lam) -> int:
        """Pieces of one cycle of the derived constants (2, or a cam's pieces per period):
        ``m`` counts these cycles."""
        return cycle_np(self.packed(lam)[1])

    def corner_at_start(self, j, lam) -> bool:
        """Whether piece j starts at a corner (a joint where the slope jumps); a joint that
        is no corner is crossed by ``reindex``, as the smooth wall's piece ends are."""
        return OBSTACLES[self.obstacle].corner_at_start(self.packed(lam)[0], j)

    @property
    def n(self) -> int:
        return len(self.pieces)


    def piece_length(self, q, lam) -> float:
        """The length L of the obstacle piece impact q lies on (its local time runs 0..L)."""
        _, d = self.packed(lam)
        j = int(self.pieces[q])
        return piece_start(d, j + 1) - piece_start(d, j)

    def rebased(self, values, param):
        """This itinerary's problem at other ``values``, continued in ``param``."""
        return dataclasses.replace(self, values=values, param=param, pieces=self.pieces.copy(),
                                   _cache={})

    def with_pieces(self, pieces):
        """The problem of another itinerary of the same system, sharing the packed rows."""
        new = dataclasses.replace(self, pieces=pieces)
        new._cache = self._cache
        return new

    def to_doc(self) -> dict:
        """The problem as plain data (a partial file's resume state), ``from_doc``'s inverse."""
        doc = {"values": dict(self.values), "param": self.param, "type": "flow",
               "obstacle": self.obstacle, "pieces": [int(j) for j in self.pieces],
               "m": int(self.m), "tol": float(self.tol)}
        if self.tables:
            doc["tables"] = self.tables
        return doc

    @classmethod
    def from_doc(cls, doc):
        return cls(dict(doc["values"]), str(doc["obstacle"]), str(doc["param"]),
                   np.array(doc["pieces"], np.int64), int(doc["m"]), float(doc["tol"]),
                   dict(doc.get("tables", {})))

    def packed(self, lam):
        """(p, d): the packed parameter row at param = lam and its derived constants."""
        def build():
            vals = dict(self.values)
            vals[self.param] = float(lam)
            p = P.pack(vals, self.obstacle, self.tol, 1e-6, 1e6, None, 0.0, self.table())
            return p, derive(p)
        return cached(self._cache, float(lam), build)

    def duration(self, lam) -> float:
        p, d = self.packed(lam)
        return self.m * (piece_start(d, cycle_np(d)) - piece_start(d, 0))

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
        out = np.full(self.n, np.inf)    # a joint that is no corner: reindex() crosses it
        for i, j in enumerate(self.pieces):
            L = piece_start(d, int(j) + 1) - piece_start(d, int(j))
            tau = X[2 * i]
            start, end = self.corner_at_start(int(j), lam), self.corner_at_start(int(j) + 1, lam)
            if start and (tau < 0.5 * L or not end):
                out[i] = tau
            elif end:
                out[i] = L - tau
        return out

    def reindex(self, X, lam):
        """On an obstacle without corners (``sine``), an impact that left its piece is put
        on the piece it now lies on (a piece end there is bookkeeping, not a corner):
        (problem, X), a new problem where a piece changed."""
        p, d = self.packed(lam)
        X = X.copy()
        pieces = self.pieces.copy()
        for i in range(self.n):
            j = int(pieces[i])
            while X[2 * i] < 0.0 and not self.corner_at_start(j, lam):
                X[2 * i] += piece_start(d, j) - piece_start(d, j - 1)
                j -= 1
            while (X[2 * i] >= piece_start(d, j + 1) - piece_start(d, j)
                   and not self.corner_at_start(j + 1, lam)):
                X[2 * i] -= piece_start(d, j + 1) - piece_start(d, j)
                j += 1
            pieces[i] = j
        if np.array_equal(pieces, self.pieces):
            return self, X
        return self.with_pieces(pieces), X

    def smallest_gap(self, X, lam):
        """The smallest gap u - z over the interior of every flight (sampled, then refined
        by a parabola through the smallest sample): negative where the flight crosses the
        obstacle (an impact the itinerary does not have), zero at a grazing."""
        p, d = self.packed(lam)
        imp = self.impacts(X, lam)
        D = self.duration(lam)
        best = min((g for g, _ in self._flight_minima(p, d, imp, D)), default=math.inf)
        return min(best, self._missed_crossings(p, d, imp, D))

    def _flight_minima(self, p, d, imp, D):
        """Per flight, (its smallest sampled gap, refined by a parabola, and its time)."""
        from .kernel import flight_gaps  # start-up: loads numba
        out = []
        s = np.linspace(0.0, 1.0, GAP_SAMPLES + 2)[1:-1]
        g = np.empty(GAP_SAMPLES)
        for i in range(self.n):
            n = (i + 1) % self.n
            t0 = imp["t"][i]
            t1 = imp["t"][n] + (D if n == 0 else 0.0)
            flight_gaps(p, d, t0, imp["u"][i], imp["v_out"][i], t0 + s * (t1 - t0), g)
            q = int(np.argmin(g))
            gq, xq = g[q], s[q]
            if 0 < q < len(s) - 1:
                a, b, c = g[q - 1], g[q], g[q + 1]
                den = a - 2 * b + c
                if den > 0:
                    x = s[q] + 0.5 * (a - c) / den * (s[1] - s[0])
                    gx = self._gap(p, d, t0, imp["u"][i], imp["v_out"][i], t0 + x * (t1 - t0))
                    if gx < gq:
                        gq, xq = gx, x
            out.append((gq, t0 + xq * (t1 - t0)))
        return out

    def across_grazing(self, X, lam):
        """The itinerary with one impact more, where a flight touches the obstacle (a located
        grazing): the new impact at the flight's smallest gap, on the piece there, leaving
        with the flight's velocity (w = 0 there, so law 5 leaves it unchanged): (problem,
        X, the new impact's index), the orbit itself at the grazing, seen as the new
        itinerary's."""
        p, d = self.packed(lam)
        imp = self.impacts(X, lam)
        D = self.duration(lam)
        minima = self._flight_minima(p, d, imp, D)
        i = int(np.argmin([g for g, _ in minima]))
        tg = minima[i][1]
        j, tau = piece_at(d, tg)
        _, v, _ = self._flight(p, d, imp["t"][i], imp["u"][i], imp["v_out"][i], tg)
        pieces = np.insert(self.pieces, i + 1, int(j))
        Xn = np.insert(X, 2 * (i + 1), [tau, v])
        return self.with_pieces(pieces), Xn, i + 1

    def _missed_crossings(self, p, d, imp, D):
        """The samples' guard: from just after each impact the kernel's certified event
        search (``kernel.first_impact_times``) must meet the obstacle first at the next
        impact.  Where it meets it earlier, the flight crosses the obstacle between two
        samples: the smallest gap after that meeting (dense samples up to the next impact,
        negative) is returned, so that no crossing goes unseen; +inf where none."""
        from .kernel import first_impact_times  # start-up: loads numba
        N = self.n
        starts, ends = [], []
        for i in range(N):
            n = (i + 1) % N
            t0, t1 = imp["t"][i], imp["t"][n] + (D if n == 0 else 0.0)
            for frac in (1e-6, 1e-4, 1e-2):     # the first start clear of the obstacle
                ts = t0 + frac * (t1 - t0)
                g = self._gap(p, d, t0, imp["u"][i], imp["v_out"][i], ts)
                if g > 0.0:
                    u, v, _ = self._flight(p, d, t0, imp["u"][i], imp["v_out"][i], ts)
                    starts.append((u, v, ts))
                    ends.append((i, t0, t1))
                    break
        if not starts:
            return math.inf
        met = first_impact_times(np.repeat(p[None], len(starts), axis=0), np.array(starts),
                                 self.m * cycle_np(d) + 8)
        worst = math.inf
        for tm, (i, t0, t1) in zip(met, ends):
            if math.isfinite(tm) and tm < t1 - 1e-9 * (1.0 + abs(t1)):
                worst = min(worst, _dip_after(
                    lambda t, i=i, t0=t0: self._gap(p, d, t0, imp["u"][i], imp["v_out"][i], t),
                    tm, t1))
        return worst

    def _gap(self, p, d, t0, u0, v0, t):
        uf, _, _ = self._flight(p, d, t0, u0, v0, t)
        j, tau = piece_at(d, t)
        return uf - z_state(p, j, tau)[0]

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

    def cycle_series(self, X, lam):
        """The attractor table's series over one cycle (``observables.IMPACT_CYCLE``): the
        impact heights u and the velocities before impact v_in."""
        imp = self.impacts(X, lam)
        return imp["u"], imp["v_in"]

    def store(self, X, lam, section):
        """What the continuation file keeps of the orbit at one point (docs/continuation.md):
        the cycle's impacts, the section state, the cycle's duration."""
        imp = self.impacts(X, lam)
        p, d = self.packed(lam)
        if section is None and OBSTACLES[self.obstacle].auto_section:
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


def _dip_after(gap, tm, t1):
    """The smallest gap of a flight just after it meets the obstacle at tm (where it goes
    below: gap(tm) = 0, gap' < 0), before t1: steps doubling from tm until the gap rises,
    then golden-section search of that bracket."""
    a, b = tm, tm + max(1e-9 * (t1 - tm), 4.0 * math.ulp(tm))
    fb = gap(b)
    c = b
    for _ in range(2100):               # doubling from 4 ulp reaches any t1 well within
        c = min(t1, tm + 2.0 * (b - tm))
        fc = gap(c)
        if c >= t1 or not math.isfinite(fc) or (fb < 0.0 and fc > fb):
            break                       # below the obstacle and rising again: bracketed
        a, b, fb = b, c, fc
    invphi = (math.sqrt(5.0) - 1.0) / 2.0
    lo, hi = a, c
    best = fb
    for _ in range(80):
        x1 = hi - invphi * (hi - lo)
        x2 = lo + invphi * (hi - lo)
        f1, f2 = gap(x1), gap(x2)
        best = min(best, f1, f2)
        if f1 < f2:
            hi = x2
        else:
            lo = x1
        if hi - lo <= 1e-13 * (1.0 + abs(hi)):
            break
    return best


def seed_from_run(values, obstacle, param, t, v_out, corner_offset, ipc, tol=1e-12,
                  tables=None):
    """A FlowOrbit and its solved X from one run's record (``cornerbif.simulate`` or a
    sweep file: its last complete cycle of ``ipc`` impacts); ``tables``: the kind's own
    [system] tables (a cam's ``profile``)."""
    n = int(np.isfinite(t).sum())
    if ipc <= 0 or n < ipc + 1:
        raise OrbitError("the run has no cycle to seed from")
    first = n - 1 - ipc
    prob = FlowOrbit(dict(values), obstacle, param, np.zeros(ipc, np.int64), 1, tol,
                     dict(tables or {}))
    lam = float(values[param])
    p, d = prob.packed(lam)
    per = piece_start(d, cycle_np(d)) - piece_start(d, 0)
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
        j, tau = piece_at(d, tt)
        j = int(j)
        # an impact recorded at a corner lies on the side its offset says
        L = piece_start(d, j + 1) - piece_start(d, j)
        off = corner_offset[first + 1 + q]
        # (the offset is to the nearest corner: the piece's start where every piece starts at
        # one, or where a cam's joint is one; the triangle's offsets are to its valleys)
        kind = OBSTACLES[obstacle]
        if off == off and off < 0 and tau < 0.5 * L and (
                kind.corner_each_piece or (kind.tables and prob.corner_at_start(j, lam))):
            j -= 1
            tau += piece_start(d, j + 1) - piece_start(d, j)
        pieces[q] = j
        X[2 * q] = tau
        X[2 * q + 1] = v_out[first + 1 + q]
    prob.pieces = pieces
    prob.m = m
    return prob, newton(prob, X, lam)


def seed_from_word(values, obstacle, param, word, simulate, tol=1e-12, cycles=6, tables=None):
    """A FlowOrbit of a cluster word (``a``, ``b``, ``g`` letters, e.g. "b^5 g", "ab"),
    stable or not, near (omega, kappa) = (2, 0) on the rectified sine: the kernel is run
    from the 2D maps' orbit of the word (``theory.word_orbit``: (a0, b1) = (u, u')(0) at
    the section corner, epsilon = 1) for a few cycles without transient, the first run of
    clusters spelling the word (up to rotation) gives the pieces and the first guess, and
    Newton finds the flow's orbit.  OrbitError when the run does not spell it.
    ``simulate``: ``cornerbif.simulate``, which runs the kernel."""

    from ...analysis import parse_word  # start-up: loads numba
    from ...theory import word_orbit  # start-up: loads numba
    if not OBSTACLES[obstacle].word_seeds:
        return seed_from_transients(values, obstacle, param, word, simulate, tol, tables)
    letters = parse_word(word)
    x, _ = word_orbit(letters, values["omega"] - 2.0, values["kappa"], values["r"])
    sys_ = {k: v for k, v in values.items() if k in P.INDEX}
    rec = cycles * (2 * len(letters) + 2)
    res = simulate([x[0, 0]], [x[0, 1]], obstacle=obstacle, transient=0,
                             record=rec, **sys_)
    t, off = res["t"][0], res["corner_offset"][0]
    clusters = _clusters(t, off)
    sym = [c[2] for c in clusters]
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


def _clusters(t, off):
    """The record's impacts grouped by the corner they are nearest to (its time t - offset,
    equal to rounding within a cluster): (first impact, count, letter) per cluster, the
    letter b (one impact after its corner), g (one before), a (two straddling it) or x."""
    n = int(np.isfinite(t).sum())
    corner_t = t[:n] - off[:n]
    out = []
    for i in range(n):
        if out and abs(corner_t[i] - corner_t[out[-1][0]]) <= 1e-9 * (1.0 + abs(corner_t[i])):
            out[-1][1] += 1
        else:
            out.append([i, 1])
    for c in out:
        i0, k = c
        c.append("b" if k == 1 and off[i0] >= 0 else "g" if k == 1 else
                 "a" if k == 2 and off[i0] < 0 <= off[i0 + 1] else "x")
    return out


def seed_from_transients(values, obstacle, param, word, simulate, tol=1e-12, tables=None,
                         grid=12, record=400):
    """A FlowOrbit of a cluster word on any obstacle with corners, stable or not: the kernel
    is run without transient from a grid of starts (``grid`` heights above the obstacle's top
    times ``grid`` velocities), and every run's clusters are scanned for a window spelling
    the word (up to rotation): a run passing near the orbit, an unstable one along its
    stable manifold, spells it for a while.  Each such window seeds Newton
    (``seed_from_run``); the first solution whose word is the word and which is admissible
    is returned.  OrbitError when none is."""
    from ...analysis import parse_word  # start-up: loads numba
    if not OBSTACLES[obstacle].corners:
        raise OrbitError(f"a word seeds an orbit on an obstacle with corners, not {obstacle!r}")
    letters = parse_word(word)
    K = len(letters)
    rotations = {letters[k:] + letters[:k] for k in range(K)}
    probe = FlowOrbit(dict(values), obstacle, param, np.zeros(1, np.int64), 1, tol,
                      dict(tables or {}))
    lam = float(values[param])
    p, d = probe.packed(lam)
    per = piece_start(d, cycle_np(d)) - piece_start(d, 0)
    top = max(z_state(p, *piece_at(d, x))[0] for x in np.linspace(0.0, per, 257)[:-1])
    scale = max(1.0, abs(top), p[P.BETA] * p[P.OMEGA])
    u0 = np.repeat(top + scale * np.linspace(0.05, 3.0, grid), grid)
    v0 = np.tile(scale * np.linspace(-2.0, 2.0, grid), grid)
    sys_ = {k: v for k, v in values.items() if k in P.INDEX}
    extra = dict(tables or {})      # the kind's own tables, by their [system] keys
    res = simulate(u0, v0, obstacle=obstacle, transient=0, record=record, **sys_, **extra)
    tried = 0
    for r in range(len(u0)):
        t, off, vout = res["t"][r], res["corner_offset"][r], res["v_out"][r]
        cl = _clusters(t, off)
        spelled = "".join(c[2] for c in cl)
        for s in range(len(cl) - K):
            if spelled[s:s + K] not in rotations:
                continue
            # the window's impacts as one cycle of the fewest whole periods that holds its
            # corners (the next cycle starts at its first corner that many periods later)
            first, nxt = cl[s][0], cl[s + K][0]
            span = (t[nxt - 1] - off[nxt - 1]) - (t[first] - off[first])
            m = int(math.floor(span / per + 1e-9)) + 1
            last = nxt - 1
            tt = np.concatenate([[t[last] - m * per], t[first:nxt]])
            vv = np.concatenate([[vout[last]], vout[first:nxt]])
            oo = np.concatenate([[off[last]], off[first:nxt]])
            tried += 1
            if tried > 4 * len(u0):     # the work is bounded: four windows a start
                raise OrbitError(f"no run from {len(u0)} starts spells {word!r} near its "
                                 f"orbit ({tried - 1} windows tried)")
            try:
                prob, X = seed_from_run(values, obstacle, param, tt, vv, oo, nxt - first, tol,
                                        tables)
            except (OrbitError, np.linalg.LinAlgError):
                continue
            if prob.word(X, lam) in rotations and prob.admissible(X, lam)[0]:
                return prob, X
    raise OrbitError(f"no run from {len(u0)} starts spells {word!r} near its orbit "
                     f"({tried} windows tried)")


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
    return problem.with_pieces(pieces), X


def word_of(problem, X, lam, cycles=4):
    """The orbit's word in the engine's symbols (``analysis.detect_cycle`` on ``cycles``
    repetitions of its impacts: clusters by nearest corner, a, b, g)."""
    from ...analysis import word_of_impacts  # start-up: loads numba
    imp = problem.impacts(X, lam)
    p, d = problem.packed(lam)
    # how far one cycle moves the corner ids (corner_of's numbering, whatever the kind)
    shift = problem.m * cycle_np(d)
    j0, tau0 = int(problem.pieces[0]), X[0]
    per_corners = corner_of(p, d, j0 + shift, tau0)[0] - corner_of(p, d, j0, tau0)[0]
    cornered = OBSTACLES[problem.obstacle].has_corners(problem.table())
    return word_of_impacts(imp["t"], imp["v_in"], imp["offset"], imp["corner"],
                           problem.duration(lam), per_corners, cornered, cycles)


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
