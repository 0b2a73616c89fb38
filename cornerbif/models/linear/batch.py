"""The linear model's kernels over a sweep's items: ``run_batch`` runs the event
loop of ``kernel.run`` for each item on its system's arrays (``kernel.prepare``; the systems of
a block stacked, ``which`` says each item's), and ``detect_contact_cycles`` finds each run's
cycle in the impacts it recorded.

The arrays of the systems of one call have one shape: their ``[system]`` tables differ only
in numbers (``LinearModel.run_items`` runs the systems of each augmented size, a forcing's
Omega 0 or not, in a call of its own).

**Cycles.**  The run's impacts k = 0 .. n-1 (contact c_k, time t_k, the impact height u_k =
a . x and velocity v_k = a . v- along the contact's gap) repeat with q impacts per cycle when,
over the whole recorded window (at least two cycles), c_(k+q) = c_k, u and v agree to
``period_tol`` (relative above 1, as ``analysis.detect_cycle``), and t_(k+q) - t_k is one
multiple P T of the system's period T (to ``period_tol``): the period P (in periods T, the
forcing's or the moving obstacles'; where the system has none, T = 0, the period is q, in
impacts).  The word is the contacts' letters over one cycle, rotated to its lexicographically
smallest form (``analysis.smallest_rotation``): "LR" for a symmetric motion between two
stops.
"""

from __future__ import annotations

import math

import numpy as np

from ... import status as S
from ..._jit import STOPPED, count_done, items_kernel, jit, stop_requested
from ...analysis import smallest_rotation
from ...obstacles.dispatch import corner_of, derived_tuple, piece_at, piece_length, piece_start
from ..flow.packed import as_tuple
from .flight import has_constant_state
from .kernel import BUDGET, CHATTERS, ESCAPED, NONFINITE, gap_at, prepare, run

# the integer settings (``LinearModel.int_settings``)
I_TRANSIENT, I_RECORD, I_CONTROL = 0, 1, 2
NINT = 3



@items_kernel
def run_batch(k0, k1, which, Es, As, Hs, normAs, cAm, cAsm, Nm, normc, rowsm, dsm, gaps, D, r, soft,
              f_omega, f_phi, f_const, ics, ints, tol, chatter, escape, t_max, o_t, o_c, o_x, o_vin, o_vout,
              o_status, o_final, counted, corners, period, o_off, o_corner):
    """Item i: the system ``which[i]`` (the stacked arrays' first index) from the start ics[i]
    = (x, v, t0) at t = t0 (the start time, 0 where ics has no column for it):
    ``ints[I_TRANSIENT]`` impacts, then up to o_t.shape[1] recorded, within the time
    ``t_max`` of its system after t0.  A start with a gap below zero: BELOW_OBSTACLE, nothing
    recorded.  ``f_omega``, ``f_phi`` (per system, per harmonic force) and ``f_const`` (a
    constant force: its state 1) start the forcing's states (``flight.forcing_state``).
    ``counted``, ``corners`` (contact indices, -1: none), ``period`` (per system) and
    ``o_off``, ``o_corner`` ((n, record); (n, 0) without them): the two-particle model's
    words (``kernel.run``).  ``Es`` .. ``dsm``, ``soft``: each system's arrays per mode (the
    soft stops acting: ``kernel.mode_arrays``); a start inside a soft stop is not run either
    (BELOW_OBSTACLE)."""
    n = gaps.shape[2]
    control = ints[I_CONTROL]
    skip = ints[I_TRANSIENT]
    rec = o_t.shape[1]
    m = Es.shape[3]
    y0 = np.empty(m)
    for i in range(k0, k1):
        if stop_requested(control):
            o_status[i] = STOPPED
            continue
        s = which[i]
        t0 = ics[i, 2 * n] if ics.shape[1] > 2 * n else 0.0
        y0[:] = 0.0
        for k in range(2 * n):
            y0[k] = ics[i, k]
        forcing_into(y0, n, f_omega, f_phi, f_const, s, t0)
        o_final[i, :] = math.nan
        inside = False
        for c in range(gaps.shape[1]):
            row, d = as_tuple(rowsm[s, 0, c]), derived_tuple(dsm[s, 0, c])   # (kernel.run's types)
            j, _ = piece_at(d, t0)
            while piece_start(d, j) + piece_length(d, j) <= t0:
                j += 1
            g, _ = gap_at(cAm[s, 0], c, y0, row, d, j, t0)
            if g < 0.0:
                inside = True
        if inside:
            o_status[i] = S.BELOW_OBSTACLE
            continue
        st, _ = run(Es[s], As[s], Hs[s], normAs[s], cAm[s], cAsm[s], Nm[s], normc[s], rowsm[s], dsm[s],
                    gaps[s], D[s], r[s], soft[s], y0, t0, n, skip, skip + rec, tol, chatter, escape,
                    t0 + t_max[s], control,
                    o_t[i], o_c[i], o_x[i], o_vin[i], o_vout[i], o_final[i], counted, corners,
                    period[s], o_off[i], o_corner[i])
        if st == STOPPED:
            o_status[i] = STOPPED
            continue
        o_status[i] = status_of(st)
        count_done(control)


