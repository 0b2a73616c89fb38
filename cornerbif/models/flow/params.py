"""The ``flow`` model's parameters: their declarations and the packed vector.

``PARAMS`` declares each parameter (default, allowed range, doc, equation; the obstacle
kinds' own parameters included) and ``OBSTACLES`` is the registered obstacle kinds
(``cornerbif/obstacles``); config reads them through the model (``models/flow/model.py``).
Inside the kernels the parameters live in one float64 vector indexed by the slots of
``slots.py``, so every kernel compiles exactly once; ``pack`` fills it, each obstacle kind
writing its own slots.

Pure Python (no numba): checking a scene reads these declarations without loading a
kernel.  ``models/flow/packed.py`` adds the jitted views of a packed row the kernels call
(``as_tuple``, ``as_tuple_profile``) and re-exports everything here, as ``P``.
"""


import numpy as np

from ... import obstacles
from ...model import FREQUENCY, Param, anything, frequency, nonnegative, unit_interval
from .slots import *  # noqa: F403 (the packed row's slots, read as P.* with the declarations)
from .slots import (
    CHATTER,
    ESCAPE,
    INDEX,
    NPARAM,
    NPARAM_PROFILE,
    OBSTACLE,
    OMEGA,
    SECTION_AUTO,
    SECTION_PIECES,
    STOP_TOL,
    TOL,
)


def steady_or_frequency(v):
    """Omega: 0 (a constant force) or a frequency."""
    return v == 0.0 or frequency(v)


# --- the declarations (read by config through the registry) ------------------------------
# every obstacle kind of the flow model, each in its own module of cornerbif/obstacles
# (obstacles.OBSTACLE_MODULES; docs/architecture.md)
OBSTACLES = obstacles.registered()

PARAMS = {p.name: p for p in (
    Param("omega", 2.0, FREQUENCY, frequency, "obstacle frequency", "eq 8"),
    Param("kappa", 0.0, "any finite number", anything, "obstacle offset", "eq 8"),
    Param("beta", 1.0, ">= 0", nonnegative, "obstacle amplitude", "eq 8"),
    Param("r", 0.8, "in [0, 1]", unit_interval, "coefficient of restitution", "eq 5"),
    Param("sigma", 0.0, ">= 0", nonnegative, "damping", "eq 4"),
    Param("k", 1.0, ">= 0", nonnegative, "natural frequency", "eq 4"),
    Param("F", 0.0, "any finite number", anything, "forcing amplitude: f = F cos(Omega t + phi)",
          "eq 4"),
    Param("Omega", 1.0, ">= 0 (0: a constant force F cos phi, e.g. a follower's spring "
          "preload; its period 2 pi / value finite otherwise)", steady_or_frequency,
          "forcing frequency", "eq 4"),
    Param("phi", 0.0, "any finite number", anything, "forcing phase", "eq 4"),
) + tuple(p for o in OBSTACLES.values() for p in o.params)}

def pack(values: dict, obstacle: str, tol: float, chatter: float, escape: float,
         section_period: float | None, stop_tol: float = 0.0, profile=None) -> np.ndarray:
    """Pack named parameters of one grid point into the kernel's float64 vector
    (``pack_many`` for one point)."""
    return pack_many(values, 1, obstacle, tol, chatter, escape, section_period, stop_tol,
                     profile)[0]


def pack_many(values: dict, n: int, obstacle: str, tol: float, chatter: float,
              escape: float, section_period: float | None, stop_tol: float = 0.0,
              profile=None) -> np.ndarray:
    """Pack n grid points into rows of the kernel's float64 vector: ``values`` maps each
    named parameter to one value or to n values (a swept one).

    Missing values take their declared defaults (``PARAMS``); the obstacle kind writes its
    own slots (``Obstacle.pack_rows``: the triangle's slopes, default beta * omega; a cam's
    table, ``profile``).  ``stop_tol`` > 0 turns the kernel's early stop on (``run.stop =
    "period"``).
    """
    kind = OBSTACLES[obstacle]
    p = np.zeros((n, NPARAM_PROFILE if kind.own_kernel else NPARAM))

    def column(name):
        v = values.get(name, PARAMS[name].default)
        return np.full(n, np.nan) if v is None else np.broadcast_to(np.asarray(v, float), n)
    for name, index in INDEX.items():
        p[:, index] = column(name)
    p[:, OBSTACLE] = kind.code
    p[:, TOL] = tol
    p[:, CHATTER] = chatter
    p[:, ESCAPE] = escape
    kind.pack_rows(p, values, profile)
    omegas, at = np.unique(p[:, OMEGA], return_inverse=True)
    p[:, SECTION_PIECES] = np.array([section_pieces(obstacle, float(w), section_period,
                                                    profile) for w in omegas])[at.ravel()]
    p[:, SECTION_AUTO] = 1.0 if (kind.auto_section and section_period is None) else 0.0
    p[:, STOP_TOL] = stop_tol
    return p


def section_pieces(obstacle: str, omega: float, section_period: float | None,
                   profile=None) -> int:
    """Smooth pieces per Poincare section period (``section_period``, else the kind's
    default: T = 2 pi / omega, a cam's own period)."""
    kind = OBSTACLES[obstacle]
    P = kind.period(omega, profile)
    sp = kind.section_period(omega, profile) if section_period is None else section_period
    return max(1, round(sp / P)) * kind.pieces_per_period(profile)
