"""Finite-difference reference for the Jacobian of the impact oscillator's flow map.

Independent check for stability code (Floquet multipliers built from flight
matrices and impact saltation matrices): this module differentiates the
*simulated* flow numerically and knows nothing about saltation matrices.  It
must not import ``cornerbif``; it only uses numpy and the naive simulator
``tests/naive.py`` (closed-form flights, exhaustive impact search, impact times
refined by ``brentq`` to ~1e-15).

Public helpers
--------------
* :func:`state_at` -- the state (u, v) at t1 from (u0, v0) at t0, through all
  impacts in (t0, t1], plus the impact count and impact times.
* :func:`fd_jacobian` -- d(u, v)(t0 + duration) / d(u0, v0) by central
  differences on a geometric ladder of steps, Richardson-extrapolated, with an
  entrywise error estimate (truncation from the ladder + a measured rounding-noise
  floor).  Steps whose perturbed runs change the impact
  sequence (number of impacts, or the smooth obstacle piece an impact lies on)
  are rejected: across such a change the map is not differentiable.
* :func:`settle` -- the state at ``t0 + n_periods * period`` from (u0, v0) at
  ``t0`` (default 0), to land on an attractor before building a test case.

Limits
------
* The start state must be strictly above the obstacle (``naive_impacts``
  requires ``u0 > z(t0)``), so a section time must not coincide with an impact.
* Near grazing (an impact with a small relative approach velocity ``w``), near a
  corner, or with an impact near ``t1`` the map is only piecewise smooth; the
  admissible step shrinks like the distance to the nonsmooth set and
  :class:`FDStepError` is raised when no step down to ``h_min`` keeps the impact
  sequence.  Close to grazing the Jacobian grows like ``1/w`` and its error
  estimate grows accordingly (it is returned, never hidden).
* Chattering (an impact slower than ``naive.CHATTER_VELOCITY``) raises
  ``RuntimeError``.
"""

import math
import os
import sys
from typing import NamedTuple

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import naive  # noqa: E402
from naive import free_flight, naive_impacts  # noqa: E402

__all__ = ["FDStepError", "FlowState", "state_at", "fd_jacobian", "settle"]

#: cap on the number of impacts simulated in one window (chatter-like blow-up guard)
MAX_IMPACTS = 100_000


class FDStepError(RuntimeError):
    """No finite-difference step keeps the impact sequence of the window unchanged."""


class FlowState(NamedTuple):
    """Result of :func:`state_at`; unpacks as ``u, v, n_impacts, impact_times``."""

    u: float
    v: float
    n_impacts: int
    impact_times: list


def _run(obstacle, omega, kappa, beta, r, u0, v0, t0, t1, sigma, k, F, Omega, phi,
         theta1, theta2, dt):
    """(u(t1), v(t1), impacts array (m, 4): t, z, v_in, v_out) through (t0, t1]."""
    t0 = float(t0)
    t1 = float(t1)
    if not t1 >= t0:
        raise ValueError(f"need t1 >= t0, got t0={t0}, t1={t1}")
    imp, status = naive_impacts(obstacle, omega, kappa, beta, r, float(u0), float(v0),
                                MAX_IMPACTS, t0=t0, sigma=sigma, k=k, F=F, Omega=Omega,
                                phi=phi, theta1=theta1, theta2=theta2, dt=dt, t_max=t1,
                                return_status=True)
    if status == "chatter":
        raise RuntimeError(f"chattering in [{t0}, {t1}] after {len(imp)} impacts "
                           f"(relative impact velocity < {naive.CHATTER_VELOCITY})")
    if status != "t_max":
        raise RuntimeError(f"more than {MAX_IMPACTS} impacts in [{t0}, {t1}]")
    fl = dict(sigma=sigma, k=k, F=F, Omega=Omega, phi=phi)
    if len(imp):
        ts, zs, _, vout = imp[-1]
        # an impact exactly at t1 gives s = 0: the post-impact state (z, v_out)
        u, v = free_flight(t1, float(ts), float(zs), float(vout), **fl)
    else:
        u, v = free_flight(t1, t0, float(u0), float(v0), **fl)
    return float(u), float(v), imp


def state_at(obstacle, omega, kappa, beta, r, u0, v0, t0, t1, sigma=0.0, k=1.0, F=0.0,
             Omega=1.0, phi=0.0, theta1=None, theta2=None, dt=1e-3):
    """State at ``t1`` of the trajectory from ``(u0, v0)`` at ``t0`` (``u0 > z(t0)``).

    Impacts are found by ``naive_impacts`` (searching (t0, t1]); the state is the
    closed-form flight from the last impact (or from the start if there is none)
    evaluated at ``t1``.  An impact at exactly ``t1`` counts, and the returned
    state is then the post-impact one.  ``dt`` is naive's detection grid step
    (it affects detection of contacts, not the accuracy of impact times).

    Returns a :class:`FlowState` ``(u, v, n_impacts, impact_times)``.
    """
    u, v, imp = _run(obstacle, omega, kappa, beta, r, u0, v0, t0, t1, sigma, k, F, Omega,
                     phi, theta1, theta2, dt)
    return FlowState(u, v, len(imp), [float(t) for t in imp[:, 0]])


