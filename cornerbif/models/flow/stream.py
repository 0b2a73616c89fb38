"""The Lyapunov spectrum of a ``flow`` run streamed through the kernel, over any number of
impacts, none of them stored (docs/stability.md, "Lyapunov exponents").

``tangent.run_lyapunov`` reads the spectrum off a run's record, so its window is capped by
the record (run.record <= 100 000 impacts, memory record x runs).  Here the same method is
carried along the run instead: Benettin's QR method (G. Benettin, L. Galgani, A. Giorgilli,
J.-M. Strelcyn, Meccanica 15 (1980) 9-30), in two dimensions q <- J q / |J q|, R11 = |J q|,
R22 = |det J| / R11, with J = S M the step from one impact to the next
(``tangent.impact_step``: the flight matrix of eq (4) and the saltation of law (5)).

**Chunks.**  The kernel ``run_one`` (kernel.py, unchanged) runs CHUNK impacts at a time into
buffers of CHUNK entries: the first call from the start with the run's transient, each next
one with no transient from the post-impact state (t, u, v+) of an impact of the chunk
before.  ``run_one`` treats a start inside a piece "as just after an impact there" (the
piece and local time from ``piece_at``, the gap search skipping its root at the start when
u = z), so the restarted run is the run continued, up to the rounding of t into (piece,
local time).  The tangent is carried over the seam exactly as between two recorded impacts:
the step from the restart impact to the next chunk's first impact is ``impact_step`` on
those two impacts (the flight matrix depends only on the time difference).  Memory per
item is the chunk's buffers, O(CHUNK), whatever the window (and per thread, as the items
kernels reuse them from item to item).

**The restart impact** is the last impact of the chunk after which the kernel flies freely,
i.e. whose relative velocity w+ = v+ - z' exceeds run.chatter (the kernel's own test after
every impact, law (5) and the chattering sum: at or below it the kernel sums a chattering
sequence or sticks, which a restart "just after an impact" would not); that is the chunk's
last impact but in a chattering run, and the impacts after it are recorded again by the next
chunk.  Its height is clamped to the obstacle: the kernel places the restart time by
``piece_at`` (period count and phase) and refuses a start below z there (BELOW_OBSTACLE), so
u = max(u_impact, z(piece_at(t))) computed as ``run_one`` computes it; the two differ by
the rounding of t into (piece, local time), a few ulp(t).

**Time** is kept absolute (not reduced modulo a period: the forcing F cos(Omega t + phi) has
its own period), so the phase of every restart is resolved to ulp(t): 2.2e-16 t, 1.1e-10 at
t = 1e6.  On a periodic orbit the restarts change nothing beyond rounding; on a chaotic one
each restart perturbs the orbit by that rounding, which the chaos amplifies: the streamed
and a recorded run then agree only statistically (tests/models/test_lyapunov_stream.py).

**Budgets.**  ``run_one`` spends run.max_events and run.max_periods per call: per chunk here
(``stream_settings`` raises them to the automatic rule of config for transient + CHUNK
impacts).  The early stop is off (a copy of the row with STOP_TOL = 0): every chunk records
its CHUNK impacts.

Impacts are numbered from the first after the transient (0): the tangent starts at impact 0,
steps 1 .. ``warmup`` only align q (a stick or a grazing impact there restarts it, as in
``run_lyapunov``), steps warmup + 1 .. warmup + window are averaged.  Statuses as
``run_lyapunov`` (cornerbif/stability.py): STICKING (-inf, -inf) for a stick in the window,
GRAZING (NaN) for a grazing impact in it, NO_WINDOW (NaN) when the run ended (kernel status
other than OK, cornerbif/status.py) before the window's end; a run stuck for good (kernel
STUCK) has the exact collapse, STICKING.
"""

import math

import numpy as np

from ... import status as S
from ..._jit import STOPPED, items_kernel, jit, raise_if_stopped, stop_requested
from ...model import automatic_budgets
from ...numerics.oscillator import derive
from ...numerics.saltation import GRAZING_TOL
from ...obstacles.dispatch import (
    derived_tuple,
    derived_tuple_profile,
    obstacle_at_offset,
    piece_at,
    z_state,
)
from ...stability import GRAZING, NO_WINDOW, OK, STICKING, log_or_minus_inf
from . import packed as P
from .kernel import run_one
from .tangent import START_U, START_V, impact_step

CHUNK = 4096            # impacts per call of run_one: the buffers' length


