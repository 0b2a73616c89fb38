"""Slow, independent reference simulator of a 1-DOF impact oscillator.

This module is deliberately *naive*: it trades speed for being easy to check
by reading.  It must not import (or share code with) the ``cornerbif``
package, because the tests use it to validate the fast kernel.

Model (Budd & Piiroinen, "Corner bifurcations in non-smoothly forced impact
oscillators")
-------------------------------------------------------------------------

Free flight (particle above the obstacle)::

    u'' + 2*sigma*u' + k**2*u = F*cos(Omega*t + phi)

solved in closed form (see :func:`free_flight`).

Obstacle ``z(t)``; the particle is constrained to ``u >= z``:

* ``"rectified_sine"``: ``z = kappa + beta*|sin(omega*t)|``; corners at
  ``t_j = j*pi/omega``.
* ``"sine"``: ``z = kappa + beta*sin(omega*t)`` (smooth; it is still split
  into pieces ``[j*pi/omega, (j+1)*pi/omega]`` for bookkeeping only).
* a cam profile: a dict ``{"period": ..., "pieces": [...]}`` as the scenes write it
  (:class:`NaiveProfile`), z = kappa + beta*g(omega*t), pieces split at their joints.
* ``"triangle"``: period ``P = pi/omega``; valley corners at ``t = n*P``
  where ``z = kappa``; slope ``+theta2`` up to the peak at local time
  ``tp = theta1*P/(theta1+theta2)``, then slope ``-theta1`` down to the next
  valley.  ``beta`` is ignored.

Impact (``u = z`` reached from above) with the Newton law
``v_out = (1+r)*z'(t*) - r*v_in``, ``z'`` being the obstacle slope at the
impact time.  Inside a smooth piece this is the ordinary derivative; at a
corner (a measure-zero event) the *right* derivative is used, i.e. the slope
of the piece the particle flies into after the impact.

Corner times are represented by exactly the floats ``j*pi/omega`` (triangle:
``n*P`` and ``n*P + tp`` with ``P = pi/omega``).  The simulator splits time
at these floats, so every sampling sub-interval lies inside one smooth piece
and each corner is itself a sample point.

Detection method of :func:`naive_impacts` (exhaustive search)
-------------------------------------------------------------
The gap ``g(t) = u(t) - z(t)`` is evaluated on a grid of step ``<= dt``
inside each smooth piece (corners included exactly).  On a sub-interval
``[t_i, t_{i+1}]`` (with ``g(t_i) > 0``) there is a contact if

* ``g(t_{i+1}) <= 0`` (sign change): the root is refined with ``brentq``; or
* ``g'(t_i) < 0 < g'(t_{i+1})`` (interior local minimum): the minimiser is
  found with ``brentq`` on ``g'``; if ``min g <= 0`` the first root is found
  with ``brentq`` on ``[t_i, argmin]``.

So a shallow incursion much narrower than ``dt`` is still detected (grazing).
The method assumes ``dt`` is small compared with ``1/k``, ``1/omega`` and
``1/Omega`` (at most one extremum of ``g`` per sub-interval, i.e. no wiggles
on the ``dt`` scale).  Roots are refined to ``xtol=1e-15`` and the smallest
allowed ``rtol`` (``4*eps``).

After an impact at ``t*`` the flight restarts from ``(t*, z(t*), v_out)``.
Sampling restarts at ``t* + h`` where ``h`` is the smallest of
``h0, 2*h0, 4*h0, ...`` (``h0 = 1e-14*max(1, |t*|)``) with ``g(t* + h) > 0``,
so the impact just processed (``g(t*) = 0``, ``g'(t*+) > 0``) is never
detected again.

Chattering: if the relative approach velocity ``|v_in - z'(t*)|`` of an
impact is below ``1e-9`` (or the particle cannot leave the obstacle after an
impact) the simulation stops; that last impact is *not* recorded, and the
status (see ``return_status``) is ``"chatter"``.
"""

import math

import numpy as np
from scipy.optimize import brentq

__all__ = [
    "free_flight",
    "z_obstacle",
    "z_slope",
    "naive_impacts",
    "naive_gap_min",
    "CHATTER_VELOCITY",
]

