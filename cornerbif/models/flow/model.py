"""The ``flow`` model (sections 2-3): one particle, one moving obstacle, law (5).

u'' + 2 sigma u' + k^2 u = f(t), f = 0 or F cos(Omega t + phi) (eq 4), for u >= z(t),
with Newton's impact law v+ = (1 + r) z'(t) - r v- (eq 5).  Its parameters and obstacles
are declared in ``models/flow/params.py`` (with the packed vector the kernels index), the
obstacles' jitted pieces in ``obstacles/dispatch.py``; the kernel is ``models/flow/kernel.py``.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np

from ... import obstacles
from ...model import IC_PREFIX, Coord, Field, Model, RunResult, Warmup, start_time_problems
from ...observables import (
    ANALYSIS_KERNELS,
    ANALYSIS_SECONDS,
    IMPACT_CYCLE,
    IMPACT_FIELDS,
    RUN_ANALYSIS_KERNELS,
    SECTION_FIELDS,
    STABILITY_FIELDS,
    U,
    V,
)
from . import params as P
from .normal_form import SIDE
from .params import OBSTACLES

KIND_OF_CODE = {float(o.code): o for o in OBSTACLES.values()}   # a packed row's OBSTACLE slot

# run.stop = "period": the kernel stops once the state at the corners repeats to this share of
# run.period_tol (relative), tighter than the analysis so that the orbit has converged well
# beyond what the period test reads (see models.flow.kernel.cycle_watch)
STOP_TOL_FACTOR = 1e-3


# which corner of a period an impact is grouped by, when a period has several (a cam
# profile's); opt-in: the built-in obstacles have one corner per period (0) or none (-1)
CORNER_FIELDS = (
    Field("impacts/corner", "corner", "which corner of the obstacle's period the impact is "
          "grouped by (impacts/corner_offset is the offset to it): its place among the "
          "period's corners from the period's start, 0 the first; -1 none (an obstacle "
          "without corners, no impact)", axis=None, dtype="i1", fill=-1),
)


# the start time t0 of each run, the obstacle's phase at the start (0: a corner of the
# rectified sine); a start coordinate beside the state, not carried by follow
T0 = Coord("t", (0.0, 0.0), 2, None, "start time t0 of the run (the obstacle's phase at the "
           "start; u(0), v(0) are the state at t0)", "")


def resonance_problem(vals, key) -> str | None:
    """Undamped exact resonance (F != 0, sigma = 0, Omega = k): numerics.oscillator's particular
    solution divides by k^2 - Omega^2; and a constant force (Omega = 0) without spring (k = 0),
    where it divides by zero too.  ``vals(name)`` gives the set of values a parameter
    takes; ``key(name)`` its dotted key."""
    res = vals("Omega") & vals("k")
    forced = any(x not in (0, 0.0, None) for x in vals("F"))
    if forced and 0.0 in vals("Omega") and 0.0 in vals("k"):
        return (f"{key('Omega')}: 0 (a constant force) with {key('k')} = 0: the flight of a "
                "particle without spring under a constant force is not modelled; give k > 0 "
                "(the follower's spring)")
    if forced and 0.0 in vals("sigma") and res:
        return (f"{key('Omega')}: {sorted(res)[0]!r} equals {key('k')} with "
                f"sigma = 0 and F != 0 (undamped exact resonance: no bounded "
                "closed-form flight); change Omega or k, or add damping sigma > 0")
    return None


# --- the time model of a run (``estimate.estimate_time``) --------------------------------------
# Seconds of one core per impact (with its share of the cycle analysis) and per obstacle piece
# crossed, by the kernel's path: "free" (sigma = 0, F = 0, k > 0: flights rotate in closed form
# and a piece without impact is crossed by the Sturm test alone), "searched" (damped or forced:
# every piece needs a certified search) and "own_kernel" (a cam's own kernel).  Measured by
# ``python benchmarks/estimate_time.py --calibrate``, but a cam's impact: its follower chatters
# and sticks, and some runs spend their event budget on a few impacts and many releases, so
# it is priced per impact asked for (transient + record) from the CPU time of the whole
# shipped sweep, ``python benchmarks/estimate_time.py --only cam_cycloidal``.
COST_IMPACT = {"free": 2.0e-7, "searched": 4.0e-7, "own_kernel": 1.5e-6}
COST_PIECE = {"free": 1.25e-8, "searched": 5.1e-8, "own_kernel": 1.13e-7}
# a run's flights last about half the oscillator's period (pi / k between impacts: the span
# per impact that ``benchmarks/estimate_time.py --calibrate`` prints)
FLIGHT_SHARE = 0.5
# where the estimate rests on the guessed flight time (the pieces' cost at least half of it),
# or runs escape after a number of impacts found from the mean impact only, it may be off by
# UNCERTAIN_FACTOR either way; elsewhere by CLOSE_FACTOR (benchmarks/estimate_time.py)
UNCERTAIN_FACTOR = 3.0
CLOSE_FACTOR = 1.5


def escape_impacts(speed, r, k, escape):
    """About how many impacts a run takes to escape (``run.escape``) off an obstacle moving at
    up to ``speed``: law (5) adds (1 + r) z' to the velocity at each impact (z' averages 2/pi
    of its peak) and keeps r of it, so v_n tends to V = (1 + r) (2/pi) speed / (1 - r); the
    run escapes once v / k exceeds ``escape``.  inf when it never does (V / k <= escape)."""
    if not (k > 0.0 and speed > 0.0):
        return math.inf
    kick = (1.0 + r) * (2.0 / math.pi) * speed
    need = escape * k
    if r >= 1.0:
        return math.ceil(need / kick) + 1
    limit = kick / (1.0 - r)
    if limit <= need or r <= 0.0:
        return math.inf if limit <= need else 2
    return math.ceil(math.log1p(-need / limit) / math.log(r)) + 1


# --- what a first run compiles (``engine.announce_compiles``) ------------------------------
# cold compile seconds, measured by ``python benchmarks/compile_time.py`` (announced rounded,
# as the time they took there: ``engine.compile_words``)
# an impact of the streamed Lyapunov exponents against one of the sweep's kernel: the kernel
# alone 4.36 and 5.32 M impacts/s, the stream 2.68 and 3.12 (one thread, Fig. 1(a) at
# omega = 2.84 and the rectified sine at 1.8: tests/models/test_lyapunov_stream.py's cases)
STREAM_COST = 1.65
COMPILE_SECONDS = {"flow": 5.8, "own_kernel": 6.9, "t0": 0.9, "stability": 2.8,
                   "continuation": 2.3, "stream": 5.9, "stream_own": 6.9}


# what ``cornerbif continue`` compiles for the flow model beyond the sweep's kernels (the
# functions the continuation calls from Python, each cached on its own)
CONTINUATION_KERNELS = ("numerics.saltation.flight_matrix", "numerics.saltation.impact_saltation",
                        "stability.multipliers", "numerics.oscillator.acceleration",
                        "obstacles.dispatch.piece_at", "models.flow.kernel.flight_gaps")


def kind_tables(scene) -> dict:
    """The obstacle kind's own [system] tables as the scene records them (a cam's
    ``profile``: plain data, which an orbit problem keeps to rebuild its rows)."""
    tables = OBSTACLES[scene.extra["obstacle"]].tables
    if not tables:
        return {}
    system = tomllib.loads(scene.text).get("system", {})
    return {key: system[key] for key in tables if key in system}


class FlowModel(Model):
    # the slot of int_settings that carries the address of a sweep's control (the stop flag
    # and runs finished, ``_jit.Control``; ``engine.with_control``)
    control_slot = P.I_CONTROL

    def check(self, ctx):
        problems = []
        if not ctx.problems:
            p = resonance_problem(ctx.values, ctx.key)
            if p:
                problems.append(p)
        kap = ctx.values_list("kappa")
        rng = ctx.ranges.get("u")
        t0 = ctx.ranges.get("t", (0.0, 0.0))
        swept_t = ctx.swept("initial.t")
        problems += start_time_problems(ctx)
        moving_start = t0[1] > 0.0 or (swept_t is not None and max(swept_t.values) > 0.0)
        if ctx.drawn and rng and moving_start and not ctx.problems and not ctx.swept("initial.u"):
            top = OBSTACLES[ctx.extra["obstacle"]].top(ctx)
            if top is not None and rng[1] <= top:
                problems.append(f"initial.u: {list(rng)} does not reach above the obstacle's "
                                f"top z = {top!r} over the start times (initial.t): a start "
                                "at such a t0 would lie below it; raise the upper end")
        z0, what = OBSTACLES[ctx.extra["obstacle"]].height_at_zero(ctx, max(kap)) if kap else (None, "")
        if ctx.drawn and rng and kap and rng[1] <= z0:
            problems.append(f"initial.u: {list(rng)} lies on or below the obstacle at t = 0 "
                            f"(z(0) = {what} up to {z0!r}); the upper end must exceed it")
        return problems

    def check_point(self, values: dict) -> str | None:
        return resonance_problem(lambda n: {values.get(n)}, lambda n: f"system.{n}")

    def wall_at_start(self, params):
        # z(0) = kappa + beta g(0): kappa but where the kind says (a cam's g(0), in numpy, bit
        # for bit the kernels' z_state), so that no heights kernel compiles before the kernel
        z0 = KIND_OF_CODE[params[0, P.OBSTACLE]].start_heights(params) if len(params) else None
        return params[:, P.KAPPA] if z0 is None else z0

    def wall_at(self, params, t0):
        # start-up: the kernels load numba here, at first use (validation loads none)
        from .kernel import obstacle_heights
        return obstacle_heights(np.ascontiguousarray(params),
                                np.ascontiguousarray(t0, dtype=float))

    def pack_values(self, values: dict, scene) -> np.ndarray:
        return self._pack(values, 1, scene)[0]

    def pack_points(self, scene, index_list):
        # the swept parameters as columns, packed at once (``params.pack_many``)
        idx = np.asarray(index_list, np.int64).reshape(len(index_list), -1)
        values = dict(scene.system)
        for i, a in enumerate(scene.axes):
            if not a.name.startswith(IC_PREFIX):
                values[a.name] = a.array[idx[:, i]]
        return self._pack(values, len(index_list), scene)

    def _pack(self, values, n, scene):
        stop_tol = STOP_TOL_FACTOR * scene.period_tol if scene.stop == "period" else 0.0
        return P.pack_many(values, n, scene.extra["obstacle"], scene.tol, scene.chatter, scene.escape,
                           scene.extra["section_period"], stop_tol, scene.obstacle_table)

    def int_settings(self, scene):
        ints = np.zeros(P.NINT, np.int64)
        ints[P.I_TRANSIENT] = scene.transient
        ints[P.I_RECORD] = scene.record
        ints[P.I_MAX_EVENTS] = scene.max_events
        # the budget at the obstacle's time scale; the kernel stretches it per point to the
        # oscillator's period 2 pi / k where that is slower (oscillator.budget_pieces)
        ints[P.I_MAX_PIECES] = scene.max_periods * P.PIECES_PER_PERIOD
        return ints

    def kernel(self):
        # start-up: the kernels load numba here, at first use (validation loads none)
        from .kernel import run_batch
        return run_batch

    def compiles(self, scene, what):
        """What a first run of ``scene`` compiles, for ``what`` ("sweep", "stability",
        "continuation", "simulate"; ``engine.cold_compiles``): (name, seconds, jitted functions) per
        kernel, the seconds from COMPILE_SECONDS."""
        # start-up: the kernels load numba here, at first use (validation loads none)
        from ..._jit import dispatchers
        from .kernel import fill_obstacle_heights, run_batch, run_batch_profile  # start-up: loads numba
        from .tangent import batch_stability  # start-up: loads numba
        out = []
        files = "sweep" in what or "continuation" in what     # "simulate": no file
        if files or "simulate" in what:
            out.append(("the cycle analysis", ANALYSIS_SECONDS,
                        dispatchers(*(ANALYSIS_KERNELS if files else RUN_ANALYSIS_KERNELS))))
            if OBSTACLES[scene.extra["obstacle"]].own_kernel:
                out.append(("the flow kernel for a cam profile", COMPILE_SECONDS["own_kernel"],
                            [run_batch_profile]))
            else:
                out.append(("the flow kernel", COMPILE_SECONDS["flow"], [run_batch]))
            if scene.initial.get("t", (0.0, 0.0))[1] > 0.0 or "initial.t" in [
                    a.name for a in scene.axes]:
                out.append(("the obstacle's heights at the start times",
                            COMPILE_SECONDS["t0"], [fill_obstacle_heights]))
        # a sweep's file tests its runs without a cycle for chaos when it finishes
        # (cornerbif.chaos: reruns with the stability pass), whatever it keeps
        if "stability" in what or "sweep" in what or ("simulate" in what
                                                      and "stability" in scene.keep):
            out.append(("the flow stability kernel", COMPILE_SECONDS["stability"],
                        [batch_stability]))
        if scene.lyapunov_impacts and "stability" in scene.keep and (files or "simulate" in what):
            from .stream import stream_batch, stream_batch_profile  # start-up: loads numba
            own = OBSTACLES[scene.extra["obstacle"]].own_kernel
            out.append(("the streamed Lyapunov kernel" + (" for a cam profile" if own else ""),
                        COMPILE_SECONDS["stream_own" if own else "stream"],
                        [stream_batch_profile if own else stream_batch]))
        if "continuation" in what:
            out.append(("the flow continuation's functions", COMPILE_SECONDS["continuation"],
                        dispatchers(*CONTINUATION_KERNELS)))
        return out

    def run_seconds(self, scene, values):
        """The time model of one run at the parameter ``values`` of a grid point
        (``estimate.estimate_time``): (seconds of one core, low, high, reasons the estimate is
        uncertain).

        A run pays per impact and per obstacle piece it crosses (``COST_IMPACT``,
        ``COST_PIECE``, by kernel path).  Its impacts are transient + record, fewer when
        it escapes first (``escape_impacts``); its flights last FLIGHT_SHARE of the
        oscillator's period 2 pi / k (2 pi / Omega for k = 0 with forcing; one piece for a
        free particle), so it crosses about that over the piece's length pieces per
        impact, at most its time budget (``run.max_periods``, docs/guarantees.md
        "Budgets").  With ``run.stop = "period"`` the transient may end early: the low end
        is the record alone.  ``run.lyapunov_impacts`` adds the stream's transient and
        impacts, at STREAM_COST each."""
        w, k, r = float(values["omega"]), float(values["k"]), float(values["r"])
        sigma, F = float(values["sigma"]), float(values["F"])
        Om = float(values["Omega"])
        kind = OBSTACLES[scene.extra["obstacle"]]
        piece = kind.period(w, scene.obstacle_table) / kind.pieces_per_period(scene.obstacle_table)
        if kind.own_kernel:
            path = "own_kernel"
        else:
            path = "free" if sigma == 0.0 and F == 0.0 and k > 0.0 else "searched"
        scale = (2 * math.pi / k if k > 0 else 2 * math.pi / Om if F != 0 and Om > 0 else 0.0)
        reasons = []
        flight = FLIGHT_SHARE * scale
        if flight <= 0.0:
            flight = piece
            reasons.append("a free particle (k = 0, F = 0) has no flight time of its own")
        n = scene.transient + scene.record
        esc = escape_impacts(kind.speed(values, scene.obstacle_table), r, k, scene.escape)
        if esc < n:
            n = esc
            reasons.append(f"runs escape (run.escape = {scene.escape:g}) after about {esc} "
                           "impacts off the fast obstacle")
        budget = scene.max_periods * max(4.0 * piece, scale) / piece
        pieces = min(n * max(1.0, flight / piece), budget)
        cost_pieces = pieces * COST_PIECE[path]
        seconds = n * COST_IMPACT[path] + cost_pieces
        if cost_pieces >= 0.5 * seconds:
            reasons.append(f"runs cross about {max(1.0, flight / piece):.2g} obstacle pieces "
                           "between impacts")
        if scene.lyapunov_impacts:
            # the stream runs the transient again, then its impacts, with the tangent steps
            # (``_streamed_lyapunov``): STREAM_COST times a recorded impact's cost
            more = min(scene.transient + scene.lyapunov_impacts, esc)
            seconds *= 1.0 + STREAM_COST * more / max(n, 1)
        f = UNCERTAIN_FACTOR if reasons else CLOSE_FACTOR
        low, high = seconds / f, seconds * f
        if scene.stop == "period" and n > scene.record:
            low *= scene.record / n
            reasons.append("runs stop once their cycle is found (run.stop = \"period\")")
        return seconds, low, high, reasons

    def time_series(self, scene, values, t, u, v_out, t_start, t_stop):
        from . import timeseries as TR  # start-up: loads numba (jitted flights), imported when drawn
        p, d = TR.pack(values, scene.extra["obstacle"], scene.extra["section_period"], scene.obstacle_table)
        s, us, zs = TR.rebuild(p, d, t, u, v_out, t_start, t_stop)
        return {"t": s, "u": us, "z": zs, "meet": TR.meet_error(p, d, t, u, v_out), "p": p,
                "d": d}

    def word_seed(self, values, scene, param, word, simulate):
        from .orbit import seed_from_word  # start-up: loads numba
        return seed_from_word(values, scene.extra["obstacle"], param, word, simulate, scene.tol,
                              tables=kind_tables(scene))

    def orbit_from_doc(self, doc):
        from .orbit import FlowOrbit  # start-up: loads numba
        return FlowOrbit.from_doc(doc)

    def orbit_seed(self, values, scene, param, word, run):
        from .orbit import seed_from_run  # start-up: loads numba
        return seed_from_run(values, scene.extra["obstacle"], param, run["t"], run["v_out"],
                             run["corner_offset"], run["ipc"], scene.tol, kind_tables(scene))

    def run_items(self, params, ics, ints, scene):
        # NaN marks "no impact" in what is stored and in t, where the analysis reads the end
        # of the recorded window; what is neither is left unfilled (a summary-only chart then
        # touches only the few rows' entries its early-stopped runs write)
        fill = {"t"} | {f.source for f in self.fields(scene.keep)}
        kind = OBSTACLES[scene.extra["obstacle"]]
        cornered = np.full(params.shape[0], kind.has_corners(scene.obstacle_table))
        res = _run_flow(params, ics, ints, scene, fill, cornered)
        out, st, final, period, ipc, sym, rec0 = res
        # early stop: a run stopped on a cycle the analysis does not confirm (e.g. a
        # near-grazing impact magnifies the last 1e-9 of the transient beyond period_tol)
        # runs again without it
        redo = np.flatnonzero((rec0 < ints[P.I_TRANSIENT]) & (period == 0))
        if redo.size:
            prm = np.ascontiguousarray(params[redo])
            prm[:, P.STOP_TOL] = 0.0
            again = _run_flow(prm, np.ascontiguousarray(ics[redo]), ints, scene, set(out),
                              cornered[redo])
            for k in out:
                out[k][redo] = again[0][k]
            for whole, part in zip(res[1:], again[1:]):
                whole[redo] = part
        if "stability" in scene.keep:
            out.update(_stability(params, out, ipc, ints[P.I_CONTROL]))
            if scene.lyapunov_impacts:
                out.update(_streamed_lyapunov(params, ics, ints, ipc, scene.lyapunov_impacts))
        # the kernel's corner ids are read here only (unset where a run has no impact)
        ids = out.pop("corner_id")
        if "corners" in scene.keep:
            has = np.isfinite(out["t"]) & cornered[:, None]
            out["corner"] = np.where(has, kind.corner_places(params, ids, has), -1).astype(np.int8)
        if not cornered.all():
            out["corner_offset"][~cornered] = np.nan
        return RunResult(out, st, final, period, ipc, sym)


def _stability(params, out, ipc, control=0):
    """The Floquet multipliers of each run's cycle and its Lyapunov spectrum over the
    recorded window (cornerbif.stability), under a sweep's ``control`` (its address; 0:
    none): told to stop, ``KernelStopped``."""
    # start-up: the kernels load numba here, at first use (validation loads none)
    from ..._jit import raise_if_stopped
    from ...stability import new_outputs  # start-up: loads numba
    res = new_outputs(params.shape[0])
    batch_stability(params, out["t"], out["u"], out["v_in"], out["v_out"],
                    out["corner_offset"], ipc, *res.values(), control)
    raise_if_stopped(control)
    return res


def _streamed_lyapunov(params, ics, ints, ipc, impacts):
    """``run.lyapunov_impacts``: each run's Lyapunov spectrum over ``impacts`` impacts after
    its transient, streamed by the kernel and none stored (``stream.lyapunov_stream``,
    docs/stability.md): the first WARMUP_SHARE of them align the basis, the rest, trimmed
    to whole cycles where the run has one (``ipc``), are averaged, as over a record.  The
    sweep's control stops it (``KernelStopped``), but it does not count runs: the block's
    progress is counted by the kernel before."""
    from ...stability import WARMUP_SHARE, lyapunov_window  # start-up: loads numba
    from .stream import lyapunov_stream  # start-up: loads numba
    cycles, which = np.unique(ipc, return_inverse=True)
    warmup = np.array([max(lyapunov_window(impacts, int(c), WARMUP_SHARE), 0) for c in cycles],
                      np.int64)[which.ravel()]
    res = lyapunov_stream(params, ics, ints, warmup, impacts - warmup)   # one call: all threads
    return {k: res[k] for k in ("lyapunov", "lyapunov_window", "lyapunov_status")}


def batch_stability(*args):
    """``models.flow.tangent.batch_stability``, imported at its first call (numba-free validation):
    the stability pass of a block (``_stability``), a name of this module that a test may
    replace."""
    from .tangent import batch_stability as kernel  # start-up: loads numba
    return kernel(*args)


def _run_flow(params, ics, ints, scene, fill, cornered):
    """The flow kernel and the cycle analysis on n items; outputs not in ``fill`` start
    unfilled.  Returns (out, status, final, period, impacts per cycle, symbols, first
    recorded impact)."""
    # start-up: the kernels load numba here, at first use (validation loads none)
    from ..._jit import raise_if_stopped
    from ...analysis import detect_cycles  # start-up: loads numba
    from ...numerics.fill import full  # start-up: loads numba
    from .kernel import run_batch, run_batch_profile  # start-up: loads numba
    n = params.shape[0]
    rec = scene.record
    out = {k: full((n, rec), np.nan) if k in fill else np.empty((n, rec))
           for k in ("t", "u", "v_in", "v_out", "corner_offset", "su", "sv")}
    corner = np.empty((n, rec), np.int64)
    st = np.zeros(n, np.int8)
    final = np.zeros((n, 2))
    rec0 = np.zeros(n, np.int64)
    kernel = run_batch_profile if P.wide_rows(params) else run_batch
    kernel(np.ascontiguousarray(params, dtype=np.float64), ints, ics, out["t"], out["u"], out["v_in"],
           out["v_out"], out["corner_offset"], corner, out["su"], out["sv"], st, final, rec0)
    raise_if_stopped(ints[P.I_CONTROL])     # stopped: nothing half-computed goes on
    period = np.zeros(n, np.int64)
    ipc = np.zeros(n, np.int64)
    sym = np.zeros((n, rec), np.uint8)
    out["corner_id"] = corner
    detect_cycles(out["t"], out["v_in"], out["corner_offset"], corner, cornered,
                  scene.period_tol, period, ipc, sym)
    return out, st, final, period, ipc, sym, rec0


# ``cornerbif warm``: what a first sweep (with stability and start times), a first
# continuation and a first cam sweep compile, each from a few short runs
_WARM_SYSTEM = """
[system]
obstacle = "rectified_sine"
omega = 1.999
kappa = -0.02
beta = 1.0
r = 0.8
[initial]
count = 2
seed = 1
u = [0.0, 20.0]
v = [-0.02, 0.02]
"""
WARMUPS = (
    Warmup("flow", "the flow kernel, its stability and start times", "sweep",
           '[scene]\nname = "warm_flow"\nmodel = "flow"\n' + _WARM_SYSTEM
           + 't = [0.0, 1.0]\n[sweep]\nkappa = { start = -0.02, stop = -0.019, num = 2 }\n'
           '[run]\ntransient = 10\nrecord = 8\n'
           '[output]\nkeep = ["impacts", "section", "stability"]\n'),
    Warmup("flow", "the flow continuation", "continue",
           '[scene]\nname = "warm_flow_continuation"\nmodel = "flow"\n' + _WARM_SYSTEM
           + '[run]\ntransient = 1500\nrecord = 120\n'
           '[continue]\nparameter = "kappa"\nrange = [-0.02, -0.0199]\nstart = -0.02\n'
           'seed = "b"\n'),
    Warmup("flow: cam profile", "the flow kernel for a cam profile", "sweep", """