def stream_settings(ints, chunk=CHUNK):
    """A copy of the kernel's integer settings for the stream's calls of ``run_one``: the
    record ``chunk`` and the budgets (per call) at least config's automatic rule for the
    transient and one chunk (10 events and 50 periods per impact, plus 1000 each), which a
    scene's settings, sized for its own record, may fall short of."""
    out = np.array(ints, np.int64)
    need = int(out[P.I_TRANSIENT]) + chunk
    out[P.I_RECORD] = chunk
    # within int64, as config keeps a scene's budgets (MAX_INT - 1)
    most = np.iinfo(np.int64).max - 1
    events, periods = automatic_budgets(P.EVENTS_PER_IMPACT, need)
    out[P.I_MAX_EVENTS] = min(max(int(out[P.I_MAX_EVENTS]), events), most)
    out[P.I_MAX_PIECES] = min(max(int(out[P.I_MAX_PIECES]), P.PIECES_PER_PERIOD * periods), most)
    return out


@jit
def chunk_buffers(chunk):
    """The outputs of one ``run_one`` call of ``chunk`` impacts (t, u, v-, v+, corner
    offset, corner, section u, v) and its final state and first recorded impact."""
    return (np.empty(chunk), np.empty(chunk), np.empty(chunk), np.empty(chunk),
            np.empty(chunk), np.empty(chunk, np.int64), np.empty(chunk), np.empty(chunk),
            np.empty(2), np.empty(1, np.int64))


@jit
def restart_height(p, d, t, u):
    """The height of a restart at time t from an impact at height u: u, or the obstacle's
    height z(t) where rounding put u below it.  z is computed as ``run_one`` computes it for
    a start at t (``piece_at``, ``z_state``), which refuses a start below it (BELOW_OBSTACLE)."""
    j = np.int64(0)
    tau = 0.0
    if t != 0.0:
        j, tau = piece_at(d, t)
    z, _, _, _ = z_state(p, j, tau)
    return u if u >= z else z


@jit
def restart_impact(p, d, o_t, o_vout, o_off, n):
    """The impact of a chunk of n recorded impacts to restart ``run_one`` from: the last one
    after which the kernel flies freely, w+ = v+ - z' > run.chatter (z' the slope law (5)
    used, ``obstacle_at_offset``); the last one where none is."""
    chatter = p[P.CHATTER]
    for i in range(n - 1, -1, -1):
        zp, _ = obstacle_at_offset(p, d, o_t[i], o_off[i])
        if o_vout[i] - zp > chatter:
            return i
    return n - 1


