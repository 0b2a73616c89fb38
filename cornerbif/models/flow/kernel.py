"""Event-driven kernel of the ``flow`` model (sections 2-3; eqs 4, 5, 7, 8).

``run_one`` integrates one (parameter point, initial condition) item through flights
(exact, eq 4), impacts (law 5), chattering and sticking, with the certified event search of
``roots`` and the Sturm comparison of ``sturm_clear``; ``run_batch`` fans out over items.
The phases, the early stop (``run.stop = "period"``) and the helpers are described in
docs/kernels.md; the obstacles (eqs 7, 8) live in ``obstacles.dispatch``.  Every run ends with
a status from ``cornerbif.status``; nothing raises.
"""

import math

import numpy as np

from ... import status as S
from ..._jit import POLL_EVERY, STOPPED, count_done, items_kernel, jit, jit_inline, stop_requested
from ...numerics.impact import restitution
from ...numerics.oscillator import (
    SMALL_ANGLE,
    budget_pieces,
    derive,
    forcing,
    homogeneous,
    particular,
    rotate,
    small_sincos,
    upp_bound,
)
from ...numerics.roots import (
    FAIL,
    FOUND,
    MAXIT,
    NONE,
    STEP,
    bracket,
    bracket_call,
    quad_first_root,
    quad_positive,
)
from ...numerics.saltation import flight_matrix
from ...obstacles.dispatch import (
    D_HALF,
    D_IK,
    D_NPP,
    D_REGIME,
    D_WD,
    contact_floor,
    corner_of,
    cycle_lag,
    cycle_np,
    derived_tuple,
    derived_tuple_profile,
    piece_at,
    piece_length,
    piece_start,
    sine_amp,
    sine_part,
    sinusoidal,
    sturm_floor,
    z_state,
    zpp_range,
    zppp_max,
    zpppp_max,
)
from . import packed as P

HINT_MARGIN = 1.25   # the next step's window: this times the certified bracket's rest

GAP = 0       # f = u - z along the flight
FORCE = 1     # f = N, the contact force needed to stay on the obstacle
NEGFORCE = 2  # f = -N


@jit
def contact_force(p, d, j, tau):
    """N = z'' + 2 sigma z' + k^2 z - f(t) and N' on piece j at tau.

    While stuck (u = z) the obstacle must push with N >= 0; the particle leaves
    where N changes sign.
    """
    z, zp, zpp, zppp = z_state(p, j, tau)
    sig = p[P.SIGMA]
    k2 = p[P.K] * p[P.K]
    t = piece_start(d, j) + tau
    f = forcing(p, t)
    n = zpp + 2.0 * sig * zp + k2 * z - f
    fp = 0.0
    if p[P.F_AMP] != 0.0:
        fp = -p[P.F_AMP] * p[P.F_OMEGA] * math.sin(p[P.F_OMEGA] * t + p[P.F_PHI])
    n1 = zppp + 2.0 * sig * zpp + k2 * zp - fp
    return n, n1


@jit
def evaluate(kind, p, d, j, tau_ref, uh_ref, vh_ref, s):
    """Value, slope and curvature of the searched function at tau_ref + s."""
    tau = tau_ref + s
    if kind == GAP:
        uh, vh = homogeneous(p, d, uh_ref, vh_ref, s)
        t = piece_start(d, j) + tau
        up, vp = particular(p, d, t)
        u = uh + up
        v = vh + vp
        z, zp, zpp, _ = z_state(p, j, tau)
        upp = -2.0 * p[P.SIGMA] * v - p[P.K] * p[P.K] * u + forcing(p, t)
        return u - z, v - zp, upp - zpp
    n, n1 = contact_force(p, d, j, tau)
    if kind == FORCE:
        return n, n1, 0.0
    return -n, -n1, 0.0


@jit
def first_root(kind, p, d, j, tau_ref, uh_ref, vh_ref, s0, s_end, lo2, hi2, m3, tol, skip_first):
    """First root of the function ``kind`` on [s0, s_end]: the certified steps of
    ``roots.bracket``, whose docstring says what the bounds lo2, hi2, m3 are.

    Returns (code, s): code FOUND with the root, NONE with s_end, FAIL when the
    step budget ran out.  ``skip_first`` ignores f <= 0 at s0 (the point just
    after an impact, where g = 0 and g' > 0).
    """
    s = s0
    f, fp, fpp = evaluate(kind, p, d, j, tau_ref, uh_ref, vh_ref, s)
    first = skip_first
    for _ in range(MAXIT):
        code, h, _ = bracket_call(f, fp, fpp, 0.0, first, s_end - s, lo2, hi2, m3, math.inf,
                                  tol, -1.0)
        first = False
        if code == NONE:
            return NONE, s_end
        if code != STEP:
            return code, s + h
        s = s + h
        if s >= s_end:
            return NONE, s_end
        f, fp, fpp = evaluate(kind, p, d, j, tau_ref, uh_ref, vh_ref, s)
    return FAIL, s


