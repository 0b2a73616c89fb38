"""The "typical user's" SciPy peer: a plain ``solve_ivp`` event loop.

System (Budd & Piiroinen, "Corner bifurcations in non-smoothly forced impact
oscillators", the paper in ``shared/paper``): sigma = 0, k = 1, no forcing,

    u'' + u = 0            while u > z(t),
    z(t) = kappa + beta*|sin(omega t)|                                    (8)
    v+ = (1 + r) z'(t) - r v-                at u = z(t)                  (5)
    z'(t) = beta*omega*cos(omega t)*sign(sin(omega t)).

This module is a *benchmark peer*, not a reference solver: it is written the
way a typical SciPy user writes an impact loop, so that the speed and the
failure modes of that approach can be measured against the engine.

The loop
--------
1. ``solve_ivp(rhs, (t, t_bound), [u, v], method=..., rtol=..., atol=...,
   max_step=..., events=gap)`` with ``gap(t, y) = u - kappa - beta*|sin(omega t)|``,
   ``gap.terminal = True`` and ``gap.direction = -1``;
2. take the first event ``(t_e, u_e, v_in)``, apply the impact law
   ``v_out = (1 + r) z'(t_e) - r v_in``;
3. restart ``solve_ivp`` at ``t_e`` with ``[u_e, v_out]`` (no nudge: after the
   impact ``g' = v_out - z' > 0`` and ``direction = -1`` prevent re-triggering
   in most cases).

Choices a typical user has to make, kept simple and documented here:

* **Spurious event at the start.**  If the solver reports the event within
  ``1e-12`` of the segment start with ``v_in >= z'`` (particle not
  approaching the obstacle), the event is skipped: the state is advanced
  over ``[t, t + 1e-9]`` by an event-free ``solve_ivp`` call and the loop
  goes on.  Counted in ``"skipped"``.
* **Corner convention.**  z' is undefined at the corners ``t_k = k pi/omega``
  (the paper leaves the impact law undefined there).  An impact located
  within ``corner_tol`` (default ``1e-9``) of a corner uses the right
  derivative ``z'(t_k+) = +beta*omega`` (the obstacle is leaving the corner).
  Without this, ``np.sign`` of a round-off-sized ``sin(omega t_e)`` picks
  -beta*omega or +beta*omega at random; e.g. the eq. (6) orbit
  ``u = 18|sin t|`` at omega = 2, kappa = 0, r = 0.8 impacts exactly at the
  corners and needs z' = +2 there (v_out = 0.8*18 + 1.8*2 = 18).
  ``corner_tol=0`` gives the bare sign formula.  Because that orbit sits
  exactly on the corner it is fragile: DOP853 (rtol 1e-9) keeps it to ~6e-8
  over 2000 impacts (its event times drift to *after* the corner), RK45
  drifts to before the corner by ~6e-11 per impact and leaves the orbit
  after ~8 impacts (~28 with ``corner_tol=1e-7``).
* **Chatter.**  If the relative impact velocity ``|v_in - z'|`` falls below
  ``1e-9`` the run stops with status ``"chatter"`` (the impact is recorded).
* **No t_max.**  Each segment is then bounded by ``t + horizon`` (default
  1e3); no event in that window ends the run with status ``"no_impact"``.

Misses
------
After every segment the solution's step points ``t_i`` (returned by
``solve_ivp`` anyway, no extra cost) are checked: the segment counts as a
*miss* if ``u(t_i) - z(t_i) < -1e-9`` at some step point, i.e. the solver
went through the obstacle without reporting an event.  The usual way this
happens: the restart state sits on ``g = 0`` to round-off; if ``g(t_e)`` comes
out as ``-1e-17`` and the particle goes down relative to the obstacle (a
low-velocity re-impact, typically just after a corner where z' jumps up),
``find_active_events`` needs ``g_old >= 0`` and sees no crossing.

With ``dense_check=True`` the segment is also integrated with
``dense_output=True`` and the interpolant is sampled inside every step
(``dense_samples`` points per step plus every arch top of z inside the step),
which additionally catches a particle that dips through the obstacle and
comes back within one step.  This costs extra right-hand-side evaluations
(DOP853 needs 3 more stages per step for its dense output), so it is off by
default and the timing of a ``dense_check`` run is not the typical user's.

``seconds`` is the wall time of the loop (solver calls + impact law) with the
miss bookkeeping subtracted (reported as ``audit_seconds``).

Usage::

    /work/venv/bin/python benchmarks/peer_scipy.py [DOP853|RK45]  # tiny Fig. 4(c) sweep
"""

