"""The ``map2d`` model in the figures of sections 4-5: the maps' own side, whose regions are
the rule (56) itself (``maps.region``)."""

import numpy as np

from ...model import NormalFormSide


def map_regions(a, b, omega1, kappa1, r):
    """Letter of the map (56) acting on each x = (a, b): 'a', 'b', 'g' (or 'x' for NaN)."""
    from .maps import region  # start-up: loads numba (jitted), imported when drawn
    code = np.array([region(float(x), float(y), omega1, kappa1, r)
                     for x, y in zip(np.ravel(a), np.ravel(b))], dtype=np.int64)
    return np.array(["abgx"[c] if c >= 0 else "x" for c in code]).reshape(np.shape(a))


class MapsSide(NormalFormSide):
    def step(self, a, b, omega1, kappa1, r):
        """One step of the maps (56) from x = (a, b): (a', b', the region's code)."""
        from .maps import step  # start-up: loads numba
        return step(float(a), float(b), omega1, kappa1, r)

    def region(self, a, b, omega1, kappa1, r):
        """The code of the map (56) acting on x = (a, b): 0 alpha, 1 beta, 2 gamma."""
        from .maps import region  # start-up: loads numba
        return region(float(a), float(b), omega1, kappa1, r)

    def start_regions(self, data, omega, omega1, kappa1, r):
        a0, b0 = data.initial["u"].ravel(), data.initial["v"].ravel()
        return map_regions(a0, b0, omega1, kappa1, r), "the map's rule (56)"

    def point_regions(self, a, b, omega1, kappa1, r):
        return map_regions(a, b, omega1, kappa1, r)


SIDE = MapsSide(maps=True, panel="the local 2D maps (56)", order=1, first_return=1)
