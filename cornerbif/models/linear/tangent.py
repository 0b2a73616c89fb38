"""Tangent dynamics of the ``linear`` model (docs/linear.md, "Stability"; docs/stability.md):
the monodromy of each run's last recorded cycle and its Lyapunov spectrum over the recorded
window, in the 2N-dimensional state y = (x, v), as products of the flights' Jacobians and
the impacts' saltation matrices.  Everything runs after the event loop, on what it recorded
(each impact's time, contact, x, v- and v+), as the other models' passes do.

**Flights.**  Between impacts y' = A_y y + (forcing), A_y = [[0, I], [-M^-1 K, -M^-1 C]]: the
forcing is additive (the augmented matrix A of flight.py is block upper-triangular, its
forcing states driven by nothing of (x, v)), so the Jacobian of a flight of length h is the
(x, v) block of expm(A h), whatever the forcing: expm(A_y h), det = exp(-tr(M^-1 C) h).
It is carried by the kernel's own flight (``kernel.advance``: the ladder E_k = expm(A H / 2^k)
and the short series), column by column (``carry_flight``).

**Impacts** (docs/linear.md, "The laws": the generalised Newton law, the paper's law (5) for
N = 1 and law (74) for two masses).  The surface is g(y, t) = a . x - z(t) = 0, its gradient
n = (a, 0), reached with dg/dt = a . v- - z'(t*) = w- < 0; the jump is
R(y, t) = (x, v - (1 + r) (a . v - z'(t)) m), m = M^-1 a / (a^T M^-1 a), so

    D_y R = [[I, 0], [0, I - (1 + r) m a^T]],   d_t R = (0, (1 + r) z''(t*) m).

A perturbation dy of the state just before the impact, at the fixed time t*, meets the
surface at t* + dt, n . (dy + f- dt) + (d_t g) dt = 0, so dt = -n . dy / w-; the jump there,
flown back to t*, gives dy+ = D_y R (dy + f- dt) + d_t R dt - f+ dt:

    S = D_y R + (f+ - D_y R f- - d_t R) n^T / w-,   f-+ = (v-+, M^-1 (F(t*) - C v-+ - K x)).

With v+ - v- = -(1 + r) w- m and a+ - a- = -M^-1 C (v+ - v-),
f+ - D_y R f- - d_t R = (1 + r) w- (-m, M^-1 C m + ((a . a- - z'') / w-) m), hence

    S = [[I - (1 + r) m a^T,                              0                ],
         [(1 + r) (M^-1 C m + ((a . a- - z'') / w-) m) a^T, I - (1 + r) m a^T]],

a- the acceleration just before the impact (a . a- - z'' = g'', the gap's curvature,
over g' = w-: the term that diverges at a graze).  Block triangular, with
det (I - (1 + r) m a^T) = 1 - (1 + r) a^T m = -r: det S = r^2 for every N, contact and
obstacle.  N = 1, M = 1, a = 1, C = 2 sigma is the flow's [[-r, 0], [(1 + r) ((a- - z'')/w-
+ 2 sigma), -r]] (``numerics.saltation.impact_saltation``); two masses with a = (-1, 1) the
two-particle model's z-u saltation (law 74, ``two_particle.tangent.zu_saltation``).

z' and z'' are the obstacle's on the piece the impact lies on.  Near a corner (within
CORNER_WINDOW of a piece's end) that is the side whose slope the law used, which the record
says: w+ = -r w- gives z' = (a . v+ + r a . v-) / (1 + r).

**The cycle and the window.**  The monodromy from just after impact k to just after impact
k + q a cycle later (q = impacts per cycle) is J = S_(k+q) Phi_(k+q) ... S_(k+1) Phi_(k+1),
det J = exp(-tr(M^-1 C) (t_(k+q) - t_k)) prod r_c^2; its eigenvalues, sorted by modulus, are
the Floquet multipliers (2N: an autonomous system's have the trivial 1 of the flow's
direction among them).  The Lyapunov spectrum (2N) carries a Gram-Schmidt basis through every
step (``stability.gram_schmidt``), the warm-up aligning it (``stability.lyapunov_window``).
A recorded impact with |w-| below GRAZING_TOL of its velocity scale (``grazes``): GRAZING
(NaN).  The record holds no sticking (a run that chatters to rest ends there, STUCK), so no
step is a collapse.
"""

