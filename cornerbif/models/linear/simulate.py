"""Event-driven simulation of a linear vibro-impact system in pure numpy: exact
flights (flight.py), certified first events on every contact (events.py), the generalised
Newton law at each impact (impact.py).  A reference for the kernel,
and the check of those three pieces together against the engine's kernels
(tests/models/test_linear_simulate.py).

Simultaneous events: the contact whose gap reaches zero first is taken, ties (events within
``tol`` of each other) in the order the scene declares the contacts.  A graze applies the
law as an impact where the contact approaches (w- < 0); an event where it moves away
(w >= 0: a graze, or a gap left below zero by the last impact's resolution) is stepped
over by the leaving rule's free step, as the kernel does.

**Soft stops** (law "spring", on a fixed obstacle z = kappa): outside (g > 0) a soft stop's
first event is its entry (g reaching 0 with g' < 0), where nothing jumps: the flight switches
to the one with its spring and dashpot acting (``flight.augmented(system, active)``) and the
entry is recorded as an impact with v+ = v-.  Inside, its event is its exit: the certified
search on -g = -a . x + kappa from above (the same search), reaching 0 with g' > 0; the
flight switches back, and the exit is not an impact (``exits`` collects them when given).
Other contacts are searched as always, on the flight of the soft stops acting.
Not handled yet (the run stops and says so): chattering (an impact whose relative velocity
after it is below ``chatter``), sticking.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .declare import FIXED
from .events import IMPACT, NONE, ContactObstacle, Gap, first_event_piece
from .flight import augmented, expm, forcing_state, soft_contacts
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
             tol: float = 1e-12, chatter: float = 1e-6, exits=None):
    """The first ``count`` impacts from (x0, v0) at t0, within ``horizon`` of time: a list of
    Impact (a soft stop's entries among them), and why the run ended ("ok", "no impact
    within the horizon", "chatters on contact R at t = ..."). ``exits``: a list that
    collects the soft stops' exits, as Impact (v_in = v_out)."""
    n = system.n
    soft = {i: b for b, i in enumerate(soft_contacts(system))}
    obstacles = [ContactObstacle(c.obstacle, c.kappa, c.beta, c.omega) for c in system.contacts]
    inside_of = {i: ContactObstacle(FIXED, -system.contacts[i].kappa) for i in soft}
    t = float(t0)
    y = np.concatenate([np.asarray(x0, float), np.asarray(v0, float), forcing_state(system, t)])
    act = sum(1 << b for i, b in soft.items()
              if system.contacts[i].gap @ y[:n] - system.contacts[i].kappa < 0.0)
    flights = {}

    def mode(act):
        if act not in flights:
            A = augmented(system, act)
            flights[act] = (A, 2.0 * np.pi / max(1e-3, min(np.linalg.norm(A, 2), 1e3)))
        return flights[act]

    def gap(i, A, y, t):
        """Contact i's searched gap: -g for a soft stop acting (its exit is -g's root)."""
        c = system.contacts[i]
        if i in soft and act >> soft[i] & 1:
            return Gap(A, y, t, -c.gap, inside_of[i])
        return Gap(A, y, t, c.gap, obstacles[i])

    out = []
    while len(out) < count:
        A, window = mode(act)           # searched a window at a time
        best = (np.inf, -1, NONE, -1)
        while best[1] < 0:
            for i in range(len(system.contacts)):
                kind, s, j = first_event_piece(gap(i, A, y, t), window, tol)
                if kind != NONE and s < best[0]:
                    best = (s, i, kind, j)
            if best[1] < 0:
                # none in this window: fly through it and search the next
                y = expm(A * window) @ y
                t += window
                if t - t0 > horizon:
                    return out, "no impact within the horizon"
        s, i, kind, j = best
        y = expm(A * s) @ y
        t += s
        c = system.contacts[i]
        g = gap(i, A, y, t)
        _, zp = g.obstacle.state(j, t)          # the slope of the piece it was found on
        v_in = y[n:2 * n].copy()
        w = g.c[:n] @ v_in - zp                 # (along -a inside a soft stop)
        if w >= 0.0:
            # moving away (a graze, or a gap left below zero by the last impact's
            # resolution): no impact; on past it by the leaving rule's free step w / B
            step = max(2.0 * tol, w / g.bound2(y, window, j))
            y = expm(A * step) @ y
            t += step
            continue
        if i in soft:
            act ^= 1 << soft[i]                 # entered or left: no jump, the flight switches
            if act >> soft[i] & 1:
                out.append(Impact(t, c.name, y[:n].copy(), v_in, v_in.copy(), kind != IMPACT))
            elif exits is not None:
                exits.append(Impact(t, c.name, y[:n].copy(), v_in, v_in.copy(), kind != IMPACT))
            continue
        v_out = newton_impact(system.mass, c.gap, v_in, zp, c.r)
        y[n:2 * n] = v_out
        out.append(Impact(t, c.name, y[:n].copy(), v_in, v_out, kind != IMPACT))
        if c.gap @ v_out - zp <= chatter:
            return out, f"chatters on contact {c.name} at t = {t!r} (not implemented yet)"
    return out, "ok"
