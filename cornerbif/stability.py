"""Tangent dynamics through flights, impacts and corners: Floquet multipliers and
Lyapunov exponents of every model (docs/stability.md).

Every flight of the oscillator (eq 4) is linear with additive forcing, so its Jacobian is
the closed-form flight matrix ``flight_matrix`` in every damping regime; an impact on the
moving obstacle by law (5) is linearised by the saltation matrix ``impact_saltation``
(the time-of-impact correction included), on the side of a corner that the impact lies on.
All of it runs after the kernel, on what the run recorded: ``impact_step`` is the
Jacobian S M from one recorded impact to the next (or the exact collapse where the record
shows sticking).

* ``flow``: the multipliers of the last recorded cycle are the eigenvalues of the product
  of the steps over it (``cycle_jacobian``, ``multipliers``: the monodromy from just after
  an impact to just after the same impact a cycle later, det = exp(-2 sigma T) r^(2N));
  the Lyapunov spectrum carries a QR basis through every step of the window
  (``run_lyapunov``).  ``batch_stability`` does both for every run.
* ``map2d``: the products of the maps' linear parts (eq 57) (``map_cycle_multipliers``)
  and their exact exponents (``map_lyapunov``), ``batch_map_stability``.
* ``two_particle``: 4x4 steps through w-z impacts (law 5) and z-u impacts (law 74,
  ``zu_saltation``), merged from the two recorded tables (``two_particle_steps``), the
  monodromy's eigenvalues and a Gram-Schmidt spectrum (``two_particle_outputs``).
"""

import math

import numpy as np
from numba import prange

from ._jit import jit, pjit, raise_if_stopped, stop_requested
from .models.flow import packed as P
from .models.two_particle import kernel as TK
from .models.two_particle import packed as TP
from .numerics.oscillator import acceleration, derive, particular
from .obstacles.dispatch import piece_at, piece_length, piece_lengths, z_state

# how a cycle's multipliers were found (``stability/status`` in the file)
OK = 0
GRAZING = 1        # an impact with relative velocity ~0: the saltation diverges (NaN)
STICKING = 2       # the cycle sticks: its monodromy is zero, multipliers exactly (0, 0)
NO_CYCLE = 3       # no cycle of at least one impact in the record (NaN)
NO_WINDOW = 4      # fewer than two recorded impacts after the warm-up: no exponents (NaN)
PARTICLE_STICKS = 5  # two_particle: z on the wall or u on z, a partial collapse (NaN)
TABLE_FULL = 6     # two_particle: the w-z table filled before the window's end (NaN)
REASONS = {OK: "ok", GRAZING: "grazing impact (relative velocity ~0): none",
           STICKING: "sticks to the obstacle: multipliers exactly 0, exponents -inf",
           NO_CYCLE: "no cycle with impacts in the record: none",
           NO_WINDOW: "too few recorded impacts for exponents: none",
           PARTICLE_STICKS: "a particle sticks (z on the wall or u on z): partial collapse, "
                            "not derived: none",
           TABLE_FULL: "the w-z impact table filled before the window's end: none"}
# the share of a run's recorded impacts that aligns the Lyapunov basis before the exponents
# are averaged (docs/stability.md, "Lyapunov exponents")
WARMUP_SHARE = 0.25
# a generic first basis vector (not an eigenvector of a triangular or diagonal step)
START_U, START_V = 0.6, 0.8
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
def obstacle_at_offset(p, d, t, offset):
    """(z', z'') of the obstacle at an impact given by its offset to the nearest valley
    corner (``impacts/corner_offset``: t - t_corner, >= 0 after the corner): the slope
    and curvature of the piece the impact lies on, as the kernel's law (5) used them.  A
    profile's impact is placed by its time t (its corners need not start a period); one
    at a joint takes the piece on the offset's side."""
    if p[P.OBSTACLE] == P.PROFILE:
        j, tau = piece_at(d, t)
        if offset < 0.0 and tau == 0.0:
            j -= 1
            tau = piece_length(d, j)
        _, zp, zpp, _ = z_state(p, j, tau)
        return zp, zpp
    L0, L1, per = piece_lengths(p)
    if p[P.OBSTACLE] == P.RECTIFIED_SINE:
        j, tau = (0, offset) if offset >= 0.0 else (0, L0 + offset)
    else:
        x = offset if offset >= 0.0 else per + offset
        j, tau = (0, x) if x < L0 else (1, x - L0)
    _, zp, zpp, _ = z_state(p, j, tau)
    return zp, zpp


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
def recorded_count(t):
    """The number of recorded events: the entries of ``t`` before the first NaN."""
    n = 0
    while n < t.shape[0] and t[n] == t[n]:
        n += 1
    return n