import math

import numpy as np

from ..._jit import items_kernel, jit, raise_if_stopped, stop_requested
from ...numerics.saltation import grazes
from ...obstacles.dispatch import derived_tuple, piece_at, piece_length, piece_start, z_state
from ...stability import (
    GRAZING,
    NO_CYCLE,
    NO_WINDOW,
    OK,
    WARMUP_SHARE,
    generic_basis,
    gram_schmidt,
    lyapunov_window,
    multipliers,
    recorded_count,
    sort_nan_last,
    sorted_eigenvalues,
)
from ..flow.packed import as_tuple
from .batch import forcing_into, system_arrays
from .kernel import advance

# an impact this close to a piece's end (relative to 1 + |t|) may lie on either side of the
# corner: the side whose slope the law used is taken (``obstacle_at_impact``)
CORNER_WINDOW = 1e-9


@jit
def carry_flight(E, A, H, h, n, Q, y, tmp, tmp2):
    """Each column q of ``Q`` (2n rows) <- Phi(h) q, Phi(h) the (x, v) block of expm(A h): the
    flight's Jacobian, by the kernel's flight (``kernel.advance`` on (q, 0), the forcing
    states unperturbed).  ``y``, ``tmp``, ``tmp2``: work vectors of A's size."""
    for k in range(Q.shape[1]):
        y[:] = 0.0
        for a in range(2 * n):
            y[a] = Q[a, k]
        advance(E, A, H, y, h, tmp, tmp2)
        for a in range(2 * n):
            Q[a, k] = y[a]


@jit
def flight_jacobian(E, A, H, h, n):
    """Phi(h) (2n x 2n): the Jacobian of a flight of length h (``carry_flight`` of I)."""
    m = A.shape[0]
    Q = np.eye(2 * n)
    carry_flight(E, A, H, h, n, Q, np.empty(m), np.empty(m), np.empty(m))
    return Q


@jit
def saltation(n, a, Dc, r, A, acc, w, zpp):
    """The saltation matrix S (2n x 2n) of an impact on a contact with gap vector ``a``
    (``Dc`` = M^-1 a, restitution ``r``), reached with w- = ``w`` < 0, gap acceleration
    ``acc`` = a . a- and obstacle curvature ``zpp`` = z''(t*); ``A`` the augmented flight
    matrix (its block -M^-1 C).  The module docstring derives it; det S = r^2."""
    ad = 0.0
    for j in range(n):
        ad += a[j] * Dc[j]
    kap = (acc - zpp) / w
    s = 1.0 + r
    S = np.eye(2 * n)
    for i in range(n):
        mi = Dc[i] / ad
        cm = 0.0                           # (M^-1 C m)_i = -(A_vv m)_i
        for j in range(n):
            cm -= A[n + i, n + j] * Dc[j] / ad
        for j in range(n):
            S[i, j] -= s * mi * a[j]
            S[n + i, n + j] -= s * mi * a[j]
            S[n + i, j] += s * (cm + kap * mi) * a[j]
    return S


@jit
def obstacle_at_impact(row, d, t, zp_seen):
    """(z', z'') of the obstacle at an impact at time t: on the piece t lies on (as the
    kernel takes it: at a piece's end, the one that goes on past t), or within
    CORNER_WINDOW of a piece's end the neighbouring piece whose slope is closer to
    ``zp_seen``, the slope the impact law used."""
    j, _ = piece_at(d, t)
    while piece_start(d, j) + piece_length(d, j) <= t:
        j += 1
    _, zp, zpp, _ = z_state(row, j, t - piece_start(d, j))
    near = CORNER_WINDOW * (1.0 + abs(t))
    for jj in (j - 1, j + 1):
        if jj < 0:
            continue
        edge = piece_start(d, jj) + piece_length(d, jj) if jj < j else piece_start(d, jj)
        if abs(t - edge) <= near:
            _, zp2, zpp2, _ = z_state(row, jj, t - piece_start(d, jj))
            if abs(zp2 - zp_seen) < abs(zp - zp_seen):
                zp, zpp = zp2, zpp2
    return zp, zpp