OBSTACLES = ("rectified_sine", "sine", "triangle")

#: impacts with a smaller relative velocity stop the simulation (chattering)
CHATTER_VELOCITY = 1e-9

_XTOL = 1e-15
_RTOL = 4.0 * np.finfo(float).eps  # smallest rtol accepted by brentq


# ---------------------------------------------------------------------------
# free flight, closed form
# ---------------------------------------------------------------------------
def _particular(t, t0, k, sigma, F, Omega, phi):
    """A particular solution (u_p, u_p') of u''+2 sigma u'+k^2 u = F cos(Omega t+phi)."""
    t = np.asarray(t, dtype=float)
    if F == 0.0:
        zero = np.zeros_like(t)
        return zero, zero
    th = Omega * t + phi
    a = k * k - Omega * Omega
    b = 2.0 * sigma * Omega
    D = a * a + b * b
    if D != 0.0:
        # (k^2-Omega^2) X + 2 sigma Omega Y = F ; (k^2-Omega^2) Y - 2 sigma Omega X = 0
        X = F * a / D
        Y = F * b / D
        up = X * np.cos(th) + Y * np.sin(th)
        vp = Omega * (-X * np.sin(th) + Y * np.cos(th))
        return up, vp
    if sigma == 0.0 and Omega != 0.0:
        # undamped resonance k == Omega: u_p = A (t-t0) sin(Omega t+phi), A = F/(2 Omega)
        A = F / (2.0 * Omega)
        s = t - t0
        up = A * s * np.sin(th)
        vp = A * np.sin(th) + A * s * Omega * np.cos(th)
        return up, vp
    raise NotImplementedError("degenerate forcing with k = Omega = 0 is not supported")


def free_flight(t, t0, u0, v0, sigma=0.0, k=1.0, F=0.0, Omega=1.0, phi=0.0):
    """Exact solution (u(t), u'(t)) of the free flight from u(t0)=u0, u'(t0)=v0.

    u = u_p + w with u_p a particular solution and w the homogeneous part::

        w(t)  = exp(-sigma s) [ w0 C(s) + (w0' + sigma w0) S(s) ]
        w'(t) = exp(-sigma s) [ w0' C(s) - (sigma w0' + k^2 w0) S(s) ]

    with s = t - t0 and (C, S) = (cos(wd s), sin(wd s)/wd), wd = sqrt(k^2-sigma^2)
    (underdamped); (1, s) (critical); (cosh(mu s), sinh(mu s)/mu),
    mu = sqrt(sigma^2-k^2) (overdamped).  ``t`` may be an array.
    """
    t = np.asarray(t, dtype=float)
    s = t - t0
    up, vp = _particular(t, t0, k, sigma, F, Omega, phi)
    up0, vp0 = _particular(np.asarray(t0, dtype=float), t0, k, sigma, F, Omega, phi)
    w0 = u0 - float(up0)
    w1 = v0 - float(vp0)
    disc = k * k - sigma * sigma
    if disc > 0.0:
        wd = math.sqrt(disc)
        C = np.cos(wd * s)
        S = np.sin(wd * s) / wd
    elif disc == 0.0:
        C = np.ones_like(s)
        S = s
    else:
        mu = math.sqrt(-disc)
        C = np.cosh(mu * s)
        S = np.sinh(mu * s) / mu
    E = np.exp(-sigma * s)
    w = E * (w0 * C + (w1 + sigma * w0) * S)
    wp = E * (w1 * C - (sigma * w1 + k * k * w0) * S)
    u = up + w
    v = vp + wp
    if u.ndim == 0:
        return float(u), float(v)
    return u, v


