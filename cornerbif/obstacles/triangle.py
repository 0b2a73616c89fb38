"""The wedge of eq (7) made periodic with period pi / omega: from each corner (a valley at
z = kappa) the obstacle rises with slope theta2 to a peak and falls back with slope -theta1
into the next corner.  Two pieces per period; its own parameters theta1 and theta2 (default
beta omega, the slope of eq (8) at its corners).  Its jitted pieces are the ``TRIANGLE``
branches of ``obstacles/dispatch.py``."""

import math

import numpy as np

from ..model import Obstacle, Param, positive
from ..models.flow.slots import BETA, OMEGA, THETA1, THETA2


class Triangle(Obstacle):
    def pack_rows(self, rows, values, table=None):
        """theta1 and theta2 into their slots, beta omega where the scene gives none (None or
        NaN), as ``values`` maps each to one value or one per row."""
        n = rows.shape[0]
        for name, index in (("theta1", THETA1), ("theta2", THETA2)):
            v = values.get(name)
            t = np.full(n, np.nan) if v is None else np.broadcast_to(np.asarray(v, float), n)
            rows[:, index] = np.where(np.isnan(t), rows[:, BETA] * rows[:, OMEGA], t)

    def top(self, ctx):
        """Its peak theta1 theta2 / (theta1 + theta2) pi / omega above kappa, the highest over
        the scene's values."""
        kap = max(ctx.values_list("kappa"))
        beta = max(ctx.values_list("beta"))
        w = min(ctx.values_list("omega"))
        t1 = [x if x is not None else beta * w for x in ctx.values_list("theta1")]
        t2 = [x if x is not None else beta * w for x in ctx.values_list("theta2")]
        return kap + max(a * b / (a + b) for a in t1 for b in t2) * math.pi / w

    def speed(self, values, table=None):
        """The steeper of its two slopes."""
        w, beta = float(values["omega"]), float(values["beta"])
        t1, t2 = values.get("theta1"), values.get("theta2")
        return max(beta * w if t1 is None else float(t1), beta * w if t2 is None else float(t2))


OBSTACLE = Triangle(
    "triangle", 2, "eq (7) made periodic, period pi / omega: slope +theta2 after each corner, "
    "-theta1 before it", period_pi=1, pieces=2, corners=True, corner_wedge=True,
    params=(Param("theta1", None, "> 0 (default beta * omega, the slope of eq (8) at its "
                  "corners)", positive, "triangle: slope magnitude before each corner", "eq 7",
                  obstacles=("triangle",)),
            Param("theta2", None, "> 0 (default beta * omega)", positive,
                  "triangle: slope after each corner", "eq 7", obstacles=("triangle",))))
