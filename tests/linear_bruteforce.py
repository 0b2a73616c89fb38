"""An independent brute force for the linear model's jitted event loop (issue 33,
``cornerbif.models.linear.kernel.run_system``), shared by tests/models/test_linear_certify.py
and benchmarks/certify_linear.py.

Nothing here calls cornerbif's numerics (flight, expm, events, obstacles, the impact law):
the scene's ``[system]`` table is read again here, the augmented matrix is built here, flights
are scipy's ``expm`` of it, the obstacles' z, z', z'' are written out, and the impact law is
written out.  cornerbif is imported only to build the kernel's system from the same table
(``declare.read_system``) and to run the kernel.

**The flight.**  y = (x, v, cos and sin of each harmonic force's phase, 1 for the constant
forces), y' = A y, y(t + s) = expm(A s) y(t).  A flight from (t_s, y_s) is sampled at nodes
dt = DT_RATE / rho apart (rho = max(|A|_2, the obstacles' omega, 1)), the nodes' states by
scipy's expm of A j dt (j < BLOCK) and of A BLOCK dt, and each contact's obstacle corners
(the rectified sine's k pi / omega, the triangle's k pi / (2 omega)) are nodes of that
contact, their states by expm from the node before.  Between two nodes the obstacle is one
smooth piece, taken from the interval's midpoint.

**The gap's minima.**  At every node the gap g = a . x - z(t), its rate g' = a . v - z' and
g'' = a . v' - z'' are known (one-sided at a corner).  An interval [p, p + h] is cleared when
the Taylor bound g(s) >= g(p) - |g'(p)| h - G h^2 / 2 (from either end; G = |c A^2| |y|
e^(|A| h) + max |z''|, a bound of |g''|) stays positive.  Every other interval is resampled
at SUB sub-intervals (states by expm of A h / SUB), each sub-interval not cleared in turn is
cut at the root of g'' (where g'' changes sign at its ends) and at the roots of g' (where g'
changes sign on a piece with g' monotone), so that g is monotone between the cuts, and each
cut's g is evaluated (scipy's brentq, the states by expm from the interval's start).  So
every local minimum of the gap that comes near zero is refined, corners included (a corner
is a node); a grazing dip far shallower than the node spacing is found.  (What this
assumes: g'' changes sign at most once in a sub-interval of length dt / SUB <= 0.00625 /
rho, over which g''' turns by a few thousandths of its scale.)

**The first event** after t_s is the first monotone stretch where the gap goes from above
zero to <= 0: its root by brentq to 1e-15 (plus four ulps of t).  At the flight's start a
contact with g <= 0 that is leaving (g' > 0: the contact just impacted) is above zero once
its gap has risen past zero; one with g <= 0 and g' <= 0 is an event at the start.

**The check of a kernel run** (``check_run``) restarts the brute force from the kernel's
state just after each impact k - 1 (its x and v_out, the forces' phases at its time) and
asks of impact k at t_k on contact c, with the gaps' allowance
eps = (1 + |a| |y|) (EPS_GAP + DRIFT |A| (t_k - t_(k-1))) (|y| the larger of the flight's
end states' sizes, |A| (t_k - t_(k-1)) its length in the kernel's chunks):

* nothing missed: every contact's gap stays >= -eps over [t_(k-1), t_k];
* a real impact: the brute force's gap of contact c at t_k is <= eps;
* the state: the brute force's x and v at t_k equal the kernel's x and v_in (to 1e-9 of
  1 + |y|), and the law v+ = v- - (1 + r) w- M^-1 a / (a^T M^-1 a), w = a . v- - z', on the
  kernel's v_in gives its v_out (to 1e-12 of 1 + |v|, either side's z' at a corner);
* a run that ends on its time budget (BUDGET) has nothing below -eps after its last impact
  up to t_max.

The allowance is the kernel's documented resolution (docs/linear.md, "The certification's
limits"): it resolves an impact's time to ``tol`` = 1e-12 (a gap of |w| 1e-12), and its
flights are products of a ladder of matrices that drift by rounding, "about 1e-12 over 80
chunks".  Measured over 2000 systems at commit 4f95934 (benchmarks/certify_linear.py
reports it): the largest gap at or before an impact is 6e-12 (1 + |a| |y|), 0.11 of the
allowance, on a flight of 1004 chunks (|A| = 74) where the kernel's a . x is off by 9.9e-11
against a 40-digit mpmath flight and the brute force's by 5e-13.  So EPS_GAP = 1e-11 and
DRIFT = 1e-13 a chunk (eight times the documented rate) leave a margin of nine; a missed
impact of a random system is a dip orders deeper.
The time differences between the kernel's impacts and the brute force's first events are
measured, not asserted.

**Grazing flights** (``graze_case``, ``check_graze``) test the shallower dips: a contact's
least gap on a flight put at -delta (a dip, to be the kernel's first impact) or +delta (a
clearance, no impact), delta = 1e-6 .. 1e-12, at a smooth low point or at a corner pointing
up.  A graze decided the other way is the kernel's rounding where its own gap there is off
by at least half the depth in the direction that explains it (measured: the same place made
a dip of 1e-8, the kernel's state at that impact against the brute force's flight), and
wrong otherwise.  At 4f95934, 1 of 2000 was its rounding: a 1e-12 dip at a triangle's corner
146 chunks from the start, where the kernel's gap is off by +1.08e-12 and the brute force's
by 5e-15 (against a 40-digit mpmath flight).
"""

from __future__ import annotations

import math

import numpy as np
import scipy.linalg
from scipy.optimize import brentq

DT_RATE = 0.05            # node spacing: DT_RATE / rho
BLOCK = 64                # nodes computed per block: expm(A j dt), j < BLOCK
SUB = 8                   # an interval not cleared is resampled at SUB sub-intervals
EPS_GAP = 1e-11           # the gaps' allowance: (1 + |a| |y|) (EPS_GAP + DRIFT |A| length) ...
DRIFT = 1e-13             # ... the flight's length in the kernel's chunks 1 / |A| (module docstring)
STATE_TOL = 1e-9          # the kernel's state at an impact against the brute force's flight
LAW_TOL = 1e-12           # the kernel's v_out against the law written out here
KINDS = ("fixed", "sine", "rectified_sine", "triangle")
WINDOW = 400             # the hybrid check's flights: at most WINDOW nodes at a time
ROOT_XTOL = 1e-15
ROOT_RTOL = 4 * np.finfo(float).eps


def _root(f, l, r):
    """The root of f in [l, r] by brentq (to ROOT_XTOL plus four ulps), or None where f does
    not change sign there as evaluated."""
    fl, fr = f(l), f(r)
    if fl == 0.0:
        return l
    if fr == 0.0:
        return r
    if (fl < 0.0) == (fr < 0.0):
        return None
    return brentq(f, l, r, xtol=ROOT_XTOL, rtol=ROOT_RTOL)


# ------------------------------------------------------------------ the system, read again
class Obstacle:
    """z(t) = kappa + beta shape(omega t) of one kind, written out: "fixed" (z = kappa),
    "sine" (beta sin(omega t)), "rectified_sine" (beta |sin(omega t)|, corners at
    k pi / omega) and "triangle" (slope +beta omega from each k pi / omega to the peak
    beta pi / 2 at the half period, then -beta omega: corners every pi / (2 omega))."""

    def __init__(self, kind, kappa=0.0, beta=0.0, omega=0.0):
        self.kind, self.kappa, self.beta, self.omega = kind, float(kappa), float(beta), float(omega)
        self.spacing = (math.pi / omega if kind == "rectified_sine" else
                        math.pi / (2.0 * omega) if kind == "triangle" else None)
        self.zpp_max = abs(beta) * omega * omega if kind in ("sine", "rectified_sine") else 0.0

    def corners(self, t0, t1):
        """The corners strictly inside (t0, t1)."""
        if self.spacing is None:
            return np.empty(0)
        k = np.arange(math.floor(t0 / self.spacing), math.floor(t1 / self.spacing) + 2)
        c = k * self.spacing
        return c[(c > t0) & (c < t1)]

    def piece(self, t):
        """The smooth piece holding time t (the corners' index before it)."""
        if self.spacing is None:
            return np.zeros(np.shape(t), dtype=np.int64)
        return np.floor(np.asarray(t) / self.spacing).astype(np.int64)

    def z(self, t, k):
        """z, z', z'' at times t on pieces k (arrays broadcast)."""
        t = np.asarray(t, float)
        if self.kind == "fixed":
            zero = np.zeros_like(t)
            return self.kappa + zero, zero, zero
        if self.kind == "sine":
            s, c = np.sin(self.omega * t), np.cos(self.omega * t)
        elif self.kind == "rectified_sine":
            u = t - np.asarray(k) * self.spacing          # the piece's own sine, >= 0 on it
            s, c = np.sin(self.omega * u), np.cos(self.omega * u)
        else:
            u = t - np.asarray(k) * self.spacing
            up = np.asarray(k) % 2 == 0
            s = self.beta * self.omega
            z = self.kappa + np.where(up, s * u, s * (self.spacing - u))
            return z, np.where(up, s, -s) + 0.0 * t, np.zeros_like(t)
        b, w = self.beta, self.omega
        return self.kappa + b * s, b * w * c, -b * w * w * s