# ---------------------------------------------------------------------------
# obstacle, piecewise
# ---------------------------------------------------------------------------
class NaiveProfile:
    """A cam profile ``{"period": P, "pieces": [...]}`` as the scenes write it (docs/cams.md),
    evaluated here from the formulas directly: z = kappa + beta g(omega t), g of the cam
    angle, piece m over [start_m, start_m + span_m]; a piece is ``poly`` (powers of the
    local angle) plus ``sine = [a, b, n]`` (a sin(n phi) + b cos(n phi)), or a motion
    ``law`` of rise h from the previous piece's end height (x = phi / span):
    dwell 0, constant_velocity h x, parabolic 2 h x^2 then h (1 - 2 (1 - x)^2),
    simple_harmonic h (1 - cos(pi x)) / 2, cycloidal h (x - sin(2 pi x) / (2 pi)),
    polynomial_345 h (10 x^3 - 15 x^4 + 6 x^5).  Pieces split time for the search only."""

    def __init__(self, spec):
        self.period = float(spec.get("period", 2 * math.pi))
        self.pieces = []
        start = 0.0
        height = 0.0
        for pc in spec["pieces"]:
            span = float(pc["span"])
            if "law" in pc:
                law, h, h0 = pc["law"], float(pc.get("rise", 0.0)), height
                self.pieces.append((start, span, ("law", law, h, h0)))
            else:
                poly = [float(c) for c in pc.get("poly", [0.0])]
                a, b, n = (float(x) for x in pc.get("sine", [0.0, 0.0, 0.0]))
                self.pieces.append((start, span, ("poly", poly, a, b, n)))
            height = self.g(len(self.pieces) - 1, span)[0]
            start += span

    def g(self, m, phi):
        """(g, dg/dphi) of piece m at local angle phi (arrays welcome)."""
        _, span, f = self.pieces[m]
        phi = np.asarray(phi, float)
        if f[0] == "poly":
            _, poly, a, b, n = f
            c = np.array(poly)
            g = np.polyval(c[::-1], phi) + a * np.sin(n * phi) + b * np.cos(n * phi)
            dc = c[1:] * np.arange(1, c.size)
            gp = (np.polyval(dc[::-1], phi) if dc.size else 0.0 * phi) \
                + n * (a * np.cos(n * phi) - b * np.sin(n * phi))
            return g, gp
        _, law, h, h0 = f
        x = phi / span
        if law == "dwell":
            return h0 + 0.0 * x, 0.0 * x
        if law == "constant_velocity":
            return h0 + h * x, h / span + 0.0 * x
        if law == "parabolic":
            g = np.where(x < 0.5, 2 * h * x ** 2, h * (1 - 2 * (1 - x) ** 2))
            gp = np.where(x < 0.5, 4 * h * x, 4 * h * (1 - x)) / span
            return h0 + g, gp
        if law == "simple_harmonic":
            return h0 + h * (1 - np.cos(np.pi * x)) / 2, h * np.pi * np.sin(np.pi * x) / (2 * span)
        if law == "cycloidal":
            return (h0 + h * (x - np.sin(2 * np.pi * x) / (2 * np.pi)),
                    h * (1 - np.cos(2 * np.pi * x)) / span)
        if law == "polynomial_345":
            return (h0 + h * (10 * x ** 3 - 15 * x ** 4 + 6 * x ** 5),
                    h * (30 * x ** 2 - 60 * x ** 3 + 30 * x ** 4) / span)
        raise ValueError(f"unknown law {law!r}")

    def bounds(self, j, omega):
        n, m = divmod(j, len(self.pieces))
        start, span, _ = self.pieces[m]
        a = (n * self.period + start) / omega
        return a, a + span / omega

    def z(self, j, t, omega, kappa, beta):
        a, _ = self.bounds(j, omega)
        g, gp = self.g(j % len(self.pieces), omega * (np.asarray(t, float) - a))
        return kappa + beta * g, beta * omega * gp


def _check_obstacle(obstacle, omega, theta1, theta2):
    if isinstance(obstacle, NaiveProfile):
        if not omega > 0.0:
            raise ValueError("omega must be > 0")
        return
    if obstacle not in OBSTACLES:
        raise ValueError(f"unknown obstacle {obstacle!r}; expected one of {OBSTACLES}")
    if not omega > 0.0:
        raise ValueError("omega must be > 0")
    if obstacle == "triangle":
        if theta1 is None or theta2 is None or not (theta1 > 0.0 and theta2 > 0.0):
            raise ValueError("triangle obstacle needs theta1 > 0 and theta2 > 0")