@jit
def stream_one(p, d, row, drow, ints, u0, v0, t0, warmup, window, o_t, o_u, o_vin, o_vout,
               o_off, o_corner, o_su, o_sv, final, info):
    """The Lyapunov spectrum (per unit time) of the run from (t0, u0, v0) over the ``window``
    impacts after ``warmup`` aligning ones, the first counted after the transient
    (``ints[I_TRANSIENT]``): (lambda1, lambda2, averaging time, Lyapunov status, kernel
    status, impacts averaged).

    ``p``, ``d``: the tuples ``run_one`` takes (``run_batch``'s or ``run_batch_profile``'s)
    of the packed row ``row`` with STOP_TOL = 0; ``row``, ``drow`` = derive(row): the same
    as arrays, which the tangent steps take (``impact_step``, as in ``batch_stability``:
    its compiled code, and the obstacle's slots beyond a built-in tuple's); ``ints``: the
    kernel's settings (``stream_settings``); the buffers: ``chunk_buffers``, of any common
    length (the chunk).  The algorithm of ``tangent.run_lyapunov`` over the stream of impacts
    (module docstring): sum log R11 and log|det J| over the window, lambda1 = sum1 / W,
    lambda2 = (sumdet - sum1) / W, W = t_(warmup + window) - t_warmup.  A stick in the
    window ends it at once (-inf is final: the averaging time and count then run to the
    stick); a grazing impact in it makes the result NaN (GRAZING) and the stream goes on,
    as a later stick still gives -inf in ``run_lyapunov``.
    """
    nan = math.nan
    chunk = o_t.shape[0]
    settings = ints.copy()
    settings[P.I_RECORD] = chunk
    steps = warmup + window     # tangent steps after impact 0
    qu, qv = START_U, START_V
    sum1 = 0.0
    sumdet = 0.0
    grazing = False
    step = -1                   # the number of the impact last carried (-1: none yet)
    t_w = nan                   # the window's start: the time of impact ``warmup``
    tp = nan                    # the impact last carried: t, u, v+
    up = nan
    vp = nan
    u = u0
    v = v0
    t = t0
    if window < 1:
        return nan, nan, nan, NO_WINDOW, S.OK, 0
    while True:
        o_t[:] = nan            # recorded impacts: the entries before the first NaN
        status = run_one(p, d, settings, u, v, t, o_t, o_u, o_vin, o_vout, o_off, o_corner,
                         o_su, o_sv, final, info)
        settings[P.I_TRANSIENT] = 0
        n = 0
        while n < chunk and o_t[n] == o_t[n]:
            n += 1
        last = n - 1
        if status == S.OK and n > 0:
            last = restart_impact(row, drow, o_t, o_vout, o_off, n)
        for i in range(last + 1):
            step += 1
            if step > 0:
                j11, j12, j21, j22, st = impact_step(row, drow, tp, up, vp, o_t[i], o_u[i],
                                                     o_vin[i], o_off[i], GRAZING_TOL)
                inside = step > warmup
                if st == STICKING and inside:
                    # the tangent collapses to zero (exact): -inf is final
                    return -math.inf, -math.inf, o_t[i] - t_w, STICKING, status, step - warmup
                if st != OK:
                    if inside:
                        grazing = True
                    qu, qv = START_U, START_V       # before the window: the basis restarts
                else:
                    xu = j11 * qu + j12 * qv
                    xv = j21 * qu + j22 * qv
                    r11 = math.hypot(xu, xv)
                    if r11 == 0.0:
                        # J q = 0: every direction collapses (r = 0 at two impacts in a row)
                        if inside:
                            return -math.inf, -math.inf, o_t[i] - t_w, OK, status, step - warmup
                        qu, qv = START_U, START_V
                    else:
                        qu = xu / r11
                        qv = xv / r11
                        if inside:
                            sum1 += math.log(r11)
                            sumdet += log_or_minus_inf(abs(j11 * j22 - j12 * j21))
            if step == warmup:
                t_w = o_t[i]
            tp = o_t[i]
            up = o_u[i]
            vp = o_vout[i]
            if step == steps:
                dur = tp - t_w
                if not dur > 0.0:
                    return nan, nan, dur, NO_WINDOW, status, window
                if grazing:
                    return nan, nan, dur, GRAZING, status, window
                return sum1 / dur, (sumdet - sum1) / dur, dur, OK, status, window
        if status != S.OK or n == 0:
            # the run ended before the window did: stuck for good is the exact collapse
            done = max(step - warmup, 0)
            dur = tp - t_w if step >= warmup else nan
            if status == S.STUCK:
                return -math.inf, -math.inf, dur, STICKING, status, done
            return nan, nan, dur, NO_WINDOW, status, done
        # the next chunk: from just after the restart impact (module docstring)
        t = tp
        u = restart_height(p, d, tp, up)
        v = vp


@jit
def store_stream(i, res, o_lam, o_dur, o_lstatus, o_status, o_count):
    """Item i's ``stream_one`` result into the outputs."""
    l1, l2, dur, lst, st, count = res
    o_lam[i, 0] = l1
    o_lam[i, 1] = l2
    o_dur[i] = dur
    o_lstatus[i] = lst
    o_status[i] = st
    o_count[i] = count


@jit
def stream_row(row, out):
    """``out`` <- packed row ``row`` with the early stop off (STOP_TOL = 0): every chunk
    records its impacts."""
    out[:] = row
    out[P.STOP_TOL] = 0.0


@items_kernel
def stream_batch(k0, k1, params, ints, ics, warmup, window, o_lam, o_dur, o_lstatus, o_status,
                 o_count):
    """``stream_one`` for every item i = (params[i], ics[i]) in parallel (``run_batch``'s
    tuples).  Under a sweep's control (``ints[I_CONTROL]``) an item not begun is skipped
    once it says stop, and a run told to stop returns ``STOPPED`` (kernel status; outputs
    incomplete: ``lyapunov_stream`` raises).  Items are not counted as done: in a sweep the
    stream is the stability pass of items the kernel already counted."""
    n = params.shape[0]
    stride = 7919 if n % 7919 != 0 else 1     # run_batch's spread of neighbouring items
    o_t, o_u, o_vin, o_vout, o_off, o_corner, o_su, o_sv, final, info = chunk_buffers(CHUNK)
    row = np.empty(params.shape[1])
    for k in range(k0, k1):
        i = (k * stride) % n
        if stop_requested(ints[P.I_CONTROL]):
            o_status[i] = STOPPED
            continue
        stream_row(params[i], row)
        t0 = ics[i, 2] if ics.shape[1] > 2 else 0.0
        drow = derive(row)
        res = stream_one(P.as_tuple(row), derived_tuple(drow), row, drow, ints, ics[i, 0],
                         ics[i, 1], t0, warmup[i], window[i], o_t, o_u, o_vin, o_vout, o_off,
                         o_corner, o_su, o_sv, final, info)
        store_stream(i, res, o_lam, o_dur, o_lstatus, o_status, o_count)