def _matrix(v, n):
    if v is None:
        return np.zeros((n, n))
    if all(isinstance(r, list) for r in v):
        return np.array(v, float)
    return np.diag(np.array(v, float))


class System:
    """The table's system for the brute force: M, K, C, forces, contacts (name, a, Obstacle,
    r), the augmented matrix A and the node ladder."""

    def __init__(self, table):
        dofs = list(table["dofs"])
        n = self.n = len(dofs)
        self.M = _matrix(table["mass"], n)
        self.M = 0.5 * (self.M + self.M.T)
        self.K = _matrix(table["stiffness"], n)
        self.K = 0.5 * (self.K + self.K.T)
        self.C = _matrix(table.get("damping"), n)
        harmonic, constant = [], np.zeros(n)
        for f in table.get("forcing", []):
            on, F = dofs.index(f["on"]), float(f["F"])
            Om, phi = float(f.get("Omega", 0.0)), float(f.get("phi", 0.0))
            if Om > 0.0:
                harmonic.append((on, F, Om, phi))
            else:
                constant[on] += F * math.cos(phi)
        self.harmonic = harmonic
        self.constant = constant
        # a soft stop (law "spring") pushes by k kappa a while it acts: the state 1 is carried
        springs = [c for c in table["contact"] if c.get("law", "impact") == "spring"]
        self.has_constant = (any(f.get("Omega", 0.0) == 0.0 for f in table.get("forcing", []))
                             or bool(springs))
        m = self.m = 2 * n + 2 * len(harmonic) + (1 if self.has_constant else 0)
        self.Minv = np.linalg.inv(self.M)
        A = self.A = self._augment(self.K, self.C, constant)
        self.normA = float(np.linalg.norm(A, 2))
        self.contacts = []
        for c in table["contact"]:
            g = c["gap"]
            a = (np.array([float(g.get(d, 0.0)) for d in dofs]) if isinstance(g, dict)
                 else np.array(g, float))
            ob = Obstacle(c.get("obstacle", "fixed"), c.get("kappa", 0.0), c.get("beta", 0.0),
                          c.get("omega", 0.0))
            self.contacts.append((c["name"], a, ob, float(c.get("r", 0.8))))
        self.names = [c[0] for c in self.contacts]
        # soft stops (the hybrid runs below): contact index -> (bit, k, c, kappa)
        self.soft = {}
        for i, c in enumerate(table["contact"]):
            if c.get("law", "impact") == "spring":
                self.soft[i] = (len(self.soft), float(c["k"]), float(c.get("c", 0.0)),
                                float(c.get("kappa", 0.0)))
        self.holdable = [not self.soft and c.get("law", "impact") == "impact"
                         and c.get("obstacle", "fixed") == "fixed" for c in table["contact"]]
        self._modes = {}
        rate = max([self.normA, 1.0] + [c[2].omega for c in self.contacts])
        self.dt = DT_RATE / rate
        self.E_steps = np.array([scipy.linalg.expm(A * (self.dt * j)) for j in range(BLOCK)])
        self.E_block = scipy.linalg.expm(A * (self.dt * BLOCK))
        self.rows = []
        for _, a, _, _ in self.contacts:
            c0 = np.zeros(m)
            c0[:n] = a
            c1 = c0 @ A
            c2 = c1 @ A
            self.rows.append((c0, c1, c2, float(np.linalg.norm(c2))))

    def _augment(self, K, C, constant):
        """The augmented matrix of M x'' + C x' + K x = the harmonic forces + ``constant``."""
        n, m, Minv = self.n, self.m, self.Minv
        A = np.zeros((m, m))
        A[:n, n:2 * n] = np.eye(n)
        A[n:2 * n, :n] = -Minv @ K
        A[n:2 * n, n:2 * n] = -Minv @ C
        for j, (on, F, Om, _) in enumerate(self.harmonic):
            ci, si = 2 * n + 2 * j, 2 * n + 2 * j + 1
            A[n:2 * n, ci] += Minv[:, on] * F
            A[ci, si] = -Om
            A[si, ci] = Om
        if self.has_constant:
            A[n:2 * n, m - 1] = Minv @ constant
        return A

    def state(self, t, x, v):
        ph = []
        for _, _, Om, phi in self.harmonic:
            ph += [math.cos(Om * t + phi), math.sin(Om * t + phi)]
        if self.has_constant:
            ph.append(1.0)
        return np.concatenate([np.asarray(x, float), np.asarray(v, float), np.array(ph)])

    def flow(self, y, s):
        """The state s later: expm(A s) y."""
        return scipy.linalg.expm(self.A * s) @ y

    def law(self, i, v_in, zp):
        """v+ of an impact on contact i with obstacle slope zp: the generalised Newton law."""
        _, a, _, r = self.contacts[i]
        d = np.linalg.solve(self.M, a)
        w = a @ v_in - zp
        return v_in - (1.0 + r) * w * d / (a @ d)


