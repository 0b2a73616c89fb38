"""The paper's obstacle, eq (8): z = kappa + beta |sin(omega t)|, period pi / omega, one
corner per period at its start (the valleys z = kappa at t = k pi / omega).

What it can do beyond a plain obstacle: the corner normal form of sections 4-5 (the maps
alpha, beta, gamma and the closed forms of section 3.3 are derived for it), the section
corners put between the impact clusters of its attractors near omega = 2 (one cluster every
second corner), seeds of periodic orbits from a bare word of cluster letters, and the wedge
figure of eq (7).  Its jitted pieces are the ``RECTIFIED_SINE`` branches of
``obstacles/dispatch.py``."""

from ..model import Obstacle

OBSTACLE = Obstacle("rectified_sine", 1, "kappa + beta |sin(omega t)| (eq 8), corners at "
                    "k pi / omega", period_pi=1, pieces=1, corners=True, normal_form=True,
                    auto_section=True, word_seeds=True, corner_wedge=True)