@items_kernel
def stream_batch_profile(k0, k1, params, ints, ics, warmup, window, o_lam, o_dur, o_lstatus,
                         o_status, o_count):
    """``stream_batch`` for rows of ``obstacle = "profile"`` (``run_batch_profile``'s
    tuples, which refer to the row: here the item's copy ``row``)."""
    if params.shape[1] != P.NPARAM_PROFILE:
        raise ValueError("stream_batch_profile: params must be rows of NPARAM_PROFILE floats")
    n = params.shape[0]
    stride = 7919 if n % 7919 != 0 else 1
    o_t, o_u, o_vin, o_vout, o_off, o_corner, o_su, o_sv, final, info = chunk_buffers(CHUNK)
    # the item's row, with the early stop off: contiguous, and alive through every item's
    # call (the tuples refer to it by its address)
    row = np.empty(params.shape[1])
    for k in range(k0, k1):
        i = (k * stride) % n
        if stop_requested(ints[P.I_CONTROL]):
            o_status[i] = STOPPED
            continue
        stream_row(params[i], row)
        t0 = ics[i, 2] if ics.shape[1] > 2 else 0.0
        drow = derive(row)
        res = stream_one(P.as_tuple_profile(row), derived_tuple_profile(drow, row), row, drow,
                         ints, ics[i, 0], ics[i, 1], t0, warmup[i], window[i], o_t, o_u, o_vin,
                         o_vout, o_off, o_corner, o_su, o_sv, final, info)
        store_stream(i, res, o_lam, o_dur, o_lstatus, o_status, o_count)


def lyapunov_stream(params, ics, ints, warmup, window):
    """The Lyapunov spectrum of each run (params[i], ics[i]) over ``window`` impacts after
    ``warmup`` aligning ones (each a number or one per run), counted from the first impact
    after the transient (``ints[I_TRANSIENT]``), none of them stored (``stream_one``; module docstring).

    ``params``: packed flow rows as ``run_batch`` takes them (one row, or one per start;
    a cam's wider rows run on ``stream_batch_profile``); ``ics``: rows (u, v[, t0]);
    ``ints``: the kernel's integer settings (``FlowModel.int_settings``: transient, budgets,
    the control's address, under which a stopped call raises ``KernelStopped``); the record
    is the chunk and the budgets are per chunk (``stream_settings``).

    Returns a dict of arrays over the runs: ``lyapunov`` (n, 2), ``lyapunov_window`` (the
    averaging time), ``lyapunov_status`` (cornerbif.stability), ``status`` (the kernel's,
    cornerbif.status: of its last call, OK unless the run ended or stopped there, which may
    be after the window's last impact) and ``impacts`` (impacts averaged: ``window`` unless
    the run ended or stuck before)."""
    ics = np.ascontiguousarray(np.atleast_2d(np.asarray(ics, np.float64)))
    params = np.atleast_2d(np.asarray(params, np.float64))
    n = ics.shape[0]
    if params.shape[0] == 1 and n > 1:
        params = np.repeat(params, n, axis=0)
    params = np.ascontiguousarray(params)
    if params.shape[0] != n:
        raise ValueError(f"lyapunov_stream: {params.shape[0]} parameter rows for {n} starts")
    warmup = np.ascontiguousarray(np.broadcast_to(np.asarray(warmup), (n,)), np.int64)
    window = np.ascontiguousarray(np.broadcast_to(np.asarray(window), (n,)), np.int64)
    if (warmup < 0).any() or (window < 1).any():
        raise ValueError(f"lyapunov_stream: warmup {warmup.min()} must be >= 0 and window "
                         f"{window.min()} >= 1")
    settings = stream_settings(ints)
    out = {"lyapunov": np.empty((n, 2)), "lyapunov_window": np.empty(n),
           "lyapunov_status": np.empty(n, np.int8), "status": np.empty(n, np.int8),
           "impacts": np.empty(n, np.int64)}
    kernel = stream_batch_profile if P.wide_rows(params) else stream_batch
    kernel(params, settings, ics, warmup, window, *out.values())
    raise_if_stopped(settings[P.I_CONTROL])
    return out
