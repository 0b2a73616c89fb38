"""Tangent dynamics of the ``flow`` model through flights and impacts (docs/stability.md).

Every flight of the oscillator (eq 4) is linear with additive forcing, so its Jacobian is
the closed-form flight matrix ``flight_matrix`` in every damping regime; an impact on the
moving obstacle by law (5) is linearised by the saltation matrix ``impact_saltation``
(the time-of-impact correction included), on the side of a corner that the impact lies on.
The Floquet multipliers of a recorded cycle are the eigenvalues of the product of these
matrices over one cycle of impacts (``cycle_jacobian``, ``multipliers``): the monodromy
from just after an impact to just after the same impact one cycle later, similar to the
Poincare section map's Jacobian over the cycle.  The determinant of that product is
exp(-2 sigma T_cycle) r^(2N) in closed form (Liouville for the flights, r^2 per impact).

Status (issue 17, in progress): the flow's multipliers, stored by sweeps that keep
``"stability"`` (``batch_multipliers``: the last complete cycle of each run's record);
checked against finite-difference Jacobians of the section map (``tests/test_stability.py``).
The Lyapunov spectrum, ``map2d`` and ``two_particle`` are still to come.
"""

import math

import numpy as np
from numba import prange

from ._jit import jit, pjit
from .models import params as P
from .models.obstacle import piece_lengths, z_state
from .models.oscillator import derive, forcing, homogeneous, particular

# how a cycle's multipliers were found (``stability/status`` in the file)
OK = 0
GRAZING = 1        # an impact with relative velocity ~0: the saltation diverges (NaN)
STICKING = 2       # the cycle sticks: its monodromy is zero, multipliers exactly (0, 0)
NO_CYCLE = 3       # no cycle of at least one impact in the record (NaN)
REASONS = {OK: "ok", GRAZING: "grazing impact (relative velocity ~0): none",
           STICKING: "the cycle sticks to the obstacle: multipliers exactly 0",
           NO_CYCLE: "no cycle with impacts in the record: none"}
GRAZING_TOL = 1e-9   # |w-| below this times the impact's velocity scale counts as grazing
FLIGHT_TOL = 1e-7    # a recorded impact further than this (relative) from the free flight
                     # of the one before was reached through sticking


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
def obstacle_at_offset(p, offset):
    """(z', z'') of the obstacle at an impact given by its offset to the nearest valley
    corner (``impacts/corner_offset``: t - t_corner, >= 0 after the corner): the slope
    and curvature of the piece the impact lies on, as the kernel's law (5) used them."""
    L0, L1, per = piece_lengths(p)
    if p[P.OBSTACLE] == P.RECTIFIED_SINE:
        j, tau = (0, offset) if offset >= 0.0 else (0, L0 + offset)
    else:
        x = offset if offset >= 0.0 else per + offset
        j, tau = (0, x) if x < L0 else (1, x - L0)
    _, zp, zpp, _ = z_state(p, j, tau)
    return zp, zpp


@jit
def cycle_jacobian(p, t, u, v_in, v_out, offset, first, n, grazing_tol):
    """The monodromy of a cycle of ``n`` recorded impacts starting after impact ``first``:
    J = S_(first+n) M_(first+n) ... S_(first+1) M_(first+1), M the flight matrices
    between consecutive impacts and S the impacts' saltations.

    Returns (j11, j12, j21, j22, duration, status): status GRAZING (NaN matrix) where an
    impact's relative velocity is below ``grazing_tol`` times the impact's velocity scale.
    """
    sig = p[P.SIGMA]
    k = p[P.K]
    r = p[P.R]
    a, b, c, d = 1.0, 0.0, 0.0, 1.0
    for i in range(first + 1, first + n + 1):
        m11, m12, m21, m22 = flight_matrix(sig, k, t[i] - t[i - 1])
        a, b, c, d = (m11 * a + m12 * c, m11 * b + m12 * d, m21 * a + m22 * c,
                      m21 * b + m22 * d)
        zp, zpp = obstacle_at_offset(p, offset[i])
        w = v_in[i] - zp
        if not abs(w) > grazing_tol * (abs(v_in[i]) + abs(zp) + 1.0):
            nan = math.nan
            return nan, nan, nan, nan, t[first + n] - t[first], GRAZING
        acc = forcing(p, t[i]) - 2.0 * sig * v_in[i] - k * k * u[i]
        s11, s12, s21, s22 = impact_saltation(r, sig, w, acc, zpp)
        a, b, c, d = (s11 * a + s12 * c, s11 * b + s12 * d, s21 * a + s22 * c,
                      s21 * b + s22 * d)
    return a, b, c, d, t[first + n] - t[first], OK


@jit
def multipliers(j11, j12, j21, j22):
    """The eigenvalues of a real 2x2 matrix, sorted by decreasing modulus:
    (re1, im1, re2, im2).  The discriminant from the entries, ((j11 - j22)/2)^2 + j12 j21
    (not tr^2/4 - det, which cancels: a triangular matrix keeps real eigenvalues); the
    smaller real root as det / (larger), without cancellation."""
    tr = j11 + j22
    det = j11 * j22 - j12 * j21
    half = 0.5 * (j11 - j22)
    disc = half * half + j12 * j21
    if disc >= 0.0:
        s = math.sqrt(disc)
        big = 0.5 * tr + (s if tr >= 0.0 else -s)
        small = det / big if big != 0.0 else 0.0
        return big, 0.0, small, 0.0
    s = math.sqrt(-disc)
    return 0.5 * tr, s, 0.5 * tr, -s