def _signature(obstacle, omega, theta1, theta2, imp):
    """What must stay fixed under a perturbation for the map to be smooth:
    the number of impacts and (obstacles with corners) the smooth piece of each
    impact.  naive reports a corner impact with the right-hand piece, which is
    what ``_piece_index`` (right-continuous) returns for the corner float."""
    if obstacle == "sine":  # pieces are bookkeeping only: z is smooth across them
        return (len(imp),)
    return (len(imp),) + tuple(naive._piece_index(obstacle, float(t), omega, theta1, theta2)
                               for t in imp[:, 0])


def _noise_level(run, x0, col, scale, sig0):
    """Absolute noise (per output component) of the simulated end state, ECnoise-style.

    The map is evaluated at ``x0 + m*delta*e_col``, ``m = -4..4``; for ``delta``
    this small the smooth part of the k-th differences (k = 3..6) is negligible,
    so ``rms(diff^k) / sqrt(binom(2k, k))`` estimates the standard deviation of
    the rounding noise (impact times are only refined to ~1e-15 + 9e-16*|t| by
    naive's ``brentq``).  The largest estimate over k is returned, or None if no
    delta keeps the impact sequence.
    """
    for delta in (1e-6, 1e-8, 1e-10):
        X = []
        for m in range(-4, 5):
            x = x0.copy()
            x[col] += m * delta * scale
            fx = run(x)
            if fx is None or fx[1] != sig0:
                break
            X.append(fx[0])
        else:
            X = np.array(X)
            est = [np.sqrt(np.mean(np.diff(X, n=kk, axis=0) ** 2, axis=0))
                   / math.sqrt(math.comb(2 * kk, kk)) for kk in range(3, 7)]
            return np.max(est, axis=0)
    return None