def _piece_bounds(obstacle, j, omega, theta1, theta2):
    """[a_j, b_j] of smooth piece j (corner floats computed one single way)."""
    if isinstance(obstacle, NaiveProfile):
        return obstacle.bounds(j, omega)
    P = math.pi / omega
    if obstacle == "triangle":
        n, half = divmod(j, 2)
        tp = theta1 * P / (theta1 + theta2)
        if half == 0:
            return n * P, n * P + tp
        return n * P + tp, (n + 1) * P
    return j * math.pi / omega, (j + 1) * math.pi / omega


def _piece_index(obstacle, t, omega, theta1, theta2):
    """j with a_j <= t < b_j (right-continuous, exact float comparison)."""
    P = math.pi / omega
    if isinstance(obstacle, NaiveProfile):
        j = len(obstacle.pieces) * int(math.floor(t * omega / obstacle.period))
    elif obstacle == "triangle":
        j = 2 * int(math.floor(t / P))
    else:
        j = int(math.floor(t * omega / math.pi))
    while True:
        a, b = _piece_bounds(obstacle, j, omega, theta1, theta2)
        if t < a:
            j -= 1
        elif t >= b:
            j += 1
        else:
            return j


def _z_piece(obstacle, j, t, omega, kappa, beta, theta1, theta2):
    """(z, z') on smooth piece j, using that piece's smooth formula (extended
    beyond the piece if t lies outside it).  ``t`` may be an array."""
    t = np.asarray(t, dtype=float)
    if isinstance(obstacle, NaiveProfile):
        return obstacle.z(j, t, omega, kappa, beta)
    if obstacle == "rectified_sine":
        # on piece j, omega t in [j pi, (j+1) pi] and |sin(omega t)| = sin(omega t - j pi)
        a = j * math.pi / omega
        x = omega * (t - a)
        return kappa + beta * np.sin(x), beta * omega * np.cos(x)
    if obstacle == "sine":
        return kappa + beta * np.sin(omega * t), beta * omega * np.cos(omega * t)
    # triangle
    P = math.pi / omega
    n, half = divmod(j, 2)
    if half == 0:  # rising, valley at n P
        return kappa + theta2 * (t - n * P), np.full_like(t, theta2)
    return kappa + theta1 * ((n + 1) * P - t), np.full_like(t, -theta1)


def _snap_piece(obstacle, t, omega, theta1, theta2):
    """Piece index for the public helpers: right-continuous, and a time within
    1e-12*max(1,|t|) *before* a corner is treated as the corner itself."""
    j = _piece_index(obstacle, t, omega, theta1, theta2)
    _, b = _piece_bounds(obstacle, j, omega, theta1, theta2)
    if b - t <= 1e-12 * max(1.0, abs(t)):
        j += 1
    return j


def z_obstacle(obstacle, t, omega, kappa, beta=1.0, theta1=None, theta2=None):
    """Obstacle position z(t) (scalar or array ``t``)."""
    _check_obstacle(obstacle, omega, theta1, theta2)

    def one(tt):
        j = _snap_piece(obstacle, tt, omega, theta1, theta2)
        return float(_z_piece(obstacle, j, tt, omega, kappa, beta, theta1, theta2)[0])

    if np.ndim(t) == 0:
        return one(float(t))
    return np.array([one(float(tt)) for tt in np.ravel(t)]).reshape(np.shape(t))


def z_slope(obstacle, t, omega, kappa, beta=1.0, theta1=None, theta2=None):
    """Obstacle slope z'(t), one-sided: at a corner (a float within
    1e-12*max(1,|t|) of a corner time) the RIGHT derivative z'(t+) is returned.
    E.g. rectified_sine at t = j*pi/omega gives +beta*omega; triangle gives
    +theta2 at a valley and -theta1 at a peak."""
    _check_obstacle(obstacle, omega, theta1, theta2)

    def one(tt):
        j = _snap_piece(obstacle, tt, omega, theta1, theta2)
        return float(_z_piece(obstacle, j, tt, omega, kappa, beta, theta1, theta2)[1])

    if np.ndim(t) == 0:
        return one(float(t))
    return np.array([one(float(tt)) for tt in np.ravel(t)]).reshape(np.shape(t))


