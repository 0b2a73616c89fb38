"""Finite-difference reference for the Jacobian of the two-particle system's flow map.

Independent check for stability code (Floquet multipliers built from flight
matrices and impact saltation matrices) of the two-particle model of the paper's
section 6 (eqs 72-74): this module simulates the system slowly and plainly and
differentiates the *simulated* map numerically; it knows nothing about saltation
matrices.  It must not import ``cornerbif``; it only uses numpy, scipy's
``brentq`` and the closed-form flight ``naive.free_flight`` of ``tests/naive.py``.
It mirrors the one-particle reference ``tests/fd_reference.py``.

System
------
State ``x = (z, y, u, v)``: heavy particle ``z`` (velocity ``y``), light particle
``u`` (velocity ``v``), wall ``w(t) = kappa + beta sin(omega0 t)``; the order
``w <= z <= u`` is kept by impacts.  Flights (each particle on its own)::

    z'' + 2 sigma1 z' + omega1^2 z = F1 cos(Omega1 t + phi1)
    u'' + 2 sigma2 u' + omega2^2 u = F2 cos(Omega2 t + phi2)

Events (the first zero after the current time of either gap):

* ``'wz'``: ``g1 = z - w`` reaches 0 (decreasing): law (5) with ``r1``,
  ``y+ = (1 + r1) w'(t) - r1 y-``; ``u, v`` unchanged.
* ``'zu'``: ``g2 = u - z`` reaches 0 (decreasing): law (74) with ``r2`` and
  ``mu = M/m``: ``d = (1 + r2)(v- - y-)``, ``y+ = y- + d/(1 + mu)``,
  ``v+ = v- - d mu/(1 + mu)`` (momentum ``mu y + v`` conserved, ``v - y``
  reversed and scaled by ``r2``); ``mu = inf``: ``y+ = y-``, ``v+ = (1 + r2) y- - r2 v-``.

Parameters are a dict ``p`` with keys ``omega0, omega1, omega2, mu, r1, r2,
kappa, beta`` (required) and ``sigma1, sigma2, F1, F2`` (default 0), ``Omega1,
Omega2`` (default 1), ``phi1, phi2`` (default 0).

Event search (exhaustive, as in ``naive.naive_impacts``)
-------------------------------------------------------
Each gap is sampled on a grid of step ``<= dt``; on a sub-interval there is a
contact if the gap is ``<= 0`` at its right end (root refined by ``brentq``) or
if the gap has an interior local minimum (``g'`` from - to +, minimiser by
``brentq`` on ``g'``) with ``g <= 0`` (first root by ``brentq``).  So incursions
narrower than ``dt`` are found; ``dt`` must be small against the time scales
``1/omega_i``, ``1/Omega_i`` and against the gaps' curvature time scale (at most
one extremum of a gap per sub-interval).  Roots are refined to ``xtol=1e-15``,
``rtol=4 eps`` in a *local* time ``s = t - t0`` (``t0`` the start of the run), and
the wall and forcing are written as smooth functions of ``s`` with phases fixed
once per run (``sin(omega0 (t0 + s)) = sin(omega0 t0) cos(omega0 s) + ...``), so the
rounding noise of the end state does not grow with ``|t0|``.  The earlier of the
two gaps' contacts is applied (an exact tie: ``'wz'`` first).  After an event the
gap that was hit restarts at 0 with a positive rate; its sampling restarts at
``s* + h``, ``h`` the smallest of ``1e-14 * max(1, |s*|) * 2^m`` with a positive
gap, so that event is never found again.

Public helpers
--------------
* :func:`state_at` -- the state at ``t1`` from ``x0`` at ``t0`` and the events
  ``(t, kind)`` in ``(t0, t1]``.
* :func:`trajectory` -- the same run with every event's pre- and post-event state.
* :func:`fd_jacobian` -- ``dx(t0 + duration) / dx0`` by central differences on a
  geometric ladder of steps, Richardson-extrapolated, with an entrywise error
  estimate (truncation from the ladder + a measured rounding-noise floor).  Steps
  whose perturbed runs change the event sequence (number or kinds or order of
  events) are rejected: across such a change the map is not differentiable.
* :func:`settle` -- the state at ``t0 + n_periods * period``, to land on an
  attractor before building a test case.

Limits
------
* The start must be strictly ordered, ``w(t0) < z0 < u0``, so a section time must
  not coincide with an event.
* Near grazing (an event with a small relative approach velocity), near a
  simultaneous (triple, ``w = z = u``) impact, or with an event near ``t1`` the
  map is only piecewise smooth; the admissible step shrinks like the distance to
  the nonsmooth set and :class:`FDStepError` is raised when no step down to
  ``h_min`` keeps the event sequence.  Near grazing the Jacobian grows like
  ``1/|approach velocity|`` and so does its error estimate (returned, never hidden).
* Chattering / sticking (an event slower than :data:`CHATTER_VELOCITY`, or a gap
  that does not open after an event) raises ``RuntimeError``, as does a contact
  found with a non-negative approach velocity (order violated, e.g. a
  simultaneous impact).  Resolving sticking phases is out of scope.
* Slow: pure Python/numpy, roughly 1 ms per event plus ~1 ms per time unit;
  a 4x4 Jacobian needs ~170 runs of the window.
"""

