"""The time model of a linear run (``estimate.estimate_time``, ``--dry-run``): what the event
loop (kernel.py) pays per impact, per chunk of its flights and per obstacle piece it walks.

A run flies in chunks of H = 1 / |A| (|A| the 2-norm of the augmented matrix, flight.py), so a
stiff system pays for every chunk between its impacts; a contact on a moving obstacle is
searched piece by piece, so a fast obstacle pays for every piece.  The coefficients are
measured on this machine by ``python benchmarks/estimate_time.py --calibrate`` (one numba
thread, process CPU time): ``COST_IMPACT`` an impact, its chunks aside (the calibration's
2.7 us includes ``simulate``'s own overhead per call; whole sweeps give 0.7-1.7 us);
``COST_CHUNK`` a chunk that proves no event; ``COST_PIECE`` an obstacle piece walked within a
chunk.  A system is
prepared once per grid point (``kernel.prepare``, ``COST_SYSTEM``).  A run counts its
impacts (transient + record) over every contact, but with ``[system] words`` over the
``impacts`` contact alone, while it resolves every contact's impacts between them
(``resolved_per_counted``).
"""

from __future__ import annotations

import math

import numpy as np

from ... import obstacles
from .declare import FIXED
from .flight import augmented
from .system import LinearSystem

COST_IMPACT = 1.0e-6
COST_CHUNK = 2.0e-7
COST_PIECE = 8.6e-8
COST_SYSTEM = 6e-4
# the range around the model: whole sweeps (``python benchmarks/estimate_time.py --only
# two_stops bouncing_ball fig06a_linear``, two threads) took from 0.5 to 2.5 times it
SPREAD = (0.5, 2.5)


def piece_rate(system: LinearSystem) -> float:
    """Obstacle pieces per unit time, summed over the contacts on a moving obstacle."""
    kinds = obstacles.registered()
    rate = 0.0
    for c in system.contacts:
        if c.obstacle != FIXED:
            kind = kinds[c.obstacle]
            rate += kind.pieces_per_period(None) / kind.period(c.omega)
    return rate


def resolved_per_counted(system: LinearSystem) -> float:
    """Impacts a run resolves per impact it counts: 1, but with ``[system] words`` a run
    counts the ``impacts`` contact's impacts alone and resolves every contact's between them
    (the ``corners`` contact's, which name them).  Each contact is taken to impact about
    once a time scale, the rate ``run_seconds`` takes for every flight: as many impacts as
    contacts per counted one.  Fig. 19(a)'s system (``configs/fig19a_linear.toml``): 2,
    where its sweep resolves 1.85 (0.85 W impacts per U impact, its U impacts 0.85 wall
    periods apart: benchmarks/README.md, "The two-particle kernel against the flow's")."""
    return float(len(system.contacts)) if system.words is not None else 1.0


def run_seconds(system: LinearSystem, impacts: int, time_scale: float, budget: float,
                starts: int) -> tuple:
    """(seconds of one core, low, high, reasons) for one run of ``impacts`` impacts of
    ``system`` (transient + record, as the run counts them), whose flights last about
    ``time_scale`` between counted impacts (the system's period, else its slowest natural
    period: ``model.time_scale``) and at most ``budget`` in all (``run.max_periods`` time
    scales); ``starts``: the runs of a grid point, which share its system's preparation.
    Every impact resolved is paid (``resolved_per_counted``: with ``[system] words``, the
    other contacts' too).  The low end: the impacts alone, a chunk each; the high end: the
    whole budget flown."""
    norm = float(np.linalg.norm(augmented(system), 2))
    rate = piece_rate(system)
    events = impacts * resolved_per_counted(system)
    base = events * COST_IMPACT + COST_SYSTEM / max(1, starts)

    def flown(span):
        return span * norm * COST_CHUNK + span * rate * COST_PIECE

    middle = base + flown(min(impacts * time_scale, budget))
    low = SPREAD[0] * (base + events * COST_CHUNK)
    high = SPREAD[1] * (base + flown(budget) + events * COST_CHUNK)
    reasons = []
    if high > 1.5 * low:
        reasons.append("a run may fly up to its time budget (run.max_periods) between impacts, "
                       "in chunks of 1/|A|" + (" and obstacle pieces" if rate > 0.0 else ""))
    if not math.isfinite(high):
        reasons.append("the budget's chunks or pieces are past counting")
    return middle, low, high, reasons
