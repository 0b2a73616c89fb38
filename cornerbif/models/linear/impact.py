"""The impact law of a linear system's contact: the generalised Newton law.

A contact's gap is g = a . x - z(t); at an impact (g = 0, approaching: w- = a . v- - z' < 0)
an impulse P acts along the contact's normal in configuration space, the generalised force
a: M (v+ - v-) = P a.  Newton's law on the relative normal velocity, w+ = -r w-, fixes P:
a . v+ - z' = a . v- + P a.M^-1 a - z' = -r w-, so

    v+ = v- - (1 + r) w- M^-1 a / (a^T M^-1 a).

With N = 1, M = m and a = 1 this is the paper's law (5), v+ = (1 + r) z' - r v-; with two
masses (z of mass M, u of mass M / mu) and a = (-1, 1) (the gap u - z) it is law (74).
The momentum M v changes by P a only: q . M v is conserved for every q with q . a = 0
(two masses against each other, a = (-1, 1): the total momentum); with r = 1 and a fixed
obstacle the kinetic energy v . M v / 2 is conserved.
"""

from __future__ import annotations

import numpy as np


def newton_impact(mass, gap, v_in, z_slope, r):
    """The velocities v+ just after an impact on a contact with gap vector ``gap`` (a) at
    obstacle slope ``z_slope`` (z'), from v- = ``v_in``, with restitution ``r`` (module
    docstring)."""
    a = np.asarray(gap, float)
    v = np.asarray(v_in, float)
    d = np.linalg.solve(np.asarray(mass, float), a)         # M^-1 a
    w = a @ v - z_slope
    return v - (1.0 + r) * w * d / (a @ d)
