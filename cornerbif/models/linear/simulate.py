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

**Sticking** (docs/linear.md, "Sticking"): an impact whose rebound a . v+ - z' is at most
``chatter`` on a contact that can be held (``flight.holdable``: law "impact", a fixed
obstacle, no soft stops in the system), where its contact force lam (``flight.held``) is > 0
after the law with r = 0, is recorded as an impact with v+ the held velocity (a . v+ = 0),
the state put on the contact, and the flight switches to the held one (the accelerations
projected, a . x'' = 0).  While held, the contact's searched "gap" is lam = row . y (the same
certified search, z = 0): its root with lam' < 0 is the release (not recorded; ``releases``
collects them), where the flight switches back, the contact free for the step 2 g3 / B4
(g3 = g^(3), B4 >= |g^(4)|), over which its gap is at least g3 s^3 / 12 > 0 (g, g', g'' are
0 at the release).  Other contacts are searched on the held flight; an impact on one of them
releases the held contact (its law alone, then the free flight: a held contact it drives into
the stop is its next impact).  Not handled (the run stops and says so): a chatter where the
contact cannot be held or lam <= 0, or on another contact while one is held.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .declare import FIXED
from .events import IMPACT, NONE, ContactObstacle, Gap, first_event_piece
from .flight import augmented, expm, forcing_state, held, holdable, soft_contacts
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
             tol: float = 1e-12, chatter: float = 1e-6, exits=None, releases=None):
    """The first ``count`` impacts from (x0, v0) at t0, within ``horizon`` of time: a list of
    Impact (a soft stop's entries and the impacts that start a hold among them), and why the
    run ended ("ok", "no impact within the horizon", "held on contact R from t = ... to the
    horizon", "chatters on contact R at t = ..."). ``exits``: a list that collects the soft
    stops' exits, as Impact (v_in = v_out); ``releases``: the held contacts' releases."""
    n = system.n
    soft = {i: b for b, i in enumerate(soft_contacts(system))}
    can_hold = holdable(system)
    obstacles = [ContactObstacle(c.obstacle, c.kappa, c.beta, c.omega) for c in system.contacts]
    inside_of = {i: ContactObstacle(FIXED, -system.contacts[i].kappa) for i in soft}
    zero = ContactObstacle(FIXED, 0.0)
    t = float(t0)
    y = np.concatenate([np.asarray(x0, float), np.asarray(v0, float), forcing_state(system, t)])
    act = sum(1 << b for i, b in soft.items()
              if system.contacts[i].gap @ y[:n] - system.contacts[i].kappa < 0.0)
    hold = -1                       # the contact held, -1: none
    free_from = {}                  # a released contact: searched from this time on
    flights = {}

    def window_of(A):
        return 2.0 * np.pi / max(1e-3, min(np.linalg.norm(A, 2), 1e3))

    def mode(act, hold):
        key = ("held", hold) if hold >= 0 else act
        if key not in flights:
            if hold >= 0:
                A, row = held(system, hold)
                flights[key] = (A, window_of(A), row)
            else:
                A = augmented(system, act)
                flights[key] = (A, window_of(A), None)
        return flights[key]

    def gap(i, A, y, t):
        """Contact i's searched gap: -g for a soft stop acting (its exit is -g's root), the
        contact force lam for the held contact (its release is lam's root)."""
        c = system.contacts[i]
        if i == hold:
            return Gap(A, y, t, mode(act, hold)[2], zero)
        if i in soft and act >> soft[i] & 1:
            return Gap(A, y, t, -c.gap, inside_of[i])
        return Gap(A, y, t, c.gap, obstacles[i])

    out = []
    while len(out) < count:
        A, window, _ = mode(act, hold)           # searched a window at a time
        best = (np.inf, -1, NONE, -1)
        while best[1] < 0:
            for i in range(len(system.contacts)):
                off = free_from.get(i, -np.inf) - t
                if off >= window:
                    continue
                if off > 0.0:
                    kind, s, j = first_event_piece(gap(i, A, expm(A * off) @ y, t + off),
                                                   window - off, tol)
                    s += off
                else:
                    kind, s, j = first_event_piece(gap(i, A, y, t), window, tol)
                if kind != NONE and s < best[0]:
                    best = (s, i, kind, j)
            if best[1] < 0:
                # none in this window: fly through it and search the next
                y = expm(A * window) @ y
                t += window
                if t - t0 > horizon:
                    if hold >= 0:
                        return out, (f"held on contact {system.contacts[hold].name} to the "
                                     "horizon")
                    return out, "no impact within the horizon"
        s, i, kind, j = best
        y = expm(A * s) @ y
        t += s
        c = system.contacts[i]
        g = gap(i, A, y, t)
        _, zp = g.obstacle.state(j, t)          # the slope of the piece it was found on
        v_in = y[n:2 * n].copy()
        w = g.c[:n] @ v_in - zp                 # (along -a inside a soft stop)
        if i == hold:
            w = g.cA[1] @ y                     # lam'
        if w >= 0.0:
            # moving away (a graze, or a gap left below zero by the last impact's
            # resolution): no impact; on past it by the leaving rule's free step w / B
            step = max(2.0 * tol, w / g.bound2(y, window, j))
            y = expm(A * step) @ y
            t += step
            continue
        if i == hold:
            # the contact force turns negative: released (the state goes on, no jump)
            hold = -1
            A0, window0, _ = mode(act, hold)
            g = Gap(A0, y, t, c.gap, obstacles[i])
            g3 = g.cA[3] @ y
            h = 1.0 / max(g.normA, 1e-300)      # the kernel's chunk
            step = max(2.0 * tol, min(h, 2.0 * g3 / g.bound4(y, h))) if g3 > 0.0 else 2.0 * tol
            free_from = {i: t + step}
            if releases is not None:
                releases.append(Impact(t, c.name, y[:n].copy(), v_in, v_in.copy(), False))
            continue
        if i in soft:
            act ^= 1 << soft[i]                 # entered or left: no jump, the flight switches
            if act >> soft[i] & 1:
                out.append(Impact(t, c.name, y[:n].copy(), v_in, v_in.copy(), kind != IMPACT))
            elif exits is not None:
                exits.append(Impact(t, c.name, y[:n].copy(), v_in, v_in.copy(), kind != IMPACT))
            continue
        v_out = newton_impact(system.mass, c.gap, v_in, zp, c.r)
        if c.gap @ v_out - zp > chatter:
            if hold >= 0:
                hold = -1                       # an impact elsewhere releases the held contact
            # the velocities change: a released contact's free step was bounded on the flight
            # before, and is searched again from here (the kernel's rule)
            free_from = {}
            y[n:2 * n] = v_out
            out.append(Impact(t, c.name, y[:n].copy(), v_in, v_out, kind != IMPACT))
            continue
        if can_hold[i] and hold < 0:
            v_held = newton_impact(system.mass, c.gap, v_in, zp, 0.0)
            yh = y.copy()
            yh[n:2 * n] = v_held
            row = mode(act, i)[2]
            if row is not None and row @ yh > 0.0:
                # chattered to rest, pressed on: held (docs/linear.md, "Sticking")
                # on the contact: g = a . x - kappa = 0 (the smallest move in M's metric,
                # within the event's resolution |w| tol)
                d = np.linalg.solve(system.mass, c.gap)
                yh[:n] -= (c.gap @ yh[:n] - c.kappa) * d / (c.gap @ d)
                y = yh
                hold = i
                free_from = {}
                out.append(Impact(t, c.name, y[:n].copy(), v_in, v_held, kind != IMPACT))
                continue
        y[n:2 * n] = v_out
        out.append(Impact(t, c.name, y[:n].copy(), v_in, v_out, kind != IMPACT))
        return out, f"chatters on contact {c.name} at t = {t!r} (where it cannot be held)"
    return out, "ok"