@jit_inline
def free_state(p, d, j, tau_ref, uh_ref, vh_ref, s, sa, ua, vka, za, zwa):
    """State of a free undamped flight (sigma = 0, f = 0) against a sinusoidal piece at s.

    Returns (u, u', z - kappa, z') at tau_ref + s and the anchor (sa, ua, vka, za, zwa):
    the last point where the state was evaluated by the closed forms (eqs 4, 8), kept as
    (u, u'/k, z - kappa, z'/omega).  Within ``SMALL_ANGLE`` of the anchor (in k x and
    omega x, x = s - sa) the state is the anchor's, rotated: (u, u'/k) turns at rate k
    and (z - kappa, z'/omega) at rate omega, with the small angles' sine and cosine from
    ``small_sincos`` (no libm call, no division); farther away it is evaluated afresh
    and becomes the anchor.
    """
    x = s - sa
    k = p[P.K]
    w = p[P.OMEGA]
    if abs(x) * max(k, w) <= SMALL_ANGLE:
        s1, c1 = small_sincos(k * x)
        s2, c2 = small_sincos(w * x)
        return (ua * c1 + vka * s1, k * (vka * c1 - ua * s1),
                za * c2 + zwa * s2, w * (zwa * c2 - za * s2), sa, ua, vka, za, zwa)
    u, v = homogeneous(p, d, uh_ref, vh_ref, s)
    zr, zp = sine_part(p, j, tau_ref + s)
    return u, v, zr, zp, s, u, v * d[D_IK], zr, zp / w


@jit_inline
def free_start(p, d, j, tau_ref, uh_ref, vh_ref, s0, t0):
    """State (u, u', z - kappa, z') of a free undamped flight (eq 4, sigma = 0, f = 0)
    against a sinusoidal piece (eq 8) at tau_ref + s0, the first point of its search.
    ``t0`` = tan(k s0 / 2) when s0 is the Sturm root (``sturm_clear``), else NaN: the
    flight's rotation to s0 then needs no libm call."""
    if t0 == t0:
        q = 1.0 / (1.0 + t0 * t0)
        u, v = rotate(p, d, uh_ref, vh_ref, (1.0 - t0 * t0) * q, 2.0 * t0 * q)   # sigma = 0
    else:
        u, v = homogeneous(p, d, uh_ref, vh_ref, s0)
    zr, zp = sine_part(p, j, tau_ref + s0)
    return u, v, zr, zp


PHASE_GRID = 32   # cells of the phase grid over a piece (``phase_grid``)
G_COSK = 0        # rows of the phase grid at tau_m = m L / PHASE_GRID, m = 0 .. PHASE_GRID:
G_SINK = 1        # cos and sin of k tau_m,
G_TANK = 2        # tan(k tau_m / 2) (inf from k tau_m >= pi on),
G_SINW = 3        # sin and cos of omega tau_m,
G_COSW = 4
G_TAU = 5         # and tau_m itself


@jit
def phase_grid(p, d):
    """Phases of the free flight (eq 4: u_h turns at rate k) and of a sinusoidal obstacle
    (eq 8: z - kappa = b sin(omega tau)) at PHASE_GRID + 1 points tau_m of a piece (rows
    ``G_*``), computed once per run: a search that starts at a corner starts from the grid
    point before its Sturm root (``grid_start``), whose state is a rotation by table
    values."""
    k = p[P.K]
    w = p[P.OMEGA]
    g = np.empty((6, PHASE_GRID + 1))
    dt = piece_length(d, 0) / PHASE_GRID
    for m in range(PHASE_GRID + 1):
        tm = m * dt
        c = math.cos(k * tm)
        sn = math.sin(k * tm)
        g[G_COSK, m] = c
        g[G_SINK, m] = sn
        g[G_TANK, m] = sn / (1.0 + c) if k * tm < math.pi else math.inf
        g[G_SINW, m] = math.sin(w * tm)
        g[G_COSW, m] = math.cos(w * tm)
        g[G_TAU, m] = tm
    return g


@jit_inline
def grid_start(p, d, j, uh_ref, vh_ref, grid, t):
    """The last grid point tau_m (m < PHASE_GRID) with tan(k tau_m / 2) <= t, for a flight
    from the corner of piece j whose Sturm root has tan(k s / 2) = t: no root before
    tau_m <= s.  Returns (tau_m, u, u', z - kappa, z') there, the flight rotated by the
    grid's phases (sigma = 0, f = 0): no libm call, no division."""
    m = 0
    for i in range(1, PHASE_GRID):     # a count, not a bisection: no branch to mispredict
        m += grid[G_TANK, i] <= t
    c = grid[G_COSK, m]
    sn = grid[G_SINK, m]
    k = p[P.K]
    vk = vh_ref * d[D_IK]
    b = sine_amp(p, j)
    return (grid[G_TAU, m], uh_ref * c + vk * sn, k * (vk * c - uh_ref * sn),
            b * grid[G_SINW, m], b * p[P.OMEGA] * grid[G_COSW, m])


@jit_inline
def first_impact_free(p, d, j, tau_ref, uh_ref, vh_ref, s0, u, v, zr, zp, s_end, lo2, hi2, m3,
                      m4, tol, skip_first):
    """``first_root`` of the gap g = u - z for a free undamped flight (sigma = 0, f = 0)
    against a sinusoidal piece, from the state (u, u', z - kappa, z') at s0 (``free_start``
    or ``grid_start``), with the state carried by ``free_state``: points of the search
    near each other cost no trigonometry.

    ``m4`` bounds |g''''| over the flight; the search also uses g''' = omega^2 z' -
    k^2 u' at each point (``roots.bracket``).

    Returns (code, s, u, u', z, z', z''): the state at s is the one at the root for
    FOUND (otherwise the last one evaluated).
    """
    kap = p[P.KAPPA]
    k2 = p[P.K] * p[P.K]
    w2 = p[P.OMEGA] * p[P.OMEGA]
    s = s0
    sa, ua, vka, za, zwa = s, u, v * d[D_IK], zr, zp / p[P.OMEGA]
    first = skip_first
    hint = -1.0
    for _ in range(MAXIT):
        z = kap + zr
        code, h, hup = bracket(u - z, v - zp, w2 * zr - k2 * u, w2 * zp - k2 * v, first,
                               s_end - s, lo2, hi2, m3, m4, tol, hint)
        first = False
        if code == NONE:
            return NONE, s_end, u, v, z, zp, -w2 * zr
        if code == FOUND and h > 0.0:
            s = s + h
            u, v, zr, zp, sa, ua, vka, za, zwa = free_state(p, d, j, tau_ref, uh_ref, vh_ref,
                                                            s, sa, ua, vka, za, zwa)
            z = kap + zr
        if code != STEP:
            return code, s, u, v, z, zp, -w2 * zr
        s = s + h
        if s >= s_end:
            return NONE, s_end, u, v, z, zp, -w2 * zr
        # the step's certified bracket holds the root: the next point's window, known
        # before its evaluation (keeps a square root off the chain of dependent steps)
        hint = HINT_MARGIN * (hup - h) if hup < math.inf else -1.0
        u, v, zr, zp, sa, ua, vka, za, zwa = free_state(p, d, j, tau_ref, uh_ref, vh_ref, s,
                                                        sa, ua, vka, za, zwa)
    return FAIL, s, u, v, kap + zr, zp, -w2 * zr