# ------------------------------------------------------------------ a flight and its gaps
class Flight:
    """The free flight from the state y_s at t_s, sampled up to t_e (module docstring)."""

    def __init__(self, system, t_s, y_s, t_e):
        s = self.s = system
        self.t_s, self.y_s = float(t_s), np.asarray(y_s, float)
        steps = max(1, math.ceil((t_e - t_s) / s.dt))
        nb = -(-(steps + 1) // BLOCK)
        Y = np.empty((nb * BLOCK, s.m))
        y = self.y_s
        for b in range(nb):
            Y[b * BLOCK:(b + 1) * BLOCK] = np.einsum("jkl,l->jk", s.E_steps, y)
            y = s.E_block @ y
        self.T = self.t_s + s.dt * np.arange(steps + 1)
        self.Y = Y[:steps + 1]
        self.t_e = float(self.T[-1])
        self._ints = {}
        self._analysed = {}

    def state_at(self, t):
        j = int(np.clip(math.floor((t - self.t_s) / self.s.dt), 0, len(self.T) - 1))
        return self.s.flow(self.Y[j], t - self.T[j])

    def gap_at(self, i, t, k=None):
        """Contact i's (g, g', g'') at time t, on piece k (default: the piece of t)."""
        c0, c1, c2, _ = self.s.rows[i]
        ob = self.s.contacts[i][2]
        y = self.state_at(t)
        k = ob.piece(t) if k is None else k
        z, z1, z2 = ob.z(t, k)
        return float(c0 @ y - z), float(c1 @ y - z1), float(c2 @ y - z2)

    def intervals(self, i):
        """Contact i's nodes (the uniform ones and its corners): times T, states Y, and per
        interval its piece, the gap's values at both ends and whether it is cleared."""
        if i in self._ints:
            return self._ints[i]
        s = self.s
        ob = s.contacts[i][2]
        T, Y = self.T, self.Y
        cs = ob.corners(self.t_s, self.t_e)
        if cs.size:
            j = np.clip(np.floor((cs - self.t_s) / s.dt).astype(np.int64), 0, len(T) - 1)
            Yc = np.array([s.flow(Y[jj], c - T[jj]) for jj, c in zip(j, cs)])
            # a uniform node within 1e-10 of a corner is dropped: the corner replaces it
            near = np.zeros(len(T), bool)
            pos = np.searchsorted(T, cs)
            for p in (pos - 1, pos):
                ok = (p >= 1) & (p < len(T) - 1)
                near[p[ok]] |= np.abs(T[p[ok]] - cs[ok]) < 1e-10
            keep = ~near
            T = np.concatenate([T[keep], cs])
            Y = np.concatenate([Y[keep], Yc])
            order = np.argsort(T, kind="stable")
            T, Y = T[order], Y[order]
        c0, c1, c2, nc2 = s.rows[i]
        k = ob.piece(0.5 * (T[:-1] + T[1:]))
        h = np.diff(T)
        ends = []
        for side in (slice(None, -1), slice(1, None)):
            z, z1, z2 = ob.z(T[side], k)
            ends.append((Y[side] @ c0 - z, Y[side] @ c1 - z1, Y[side] @ c2 - z2))
        ny = np.linalg.norm(Y, axis=1)
        G = nc2 * np.maximum(ny[:-1], ny[1:]) * np.exp(s.normA * h) + ob.zpp_max
        low = np.maximum(ends[0][0] - np.abs(ends[0][1]) * h, ends[1][0] - np.abs(ends[1][1]) * h) \
            - G * h * h / 2.0
        out = {"T": T, "Y": Y, "k": k, "h": h, "L": ends[0], "R": ends[1], "clear": low > 0.0,
               "G": G}
        self._ints[i] = out
        return out

    def _analyse(self, i, q):
        """Interval q of contact i resampled and cut into monotone stretches: a list of
        (t_left, t_right, g_left, g_right), the stretches in order, a cleared sub-interval
        as one stretch with g > 0 throughout (its g_left, g_right are its ends)."""
        key = (i, q)
        if key in self._analysed:
            return self._analysed[key]
        s = self.s
        iv = self.intervals(i)
        a, h, k, ya = iv["T"][q], iv["h"][q], iv["k"][q], iv["Y"][q]
        c0, c1, c2, nc2 = s.rows[i]
        ob = s.contacts[i][2]
        cache = s.__dict__.setdefault("_esub", {})      # the same h recurs: one expm for each
        E = cache.get(h)
        if E is None:
            E = cache[h] = scipy.linalg.expm(s.A * (h / SUB))
        U = np.empty((SUB + 1, s.m))
        U[0] = ya
        for j in range(SUB):
            U[j + 1] = E @ U[j]
        tu = a + h * np.arange(SUB + 1) / SUB
        tu[-1] = a + h
        z, z1, z2 = ob.z(tu, k)
        g0, g1, g2 = U @ c0 - z, U @ c1 - z1, U @ c2 - z2
        ny = np.linalg.norm(U, axis=1)
        hs = h / SUB

        def at(t, which):
            y = s.flow(ya, t - a)
            zz = ob.z(t, k)
            return float((c0, c1, c2)[which] @ y - zz[which])

        stretches = []
        for j in range(SUB):
            G = nc2 * max(ny[j], ny[j + 1]) * math.exp(s.normA * hs) + ob.zpp_max
            low = max(g0[j] - abs(g1[j]) * hs, g0[j + 1] - abs(g1[j + 1]) * hs) - G * hs * hs / 2
            u, v = tu[j], tu[j + 1]
            if low > 0.0:
                stretches.append((u, v, g0[j], g0[j + 1]))
                continue
            cuts = [(u, g1[j]), (v, g1[j + 1])]
            if g2[j] * g2[j + 1] < 0.0:
                ti = _root(lambda t: at(t, 2), u, v)
                if ti is not None:
                    cuts.insert(1, (ti, at(ti, 1)))
            pts = [u]
            for (l, dl), (r, dr) in zip(cuts[:-1], cuts[1:]):
                if dl * dr < 0.0:
                    tc = _root(lambda t: at(t, 1), l, r)
                    if tc is not None:
                        pts.append(tc)
                pts.append(r)
            pts = sorted(set(pts))
            gv = [g0[j]] + [at(t, 0) for t in pts[1:-1]] + [g0[j + 1]]
            stretches += [(pts[m], pts[m + 1], gv[m], gv[m + 1]) for m in range(len(pts) - 1)]
        self._analysed[key] = (stretches, lambda t: at(t, 0))
        return self._analysed[key]

    def scan(self, i, t_min_to=None):
        """Contact i over the flight: (its first event time or None, whether that event is
        a start that never rose above zero, the gap's least value over [t_s, t_min_to]
        (default: the whole flight), and its time).  A contact leaving at the start (g <= 0,
        g' > 0: the one just impacted) counts for the least value once it has risen above
        zero (its start is the last impact's, checked there)."""
        iv = self.intervals(i)
        t_min_to = self.t_e if t_min_to is None else t_min_to
        event, stuck = None, False
        gs, g1s = iv["L"][0][0], iv["L"][1][0]
        leaving = gs <= 0.0 and g1s > 0.0
        if gs <= 0.0 and not leaving:
            event = self.t_s
        above = not leaving
        # the nodes' values count for the least value wherever they lie
        Tn = np.concatenate([iv["T"][:-1], iv["T"][1:]])
        Gn = np.concatenate([iv["L"][0], iv["R"][0]])
        use = (Tn <= t_min_to) & ~(leaving & (Tn == self.t_s))
        gmin, tmin = math.inf, self.t_s
        if use.any():
            j = int(np.argmin(np.where(use, Gn, np.inf)))
            gmin, tmin = float(Gn[j]), float(Tn[j])
        for q in np.flatnonzero(~iv["clear"]):
            if event is not None and iv["T"][q] > t_min_to:
                break
            if not above and q > 0 and iv["clear"][:q].any():
                above = True             # a cleared interval has g > 0 throughout
            stretches, g = self._analyse(i, q)
            for (l, r, gl, gr) in stretches:
                if not above:
                    if gr > 0.0:
                        above = True     # risen past zero: left the contact
                    elif event is None and gr <= gl:
                        event, stuck = self.t_s, True
                    continue
                if l <= t_min_to:
                    # the least value over [l, min(r, t_min_to)]: the stretch is monotone
                    ge = gr if r <= t_min_to else g(t_min_to)
                    if min(gl, ge) < gmin:
                        gmin, tmin = (gl, l) if gl < ge else (ge, min(r, t_min_to))
                if event is not None:
                    continue
                if gl <= 0.0:
                    event = l
                elif gr <= 0.0:
                    event = _root(g, l, r)
                    event = r if event is None else event
            if event is not None and iv["T"][q] + iv["h"][q] >= t_min_to:
                break
        if not above and event is None:
            event, stuck = self.t_s, True
        if gmin == math.inf:
            gmin = 0.0
        return event, stuck, gmin, tmin

    def first_event(self, t_min_to=None):
        """The first event over all contacts: (contact, time, stuck), or None; and per
        contact (least gap up to t_min_to, its time)."""
        best, mins = None, []
        for i in range(len(self.s.contacts)):
            ev, stuck, gmin, tmin = self.scan(i, t_min_to)
            mins.append((gmin, tmin))
            if ev is not None and (best is None or ev < best[1]):
                best = (i, ev, stuck)
        return best, mins

    def local_minima(self, i, where):
        """Contact i's local minima (t, g) in time order: "smooth" (g' = 0 inside a piece,
        refined) or "corner" (a corner with g' < 0 before and > 0 after)."""
        iv = self.intervals(i)
        out = []
        if where == "corner":
            ob = self.s.contacts[i][2]
            for c in ob.corners(self.t_s, self.t_e):
                q = int(np.searchsorted(iv["T"], c))
                if q < 1 or q >= len(iv["T"]) - 1 or iv["T"][q] != c:
                    continue
                if iv["R"][1][q - 1] < 0.0 < iv["L"][1][q]:
                    out.append((float(c), float(iv["L"][0][q])))
            return out
        L1, R1 = iv["L"][1], iv["R"][1]
        for q in np.flatnonzero((L1 < 0.0) & (R1 > 0.0)):
            a, h, k, ya = iv["T"][q], iv["h"][q], iv["k"][q], iv["Y"][q]
            c0, c1, _, _ = self.s.rows[i]
            ob = self.s.contacts[i][2]

            def d1(t, c1=c1, ya=ya, a=a, ob=ob, k=k):
                return float(c1 @ self.s.flow(ya, t - a) - ob.z(t, k)[1])

            tm = _root(d1, a, a + h)
            if tm is None:
                continue
            y = self.s.flow(ya, tm - a)
            out.append((float(tm), float(c0 @ y - ob.z(tm, k)[0])))
        return out


# ------------------------------------------------------------------ random systems
def _spd(rng, n):
    if rng.random() < 0.4:
        return np.diag(rng.uniform(0.2, 3.0, n))
    L = rng.standard_normal((n, n))
    M = L @ L.T + np.diag(rng.uniform(0.2, 2.0, n))
    return 0.5 * (M + M.T)


def random_table(rng, n=None, nc=None):
    """A random [system] table: N = 1..4 coordinates, a random SPD mass (diagonal or full),
    a PSD stiffness of random rank (0 .. N: free masses included), damping sometimes (with a
    gyroscopic part sometimes), harmonic forces and a constant force (gravity) sometimes,
    1..3 contacts of random gap vectors, obstacle kinds, beta of either sign, omega, and r
    in [0, 1).  The contacts' kappa are 0 here (``random_case`` places them)."""
    n = int(rng.integers(1, 5)) if n is None else n
    dofs = [f"q{i}" for i in range(n)]
    M = _spd(rng, n)
    rank = int(rng.choice(n + 1))
    R = rng.standard_normal((n, rank)) * math.sqrt(rng.uniform(0.2, 4.0))
    K = R @ R.T if rank else np.zeros((n, n))
    K = 0.5 * (K + K.T)
    table = {"dofs": dofs, "mass": M.tolist(), "stiffness": K.tolist()}
    if rng.random() < 0.5:
        D = rng.standard_normal((n, n))
        C = (D @ D.T) * rng.uniform(0.005, 0.1)
        if rng.random() < 0.3:
            G = rng.standard_normal((n, n)) * 0.2
            C = C + (G - G.T)
        table["damping"] = C.tolist()
    forcing = []
    for _ in range(int(rng.choice([0, 1, 1, 2]))):
        forcing.append({"on": dofs[int(rng.integers(n))], "F": float(rng.uniform(0.1, 2.0)),
                        "Omega": float(rng.uniform(0.3, 4.0)), "phi": float(rng.uniform(0, 2 * math.pi))})
    if rng.random() < (0.7 if rank < n else 0.3):
        on = dofs[int(rng.integers(n))]
        forcing.append({"on": on, "F": float(rng.choice([-1, 1]) * rng.uniform(0.3, 2.0))})
    if forcing:
        table["forcing"] = forcing
    contacts = []
    for j in range(int(rng.integers(1, 4)) if nc is None else nc):
        u = rng.random()
        if u < 0.3 or n == 1:
            a = np.zeros(n)
            a[int(rng.integers(n))] = float(rng.choice([-1.0, 1.0]))
        elif u < 0.6:
            a = np.zeros(n)
            i, k = rng.choice(n, 2, replace=False)
            a[i], a[k] = 1.0, -1.0
        else:
            a = rng.standard_normal(n)
        kind = KINDS[int(rng.integers(len(KINDS)))]
        c = {"name": "ABC"[j], "gap": a.tolist(), "obstacle": kind, "kappa": 0.0,
             "r": float(rng.uniform(0.0, 1.0))}
        if kind != "fixed":
            c["beta"] = float(rng.choice([-1, 1]) * rng.uniform(0.02, 0.5))
            c["omega"] = float(rng.uniform(0.5, 5.0))
        contacts.append(c)
    table["contact"] = contacts
    return table


def place_contacts(table, t0, x0, v0, rng, span=10.0, only=None):
    """Each contact's kappa (of those in ``only``, default all) so that the gap starts
    positive and the flight without impacts would reach zero within ``span`` (kappa between
    the gap's start and its least value on the free flight, or just below the start where
    the gap only rises)."""
    s = System(table)
    fl = Flight(s, t0, s.state(t0, x0, v0), t0 + span)
    for i, c in enumerate(table["contact"]):
        if only is not None and i not in only:
            continue
        iv = fl.intervals(i)
        g = np.concatenate([iv["L"][0], iv["R"][0][-1:]]) + c["kappa"]      # kappa = 0
        g_start, g_min = float(g[0]), float(g.min())
        if g_start - g_min > 1e-3:
            c["kappa"] = g_start - rng.uniform(0.2, 0.95) * (g_start - g_min)
        else:
            c["kappa"] = g_start - rng.uniform(0.01, 0.5)
    return table


def random_case(seed):
    """(table, t0, x0, v0): a random system (``random_table``) and start, its contacts placed
    (``place_contacts``)."""
    rng = np.random.default_rng(seed)
    table = random_table(rng)
    n = len(table["dofs"])
    t0 = float(rng.uniform(0.0, 10.0))
    x0, v0 = rng.standard_normal(n).tolist(), rng.standard_normal(n).tolist()
    place_contacts(table, t0, x0, v0, rng)
    return table, t0, x0, v0


# ------------------------------------------------------------------ the kernel against it
def kernel(table, t0, x0, v0, count, t_max):
    """The kernel's run of the table's system: (its status's name, its impacts: the dict of
    ``run_system``)."""
    from cornerbif.models.linear import kernel as K
    from cornerbif.models.linear.declare import read_system
    system, problems = read_system(table)
    if problems:
        raise ValueError(problems)
    st, out = K.run_system(system, t0, np.asarray(x0, float), np.asarray(v0, float), count,
                           t_max=t_max)
    names = {K.OK: "OK", K.CHATTERS: "CHATTERS", K.BUDGET: "BUDGET", K.ESCAPED: "ESCAPED",
             K.NONFINITE: "NONFINITE"}
    return names.get(st, str(st)), out


def check_run(table, t0, x0, v0, count=10, t_max=None, span=30.0, run=None):
    """The kernel's run against the brute force, impact by impact (module docstring):
    a dict with the status, the impacts compared, the problems found (each a dict saying
    what, at which impact) and the worst differences.  ``run``: the kernel's (status,
    impacts) to check instead of running it (a test alters one to see this fail)."""
    t_max = t0 + span if t_max is None else t_max
    status, out = kernel(table, t0, x0, v0, count, t_max) if run is None else run
    s = System(table)
    res = {"status": status, "impacts": 0, "problems": [], "dt_worst": 0.0, "dt_gap_worst": 0.0,
           "early_depth": 0.0, "gap_at_impact": 0.0, "allowance_used": 0.0, "state_worst": 0.0,
           "law_worst": 0.0,
           "kernel_t": [float(t) for t in out["t"]], "kernel_contact": list(out["contact"]),
           "bf_t": [], "bf_contact": [], "flights": 0}
    if status in ("ESCAPED", "NONFINITE"):
        return res
    norms = [float(np.linalg.norm(c[1])) for c in s.contacts]

    def allowance(fl, t_end, y_end):
        """The gaps' allowance over the flight, per unit of (1 + |a| |y|); |y| its size."""
        size = max(np.abs(fl.y_s[:2 * s.n]).max(), np.abs(y_end[:2 * s.n]).max())
        return EPS_GAP + DRIFT * s.normA * (t_end - fl.t_s), size

    def misses(fl, mins, t_end, y_end, where):
        """Every contact's least gap over the flight against its allowance."""
        eps, size = allowance(fl, t_end, y_end)
        worst = None
        for j, (g, at) in enumerate(mins):
            rel = -g / (1.0 + norms[j] * size)
            res["early_depth"] = max(res["early_depth"], rel)
            res["allowance_used"] = max(res["allowance_used"], rel / eps)
            if rel > eps and (worst is None or rel > worst[0]):
                worst = (rel, j, g, at)
        if worst is not None:
            res["problems"].append(dict(where, what="missed", contact_missed=s.names[worst[1]],
                                        gap=worst[2], at=worst[3], allowance=eps))
        res["flights"] += 1
        return eps, size

    t, y = float(t0), s.state(t0, x0, v0)
    for k in range(len(out["t"])):
        tk, ck = float(out["t"][k]), s.names.index(out["contact"][k])
        fl = Flight(s, t, y, tk + 4 * s.dt)
        ev, mins = fl.first_event(t_min_to=tk)
        res["bf_t"].append(None if ev is None else float(ev[1]))
        res["bf_contact"].append(None if ev is None else s.names[ev[0]])
        where = {"impact": k, "t": tk, "contact": out["contact"][k],
                 "bf_event": None if ev is None else float(ev[1]),
                 "bf_contact": None if ev is None else s.names[ev[0]]}
        yb = fl.state_at(tk)
        eps, size = misses(fl, mins, tk, yb, where)
        gk, g1k, _ = fl.gap_at(ck, tk)
        rel = gk / (1.0 + norms[ck] * size)
        res["gap_at_impact"] = max(res["gap_at_impact"], abs(rel))
        res["allowance_used"] = max(res["allowance_used"], rel / eps)
        if rel > eps:
            res["problems"].append(dict(where, what="no contact there", gap=gk, allowance=eps))
        if ev is not None and ev[0] == ck:
            dt = abs(float(ev[1]) - tk)
            res["dt_worst"] = max(res["dt_worst"], dt)
            res["dt_gap_worst"] = max(res["dt_gap_worst"], dt * abs(g1k) / (1.0 + norms[ck] * size))
        # the state there and the law
        x_k, vin_k, vout_k = out["x"][k], out["v_in"][k], out["v_out"][k]
        n = s.n
        dstate = max(np.abs(yb[:n] - x_k).max(), np.abs(yb[n:2 * n] - vin_k).max()) / (1.0 + size)
        res["state_worst"] = max(res["state_worst"], dstate)
        if dstate > STATE_TOL:
            res["problems"].append(dict(where, what="state", diff=dstate))
        ob = s.contacts[ck][2]
        kp = int(ob.piece(tk))
        corner = ob.spacing is not None and min(abs(tk - kk * ob.spacing) for kk in (kp, kp + 1)) < 1e-9
        sides = [kp, kp - 1, kp + 1] if corner else [kp]     # at a corner: either side's z'
        dlaw = min(np.abs(s.law(ck, vin_k, float(ob.z(tk, kk)[1])) - vout_k).max() for kk in sides)
        dlaw /= 1.0 + np.abs(vin_k).max()
        res["law_worst"] = max(res["law_worst"], dlaw)
        if dlaw > LAW_TOL:
            res["problems"].append(dict(where, what="law", diff=dlaw))
        res["impacts"] += 1
        t, y = tk, s.state(tk, x_k, vout_k)
    if status == "BUDGET" and t < t_max:
        fl = Flight(s, t, y, t_max)
        ev, mins = fl.first_event(t_min_to=t_max)
        where = {"impact": len(out["t"]), "t": None, "contact": None,
                 "after": "the last impact, to t_max", "bf_event": None if ev is None else float(ev[1])}
        misses(fl, mins, t_max, fl.state_at(t_max), where)
    return res


# ------------------------------------------------------------------ grazing flights
GRAZE_DEPTHS = (1e-6, 1e-8, 1e-10, 1e-11, 1e-12)


def graze_plan(g):
    """The g-th grazing flight's (where, delta): smooth and corner in turn, then each depth
    of GRAZE_DEPTHS, then a dip (delta < 0) and a clearance: every 20 cover all."""
    where = ("smooth", "corner")[g % 2]
    depth = GRAZE_DEPTHS[(g // 2) % len(GRAZE_DEPTHS)]
    return where, (-depth if (g // (2 * len(GRAZE_DEPTHS))) % 2 == 0 else depth)


def graze_case(seed, delta, where, tries=30):
    """A flight that grazes contact A with least gap ``delta`` (< 0: a dip of that depth, an
    impact to be found; > 0: a clearance, no impact), at a smooth point of the gap
    (``where`` = "smooth") or at a corner of the obstacle ("corner": a rectified sine with
    beta < 0 or a triangle, whose corners point up).  A random system and start
    (``random_table``); contact A's kappa shifted so that its first low point on the free
    flight (below every earlier value of its gap by 1e-3) sits at delta; the other contacts'
    kappa put 0.2 below their least gap on the flight.  Returns a dict (table, t0, x0, v0;
    t_graze; dip: its ends (t_left, t_right) for a dip, else None; window: the times where
    a kernel's impact counts as this graze's: the dip's ends widened by their distance and
    1e-9 (a dip), or where the gap is below about 5 delta (a clearance at a smooth point:
    2 sqrt(2 delta / |g''|) either side; at a corner: 1e-6)), or None when no try gave one."""
    rng = np.random.default_rng(seed)
    for _ in range(tries):
        table = random_table(rng)
        c = table["contact"][0]
        if where == "corner":
            c["obstacle"] = ["rectified_sine", "triangle"][int(rng.integers(2))]
            c["omega"] = float(rng.uniform(0.5, 5.0))
            c["beta"] = float(rng.uniform(0.02, 0.5)) * (-1.0 if c["obstacle"] == "rectified_sine"
                                                         else float(rng.choice([-1, 1])))
        n = len(table["dofs"])
        t0 = float(rng.uniform(0.0, 10.0))
        x0, v0 = rng.standard_normal(n).tolist(), rng.standard_normal(n).tolist()
        span = 8.0
        s = System(table)
        fl = Flight(s, t0, s.state(t0, x0, v0), t0 + span)
        for j in range(1, len(table["contact"])):
            iv = fl.intervals(j)
            table["contact"][j]["kappa"] = float(min(iv["L"][0].min(), iv["R"][0].min())) - 0.2
        iv = fl.intervals(0)
        for tm, gm in fl.local_minima(0, where):
            if tm < t0 + 0.1 or tm > t0 + span - 0.5:
                continue
            before = iv["T"][:-1] < tm - 1e-9
            # the valley of tm: back from tm while the gap falls towards it
            q = int(np.searchsorted(iv["T"], tm)) - 1
            while q > 0 and iv["L"][1][q] < 0.0:
                q -= 1
            earlier = before & (np.arange(len(before)) < q)
            if earlier.any() and iv["L"][0][earlier].min() < gm + 1e-3:
                continue
            if not earlier.any() and iv["L"][0][0] < gm + 1e-3:
                continue
            c["kappa"] = float(c["kappa"] + (gm - delta))
            s2 = System(table)
            fl2 = Flight(s2, t0, s2.state(t0, x0, v0), tm + 0.5)
            dip = _dip(fl2, tm) if delta < 0 else None
            ev, mins = fl2.first_event(t_min_to=tm + 1e-6)
            if delta < 0:
                ok = dip is not None and ev is not None and ev[0] == 0 and abs(ev[1] - dip[0]) <= 1e-9
            else:
                ok = (ev is None or ev[1] > tm + 1e-6) and min(m[0] for m in mins) >= 0.5 * delta
            if ok:
                if dip is not None:
                    w = dip[1] - dip[0] + 1e-9
                    window = (dip[0] - w, dip[1] + w)
                elif where == "smooth":
                    w = 2.0 * math.sqrt(2.0 * delta / max(abs(fl2.gap_at(0, tm)[2]), 1e-300)) + 1e-9
                    window = (tm - w, tm + w)
                else:
                    window = (tm - 1e-6, tm + 1e-6)
                return {"table": table, "t0": t0, "x0": x0, "v0": v0, "t_graze": tm,
                        "dip": dip, "window": window}
            c["kappa"] = 0.0
        # try another system
    return None


def _dip(fl, tm):
    """The ends (t_left, t_right) of contact 0's dip below zero around its low point tm."""
    ends = []
    for sign in (-1.0, 1.0):
        w = 1e-12
        while w < 0.5 and fl.gap_at(0, tm + sign * w)[0] <= 0.0:
            w *= 2.0
        if w >= 0.5:
            return None
        ends.append(_root(lambda t: fl.gap_at(0, t)[0], *sorted((tm, tm + sign * w))))
    return None if None in ends else (ends[0], ends[1])


PROBE = 1e-8          # the depth of the dip that measures the kernel's flight at a graze


def kernel_gap_error(case, delta):
    """The kernel's own error in contact A's gap near the graze: the graze made a dip of
    PROBE, the kernel's state at its impact there against the brute force's flight at the
    same time, a . (x_kernel - x_bf) (z is the same function of time).  None when the probe's
    first impact is not contact A's near the graze."""
    table = {**case["table"], "contact": [dict(c) for c in case["table"]["contact"]]}
    table["contact"][0]["kappa"] += PROBE + delta          # least gap delta -> -PROBE
    t0, x0, v0, tm = case["t0"], case["x0"], case["v0"], case["t_graze"]
    _, out = kernel(table, t0, x0, v0, 1, tm + 0.5)
    if not len(out["t"]) or out["contact"][0] != "A" or abs(out["t"][0] - tm) > 1e-3:
        return None
    s = System(table)
    y = Flight(s, t0, s.state(t0, x0, v0), tm + 0.5).state_at(float(out["t"][0]))
    return float(s.contacts[0][1] @ (out["x"][0] - y[:s.n]))


def check_graze(seed, delta, where):
    """A grazing flight (``graze_case``) through the kernel: (the case or None, the graze's
    verdict dict, the run's ``check_run`` dict).  The verdict: a dip (delta < 0) must be the
    kernel's first impact, on contact A, within the case's window; a clearance (delta > 0)
    must not be an impact of contact A within its window.  Decided the other way, the
    kernel's own error in the gap there is measured (``kernel_gap_error``): where it is at
    least half the graze's depth, in the direction that explains the decision, the graze was
    decided by the kernel's rounding (docs/linear.md, "The certification's limits": its
    flights drift by about 1e-12), ``rounding`` in the verdict; otherwise ``wrong``."""
    case = graze_case(seed, delta, where)
    if case is None:
        return None, None, None
    lo, hi = case["window"]
    res = check_run(case["table"], case["t0"], case["x0"], case["v0"], count=3,
                    t_max=case["t_graze"] + 0.5)
    kt, kc = res["kernel_t"], res["kernel_contact"]
    v = {"delta": delta, "where": where, "t_graze": case["t_graze"], "window": case["window"],
         "ok": True, "dt": None, "rounding": False, "wrong": False}
    if delta < 0:
        v["ok"] = bool(kt) and kc[0] == "A" and lo <= kt[0] <= hi
        if kt:
            v["dt"] = abs(kt[0] - case["dip"][0])           # from the dip's first root
    else:
        v["ok"] = not any(c == "A" and lo <= t <= hi for t, c in zip(kt, kc))
    if not v["ok"]:
        v["what"] = "dip missed" if delta < 0 else "impact on a clearance"
        e = v["kernel_gap_error"] = kernel_gap_error(case, delta)
        v["rounding"] = e is not None and (e >= 0.5 * abs(delta) if delta < 0 else e <= -0.5 * delta)
        v["wrong"] = not v["rounding"]
    v["case"] = {k: case[k] for k in ("table", "t0", "x0", "v0")}
    return case, v, res


# ------------------------------------------------------------------ hybrid runs: soft stops, holds
# (docs/linear.md, "Soft stops" and "Sticking"; the check's design is ``check_hybrid``'s)
class Mode:
    """One flight of a hybrid system and its surfaces, in the shape ``Flight`` reads: the
    matrix A of the flight that acts (a set of soft stops acting, or one contact held) and
    per contact the "gap" searched in that flight (name, row c0 on the augmented state,
    Obstacle): a hard contact's gap a . x - z(t); a soft stop outside, g = a . x - kappa; a
    soft stop acting, -g = (-a) . x - (-kappa) (its exit is -g reaching 0 from above); the
    held contact, its contact force as an acceleration along the unit normal,
    l = -(a . x''_free) / |a| (the free flight's acceleration rows: l < 0 pulls, a release)."""

    def __init__(self, s, act, hold):
        n, m = s.n, s.m
        self.n, self.m, self.act, self.hold = n, m, act, hold
        if hold >= 0:
            A0 = s.A
            a = s.contacts[hold][1]
            d = s.Minv @ a
            acc = a @ A0[n:2 * n, :]                       # a . x'' of the free flight
            A = A0.copy()
            A[n:2 * n, :] = A0[n:2 * n, :] - np.outer(d, acc) / (a @ d)   # P M^-1 (forces)
        elif act:
            K, C, constant = s.K.copy(), s.C.copy(), s.constant.copy()
            for i, (b, k, c, kappa) in s.soft.items():
                if act >> b & 1:
                    a = s.contacts[i][1]
                    K += k * np.outer(a, a)
                    C += c * np.outer(a, a)
                    constant += k * kappa * a
            A = s._augment(K, C, constant)
        else:
            A = s.A
        self.A = A
        self.normA = float(np.linalg.norm(A, 2))
        self.contacts, self.rows, self.norms = [], [], []
        for i, (name, a, ob, r) in enumerate(s.contacts):
            c0 = np.zeros(m)
            if i == hold:
                c0 = -(a @ s.A[n:2 * n, :]) / np.linalg.norm(a)
                ob = Obstacle("fixed", 0.0)
            elif i in s.soft and act >> s.soft[i][0] & 1:
                c0[:n] = -a
                ob = Obstacle("fixed", -ob.kappa)
            else:
                c0[:n] = a
            self.contacts.append((name, c0[:n], ob, r))
            c1 = c0 @ A
            c2 = c1 @ A
            self.rows.append((c0, c1, c2, float(np.linalg.norm(c2))))
            self.norms.append(float(np.linalg.norm(c0)))
        rate = max([self.normA, 1.0] + [c[2].omega for c in self.contacts])
        self.dt = DT_RATE / rate
        self.E_steps = np.array([scipy.linalg.expm(A * (self.dt * j)) for j in range(BLOCK)])
        self.E_block = scipy.linalg.expm(A * (self.dt * BLOCK))

    def flow(self, y, s):
        return scipy.linalg.expm(self.A * s) @ y


def mode(s, act, hold):
    """The system's flight with the soft stops ``act`` acting (bit b: soft stop b) or contact
    ``hold`` held (-1: none), memoised on the System."""
    key = (act, hold)
    if key not in s._modes:
        s._modes[key] = Mode(s, act, hold)
    return s._modes[key]


def initial_act(s, x):
    """The soft stops acting at a start: those with g = a . x - kappa < 0."""
    return sum(1 << b for i, (b, _, _, kappa) in s.soft.items() if s.contacts[i][1] @ x - kappa < 0.0)


class Segment:
    """The flight of mode ``md`` from (t, y) sampled to t_e, each surface's ``Flight`` (a
    surface in ``late`` {i: t_i} is searched from t_i on: the contact just released, whose
    gap rises as g''' s^3 / 6 from its release, cleared up to t_i by a bound)."""

    def __init__(self, md, t, y, t_e, late=None):
        self.md, self.t = md, t
        self.fl = Flight(md, t, y, t_e)
        self.fls = []
        for i in range(len(md.contacts)):
            tl = (late or {}).get(i)
            if tl is None or tl <= t:
                self.fls.append(self.fl)
            else:
                self.fls.append(Flight(md, tl, self.fl.state_at(tl), max(t_e, tl + md.dt)))

    def first(self, t_min_to):
        """The first event (surface, time), or None, and each surface's least value up to
        t_min_to (value, time)."""
        best, mins = None, []
        for i, f in enumerate(self.fls):
            if f.t_s > t_min_to:
                ev, gmin, tmin = None, math.inf, f.t_s
            else:
                ev, _, gmin, tmin = f.scan(i, t_min_to)
            mins.append((gmin, tmin))
            if ev is not None and (best is None or ev < best[1]):
                best = (i, ev)
        return best, mins


def release_clearance(md_free, i, y):
    """After a release of contact i at state y (g, g', g'' zero): g(s) >= g''' s^3 / 6 -
    B4 s^4 / 24 >= g''' s^3 / 12 > 0 for s <= 2 g''' / B4 (B4 = |c A^4| |y| e^(|A| s)
    bounds g''''), capped at the node spacing: (that step, g''')."""
    c0 = md_free.rows[i][0]
    A = md_free.A
    c3 = c0 @ A @ A @ A
    c4 = c3 @ A
    g3 = float(c3 @ y)
    if not g3 > 0.0:
        return None, g3
    B4 = float(np.linalg.norm(c4) * np.linalg.norm(y) * math.exp(md_free.normA * md_free.dt))
    return min(md_free.dt, 2.0 * g3 / B4), g3


def _w(s, i, t, v):
    """Contact i's approach speed w = a . v - z'(t) (either side's z' at a corner: the
    side with the smaller |w|, the law checked on both)."""
    a, ob = s.contacts[i][1], s.contacts[i][2]
    return float(a @ v - ob.z(t, ob.piece(t))[1])


def check_hybrid(table, t0, x0, v0, count=10, t_max=None, span=30.0, run=None, chatter=1e-6,
                 max_switches=400):
    """The kernel's run of a system with soft stops, or one that sticks, against the brute
    force, event by event (docs/linear.md, "Certified events"; the design):

    The kernel records impacts, soft-stop entries (v+ = v-) and the impacts that start a
    hold; it records neither exits nor releases.  The brute force therefore runs the hybrid
    system itself between two recorded events: restarted from the kernel's state just after
    recorded event k - 1, in the mode that event implies (the soft stops acting: the set
    before, with an entry's stop added; held: the brute force's own decision at that impact,
    from -r w- <= chatter and the contact force after the law with r = 0 being > 0), it
    finds the first crossing of every surface of that mode (``Mode``: a hard gap, a soft
    stop's g outside, -g inside, the held contact's force) with ``Flight``'s search.  A
    crossing of an unrecorded kind (an exit, a release) before the kernel's next recorded
    event is taken by the brute force itself: it switches mode at its own root, from its own
    state, and searches on (a released contact from the bound of ``release_clearance``).  The
    first crossing of a recorded kind must be the kernel's event k:

    * nothing missed: over [t_(k-1), t_k], through the brute force's own switches, every
      surface stays >= -eps (eps: ``check_run``'s allowance, on the row's norm and the
      flight's length from t_(k-1) in chunks of the largest |A| of the modes flown).  So an
      entry the kernel missed is a stop's g below -eps; an exit the kernel missed (it goes on
      inside) shows as the brute force's re-entry (a missed entry), or as a state that is
      not the brute force's at event k; a release it missed, as the contact's next impact
      (missed) or the state; a spurious exit, as an entry recorded where the brute force is
      inside ("entry while inside"); a spurious release, as an impact of the held contact;
    * each recorded event is real: its surface (in the brute force's mode) is within eps of
      0 at t_k; an entry is of a stop outside; v_out = v_in for an entry, the Newton law
      (r, or r = 0 where the brute force holds) for an impact; the state is the brute force's;
    * a run that ends on its time budget (BUDGET, or CHATTERS while held) has nothing
      recorded-kind after its last event up to t_max, through the brute force's own
      exits and releases; a run that ends CHATTERS otherwise ends at a chatter the brute
      force cannot hold.

    Returns a dict of counts (events, entries, impacts, holds, and the brute force's exits
    and releases), worst differences and problems."""
    t_max = t0 + span if t_max is None else t_max
    status, out = kernel(table, t0, x0, v0, count, t_max) if run is None else run
    s = System(table)
    res = {"status": status, "events": 0, "entries": 0, "impacts": 0, "holds": 0, "exits": 0,
           "releases": 0, "problems": [], "early_depth": 0.0, "gap_at_event": 0.0,
           "allowance_used": 0.0, "state_worst": 0.0, "law_worst": 0.0, "dt_worst": 0.0,
           "kernel_t": [float(t) for t in out["t"]], "kernel_contact": list(out["contact"]),
           "switches": []}
    if status in ("ESCAPED", "NONFINITE"):
        return res
    n = s.n
    t, y = float(t0), s.state(t0, x0, v0)
    act, hold, late = initial_act(s, np.asarray(x0, float)), -1, {}
    free = mode(s, 0, -1)
    K = len(out["t"])
    ended_chatter = False
    for k in range(K + 1):
        tail = k == K
        if tail and not (status == "BUDGET" or (status == "CHATTERS" and hold >= 0)):
            if status == "CHATTERS" and not ended_chatter:
                res["problems"].append({"event": k, "what": "status", "status": status,
                                        "why": "CHATTERS, but the brute force does not see the "
                                               "last impact chatter unheld"})
            break
        tk = t_max if tail else float(out["t"][k])
        t_last, size, normA, switches = t, float(np.abs(y[:2 * n]).max()), 0.0, []
        where = {"event": k, "t": None if tail else tk,
                 "contact": None if tail else out["contact"][k]}
        aborted = False
        while True:
            md = mode(s, act, hold)
            normA = max(normA, md.normA)
            t_we = min(tk, t + WINDOW * md.dt)           # flown a window at a time
            seg = Segment(md, t, y, t_we + 4 * md.dt, late)
            ev, _ = seg.first(t)
            unrecorded = ev is not None and (ev[0] == hold
                                             or (ev[0] in s.soft and act >> s.soft[ev[0]][0] & 1))
            if unrecorded and ev[1] < tk and ev[1] <= t_we and len(switches) < max_switches:
                # an exit or a release before the kernel's next event: the brute force's own
                i, te = ev
                _, mins = seg.first(te)
                ye = seg.fls[i].state_at(te)
                size = max(size, float(np.abs(ye[:2 * n]).max()))
                _misses(res, md, mins, s, size, t_last, te, normA, dict(where, switches=list(switches)))
                switches.append(("exit" if hold < 0 else "release", s.names[i], te))
                t, y, late = te, ye, {}
                if hold >= 0:
                    hold = -1
                    res["releases"] += 1
                    step, g3 = release_clearance(free, i, ye)
                    if step is None:
                        res["problems"].append(dict(where, what="degenerate release", g3=g3, at=te))
                        step = free.dt
                    late = {i: te + step}
                else:
                    act ^= 1 << s.soft[i][0]
                    res["exits"] += 1
                continue
            _, mins = seg.first(t_we)
            yk = seg.fl.state_at(t_we)
            size = max(size, float(np.abs(yk[:2 * n]).max()))
            before = len(res["problems"])
            eps = _misses(res, md, mins, s, size, t_last, t_we, normA, dict(where, switches=list(switches)))
            if t_we < tk:
                if len(res["problems"]) > before:
                    aborted = True          # a miss: the brute force cannot go on past it
                    break
                t, y = t_we, yk
                late = {i: tl for i, tl in late.items() if tl > t_we}
                continue
            break
        res["switches"].append(switches)
        if tail or aborted:
            break
        # the recorded event k
        ck = s.names.index(out["contact"][k])
        x_k, vin_k, vout_k = (np.asarray(out[key][k], float) for key in ("x", "v_in", "v_out"))
        f = seg.fls[ck]
        obk = md.contacts[ck][2]
        gk = float(md.rows[ck][0] @ f.state_at(tk) - obk.z(tk, obk.piece(tk))[0])
        rel = gk / (1.0 + md.norms[ck] * size)
        res["gap_at_event"] = max(res["gap_at_event"], abs(rel))
        res["allowance_used"] = max(res["allowance_used"], rel / eps)
        if rel > eps:
            res["problems"].append(dict(where, what="no contact there", gap=gk, allowance=eps))
        if ev is not None and ev[0] == ck:
            res["dt_worst"] = max(res["dt_worst"], abs(ev[1] - tk))
        dstate = max(np.abs(yk[:n] - x_k).max(), np.abs(yk[n:2 * n] - vin_k).max()) / (1.0 + size)
        res["state_worst"] = max(res["state_worst"], dstate)
        if dstate > STATE_TOL:
            res["problems"].append(dict(where, what="state", diff=dstate))
        scale = 1.0 + np.abs(vin_k).max()
        if ck == hold:
            res["problems"].append(dict(where, what="an impact of the held contact (a release missed "
                                                    "or spurious)"))
        if ck in s.soft:
            if act >> s.soft[ck][0] & 1:
                res["problems"].append(dict(where, what="entry while inside (an exit the brute force "
                                                        "does not have)"))
            dlaw = np.abs(vout_k - vin_k).max() / scale
            act |= 1 << s.soft[ck][0]
            res["entries"] += 1
        else:
            was_held = hold
            hold = -1                       # an impact releases a held contact
            ob = s.contacts[ck][2]
            kp = int(ob.piece(tk))
            corner = ob.spacing is not None and min(abs(tk - kk * ob.spacing) for kk in (kp, kp + 1)) < 1e-9
            sides = [kp, kp - 1, kp + 1] if corner else [kp]
            r = s.contacts[ck][3]
            best = None
            for kk in sides:
                zp = float(ob.z(tk, kk)[1])
                w = float(s.contacts[ck][1] @ vin_k - zp)
                chat = -r * w <= chatter
                near = abs(-r * w - chatter) <= 1e-9 * chatter      # the kernel's rounding decides
                v_r = s.law(ck, vin_k, zp)
                dk = s.Minv @ s.contacts[ck][1]
                v_0 = vin_k - w * dk / (s.contacts[ck][1] @ dk)        # the law with r = 0
                lam = None
                if chat and s.holdable[ck] and was_held < 0:
                    lam = float(mode(s, 0, ck).rows[ck][0] @ s.state(tk, x_k, v_0))
                holds = lam is not None and lam > 0.0
                options = [(holds, v_0 if holds else v_r, chat)]
                if near or (lam is not None and abs(lam) <= 1e-9 * (1.0 + np.abs(x_k).max())):
                    options.append((not holds, v_r if holds else v_0, chat))
                for hh, vv, cc in options:
                    d = np.abs(vv - vout_k).max() / scale
                    if best is None or d < best[0]:
                        best = (d, hh, cc)
            dlaw, holds, chat = best
            if holds:
                hold = ck
                res["holds"] += 1
            elif chat:
                # a chatter that is not held (or a second contact's while one is held): the
                # kernel ends the run there, CHATTERS
                ended_chatter = True
                if k != K - 1 or status != "CHATTERS":
                    res["problems"].append(dict(where, what="a chatter the kernel went past unheld"))
            res["impacts"] += 1
        res["law_worst"] = max(res["law_worst"], dlaw)
        if dlaw > LAW_TOL:
            res["problems"].append(dict(where, what="law", diff=dlaw))
        res["events"] += 1
        t, y, late = tk, s.state(tk, x_k, vout_k), {}
    return res


def _misses(res, md, mins, s, size, t_last, t_end, normA, where):
    """Every surface's least value over the flight (``mins``) against the allowance; a miss
    recorded as a problem.  Returns the allowance (per unit of 1 + |c0| |y|)."""
    eps = EPS_GAP + DRIFT * normA * (t_end - t_last)
    worst = None
    for j, (g, at) in enumerate(mins):
        if g == math.inf:
            continue
        rel = -g / (1.0 + md.norms[j] * size)
        res["early_depth"] = max(res["early_depth"], rel)
        res["allowance_used"] = max(res["allowance_used"], rel / eps)
        if rel > eps and (worst is None or rel > worst[0]):
            worst = (rel, j, g, at)
    if worst is not None:
        j = worst[1]
        kind = ("release" if j == md.hold else
                "exit" if j in s.soft and md.act >> s.soft[j][0] & 1 else
                "entry" if j in s.soft else "impact")
        res["problems"].append(dict(where, what="missed", missed=f"{kind} of {s.names[j]}", gap=worst[2],
                                    at=worst[3], allowance=eps))
    return eps


# ------------------------------------------------------------------ random hybrid systems
def soften(c, rng):
    """Contact table ``c`` made a soft stop: law "spring" on its fixed obstacle, k
    log-uniform in [1, 100], c = 0 (a third of them) or up to 0.5."""
    for key in ("beta", "omega", "r"):
        c.pop(key, None)
    c["obstacle"] = "fixed"
    c["law"] = "spring"
    c["k"] = float(math.exp(rng.uniform(0.0, math.log(100.0))))
    c["c"] = 0.0 if rng.random() < 1 / 3 else float(rng.uniform(0.0, 0.5))
    return c


def random_soft_case(seed):
    """(table, t0, x0, v0): a random system (``random_table``: N = 1..4) with 1..3 contacts,
    all soft stops (half of them) or all but one hard contact of any obstacle kind, placed as
    ``place_contacts`` places them (the free flight reaches each)."""
    rng = np.random.default_rng(seed)
    table = random_table(rng)
    cs = table["contact"]
    ns = len(cs) if (len(cs) == 1 or rng.random() < 0.5) else len(cs) - 1
    for c in cs[:ns]:
        soften(c, rng)
    n = len(table["dofs"])
    t0 = float(rng.uniform(0.0, 10.0))
    x0, v0 = rng.standard_normal(n).tolist(), rng.standard_normal(n).tolist()
    place_contacts(table, t0, x0, v0, rng)
    return table, t0, x0, v0


def random_stick_case(seed):
    """(table, t0, x0, v0): a random system that lands on a fixed stop and can stick there: N =
    1..3, a random SPD mass, a PSD stiffness of random rank, damping sometimes; contact A a
    fixed stop on one coordinate (its sign random) with r = 0 (two fifths) or r in (0, 0.4)
    (a chatter to rest), a constant force pressing into it and a harmonic force on the same
    coordinate of up to 2.5 times that (releasing it, or not); a second fixed stop of any
    gap vector sometimes (r in [0, 1))."""
    rng = np.random.default_rng(seed)
    n = int(rng.integers(1, 4))
    table = random_table(rng, n=n, nc=int(rng.choice([1, 1, 2])))
    j = int(rng.integers(n))
    sign = float(rng.choice([-1.0, 1.0]))
    a = np.zeros(n)
    a[j] = sign
    for c in table["contact"]:
        c.pop("beta", None)
        c.pop("omega", None)
        c["obstacle"] = "fixed"
    A = table["contact"][0]
    A["gap"] = a.tolist()
    A["r"] = 0.0 if rng.random() < 0.4 else float(rng.uniform(0.0, 0.4))
    Fg = float(rng.uniform(0.5, 2.0))
    table["forcing"] = [{"on": f"q{j}", "F": -sign * Fg},
                        {"on": f"q{j}", "F": float(rng.uniform(0.0, 2.5) * Fg),
                         "Omega": float(rng.uniform(0.5, 3.0)), "phi": float(rng.uniform(0, 2 * math.pi))}]
    t0 = float(rng.uniform(0.0, 10.0))
    x0, v0 = rng.standard_normal(n).tolist(), rng.standard_normal(n).tolist()
    place_contacts(table, t0, x0, v0, rng)
    return table, t0, x0, v0


# ------------------------------------------------------------------ hybrid grazes
HYBRID_GRAZES = ("entry", "exit", "release")


def _first_low(fl, i, margin=1e-3):
    """Surface i's first smooth low point (t, value) on flight ``fl`` that lies below every
    earlier value (its valley's included) by ``margin``, at least 0.1 after the start and
    0.5 before the flight's end; None when there is none."""
    iv = fl.intervals(i)
    for tm, gm in fl.local_minima(i, "smooth"):
        if tm < fl.t_s + 0.1 or tm > fl.t_e - 0.5:
            continue
        q = int(np.searchsorted(iv["T"], tm)) - 1
        while q > 0 and iv["L"][1][q] < 0.0:
            q -= 1
        if q == 0 or iv["L"][0][:q].min() < gm + margin or iv["L"][0][0] < gm + margin:
            continue
        return float(tm), float(gm)
    return None


def _dip_of(fl, i, tm):
    """The ends of surface i's dip below zero around its low point tm (``_dip`` for any
    surface)."""
    def g(t):
        return fl.gap_at(i, t)[0]
    ends = []
    for sign in (-1.0, 1.0):
        w = 1e-12
        while w < 0.5 and g(tm + sign * w) <= 0.0:
            w *= 2.0
        if w >= 0.5:
            return None
        ends.append(_root(g, *sorted((tm, tm + sign * w))))
    return None if None in ends else (ends[0], ends[1])


def _force_along(table, a, mu):
    """A constant force mu a added to the table's forcing (one entry per coordinate)."""
    table.setdefault("forcing", [])
    for j, aj in enumerate(a):
        if aj != 0.0:
            table["forcing"].append({"on": table["dofs"][j], "F": float(mu * aj)})


def hybrid_graze_case(seed, kind, delta, tries=40, span=8.0):
    """A flight whose surface of contact A has its least value at ``delta`` (< 0: a dip of
    that depth, an event to be found; > 0: a clearance), the first low point of that
    surface after the start (every earlier value above it by 1e-3):

    * "entry": A a soft stop, outside; its gap g on the free flight (as ``graze_case``:
      kappa shifted, which moves g alone);
    * "exit": A a soft stop, the start inside it (g0 in [-1, -0.3]); -g on the flight with
      its spring acting.  A constant force mu a (along the stop's normal) moves the mode's
      equilibrium by dx = K'^-1 mu a (K' = K + k a a^T, invertible: tries without are
      skipped); the start moved by dx too, the whole flight moves by dx, and g by
      mu a^T K'^-1 a: -g shifted without changing its shape;
    * "release": A a fixed stop with r = 0 and a constant force pressing into it (the
      systems of ``random_stick_case``), the start on the stop (g0 = 0) with a . v0 < 0:
      an impact at once that holds (the brute force's contact force after it > 0).  A
      constant force mu a changes neither the held motion (the constraint takes it whole:
      P M^-1 a = 0) nor the impact law, and moves the contact force l (``Mode``) by
      -mu a^T M^-1 a / |a|: l shifted without changing its shape.

    Returns a dict (table, t0, x0, v0, kind, surface mode (act, hold), t_graze, dip: its
    ends for a dip, window: where a kernel's event counts as this graze's), or None."""
    rng = np.random.default_rng(seed)
    for _ in range(tries):
        if kind == "release":
            table, t0, x0, v0 = random_stick_case(int(rng.integers(2**31)))
            table["contact"][0]["r"] = 0.0
            n = len(table["dofs"])
            a = np.array(table["contact"][0]["gap"])
            x0 = np.array(x0)
            v0 = np.array(v0)
            v0 -= a * (a @ v0 + float(rng.uniform(0.05, 1.0))) / (a @ a)     # a . v0 < 0
            table["contact"][0]["kappa"] = float(a @ x0)                        # g0 = 0
            x0, v0 = x0.tolist(), v0.tolist()
        else:
            table = random_table(rng)
            soften(table["contact"][0], rng)
            n = len(table["dofs"])
            t0 = float(rng.uniform(0.0, 10.0))
            x0, v0 = rng.standard_normal(n).tolist(), rng.standard_normal(n).tolist()
            a = np.array(table["contact"][0]["gap"], float)
            if kind == "exit":
                table["contact"][0]["kappa"] = float(a @ x0 + rng.uniform(0.3, 1.0))
        for c in table["contact"][1:]:
            c["kappa"] = -1e3             # out of the way; placed on the final flight below
        s = System(table)
        if kind == "release":
            x, v = np.array(x0), np.array(v0)
            w = a @ v
            v_h = v - w * (s.Minv @ a) / (a @ s.Minv @ a)
            md = mode(s, 0, 0)
            y_h = s.state(t0, x, v_h)
            if not md.rows[0][0] @ y_h > 0.0:
                continue
            fl = Flight(md, t0, y_h, t0 + span)
        else:
            md = mode(s, 1 if kind == "exit" else 0, -1)
            fl = Flight(md, t0, s.state(t0, x0, v0), t0 + span)
        low = _first_low(fl, 0)
        if low is None:
            continue
        tm, gm = low
        if kind == "entry":
            table["contact"][0]["kappa"] += gm - delta
        elif kind == "exit":
            k = table["contact"][0]["k"]
            Kp = s.K + k * np.outer(a, a)
            if np.linalg.cond(Kp) > 1e8:
                continue
            q = a @ np.linalg.solve(Kp, a)
            mu = (gm - delta) / q
            dx = np.linalg.solve(Kp, mu * a)
            _force_along(table, a, mu)
            x0 = (np.array(x0) + dx).tolist()
        else:
            q = a @ s.Minv @ a / np.linalg.norm(a)
            _force_along(table, a, (gm - delta) / q)
        s2 = System(table)
        if kind == "release":
            md2 = mode(s2, 0, 0)
            y2 = s2.state(t0, x0, np.array(v0) - (a @ np.array(v0)) * (s2.Minv @ a) / (a @ s2.Minv @ a))
        else:
            md2 = mode(s2, initial_act(s2, np.array(x0)), -1)
            if kind == "exit" and md2.act != 1:
                continue
            y2 = s2.state(t0, x0, v0)
        fl2 = Flight(md2, t0, y2, tm + 0.5)
        g_at = fl2.gap_at(0, tm)
        _, _, gmin, tmin = fl2.scan(0, tm + 1e-3)
        if abs(gmin - delta) > 1e-14 + 1e-3 * abs(delta) or abs(tmin - tm) > 1e-3:
            continue
        dip = _dip_of(fl2, 0, tm) if delta < 0 else None
        if delta < 0 and dip is None:
            continue
        for j in range(1, len(table["contact"])):
            # the other contacts 0.2 below their least gap on the graze's flight (not acting,
            # they do not change it)
            iv = fl2.intervals(j)
            table["contact"][j]["kappa"] += float(min(iv["L"][0].min(), iv["R"][0].min())) - 0.2
        if dip is not None:
            # a release's landing follows the dip's end by about twice the dip's width
            w = dip[1] - dip[0] + 1e-9
            window = (dip[0] - w, dip[1] + (3.0 if kind == "release" else 1.0) * w)
        else:
            w = 2.0 * math.sqrt(2.0 * delta / max(abs(g_at[2]), 1e-300)) + 1e-9
            window = (tm - w, tm + w)
        if kind == "release":
            # the landing after a release's dip comes after its end by a time of the gap's
            # rounding: a gap of about delta tau^2 rises and falls (tau the dip's width);
            # measured up to 2.1e-4 after a dip of 1e-12
            window = (window[0], max(window[1], tm + 1e-3))
        return {"table": table, "t0": t0, "x0": x0, "v0": v0, "kind": kind, "t_graze": tm,
                "dip": dip, "window": window}
    return None


def check_hybrid_graze(seed, kind, delta):
    """A hybrid graze (``hybrid_graze_case``) through the kernel and ``check_hybrid``: (the
    case or None, the verdict, the check's dict).  Contact A's events in the graze's window
    among the kernel's recorded events (a release's start, the hold at t0, not counted):
    a dip must have one (an entry; after an exit's dip, the re-entry; after a release's dip,
    the landing that follows it), a clearance none."""
    case = hybrid_graze_case(seed, kind, delta)
    if case is None:
        return None, None, None
    lo, hi = case["window"]
    count = 4 if kind == "release" else 3
    res = check_hybrid(case["table"], case["t0"], case["x0"], case["v0"], count=count,
                       t_max=case["t_graze"] + 0.5)
    kt, kc = res["kernel_t"], res["kernel_contact"]
    hits = [t for t, c in zip(kt, kc) if c == "A" and lo <= t <= hi and t > case["t0"]]
    v = {"kind": kind, "delta": delta, "t_graze": case["t_graze"], "window": case["window"],
         "ok": bool(hits) if delta < 0 else not hits}
    if not v["ok"]:
        v["what"] = "dip missed" if delta < 0 else "event on a clearance"
    return case, v, res


def hybrid_graze_plan(g, slow_releases=False):
    """The g-th hybrid graze's (kind, delta): entry, exit and release in turn, then each
    depth of GRAZE_DEPTHS, a dip (delta < 0) and a clearance in turn: every 30 cover all.
    A release's dips of 1e-8 .. 1e-11 are replaced by its clearances unless
    ``slow_releases`` (the kernel takes 5 to 60 s on each: docs/linear.md, "Certified
    against a brute force")."""
    kind = HYBRID_GRAZES[g % 3]
    depth = GRAZE_DEPTHS[(g // 3) % len(GRAZE_DEPTHS)]
    delta = -depth if (g // (3 * len(GRAZE_DEPTHS))) % 2 == 0 else depth
    if kind == "release" and delta < 0 and depth not in (1e-6, 1e-12) and not slow_releases:
        delta = depth
    return kind, delta