# The systems' stacked arrays travel as one tuple ``sy`` (``system_tuple``: E, A, H, cA,
# rows, ds, gaps, D, r, f_omega, f_phi, f_const, as ``batch.system_arrays`` makes them and
# ``batch.run_batch`` takes them, each indexed by the system s) and a run's record as
# ``rec`` = (t, contact, x, v_in, v_out).
SYSTEM_KEYS = ("E", "A", "H", "cA", "rows", "ds", "gaps", "D", "r", "f_omega", "f_phi",
               "f_const")


def system_tuple(arrays):
    """The tuple ``sy`` of ``batch.system_arrays``'s dict."""
    return tuple(arrays[k] for k in SYSTEM_KEYS)


@jit
def impact_saltation_at(sy, s, tk, ck, xk, vin, vout, y):
    """(S, status) of a recorded impact (time ``tk``, contact ``ck``, x, v-, v+) of system
    ``s`` of ``sy``: GRAZING (S unset) where |w-| is below GRAZING_TOL of its velocity
    scale.  ``y``: a work vector of A's size (the augmented state just before)."""
    _, A, _, cA, rows, ds, gaps, D, r, f_omega, f_phi, f_const = sy
    n = gaps.shape[2]
    a = gaps[s, ck]
    av_in = 0.0
    av_out = 0.0
    for j in range(n):
        av_in += a[j] * vin[j]
        av_out += a[j] * vout[j]
    rc = r[s, ck]
    zp, zpp = obstacle_at_impact(as_tuple(rows[s, ck]), derived_tuple(ds[s, ck]), tk,
                                 (av_out + rc * av_in) / (1.0 + rc))
    w = av_in - zp
    if grazes(w, av_in, zp) or abs(av_out - zp) <= 1e-9 * abs(w):
        # (or an impact that starts a hold, whose rebound is 0: sticking's collapse and the
        # held flight are not in this pass yet, docs/linear.md "Sticking")
        return np.empty((2 * n, 2 * n)), GRAZING
    y[:] = 0.0
    for j in range(n):
        y[j] = xk[j]
        y[n + j] = vin[j]
    forcing_into(y, n, f_omega, f_phi, f_const, s, tk)
    acc = 0.0                               # a . a- = c A^2 y (c = (a, 0, 0))
    for j in range(y.shape[0]):
        acc += cA[s, ck, 2, j] * y[j]
    return saltation(n, a, D[s, ck], rc, A[s], acc, w, zpp), OK


@jit
def carry_step(sy, s, rec, k, Q, work):
    """Q <- S_k Phi(t_k - t_(k-1)) Q: the tangent basis ``Q`` (2n x K) from just after
    recorded impact k - 1 of ``rec`` to just after impact k.  Returns OK or GRAZING (Q then
    unchanged past its flight).  ``work``: (2n x K, then three vectors of A's size)."""
    E, A, H = sy[0], sy[1], sy[2]
    t, c, x, v_in, v_out = rec
    wq, y, tmp, tmp2 = work
    n = x.shape[1]
    carry_flight(E[s], A[s], H[s], t[k] - t[k - 1], n, Q, y, tmp, tmp2)
    S, st = impact_saltation_at(sy, s, t[k], c[k], x[k], v_in[k], v_out[k], y)
    if st != OK:
        return st
    for b in range(Q.shape[1]):             # element by element (no BLAS call per step)
        for i in range(2 * n):
            acc = 0.0
            for j in range(2 * n):
                acc += S[i, j] * Q[j, b]
            wq[i, b] = acc
    for b in range(Q.shape[1]):
        for i in range(2 * n):
            Q[i, b] = wq[i, b]
    return OK


