"""The ``flow`` model in the figures of sections 4-5: the impacting system beside its corner
normal form, its starts lettered by the corner cluster it met in its first period."""

import math

import numpy as np

from ...model import NormalFormSide


def flow_regions(t, offset, omega):
    """Letter of the first-period corner cluster of each flow start (section 4).

    ``t`` and ``offset`` are the impacts (time, signed offset to the nearest
    corner) of each start, shape (n, record).  Only impacts with t < T =
    2 pi/omega whose nearest corner is t0 = pi/omega count.
    """
    T = 2.0 * math.pi / omega
    t0 = math.pi / omega
    out = np.full(t.shape[0], "x", dtype="<U1")
    for i in range(t.shape[0]):
        ok = np.isfinite(t[i]) & (t[i] < T) & (np.abs(t[i] - t0) < 0.5 * t0)
        off = offset[i][ok]
        before, after = int(np.sum(off < 0)), int(np.sum(off >= 0))
        if before == 0 and after == 1:
            out[i] = "b"
        elif before == 1 and after == 0:
            out[i] = "g"
        elif before == 1 and after == 1:
            out[i] = "a"
    return out


class FlowSide(NormalFormSide):
    def start_regions(self, data, omega, omega1, kappa1, r):
        if "impacts/t" not in data.data:
            raise ValueError(f"{data.path}: plot kind 'regions' of a flow file needs "
                             "output.keep = [\"impacts\", ...]")
        n = data.initial["u"].size
        lab = flow_regions(data.data["impacts/t"].reshape(n, -1),
                           data.data["impacts/corner_offset"].reshape(n, -1), omega)
        return lab, "the flow's first impacts at $t_0 = \\pi/\\omega$"


SIDE = FlowSide(maps=False, panel="the impacting system (direct simulation of the flow)",
                order=0, first_return=0)