@jit_inline
def sturm_clear(p, d, j, g0, gp0, rest, cr, sr, have_rot, t_only):
    """Certified root-free length of a flight on piece j (sigma = 0, f = 0), eqs (4), (7)-(8).

    With u'' = -k^2 u, the gap satisfies g'' + k^2 g = -k^2 z - z'' =: f(tau), and on
    each piece f >= f_min (``obstacle.sturm_floors``, ``obstacle.sturm_floor``).  By
    Sturm comparison g >= y on [0, pi/k], where y'' + k^2 y = f_min with y, y' = g, g'
    at s = 0, so g has no root before the first root of the sinusoid y (closed form).

    Returns (length, cr, sr, have_rot, t): the length (``rest`` when y stays positive over
    the rest of the piece; 0 when g0 < 0, or g0 = 0 with g0' <= 0: nothing can be
    certified; right after an impact, g0 = 0 < g0', y starts positive) and the rotation
    (cr, sr) = (cos, sin)(k rest) of the flight to the end of the piece, which the
    caller passes in when it has it (``have_rot``, e.g. precomputed for whole pieces)
    and which is computed here when the test needs it, so that the caller can carry
    the flight over the corner without trigonometry; t = tan(k length / 2) when the
    length is the root of y (NaN otherwise), from which the search's first point gets
    its rotation (cos, sin)(k length) = ((1 - t^2), 2 t) / (1 + t^2) without libm.
    With ``t_only`` a root of y within the reach of the comparison (t finite) is returned
    as length -1 with its t, for the caller to place on its phase grid (no arctangent).
    """
    if g0 < 0.0 or (g0 == 0.0 and gp0 <= 0.0):
        return 0.0, cr, sr, have_rot, math.nan
    c = sturm_floor(d, j)                               # f_min / k^2 (``sturm_floors``)
    x = g0 - c
    yv = gp0 * d[D_IK]
    window = d[D_HALF]
    if window > rest:
        window = rest
    # y(s) = c + x cos(ks) + yv sin(ks); with t = tan(ks/2) its zeros solve
    # (c - x) t^2 + 2 yv t + (c + x) = 0, and s in [0, pi/k) maps monotonically to t >= 0
    # (stable for short flights, where acos(-c/A) would cancel; a square root and an
    # arctangent)
    c2 = c + x          # = g0: y(0)
    if c2 < 0.0 or (c2 == 0.0 and yv <= 0.0):
        return 0.0, cr, sr, have_rot, math.nan
    if c2 == 0.0 and c - x >= 0.0:
        # right after an impact (g0 = 0 < g0') with f_min >= 0: y has no root
        return window, cr, sr, have_rot, math.nan
    if window == rest:
        # the root lies beyond the piece iff tr >= tan(k rest / 2) = sin / (1 + cos) of
        # k rest, i.e. iff the quadratic in t stays positive up to there (no square root,
        # no arctangent); the same rotation carries the flight over the corner.  A margin
        # of 1e-12 (and 1 + cos away from 0) keeps the shortcut strictly inside the
        # exact test
        if not have_rot:
            ang = d[D_WD] * rest
            cr = math.cos(ang)
            sr = math.sin(ang)
            have_rot = True
        den = 1.0 + cr
        if den > 1e-3 and quad_positive(c2, 2.0 * yv, 2.0 * (c - x), sr / den * (1.0 + 1e-12)):
            return window, cr, sr, have_rot, math.nan
    tr = quad_first_root(c2, 2.0 * yv, 2.0 * (c - x))
    if tr == math.inf:
        return window, cr, sr, have_rot, math.nan
    if t_only:
        return -1.0, cr, sr, have_rot, tr
    s1 = 2.0 * math.atan(tr) * d[D_IK]
    if s1 >= window:
        return window, cr, sr, have_rot, math.nan
    return s1, cr, sr, have_rot, tr


WATCH_EVERY = 32   # corners between two searches for a cycle (early stop)
NO_END = np.iinfo(np.int64).max   # j_end of a run without a confirmed cycle (early stop)


