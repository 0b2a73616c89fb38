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
# the named parameters of models/flow_model.PARAMS and their slots (theta1, theta2: pack)
INDEX = {"omega": OMEGA, "kappa": KAPPA, "beta": BETA, "r": R, "sigma": SIGMA, "k": K,
         "F": F_AMP, "Omega": F_OMEGA, "phi": F_PHI}


@jit
def as_tuple(p):
    """The packed parameter row as a tuple of NPARAM floats.

    A tuple is a value: the kernels' many small calls pass it without the atomic
    reference counting every array argument costs (measured: a fifth of the flow
    kernel's time went to NRT_incref / NRT_decref).
    """
    return (p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9],
            p[10], p[11], p[12], p[13], p[14], p[15], p[16], p[17])


# --- obstacle codes (declared with each obstacle in models/flow_model.OBSTACLES) ---------
from .flow_model import OBSTACLES as _DECLARED  # noqa: E402  (numba-free declarations)

SINE = _DECLARED["sine"].code                      # section 2.2 (smooth, no corners)
RECTIFIED_SINE = _DECLARED["rectified_sine"].code  # eq (8), corners at k pi / omega
TRIANGLE = _DECLARED["triangle"].code              # eq (7) made periodic with period pi / omega

OBSTACLES = {name: ob.code for name, ob in _DECLARED.items()}

# --- integer run settings (a small int64 vector) --------------------------------------
I_TRANSIENT = 0
I_RECORD = 1
I_MAX_EVENTS = 2
I_MAX_PIECES = 3
NINT = 4


def obstacle_period(obstacle: str, omega: float) -> float:
    """Forcing period P (``Obstacle.period``): pi/omega for rectified_sine and triangle,
    2 pi/omega for sine."""
    return _DECLARED[obstacle].period(omega)


def pieces_per_period(obstacle: str) -> int:
    """Smooth pieces per forcing period (``Obstacle.pieces``).

    ``sine`` is split at its half periods (no corner there, but the sign of z''
    is fixed on each half, which tightens the event-location bound);
    ``triangle`` has a rising and a falling piece.
    """
    return _DECLARED[obstacle].pieces


def pack(values: dict, obstacle: str, tol: float, chatter: float, escape: float,
         section_period: float | None, stop_tol: float = 0.0) -> np.ndarray:
    """Pack named parameters of one grid point into the kernel's float64 vector.

    Missing values take their declared defaults (``models.flow_model.PARAMS``);
    theta1 and theta2 default to beta * omega.  ``stop_tol`` > 0 turns the kernel's
    early stop on (``run.stop = "period"``).
    """
    from .flow_model import AUTO_SECTION, PARAMS, section_pieces
    v = {k: values.get(k, p.default) for k, p in PARAMS.items()}
    p = np.zeros(NPARAM)
    for name, index in INDEX.items():
        p[index] = v[name]
    for name, index in (("theta1", THETA1), ("theta2", THETA2)):
        t = v[name]
        p[index] = v["beta"] * v["omega"] if t is None or (isinstance(t, float) and math.isnan(t)) else t
    p[OBSTACLE] = OBSTACLES[obstacle]
    p[TOL] = tol
    p[CHATTER] = chatter
    p[ESCAPE] = escape
    p[SECTION_PIECES] = section_pieces(obstacle, v["omega"], section_period)
    p[SECTION_AUTO] = 1.0 if (obstacle in AUTO_SECTION and section_period is None) else 0.0
    p[STOP_TOL] = stop_tol
    return p
