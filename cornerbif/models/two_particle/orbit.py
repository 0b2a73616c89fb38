"""The periodic-orbit problem of the two-particle system (section 6, docs/continuation.md):
a closed chain of w-z impacts (law 5) and z-u impacts (law 74) in the state (z, y, u, v), its
monodromy from the tangent steps (``models.two_particle.tangent``), and its seed from a state at
a section time (``two_particle_seed``)."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ...continuation import (
    GAP_SAMPLES,
    OrbitError,
    admissible,
    cached,
    central_d_param,
    newton,
)
from ...numerics.oscillator import D_X, D_Y, acceleration, particular
from ...numerics.saltation import flight_matrix
from ...stability import OK, sorted_eigenvalues
from ..flow import slots as FP
from . import kernel as TK
from . import packed as TPM
from .kernel import run_tables
from .tangent import two_particle_steps


@dataclass
class TwoParticleOrbit:
    """The periodic orbit of the ``two_particle`` model (section 6) as a closed chain of
    events: event k is a w-z impact ("W": law 5 with r1 on the wall, eq 72) or a z-u
    impact ("U": law 74); the unknowns per event are its time t_k and the state
    x_k+ = (z, y, u, v) just after it; both particles fly in closed form between events
    (``numerics.saltation.flight_matrix`` and the oscillator rows of ``models.two_particle.kernel``).
    Per event five equations: its gap vanishes at t_k for the state the flight brings,
    and the state after it is the impact law of that state.  The cycle closes after m wall
    periods.  The Jacobian is in closed form (``jacobian``: flight matrices, the free
    flights' field and the impact laws' derivatives).  A corner collision is two
    consecutive events meeting in time (a w-z and a z-u impact: this system's corner);
    across it the two swap.
    """

    values: dict
    param: str
    kinds: str          # "W" / "U" per event of one cycle, in time order
    m: int
    obstacle: str = "two_particle"
    _cache: dict = field(default_factory=dict, repr=False)

    def to_doc(self) -> dict:
        """The problem as plain data (a partial file's resume state), ``from_doc``'s inverse."""
        return {"values": dict(self.values), "param": self.param, "type": "two_particle",
                "kinds": self.kinds, "m": int(self.m)}

    @classmethod
    def from_doc(cls, doc):
        return cls(dict(doc["values"]), str(doc["param"]), str(doc["kinds"]), int(doc["m"]))

    @property
    def n(self) -> int:
        return len(self.kinds)

    def packed(self, lam):
        def build():
            vals = dict(self.values)
            vals[self.param] = float(lam)
            p = TPM.pack(vals)
            return (p, *TK.oscillators(p, TK.derive(p)))
        return cached(self._cache, float(lam), build)

    def duration(self, lam) -> float:
        p, _, _ = self.packed(lam)
        return self.m * 2.0 * math.pi / p[TPM.OMEGA0]

    def _fly(self, lam, t0, x, t1):
        """Both particles' free flights from state x at t0 to t1."""
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

    def _field(self, lam, t, x):
        """The vector field of both free flights at (t, x): (y, z'', v, u'') (eq 4 for each
        particle's oscillator row)."""
        p, Q, _ = self.packed(lam)
        return np.array([x[1], acceleration(Q[TK.RZ], t, x[0], x[1]),
                         x[3], acceleration(Q[TK.RU], t, x[2], x[3])])

    def _flight_matrix(self, lam, dt):
        """d x(t1) / d x(t0) of both free flights over dt (block diagonal)."""
        p, _, _ = self.packed(lam)
        Phi = np.zeros((4, 4))
        for off, s, k in ((0, p[TPM.SIGMA1], p[TPM.OMEGA1]), (2, p[TPM.SIGMA2], p[TPM.OMEGA2])):
            Phi[off:off + 2, off:off + 2] = np.array(flight_matrix(s, k, dt)).reshape(2, 2)
        return Phi

    def _law_derivatives(self, lam, kind, t):
        """(dgap/dx-, dgap/dt, dx+/dx-, dx+/dt) of an event of ``kind`` at t (``_law``): the
        w-z impact's law (5) on the wall w(t) of eq (72), or law (74), linear in (y, v)."""
        p, _, _ = self.packed(lam)
        Lx = np.eye(4)
        Lt = np.zeros(4)
        if kind == "W":
            _, wp, wpp, _ = TK.wall(p, t, 0.0)
            Lx[1, 1] = -p[TPM.R1]
            Lt[1] = (1.0 + p[TPM.R1]) * wpp
            return np.array([1.0, 0.0, 0.0, 0.0]), -wp, Lx, Lt
        for c, (y, v) in ((1, (1.0, 0.0)), (3, (0.0, 1.0))):
            Lx[1, c], Lx[3, c] = TPM.mass_ratio_impact(y, v, p[TPM.MU], p[TPM.R2])
        return np.array([-1.0, 0.0, 1.0, 0.0]), 0.0, Lx, Lt

    def jacobian(self, X, lam):
        """dR/dX in closed form (``residual``): event k's arrival x- = Phi (x_j - x_p(t_j)) +
        x_p(t_k) from event j = k - 1 gives dx-/dx_j = Phi, dx-/dt_j = -Phi F(t_j, x_j) and
        dx-/dt_k = F(t_k, x-) (F the free flights' field, Phi their flight matrices); the gap
        and the impact law are differentiated at (t_k, x-) (``_law_derivatives``)."""
        N = self.n
        Jm = np.zeros((5 * N, 5 * N))
        for k in range(N):
            j = (k - 1) % N
            tk, xm = self._arrival(X, lam, k)
            tj, xj = X[5 * j], X[5 * j + 1:5 * j + 5]
            Phi = self._flight_matrix(lam, tk - tj)
            d_tj = -Phi @ self._field(lam, tj, xj)
            d_tk = self._field(lam, tk, xm)
            gx, gt, Lx, Lt = self._law_derivatives(lam, self.kinds[k], tk)
            rows = slice(5 * k + 1, 5 * k + 5)
            # the gap row
            Jm[5 * k, 5 * j + 1:5 * j + 5] += gx @ Phi
            Jm[5 * k, 5 * j] += gx @ d_tj
            Jm[5 * k, 5 * k] += gx @ d_tk + gt
            # the law rows: x_k - L(t_k, x-)
            Jm[rows, 5 * j + 1:5 * j + 5] -= Lx @ Phi
            Jm[rows, 5 * j] -= Lx @ d_tj
            Jm[rows, 5 * k] -= Lx @ d_tk + Lt
            Jm[rows, 5 * k + 1:5 * k + 5] += np.eye(4)
        return Jm

    def d_param(self, X, lam):
        return central_d_param(self.residual, X, lam)

    def tables(self, X, lam):
        """The orbit as the kernel's tables over two cycles (z-u rows:
        t, u, v_in, v_out, y_in, y_out, offset; w-z rows: t, z, y_in, y_out), for
        ``models.two_particle.tangent.two_particle_steps``."""
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
        # a NaN row: the table is not full (models.two_particle.tangent.two_particle_steps' TABLE_FULL test)
        wz.append([math.nan] * 4)
        return np.array(zu), np.array(wz).reshape(-1, 4)

    def impacts(self, X, lam):
        """Per event: its time and the relative velocity of its approach (< 0)."""
        w = np.empty(self.n)
        for k in range(self.n):
            t, xm = self._arrival(X, lam, k)
            if self.kinds[k] == "W":
                p, _, _ = self.packed(lam)
                w[k] = xm[1] - TK.wall(p, t, 0.0)[1]
            else:
                w[k] = xm[3] - xm[1]
        return {"w": w, "t": X[0::5].copy()}

    def floquet(self, X, lam):
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
        """The smallest of both gaps z - w and u - z over the interior of every flight,
        certified: ``GAP_SAMPLES`` samples per flight, then every stretch between two samples
        (or an event) whose gaps the bound of their second derivative (``_gap_curvature``)
        does not prove positive is halved until it does, or a negative gap is found, or it
        is below rounding.  A flight that crosses either surface is never called clear."""
        N = self.n
        D = self.duration(lam)
        best = math.inf
        for k in range(N):
            t0 = X[5 * k]
            t1 = X[5 * ((k + 1) % N)] + (D if k == N - 1 else 0.0)
            best = min(best, self._flight_gap(lam, t0, X[5 * k + 1:5 * k + 5], t1))
        return best

    def _gaps(self, lam, t0, x0, t):
        """(z - w, u - z) and their time derivatives at t on the flight from (t0, x0)."""
        p, _, _ = self.packed(lam)
        x = self._fly(lam, t0, x0, t)
        w, wp, _, _ = TK.wall(p, t, 0.0)
        return np.array([x[0] - w, x[2] - x[0]]), np.array([x[1] - wp, x[3] - x[1]])

    def _gap_curvature(self, lam, t0, x0, t1):
        """Bounds of |(z - w)''| and |(u - z)''| over the flight from (t0, x0) to t1: each
        particle's |x''| <= |F| + 2 sigma V + k^2 U (eq 4), U and V bounding |x| and |x'|:
        the particular solution's amplitude A (and W A) plus the free part's, whose energy
        x'^2 + k^2 x^2 does not grow (sigma >= 0), or, with k = 0, |dx| + |dv| (t1 - t0) and
        |dv|; the wall's |w''| <= beta omega0^2.  inf where a bound is not finite."""
        p, Q, Dd = self.packed(lam)
        acc = []
        for off, row in ((0, TK.RZ), (2, TK.RU)):
            q, d = Q[row], Dd[row]
            k, sig, F, W = q[FP.K], q[FP.SIGMA], q[FP.F_AMP], q[FP.F_OMEGA]
            A = math.hypot(d[D_X], d[D_Y]) if F != 0.0 else 0.0
            up, vp = particular(q, d, t0)
            du, dv = x0[off] - up, x0[off + 1] - vp
            if k > 0.0:
                E = math.sqrt(dv * dv + k * k * du * du)
                U, V = A + E / k, W * A + E
            else:
                U, V = A + abs(du) + abs(dv) * (t1 - t0), W * A + abs(dv)
            acc.append(abs(F) + 2.0 * sig * V + k * k * U)
        wall = p[TPM.BETA] * p[TPM.OMEGA0] ** 2
        out = np.array([acc[0] + wall, acc[1] + acc[0]])
        return np.where(np.isfinite(out), out, np.inf)

    def _flight_gap(self, lam, t0, x0, t1, budget=4000):
        """The smallest interior gap of one flight, certified (``smallest_gap``)."""
        M = self._gap_curvature(lam, t0, x0, t1)
        ts = np.linspace(t0, t1, GAP_SAMPLES + 2)
        g = np.empty((len(ts), 2))
        dg = np.empty((len(ts), 2))
        for i, t in enumerate(ts):
            g[i], dg[i] = self._gaps(lam, t0, x0, t)
        best = float(g[1:-1].min()) if len(ts) > 2 else math.inf
        if not np.all(np.isfinite(M)):
            return best
        # the events' own gaps are 0 at the ends (to rounding): the ends count as 0 there,
        # and are certified by their slope (leaving at t0, arriving at t1)
        g[0] = np.maximum(g[0], 0.0)
        g[-1] = np.maximum(g[-1], 0.0)
        tiny = 1e-13 * (1.0 + abs(t1))
        for c in range(2):
            stack = [(ts[i], g[i, c], ts[i + 1], g[i + 1, c]) for i in range(len(ts) - 1)]
            while stack and budget > 0:
                a, ga, b, gb = stack.pop()
                if ga < 0.0 or gb < 0.0:
                    continue                    # a crossing, already in best
                h = b - a
                if min(ga, gb) - M[c] * h * h / 8.0 >= 0.0 or h < tiny:
                    continue
                if a == t0 and ga == 0.0 and dg[0, c] > 0.0 and 2.0 * dg[0, c] >= M[c] * h \
                        and gb > 0.0:
                    continue                    # leaving: g >= g'(t0) s - M s^2 / 2 > 0
                if b == t1 and gb == 0.0 and dg[-1, c] < 0.0 and -2.0 * dg[-1, c] >= M[c] * h \
                        and ga > 0.0:
                    continue                    # arriving: likewise from t1
                m = 0.5 * (a + b)
                gm = self._gaps(lam, t0, x0, m)[0][c]
                budget -= 1
                best = min(best, gm)
                stack += [(a, ga, m, gm), (m, gm, b, gb)]
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

    def cycle_series(self, X, lam):
        """The attractor table's series over one cycle (``observables.IMPACT_CYCLE``, of the
        u-z impacts): their heights u and the velocities before impact v_in."""
        zu, _ = self.tables(X, lam)
        n_zu = self.kinds.count("U")
        zu = zu.reshape(-1, 7)
        return zu[:n_zu, 1].copy(), zu[:n_zu, 2].copy()

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
    kw = {k: v for k, v in values.items() if k in TPM.NAMES}
    for F, W in (("F1", "Omega1"), ("F2", "Omega2")):
        if kw.get(F, 0.0) != 0.0:
            ratio = kw.get(W, 1.0) / kw["omega0"]
            if abs(ratio - round(ratio)) > 1e-9 * max(1.0, ratio) or round(ratio) < 1:
                raise OrbitError(f"{F} != 0 with {W}/omega0 = {ratio!r} not a whole number: "
                                 "the seed's section state (t = n 2 pi/omega0) would not be "
                                 "a state at t = 0, nor the forcing periodic with the wall")
    r = run_tables(*x_section, transient=0, record=ipc + 2, **kw)
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
