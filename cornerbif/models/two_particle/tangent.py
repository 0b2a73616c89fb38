"""Tangent dynamics of the two-particle system (section 6, docs/stability.md): 4x4 steps
through w-z impacts (law 5) and z-u impacts (law 74, ``zu_saltation``), merged from the two
recorded tables (``two_particle_steps``), the monodromy's eigenvalues and a Gram-Schmidt
spectrum (``two_particle_outputs``).
"""

import math

import numpy as np

from ..._jit import items_kernel, jit, raise_if_stopped, stop_requested
from ...numerics.oscillator import acceleration
from ...numerics.saltation import flight_matrix, flight_misses, grazes, impact_saltation
from ...stability import (
    GRAZING,
    NO_CYCLE,
    NO_WINDOW,
    OK,
    PARTICLE_STICKS,
    TABLE_FULL,
    WARMUP_SHARE,
    generic_basis,
    gram_schmidt,
    lyapunov_window,
    recorded_count,
    sort_nan_last,
    sorted_eigenvalues,
)
from . import kernel as TK
from . import packed as TP


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
    # as the kernel calls them (a tuple of the row, its constants as a tuple): the same
    # compiled functions, which a first run then compiles once, not twice
    pt = TP.as_tuple(p)
    Q, D = TK.oscillators(pt, TK.constants_tuple(TK.derive(p)))
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
            wv, wp, wpp, _ = TK.wall(pt, te, 0.0)
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
            SF = S @ F
            for a in range(4):         # element by element: an array assignment compiles
                for b in range(4):     # numba's shape-mismatch message (3 s of a first compile)
                    G[m, a, b] = SF[a, b]
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
    for a in range(4):                 # element by element (as in two_particle_steps)
        for b in range(4):
            out[a, b] = J[a, b]
    return dur, OK


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
    sort_nan_last(logs)
    for a in range(4):
        out[a] = logs[3 - a] / win      # largest first
    return win, OK


@items_kernel
def batch_two_particle_stability(k0, k1, params, zu, wz, ipc, o_J, o_dur, o_status, o_lam, o_win,
                                 o_lstatus, control=0):
    """Monodromies and Lyapunov spectra of every run (row) in parallel; the multipliers are
    the monodromies' eigenvalues (``two_particle_multipliers``); ``control`` as for
    ``batch_stability``."""
    for i in range(k0, k1):
        if stop_requested(control):
            continue
        o_dur[i], o_status[i] = two_particle_monodromy(params[i], zu[i], wz[i], ipc[i], o_J[i])
        o_win[i], o_lstatus[i] = two_particle_lyapunov(params[i], zu[i], wz[i], ipc[i],
                                                       WARMUP_SHARE, o_lam[i])


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
