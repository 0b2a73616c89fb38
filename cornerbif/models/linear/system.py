"""A linear vibro-impact system as a scene declares it (docs/linear.md): N coordinates x
with a mass matrix M, a stiffness K and a damping C,
harmonic and constant forces, and contacts, each a gap g = a . x - z(t) that stays >= 0 in
flight against an obstacle z(t) = kappa + beta shape(omega t), with an impact law
(restitution r: the generalised Newton law, ``impact.newton_impact``) or a soft stop (a
spring k and dashpot c acting while g < 0).

Between events the motion is M x'' + C x' + K x = f(t), f = sum of the forces: linear, so
its flights are exact (``flight.py``).  This module holds only the declarations, pure
Python (checking a scene loads no numba); ``declare.read_system`` builds them from the
scene's ``[system]`` table and says what is wrong with it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

MAX_DOFS = 6          # N: the exact flight's augmented matrix stays small (flight.py)
MAX_CONTACTS = 8
MAX_SOFT = 3          # soft stops (law "spring"): each set of them acting is a flight (2^3)


@dataclass(frozen=True)
class Forcing:
    """F cos(Omega t + phi) on coordinate ``on`` (an index into the system's dofs);
    Omega = 0: the constant force F cos(phi)."""
    on: int
    F: float
    Omega: float = 0.0
    phi: float = 0.0


@dataclass(frozen=True)
class Contact:
    """A contact: the gap g = a . x - z(t), z = kappa + beta shape(omega t) (``obstacle``:
    "fixed", z = kappa, or an obstacle kind of cornerbif.obstacles), and its law: "impact"
    (w+ = -r w-, w = a . v - z') or "spring" (a soft stop: the generalised force
    -(k g + c g') a while g < 0, g' = a . v - z')."""
    name: str                  # one letter: the impact's symbol in words
    gap: np.ndarray            # (N,) the vector a
    obstacle: str = "fixed"
    kappa: float = 0.0
    beta: float = 0.0
    omega: float = 0.0
    law: str = "impact"
    r: float = 0.8
    k: float = 0.0
    c: float = 0.0


@dataclass(frozen=True)
class Words:
    """The two-particle model's words (section 6; ``[system] words``): the impacts on
    contact ``impacts`` (its index) are recorded and named by their offsets to the impacts
    on contact ``corners``, which play the obstacle's corners (the w-z impacts of Fig. 19
    about which its u-z impacts cluster).  ``height`` and ``velocity`` (dof indices, -1:
    the gap's own u = a . x and v = a . v) are the coordinate whose position at the impact
    is its height u and the one whose velocities before and after are its v_in and v_out
    (the two-particle model's u = z and v = u')."""
    impacts: int
    corners: int
    height: int = -1
    velocity: int = -1


@dataclass(frozen=True)
class LinearSystem:
    """M x'' + C x' + K x = sum of ``forcing``, with ``contacts``; ``words``: None (the
    contacts' letters, or the paper's corner clusters with one cornered contact) or the
    two-particle model's (``Words``)."""
    dofs: tuple               # coordinate names, in order
    mass: np.ndarray          # (N, N) symmetric positive-definite
    stiffness: np.ndarray     # (N, N) symmetric positive semi-definite
    damping: np.ndarray       # (N, N) its symmetric part positive semi-definite
    forcing: tuple = ()       # of Forcing
    contacts: tuple = ()      # of Contact
    words: Words | None = None

    @property
    def n(self) -> int:
        return len(self.dofs)
