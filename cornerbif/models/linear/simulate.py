"""Event-driven simulation of a linear vibro-impact system in pure numpy: exact
flights (flight.py), certified first events on every contact (events.py), the generalised
Newton law at each impact (impact.py).  A reference for the kernel,
and the check of those three pieces together against the engine's kernels
(tests/models/test_linear_simulate.py).

Simultaneous events: the contact whose gap reaches zero first is taken, ties (events within
``tol`` of each other) in the order the scene declares the contacts.  A graze applies the
law as an impact where the contact approaches (w- < 0); an event where it moves away
(w >= 0: a graze, or a gap left below zero by the last impact's resolution) is stepped
over by the leaving rule's free step, as the kernel does.  Not handled yet (the run stops and says so):
chattering (an impact whose relative velocity after it is below ``chatter``), sticking, soft
stops (law "spring").
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .events import IMPACT, NONE, ContactObstacle, Gap, first_event_piece
from .flight import augmented, expm, forcing_state
from .impact import newton_impact
from .system import LinearSystem


@dataclass
class Impact:
    t: float
    contact: str          # its name: the symbol
    x: np.ndarray
    v_in: np.ndarray
    v_out: np.ndarray
    graze: bool


def simulate(system: LinearSystem, x0, v0, t0: float, count: int, horizon: float = 1e4,
             tol: float = 1e-12, chatter: float = 1e-6):
    """The first ``count`` impacts from (x0, v0) at t0, within ``horizon`` of time: a list of
    Impact, and why the run ended ("ok", "no impact within the horizon", "chatters on
    contact R at t = ...", "a soft stop: not implemented")."""
    if any(c.law != "impact" for c in system.contacts):
        return [], "a soft stop (law 'spring'): not implemented yet"
    A = augmented(system)
    n = system.n
    obstacles = [ContactObstacle(c.obstacle, c.kappa, c.beta, c.omega) for c in system.contacts]
    t = float(t0)
    y = np.concatenate([np.asarray(x0, float), np.asarray(v0, float), forcing_state(system, t)])
    out = []
    window = 2.0 * np.pi / max(1e-3, min(np.linalg.norm(A, 2), 1e3))   # searched at a time
    while len(out) < count:
        best = (np.inf, -1, NONE, -1)
        length = window
        while best[1] < 0:
            for i, c in enumerate(system.contacts):
                kind, s, j = first_event_piece(Gap(A, y, t, c.gap, obstacles[i]), length, tol)
                if kind != NONE and s < best[0]:
                    best = (s, i, kind, j)
            if best[1] < 0:
                # none in this window: fly through it and search the next
                y = expm(A * length) @ y
                t += length
                if t - t0 > horizon:
                    return out, "no impact within the horizon"
        s, i, kind, j = best
        y = expm(A * s) @ y
        t += s
        c = system.contacts[i]
        _, zp = obstacles[i].state(j, t)          # the slope of the piece it was found on
        v_in = y[n:2 * n].copy()
        w = c.gap @ v_in - zp
        if w >= 0.0:
            # moving away (a graze, or a gap left below zero by the last impact's
            # resolution): no impact; on past it by the leaving rule's free step w / B
            gap = Gap(A, y, t, c.gap, obstacles[i])
            step = max(2.0 * tol, w / gap.bound2(y, window, j))
            y = expm(A * step) @ y
            t += step
            continue
        v_out = newton_impact(system.mass, c.gap, v_in, zp, c.r)
        y[n:2 * n] = v_out
        out.append(Impact(t, c.name, y[:n].copy(), v_in, v_out, kind != IMPACT))
        if c.gap @ v_out - zp <= chatter:
            return out, f"chatters on contact {c.name} at t = {t!r} (not implemented yet)"
    return out, "ok"