@jit
def workspace(sy, n):
    """The work arrays of ``carry_step`` for a 2n x 2n basis."""
    m = sy[1].shape[1]
    return np.empty((2 * n, 2 * n)), np.empty(m), np.empty(m), np.empty(m)


@jit
def monodromy_between(sy, s, rec, first, last, out):
    """The Jacobian (into ``out``, 2n x 2n) from just after recorded impact ``first`` of
    ``rec`` to just after impact ``last``: S_last Phi_last ... S_(first+1) Phi_(first+1).
    Returns OK, or GRAZING (``out`` NaN)."""
    n = rec[2].shape[1]
    J = np.eye(2 * n)
    work = workspace(sy, n)
    for k in range(first + 1, last + 1):
        st = carry_step(sy, s, rec, k, J, work)
        if st != OK:
            out[:, :] = math.nan
            return st
    for i in range(2 * n):
        for j in range(2 * n):
            out[i, j] = J[i, j]
    return OK


@jit
def linear_lyapunov(sy, s, rec, ipc, warmup_share, out):
    """The Lyapunov spectrum (into ``out``, 2n, per unit time, largest first) over one run's
    recorded impacts ``rec``, by Gram-Schmidt after every impact; the warm-up
    (``lyapunov_window``) aligns the basis, the logarithms are averaged over the window
    (whole cycles where the run has one): (window, status).  A grazing impact in the warm-up
    restarts the basis at the next step; one in the window gives NaN and GRAZING."""
    t = rec[0]
    n = rec[2].shape[1]
    steps = recorded_count(t) - 1
    out[:] = math.nan
    start = lyapunov_window(steps, ipc, warmup_share)
    if start < 0 or not t[steps] > t[start]:
        return math.nan, NO_WINDOW
    win = t[steps] - t[start]
    Q = generic_basis(2 * n)
    work = workspace(sy, n)
    discard = np.zeros(2 * n)
    logs = np.zeros(2 * n)
    for k in range(1, steps + 1):
        st = carry_step(sy, s, rec, k, Q, work)
        if st != OK:
            if k > start:
                return win, st
            Q = generic_basis(2 * n)       # before the window: the basis restarts
            continue
        gram_schmidt(Q, logs if k > start else discard)
    sort_nan_last(logs)
    for a in range(2 * n):
        out[a] = logs[2 * n - 1 - a] / win        # largest first
    return win, OK


@items_kernel
def batch_linear_stability(k0, k1, which, sy, t, c, x, v_in, v_out, ipc, o_J, o_re, o_im, o_dur,
                           o_status, o_lam, o_win, o_lstatus, control=0):
    """Each item (row) i of system ``which[i]`` of ``sy`` (the stacked arrays of
    ``batch.system_arrays``, as ``system_tuple``), in parallel: the monodromy of its last
    recorded cycle of ``ipc[i]`` impacts into o_J[i] (with its duration and status) and, for
    N = 1, its multipliers (``stability.multipliers``: the flow's, from the entries); the
    Lyapunov spectrum over its record.  ``control`` as for ``flow.tangent.batch_stability``."""
    for i in range(k0, k1):
        if stop_requested(control):
            continue
        s = which[i]
        rec = (t[i], c[i], x[i], v_in[i], v_out[i])
        nrec = recorded_count(t[i])
        q = ipc[i]
        o_re[i, :] = math.nan
        o_im[i, :] = math.nan
        if q <= 0 or nrec < q + 1:
            o_J[i, :, :] = math.nan
            o_dur[i] = math.nan
            o_status[i] = NO_CYCLE
        else:
            first = nrec - 1 - q
            o_dur[i] = t[i, nrec - 1] - t[i, first]
            o_status[i] = monodromy_between(sy, s, rec, first, nrec - 1, o_J[i])
            if o_status[i] == OK and o_J.shape[1] == 2:
                J = o_J[i]
                o_re[i, 0], o_im[i, 0], o_re[i, 1], o_im[i, 1] = multipliers(
                    J[0, 0], J[0, 1], J[1, 0], J[1, 1])
        o_win[i], o_lstatus[i] = linear_lyapunov(sy, s, rec, q, WARMUP_SHARE, o_lam[i])


