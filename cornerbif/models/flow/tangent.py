"""Tangent dynamics of the ``flow`` model (docs/stability.md): through every flight the
closed-form flight matrix, through every impact by law (5) the saltation matrix on the side of
the corner the impact lies on.  All of it runs after the kernel, on what the run recorded:
``impact_step`` is the Jacobian S M from one recorded impact to the next (or the exact
collapse where the record shows sticking).

The multipliers of the last recorded cycle are the eigenvalues of the product of the steps
over it (``cycle_jacobian``: the monodromy from just after an impact to just after the same
impact a cycle later, det = exp(-2 sigma T) r^(2N)); the Lyapunov spectrum carries a QR basis
through every step of the window (``run_lyapunov``).  ``batch_stability`` does both for every
run.
"""

import math

import numpy as np

from ..._jit import items_kernel, jit, stop_requested
from ...numerics.oscillator import acceleration, derive
from ...numerics.saltation import GRAZING_TOL, flight_matrix, flight_misses, impact_saltation
from ...obstacles.dispatch import obstacle_at_offset
from ...stability import (
    GRAZING,
    NO_CYCLE,
    NO_WINDOW,
    OK,
    REASONS,
    STICKING,
    WARMUP_SHARE,
    log_or_minus_inf,
    lyapunov_window,
    multipliers,
    recorded_count,
    store,
)
from . import packed as P

# a generic first basis vector (not an eigenvector of a triangular or diagonal step)
START_U, START_V = 0.6, 0.8


@jit
def impact_step(p, d, t0, u0, v0, t1, u1, v1, offset1, grazing_tol):
    """The Jacobian S M from just after a recorded impact (t0, u0, v0 = v+) to just after
    the next (t1, u1, v1 = v-, on the side ``offset1`` of its corner): the flight matrix
    M(t1 - t0) and the saltation S of the impact at t1.

    Returns (j11, j12, j21, j22, status): STICKING (zero matrix) where the free flight
    from (t0, u0, v0) misses (u1, v1) by more than FLIGHT_TOL relative (the particle stuck
    in between: the state after release does not depend on the state before), GRAZING
    (NaN) where |w-| is below ``grazing_tol`` times the impact's velocity scale."""
    sig = p[P.SIGMA]
    k = p[P.K]
    m11, m12, m21, m22 = flight_matrix(sig, k, t1 - t0)
    if flight_misses(p, d, m11, m12, m21, m22, t0, u0, v0, t1, u1, v1):
        return 0.0, 0.0, 0.0, 0.0, STICKING
    zp, zpp = obstacle_at_offset(p, d, t1, offset1)
    w = v1 - zp
    if not abs(w) > grazing_tol * (abs(v1) + abs(zp) + 1.0):     # grazes(), own tolerance
        nan = math.nan
        return nan, nan, nan, nan, GRAZING
    acc = acceleration(p, t1, u1, v1)
    s11, s12, s21, s22 = impact_saltation(p[P.R], sig, w, acc, zpp)
    return (s11 * m11 + s12 * m21, s11 * m12 + s12 * m22, s21 * m11 + s22 * m21,
            s21 * m12 + s22 * m22, OK)


@jit
def cycle_jacobian(p, t, u, v_in, v_out, offset, first, n, grazing_tol):
    """The monodromy of a cycle of ``n`` recorded impacts starting after impact ``first``:
    J = S_(first+n) M_(first+n) ... S_(first+1) M_(first+1), M the flight matrices
    between consecutive impacts and S the impacts' saltations (``impact_step``).

    Returns (j11, j12, j21, j22, duration, status): the zero matrix and STICKING where
    the cycle sticks, NaN and GRAZING where an impact grazes.
    """
    d = derive(p)
    a, b, c, e = 1.0, 0.0, 0.0, 1.0
    dur = t[first + n] - t[first]
    status = OK
    for i in range(first + 1, first + n + 1):
        j11, j12, j21, j22, st = impact_step(p, d, t[i - 1], u[i - 1], v_out[i - 1], t[i],
                                             u[i], v_in[i], offset[i], grazing_tol)
        if st == STICKING:
            # the state collapses: the monodromy is zero whatever else the cycle holds
            return 0.0, 0.0, 0.0, 0.0, dur, STICKING
        if st != OK:
            status = st
        a, b, c, e = (j11 * a + j12 * c, j11 * b + j12 * e, j21 * a + j22 * c,
                      j21 * b + j22 * e)
    return a, b, c, e, dur, status


