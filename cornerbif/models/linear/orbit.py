"""The periodic-orbit problem of the ``linear`` model (docs/linear.md, "Continuation"): a
closed chain of impacts on hard contacts (law "impact"), in time order, with unknowns per
impact its time t_k and the state (x_k, v_k) just after it.

Per impact k, reached by the exact flight (``flight.py``: y = (x, v, forcing states),
y(t) = expm(A (t - t_j)) y(t_j)) from impact j = k - 1, 1 + 2N equations:

    a . x- - z(t_k) = 0,    x_k - x- = 0,    v_k - (v- - (1 + r) (a . v- - z'(t_k)) m) = 0,

m = M^-1 a / (a^T M^-1 a) (the generalised Newton law, ``impact.newton_impact``); the chain
closes after m periods T of the system (``model.system_period``): impact 0 is reached at
t_0 + m T.  The Jacobian is in closed form (``LinearOrbit.jacobian``): d y- / d y_j = Phi,
the (x, v) block of expm(A h); d y- / d t_j = -Phi f(t_j, y_j); d y- / d t_k = f(t_k, y-) (f
the flight's field); the gap and the law are differentiated at (t_k, y-).  The monodromy is
the product of the flights' Phi and the impacts' saltation matrices S = D_y R + (f+ - D_y R
f- - d_t R) n^T / w- (tangent.py's, written here from the same algebra on the orbit's
unknowns; its multipliers equal the stability pass's: tests/models/test_linear_continuation.py).

An impact on an obstacle with corners keeps its piece (the itinerary says on which side of
each corner it lies, as the flow's ``FlowOrbit``); a corner collision is an impact time
meeting its piece's corner, or two consecutive impacts on different contacts meeting in time
(across it they swap, as the two-particle model's events).  The grazing monitor is certified
(``_flight_gap``): every contact's gap over every flight, sampled and then every stretch that
the bound of its second derivative (``events.Gap.bound2``, the event search's) does not prove
positive is halved.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ... import obstacles
from ...continuation import GAP_SAMPLES, OrbitError, admissible, cached, central_d_param, newton
from ...obstacles.dispatch import corner_of, piece_at, piece_length, piece_start, z_state
from ...stability import sorted_eigenvalues
from . import declare
from .declare import paper_words, system_period
from .events import ContactObstacle, Gap
from .flight import augmented, expm, forcing_state

# an impact within this of a piece's end (relative to 1 + |t|) may lie on either side of the
# corner: the seed takes the side whose slope the recorded law used (tangent.CORNER_WINDOW)
CORNER_WINDOW = 1e-9


@dataclass
class LinearOrbit:
    """The periodic orbit of a ``linear`` scene as a closed chain of impacts (module
    docstring).  ``table``: the scene's [system] table (plain data); ``values``: its numbers
    by path (``declare.numeric_paths``), ``param`` the one continued; ``contacts``: the
    contact index of each impact of one cycle, in time order; ``pieces``: each impact's
    obstacle piece where its contact's obstacle has corners (-1 elsewhere: a smooth
    obstacle's piece ends are not events); ``m``: periods T per cycle.  X holds per impact
    (t_k, x_k, v_k), 1 + 2N numbers."""

    table: dict
    values: dict
    param: str
    contacts: tuple
    pieces: tuple
    m: int
    obstacle: str = "linear"
    _cache: dict = field(default_factory=dict, repr=False)

    def to_doc(self) -> dict:
        """The problem as plain data (a partial file's resume state), ``from_doc``'s inverse."""
        return {"type": "linear", "table": self.table, "values": dict(self.values),
                "param": self.param, "contacts": [int(c) for c in self.contacts],
                "pieces": [int(j) for j in self.pieces], "m": int(self.m)}

    @classmethod
    def from_doc(cls, doc):
        return cls(doc["table"], dict(doc["values"]), str(doc["param"]),
                   tuple(int(c) for c in doc["contacts"]), tuple(int(j) for j in doc["pieces"]),
                   int(doc["m"]))

    @property
    def n(self) -> int:
        return len(self.contacts)

    # --- the system at a parameter value ----------------------------------------------
    def setup(self, lam):
        """The system at param = lam and what the equations read of it (cached)."""
        def build():
            vals = dict(self.values)
            vals[self.param] = float(lam)
            base = declare.numeric_paths(self.table)
            table = self.table
            for path, v in vals.items():
                if v != base.get(path):
                    table = declare.with_value(table, path, v)
            system, bad = declare.read_system(table)
            if bad:
                raise OrbitError(f"{self.param} = {lam!r}: {bad[0]}")
            T = system_period(system)
            if not T > 0.0:
                raise OrbitError(f"{self.param} = {lam!r}: the system has no period T")
            nd = system.n
            A = augmented(system)
            gaps = [np.asarray(c.gap, float) for c in system.contacts]
            Minv_a = [np.linalg.solve(system.mass, a) for a in gaps]
            obs = [ContactObstacle(c.obstacle, c.kappa, c.beta, c.omega) for c in system.contacts]
            kinds = obstacles.registered()
            corners = [c.obstacle != declare.FIXED and kinds[c.obstacle].has_corners(None)
                       for c in system.contacts]
            return _Setup(system=system, n=nd, A=A, gaps=gaps,
                          mvec=[d / (a @ d) for a, d in zip(gaps, Minv_a)],
                          r=[c.r for c in system.contacts], obs=obs, corners=corners,
                          kinds=[kinds.get(c.obstacle) for c in system.contacts], T=T,
                          D=self.m * T)
        return cached(self._cache, float(lam), build)

    def duration(self, lam) -> float:
        return self.setup(lam).D

    def _unpack(self, X, k):
        """(t_k, x_k, v_k) of impact k."""
        nd = (len(X) // self.n - 1) // 2
        b = (1 + 2 * nd) * k
        return X[b], X[b + 1:b + 1 + nd], X[b + 1 + nd:b + 1 + 2 * nd]

    def _piece(self, s, k, t):
        """The obstacle piece impact k lies on (its own where its obstacle has corners, else
        the one t lies on) and t's local time there."""
        c = self.contacts[k]
        d = s.obs[c].d
        j = self.pieces[k] if s.corners[c] else int(piece_at(d, t)[0])
        return j, t - piece_start(d, j)

    def _obstacle(self, s, k, t):
        """(z, z', z'') of impact k's obstacle at time t (on its piece)."""
        c = self.contacts[k]
        j, tau = self._piece(s, k, t)
        z, zp, zpp, _ = z_state(s.obs[c].row, j, tau)
        return z, zp, zpp

    def _state(self, s, t, x, v):
        return np.concatenate([x, v, forcing_state(s.system, t)])

    def _arrival(self, X, lam, k):
        """(t_k, the time the flight reaches it (t_0 + D for k = 0), y at impact k - 1, the
        augmented state y- just before impact k, E = expm(A h))."""
        s = self.setup(lam)
        j = (k - 1) % self.n
        tj, xj, vj = self._unpack(X, j)
        tk = self._unpack(X, k)[0]
        ta = tk + (s.D if k == 0 else 0.0)
        yj = self._state(s, tj, xj, vj)
        E = expm(s.A * (ta - tj))
        return tk, ta, yj, E @ yj, E

    def _law(self, s, k, t, ym):
        """(gap, the state just after impact k at t) from the state y- before it."""
        nd = s.n
        c = self.contacts[k]
        a = s.gaps[c]
        z, zp, _ = self._obstacle(s, k, t)
        x, v = ym[:nd], ym[nd:2 * nd]
        w = a @ v - zp
        return a @ x - z, x, v - (1.0 + s.r[c]) * w * s.mvec[c]

    def residual(self, X, lam):
        s = self.setup(lam)
        nd = s.n
        w = 1 + 2 * nd
        R = np.empty(len(X))
        for k in range(self.n):
            tk, _, _, ym, _ = self._arrival(X, lam, k)
            g, xp, vp = self._law(s, k, tk, ym)
            _, xk, vk = self._unpack(X, k)
            R[w * k] = g
            R[w * k + 1:w * k + 1 + nd] = xk - xp
            R[w * k + 1 + nd:w * (k + 1)] = vk - vp
        return R

    def _field(self, s, y):
        """The flight's field f = (x', v') at the augmented state y."""
        return (s.A @ y)[:2 * s.n]

    def _law_derivatives(self, s, k, t):
        """(G_y, G_t): the derivatives of (g, -x+, -v+) (the residual's parts that depend on
        the arrival) with respect to y- = (x-, v-) and to t explicitly (z', z'')."""
        nd = s.n
        c = self.contacts[k]
        a, mv, r = s.gaps[c], s.mvec[c], s.r[c]
        _, zp, zpp = self._obstacle(s, k, t)
        Gy = np.zeros((1 + 2 * nd, 2 * nd))
        Gy[0, :nd] = a
        Gy[1:1 + nd, :nd] = -np.eye(nd)
        Gy[1 + nd:, nd:] = -(np.eye(nd) - (1.0 + r) * np.outer(mv, a))
        Gt = np.zeros(1 + 2 * nd)
        Gt[0] = -zp
        Gt[1 + nd:] = -(1.0 + r) * zpp * mv
        return Gy, Gt

    def jacobian(self, X, lam):
        """dR/dX in closed form (module docstring)."""
        s = self.setup(lam)
        nd = s.n
        w = 1 + 2 * nd
        Jm = np.zeros((len(X), len(X)))
        for k in range(self.n):
            j = (k - 1) % self.n
            tk, _, yj, ym, E = self._arrival(X, lam, k)
            Phi = E[:2 * nd, :2 * nd]
            Gy, Gt = self._law_derivatives(s, k, tk)
            rows = slice(w * k, w * (k + 1))
            Jm[rows, w * j] += Gy @ (-Phi @ self._field(s, yj))
            Jm[rows, w * j + 1:w * (j + 1)] += Gy @ Phi
            Jm[rows, w * k] += Gy @ self._field(s, ym) + Gt
            Jm[w * k + 1:w * (k + 1), w * k + 1:w * (k + 1)] += np.eye(2 * nd)
        return Jm

    def d_param(self, X, lam):
        return central_d_param(self.residual, X, lam)

    # --- what the orbit is -------------------------------------------------------------
    def impacts(self, X, lam):
        """Per impact: its time ``t``, contact, height u = a . x, the velocities a . v along
        its gap before and after (``v_in``, ``v_out``) and the relative velocity of its
        approach w- = a . v- - z' (< 0 for an impact)."""
        s = self.setup(lam)
        nd = s.n
        out = {k: np.empty(self.n) for k in ("t", "u", "v_in", "v_out", "w")}
        out["contact"] = np.array(self.contacts, np.int64)
        for k in range(self.n):
            tk, _, _, ym, _ = self._arrival(X, lam, k)
            a = s.gaps[self.contacts[k]]
            _, xk, vk = self._unpack(X, k)
            zp = self._obstacle(s, k, tk)[1]
            out["t"][k] = tk
            out["u"][k] = a @ xk
            out["v_in"][k] = a @ ym[nd:2 * nd]
            out["v_out"][k] = a @ vk
            out["w"][k] = out["v_in"][k] - zp
        return out

    def monodromy(self, X, lam):
        """J = S_0 Phi_0 S_(N-1) Phi_(N-1) ... S_1 Phi_1 from just after impact 0 to just after
        it a cycle later: the flights' Phi and the saltation matrices
        S = D_y R + (f+ - D_y R f- - d_t R) n^T / w- (tangent.py), n = (a, 0)."""
        s = self.setup(lam)
        nd = s.n
        J = np.eye(2 * nd)
        for step in range(1, self.n + 1):
            k = step % self.n
            c = self.contacts[k]
            a, mv, r = s.gaps[c], s.mvec[c], s.r[c]
            tk, ta, _, ym, E = self._arrival(X, lam, k)
            _, zp, zpp = self._obstacle(s, k, tk)
            w = a @ ym[nd:2 * nd] - zp
            DyR = np.eye(2 * nd)
            DyR[nd:, nd:] -= (1.0 + r) * np.outer(mv, a)
            dtR = np.zeros(2 * nd)
            dtR[nd:] = (1.0 + r) * zpp * mv
            yp = ym.copy()
            yp[nd:2 * nd] = ym[nd:2 * nd] - (1.0 + r) * w * mv
            fm, fp = self._field(s, ym), self._field(s, yp)
            nvec = np.concatenate([a, np.zeros(nd)])
            S = DyR + np.outer(fp - DyR @ fm - dtR, nvec) / w
            J = S @ E[:2 * nd, :2 * nd] @ J
        return J

    def floquet(self, X, lam):
        J = self.monodromy(X, lam)
        return sorted_eigenvalues(J[None])[0], J

    def corner_distances(self, X, lam):
        """Per impact, the signed time to its corner: on an obstacle with corners, tau (the
        corner at its piece's start) or L - tau (at its end), whichever is nearer (negative
        once crossed); and, where the next impact is on another contact, the time to it (two
        impacts meeting change the itinerary).  The smaller of the two; inf where neither."""
        s = self.setup(lam)
        out = np.full(self.n, np.inf)
        t = np.array([self._unpack(X, k)[0] for k in range(self.n)])
        for k in range(self.n):
            c = self.contacts[k]
            if s.corners[c]:
                d = s.obs[c].d
                row = s.obs[c].row
                j = self.pieces[k]
                L = piece_length(d, j)
                tau = t[k] - piece_start(d, j)
                start = s.kinds[c].corner_at_start(row, j)
                end = s.kinds[c].corner_at_start(row, j + 1)
                if start and (tau < 0.5 * L or not end):
                    out[k] = tau
                elif end:
                    out[k] = L - tau
            nxt = (k + 1) % self.n
            if self.contacts[nxt] != c:
                out[k] = min(out[k], (t[nxt] + (s.D if nxt == 0 else 0.0)) - t[k])
        return out

    def reindex(self, X, lam):
        return self, X

    def smallest_gap(self, X, lam):
        """The smallest gap of every contact over the interior of every flight, certified
        (``_flight_gap``): a flight that crosses a contact is never called clear."""
        s = self.setup(lam)
        best = math.inf
        for k in range(self.n):
            nxt = (k + 1) % self.n
            tk, xk, vk = self._unpack(X, k)
            t1 = self._unpack(X, nxt)[0] + (s.D if nxt == 0 else 0.0)
            y0 = self._state(s, tk, xk, vk)
            for c in range(len(s.gaps)):
                best = min(best, self._flight_gap(s, c, tk, y0, t1, c == self.contacts[k],
                                                  c == self.contacts[nxt]))
        return best

    def _flight_gap(self, s, c, t0, y0, t1, leaving, arriving, budget=4000):
        """The smallest gap of contact c over the interior of the flight from y0 at t0 to
        t1, certified: ``GAP_SAMPLES`` samples spread over the obstacle's smooth pieces (its
        corners among them), the smallest refined by Newton on g' = 0; then every stretch
        between two samples whose gap the bound B of |g''| over it (``events.Gap.bound2``)
        does not prove positive (min(g_a, g_b) - B h^2 / 8 > 0, or, at the flight's end on
        the impacting contact, where g = 0, its slope: 2 |g'| >= B h) is halved, until it
        is, or a negative gap is found, or it is below rounding.  ``leaving``/``arriving``:
        c is the contact of the impact at t0 / t1 (its gap is 0 there)."""
        gap = Gap(s.A, y0, t0, s.gaps[c], s.obs[c])
        span = t1 - t0
        best = math.inf
        tiny = 1e-13 * (1.0 + abs(t1))
        for j, a, b in s.obs[c].pieces(t0, t1):
            k = max(2, int(math.ceil(GAP_SAMPLES * (b - a) / span)) + 1)
            ts = np.linspace(a, b, k)
            ys = [gap.state(t - t0) for t in ts]
            vals = [gap.value(t - t0, j, y) for t, y in zip(ts, ys)]
            g = np.array([v[0] for v in vals])
            dg = np.array([v[1] for v in vals])
            at0 = leaving and a == t0
            at1 = arriving and b == t1
            if at0:
                g[0] = 0.0          # the impact's own gap, 0 by its equation (to rounding)
            if at1:
                g[-1] = 0.0
            inner = [i for i in range(k) if not ((i == 0 and a == t0) or (i == k - 1 and b == t1))]
            if inner:
                i = min(inner, key=lambda q: g[q])
                best = min(best, g[i])
                if 0 < i < k - 1 and g[i] <= g[i - 1] and g[i] <= g[i + 1]:
                    best = min(best, self._refined(gap, j, ts, i, t0))
            stack = [(ts[i], g[i], dg[i], ys[i], ts[i + 1], g[i + 1], dg[i + 1])
                     for i in range(k - 1)]
            while stack and budget > 0:
                ta, ga, da, ya, tb, gb, db = stack.pop()
                if ga < 0.0 or gb < 0.0:
                    continue                    # a crossing, already in best
                h = tb - ta
                B = gap.bound2(ya, h, j)
                if not math.isfinite(B):
                    break
                if min(ga, gb) - B * h * h / 8.0 > 0.0 or h < tiny:
                    continue
                if at0 and ta == t0 and ga == 0.0 and da > 0.0 and 2.0 * da >= B * h and gb > 0.0:
                    continue                    # leaving: g >= g'(t0) s - B s^2 / 2 > 0
                if at1 and tb == t1 and gb == 0.0 and db < 0.0 and -2.0 * db >= B * h \
                        and ga > 0.0:
                    continue                    # arriving: likewise from t1
                tm = 0.5 * (ta + tb)
                ym = gap.state(tm - t0)
                gm, dm = gap.value(tm - t0, j, ym)
                budget -= 1
                best = min(best, gm)
                stack += [(ta, ga, da, ya, tm, gm, dm), (tm, gm, dm, ym, tb, gb, db)]
        return best

    @staticmethod
    def _refined(gap, j, ts, i, t0):
        """The gap at the minimum near sample i (Newton on g' = 0 with g'' = c A^2 y - z'',
        kept within the neighbouring samples), or inf where it does not settle there."""
        lo, hi = ts[max(i - 1, 0)], ts[min(i + 1, len(ts) - 1)]
        t = ts[i]
        for _ in range(12):
            y = gap.state(t - t0)
            g, dg = gap.value(t - t0, j, y)
            dpt = t - piece_start(gap.obstacle.d, j)
            zpp = z_state(gap.obstacle.row, j, dpt)[2]
            ddg = gap.cA[2] @ y - zpp
            if not ddg > 0.0:
                return math.inf
            tn = t - dg / ddg
            if not lo <= tn <= hi:
                return math.inf
            if abs(tn - t) <= 1e-15 * (1.0 + abs(t)):
                t = tn
                break
            t = tn
        return gap.value(t - t0, j)[0]

    # --- the itinerary -----------------------------------------------------------------
    def word(self, X, lam):
        """The orbit's word as the model names its runs: the paper's corner clusters (one
        contact on a cornered obstacle, beta > 0: ``model.paper_words``, the flow's
        ``analysis.detect_cycles``) or its contacts' letters, rotated to the smallest form."""
        s = self.setup(lam)
        if paper_words(s.system):
            return self._paper_word(s, X, lam)
        letters = "".join(s.system.contacts[c].name for c in self.contacts)
        return min(letters[i:] + letters[:i] for i in range(len(letters)))

    def _paper_word(self, s, X, lam, cycles=4):
        from ...analysis import word_of_impacts  # start-up: loads numba
        imp = self.impacts(X, lam)
        ob = s.obs[0]
        N = self.n
        corner, off = np.empty(N, np.int64), np.empty(N)
        for k in range(N):
            j, tau = self._piece(s, k, imp["t"][k])
            corner[k], off[k] = corner_of(ob.row, ob.d, j, tau)
        j0, tau0 = self._piece(s, 0, imp["t"][0])
        shift = int(piece_at(ob.d, imp["t"][0] + s.D)[0] - piece_at(ob.d, imp["t"][0])[0])
        per_corners = corner_of(ob.row, ob.d, j0 + shift, tau0)[0] - corner[0]
        return word_of_impacts(imp["t"], imp["v_in"], off, corner, s.D, per_corners,
                               True, cycles)

    def itinerary(self) -> str:
        return (f"impacts on contacts {list(map(int, self.contacts))}, pieces "
                f"{list(map(int, self.pieces))}, {self.m} period(s) T")

    def admissible(self, X, lam):
        return admissible(self, X, lam)

    def with_events(self, contacts, pieces):
        new = dataclasses.replace(self, contacts=tuple(contacts), pieces=tuple(pieces))
        new._cache = self._cache
        return new

    def across(self, q, X, lam):
        """Across a corner collision of impact q: on its obstacle's corner, the impact on the
        neighbouring piece (as the flow's ``across_corner``); two impacts on different
        contacts meeting, the two swap (the laws applied in the new order, as the two-particle
        model's ``across``)."""
        s = self.setup(lam)
        c = self.contacts[q]
        nxt = (q + 1) % self.n
        tq = self._unpack(X, q)[0]
        tn = self._unpack(X, nxt)[0] + (s.D if nxt == 0 else 0.0)
        corner = math.inf
        if s.corners[c]:
            d = s.obs[c].d
            j = self.pieces[q]
            tau = tq - piece_start(d, j)
            corner = min(abs(tau), abs(piece_length(d, j) - tau))
        if self.contacts[nxt] != c and abs(tn - tq) < corner:
            return self._swap(s, q, X, lam)
        d = s.obs[c].d
        j = self.pieces[q]
        pieces = list(self.pieces)
        tau = tq - piece_start(d, j)
        pieces[q] = j - 1 if tau < 0.5 * piece_length(d, j) else j + 1
        return self.with_events(self.contacts, pieces), X.copy()

    def _swap(self, s, q, X, lam):
        """Impacts q and q + 1 (on different contacts) in the other order: the guess is the
        two laws applied in the new order to the state just before impact q, the times
        exchanged (equal at the collision); an impact that moves across the cycle's end
        changes its piece by the cycle's pieces."""
        nd = s.n
        w = 1 + 2 * nd
        r = (q + 1) % self.n
        contacts, pieces = list(self.contacts), list(self.pieces)
        contacts[q], contacts[r] = contacts[r], contacts[q]
        pieces[q], pieces[r] = pieces[r], pieces[q]
        tq = self._unpack(X, q)[0]
        tr = self._unpack(X, r)[0]
        if r == 0:        # the last impact passes the first one of the next cycle
            tq_new, tr_new = tr + s.D, tq - s.D
            for idx, sign in ((q, 1), (r, -1)):
                if pieces[idx] >= 0:
                    pieces[idx] += sign * self._pieces_per_cycle(s, contacts[idx])
        else:
            tq_new, tr_new = tr, tq
        new = self.with_events(contacts, pieces)
        _, _, _, ym, _ = self._arrival(X, lam, q)
        _, x1, v1 = new._law(s, q, tq_new, ym)
        y1 = ym.copy()
        y1[nd:2 * nd] = v1
        _, x2, v2 = new._law(s, r, tr_new, y1)
        Xn = X.copy()
        Xn[w * q], Xn[w * q + 1:w * q + 1 + nd], Xn[w * q + 1 + nd:w * (q + 1)] = tq_new, x1, v1
        Xn[w * r], Xn[w * r + 1:w * r + 1 + nd], Xn[w * r + 1 + nd:w * (r + 1)] = tr_new, x2, v2
        return new, Xn

    @staticmethod
    def _pieces_per_cycle(s, c):
        """How many pieces of contact c's obstacle one cycle (D) spans."""
        d = s.obs[c].d
        h = 0.5 * piece_length(d, 0)
        return int(piece_at(d, s.D + h)[0] - piece_at(d, h)[0])

    def cycle_series(self, X, lam):
        """The attractor table's series over one cycle (``observables.IMPACT_CYCLE``): the
        impact heights u and the velocities before impact v_in, along the gaps."""
        imp = self.impacts(X, lam)
        return imp["u"], imp["v_in"]

    def store(self, X, lam, section):
        imp = self.impacts(X, lam)
        return {"impact_t": imp["t"], "impact_u": imp["u"], "impact_v_in": imp["v_in"],
                "impact_v_out": imp["v_out"], "impact_contact": imp["contact"].astype(float),
                "cycle_duration": self.duration(lam)}


@dataclass
class _Setup:
    system: object
    n: int
    A: np.ndarray
    gaps: list
    mvec: list
    r: list
    obs: list
    corners: list
    kinds: list
    T: float
    D: float


def linear_seed(table, values, param, run):
    """A LinearOrbit and its solved unknowns from one run's record (``run_items``' outputs
    of that run: ``t``, ``contact``, ``x_<d>``, ``v_<d>`` just after each impact, ``v_in``,
    ``v_out`` along the gaps, ``ipc``): its last complete cycle of ``ipc`` impacts, the
    times shifted into the first cycle, each impact on a cornered obstacle on the piece whose
    slope its recorded law used."""
    ipc = int(run["ipc"])
    t = np.asarray(run["t"], float)
    n = int(np.isfinite(t).sum())
    if ipc <= 0 or n < ipc + 1:
        raise OrbitError("the run has no cycle to seed from")
    first = n - 1 - ipc
    lam = float(values[param])
    s = LinearOrbit(table, dict(values), param, (), (), 1).setup(lam)
    system, T = s.system, s.T
    m = int(round((t[first + ipc] - t[first]) / T))
    if m < 1 or abs(t[first + ipc] - t[first] - m * T) > 1e-6 * (1.0 + m * T):
        raise OrbitError(f"the run's cycle lasts {float(t[first + ipc] - t[first])!r}, not a "
                         f"whole number of periods T = {T!r}")
    dofs = system.dofs
    idx = np.arange(first + 1, first + 1 + ipc)
    contacts = [int(run["contact"][i]) for i in idx]
    vin, vout = np.asarray(run["v_in"], float), np.asarray(run["v_out"], float)
    prob = LinearOrbit(table, dict(values), param, tuple(contacts), (-1,) * ipc, m)
    s = prob.setup(lam)
    shift = math.floor(t[idx[0]] / s.D) * s.D
    nd = system.n
    X = np.empty(ipc * (1 + 2 * nd))
    pieces = []
    for k, i in enumerate(idx):
        c = contacts[k]
        r = s.r[c]
        if abs(vout[i] - (vout[i] + r * vin[i]) / (1.0 + r)) <= 1e-9 * abs(vin[i]):
            raise OrbitError(f"impact {k} of the cycle (t = {t[i]!r}, contact "
                             f"{system.contacts[c].name}) comes to rest on its contact "
                             "(sticking): its orbit is not a chain of impacts; not continued")
        tk = t[i] - shift
        j = -1
        if s.corners[c]:
            d, row = s.obs[c].d, s.obs[c].row
            j = int(piece_at(d, tk)[0])
            seen = (vout[i] + r * vin[i]) / (1.0 + r)
            best = abs(z_state(row, j, tk - piece_start(d, j))[1] - seen)
            for jj in (j - 1, j + 1):
                edge = piece_start(d, max(j, jj))
                if jj >= 0 and abs(tk - edge) <= CORNER_WINDOW * (1.0 + abs(tk)):
                    err = abs(z_state(row, jj, tk - piece_start(d, jj))[1] - seen)
                    if err < best:
                        j, best = jj, err
        pieces.append(j)
        b = k * (1 + 2 * nd)
        X[b] = tk
        X[b + 1:b + 1 + nd] = [run[f"x_{dname}"][i] for dname in dofs]
        X[b + 1 + nd:b + 1 + 2 * nd] = [run[f"v_{dname}"][i] for dname in dofs]
    prob = prob.with_events(contacts, pieces)
    return prob, newton(prob, X, lam)