import math
import os
import sys
from typing import NamedTuple

import numpy as np
from scipy.optimize import brentq

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from naive import free_flight  # noqa: E402

__all__ = ["FDStepError", "TwoParticleState", "Event", "DEFAULTS", "CHATTER_VELOCITY",
           "state_at", "trajectory", "fd_jacobian", "settle"]

#: cap on the number of events simulated in one run (chatter-like blow-up guard)
MAX_EVENTS = 100_000

#: events with a smaller relative approach velocity stop the run (RuntimeError)
CHATTER_VELOCITY = 1e-9

#: optional parameters and their defaults (the paper's eq 73: no damping, no forcing)
DEFAULTS = dict(sigma1=0.0, sigma2=0.0, F1=0.0, F2=0.0, Omega1=1.0, Omega2=1.0, phi1=0.0,
                phi2=0.0)
REQUIRED = ("omega0", "omega1", "omega2", "mu", "r1", "r2", "kappa", "beta")

_XTOL = 1e-15
_RTOL = 4.0 * np.finfo(float).eps  # smallest rtol accepted by brentq
_CHUNK_MIN = 512  # grid steps per sampling chunk right after an event
_CHUNK_MAX = 8192  # chunk length doubles while no event is found, up to this


class FDStepError(RuntimeError):
    """No finite-difference step keeps the event sequence of the window unchanged."""


class TwoParticleState(NamedTuple):
    """Result of :func:`state_at`; unpacks as ``x, events``."""

    x: np.ndarray  # (z, y, u, v) at t1
    events: list  # [(t, 'wz' | 'zu'), ...] in (t0, t1]


class Event(NamedTuple):
    """One event of :func:`trajectory`."""

    t: float
    kind: str  # 'wz' or 'zu'
    pre: np.ndarray  # (z, y, u, v) just before
    post: np.ndarray  # (z, y, u, v) just after


def _full_params(p):
    missing = [k for k in REQUIRED if k not in p]
    if missing:
        raise ValueError(f"missing parameters {missing}")
    unknown = sorted(set(p) - set(REQUIRED) - set(DEFAULTS))
    if unknown:
        raise ValueError(f"unknown parameters {unknown}")
    q = dict(DEFAULTS)
    q.update({k: float(v) for k, v in p.items()})
    return q