def linear_outputs(arrays, which, t, c, x, v_in, v_out, ipc, control=0):
    """The ``stability`` observable of the linear model for n runs (docs/linear.md,
    "Stability"): the Floquet multipliers (2N, by decreasing modulus) of each run's last
    recorded cycle and its Lyapunov spectrum (2N) over the recorded window, keyed as
    ``stability.new_outputs``, and ``monodromy`` (n, 2N, 2N).  ``arrays``: the stacked
    arrays of the runs' systems (``batch.system_arrays``), ``which`` each run's system; ``t``,
    ``c``, ``x``, ``v_in``, ``v_out``: the recorded impacts (time, contact index, x, v-, v+).
    Under a sweep's ``control`` told to stop: ``KernelStopped``."""
    n = t.shape[0]
    nd = x.shape[2]
    J = np.empty((n, 2 * nd, 2 * nd))
    res = {"mu_re": np.empty((n, 2 * nd)), "mu_im": np.empty((n, 2 * nd)),
           "cycle_duration": np.empty(n), "stability_status": np.empty(n, np.int8),
           "lyapunov": np.empty((n, 2 * nd)), "lyapunov_window": np.empty(n),
           "lyapunov_status": np.empty(n, np.int8)}
    batch_linear_stability(np.ascontiguousarray(which, dtype=np.int64), system_tuple(arrays),
                           np.ascontiguousarray(t), np.ascontiguousarray(c, dtype=np.int64),
                           np.ascontiguousarray(x),
                           np.ascontiguousarray(v_in), np.ascontiguousarray(v_out),
                           np.ascontiguousarray(ipc, dtype=np.int64), J, res["mu_re"],
                           res["mu_im"], res["cycle_duration"], res["stability_status"],
                           res["lyapunov"], res["lyapunov_window"], res["lyapunov_status"],
                           control)
    raise_if_stopped(control)
    if nd > 1:                 # N = 1: the kernel's 2x2 multipliers, as the flow's
        mu = sorted_eigenvalues(J)
        res["mu_re"], res["mu_im"] = mu.real.copy(), mu.imag.copy()
    return {**res, "monodromy": J}


def cycle_monodromy(system, record, first, count):
    """The Jacobian of ``count`` recorded impacts after impact ``first`` of one run of
    ``system`` (Python entry; ``record`` a dict of t, contact (indices), x, v_in, v_out as
    ``kernel.run_system`` gives them, contact names or indices): a dict with ``jacobian``
    (2N x 2N), ``multipliers`` (by decreasing modulus), ``duration``, ``det_closed_form`` =
    exp(-tr(M^-1 C) duration) prod r_c^2 and ``status`` (OK or GRAZING)."""
    names = [ct.name for ct in system.contacts]
    c = np.array([names.index(k) if isinstance(k, str) else int(k) for k in record["contact"]],
                 np.int64)
    t = np.asarray(record["t"], float)
    n = system.n
    out = np.empty((2 * n, 2 * n))
    rec = (t, c) + tuple(np.ascontiguousarray(record[k], dtype=float)
                         for k in ("x", "v_in", "v_out"))
    st = monodromy_between(system_tuple(system_arrays([system])), 0, rec, int(first),
                           int(first + count), out)
    dur = float(t[first + count] - t[first])
    tr = float(np.trace(np.linalg.solve(system.mass, system.damping)))
    det = math.exp(-tr * dur) * math.prod(system.contacts[k].r ** 2
                                          for k in c[first + 1:first + count + 1])
    return {"jacobian": out, "multipliers": sorted_eigenvalues(out), "duration": dur,
            "det_closed_form": det, "status": st}
