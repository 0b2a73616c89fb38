"""The linearised oscillator (docs/stability.md): the closed-form flight matrix of eq (4) in
every damping regime (``flight_matrix``), the saltation matrix of an impact by law (5) on a
moving obstacle, the time-of-impact correction included (``impact_saltation``), and the tests
on a recorded impact that decide whether they apply (``grazes``, ``flight_misses``).  Shared
by the ``flow`` and ``two_particle`` tangent steps and by the orbit problems of continuation.
"""

import math

from .._jit import jit
from .oscillator import particular

GRAZING_TOL = 1e-9   # |w-| below this times the impact's velocity scale counts as grazing
FLIGHT_TOL = 1e-7    # a recorded impact further than this from the free flight of the one
                     # before (relative to its position and to its velocity) was reached
                     # through sticking


@jit
def flight_matrix(sigma, k, tau):
    """exp(A tau), A = [[0, 1], [-k^2, -2 sigma]] (eq 4 without forcing): the Jacobian of a
    flight of duration ``tau`` with respect to its initial state (u, v).

    With B = A + sigma I, B^2 = (sigma^2 - k^2) I, so exp(A tau) = exp(-sigma tau)
    (c I + s B) with c = cos(w_d tau), s = sin(w_d tau)/w_d, w_d = sqrt(k^2 - sigma^2)
    (under-damped), c = 1, s = tau (critical), c = cosh(q tau), s = sinh(q tau)/q,
    q = sqrt(sigma^2 - k^2) (over-damped, and the free particle k = sigma = 0 as its
    limit c = 1, s = tau).  Returns (m11, m12, m21, m22); det = exp(-2 sigma tau).
    """
    disc = k * k - sigma * sigma
    if disc > 0.0:
        wd = math.sqrt(disc)
        c = math.cos(wd * tau)
        s = math.sin(wd * tau) / wd
    elif disc == 0.0:
        c = 1.0
        s = tau
    else:
        q = math.sqrt(-disc)
        if q * tau > 1.0:
            # e^(-sigma tau) cosh(q tau) as the sum of the two modes' decays: no
            # overflow of cosh past q tau = 710 (a long heavily damped flight)
            e1 = 0.5 * math.exp((q - sigma) * tau)
            e2 = 0.5 * math.exp(-(q + sigma) * tau)
            ce = e1 + e2
            se = (e1 - e2) / q
            return ce + sigma * se, se, -k * k * se, ce - sigma * se
        c = math.cosh(q * tau)
        s = math.sinh(q * tau) / q
    e = math.exp(-sigma * tau)
    return e * (c + sigma * s), e * s, -e * k * k * s, e * (c - sigma * s)


@jit
def impact_saltation(r, sigma, w_in, a_in, zpp):
    """The saltation matrix of an impact by law (5) on the moving obstacle.

    The impact surface is g = u - z(t) = 0, crossed with relative velocity
    w- = v- - z'(t*) < 0; the jump is R(u, v, t) = (u, (1 + r) z'(t) - r v).  The
    perturbed impact happens at t* + dt with dt = -du-/w- (to first order), and
    S = D_x R + (f+ - D_x R f- - d_t R) (grad g)^T / (dg/dt), f^(-/+) = (v^(-/+), a^(-/+)),
    which with a+ = a- - 2 sigma (v+ - v-) gives

        S = [[-r, 0], [(1 + r) ((a- - z'')/w- + 2 sigma), -r]],  det S = r^2,

    a- = f(t*) - 2 sigma v- - k^2 u the acceleration just before the impact and z'' the
    obstacle's curvature on the piece the impact lies on (the one-sided value at a
    corner).  Returns (s11, s12, s21, s22).
    """
    return -r, 0.0, (1.0 + r) * ((a_in - zpp) / w_in + 2.0 * sigma), -r


@jit
def grazes(w, a, b):
    """Whether a relative impact velocity w is zero to GRAZING_TOL of the velocities a, b
    of the two sides: the saltation (a- - z'')/w diverges there."""
    return not abs(w) > GRAZING_TOL * (abs(a) + abs(b) + 1.0)


@jit
def flight_misses(p, d, m11, m12, m21, m22, t0, u0, v0, t1, u1, v1):
    """Whether the free flight of the oscillator ``p`` (a ``flow`` row; ``d`` its
    ``derive``d constants) from (u0, v0) at t0 misses the recorded (u1, v1) at t1 by more
    than FLIGHT_TOL relative: x(t1) = x_p(t1) + M (x(t0) - x_p(t0)), M the flight matrix
    (numerics.oscillator's split into particular and homogeneous parts)."""
    up0, vp0 = particular(p, d, t0)
    up1, vp1 = particular(p, d, t1)
    uf = up1 + m11 * (u0 - up0) + m12 * (v0 - vp0)
    vf = vp1 + m21 * (u0 - up0) + m22 * (v0 - vp0)
    return not (abs(uf - u1) <= FLIGHT_TOL * (1.0 + abs(u1))
                and abs(vf - v1) <= FLIGHT_TOL * (1.0 + abs(v1)))