class _Model:
    """Wall and flights in the local time s = t - t_base (phases fixed once)."""

    def __init__(self, p, t_base):
        self.p = p
        th = p["omega0"] * t_base
        self.sw, self.cw = math.sin(th), math.cos(th)
        self.fz = dict(sigma=p["sigma1"], k=p["omega1"], F=p["F1"], Omega=p["Omega1"],
                       phi=p["phi1"] + p["Omega1"] * t_base if p["F1"] != 0.0 else p["phi1"])
        self.fu = dict(sigma=p["sigma2"], k=p["omega2"], F=p["F2"], Omega=p["Omega2"],
                       phi=p["phi2"] + p["Omega2"] * t_base if p["F2"] != 0.0 else p["phi2"])

    def wall(self, s):
        """(w, w') at local time s (scalar or array)."""
        a = self.p["omega0"] * np.asarray(s, dtype=float)
        ca, sa = np.cos(a), np.sin(a)
        sn = self.sw * ca + self.cw * sa  # sin(omega0 (t_base + s))
        cs = self.cw * ca - self.sw * sa  # cos(omega0 (t_base + s))
        return self.p["kappa"] + self.p["beta"] * sn, self.p["beta"] * self.p["omega0"] * cs

    def z(self, s, zref):
        return free_flight(s, *zref, **self.fz)

    def u(self, s, uref):
        return free_flight(s, *uref, **self.fu)


def _grid(lo, hi, dt):
    n = max(1, int(math.ceil((hi - lo) / dt)))
    T = lo + (hi - lo) * (np.arange(n + 1) / n)
    T[0] = lo
    T[-1] = hi
    return T


def _scan(gap, lo, hi, dt):
    """First s in [lo, hi] with gap <= 0 (see module docstring), or None.

    ``gap(s)`` returns (g, g') for scalar or array s."""
    T = _grid(lo, hi, dt)
    G, GP = gap(T)
    if G[0] <= 0.0:
        return lo

    def g(s):
        return float(gap(s)[0])

    def gp(s):
        return float(gap(s)[1])

    below = np.nonzero(G[1:] <= 0.0)[0]
    i_c = int(below[0]) if below.size else len(T) - 1
    for i in np.nonzero((GP[:i_c] < 0.0) & (GP[1:i_c + 1] > 0.0))[0]:
        tm = brentq(gp, T[i], T[i + 1], xtol=_XTOL, rtol=_RTOL, maxiter=500)
        if g(tm) <= 0.0:
            return brentq(g, T[i], tm, xtol=_XTOL, rtol=_RTOL, maxiter=500)
    if below.size:
        return brentq(g, T[i_c], T[i_c + 1], xtol=_XTOL, rtol=_RTOL, maxiter=500)
    return None


def _move_off(gap, s, dt):
    """Smallest h = 1e-14 max(1, |s|) 2^m with gap(s + h) > 0 (gap just hit at s)."""
    h = 1e-14 * max(1.0, abs(s))
    while float(gap(s + h)[0]) <= 0.0:
        h *= 2.0
        if h > dt:
            raise RuntimeError(f"sticking: a gap does not open after the event at local "
                               f"time {s}")
    return h