@jit
def forcing_into(y, n, f_omega, f_phi, f_const, s, t):
    """The forcing part of the augmented state ``y`` (after its 2n coordinates and
    velocities) at time t for system ``s`` of the stacked ``f_omega``, ``f_phi`` (per
    harmonic force) and ``f_const`` (a constant force: its state 1, last):
    (cos, sin)(Omega t + phi) per harmonic force (``flight.forcing_state``)."""
    for h in range(f_omega.shape[1]):
        th = f_phi[s, h] if t == 0.0 else f_omega[s, h] * t + f_phi[s, h]
        y[2 * n + 2 * h] = math.cos(th)
        y[2 * n + 2 * h + 1] = math.sin(th)
    if f_const[s]:
        y[y.shape[0] - 1] = 1.0


@jit
def status_of(st):
    """The file's status code (cornerbif.status) of an ending of ``kernel.run``."""
    if st == CHATTERS:
        return S.STUCK                 # held at the budget, or chattering where it cannot be held
    if st == BUDGET:
        return S.NO_IMPACT
    if st == ESCAPED:
        return S.ESCAPED
    if st == NONFINITE:
        return S.NONFINITE
    return S.OK


@jit
def detect_contact_cycle(t, c, u, v, period, tol, letters, sym_out):
    """(period, impacts per cycle) of one run's impacts and its word into ``sym_out``
    (module docstring); (0, 0) when no cycle repeats twice in the window."""
    n = 0
    while n < t.shape[0] and t[n] == t[n]:
        n += 1
    sym_out[:] = 0
    for q in range(1, n // 2 + 1):
        ok = True
        whole = -1.0
        for k in range(n - q):
            e = k + q
            if c[k] != c[e] or abs(u[k] - u[e]) > tol * (1.0 + abs(u[k])) \
                    or abs(v[k] - v[e]) > tol * (1.0 + abs(v[k])):
                ok = False
                break
            if period > 0.0:
                dt = t[e] - t[k]
                p = math.floor(dt / period + 0.5)
                if p < 1.0 or abs(dt - p * period) > tol or (whole >= 0.0 and p != whole):
                    ok = False
                    break
                whole = p
        if ok:
            word = np.empty(q, np.uint8)
            for k in range(q):
                word[k] = letters[c[n - q + k]]
            best = smallest_rotation(word, 0, q)
            for k in range(q):
                sym_out[k] = word[(best + k) % q]
            return (int(whole) if period > 0.0 else q), q
    return 0, 0


@items_kernel
def detect_contact_cycles(k0, k1, t, c, u, v, period, tol, letters, o_period, o_ipc, o_sym):
    """``detect_contact_cycle`` over all items (``period``: each item's system period T)."""
    for i in range(k0, k1):
        p, q = detect_contact_cycle(t[i], c[i], u[i], v[i], period[i], tol, letters, o_sym[i])
        o_period[i] = p
        o_ipc[i] = q


@items_kernel
def corner_offsets(k0, k1, t, rows, ds, o_off, o_corner):
    """Each recorded impact's nearest corner of the (one) contact's obstacle and its signed
    offset t - t_corner (``obstacles.dispatch.corner_of``, the flow kernel's grouping): the
    paper's corner clusters, for ``analysis.detect_cycles`` (``model.paper_words``).
    ``rows``, ``ds``: each item's packed obstacle row and its derived row."""
    for i in range(k0, k1):
        row, d = as_tuple(rows[i]), derived_tuple(ds[i])      # (kernel.run's types)
        for k in range(t.shape[1]):
            tk = t[i, k]
            if not (tk == tk):
                break
            j, tau = piece_at(d, tk)
            # at a piece's end, tk rounds into either piece: the one that goes on past it
            while piece_start(d, j) + piece_length(d, j) <= tk:
                j += 1
            c, off = corner_of(row, d, j, tk - piece_start(d, j))
            o_corner[i, k] = c
            o_off[i, k] = off


def system_arrays(systems):
    """The stacked arrays of ``run_batch`` and of the stability pass (``tangent``) for systems of one
    augmented size (``kernel.prepare`` of each): a dict."""
    nd = systems[0].n
    prepared = [prepare(s, 0.0, np.zeros(nd), np.zeros(nd)) for s in systems]

    def stack(key, dtype=float):
        return np.ascontiguousarray(np.stack([np.asarray(p[key], dtype) for p in prepared]))

    harmonic = [[f for f in s.forcing if f.Omega > 0.0] for s in systems]
    out = {k: stack(k) for k in ("E", "A", "cA", "cAs", "N", "normc", "rows", "ds", "gaps",
                                 "D", "r", "Es", "As", "Hs", "normAs", "cAm", "cAsm", "Nm", "rowsm",
                                 "dsm")}
    out["soft"] = stack("soft", np.int64)
    out["H"] = np.array([p["H"] for p in prepared])
    out["normA"] = np.array([p["normA"] for p in prepared])
    out["f_omega"] = np.array([[f.Omega for f in h] for h in harmonic],
                              float).reshape(len(systems), -1)
    out["f_phi"] = np.array([[f.phi for f in h] for h in harmonic],
                            float).reshape(len(systems), -1)
    out["f_const"] = np.array([has_constant_state(s) for s in systems], np.bool_)
    return out
