"""Time series u(t), z(t) of a recorded attractor, rebuilt from its stored impacts.

The kernels keep impacts, not trajectories (a time series is asked for by
``output.keep = ["impacts"]`` and drawn from them).  Between two impacts the particle
is in free flight, and free flight is exact in closed form, so the trajectory is rebuilt from the
state just after each impact, (t_i, u_i, v_i^+), with the very functions the
kernel uses: ``numerics.oscillator.homogeneous`` and ``particular`` (eq 4) for u,
``obstacles.dispatch.z_state`` (eq 8, section 2.2, eq 7) for z.  No formula is
repeated here.

The rebuilt flight must meet the obstacle at the next stored impact
(``meet_error``): this is the check that the stored impacts and the free flight
agree.  A flight that contains a sticking phase (chattering, r < 1) is not free
flight; such a gap is reported by ``meet_error`` as large, and the plot marks it.
"""

from __future__ import annotations

import math

import numpy as np

from ...numerics.oscillator import derive, homogeneous, particular
from ...obstacles.dispatch import piece_at, z_state
from . import packed as P


def pack(values: dict, obstacle: str, section_period=None,
         profile=None) -> tuple[np.ndarray, np.ndarray]:
    """Packed parameters and derived constants of one point of a ``flow`` scene (a cam
    profile's checked ``Profile`` for ``obstacle = "profile"``)."""
    p = P.pack(values, obstacle, 1e-12, 1e-6, 1e6, section_period, profile=profile)
    return p, derive(p)


def obstacle_height(p: np.ndarray, d: np.ndarray, t) -> np.ndarray:
    """z(t) at absolute times t (eq 8, or the scene's obstacle)."""
    t = np.atleast_1d(np.asarray(t, float))
    out = np.empty(t.shape)
    for i, ti in enumerate(t.flat):
        j, tau = piece_at(d, ti)
        out.flat[i] = z_state(p, j, tau)[0]
    return out


def free_flight(p: np.ndarray, d: np.ndarray, t0: float, u0: float, v0: float, t) -> np.ndarray:
    """u(t) of the free flight that leaves (u0, v0) at t0 (eq 4, closed form)."""
    t = np.atleast_1d(np.asarray(t, float))
    up0, vp0 = particular(p, d, t0)
    uh0, vh0 = u0 - up0, v0 - vp0
    out = np.empty(t.shape)
    for i, ti in enumerate(t.flat):
        out.flat[i] = homogeneous(p, d, uh0, vh0, ti - t0)[0] + particular(p, d, ti)[0]
    return out


def meet_error(p, d, t, u, v_out) -> np.ndarray:
    """|u_i(t_{i+1}) - z(t_{i+1})| for each consecutive pair of stored impacts.

    u_i is the free flight from impact i; the value should be at the level of
    the event tolerance times the impact speed.  NaN where impact i+1 is absent.
    """
    n = len(t)
    err = np.full(max(n - 1, 0), np.nan)
    for i in range(n - 1):
        if not (np.isfinite(t[i]) and np.isfinite(t[i + 1])):
            continue
        ui = free_flight(p, d, t[i], u[i], v_out[i], t[i + 1])[0]
        err[i] = abs(ui - obstacle_height(p, d, t[i + 1])[0])
    return err


def rebuild(p, d, t, u, v_out, t_start, t_stop, samples_per_unit=40.0):
    """u(s), z(s) on a grid over [t_start, t_stop] from the stored impacts.

    Each sample takes the flight of the last impact at or before it; samples
    before the first impact are NaN.  Every impact time is itself a sample, so
    the drawn curve has its corners at the impacts.
    Returns (s, u(s), z(s)).
    """
    ok = np.isfinite(t)
    t, u, v_out = t[ok], u[ok], v_out[ok]
    n = max(2, int(math.ceil((t_stop - t_start) * samples_per_unit)) + 1)
    grid = np.linspace(t_start, t_stop, n)
    inside = t[(t > t_start) & (t < t_stop)]
    s = np.unique(np.concatenate([grid, inside]))
    us = np.full(s.shape, np.nan)
    which = np.searchsorted(t, s, side="right") - 1
    for i in np.unique(which):
        if i < 0:
            continue
        sel = which == i
        us[sel] = free_flight(p, d, t[i], u[i], v_out[i], s[sel])
    return s, us, obstacle_height(p, d, s)