def _simulate(p, x0, t0, t1, dt, record=False):
    """Run from x0 at t0 to t1: (x(t1), [Event or (t, kind)]).  Raises ValueError for a
    start that is not strictly ordered, RuntimeError for chattering/sticking."""
    p = _full_params(p)
    t0 = float(t0)
    t1 = float(t1)
    if not t1 >= t0:
        raise ValueError(f"need t1 >= t0, got t0={t0}, t1={t1}")
    if not dt > 0.0:
        raise ValueError("dt must be > 0")
    x0 = np.asarray(x0, dtype=float)
    if x0.shape != (4,) or not np.all(np.isfinite(x0)):
        raise ValueError(f"x0 must be 4 finite numbers (z, y, u, v), got {x0}")
    M = _Model(p, t0)
    w0 = float(M.wall(0.0)[0])
    if not (w0 < x0[0] < x0[2]):
        raise ValueError(f"start must be strictly ordered w < z < u: w(t0)={w0}, "
                         f"z0={x0[0]}, u0={x0[2]}")
    r1, r2, mu = p["r1"], p["r2"], p["mu"]
    S1 = t1 - t0
    # an event found within ``margin`` after t1 counts as an event at t1 (clamped): event
    # times are only known to brentq's tolerance, and t1 itself to one ulp of |t1|
    margin = 4e-15 * max(1.0, abs(S1)) + 2.0 * float(np.spacing(abs(t1)))
    S_end = S1 + margin
    zref = (0.0, float(x0[0]), float(x0[1]))  # (s_ref, z, y) of the current z flight
    uref = (0.0, float(x0[2]), float(x0[3]))

    def gap_wz(s):
        z, y = M.z(s, zref)
        w, wp = M.wall(s)
        return z - w, y - wp

    def gap_zu(s):
        z, y = M.z(s, zref)
        u, v = M.u(s, uref)
        return u - z, v - y

    events = []
    s = 0.0
    just = None  # index of the gap hit at s (0: wz, 1: zu), or None
    chunk = _CHUNK_MIN * dt
    while True:
        hi = min(S_end, s + chunk)
        found = []
        for gi, gap in enumerate((gap_wz, gap_zu)):
            lo = s
            if just == gi:
                lo = s + _move_off(gap, s, dt)
                if lo > hi:
                    continue
            sc = _scan(gap, lo, hi, dt)
            if sc is not None:
                found.append((sc, gi))
        if not found:
            if hi >= S_end:
                break
            s = hi
            just = None
            chunk = min(2.0 * chunk, _CHUNK_MAX * dt)
            continue
        sc, gi = min(found)  # earliest; an exact tie gives 'wz' (gi = 0) first
        sc = min(sc, S1)
        z, y = M.z(sc, zref)
        u, v = M.u(sc, uref)
        pre = np.array([z, y, u, v], dtype=float)
        if gi == 0:
            w, wp = M.wall(sc)
            w, wp = float(w), float(wp)
            rel = y - wp
            kind = "wz"
            if not rel < -CHATTER_VELOCITY:
                raise RuntimeError(f"chattering/grazing or order violated: w-z event at "
                                   f"t={t0 + sc} with relative velocity {rel} (after "
                                   f"{len(events)} events)")
            y_out = (1.0 + r1) * wp - r1 * y
            zref = (sc, w, y_out)
            post = np.array([w, y_out, u, v])
        else:
            rel = v - y
            kind = "zu"
            if not rel < -CHATTER_VELOCITY:
                raise RuntimeError(f"chattering/grazing or order violated: z-u event at "
                                   f"t={t0 + sc} with relative velocity {rel} (after "
                                   f"{len(events)} events)")
            if math.isinf(mu):
                y_out = y
                v_out = (1.0 + r2) * y - r2 * v
            else:
                d = (1.0 + r2) * rel
                y_out = y + d / (1.0 + mu)
                v_out = v - d * (mu / (1.0 + mu))
            zref = (sc, z, y_out)
            uref = (sc, z, v_out)
            post = np.array([z, y_out, z, v_out])
        t_ev = t0 + sc
        events.append(Event(t_ev, kind, pre, post) if record else (t_ev, kind))
        if len(events) >= MAX_EVENTS:
            raise RuntimeError(f"more than {MAX_EVENTS} events in [{t0}, {t1}]")
        s = sc
        just = gi
        chunk = _CHUNK_MIN * dt
    z, y = M.z(S1, zref)
    u, v = M.u(S1, uref)
    return np.array([z, y, u, v], dtype=float), events


def state_at(p, x0, t0, t1, dt=1e-3):
    """State at ``t1`` of the trajectory from ``x0 = (z0, y0, u0, v0)`` at ``t0``.

    Events in ``(t0, t1]`` are found by the exhaustive search of the module
    docstring; an event at ``t1`` counts (also one found up to ``4e-15 max(1, t1 -
    t0) + 2 ulp(t1)`` later, which is then put at ``t1``) and the returned state is
    then the post-event one.  ``dt`` is the detection grid step (it affects which contacts
    are detected, not the accuracy of event times).

    Returns a :class:`TwoParticleState` ``(x, events)`` with ``events`` a list of
    ``(t, kind)``, kind ``'wz'`` or ``'zu'``.
    """
    x, ev = _simulate(p, x0, t0, t1, dt)
    return TwoParticleState(x, ev)


def trajectory(p, x0, t0, t1, dt=1e-3):
    """Like :func:`state_at` but returns ``(x(t1), [Event(t, kind, pre, post), ...])``
    with the full state just before and just after each event."""
    return _simulate(p, x0, t0, t1, dt, record=True)


