"""The ``flow`` model (sections 2-3): one particle, one moving obstacle, law (5).

u'' + 2 sigma u' + k^2 u = f(t), f = 0 or F cos(Omega t + phi) (eq 4), for u >= z(t),
with Newton's impact law v+ = (1 + r) z'(t) - r v- (eq 5).  Its parameters and obstacles
are declared in ``models/params.py`` (with the packed vector the kernels index), the
obstacles' jitted pieces in ``models/obstacle.py``; the kernel is ``kernels/flow.py``.
"""

from __future__ import annotations

import math

import numpy as np

from ..analysis import detect_cycles
from ..kernels.fill import full
from ..kernels.flow import obstacle_heights, run_batch, run_batch_profile
from ..model import Coord, CycleSeries, Field, Model
from ..stability import batch_stability, new_outputs
from . import params as P
from .params import OBSTACLES

# run.stop = "period": the kernel stops once the state at the corners repeats to this share of
# run.period_tol (relative), tighter than the analysis so that the orbit has converged well
# beyond what the period test reads (see kernels.flow.cycle_watch)
STOP_TOL_FACTOR = 1e-3

IMPACT_FIELDS = (
    Field("impacts/t", "t", "impact time t", "time"),
    Field("impacts/u", "u", "impact height u = z(t)", "length"),
    Field("impacts/v_in", "v_in", "velocity just before impact v-", "length/time"),
    Field("impacts/v_out", "v_out", "velocity just after impact v+ (law 5)", "length/time"),
    Field("impacts/corner_offset", "corner_offset",
          "signed offset of the impact to the nearest corner (t - t_k)", "time"),
)
# which corner of a period an impact is grouped by, when a period has several (a cam
# profile's); opt-in: the built-in obstacles have one corner per period (0) or none (-1)
CORNER_FIELDS = (
    Field("impacts/corner", "corner", "which corner of the obstacle's period the impact is "
          "grouped by (impacts/corner_offset is the offset to it): its place among the "
          "period's corners from the period's start, 0 the first; -1 none (an obstacle "
          "without corners, no impact)", axis=None, dtype="i1", fill=-1),
)
SECTION_FIELDS = (
    Field("section/u", "su", "u at the Poincare section t = nT"),
    Field("section/v", "sv", "v at the Poincare section t = nT"),
)
STABILITY_FIELDS = (
    Field("stability/multiplier_re", "mu_re", "real part of the Floquet multipliers of the "
          "run's cycle, by decreasing modulus (docs/stability.md)", axis=("multiplier", 2)),
    Field("stability/multiplier_im", "mu_im", "imaginary part of the Floquet multipliers",
          axis=("multiplier", 2)),
    Field("stability/cycle_duration", "cycle_duration", "duration of the cycle", "time",
          axis=()),
    Field("stability/status", "stability_status", "how the multipliers were found: 0 ok, "
          "1 grazing impact (none), 2 the cycle sticks (exactly 0), 3 no cycle (none); "
          "two_particle: 5 a particle sticks (none), 6 the w-z table filled (none)",
          axis=(), dtype="i1", fill=-1),
    Field("stability/lyapunov", "lyapunov", "Lyapunov exponents over the recorded window, "
          "largest first, per unit time (QR through flights and impacts, docs/stability.md)",
          "1/time", axis=("exponent", 2)),
    Field("stability/lyapunov_window", "lyapunov_window", "time over which the Lyapunov "
          "exponents are averaged (after the warm-up, whole cycles where there is one)",
          "time", axis=()),
    Field("stability/lyapunov_status", "lyapunov_status", "how the exponents were found: 0 "
          "ok, 1 grazing impact (none), 2 the window sticks (-inf), 4 too few impacts (none); "
          "two_particle: 5 a particle sticks (none), 6 the w-z table filled (none)",
          axis=(), dtype="i1", fill=-1),
)
# an attractor's identity beside its word: the impact heights and velocities over one cycle
IMPACT_CYCLE = CycleSeries(end="t", a="u", b="v_in", per="impacts", names=("u", "v_in"),
                           long_names=("impact height u", "velocity before impact v-"))
U = Coord("u", (0.0, 20.0), 0, "wall", "initial position u(0)",
          "u at the last section crossed (the state a followed sweep carries on)")
V = Coord("v", (-20.0, 20.0), 1, None, "initial velocity v(0)", "v at the last section crossed")
# the start time t0 of each run, the obstacle's phase at the start (0: a corner of the
# rectified sine); a start coordinate beside the state, not carried by follow
T0 = Coord("t", (0.0, 0.0), 2, None, "start time t0 of the run (the obstacle's phase at the "
           "start; u(0), v(0) are the state at t0)", "")


