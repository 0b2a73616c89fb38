"""The jitted pieces of the ``two_particle`` model (section 6) that read its packed
parameter row: the row as a tuple, law (74) for z-u impacts.

The model's equations (72)-(74), its declarations, the slots of the packed vector and
``pack`` are in ``models/two_particle/params.py`` (pure Python, so that checking a scene
loads no numba); they are re-exported here, where the kernels read them as ``P.*``.
"""

import math

from ..._jit import jit
from ...numerics.impact import restitution
from .params import *  # noqa: F403 (the declarations and slots, read by the kernels as P.*)


@jit
def as_tuple(p):
    """The packed parameter row as a tuple of NPARAM floats: a value, so the kernel's calls
    pass it without atomic reference counting (see ``params.as_tuple``)."""
    return (p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9], p[10], p[11], p[12],
            p[13], p[14], p[15], p[16], p[17], p[18], p[19])


@jit
def mass_ratio_impact(y_in, v_in, mu, r2):
    """Law (74): velocities (y+, v+) of z (mass M) and u (mass m = M/mu) after u = z.

    Written as increments, d = (1 + r2)(v- - y-):
    y+ = y- + d/(1 + mu), v+ = v- - d + d/(1 + mu), which is the matrix of (74)
    rearranged; it conserves mu y + v and gives v+ - y+ = -r2 (v- - y-) to
    rounding.  ``mu = inf`` returns exactly law (5): y+ = y-,
    v+ = (1 + r2) y- - r2 v-.
    """
    if mu == math.inf:
        return y_in, restitution(v_in, y_in, r2)
    d = (1.0 + r2) * (v_in - y_in)
    a = d / (1.0 + mu)
    return y_in + a, (v_in - d) + a