def _noise_level(run, x0, col, scale, sig0):
    """Absolute noise (per output component) of the simulated end state, ECnoise-style.

    The map is evaluated at ``x0 + m*delta*e_col``, ``m = -8..8``; for ``delta``
    this small the smooth part of the k-th differences (k = 3..6) is negligible,
    so ``rms(diff^k) / sqrt(binom(2k, k))`` estimates the standard deviation of
    the rounding noise.  The noise of this simulator is far from white (end states
    are sums of O(|v| / omega) terms, event times come from brentq iterations whose
    rounding varies slowly with x0), so a 9-point estimate can be 100x too small;
    17 points and the largest estimate over k and over the first two admissible
    ``delta`` of (1e-6, 1e-8, 1e-10) are used.  Returns None if no delta keeps the
    event sequence.
    """
    found = []
    for delta in (1e-6, 1e-8, 1e-10):
        X = []
        for m in range(-8, 9):
            x = x0.copy()
            x[col] += m * delta * scale
            fx = run(x)
            if fx is None or fx[1] != sig0:
                break
            X.append(fx[0])
        else:
            X = np.array(X)
            found += [np.sqrt(np.mean(np.diff(X, n=kk, axis=0) ** 2, axis=0))
                      / math.sqrt(math.comb(2 * kk, kk)) for kk in range(3, 7)]
            if len(found) == 8:
                break
    return np.max(found, axis=0) if found else None


_NAMES = ("z0", "y0", "u0", "v0")


