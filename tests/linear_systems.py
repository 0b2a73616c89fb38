"""Linear systems the tests of the linear model share (issue 33): the paper's two systems as
special cases, and an impact damper."""

import numpy as np

from cornerbif.models.linear.system import Contact, Forcing, LinearSystem

MU, OMEGA1, OMEGA2 = 1000.0, 1.001, 1.0      # Fig. 19(a)'s two particles


def one_mass(obstacle, omega, sigma=0.0, k=1.0, F=0.0, Omega=1.0, phi=0.0, r=0.8):
    """The flow model's system: u'' + 2 sigma u' + k^2 u = F cos(Omega t + phi) against the
    obstacle kappa + beta shape(omega t), kappa = 0, beta = 1, law (5) with r."""
    forcing = (Forcing(0, F, Omega, phi),) if F else ()
    return LinearSystem(("u",), np.array([[1.0]]), np.array([[k * k]]),
                        np.array([[2.0 * sigma]]), forcing,
                        (Contact("R", np.array([1.0]), obstacle, 0.0, 1.0, omega, r=r),))


def two_particles(omega0=2.0):
    """Fig. 19(a)'s system: z (mass 1, z'' + omega1^2 z = 0) above the wall
    w = sin(omega0 t) (contact W: the gap z - w, law 5 with r1 = 0.8) and u (mass 1/mu,
    u'' + omega2^2 u = 0) above z (contact U: the gap u - z, law 74 with r2 = 0.8)."""
    return LinearSystem(("z", "u"), np.diag([1.0, 1.0 / MU]),
                        np.diag([OMEGA1 * OMEGA1, OMEGA2 * OMEGA2 / MU]), np.zeros((2, 2)), (),
                        (Contact("W", np.array([1.0, 0.0]), "sine", 0.0, 1.0, omega0, r=0.8),
                         Contact("U", np.array([-1.0, 1.0]), "fixed", 0.0, r=0.8)))


def impact_damper():
    """A forced, damped primary x (m = 1, k = 1, c = 0.05, 0.7 cos(0.9 t)) with a free mass
    y (m = 0.1) in a cavity of clearance 2 x 0.4 (contacts R: y - x >= -0.4 and
    L: x - y >= -0.4, r = 0.5)."""
    return LinearSystem(("x", "y"), np.diag([1.0, 0.1]), np.diag([1.0, 0.0]),
                        np.diag([0.05, 0.0]), (Forcing(0, 0.7, 0.9, 0.0),),
                        (Contact("R", np.array([-1.0, 1.0]), "fixed", -0.4, r=0.5),
                         Contact("L", np.array([1.0, -1.0]), "fixed", -0.4, r=0.5)))
