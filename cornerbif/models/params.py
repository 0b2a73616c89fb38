"""The ``flow`` model's parameters: their declarations and the packed vector (STYLE example 4).

``PARAMS`` declares each parameter (default, allowed range, doc, equation) and
``OBSTACLES`` each obstacle; config reads them through the registry
(``models/flow_model.py``).  Inside the kernels the parameters live in one float64
vector indexed by the constants below, so every kernel compiles exactly once.
"""

import math

import numpy as np

from .._jit import jit
from ..model import FREQUENCY, Obstacle, Param, anything, frequency, nonnegative, positive, unit_interval

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
# the named parameters of PARAMS (below) and their slots (theta1, theta2: pack)
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


# --- the declarations (read by config through the registry) ------------------------------
# every obstacle of the flow model: a new one is a line here and its jitted pieces in
# models/obstacle.py (docs/architecture.md)
OBSTACLES = {
    "sine": Obstacle("sine", 0, "kappa + beta sin(omega t) (section 2.2, no corners)",
                     period_pi=2, pieces=2, corners=False),
    "rectified_sine": Obstacle("rectified_sine", 1, "kappa + beta |sin(omega t)| (eq 8), "
                               "corners at k pi / omega", period_pi=1, pieces=1, corners=True,
                               normal_form=True),
    "triangle": Obstacle("triangle", 2, "eq (7) made periodic, period pi / omega: slope "
                         "+theta2 after each corner, -theta1 before it", period_pi=1, pieces=2,
                         corners=True),
}
# the section corners are put between the impact clusters (kernels.flow) for obstacles whose
# attractors near omega = 2 have one cluster every second corner (sections 3-4)
AUTO_SECTION = ("rectified_sine",)

PARAMS = {p.name: p for p in (
    Param("omega", 2.0, FREQUENCY, frequency, "obstacle frequency", "eq 8"),
    Param("kappa", 0.0, "any finite number", anything, "obstacle offset", "eq 8"),
    Param("beta", 1.0, ">= 0", nonnegative, "obstacle amplitude", "eq 8"),
    Param("r", 0.8, "in [0, 1]", unit_interval, "coefficient of restitution", "eq 5"),
    Param("sigma", 0.0, ">= 0", nonnegative, "damping", "eq 4"),
    Param("k", 1.0, ">= 0", nonnegative, "natural frequency", "eq 4"),
    Param("F", 0.0, "any finite number", anything, "forcing amplitude: f = F cos(Omega t + phi)",
          "eq 4"),
    Param("Omega", 1.0, FREQUENCY, frequency, "forcing frequency", "eq 4"),
    Param("phi", 0.0, "any finite number", anything, "forcing phase", "eq 4"),
    Param("theta1", None, "> 0 (default beta * omega, the slope of eq (8) at its corners)",
          positive, "triangle: slope magnitude before each corner", "eq 7",
          obstacles=("triangle",)),
    Param("theta2", None, "> 0 (default beta * omega)", positive,
          "triangle: slope after each corner", "eq 7", obstacles=("triangle",)),
)}

# the obstacle codes the kernels compare (models/obstacle.py)
SINE = OBSTACLES["sine"].code                      # section 2.2 (smooth, no corners)
RECTIFIED_SINE = OBSTACLES["rectified_sine"].code  # eq (8), corners at k pi / omega
TRIANGLE = OBSTACLES["triangle"].code              # eq (7) made periodic with period pi / omega

# --- integer run settings (a small int64 vector) --------------------------------------
I_TRANSIENT = 0
I_RECORD = 1
I_MAX_EVENTS = 2
I_MAX_PIECES = 3
NINT = 4


def obstacle_period(obstacle: str, omega: float) -> float:
    """Forcing period P (``Obstacle.period``): pi/omega for rectified_sine and triangle,
    2 pi/omega for sine."""
    return OBSTACLES[obstacle].period(omega)


def pieces_per_period(obstacle: str) -> int:
    """Smooth pieces per forcing period (``Obstacle.pieces``).

    ``sine`` is split at its half periods (no corner there, but the sign of z''
    is fixed on each half, which tightens the event-location bound);
    ``triangle`` has a rising and a falling piece.
    """
    return OBSTACLES[obstacle].pieces


def pack(values: dict, obstacle: str, tol: float, chatter: float, escape: float,
         section_period: float | None, stop_tol: float = 0.0) -> np.ndarray:
    """Pack named parameters of one grid point into the kernel's float64 vector.

    Missing values take their declared defaults (``PARAMS``);
    theta1 and theta2 default to beta * omega.  ``stop_tol`` > 0 turns the kernel's
    early stop on (``run.stop = "period"``).
    """
    v = {k: values.get(k, p.default) for k, p in PARAMS.items()}
    p = np.zeros(NPARAM)
    for name, index in INDEX.items():
        p[index] = v[name]
    for name, index in (("theta1", THETA1), ("theta2", THETA2)):
        t = v[name]
        p[index] = v["beta"] * v["omega"] if t is None or (isinstance(t, float) and math.isnan(t)) else t
    p[OBSTACLE] = OBSTACLES[obstacle].code
    p[TOL] = tol
    p[CHATTER] = chatter
    p[ESCAPE] = escape
    p[SECTION_PIECES] = section_pieces(obstacle, v["omega"], section_period)
    p[SECTION_AUTO] = 1.0 if (obstacle in AUTO_SECTION and section_period is None) else 0.0
    p[STOP_TOL] = stop_tol
    return p


def section_pieces(obstacle: str, omega: float, section_period: float | None) -> int:
    """Smooth pieces per Poincare section period (default T = 2 pi / omega)."""
    ob = OBSTACLES[obstacle]
    P = ob.period(omega)
    sp = 2.0 * math.pi / omega if section_period is None else section_period
    return max(1, round(sp / P)) * ob.pieces