@jit
def lyapunov_window(steps, ipc, warmup_share):
    """The first step of the averaging window over ``steps`` recorded steps: after the
    warm-up (``warmup_share`` of them), trimmed to whole cycles of ``ipc`` steps ending at
    the last when the run has a cycle; -1 when no step is left."""
    w0 = int(warmup_share * steps)
    if steps - w0 < 1:
        return -1
    if ipc > 0 and (steps - w0) >= ipc:
        return steps - ((steps - w0) // ipc) * ipc
    return w0


@jit
def log_or_minus_inf(x):
    """log(x) for x > 0, -inf for x = 0 (an exact collapse: r = 0 makes det S = 0)."""
    return math.log(x) if x > 0.0 else -math.inf


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


def new_outputs(n):
    """The arrays of the ``stability`` observable for n items, keyed by the Fields'
    sources (``models.flow.model.STABILITY_FIELDS``), in the order the batch kernels fill them."""
    return {"mu_re": np.empty((n, 2)), "mu_im": np.empty((n, 2)),
            "cycle_duration": np.empty(n), "stability_status": np.empty(n, np.int8),
            "lyapunov": np.empty((n, 2)), "lyapunov_window": np.empty(n),
            "lyapunov_status": np.empty(n, np.int8)}


@jit
def store(i, mult, lyap, o_re, o_im, o_dur, o_status, o_lam, o_win, o_lstatus):
    """Item i's multipliers (re1, im1, re2, im2, duration, status) and Lyapunov spectrum
    (lambda1, lambda2, window, status) into the outputs."""
    re1, im1, re2, im2, dur, st = mult
    o_re[i, 0] = re1
    o_re[i, 1] = re2
    o_im[i, 0] = im1
    o_im[i, 1] = im2
    o_dur[i] = dur
    o_status[i] = st
    l1, l2, win, lst = lyap
    o_lam[i, 0] = l1
    o_lam[i, 1] = l2
    o_win[i] = win
    o_lstatus[i] = lst


@pjit
def batch_stability(params, t, u, v_in, v_out, offset, ipc, o_re, o_im, o_dur, o_status,
                    o_lam, o_win, o_lstatus, control=0):
    """``run_cycle_multipliers`` and ``run_lyapunov`` for every item (row) in parallel.

    ``control``: the address of a sweep's control (``_jit.Control``; 0, the default: none),
    whose stop flag is read before each row (a row costs at most its record, run.record <=
    100000 impacts: tens of milliseconds); told to stop, the rows not begun are skipped and
    the outputs are incomplete (the caller raises ``KernelStopped``: ``raise_if_stopped``)."""
    for i in prange(params.shape[0]):
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
        s = map_slope(g, r)
        a, b, c, d = s * a, s * b, s * (h * a + c), s * (h * b + d)
    re1, im1, re2, im2 = multipliers(a, b, c, d)
    return re1, im1, re2, im2, float(period), OK


@jit
def map_slope(region, r):
    """The factor s of a map's linear part s [[1, 0], [h, 1]] (eq 57): -r^2 for alpha
    (region 0), r for beta and gamma."""
    return -r * r if region == 0 else r


@jit
def map_lyapunov(r, regions):
    """The Lyapunov spectrum (per iterate) of the local maps over the recorded steps (the
    finite ones: a region < 0 marks an iterate that was not): (lambda1, lambda2, number of
    steps, status).

    Every linear part s [[1, 0], [h, 1]] (eq 57) maps e2 = (0, 1) to s e2: the maps share
    the invariant direction e2, so with the Gram-Schmidt basis started at (e2, e1) the
    first vector stays e2 and every step's R = diag(|s|, |s|) exactly.  Both exponents are
    the mean of log|s| over the window (log r for beta and gamma, 2 log r for alpha), with
    no warm-up: on a cycle, log|mu| / period for its double multiplier s^period (a
    Jordan block: a generic start basis would converge only like log(N)/N)."""
    n = 0
    total = 0.0
    while n < regions.shape[0] and regions[n] >= 0:
        total += log_or_minus_inf(abs(map_slope(regions[n], r)))
        n += 1
    if n == 0:
        return math.nan, math.nan, math.nan, NO_WINDOW
    lam = total / n
    return lam, lam, float(n), OK


@pjit
def batch_map_stability(params, regions, period, o_re, o_im, o_dur, o_status, o_lam, o_win,
                        o_lstatus, control=0):
    """``map_cycle_multipliers`` and ``map_lyapunov`` for every item (row of ``params`` =
    [omega1, kappa1, r]); ``control`` as for ``batch_stability``."""
    for i in prange(params.shape[0]):
        if stop_requested(control):
            continue
        store(i, map_cycle_multipliers(params[i, 0], params[i, 2], regions[i], period[i]),
              map_lyapunov(params[i, 2], regions[i]),
              o_re, o_im, o_dur, o_status, o_lam, o_win, o_lstatus)


# ------------------------------------------------------------------ two particles (section 6)


@jit
def zu_saltation(mu, r2, sigma1, sigma2, rho, a_z, a_u):
    """The 4x4 saltation matrix of a z-u impact by law (74) in x = (z, y, u, v).

    The surface is g = u - z = 0 (grad g = n = (-1, 0, 1, 0)), reached with relative
    velocity rho = v- - y- < 0; the jump R keeps z, u and maps y+ = y + A (v - y),
    v+ = v - B (v - y), A = (1 + r2)/(1 + mu), B = (1 + r2) - A (0 and 1 + r2 for
    mu = inf: law (5) against z).  S = D_x R + (f+ - D_x R f-) n^T / rho with
    f = (y, a_z, v, a_u), a^+ = a^- - 2 sigma (velocity jump), gives the rank-one update
    of D_x R by c n^T / rho, c = (dy, -2 sigma1 dy + A (a_z - a_u), dv,
    -2 sigma2 dv + B (a_u - a_z)), dy = A rho, dv = -B rho; det S = r2^2
    (docs/stability.md).  a_z, a_u are the accelerations just before the impact."""
    A = 0.0 if mu == math.inf else (1.0 + r2) / (1.0 + mu)
    B = (1.0 + r2) - A
    S = np.zeros((4, 4))
    S[0, 0] = 1.0
    S[2, 2] = 1.0
    S[1, 1] = 1.0 - A
    S[1, 3] = A
    S[3, 1] = B
    S[3, 3] = 1.0 - B
    # c / rho with dy = A rho, dv = -B rho
    c0 = A
    c1 = -2.0 * sigma1 * A + A * (a_z - a_u) / rho
    c2 = -B
    c3 = 2.0 * sigma2 * B + B * (a_u - a_z) / rho
    S[0, 0] -= c0
    S[0, 2] += c0
    S[1, 0] -= c1
    S[1, 2] += c1
    S[2, 0] -= c2
    S[2, 2] += c2
    S[3, 0] -= c3
    S[3, 2] += c3
    return S


@jit
def _block(G, off, m11, m12, m21, m22):
    G[off, off] = m11
    G[off, off + 1] = m12
    G[off + 1, off] = m21
    G[off + 1, off + 1] = m22


@jit
def two_particle_steps(p, zu, wz, i0, i1):
    """The Jacobians of the events from just after z-u impact ``i0`` to just after z-u
    impact ``i1`` of one run's record (``zu``: the kernel's z-u table, ``wz``: its w-z
    table, both in time order; a w-z impact at the time of a z-u impact comes first, the
    kernel's policy for a triple impact).

    Each step is S blockdiag(M_z(tau), M_u(tau)): both particles' flight matrices over
    the time tau since the previous event (``flight_matrix``; z with sigma1, omega1, u
    with sigma2, omega2), then the event's saltation: law (5) with r1 on the wall for z
    (``impact_saltation``, w' and w'' of eq 72; u unchanged) or law (74)
    (``zu_saltation``).  Returns (G (m, 4, 4), event times (m,), status):
    PARTICLE_STICKS where a recorded event is not reached by the free flight of z from
    the event before, or of u from the z-u impact before; GRAZING where an impact's
    relative velocity is below GRAZING_TOL times its velocity scale; TABLE_FULL where the
    w-z table filled before z-u impact ``i1`` (w-z impacts may be missing)."""
    last = wz.shape[0] - 1
    if last >= 0 and wz[last, TK.WZ_T] == wz[last, TK.WZ_T] and \
            wz[last, TK.WZ_T] < zu[i1, TK.ZU_T]:
        return np.zeros((0, 4, 4)), np.zeros(0), TABLE_FULL
    c = TK.derive(p)
    Q, D = TK.oscillators(p, c)
    s1, w1 = p[TP.SIGMA1], p[TP.OMEGA1]
    s2, w2 = p[TP.SIGMA2], p[TP.OMEGA2]
    t0 = zu[i0, TK.ZU_T]
    nwz = 0
    first_wz = -1
    for j in range(wz.shape[0]):
        tw = wz[j, TK.WZ_T]
        if not tw == tw:
            break
        if t0 < tw <= zu[i1, TK.ZU_T]:
            if first_wz < 0:
                first_wz = j
            nwz += 1
    m_total = (i1 - i0) + nwz
    G = np.zeros((m_total, 4, 4))
    times = np.empty(m_total)
    tz, zz, yz = t0, zu[i0, TK.ZU_U], zu[i0, TK.ZU_YOUT]
    tu, uu, vu = t0, zu[i0, TK.ZU_U], zu[i0, TK.ZU_VOUT]
    t_prev = t0
    j = first_wz
    j_end = first_wz + nwz
    i = i0 + 1
    for m in range(m_total):
        is_wz = j >= 0 and j < j_end and (i > i1 or wz[j, TK.WZ_T] <= zu[i, TK.ZU_T])
        te = wz[j, TK.WZ_T] if is_wz else zu[i, TK.ZU_T]
        tau = te - t_prev
        z11, z12, z21, z22 = flight_matrix(s1, w1, tau)
        u11, u12, u21, u22 = flight_matrix(s2, w2, tau)
        times[m] = te
        if is_wz:
            wv, wp, wpp, _ = TK.wall(p, te, 0.0)
            y_in = wz[j, TK.WZ_YIN]
            zrec = wz[j, TK.WZ_Z]
            if flight_misses(Q[TK.RZ], D[TK.RZ], z11, z12, z21, z22, tz, zz, yz, te, zrec,
                             y_in):
                return G, times, PARTICLE_STICKS
            rel = y_in - wp
            if grazes(rel, y_in, wp):
                return G, times, GRAZING
            a_z = acceleration(Q[TK.RZ], te, zrec, y_in)
            a11, a12, a21, a22 = impact_saltation(p[TP.R1], s1, rel, a_z, wpp)
            _block(G[m], 0, a11 * z11 + a12 * z21, a11 * z12 + a12 * z22,
                   a21 * z11 + a22 * z21, a21 * z12 + a22 * z22)
            _block(G[m], 2, u11, u12, u21, u22)
            tz, zz, yz = te, zrec, wz[j, TK.WZ_YOUT]
            j += 1
        else:
            x = zu[i, TK.ZU_U]
            y_in = zu[i, TK.ZU_YIN]
            v_in = zu[i, TK.ZU_VIN]
            if flight_misses(Q[TK.RZ], D[TK.RZ], z11, z12, z21, z22, tz, zz, yz, te, x, y_in):
                return G, times, PARTICLE_STICKS
            f11, f12, f21, f22 = flight_matrix(s2, w2, te - tu)
            if flight_misses(Q[TK.RU], D[TK.RU], f11, f12, f21, f22, tu, uu, vu, te, x, v_in):
                return G, times, PARTICLE_STICKS
            rho = v_in - y_in
            if grazes(rho, v_in, y_in):
                return G, times, GRAZING
            a_z = acceleration(Q[TK.RZ], te, x, y_in)
            a_u = acceleration(Q[TK.RU], te, x, v_in)
            S = zu_saltation(p[TP.MU], p[TP.R2], s1, s2, rho, a_z, a_u)
            F = np.zeros((4, 4))
            _block(F, 0, z11, z12, z21, z22)
            _block(F, 2, u11, u12, u21, u22)
            G[m] = S @ F
            tz, zz, yz = te, x, zu[i, TK.ZU_YOUT]
            tu, uu, vu = te, x, zu[i, TK.ZU_VOUT]
            i += 1
        t_prev = te
    return G, times, OK


@jit
def recorded(zu):
    """The number of recorded z-u impacts (rows before the first NaN time)."""
    return recorded_count(zu[:, TK.ZU_T])


@jit
def two_particle_monodromy(p, zu, wz, ipc, out):
    """The monodromy (into ``out``, 4x4) of the last complete cycle of ``ipc`` z-u impacts
    in one run's record: (duration, status)."""
    n = recorded(zu)
    if ipc <= 0 or n < ipc + 1:
        out[:, :] = math.nan
        return math.nan, NO_CYCLE
    first = n - 1 - ipc
    dur = zu[n - 1, TK.ZU_T] - zu[first, TK.ZU_T]
    G, _, st = two_particle_steps(p, zu, wz, first, n - 1)
    if st != OK:
        out[:, :] = math.nan
        return dur, st
    J = np.eye(4)
    for m in range(G.shape[0]):
        J = G[m] @ J
    out[:, :] = J
    return dur, OK


@jit
def gram_schmidt(A, logs):
    """Modified Gram-Schmidt on the columns of A in place (A <- Q); logs[i] += log R_ii."""
    n = A.shape[1]
    for a in range(n):
        for b in range(a):
            dot = 0.0
            for r in range(A.shape[0]):
                dot += A[r, b] * A[r, a]
            for r in range(A.shape[0]):
                A[r, a] -= dot * A[r, b]
        nrm = 0.0
        for r in range(A.shape[0]):
            nrm += A[r, a] * A[r, a]
        nrm = math.sqrt(nrm)
        if nrm == 0.0:
            logs[a] += -math.inf      # an exact collapse (r1 or r2 = 0): the column stays 0
            continue
        logs[a] += math.log(nrm)
        for r in range(A.shape[0]):
            A[r, a] /= nrm


@jit
def generic_basis(n):
    """A fixed orthonormal n x n basis aligned with no coordinate block (the Gram-Schmidt
    start of the Lyapunov spectrum)."""
    B = np.empty((n, n))
    for a in range(n):
        for b in range(n):
            B[a, b] = 1.0 / (1.0 + a + 2.0 * b) + (1.0 if a == b else 0.0)
    gram_schmidt(B, np.zeros(n))
    return B


@jit
def two_particle_lyapunov(p, zu, wz, ipc, warmup_share, out):
    """The Lyapunov spectrum (into ``out``, 4, per unit time, largest first) over one
    run's recorded z-u impacts, by QR re-orthonormalisation (modified Gram-Schmidt) after
    every event; the warm-up (``lyapunov_window``) aligns the basis, the logarithms are
    averaged over the window (whole cycles where the run has one): (window, status).  A
    problem during the warm-up restarts the basis at the window; one in the window gives
    NaN and its status."""
    n = recorded(zu)
    steps = n - 1
    out[:] = math.nan
    start = lyapunov_window(steps, ipc, warmup_share)
    if start < 0 or not zu[steps, TK.ZU_T] > zu[start, TK.ZU_T]:
        return math.nan, NO_WINDOW
    win = zu[steps, TK.ZU_T] - zu[start, TK.ZU_T]
    G, _, st = two_particle_steps(p, zu, wz, start, steps)
    if st != OK:
        return win, st
    Qb = generic_basis(4)
    discard = np.zeros(4)
    if start > 0:
        Gw, _, st_w = two_particle_steps(p, zu, wz, 0, start)
        if st_w == OK:
            for m in range(Gw.shape[0]):
                Qb = Gw[m] @ Qb
                gram_schmidt(Qb, discard)
    logs = np.zeros(4)
    for m in range(G.shape[0]):
        Qb = G[m] @ Qb
        gram_schmidt(Qb, logs)
    logs.sort()
    for a in range(4):
        out[a] = logs[3 - a] / win      # largest first
    return win, OK


@pjit
def batch_two_particle_stability(params, zu, wz, ipc, o_J, o_dur, o_status, o_lam, o_win,
                                 o_lstatus, control=0):
    """Monodromies and Lyapunov spectra of every run (row) in parallel; the multipliers are
    the monodromies' eigenvalues (``two_particle_multipliers``); ``control`` as for
    ``batch_stability``."""
    for i in prange(params.shape[0]):
        if stop_requested(control):
            continue
        o_dur[i], o_status[i] = two_particle_monodromy(params[i], zu[i], wz[i], ipc[i], o_J[i])
        o_win[i], o_lstatus[i] = two_particle_lyapunov(params[i], zu[i], wz[i], ipc[i],
                                                       WARMUP_SHARE, o_lam[i])


def sorted_eigenvalues(J):
    """Eigenvalues of a stack of square matrices (..., n, n), by decreasing modulus (a
    conjugate pair: positive imaginary part first); NaN rows stay NaN."""
    J = np.asarray(J)
    out = np.full(J.shape[:-1], np.nan + 0j)
    ok = np.isfinite(J).all(axis=(-2, -1))
    if ok.any():
        w = np.linalg.eigvals(J[ok])
        order = np.lexsort((-w.imag, -np.abs(w)), axis=-1)
        out[ok] = np.take_along_axis(w, order, axis=-1)
    return out


def two_particle_outputs(params, zu, wz, ipc, control=0):
    """The ``stability`` observable of the two-particle model for n runs: the Floquet
    multipliers (4, sorted by modulus) of each run's last cycle and its Lyapunov spectrum
    (4) over the recorded window, keyed as ``new_outputs``.  Under a sweep's ``control``
    (its address; 0: none) told to stop: ``KernelStopped``."""
    n = params.shape[0]
    J = np.empty((n, 4, 4))
    res = {"cycle_duration": np.empty(n), "stability_status": np.empty(n, np.int8),
           "lyapunov": np.empty((n, 4)), "lyapunov_window": np.empty(n),
           "lyapunov_status": np.empty(n, np.int8)}
    batch_two_particle_stability(params, zu, wz, ipc, J, res["cycle_duration"],
                                 res["stability_status"], res["lyapunov"],
                                 res["lyapunov_window"], res["lyapunov_status"], control)
    raise_if_stopped(control)
    mu = sorted_eigenvalues(J)
    return {"mu_re": mu.real.copy(), "mu_im": mu.imag.copy(), **res, "monodromy": J}