from __future__ import annotations

import json
import math
import sys
import time

import numpy as np
from scipy.integrate import solve_ivp

MISS_TOL = 1e-9          # "below the obstacle" threshold for the miss audit
CHATTER_TOL = 1e-9       # relative impact velocity that ends the run
START_TOL = 1e-12        # "event at the segment start"
SKIP_DT = 1e-9           # event-free advance after a spurious start event


def _rhs(t, y):
    # u'' + u = 0, written the way a typical user writes it
    return [y[1], -y[0]]


def run_peer(omega, kappa, beta, r, u0, v0, n_impacts, method="DOP853",
             rtol=1e-9, atol=1e-12, t0=0.0, t_max=None, max_step=np.inf,
             corner_tol=1e-9, horizon=1e3, dense_check=False, dense_samples=8):
    """Run the solve_ivp event loop until ``n_impacts`` impacts (or a stop).

    Returns a dict: ``t``, ``u``, ``v_in``, ``v_out`` (arrays of the impacts
    found), ``misses`` (segments with a step point below the obstacle by more
    than 1e-9), ``seconds``, ``status`` (``"ok"``, ``"t_max"``,
    ``"chatter"``, ``"no_impact"``, ``"below_obstacle"`` or
    ``"solver_failed"``), plus ``segments``, ``skipped``, ``nfev``,
    ``audit_seconds``, ``method``.
    """
    omega = float(omega)
    kappa = float(kappa)
    beta = float(beta)
    r = float(r)
    period = math.pi / omega

    def gap(t, y):
        return y[0] - kappa - beta * np.abs(np.sin(omega * t))

    gap.terminal = True
    gap.direction = -1

    def zdot(t):
        k = round(t / period)
        if abs(t - k * period) <= corner_tol:
            return beta * omega                      # right derivative at a corner
        return beta * omega * np.cos(omega * t) * np.sign(np.sin(omega * t))

    T, U, VIN, VOUT = [], [], [], []
    misses = segments = skipped = nfev = 0
    audit = 0.0
    status = "ok"
    t = float(t0)
    y = [float(u0), float(v0)]

    if gap(t, y) <= 0.0:
        status = "below_obstacle"
        n_impacts = 0

    start = time.perf_counter()
    while len(T) < n_impacts:
        t_bound = t_max if t_max is not None else t + horizon
        if t >= t_bound:
            status = "t_max"
            break
        sol = solve_ivp(_rhs, (t, t_bound), y, method=method, rtol=rtol,
                        atol=atol, max_step=max_step, events=gap,
                        dense_output=dense_check)
        segments += 1
        nfev += sol.nfev

        a0 = time.perf_counter()                      # --- miss audit (untimed)
        ts = sol.t
        g = sol.y[0] - kappa - beta * np.abs(np.sin(omega * ts))
        missed = bool(np.any(g < -MISS_TOL))
        if dense_check and not missed and ts.size > 1:
            s = np.linspace(0.0, 1.0, dense_samples + 2)[1:-1]
            tt = (ts[:-1, None] + np.diff(ts)[:, None] * s[None, :]).ravel()
            k0 = math.ceil(omega * ts[0] / math.pi - 0.5)
            k1 = math.floor(omega * ts[-1] / math.pi - 0.5)
            tops = (np.arange(k0, k1 + 1) + 0.5) * period  # arch tops of z
            tt = np.concatenate((tt, tops))
            gd = sol.sol(tt)[0] - kappa - beta * np.abs(np.sin(omega * tt))
            missed = bool(np.any(gd < -MISS_TOL))
        misses += missed
        audit += time.perf_counter() - a0

        if sol.status == -1:
            status = "solver_failed"
            break
        if sol.status == 0:                           # reached t_bound, no event
            status = "t_max" if t_max is not None else "no_impact"
            break

        te = float(sol.t_events[0][0])
        ue, vin = (float(x) for x in sol.y_events[0][0])
        zd = float(zdot(te))

        if te - t <= START_TOL and vin >= zd:         # spurious: skip it
            skipped += 1
            adv = solve_ivp(_rhs, (te, te + SKIP_DT), [ue, vin], method=method,
                            rtol=rtol, atol=atol)
            nfev += adv.nfev
            t, y = float(adv.t[-1]), [float(adv.y[0, -1]), float(adv.y[1, -1])]
            continue

        vout = (1.0 + r) * zd - r * vin
        T.append(te)
        U.append(ue)
        VIN.append(vin)
        VOUT.append(vout)
        if abs(vin - zd) < CHATTER_TOL:
            status = "chatter"
            break
        t, y = te, [ue, vout]
    seconds = time.perf_counter() - start - audit

    return {
        "t": np.array(T), "u": np.array(U),
        "v_in": np.array(VIN), "v_out": np.array(VOUT),
        "misses": int(misses), "seconds": seconds, "status": status,
        "segments": segments, "skipped": skipped, "nfev": int(nfev),
        "audit_seconds": audit, "method": method,
    }