def fd_jacobian(p, x0, t0, duration, h=None, h_max=1e-3, h_min=1e-8, ratio=0.5, dt=1e-3,
                full_output=False):
    """Jacobian ``dx(t0 + duration) / dx0`` (4x4, ``x = (z, y, u, v)``) by central
    differences.

    Steps are relative to the state scale: column ``i`` (perturbing ``x_i``) uses
    ``h_abs = h_rel * max(1, |x_i|)``.

    * ``h=None`` (default): a geometric ladder ``h_rel = h_max * ratio**m`` down to
      ``h_min``.  Each admissible pair of successive central differences ``D(h),
      D(ratio h)`` is Richardson-extrapolated (the O(h^2) term cancels): ``R =
      (D(ratio h) - ratio^2 D(h)) / (1 - ratio^2)``.  The truncation error of ``R``
      is estimated by the larger difference to its neighbours on the ladder
      (componentwise).
    * ``h`` given: only ``h_rel = h`` and ``ratio*h``; the truncation error is
      estimated by ``|R - D(ratio h)|``.

    The rounding error of ``R`` is bounded by ``3 * std``, the standard deviation
    following from the measured noise level ``eta`` of the simulated end state
    (see :func:`_noise_level`): ``eta / (sqrt(2) h) * sqrt(1/ratio^2 + ratio^4) /
    (1 - ratio^2)``.  Each column's error estimate is the (componentwise) sum of the
    two; the step with the smallest estimate (preferring estimates checked against
    both ladder neighbours) is returned.

    A step is admissible only if both perturbed runs have the same event sequence
    (number of events and their kinds, in order) as the unperturbed run, start
    strictly ordered and do not chatter; otherwise it is skipped (smaller steps are
    tried).  If no usable steps remain, :class:`FDStepError` is raised.

    Returns ``(J, err)``: 4x4 arrays (``err`` entrywise absolute estimates), or
    ``(J, err, info)`` with ``full_output=True`` where ``info`` holds the chosen
    relative steps per column (``h_rel``), the measured noise levels (``noise``, rows
    = columns of J), the base ``events`` [(t, kind)], ``n_events``, the event
    ``signature`` (tuple of kinds) and the base end ``state``.
    """
    t0 = float(t0)
    t1 = t0 + float(duration)
    x0 = np.array(x0, dtype=float)

    def run(x):
        """(end state, signature), or None if x is not admissible: not strictly
        ordered (ValueError) or chattering (RuntimeError, e.g. an exact grazing)."""
        try:
            xe, ev = _simulate(p, x, t0, t1, dt)
        except (ValueError, RuntimeError):
            return None
        return xe, tuple(k for _, k in ev)

    x1, ev0 = _simulate(p, x0, t0, t1, dt)
    sig0 = tuple(k for _, k in ev0)
    where0 = (f"the window [{t0}, {t1}] with events {[(round(t, 6), k) for t, k in ev0]} "
              f"is at or too close to a nonsmooth point (grazing, a simultaneous impact, "
              f"or an event at the window end)")

    if h is None:
        n_steps = int(math.floor(math.log(h_min / h_max) / math.log(ratio) + 1e-9)) + 1
        ladder = [h_max * ratio**m for m in range(n_steps)]
    else:
        ladder = [float(h), float(h) * ratio]
    q2 = ratio * ratio
    noise_gain = 3.0 / math.sqrt(2.0) * math.sqrt(1.0 / q2 + q2 * q2) / (1.0 - q2)

    J = np.empty((4, 4))
    err = np.empty((4, 4))
    chosen = []
    noises = []
    for col in range(4):
        scale = max(1.0, abs(x0[col]))
        eta = _noise_level(run, x0, col, scale, sig0)
        if eta is None:
            raise FDStepError(f"column {col} (d/d{_NAMES[col]}): even steps of 1e-10 "
                              f"(relative) change the event sequence: {where0}")
        noises.append(eta)
        D = []  # central differences (None where the step is not admissible)
        rejected = []
        for hr in ladder:
            e = np.zeros(4)
            e[col] = hr * scale
            fp, fm = run(x0 + e), run(x0 - e)
            if fp is None or fm is None:
                D.append(None)
                rejected.append((hr, "start not strictly ordered, or chattering"))
            elif fp[1] != sig0 or fm[1] != sig0:
                D.append(None)
                rejected.append((hr, f"event sequence {''.join(k[0] for k in fm[1])} / "
                                     f"{''.join(k[0] for k in fp[1])} vs "
                                     f"{''.join(k[0] for k in sig0)}"))
            else:
                D.append((fp[0] - fm[0]) / (2.0 * hr * scale))
        R = [None if (D[m] is None or D[m + 1] is None)
             else (D[m + 1] - q2 * D[m]) / (1.0 - q2) for m in range(len(D) - 1)]
        best = None  # (score, m, estimate, error)
        for m, Rm in enumerate(R):
            if Rm is None:
                continue
            nb = [R[i] for i in (m - 1, m + 1) if 0 <= i < len(R) and R[i] is not None]
            if h is not None:
                e_trunc = np.abs(Rm - D[m + 1])
            elif nb:
                e_trunc = np.max([np.abs(Rm - Ri) for Ri in nb], axis=0)
            else:
                continue
            e_m = e_trunc + noise_gain * eta / (ladder[m] * scale)
            # prefer an estimate checked against both neighbours, then the smallest error
            score = (2 - len(nb) if h is None else 0, float(np.max(e_m)))
            if best is None or score < best[0]:
                best = (score, m, Rm, e_m)
        if best is None:
            last = ", ".join(f"h_rel={hr:.1e}: {why}" for hr, why in rejected[-3:])
            raise FDStepError(
                f"column {col} (d/d{_NAMES[col]}): no admissible run of successive steps "
                f"in [{ladder[-1]:.1e}, {ladder[0]:.1e}] (relative); {where0}. "
                f"Last rejections: {last}")
        _, m, Rm, e_m = best
        J[:, col] = Rm
        err[:, col] = e_m
        chosen.append(ladder[m])
    if full_output:
        info = dict(h_rel=chosen, noise=np.array(noises), events=list(ev0),
                    n_events=len(ev0), signature=sig0, state=x1)
        return J, err, info
    return J, err


def settle(p, x0, n_periods, period, t0=0.0, dt=1e-3):
    """State ``x`` at ``t = t0 + n_periods * period`` from ``x0`` at ``t0``.

    One uninterrupted run (no restarts at the section times), to let a transient
    die out before a test case is built from the returned state.  The returned
    state is a valid start for :func:`state_at` / :func:`fd_jacobian` only if no
    event happens exactly at the section time (then ``w < z < u``).
    """
    t1 = float(t0) + n_periods * float(period)
    return state_at(p, x0, t0, t1, dt=dt).x