# ---------------------------------------------------------------------------
# gap on one piece
# ---------------------------------------------------------------------------
class _Gap:
    """g(t) = u(t) - z_j(t) and g'(t) for one free flight and one smooth piece."""

    def __init__(self, obs, flight, j):
        self.obs = obs  # dict with obstacle parameters
        self.flight = flight  # dict with flight parameters (t0,u0,v0,sigma,k,F,Omega,phi)
        self.j = j

    def uv(self, t):
        return free_flight(t, **self.flight)

    def zz(self, t):
        o = self.obs
        return _z_piece(o["obstacle"], self.j, t, o["omega"], o["kappa"], o["beta"],
                        o["theta1"], o["theta2"])

    def both(self, t):
        u, v = self.uv(t)
        z, zp = self.zz(t)
        return u - z, v - zp

    def g(self, t):
        return float(self.both(t)[0])

    def gp(self, t):
        return float(self.both(t)[1])


def _grid(lo, hi, dt):
    n = max(1, int(math.ceil((hi - lo) / dt)))
    T = lo + (hi - lo) * (np.arange(n + 1) / n)
    T[0] = lo
    T[-1] = hi
    return T


def _first_contact(obs, flight, t_start, t_end, dt, after_impact):
    """First time in (t_start, t_end] where g <= 0 for the given flight.

    Returns None (no contact), "stuck" (cannot leave obstacle after impact),
    or (t_contact, j) where j is the piece whose slope is the right
    derivative at t_contact.
    """
    name = obs["obstacle"]
    om, th1, th2 = obs["omega"], obs["theta1"], obs["theta2"]
    j = _piece_index(name, t_start, om, th1, th2)
    first = True
    while True:
        a, b = _piece_bounds(name, j, om, th1, th2)
        if a >= t_end:
            return None
        gap = _Gap(obs, flight, j)
        lo = max(a, t_start)
        hi = min(b, t_end)
        if first and after_impact:
            # move just off the impact point: smallest h0*2^m with g(t*+h) > 0
            h = 1e-14 * max(1.0, abs(t_start))
            while gap.g(t_start + h) <= 0.0:
                h *= 2.0
                if h > dt:
                    return "stuck"
            lo = t_start + h
        first = False
        if lo >= hi:
            j += 1
            continue
        T = _grid(lo, hi, dt)
        G, GP = gap.both(T)
        if G[0] <= 0.0:
            # only possible at a piece start (corner) through rounding
            return lo, j
        below = np.nonzero(G[1:] <= 0.0)[0]
        i_c = int(below[0]) if below.size else len(T) - 1
        mins = np.nonzero((GP[:i_c] < 0.0) & (GP[1:i_c + 1] > 0.0))[0]
        for i in mins:
            tm = brentq(gap.gp, T[i], T[i + 1], xtol=_XTOL, rtol=_RTOL, maxiter=500)
            if gap.g(tm) <= 0.0:
                tr = brentq(gap.g, T[i], tm, xtol=_XTOL, rtol=_RTOL, maxiter=500)
                return tr, j
        if below.size:
            tr = brentq(gap.g, T[i_c], T[i_c + 1], xtol=_XTOL, rtol=_RTOL, maxiter=500)
            if tr >= b:  # impact exactly at the corner: use the right derivative
                return b, j + 1
            return tr, j
        if hi >= t_end:
            return None
        j += 1


def _params(obstacle, omega, kappa, beta, theta1, theta2, sigma, k, F, Omega, phi):
    if isinstance(obstacle, dict):           # a cam profile (NaiveProfile)
        obstacle = NaiveProfile(obstacle)
    _check_obstacle(obstacle, omega, theta1, theta2)
    obs = dict(obstacle=obstacle, omega=float(omega), kappa=float(kappa), beta=float(beta),
               theta1=None if theta1 is None else float(theta1),
               theta2=None if theta2 is None else float(theta2))
    fl = dict(sigma=float(sigma), k=float(k), F=float(F), Omega=float(Omega), phi=float(phi))
    return obs, fl


