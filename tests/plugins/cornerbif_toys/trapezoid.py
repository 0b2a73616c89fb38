"""An obstacle kind from outside the package: a trapezoid wave z = kappa + beta g(omega t),
g rising at unit slope from 0 to ``height`` (= pi/2 duty), dwelling, falling back and
dwelling again over the period 2 pi; its four joints are corners.  Its pieces are a cam's
(polynomials), so it runs on the cam kernel (the profile's code) with no jitted code of its
own: its kind builds the cam table from its parameter ``duty`` (the rising share of the
period) and packs it into each row."""

import math

import numpy as np

from cornerbif.model import Param
from cornerbif.obstacles import profile as cam


def trapezoid(duty):
    """The cam profile of the trapezoid of rising share ``duty`` of the period 2 pi."""
    rise = duty * math.pi          # rise and fall take duty * pi each, the dwells the rest
    dwell = math.pi - rise
    return cam.read({"period": 2 * math.pi, "pieces": [
        {"span": rise, "poly": [0.0, 1.0]}, {"span": dwell, "poly": [rise]},
        {"span": rise, "poly": [rise, -1.0]}, {"span": dwell, "poly": [0.0]}]})


class Trapezoid(cam.CamProfile):
    def read_tables(self, system, w):
        duty = system.get("duty", 0.5)
        if isinstance(duty, float) and 0.0 < duty < 1.0:
            w.obstacle_table = trapezoid(duty)

    def pack_rows(self, rows, values, table=None):
        duty = np.broadcast_to(np.asarray(values.get("duty", 0.5), float), rows.shape[0])
        for row, d in zip(rows, duty):
            cam.pack_profile(row, trapezoid(float(d)))


OBSTACLE = Trapezoid(
    "trapezoid", cam.OBSTACLE.code, "kappa + beta g(omega t), g a trapezoid wave (a plug-in)",
    period_pi=2, pieces=4, corners=True, continuation=False, own_kernel=True,
    params=(Param("duty", 0.5, "in (0, 1)", lambda v: 0 < v < 1,
                  "trapezoid: the rising share of half the period", obstacles=("trapezoid",)),))