@jit
def free_flight_misses(p, d, t0, u0, v0, t1, u1, v1):
    """Whether the free flight (``models.oscillator``: particular + homogeneous parts; ``d``
    the run's ``derive``d constants) from (u0, v0) at t0 misses the recorded impact state
    (u1, v1-) at t1 by more than FLIGHT_TOL: then the particle stuck in between."""
    up0, vp0 = particular(p, d, t0)
    uh, vh = homogeneous(p, d, u0 - up0, v0 - vp0, t1 - t0)
    up1, vp1 = particular(p, d, t1)
    u = up1 + uh
    v = vp1 + vh
    scale = 1.0 + abs(u1) + abs(v1)
    return not (abs(u - u1) <= FLIGHT_TOL * scale and abs(v - v1) <= FLIGHT_TOL * scale)


@jit
def run_cycle_multipliers(p, t, u, v_in, v_out, offset, ipc):
    """The multipliers of one run's cycle of ``ipc`` impacts, the last complete one in
    its record: (re1, im1, re2, im2, duration, status)."""
    n = 0
    while n < t.shape[0] and t[n] == t[n]:
        n += 1
    nan = math.nan
    if ipc <= 0 or n < ipc + 1:
        return nan, nan, nan, nan, nan, NO_CYCLE
    first = n - 1 - ipc
    d = derive(p)
    for i in range(first + 1, first + ipc + 1):
        if free_flight_misses(p, d, t[i - 1], u[i - 1], v_out[i - 1], t[i], u[i], v_in[i]):
            return 0.0, 0.0, 0.0, 0.0, t[first + ipc] - t[first], STICKING
    j11, j12, j21, j22, dur, st = cycle_jacobian(p, t, u, v_in, v_out, offset, first, ipc,
                                                 GRAZING_TOL)
    if st != OK:
        return nan, nan, nan, nan, dur, st
    re1, im1, re2, im2 = multipliers(j11, j12, j21, j22)
    return re1, im1, re2, im2, dur, OK


def new_outputs(n):
    """The arrays of the ``stability`` observable for n items, keyed by the Fields'
    sources (``flow_model.STABILITY_FIELDS``), in the order the batch kernels fill them."""
    return {"mu_re": np.empty((n, 2)), "mu_im": np.empty((n, 2)),
            "cycle_duration": np.empty(n), "stability_status": np.empty(n, np.int8)}


@jit
def store(i, res, o_re, o_im, o_dur, o_status):
    """Item i's (re1, im1, re2, im2, duration, status) into the outputs."""
    re1, im1, re2, im2, dur, st = res
    o_re[i, 0] = re1
    o_re[i, 1] = re2
    o_im[i, 0] = im1
    o_im[i, 1] = im2
    o_dur[i] = dur
    o_status[i] = st


@pjit
def batch_multipliers(params, t, u, v_in, v_out, offset, ipc, o_re, o_im, o_dur, o_status):
    """``run_cycle_multipliers`` for every item (row) in parallel."""
    for i in prange(params.shape[0]):
        store(i, run_cycle_multipliers(params[i], t[i], u[i], v_in[i], v_out[i], offset[i],
                                       ipc[i]), o_re, o_im, o_dur, o_status)


def cycle_multipliers(params, t, u, v_in, v_out, offset, first, n, grazing_tol=GRAZING_TOL):
    """Floquet multipliers of one recorded cycle of ``n`` impacts after impact ``first``
    (Python entry: ``params`` a packed flow row, the other arrays one run's impacts).

    Returns a dict: ``jacobian`` (2x2), ``multipliers`` (complex, by decreasing modulus),
    ``duration``, ``det_closed_form`` = exp(-2 sigma duration) r^(2n) and ``status``."""
    j11, j12, j21, j22, dur, st = cycle_jacobian(
        np.asarray(params, float), np.asarray(t, float), np.asarray(u, float),
        np.asarray(v_in, float), np.asarray(v_out, float), np.asarray(offset, float),
        int(first), int(n), float(grazing_tol))
    re1, im1, re2, im2 = multipliers(j11, j12, j21, j22)
    sig = params[P.SIGMA]
    return {"jacobian": np.array([[j11, j12], [j21, j22]]),
            "multipliers": np.array([complex(re1, im1), complex(re2, im2)]),
            "duration": dur, "status": REASONS[st],
            "det_closed_form": math.exp(-2.0 * sig * dur) * params[P.R] ** (2 * n)}


# ------------------------------------------------------------------ the maps alpha, beta, gamma
@jit
def map_cycle_multipliers(omega1, r, regions, period):
    """The multipliers of the last ``period`` recorded steps of the local maps (eqs 56-60):
    the eigenvalues of the product of their linear parts s [[1, 0], [h, 1]], h = pi omega1/2,
    s = r (beta, gamma), -r^2 (alpha) (eq 57; ``theory.map_matrices``), the later steps on
    the left: (re1, im1, re2, im2, period, status)."""
    nan = math.nan
    n = regions.shape[0]
    if period <= 0 or period > n:
        return nan, nan, nan, nan, nan, NO_CYCLE
    h = 0.5 * math.pi * omega1
    a, b, c, d = 1.0, 0.0, 0.0, 1.0
    for i in range(n - period, n):
        g = regions[i]
        if g < 0:
            return nan, nan, nan, nan, nan, NO_CYCLE
        s = -r * r if g == 0 else r
        a, b, c, d = s * a, s * b, s * (h * a + c), s * (h * b + d)
    re1, im1, re2, im2 = multipliers(a, b, c, d)
    return re1, im1, re2, im2, float(period), OK


@pjit
def batch_map_multipliers(params, regions, period, o_re, o_im, o_dur, o_status):
    """``map_cycle_multipliers`` for every item (row of ``params`` = [omega1, kappa1, r])."""
    for i in prange(params.shape[0]):
        store(i, map_cycle_multipliers(params[i, 0], params[i, 2], regions[i], period[i]),
              o_re, o_im, o_dur, o_status)