# ---------------------------------------------------------------------------
# public simulator
# ---------------------------------------------------------------------------
def naive_impacts(obstacle, omega, kappa, beta, r, u0, v0, n_impacts, t0=0.0,
                  sigma=0.0, k=1.0, F=0.0, Omega=1.0, phi=0.0, theta1=None, theta2=None,
                  dt=1e-3, t_max=None, return_status=False):
    """Simulate from (t0, u0, v0) until ``n_impacts`` impacts or ``t_max``.

    Returns an array of shape (m, 4), m <= n_impacts, with columns
    (t, u, v_in, v_out) of the impacts; u is z(t) at the impact.  With
    ``return_status=True`` returns ``(array, status)`` where status is
    ``"n_impacts"``, ``"t_max"`` or ``"chatter"`` (see module docstring).

    ``t_max`` defaults to ``t0 + 200*n_impacts*pi/omega``.  Requires
    u0 > z(t0) (strictly above the obstacle).
    """
    obs, fl = _params(obstacle, omega, kappa, beta, theta1, theta2, sigma, k, F, Omega, phi)
    obstacle = obs["obstacle"]
    if not dt > 0.0:
        raise ValueError("dt must be > 0")
    t0 = float(t0)
    if t_max is None:
        t_max = t0 + 200.0 * n_impacts * math.pi / omega
    j0 = _piece_index(obstacle, t0, omega, theta1, theta2)
    z0 = float(_z_piece(obstacle, j0, t0, omega, kappa, beta, theta1, theta2)[0])
    if not u0 > z0:
        raise ValueError(f"start must be strictly above the obstacle: u0={u0} <= z(t0)={z0}")

    flight = dict(t0=t0, u0=float(u0), v0=float(v0), **fl)
    out = []
    status = "n_impacts"
    t_scan = t0
    after_impact = False
    while len(out) < n_impacts:
        ev = _first_contact(obs, flight, t_scan, t_max, dt, after_impact)
        if ev is None:
            status = "t_max"
            break
        if ev == "stuck":
            status = "chatter"
            break
        ts, j = ev
        _, v_in = free_flight(ts, **flight)
        z_s, zp = _z_piece(obstacle, j, ts, omega, kappa, beta, theta1, theta2)
        z_s, zp = float(z_s), float(zp)
        if abs(v_in - zp) < CHATTER_VELOCITY:
            status = "chatter"
            break
        v_out = (1.0 + r) * zp - r * v_in
        out.append((ts, z_s, v_in, v_out))
        flight = dict(t0=ts, u0=z_s, v0=v_out, **fl)
        t_scan = ts
        after_impact = True
    arr = np.array(out, dtype=float).reshape(-1, 4)
    if return_status:
        return arr, status
    return arr


def naive_gap_min(obstacle, omega, kappa, beta, u0, v0, t0, t1, sigma=0.0, k=1.0, F=0.0,
                  Omega=1.0, phi=0.0, theta1=None, theta2=None, dt=1e-3):
    """Minimum over [t0, t1] of the gap u(t) - z(t) of the FREE flight from
    (t0, u0, v0) (impacts ignored).  Returns (g_min, t_at_min).

    Candidates: every grid point (step <= dt, all corners and both end points
    included) and every interior local minimum of g on a smooth piece (root
    of g' found by brentq where g' changes sign from - to +).
    """
    obs, fl = _params(obstacle, omega, kappa, beta, theta1, theta2, sigma, k, F, Omega, phi)
    obstacle = obs["obstacle"]
    flight = dict(t0=float(t0), u0=float(u0), v0=float(v0), **fl)
    best = (math.inf, float(t0))
    j = _piece_index(obstacle, float(t0), omega, theta1, theta2)
    while True:
        a, b = _piece_bounds(obstacle, j, omega, theta1, theta2)
        if a > t1:
            break
        lo, hi = max(a, float(t0)), min(b, float(t1))
        if hi >= lo:
            gap = _Gap(obs, flight, j)
            T = _grid(lo, hi, dt) if hi > lo else np.array([lo])
            G, GP = gap.both(T)
            i = int(np.argmin(G))
            if G[i] < best[0]:
                best = (float(G[i]), float(T[i]))
            for i in np.nonzero((GP[:-1] < 0.0) & (GP[1:] > 0.0))[0]:
                tm = brentq(gap.gp, T[i], T[i + 1], xtol=_XTOL, rtol=_RTOL, maxiter=500)
                gm = gap.g(tm)
                if gm < best[0]:
                    best = (gm, float(tm))
        if b >= t1:
            break
        j += 1
    return best