@jit
def cycle_watch(ring_u, ring_v, ring_n, ring_s, j, u, v, n_imp, stuck, lag_step, qmax, tol):
    """Keep the state at corner j; every WATCH_EVERY corners return the lag of a cycle.

    ``ring_*`` hold (u, v, impacts so far, stuck) at the last ``ring_u.shape[0]``
    corners (>= 2 qmax + 1).  Returns the smallest lag q (a multiple of ``lag_step``,
    q <= qmax) such that the states at corners j - k and j - k - q agree for
    k = 0 .. q - 1 (|du| <= tol (1 + |u|), |dv| <= tol (1 + |v|), same phase of
    sticking) with the same number (> 0) of impacts in both cycles; 0 if none.
    """
    nr = ring_u.shape[0]
    pos = j % nr
    ring_u[pos] = u
    ring_v[pos] = v
    ring_n[pos] = n_imp
    ring_s[pos] = stuck
    if j % WATCH_EVERY != 0:
        return 0
    hmax = min(qmax, (j - 1) // 2)    # corners 1 .. j are stored (corner 0 is the start)
    tu = tol * (1.0 + abs(u))
    tv = tol * (1.0 + abs(v))
    for q in range(lag_step, hmax + 1, lag_step):
        b = pos - q
        if b < 0:
            b += nr
        if abs(ring_u[b] - u) > tu or abs(ring_v[b] - v) > tv or ring_s[b] != stuck:
            continue
        c = b - q
        if c < 0:
            c += nr
        m = n_imp - ring_n[b]
        if m <= 0 or ring_n[b] - ring_n[c] != m:
            continue
        ok = True
        for k in range(1, q):
            a = pos - k
            if a < 0:
                a += nr
            e = a - q
            if e < 0:
                e += nr
            ua = ring_u[a]
            va = ring_v[a]
            if (abs(ua - ring_u[e]) > tol * (1.0 + abs(ua))
                    or abs(va - ring_v[e]) > tol * (1.0 + abs(va)) or ring_s[a] != ring_s[e]):
                ok = False
                break
        if ok:
            return q
    return 0


@jit
def watch_for_cycle(p, d, ring_u, ring_v, ring_n, ring_s, j, u, v, n_imp, stuck, lag_step, qmax,
                    tol, last_j, last_tau, auto_phase, pps, sec_phase, rec0, j_end):
    """Early stop at corner j: keep the state, and once a cycle of q pieces is confirmed
    (``cycle_watch``) start recording here.

    Returns (still watching, number of the first recorded impact, last piece to run,
    section phase).  Recording runs 4 q + 2 more pieces (two whole cycles for
    ``analysis.detect_cycle`` besides the clusters it drops at both ends); with
    ``SECTION_AUTO`` the section moves to the corners of the parity opposite to the
    last impact's corner, as at the end of a full transient.
    """
    q = cycle_watch(ring_u, ring_v, ring_n, ring_s, j, u, v, n_imp, stuck, lag_step, qmax, tol)
    if q == 0:
        return True, rec0, j_end, sec_phase
    if auto_phase and n_imp > 0:
        c, _ = corner_of(p, d, last_j, last_tau)
        sec_phase = (c + pps // 2) % pps
    return False, n_imp, j + 4 * q + 2, sec_phase


@jit
def store_impact(p, d, i, j, tau, t, z, v_in, v_out, o_t, o_u, o_vin, o_vout, o_off, o_corner):
    """Record impact i: time, height, v-, v+ and the nearest corner with the signed offset."""
    o_t[i] = t
    o_u[i] = z
    o_vin[i] = v_in
    o_vout[i] = v_out
    c, off = corner_of(p, d, j, tau)
    o_corner[i] = c
    o_off[i] = off


@jit_inline
def release(p, d, j, tau_rel, L, tol, underdamped):
    """The particle leaves the obstacle at tau_rel on piece j (the contact force N turns
    negative).  The gap stays >= 0 while N < 0, and for less than half a damped period:
    g'' + 2 sigma g' + k^2 g = -N with g = g' = 0 at release, and the impulse response is
    >= 0 there.  Returns (code, z, z', u_h, u_h', s): the search of -N's root (FAIL when
    its budget ran out), the obstacle and the flight's homogeneous state at release, and
    the length s from which the gap search starts."""
    z, zp, _, _ = z_state(p, j, tau_rel)
    t = piece_start(d, j) + tau_rel
    up, vp = particular(p, d, t)
    code, sb = first_root(NEGFORCE, p, d, j, tau_rel, 0.0, 0.0, 0.0, L - tau_rel,
                          -d[D_NPP], d[D_NPP], math.inf, tol, True)
    wd = d[D_WD]
    if underdamped and math.pi / wd < sb:
        sb = math.pi / wd
    return code, z, zp, z - up, zp - vp, sb


@jit
def corner_ring(n, t_start):
    """The early stop's ring of the states at the last ``n`` corners (u, v, impact count,
    stuck): empty, or, for a start inside the period, of states no corner can match (the
    corners before the start are never stored; ``cycle_watch`` reads corners 1 .. j)."""
    ring_u = np.empty(n)
    ring_v = np.empty(n)
    if t_start != 0.0:
        ring_u[:] = math.inf
        ring_v[:] = math.inf
    return ring_u, ring_v, np.empty(n, np.int64), np.empty(n, np.bool_)


@jit
def piece_starts(p, d, wd):
    """The obstacle at the start of pieces 0 and 1 (z, z': it depends on the parity of j
    only) and the free rotation over each whole piece (cos, sin of w_d L_0, w_d L_1)."""
    zs0, zps0, _, _ = z_state(p, 0, 0.0)
    zs1, zps1, _, _ = z_state(p, 1, 0.0)
    return (zs0, zps0, zs1, zps1, math.cos(wd * piece_length(d, 0)),
            math.sin(wd * piece_length(d, 0)), math.cos(wd * piece_length(d, 1)),
            math.sin(wd * piece_length(d, 1)))


@jit
def run_one(p, d, ints, u0, v0, t_start, o_t, o_u, o_vin, o_vout, o_off, o_corner, o_su, o_sv,
            final, info):
    """Integrate one item from (t, u, v) = (t_start, u0, v0), t_start >= 0 (the obstacle's
    phase at the start; 0 unless the scene sets ``[initial] t``); fill its output rows.

    With early stop (``STOP_TOL`` > 0, see the module docstring) the recording
    starts where a cycle is confirmed and ``info[0]`` receives the number of the
    first recorded impact (``transient`` when no cycle was confirmed earlier).

    Impacts number ``transient`` and above are stored (time, height, v-, v+,
    signed offset to the nearest corner and that corner's index); the state at
    each Poincare section t = n T during the recording window is stored too.
    With ``SECTION_AUTO`` (rectified_sine, default section period) the section
    corners are those of the parity opposite to the last transient impact's
    corner, t = nT + phase with phase 0 or pi/omega: the paper's section, with the
    impacted corner t0 between two sections, on whichever shifted copy of the
    orbit the run landed.
    ``final`` receives the state at the last section crossed (for ``follow``).
    Returns the status code; ``STOPPED`` (outputs incomplete) when the sweep's control
    (``ints[I_CONTROL]``) asks it to stop, which it reads every POLL_EVERY passes.
    """
    tol = p[P.TOL]
    r = p[P.R]
    sig = p[P.SIGMA]
    k2 = p[P.K] * p[P.K]
    chatter = p[P.CHATTER]
    escape = p[P.ESCAPE]
    pps = np.int64(p[P.SECTION_PIECES])
    auto_phase = p[P.SECTION_AUTO] != 0.0
    sec_phase = np.int64(0)
    transient = ints[P.I_TRANSIENT]
    record = ints[P.I_RECORD]
    max_events = ints[P.I_MAX_EVENTS]
    # the time budget in pieces: run.max_periods units of the slower of the obstacle's and
    # the oscillator's time scales (``oscillator.budget_pieces``)
    max_pieces = budget_pieces(p, d, ints[P.I_MAX_PIECES])
    # the sweep's control (0: none): its stop flag is read every POLL_EVERY passes of the loop
    control = ints[P.I_CONTROL]
    passes = 0
    # stuck where the contact force is certified positive for all time (no corner, N > 0:
    # ``obstacle.contact_floor``) is stuck for good
    forever = contact_floor(p) > 0.0
    rec0 = transient          # number of the first recorded impact
    need = rec0 + record
    final[0] = math.nan
    final[1] = math.nan
    info[0] = rec0
    # early stop: watch the state at the corners for a cycle during the transient
    stop_tol = p[P.STOP_TOL]
    watch = stop_tol > 0.0 and p[P.F_AMP] == 0.0 and transient > 0
    qmax = 2 * record + 2
    ring_u, ring_v, ring_n, ring_s = corner_ring(2 * qmax + 1 if watch else 1, t_start)
    lag_step = cycle_lag(p)
    j_end = NO_END
    last_j = np.int64(0)
    last_tau = 0.0

    if not (u0 == u0 and v0 == v0 and t_start == t_start):
        return S.NONFINITE
    j = np.int64(0)
    tau_ref = 0.0
    if t_start != 0.0:
        # a start inside a piece: as just after an impact there (phase not known)
        j, tau_ref = piece_at(d, t_start)
    z0, zp0, _, _ = z_state(p, j, tau_ref)
    if u0 < z0:
        return S.BELOW_OBSTACLE

    # sigma = 0: (cos, sin)(k tau_ref), the free flight's phase at the reference point
    # since the start of the piece: (1, 0) at a corner, composed with each flight's own
    # rotation at an impact, NaN after a release from sticking (not known).  The flight
    # from an impact to the end of its piece is then a rotation by k (L - tau_ref),
    # composed without trigonometry
    c_ref = 1.0 if tau_ref == 0.0 else math.nan
    s_ref = 0.0
    amp2 = 0.0
    up, vp = particular(p, d, t_start)
    uh_ref = u0 - up
    vh_ref = v0 - vp
    skip = u0 == z0  # starting on the obstacle: treat as just left it
    s_start = 0.0
    stuck = False
    tau_s = 0.0
    n_imp = 0
    n_sec = 0
    events = 0
    pieces = 0
    wd = d[D_WD]
    zppp_bound = zppp_max(p)
    zpppp_bound = zpppp_max(p)
    sturm = p[P.SIGMA] == 0.0 and p[P.F_AMP] == 0.0 and p[P.K] > 0.0
    free_sine = sturm and sinusoidal(p)     # see first_impact_free
    grid = phase_grid(p, d) if free_sine else np.empty((6, 1))
    underdamped = d[D_REGIME] == 0.0
    # the obstacle at the start of each piece (it depends on the parity of j only) and,
    # for the Sturm test, the free rotation over a whole piece: no trigonometry for a
    # flight from corner to corner (time as piece and local time: docs/kernels.md)
    # (a profile of more than two pieces goes round its own cycle: cycle2 False)
    cycle2 = cycle_np(d) == 2
    zs0, zps0, zs1, zps1, c_l0, s_l0, c_l1, s_l1 = piece_starts(p, d, wd)
    z_ref = z0             # obstacle height and slope at (j, tau_ref)
    zp_ref = zp0

    at_corner = False      # a corner was just crossed, with the state (cu, cv), c_stuck
    cu = 0.0
    cv = 0.0
    c_stuck = False
    c_event = 0            # 1 when crossing it stuck counts as an event
    while True:
        passes += 1
        if passes & (POLL_EVERY - 1) == 0 and stop_requested(control):
            return STOPPED
        if at_corner:
            # ---- at corner j (stuck or in flight): section, early stop --------------------
            at_corner = False
            if (j - sec_phase) % pps == 0:
                if n_imp >= rec0 and n_sec < record:
                    o_su[n_sec] = cu
                    o_sv[n_sec] = cv
                    n_sec += 1
                final[0] = cu
                final[1] = cv
            if watch and n_imp < rec0:
                watch, rec0, j_end, sec_phase = watch_for_cycle(
                    p, d, ring_u, ring_v, ring_n, ring_s, j, cu, cv, n_imp, c_stuck, lag_step,
                    qmax, stop_tol, last_j, last_tau, auto_phase, pps, sec_phase, rec0, j_end)
                need = rec0 + record
                info[0] = rec0
            if j >= j_end:
                return S.OK
            events += c_event
            if events > max_events:
                return S.MAX_EVENTS
        L = piece_length(d, j)
        if stuck:
            if forever and j_end == NO_END:
                # ---- stuck for good: N > 0 for all time and no corner ------------------
                # u = z and v = z' from here on: every section the run would cross holds
                # the obstacle's state at that section corner (the flat wall: (kappa, 0))
                js = j + 1
                while (js - sec_phase) % pps != 0:
                    js += 1
                zs, zps, _, _ = z_state(p, js, 0.0)
                final[0] = zs
                final[1] = zps
                while n_imp >= rec0 and n_sec < record:
                    zs, zps, _, _ = z_state(p, js, 0.0)
                    o_su[n_sec] = zs
                    o_sv[n_sec] = zps
                    n_sec += 1
                    js += pps
                return S.STUCK
            # ---- sticking on piece j from tau_s -----------------------------------
            code, s = first_root(FORCE, p, d, j, tau_s, 0.0, 0.0, 0.0, L - tau_s,
                                 -d[D_NPP], d[D_NPP], math.inf, tol, False)
            if code == FAIL:
                return S.STEP_LIMIT
            if code == FOUND:
                tau_ref = tau_s + s
                code2, z_ref, zp_ref, uh_ref, vh_ref, s_start = release(p, d, j, tau_ref, L, tol,
                                                                        underdamped)
                if code2 == FAIL:
                    return S.STEP_LIMIT
                c_ref = math.nan
                skip = False
                stuck = False
                events += 1
                if events > max_events:
                    return S.MAX_EVENTS
                continue
            # stuck through the end of the piece: cross the corner
            _, zb, _, _ = z_state(p, j, L)
            j += 1
            pieces += 1
            if pieces > max_pieces:
                return S.STUCK
            z, za, _, _ = z_state(p, j, 0.0)
            t = piece_start(d, j)
            up, vp = particular(p, d, t)
            v_after = za
            if za > zb:
                # corner kick by law (5): an impact just after the corner
                v_out = restitution(zb, za, r)
                v_after = v_out
                if n_imp >= rec0:
                    store_impact(p, d, n_imp - rec0, j, 0.0, t, z, zb, v_out,
                                 o_t, o_u, o_vin, o_vout, o_off, o_corner)
                last_j = j
                last_tau = 0.0
                n_imp += 1
                if n_imp >= need:
                    return S.OK
                tau_ref = 0.0
                c_ref = 1.0       # the phase at a corner
                s_ref = 0.0
                z_ref = z
                zp_ref = za
                uh_ref = z - up
                vh_ref = v_out - vp
                s_start = 0.0
                skip = True
                stuck = False
                if v_out - za <= chatter:
                    nf, _ = contact_force(p, d, j, 0.0)
                    if nf > 0.0:
                        stuck = True
                        tau_s = 0.0
                        v_after = za
            elif za < zb:
                # the obstacle turns down under the particle: it leaves with zb
                v_after = zb
                tau_ref = 0.0
                c_ref = 1.0       # the phase at a corner
                s_ref = 0.0
                z_ref = z
                zp_ref = za
                uh_ref = z - up
                vh_ref = zb - vp
                s_start = 0.0
                skip = True
                stuck = False
            else:
                tau_s = 0.0
            at_corner = True      # the corner's records at the top of the loop
            cu = z
            cv = v_after
            c_stuck = stuck
            c_event = 1
            continue

        # ---- flight on piece j from tau_ref ----------------------------------------
        if sturm:
            # sigma = 0: the amplitude R of the flight, R^2 = u_h^2 + (u_h'/k)^2, without a
            # square root; the bounds of the search (upp_bound) only where one runs
            amp2 = uh_ref * uh_ref + (vh_ref * d[D_IK]) ** 2
            if not (amp2 == amp2):
                return S.NONFINITE
            if amp2 > escape * escape:
                return S.ESCAPED
        else:
            bu, bu3, amp = upp_bound(p, d, uh_ref, vh_ref)
            if not (amp == amp):
                return S.NONFINITE
            if amp > escape:
                return S.ESCAPED
        s0 = s_start
        rest = L - tau_ref
        have_rot = False
        cr = 1.0
        sr = 0.0
        t0 = math.nan
        if sturm and s_start == 0.0:
            # Sturm comparison: no root before the first root of the lower sinusoid
            if not cycle2:
                # a profile of more than two pieces: this piece's own rotation
                cl = math.cos(wd * L)
                sl = math.sin(wd * L)
            elif j % 2 == 0:
                cl = c_l0
                sl = s_l0
            else:
                cl = c_l1
                sl = s_l1
            if tau_ref == 0.0:
                have_rot = True
                cr = cl
                sr = sl
            elif c_ref == c_ref:
                # k (L - tau_ref): the whole piece's rotation less the phase at tau_ref
                have_rot = True
                cr = cl * c_ref + sl * s_ref
                sr = sl * c_ref - cl * s_ref
            s0, cr, sr, have_rot, t0 = sturm_clear(p, d, j, uh_ref - z_ref, vh_ref - zp_ref,
                                                   rest, cr, sr, have_rot,
                                                   free_sine and tau_ref == 0.0)
        at_root = False      # the search returned the state at the impact
        if s0 < rest:
            if sturm:
                bu, bu3, _ = upp_bound(p, d, uh_ref, vh_ref)
            zlo, zhi = zpp_range(p, j)
        if s0 >= rest:
            code = NONE
            s = rest
        elif free_sine:
            if s0 < 0.0:
                # a flight from the corner: its search starts at the grid point before
                # the Sturm root
                s0, u_i, v_i, zr_i, zp_i = grid_start(p, d, j, uh_ref, vh_ref, grid, t0)
            else:
                u_i, v_i, zr_i, zp_i = free_start(p, d, j, tau_ref, uh_ref, vh_ref, s0, t0)
            code, s, u_i, v_i, z_i, zp_i, zpp_i = first_impact_free(
                p, d, j, tau_ref, uh_ref, vh_ref, s0, u_i, v_i, zr_i, zp_i, rest, -bu - zhi,
                bu - zlo, bu3 + zppp_bound, bu3 * p[P.K] + zpppp_bound, tol,
                skip and s0 == 0.0)
            at_root = True
        else:
            code, s = first_root(GAP, p, d, j, tau_ref, uh_ref, vh_ref, s0, rest,
                                 -bu - zhi, bu - zlo, bu3 + zppp_bound, tol, skip and s0 == 0.0)
        if code == FAIL:
            return S.STEP_LIMIT
        if code == FOUND and s >= rest:
            # a root exactly at the corner belongs to the piece after it (right slope,
            # offset +0: a beta impact), as at every corner rule of the package
            code = NONE
        at_root = at_root and code == FOUND
        if at_root:
            uh = u_i       # sigma = 0, f = 0: no particular solution
            vh = v_i
        elif have_rot and s == rest:
            uh, vh = rotate(p, d, uh_ref, vh_ref, cr, sr)      # sigma = 0: no decay
        else:
            uh, vh = homogeneous(p, d, uh_ref, vh_ref, s)
        tau = tau_ref + s
        t = piece_start(d, j) + tau
        up, vp = particular(p, d, t)
        if code == NONE:
            # carry the flight over the end of the piece
            j += 1
            pieces += 1
            if pieces > max_pieces:
                return S.NO_IMPACT
            tau_ref = 0.0
            c_ref = 1.0       # the phase at a corner
            s_ref = 0.0
            if not cycle2:
                z_ref, zp_ref, _, _ = z_state(p, j, 0.0)
            elif j % 2 == 0:
                z_ref = zs0
                zp_ref = zps0
            else:
                z_ref = zs1
                zp_ref = zps1
            uh_ref = uh
            vh_ref = vh
            s_start = 0.0
            skip = False
            at_corner = True      # the corner's records at the top of the loop
            cu = uh + up
            cv = vh + vp
            c_stuck = False
            c_event = 0
            continue
        # ---- impact at (j, tau) -----------------------------------------------------
        if at_root:
            z = z_i
            zp = zp_i
            zpp = zpp_i
        else:
            z, zp, zpp, _ = z_state(p, j, tau)
        v_in = vh + vp
        v_out = restitution(v_in, zp, r)
        if n_imp >= rec0:
            store_impact(p, d, n_imp - rec0, j, tau, t, z, v_in, v_out,
                         o_t, o_u, o_vin, o_vout, o_off, o_corner)
        last_j = j
        last_tau = tau
        n_imp += 1
        events += 1
        if n_imp == rec0 and auto_phase:
            # the paper's section (3.3.1) has the impacted corner t0 inside a period:
            # take the section at the corners of the other parity, between the
            # clusters, whichever of the shifted copies of the orbit (3.2) this is
            c, _ = corner_of(p, d, j, tau)
            sec_phase = (c + pps // 2) % pps
        if n_imp >= need:
            return S.OK
        if events > max_events:
            return S.MAX_EVENTS
        if at_root and amp2 > 0.0:
            # the phase k s of the flight to the impact, from the homogeneous states at
            # its reference and at the root (u, u'/k) = rotation by k s of the reference
            # (sigma = 0: the amplitude R^2 = amp2 is kept), added to the phase at tau_ref
            ik = d[D_IK]
            a1 = vh_ref * ik
            b1 = vh * ik
            ck = (uh_ref * uh + a1 * b1) / amp2
            sk = (a1 * uh - uh_ref * b1) / amp2
            c_ref, s_ref = c_ref * ck - s_ref * sk, s_ref * ck + c_ref * sk
        else:
            c_ref = math.nan
        tau_ref = tau
        z_ref = z
        zp_ref = zp
        uh_ref = z - up
        vh_ref = v_out - vp
        s_start = 0.0
        skip = True
        w_out = v_out - zp
        if w_out <= chatter:
            nf = zpp + 2.0 * sig * zp + k2 * z - forcing(p, t)
            if nf > 0.0 and r < 1.0:
                # chattering: sum the geometric sequence of impacts
                tau_acc = tau + 2.0 * max(w_out, 0.0) / (nf * (1.0 - r))
                stuck = True
                tau_s = tau_acc if tau_acc < L else L


@items_kernel
def run_batch(k0, k1, params, ints, ics, o_t, o_u, o_vin, o_vout, o_off, o_corner, o_su, o_sv,
              o_status, o_final, o_rec0):
    """Run every item i = (parameter row params[i], initial state ics[i]) in parallel.

    ``o_rec0[i]`` receives the number of item i's first recorded impact (early stop).

    Each item writes only its own rows; results do not depend on the thread count.  Under
    a sweep's control (``ints[I_CONTROL]``, ``_jit.Control``) each finished item is counted,
    and a run told to stop returns ``STOPPED`` within POLL_EVERY passes of its loop (not
    counted: it did not finish).
    """
    n = params.shape[0]
    # each thread gets a contiguous range (``_jit.ItemKernel``); neighbouring items (neighbouring
    # parameter values) cost alike, so spread them with a fixed permutation (a
    # multiplicative stride coprime to n) to balance the threads.  Each item still
    # writes only its own rows: results do not depend on the order.
    stride = 7919 if n % 7919 != 0 else 1
    for k in range(k0, k1):
        i = (k * stride) % n
        t0 = ics[i, 2] if ics.shape[1] > 2 else 0.0
        # values, not arrays: no reference counting in the kernel's calls
        st = run_one(P.as_tuple(params[i]), derived_tuple(derive(params[i])), ints, ics[i, 0],
                     ics[i, 1], t0, o_t[i], o_u[i], o_vin[i], o_vout[i], o_off[i], o_corner[i],
                     o_su[i], o_sv[i], o_final[i], o_rec0[i:i + 1])
        o_status[i] = st
        if st != STOPPED:
            count_done(ints[P.I_CONTROL])


@items_kernel
def run_batch_profile(k0, k1, params, ints, ics, o_t, o_u, o_vin, o_vout, o_off, o_corner, o_su,
                      o_sv, o_status, o_final, o_rec0):
    """``run_batch`` for rows of ``obstacle = "profile"`` (NPARAM_PROFILE wide): the same
    ``run_one`` on a profile's tuples, which refer to their row of ``params`` (alive for
    the whole call; obstacles/dispatch.py, "the two tuple types").  A kernel of its own, so
    that a sweep of a built-in obstacle never compiles the profile's code."""
    if params.shape[1] != P.NPARAM_PROFILE or params.strides[1] != params.itemsize:
        raise ValueError("run_batch_profile: params must be rows of NPARAM_PROFILE "
                         "contiguous floats")
    n = params.shape[0]
    stride = 7919 if n % 7919 != 0 else 1
    for k in range(k0, k1):
        i = (k * stride) % n
        t0 = ics[i, 2] if ics.shape[1] > 2 else 0.0
        row = params[i]
        st = run_one(P.as_tuple_profile(row), derived_tuple_profile(derive(row), row), ints,
                     ics[i, 0], ics[i, 1], t0, o_t[i], o_u[i], o_vin[i], o_vout[i], o_off[i],
                     o_corner[i], o_su[i], o_sv[i], o_final[i], o_rec0[i:i + 1])
        o_status[i] = st
        if st != STOPPED:
            count_done(ints[P.I_CONTROL])


@items_kernel
def fill_obstacle_heights(k0, k1, params, t0, out):
    """out[i, m] = z(t0[i, m]) per packed row i (``obstacle_heights``)."""
    for i in range(k0, k1):
        d = derive(params[i])
        for m in range(t0.shape[1]):
            j, tau = piece_at(d, t0[i, m])
            out[i, m], _, _, _ = z_state(params[i], j, tau)


def obstacle_heights(params, t0):
    """z(t0) per packed row i and start time t0[i, m] (the floor a start drawn at t0 must
    clear)."""
    out = np.empty(t0.shape)
    fill_obstacle_heights(params, t0, out)
    return out


def first_impact_times(params, ics, pieces):
    """The time of the first impact after each start, by the kernel's certified event search
    (``run_one``, one impact recorded, no transient): ``params`` one packed row per start,
    ``ics`` rows (u, v, t0) above the obstacle; NaN where none comes within ``pieces``
    obstacle pieces.  The continuation's grazing monitor checks with it that no flight of an
    orbit meets the obstacle before its next impact (``orbit.FlowOrbit.smallest_gap``)."""
    params = np.ascontiguousarray(params, dtype=np.float64)
    ics = np.ascontiguousarray(ics, dtype=np.float64)
    n = params.shape[0]
    ints = np.zeros(P.NINT, np.int64)
    ints[P.I_RECORD] = 1
    ints[P.I_MAX_EVENTS] = 8
    ints[P.I_MAX_PIECES] = pieces
    t = np.full((n, 1), np.nan)
    scratch = [np.full((n, 1), np.nan) for _ in range(6)]
    corner = np.zeros((n, 1), np.int64)
    kernel = run_batch_profile if P.wide_rows(params) else run_batch
    kernel(params, ints, ics, t, *scratch[:4], corner, *scratch[4:], np.zeros(n, np.int8),
           np.zeros((n, 2)), np.zeros(n, np.int64))
    return t[:, 0]


@jit
def flight_gaps(p, d, t0, u0, v0, ts, out):
    """The gap u - z(t) at each time of ``ts`` along the free flight that leaves (u0, v0) at
    time t0 (eq 4 in closed form: the particular solution plus exp(A (t - t0)) acting on the
    homogeneous part, ``saltation.flight_matrix``), written into ``out``.  The continuation's
    grazing monitor samples each flight of an orbit with it (``orbit.FlowOrbit._gap`` is the
    same sum for one time), one call per flight rather than one per sample."""
    up0, vp0 = particular(p, d, t0)
    du, dv = u0 - up0, v0 - vp0
    for i in range(ts.shape[0]):
        t = ts[i]
        M = flight_matrix(p[P.SIGMA], p[P.K], t - t0)
        up1, _ = particular(p, d, t)
        j, tau = piece_at(d, t)
        out[i] = (up1 + M[0] * du + M[1] * dv) - z_state(p, j, tau)[0]
    return out