def fd_jacobian(obstacle, omega, kappa, beta, r, u0, v0, t0, duration, sigma=0.0, k=1.0,
                F=0.0, Omega=1.0, phi=0.0, theta1=None, theta2=None, h=None, h_max=1e-3,
                h_min=1e-8, ratio=0.5, dt=1e-3, full_output=False):
    """Jacobian ``d(u, v)(t0 + duration) / d(u0, v0)`` by central differences.

    Steps are relative to the state scale: column ``i`` (perturbing ``x_i``,
    ``x = (u0, v0)``) uses ``h_abs = h_rel * max(1, |x_i|)``.

    * ``h=None`` (default): a geometric ladder ``h_rel = h_max * ratio**m``
      down to ``h_min``.  Each admissible pair of successive central differences
      ``D(h), D(ratio h)`` is Richardson-extrapolated (the O(h^2) term
      cancels): ``R = (D(ratio h) - ratio^2 D(h)) / (1 - ratio^2)``.  The
      truncation error of ``R`` is estimated by the larger difference to its
      neighbours on the ladder (componentwise).
    * ``h`` given: only ``h_rel = h`` and ``ratio*h``; the truncation error is
      estimated by ``|R - D(ratio h)|``.

    The rounding error of ``R`` is bounded by ``3 * std`` where the standard
    deviation follows from the simulator's noise level ``eta`` (measured, see
    :func:`_noise_level`): ``eta / (sqrt(2) h) * sqrt(1/ratio^2 + ratio^4) /
    (1 - ratio^2)``.  Each column's error estimate is the (componentwise) sum of
    the two; the step with the smallest estimate (preferring estimates checked
    against both ladder neighbours) is returned.

    A step is admissible only if both perturbed runs have the same impact
    sequence as the unperturbed one (see :func:`_signature`), start strictly
    above the obstacle and do not chatter; otherwise it is skipped (smaller steps
    are tried).  If no usable steps remain, :class:`FDStepError` is raised.

    Returns ``(J, err)``: 2x2 arrays (``err`` entrywise absolute estimates), or
    ``(J, err, info)`` with ``full_output=True`` where ``info`` holds the chosen
    relative steps per column (``h_rel``), the measured noise levels (``noise``,
    rows = columns of J), the base impact times and the base state.
    """
    t0 = float(t0)
    t1 = t0 + float(duration)
    x0 = np.array([float(u0), float(v0)])
    args = (obstacle, omega, kappa, beta, r)
    phys = (sigma, k, F, Omega, phi, theta1, theta2, dt)

    def run(x):
        """(end state, signature), or None if x is not admissible: it starts on/below
        the obstacle (ValueError) or chatters (RuntimeError, e.g. an exact grazing)."""
        try:
            u, v, imp = _run(*args, x[0], x[1], t0, t1, *phys)
        except (ValueError, RuntimeError):
            return None
        return np.array([u, v]), _signature(obstacle, omega, theta1, theta2, imp)

    u1, v1, imp0 = _run(*args, x0[0], x0[1], t0, t1, *phys)
    sig0 = _signature(obstacle, omega, theta1, theta2, imp0)
    where0 = (f"the window [{t0}, {t1}] with impacts at {[float(t) for t in imp0[:, 0]]} is "
              f"at or too close to a nonsmooth point (grazing, a corner, or an impact at "
              f"the window end)")

    if h is None:
        n_steps = int(math.floor(math.log(h_min / h_max) / math.log(ratio) + 1e-9)) + 1
        ladder = [h_max * ratio**m for m in range(n_steps)]
    else:
        ladder = [float(h), float(h) * ratio]
    q2 = ratio * ratio
    noise_gain = 3.0 / math.sqrt(2.0) * math.sqrt(1.0 / q2 + q2 * q2) / (1.0 - q2)

    J = np.empty((2, 2))
    err = np.empty((2, 2))
    chosen = []
    noises = []
    for col in range(2):
        scale = max(1.0, abs(x0[col]))
        eta = _noise_level(run, x0, col, scale, sig0)
        if eta is None:
            raise FDStepError(f"column {col} (d/d{'uv'[col]}0): even steps of 1e-10 "
                              f"(relative) change the impact sequence: {where0}")
        noises.append(eta)
        D = []  # central differences (None where the step is not admissible)
        rejected = []
        for hr in ladder:
            e = np.zeros(2)
            e[col] = hr * scale
            fp, fm = run(x0 + e), run(x0 - e)
            if fp is None or fm is None:
                D.append(None)
                rejected.append((hr, "start below the obstacle, or chattering"))
            elif fp[1] != sig0 or fm[1] != sig0:
                D.append(None)
                rejected.append((hr, f"impact sequence {fm[1]} / {fp[1]} vs {sig0}"))
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
                f"column {col} (d/d{'uv'[col]}0): no admissible run of successive steps in "
                f"[{ladder[-1]:.1e}, {ladder[0]:.1e}] (relative); {where0}. "
                f"Last rejections: {last}")
        _, m, Rm, e_m = best
        J[:, col] = Rm
        err[:, col] = e_m
        chosen.append(ladder[m])
    if full_output:
        info = dict(h_rel=chosen, noise=np.array(noises),
                    impact_times=[float(t) for t in imp0[:, 0]], n_impacts=len(imp0),
                    state=(u1, v1))
        return J, err, info
    return J, err


def settle(obstacle, omega, kappa, beta, r, u0, v0, n_periods, period, sigma=0.0, k=1.0,
           F=0.0, Omega=1.0, phi=0.0, theta1=None, theta2=None, t0=0.0, dt=1e-3):
    """State ``(u, v)`` at ``t = t0 + n_periods * period`` from ``(u0, v0)`` at ``t0``.

    One uninterrupted simulation (no restarts at the section times), to let a
    transient die out before a test case is built from the returned state.  The
    returned state is a valid start for :func:`state_at` / :func:`fd_jacobian`
    only if no impact happens exactly at the section time (then u > z).
    """
    t1 = float(t0) + n_periods * float(period)
    st = state_at(obstacle, omega, kappa, beta, r, u0, v0, t0, t1, sigma=sigma, k=k, F=F,
                  Omega=Omega, phi=phi, theta1=theta1, theta2=theta2, dt=dt)
    return st.u, st.v


def benettin(omega, u0, v0, t0, periods, delta=1e-9, obstacle="sine", kappa=0.0, beta=1.0,
             r=0.8):
    """The largest Lyapunov exponent by Benettin's two-trajectory method on the slow
    exhaustive simulator (``state_at``, built on tests/naive.py): a companion trajectory
    ``delta`` away, carried one obstacle period T at a time and put back at distance delta
    along the separation after each period; the mean of log(separation / delta) per unit
    time."""
    T = 2 * math.pi / omega
    x = np.array([u0, v0])
    e = np.array([1.0, 1.0]) / math.sqrt(2.0)
    total = 0.0
    for i in range(periods):
        a, b = t0 + i * T, t0 + (i + 1) * T
        s0 = state_at(obstacle, omega, kappa, beta, r, x[0], x[1], a, b)
        y = x + delta * e
        s1 = state_at(obstacle, omega, kappa, beta, r, y[0], y[1], a, b)
        x = np.array([s0.u, s0.v])
        d = np.array([s1.u, s1.v]) - x
        dist = np.linalg.norm(d)
        total += math.log(dist / delta)
        e = d / dist
    return total / (periods * T)
