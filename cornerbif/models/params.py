"""Packed parameter vector of the ``flow`` model (STYLE example 4).

Parameters have names in Python and live in one float64 vector inside the
kernels, indexed by the constants below, so every kernel compiles exactly once.
"""

import math

import numpy as np

from .._jit import jit

# --- indices into the packed vector --------------------------------------------------
OMEGA = 0      # obstacle frequency omega (eq 8)
KAPPA = 1      # obstacle offset kappa (eq 8)
BETA = 2       # obstacle amplitude beta (eq 8)
R = 3          # coefficient of restitution r (eq 5)
SIGMA = 4      # damping sigma (eq 4)
K = 5          # natural frequency k (eq 4)
F_AMP = 6      # forcing amplitude F: f(t) = F cos(Omega t + phi) (eq 4)
F_OMEGA = 7    # forcing frequency Omega
F_PHI = 8      # forcing phase phi
THETA1 = 9     # triangle: slope magnitude before each corner (eq 7)
THETA2 = 10    # triangle: slope after each corner (eq 7)
OBSTACLE = 11  # obstacle code (below)
TOL = 12       # event-time tolerance
CHATTER = 13   # relative velocity below which a chattering sequence is summed
ESCAPE = 14    # amplitude bound beyond which a run is ESCAPED
SECTION_PIECES = 15  # smooth pieces per Poincare section period
SECTION_AUTO = 16    # 1: put the section corners between the impact clusters (see flow kernel)
STOP_TOL = 17        # > 0: stop once the attractor's period is established (run.stop = "period"),
                     # with this relative tolerance on the state at the corners; 0: never
NPARAM = 18


@jit
def as_tuple(p):
    """The packed parameter row as a tuple of NPARAM floats.

    A tuple is a value: the kernels' many small calls pass it without the atomic
    reference counting every array argument costs (measured: a fifth of the flow
    kernel's time went to NRT_incref / NRT_decref).
    """
    return (p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9],
            p[10], p[11], p[12], p[13], p[14], p[15], p[16], p[17])


# --- obstacle codes -------------------------------------------------------------------
SINE = 0            # kappa + beta sin(omega t), section 2.2 (smooth, no corners)
RECTIFIED_SINE = 1  # kappa + beta |sin(omega t)|, eq (8), corners at k pi / omega
TRIANGLE = 2        # eq (7) made periodic with period pi / omega

OBSTACLES = {"sine": SINE, "rectified_sine": RECTIFIED_SINE, "triangle": TRIANGLE}

# --- integer run settings (a small int64 vector) --------------------------------------
I_TRANSIENT = 0
I_RECORD = 1
I_MAX_EVENTS = 2
I_MAX_PIECES = 3
NINT = 4


def obstacle_period(obstacle: str, omega: float) -> float:
    """Forcing period P: pi/omega for rectified_sine and triangle, 2 pi/omega for sine."""
    return 2.0 * math.pi / omega if obstacle == "sine" else math.pi / omega


def pieces_per_period(obstacle: str) -> int:
    """Smooth pieces per forcing period.

    ``sine`` is split at its half periods (no corner there, but the sign of z''
    is fixed on each half, which tightens the event-location bound);
    ``triangle`` has a rising and a falling piece.
    """
    return {"sine": 2, "rectified_sine": 1, "triangle": 2}[obstacle]


def pack(values: dict, obstacle: str, tol: float, chatter: float, escape: float,
         section_period: float | None, stop_tol: float = 0.0) -> np.ndarray:
    """Pack named parameters of one grid point into the kernel's float64 vector.

    ``stop_tol`` > 0 turns the kernel's early stop on (``run.stop = "period"``).
    """
    p = np.zeros(NPARAM)
    p[OMEGA] = values["omega"]
    p[KAPPA] = values["kappa"]
    p[BETA] = values["beta"]
    p[R] = values["r"]
    p[SIGMA] = values.get("sigma", 0.0)
    p[K] = values.get("k", 1.0)
    p[F_AMP] = values.get("F", 0.0)
    p[F_OMEGA] = values.get("Omega", 1.0)
    p[F_PHI] = values.get("phi", 0.0)
    t1 = values.get("theta1")
    t2 = values.get("theta2")
    p[THETA1] = values["beta"] * values["omega"] if t1 is None or (isinstance(t1, float) and math.isnan(t1)) else t1
    p[THETA2] = values["beta"] * values["omega"] if t2 is None or (isinstance(t2, float) and math.isnan(t2)) else t2
    p[OBSTACLE] = OBSTACLES[obstacle]
    p[TOL] = tol
    p[CHATTER] = chatter
    p[ESCAPE] = escape
    P = obstacle_period(obstacle, values["omega"])
    sp = 2.0 * math.pi / values["omega"] if section_period is None else section_period
    p[SECTION_PIECES] = max(1, round(sp / P)) * pieces_per_period(obstacle)
    p[SECTION_AUTO] = 1.0 if (obstacle == "rectified_sine" and section_period is None) else 0.0
    p[STOP_TOL] = stop_tol
    return p