def resonance_problem(vals, key) -> str | None:
    """Undamped exact resonance (F != 0, sigma = 0, Omega = k): models.oscillator's particular
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


def obstacle_top(ctx):
    """The obstacle's highest point over a period at the scene's largest kappa and beta
    (the triangle: its peak; a profile: kappa + beta max g), or None when unknown."""
    kap = max(ctx.values_list("kappa"))
    beta = max(ctx.values_list("beta"))
    if ctx.obstacle in ("sine", "rectified_sine"):
        return kap + beta
    if ctx.obstacle == "profile":
        prof = getattr(ctx, "profile", None)
        if prof is None:
            return None
        th = np.linspace(0.0, prof.period, 4097)
        return kap + beta * float(prof.lift(th).max())
    if ctx.obstacle == "triangle":
        w = min(ctx.values_list("omega"))
        t1 = [x if x is not None else beta * w for x in ctx.values_list("theta1")]
        t2 = [x if x is not None else beta * w for x in ctx.values_list("theta2")]
        return kap + max(a * b / (a + b) for a in t1 for b in t2) * math.pi / w
    return None


class FlowModel(Model):
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
        if t0[0] < 0.0:
            problems.append(f"initial.t: {list(t0)} must not be negative (the start time t0)")
        if swept_t is not None and min(swept_t.values) < 0.0:
            problems.append(f"sweep.initial.t: {min(swept_t.values)!r} must not be negative "
                            "(the start time t0)")
        moving_start = t0[1] > 0.0 or (swept_t is not None and max(swept_t.values) > 0.0)
        if ctx.drawn and rng and moving_start and not ctx.problems and not ctx.swept("initial.u"):
            top = obstacle_top(ctx)
            if top is not None and rng[1] <= top:
                problems.append(f"initial.u: {list(rng)} does not reach above the obstacle's "
                                f"top z = {top!r} over the start times (initial.t): a start "
                                "at such a t0 would lie below it; raise the upper end")
        z0 = max(kap) if kap else None
        if z0 is not None and ctx.obstacle == "profile" and getattr(ctx, "profile", None):
            z0 += max(ctx.values_list("beta")) * float(ctx.profile.lift(0.0))
        if ctx.drawn and rng and kap and rng[1] <= z0:
            problems.append(f"initial.u: {list(rng)} lies on or below the obstacle at t = 0 "
                            f"(z(0) = kappa up to {max(kap)!r}); the upper end must exceed it")
        return problems

    def check_point(self, values: dict) -> str | None:
        return resonance_problem(lambda n: {values.get(n)}, lambda n: f"system.{n}")

    def wall_at_start(self, params):
        if params.shape[1] > P.NPARAM:          # a profile: z(0) = kappa + beta g(0)
            return obstacle_heights(np.ascontiguousarray(params),
                                    np.zeros((params.shape[0], 1)))[:, 0]
        return params[:, P.KAPPA]

    def wall_at(self, params, t0):
        return obstacle_heights(np.ascontiguousarray(params),
                                np.ascontiguousarray(t0, dtype=float))

    def pack_values(self, values: dict, scene) -> np.ndarray:
        return self._pack(values, 1, scene)[0]

    def pack_points(self, scene, index_list):
        # the swept parameters as columns, packed at once (``params.pack_many``)
        from ..config import IC_PREFIX
        idx = np.asarray(index_list, np.int64).reshape(len(index_list), -1)
        values = dict(scene.system)
        for i, a in enumerate(scene.axes):
            if not a.name.startswith(IC_PREFIX):
                values[a.name] = a.array[idx[:, i]]
        return self._pack(values, len(index_list), scene)

    def _pack(self, values, n, scene):
        stop_tol = STOP_TOL_FACTOR * scene.period_tol if scene.stop == "period" else 0.0
        return P.pack_many(values, n, scene.obstacle, scene.tol, scene.chatter, scene.escape,
                           scene.section_period, stop_tol, scene.profile)

    def int_settings(self, scene):
        ints = np.zeros(P.NINT, np.int64)
        ints[P.I_TRANSIENT] = scene.transient
        ints[P.I_RECORD] = scene.record
        ints[P.I_MAX_EVENTS] = scene.max_events
        per_pieces = 4  # at most 4 pieces per obstacle period (triangle, sine: 2)
        # the budget at the obstacle's time scale; the kernel stretches it per point to the
        # oscillator's period 2 pi / k where that is slower (oscillator.budget_pieces)
        ints[P.I_MAX_PIECES] = scene.max_periods * per_pieces
        return ints

    def kernel(self):
        return run_batch

    def word_seed(self, values, scene, param, word):
        from ..continuation import seed_from_word
        return seed_from_word(values, scene.obstacle, param, word, scene.tol)

    def orbit_seed(self, values, scene, param, word, run):
        from ..continuation import seed_from_run
        return seed_from_run(values, scene.obstacle, param, run["t"], run["v_out"],
                             run["corner_offset"], run["ipc"], scene.tol)

    def run_items(self, params, ics, ints, scene):
        # NaN marks "no impact" in what is stored and in t, where the analysis reads the end
        # of the recorded window; what is neither is left unfilled (a summary-only chart then
        # touches only the few rows' entries its early-stopped runs write)
        fill = {"t"} | {f.source for f in self.fields(scene.keep)}
        cornered = np.isin(params[:, P.OBSTACLE],
                           [o.code for o in OBSTACLES.values() if o.corners])
        # a profile has corners only where its slope jumps (models/profile.py)
        if params.shape[1] > P.NPARAM:
            cornered &= params[:, P.PROFILE_CORNERS] != 0
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
            out.update(_stability(params, out, ipc))
        # the kernel's corner ids are read here only (unset where a run has no impact)
        ids = out.pop("corner_id")
        if "corners" in scene.keep:
            out["corner"] = corner_places(params, ids, out["t"], cornered)
        if not cornered.all():
            out["corner_offset"][~cornered] = np.nan
        return out, st, final, period, ipc, sym


def corner_places(params, ids, t, cornered):
    """``impacts/corner``: the place of each impact's corner among its period's corners.

    ``ids`` are the kernel's corner ids (``obstacle.corner_of``): for a profile the piece
    whose start is the corner, counted on from the first piece (m = id mod its pieces per
    period, the place the number of corners among pieces 0 .. m less one); the built-in
    obstacles with corners have one per period (0); -1 where a run has no corners
    (``cornered`` false) or no impact (t NaN)."""
    has = np.isfinite(t) & cornered[:, None]
    place = np.zeros(t.shape, np.int64)
    if params.shape[1] > P.NPARAM:
        n = params[:, P.PROFILE_NP].astype(np.int64)
        flags = params[:, P.PROFILE0 + P.PC_CORNER::P.PIECE_STRIDE] != 0.0
        ordinal = np.cumsum(flags, axis=1) - 1
        m = np.where(has, ids, 0) % n[:, None]
        place = np.take_along_axis(ordinal, m, axis=1)
    return np.where(has, place, -1).astype(np.int8)


def _stability(params, out, ipc):
    """The Floquet multipliers of each run's cycle and its Lyapunov spectrum over the
    recorded window (cornerbif.stability)."""
    res = new_outputs(params.shape[0])
    batch_stability(params, out["t"], out["u"], out["v_in"], out["v_out"],
                      out["corner_offset"], ipc, *res.values())
    return res


def _run_flow(params, ics, ints, scene, fill, cornered):
    """The flow kernel and the cycle analysis on n items; outputs not in ``fill`` start
    unfilled.  Returns (out, status, final, period, impacts per cycle, symbols, first
    recorded impact)."""
    n = params.shape[0]
    rec = scene.record
    out = {k: full((n, rec), np.nan) if k in fill else np.empty((n, rec))
           for k in ("t", "u", "v_in", "v_out", "corner_offset", "su", "sv")}
    corner = np.empty((n, rec), np.int64)
    st = np.zeros(n, np.int8)
    final = np.zeros((n, 2))
    rec0 = np.zeros(n, np.int64)
    kernel = run_batch_profile if params.shape[1] > P.NPARAM else run_batch
    kernel(np.ascontiguousarray(params, dtype=np.float64), ints, ics, out["t"], out["u"], out["v_in"],
           out["v_out"], out["corner_offset"], corner, out["su"], out["sv"], st, final, rec0)
    period = np.zeros(n, np.int64)
    ipc = np.zeros(n, np.int64)
    sym = np.zeros((n, rec), np.uint8)
    out["corner_id"] = corner
    detect_cycles(out["t"], out["v_in"], out["corner_offset"], corner, cornered,
                  scene.period_tol, period, ipc, sym)
    return out, st, final, period, ipc, sym, rec0


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
    system_extra={"obstacle": "rectified_sine", "section_period": None, "profile": None},
    obstacles=OBSTACLES,
    events_per_impact=10,
    early_stop=True,
    timeseries=True,
    normal_form_role="flow",
    # per item and recorded event: 7 float64 outputs, the corner index, the word (the arrays
    # run_items allocates)
    bytes_per_event=7 * 8 + 8 + 1,
    # benchmarks/run.py, Fig. 4(c), one core (benchmarks/results/results.json)
    events_per_second=6.0e6,
)