[scene]
name = "warm_cam"
model = "flow"
[system]
obstacle = "profile"
omega = 1.0
kappa = 0.0
beta = 1.0
r = 0.5
k = 1.0
F = -2.0
Omega = 0.0
[system.profile]
period = 6.283185307179586
pieces = [{ law = "dwell", span = 1.5707963267948966 },
          { law = "cycloidal", span = 1.5707963267948966, rise = 1.0 },
          { law = "dwell", span = 1.5707963267948966 },
          { law = "cycloidal", span = 1.5707963267948966, rise = -1.0 }]
[sweep]
omega = { start = 0.5, stop = 1.0, num = 2 }
[initial]
count = 1
u = [0.0, 3.0]
v = [-1.0, 1.0]
t = [0.0, 1.0]
[run]
transient = 10
record = 8
"""),
)


MODEL = FlowModel(
    name="flow",
    doc="one particle and a moving obstacle with corners (sections 2-3, eqs 4-9)",
    params=P.PARAMS,
    state=(U, V),
    start_time=T0,
    observables={"impacts": IMPACT_FIELDS, "corners": CORNER_FIELDS,
                 "section": SECTION_FIELDS, "stability": STABILITY_FIELDS},
    opt_in=("stability", "corners"),
    continuation=True,
    seed_observable="impacts",
    cycle=IMPACT_CYCLE,
    system_extra={"obstacle": obstacles.DEFAULT, "section_period": None}
    | {t: None for o in OBSTACLES.values() for t in o.tables},
    obstacles=OBSTACLES,
    drawn_obstacle=obstacles.DEFAULT,
    events_per_impact=P.EVENTS_PER_IMPACT,
    early_stop=True,
    streams_lyapunov=True,
    timeseries=True,
    normal_form=SIDE,
    # per item and recorded event: 7 float64 outputs, the corner index, the word (the arrays
    # run_items allocates)
    bytes_per_event=7 * 8 + 8 + 1,
    # benchmarks/run.py, Fig. 4(c), one core (benchmarks/results/results.json)
    events_per_second=6.0e6,
    warmups=WARMUPS,
)