def sweep_peer(omegas, kappa=0.0, beta=1.0, r=0.8, n_starts=2, n_impacts=50,
               seed=0, method="DOP853", rtol=1e-9, atol=1e-12, max_step=np.inf,
               u_range=(0.0, 20.0), v_range=(-20.0, 20.0), **run_kw):
    """Fig. 4(c)-style sweep with the peer: random starts per omega.

    For each omega (in the given order) and each of ``n_starts`` starts, draw
    ``u0`` uniform in ``u_range`` (redrawn while ``u0 <= z(0) = kappa``), then
    ``v0`` uniform in ``v_range``, from one ``np.random.default_rng(seed)``;
    start at t = 0 and ask for ``n_impacts`` impacts.  Extra keywords go to
    :func:`run_peer`.  Returns totals (JSON-serialisable).
    """
    rng = np.random.default_rng(seed)
    omegas = np.atleast_1d(np.asarray(omegas, dtype=float))
    total_impacts = total_misses = total_segments = total_skipped = 0
    total_nfev = 0
    total_seconds = 0.0
    statuses = {}
    runs = 0
    for omega in omegas:
        for _ in range(n_starts):
            u0 = rng.uniform(*u_range)
            while u0 <= kappa:
                u0 = rng.uniform(*u_range)
            v0 = rng.uniform(*v_range)
            res = run_peer(omega, kappa, beta, r, u0, v0, n_impacts,
                           method=method, rtol=rtol, atol=atol,
                           max_step=max_step, **run_kw)
            runs += 1
            total_impacts += res["t"].size
            total_misses += res["misses"]
            total_segments += res["segments"]
            total_skipped += res["skipped"]
            total_nfev += res["nfev"]
            total_seconds += res["seconds"]
            statuses[res["status"]] = statuses.get(res["status"], 0) + 1
    return {
        "scene": "Fig. 4(c)",
        "method": method, "rtol": rtol, "atol": atol,
        "omega_min": float(omegas.min()), "omega_max": float(omegas.max()),
        "n_omegas": int(omegas.size), "n_starts": int(n_starts),
        "n_impacts": int(n_impacts), "kappa": float(kappa), "beta": float(beta),
        "r": float(r), "seed": seed, "runs": runs,
        "total_impacts": int(total_impacts),
        "total_seconds": total_seconds,
        "impacts_per_second": (total_impacts / total_seconds
                               if total_seconds > 0 else float("nan")),
        "total_misses": int(total_misses),
        "miss_fraction": (total_misses / total_segments
                          if total_segments else 0.0),
        "total_segments": int(total_segments),
        "total_skipped": int(total_skipped),
        "total_nfev": int(total_nfev),
        "statuses": statuses,
        "python": sys.version.split()[0],
    }


if __name__ == "__main__":
    out = sweep_peer(np.linspace(1.5, 2.5, 5), kappa=0.0, beta=1.0, r=0.8,
                     n_starts=2, n_impacts=50, seed=0,
                     method=sys.argv[1] if len(sys.argv) > 1 else "DOP853")
    print(json.dumps(out, indent=2))