@jit
def run_cycle_multipliers(p, t, u, v_in, v_out, offset, ipc):
    """The multipliers of one run's cycle of ``ipc`` impacts, the last complete one in
    its record: (re1, im1, re2, im2, duration, status)."""
    n = recorded_count(t)
    nan = math.nan
    if ipc <= 0 or n < ipc + 1:
        return nan, nan, nan, nan, nan, NO_CYCLE
    first = n - 1 - ipc
    j11, j12, j21, j22, dur, st = cycle_jacobian(p, t, u, v_in, v_out, offset, first, ipc,
                                                 GRAZING_TOL)
    if st == STICKING:
        return 0.0, 0.0, 0.0, 0.0, dur, STICKING
    if st != OK:
        return nan, nan, nan, nan, dur, st
    re1, im1, re2, im2 = multipliers(j11, j12, j21, j22)
    return re1, im1, re2, im2, dur, OK


@jit
def run_lyapunov(p, t, u, v_in, v_out, offset, ipc, warmup_share):
    """The Lyapunov spectrum (per unit time) of one run over its recorded impacts:
    (lambda1, lambda2, averaging time, status).

    The tangent is carried impact to impact by ``impact_step`` (S M) with Gram-Schmidt
    re-orthonormalisation at every impact: in two dimensions the first column q of the
    orthonormal basis is all there is to carry (q <- J q / |J q|, R11 = |J q|), and
    R22 = |det J| / R11.  The warm-up (``lyapunov_window``) only aligns q; the logarithms
    are averaged over the window, trimmed to whole cycles when the run has one, so that on
    a periodic orbit with real multipliers lambda_i -> log|mu_i| / duration geometrically
    (docs/stability.md).  A stick or a grazing impact during the warm-up restarts the
    basis; in the window a stick gives -inf (STICKING, exact) and a grazing NaN (GRAZING).
    """
    n = recorded_count(t)
    nan = math.nan
    steps = n - 1
    start = lyapunov_window(steps, ipc, warmup_share)
    if start < 0 or not t[steps] > t[start]:
        return nan, nan, nan, NO_WINDOW
    dur = t[steps] - t[start]
    d = derive(p)
    qu, qv = START_U, START_V
    sum1 = 0.0
    sumdet = 0.0
    grazing = False
    for i in range(1, n):
        j11, j12, j21, j22, st = impact_step(p, d, t[i - 1], u[i - 1], v_out[i - 1], t[i],
                                             u[i], v_in[i], offset[i], GRAZING_TOL)
        if st == STICKING and i > start:
            # the tangent collapses to zero (exact), whatever else the window holds
            return -math.inf, -math.inf, dur, STICKING
        if st != OK:
            if i > start:
                grazing = True
            qu, qv = START_U, START_V      # before the window: the basis restarts
            continue
        xu = j11 * qu + j12 * qv
        xv = j21 * qu + j22 * qv
        r11 = math.hypot(xu, xv)
        if r11 == 0.0:
            # J q = 0: every direction collapses (r = 0 at two impacts in a row)
            if i > start:
                return -math.inf, -math.inf, dur, OK
            qu, qv = START_U, START_V
            continue
        qu = xu / r11
        qv = xv / r11
        if i > start:
            sum1 += math.log(r11)
            sumdet += log_or_minus_inf(abs(j11 * j22 - j12 * j21))
    if grazing:
        return nan, nan, dur, GRAZING
    return sum1 / dur, (sumdet - sum1) / dur, dur, OK


@items_kernel
def batch_stability(k0, k1, params, t, u, v_in, v_out, offset, ipc, o_re, o_im, o_dur, o_status,
                    o_lam, o_win, o_lstatus, control=0):
    """``run_cycle_multipliers`` and ``run_lyapunov`` for every item (row) in parallel.

    ``control``: the address of a sweep's control (``_jit.Control``; 0, the default: none),
    whose stop flag is read before each row (a row costs at most its record, run.record <=
    100000 impacts: tens of milliseconds); told to stop, the rows not begun are skipped and
    the outputs are incomplete (the caller raises ``KernelStopped``: ``raise_if_stopped``)."""
    for i in range(k0, k1):
        if stop_requested(control):
            continue
        store(i, run_cycle_multipliers(params[i], t[i], u[i], v_in[i], v_out[i], offset[i],
                                       ipc[i]),
              run_lyapunov(params[i], t[i], u[i], v_in[i], v_out[i], offset[i], ipc[i],
                           WARMUP_SHARE),
              o_re, o_im, o_dur, o_status, o_lam, o_win, o_lstatus)


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
