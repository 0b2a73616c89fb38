"""A slow, obviously right event-driven simulation of a linear vibro-impact system (issue 33),
for the tests: exact flights at many digits and first impacts bracketed by fine sampling.

It shares nothing with cornerbif's code but the declarations (``LinearSystem``, read for
their numbers).  Everything is done in mpmath at ``DIGITS`` significant digits:

* the flight is the augmented autonomous system y' = A y (the forces' phases as states, as
  cornerbif/models/linear/flight.py does, but built and exponentiated here with mpmath's own
  expm), stepped on a sampling grid of ``per_period`` points per the fastest period by one
  matrix E = expm(A dt) computed once;
* each contact's gap g = a . x - z(t) (z: fixed, kappa + beta sin(omega t), or
  kappa + beta |sin(omega t)|) is sampled on that grid; the first sample where some gap is
  below zero brackets the first impact, which is refined by bisection (expm(A tau) from the
  bracket's left end) to ``tol``;
* the impact applies the generalised Newton law written out here,
  v+ = v- - (1 + r) w- M^-1 a / (a^T M^-1 a), w- = a . v- - z', with z' of the side the
  impact lies on (the rectified sine's corners t = n pi / omega);
* a grazing touch between two samples (a dip below zero and back within one step) is not
  seen: the sampling step is the reference's resolution, which the tests keep fine.

No chattering, sticking or soft stops: the scenes it runs have none within their impacts.
"""

from __future__ import annotations

import mpmath as mp

DIGITS = 30


def _obstacle(kind, kappa, beta, omega, t):
    """z(t), z'(t) of an obstacle kind at time t (mpf), on the side of t's own piece."""
    if kind == "fixed":
        return kappa, mp.mpf(0)
    s, c = mp.sin(omega * t), mp.cos(omega * t)
    if kind == "sine":
        return kappa + beta * s, beta * omega * c
    if kind == "rectified_sine":
        sign = 1 if s >= 0 else -1
        return kappa + beta * abs(s), sign * beta * omega * c
    raise ValueError(kind)


class Reference:
    """The system ``sys`` (a ``LinearSystem``) in mpmath."""

    def __init__(self, sys, per_period=400, tol=1e-24):
        mp.mp.dps = DIGITS
        self.sys, self.n, self.tol = sys, sys.n, mp.mpf(tol)
        n = self.n
        M = mp.matrix(sys.mass.tolist())
        self.Minv = M ** -1
        harm = [f for f in sys.forcing if f.Omega > 0]
        const = [f for f in sys.forcing if f.Omega == 0]
        m = 2 * len(harm) + (1 if const else 0)
        A = mp.zeros(2 * n + m, 2 * n + m)
        K, C = mp.matrix(sys.stiffness.tolist()), mp.matrix(sys.damping.tolist())
        MK, MC = self.Minv * K, self.Minv * C
        for i in range(n):
            A[i, n + i] = 1
            for j in range(n):
                A[n + i, j] = -MK[i, j]
                A[n + i, n + j] = -MC[i, j]
        B = mp.zeros(n, max(m, 1))
        for j, f in enumerate(harm):
            B[f.on, 2 * j] += mp.mpf(f.F)
            A[2 * n + 2 * j, 2 * n + 2 * j + 1] = -mp.mpf(f.Omega)
            A[2 * n + 2 * j + 1, 2 * n + 2 * j] = mp.mpf(f.Omega)
        for f in const:
            B[f.on, m - 1] += mp.mpf(f.F) * mp.cos(mp.mpf(f.phi))
        MB = self.Minv * B
        for i in range(n):
            for j in range(m):
                A[n + i, 2 * n + j] = MB[i, j]
        self.A, self.m, self.harm = A, m, harm
        # the fastest time scale: the flight's eigenfrequencies and the obstacles'
        freqs = [abs(complex(e)) for e in mp.eig(A)[0]] + [
            c.omega for c in sys.contacts if c.obstacle != "fixed"] + [1.0]
        self.dt = 2 * mp.pi / max(freqs) / per_period
        self.E = mp.expm(A * self.dt)

    def _y(self, t, x, v):
        y = list(x) + list(v)
        for f in self.harm:
            y += [mp.cos(f.Omega * t + f.phi), mp.sin(f.Omega * t + f.phi)]
        if self.m > 2 * len(self.harm):
            y.append(mp.mpf(1))
        return mp.matrix(y)

    def _gaps(self, t, y):
        out = []
        for c in self.sys.contacts:
            ax = mp.fsum(mp.mpf(c.gap[i]) * y[i] for i in range(self.n))
            z, _ = _obstacle(c.obstacle, mp.mpf(c.kappa), mp.mpf(c.beta), mp.mpf(c.omega), t)
            out.append(ax - z)
        return out

    def impacts(self, t0, x0, v0, count, t_max=1e4):
        """The first ``count`` impacts from (x0, v0) at t0: a list of (t, contact name,
        x, v-, v+) as floats."""
        t = mp.mpf(t0)
        y = self._y(t, [mp.mpf(a) for a in x0], [mp.mpf(a) for a in v0])
        n, out = self.n, []
        while len(out) < count and t < t_max:
            # sample until a gap is below zero (the step from an impact: its gap is 0 there)
            t1, y1 = t, y
            while True:
                t2, y2 = t1 + self.dt, self.E * y1
                g = self._gaps(t2, y2)
                if min(g) < 0:
                    break
                t1, y1 = t2, y2
                if t1 > t_max:
                    return out
            j = min(range(len(g)), key=lambda i: g[i])
            # bisection on contact j's gap over [t1, t2], from y1
            lo, hi = mp.mpf(0), t2 - t1
            while hi - lo > self.tol:
                mid = (lo + hi) / 2
                ym = mp.expm(self.A * mid) * y1
                if self._gaps(t1 + mid, ym)[j] < 0:
                    hi = mid
                else:
                    lo = mid
            t = t1 + hi
            y = mp.expm(self.A * hi) * y1
            c = self.sys.contacts[j]
            _, zp = _obstacle(c.obstacle, mp.mpf(c.kappa), mp.mpf(c.beta), mp.mpf(c.omega), t)
            a = mp.matrix([mp.mpf(ai) for ai in c.gap])
            v = mp.matrix([y[n + i] for i in range(n)])
            d = self.Minv * a
            w = mp.fsum(a[i] * v[i] for i in range(n)) - zp
            ad = mp.fsum(a[i] * d[i] for i in range(n))
            vp = v - (1 + mp.mpf(c.r)) * w / ad * d
            for i in range(n):
                y[n + i] = vp[i]
            out.append((float(t), c.name, [float(y[i]) for i in range(n)],
                        [float(v[i]) for i in range(n)], [float(vp[i]) for i in range(n)]))
        return out
