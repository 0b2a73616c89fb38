"""The ``two_particle`` model (section 6): wall w, heavy particle z, light particle u.

w = kappa + beta sin(omega0 t) (eq 72); z and u harmonic in flight with omega1, omega2
(eq 73), optionally damped and forced as the flow's oscillator (eq 4); w-z impacts by
law (5) with r1, z-u impacts by the mass-ratio law (74) with r2 and mu = M/m.  The
parameters' declarations and the packed layout are ``models/two_particle/params.py``,
the impact law ``models/two_particle/packed.py``; the kernel is ``models/two_particle/kernel.py``.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from ...model import Coord, Field, Model, RunResult, Warmup
from ...observables import (
    ANALYSIS_KERNELS,
    ANALYSIS_SECONDS,
    IMPACT_CYCLE,
    IMPACT_FIELDS,
    RUN_ANALYSIS_KERNELS,
    SECTION_FIELDS,
    U,
    V,
    stability_fields,
)
from . import params as TP

# The kernels (models/two_particle/kernel.py, the cycle analysis, the stability pass) are imported
# by the methods that run them: importing this module, as checking a scene does, loads no numba.

# the parameters that decide an undamped resonance (models.two_particle.packed.resonance_problems)
RESONANCE_PARAMS = ("F1", "F2", "sigma1", "sigma2", "Omega1", "Omega2", "omega1", "omega2", "mu")
MAX_RESONANCE_COMBINATIONS = 200_000

Z = Coord("z", (0.0, 2.0), 2, "wall", "initial z(0)", "z at the last section")
Y = Coord("y", (-2.0, 2.0), 3, None, "initial y(0) = z'(0)", "y at the last section")
U_ABOVE_Z = Coord("u", U.default, U.draw, "z", U.initial_doc, U.final_doc)

SECTION_ZY = (
    Field("section/z", "sz", "z at the Poincare section t = n 2 pi/omega0"),
    Field("section/y", "sy", "y at the Poincare section"),
)
WALL_IMPACT_FIELDS = (
    Field("wall_impacts/t", "wz_t", "wall-particle impact time"),
    Field("wall_impacts/z", "wz_z", "impact height z = w"),
    Field("wall_impacts/y_in", "wz_y_in", "velocity of z before the impact"),
    Field("wall_impacts/y_out", "wz_y_out", "velocity of z after the impact (law 5, r1)"),
)

# the flow's stability datasets with four multipliers and exponents (x = (z, y, u, v)), the
# cycle and the window counted in z-u impacts
STABILITY = stability_fields(4)


# the time model of a run (``estimate.estimate_time``): seconds of one core per z-u impact (with
# the w-z impacts between and the cycle analysis) and per section period crossed, measured by
# ``python benchmarks/estimate_time.py --calibrate``; an estimate resting on the sections' cost
# may be off by UNCERTAIN_FACTOR either way
COST_IMPACT = 8.8e-7
COST_SECTION = 8.1e-8
UNCERTAIN_FACTOR = 3.0
CLOSE_FACTOR = 1.5       # otherwise (benchmarks/estimate_time.py)


# cold compile seconds, measured by ``python benchmarks/compile_time.py`` (announced rounded,
# as the time they took there: ``engine.compile_words``)
COMPILE_SECONDS = {"two_particle": 5.8, "stability": 5.2, "continuation": 4.0}
# what ``cornerbif continue`` compiles for this model beyond the sweep's kernels
CONTINUATION_KERNELS = ("models.two_particle.tangent.two_particle_steps", "numerics.saltation.flight_matrix",
                        "numerics.saltation.impact_saltation", "models.two_particle.tangent.zu_saltation",
                        "numerics.oscillator.acceleration", "numerics.oscillator.forcing")


class TwoParticleModel(Model):
    # the slot of int_settings that carries the address of a sweep's control (the stop flag
    # and runs finished, ``_jit.Control``; ``engine.with_control``)
    control_slot = TP.I_CONTROL

    def check(self, ctx):
        problems = []
        rz, ru = ctx.ranges.get("z"), ctx.ranges.get("u")
        kap = ctx.values_list("kappa")
        if ctx.drawn and rz and ru:
            if rz[1] <= max(kap):
                problems.append(f"initial.z: {list(rz)} lies on or below the wall at t = 0 "
                                f"(w(0) = kappa up to {max(kap)!r}); the upper end must exceed it")
            if ru[1] <= rz[1]:
                problems.append(f"initial.u: {list(ru)} must reach above initial.z "
                                f"{list(rz)} (u >= z)")
        if not ctx.problems and not problems:
            # undamped exact resonance of a particle or of the stuck pair (models.two_particle.packed
            # .pack refuses it per point): checked over every combination of the values of
            # the parameters it involves, so that a sweep is refused before any kernel runs
            swept = [a for a in ctx.axes if a.name in RESONANCE_PARAMS]
            n_comb = math.prod(len(set(a.values)) for a in swept) if swept else 1
            if n_comb <= MAX_RESONANCE_COMBINATIONS:
                for combo in itertools.product(*[sorted(set(a.values)) for a in swept]):
                    vals = dict(ctx.system) | {a.name: v for a, v in zip(swept, combo)}
                    p = self.check_point(vals)
                    if p:
                        where = ", ".join(f"sweep.{a.name} = {v!r}" for a, v in zip(swept, combo))
                        problems.append(f"system/sweep: {p}" + (f" (at {where})" if where else ""))
                        break
        return problems

    def check_point(self, values: dict) -> str | None:
        """Undamped exact resonance at one point (``models.two_particle.packed.resonance_problem``)."""
        row = np.zeros(TP.NPARAM)
        for k, p in self.params.items():
            row[TP.INDEX[k]] = values.get(k, p.default)
        problem = TP.resonance_problem(row)
        return f"two_particle: {problem}" if problem else None

    def wall_at_start(self, params):
        return params[:, TP.KAPPA]             # the wall at t = 0: w(0) = kappa

    def pack_values(self, values: dict, scene) -> np.ndarray:
        return TP.pack(values, scene.tol, scene.chatter, scene.escape, scene.extra["section_period"])

    def int_settings(self, scene):
        ints = np.zeros(TP.NINT, np.int64)
        ints[TP.I_TRANSIENT] = scene.transient
        ints[TP.I_RECORD] = scene.record
        ints[TP.I_MAX_EVENTS] = scene.max_events
        ints[TP.I_MAX_PERIODS] = scene.max_periods
        return ints

    def kernel(self):
        # start-up: the kernels load numba here, at first use (validation loads none)
        from . import kernel as K
        return K.run_batch

    def compiles(self, scene, what):
        """What a first run of ``scene`` compiles (as ``FlowModel.compiles``)."""
        # start-up: the kernels load numba here, at first use (validation loads none)
        from ..._jit import dispatchers
        from . import kernel as K  # start-up: loads numba
        from .tangent import batch_two_particle_stability  # start-up: loads numba
        out = []
        files = "sweep" in what or "continuation" in what     # "simulate": no file
        if files or "simulate" in what:
            out.append(("the cycle analysis", ANALYSIS_SECONDS,
                        dispatchers(*(ANALYSIS_KERNELS if files else RUN_ANALYSIS_KERNELS))))
            out.append(("the two-particle kernel", COMPILE_SECONDS["two_particle"],
                        [K.run_batch]))
        # a sweep's file tests its runs without a cycle for chaos when it finishes
        # (cornerbif.chaos: reruns with the stability pass), whatever it keeps
        if "stability" in what or "sweep" in what or ("simulate" in what
                                                      and "stability" in scene.keep):
            out.append(("the two-particle stability kernel", COMPILE_SECONDS["stability"],
                        [batch_two_particle_stability]))
        if "continuation" in what:
            out.append(("the two-particle continuation's functions",
                        COMPILE_SECONDS["continuation"], dispatchers(*CONTINUATION_KERNELS)))
        return out

    def run_seconds(self, scene, values):
        """The time model of one run at the parameter ``values`` of a grid point
        (``estimate.estimate_time``): (seconds of one core, low, high, reasons the estimate is
        uncertain).  A run pays per z-u impact and per section period it crosses
        (COST_IMPACT, COST_SECTION); between two z-u impacts about half the slower
        particle's period pi / min(omega1, omega2) passes (measured: 1.00 pi at Fig. 19(a)),
        at most the run's time budget (``run.max_periods`` units of the slower of the
        section period and 2 pi / min(omega1, omega2), docs/guarantees.md "Budgets")."""
        w0 = float(values["omega0"])
        slow = min(float(values["omega1"]), float(values["omega2"]))
        section = scene.extra["section_period"] or 2.0 * math.pi / w0
        n = scene.transient + scene.record
        flight = math.pi / slow
        budget = scene.max_periods * max(section, 2.0 * math.pi / slow) / section
        sections = min(n * max(1.0, flight / section), budget)
        seconds = n * COST_IMPACT + sections * COST_SECTION
        reasons = []
        if sections * COST_SECTION >= 0.5 * seconds:
            reasons.append(f"runs cross about {max(1.0, flight / section):.2g} section periods "
                           "between impacts")
        f = UNCERTAIN_FACTOR if reasons else CLOSE_FACTOR
        return seconds, seconds / f, seconds * f, reasons

    def orbit_from_doc(self, doc):
        from .orbit import TwoParticleOrbit  # start-up: loads numba
        return TwoParticleOrbit.from_doc(doc)

    def orbit_seed(self, values, scene, param, word, run):
        from .orbit import two_particle_seed  # start-up: loads numba
        n = int(np.isfinite(run["sz"]).sum())
        x = [run[k][n - 1] for k in ("sz", "sy", "su", "sv")]
        return two_particle_seed(values, param, x, run["ipc"])

    def run_items(self, params, ics, ints, scene):
        """The two-particle kernel (section 6) on n items.

        ``t, u, v_in, v_out, y_in, y_out, corner_offset, corner`` are the u-z impacts (the
        offset to the nearest w-z impact, this system's corner, and its number); ``st, sz,
        sy, su, sv`` the sections; ``wz_t, wz_z, wz_y_in, wz_y_out`` the w-z impacts (the
        kernel's whole table, ``wall_capacity(record)`` rows); ``final`` is (n, 4) =
        (z, y, u, v).
        """
        # start-up: the kernels load numba here, at first use (validation loads none)
        from ..._jit import raise_if_stopped
        from ...analysis import detect_cycles  # start-up: loads numba
        from ...numerics.fill import full  # start-up: loads numba
        from . import kernel as K  # start-up: loads numba
        from .tangent import two_particle_outputs  # start-up: loads numba
        n = params.shape[0]
        rec = scene.record
        cap = wall_capacity(rec)
        o_zu = full((n, rec, K.NZU), np.nan)
        corner = full((n, rec), -1, np.int64)
        o_wz = full((n, cap, K.NWZ), np.nan)
        o_sec = full((n, rec, K.NSEC), np.nan)
        st = np.zeros(n, np.int8)
        final = np.full((n, 4), np.nan)
        K.run_batch(np.ascontiguousarray(params), ints, np.ascontiguousarray(ics), o_zu, corner,
                    o_wz, o_sec, st, final)
        raise_if_stopped(ints[TP.I_CONTROL])     # stopped: nothing half-computed goes on
        out = {"t": np.ascontiguousarray(o_zu[:, :, K.ZU_T]), "u": o_zu[:, :, K.ZU_U].copy(),
               "v_in": np.ascontiguousarray(o_zu[:, :, K.ZU_VIN]),
               "v_out": o_zu[:, :, K.ZU_VOUT].copy(),
               "corner_offset": np.ascontiguousarray(o_zu[:, :, K.ZU_OFF]),
               "su": o_sec[:, :, K.SEC_U].copy(), "sv": o_sec[:, :, K.SEC_V].copy(),
               "sz": o_sec[:, :, K.SEC_Z].copy(), "sy": o_sec[:, :, K.SEC_Y].copy(),
               # the whole w-z table (a file keeps its first ``record`` rows), the z-u
               # impacts' y and corner, the section times: views, no copies
               "wz_t": o_wz[:, :, K.WZ_T], "wz_z": o_wz[:, :, K.WZ_Z],
               "wz_y_in": o_wz[:, :, K.WZ_YIN], "wz_y_out": o_wz[:, :, K.WZ_YOUT],
               "y_in": o_zu[:, :, K.ZU_YIN], "y_out": o_zu[:, :, K.ZU_YOUT],
               "corner": corner, "st": o_sec[:, :, K.SEC_T]}
        period = np.zeros(n, np.int64)
        ipc = np.zeros(n, np.int64)
        sym = np.zeros((n, rec), np.uint8)
        t = np.where(np.isnan(out["corner_offset"]), np.nan, out["t"])
        detect_cycles(t, out["v_in"], out["corner_offset"], corner, np.ones(n, np.bool_),
                      scene.period_tol, period, ipc, sym)
        if "stability" in scene.keep:
            stab = two_particle_outputs(np.ascontiguousarray(params), o_zu, o_wz, ipc,
                                        ints[TP.I_CONTROL])
            stab.pop("monodromy")
            out.update(stab)
        return RunResult(out, st, final, period, ipc, sym)


def wall_capacity(record: int) -> int:
    """Rows of the kernel's w-z impact table: the w-z impacts between the first and the last
    recorded z-u impact (at most four per z-u impact, and a margin)."""
    return 4 * record + 8


# working memory per item and recorded z-u impact, from run_items' arrays: the z-u table
# (NZU = 7 columns), the corner index, the w-z table (4 rows of NWZ = 4 per impact), the
# sections (NSEC = 5), the 13 extracted copies, the masked t and the word
BYTES_PER_EVENT = (7 + 1 + 4 * 4 + 5 + 13 + 1) * 8 + 1

# ``cornerbif warm``: what a first sweep (with stability) and a first continuation compile
_WARM_SCENE = """
[system]
omega0 = 2.0
omega1 = 1.001
omega2 = 1.0
mu = 1000.0
r1 = 0.8
r2 = 0.8
kappa = 0.0
beta = 1.0
[initial]
count = 2
seed = 1
z = [0.0, 2.0]
y = [-2.0, 2.0]
u = [0.0, 20.0]
v = [-20.0, 20.0]
"""
WARMUPS = (
    Warmup("two_particle", "the two-particle kernel and its stability", "sweep",
           '[scene]\nname = "warm_two_particle"\nmodel = "two_particle"\n' + _WARM_SCENE
           + '[sweep]\nomega0 = { start = 1.999, stop = 2.0, num = 2 }\n'
           '[run]\ntransient = 10\nrecord = 8\n'
           '[output]\nkeep = ["impacts", "section", "stability"]\n'),
    Warmup("two_particle", "the two-particle continuation", "continue",
           '[scene]\nname = "warm_two_particle_continuation"\nmodel = "two_particle"\n'
           + _WARM_SCENE + '[run]\ntransient = 500\nrecord = 100\n'
           '[continue]\nparameter = "omega0"\nrange = [1.9999, 2.0001]\nstart = 2.0\n'),
)


MODEL = TwoParticleModel(
    name="two_particle",
    doc="a wall, a heavy and a light particle (section 6, eqs 72-74)",
    params=TP.PARAMS,
    state=(Z, Y, U_ABOVE_Z, V),
    # the Poincare section's period (default 2 pi / omega0)
    system_extra={"section_period": None},
    observables={"impacts": IMPACT_FIELDS, "section": SECTION_FIELDS + SECTION_ZY,
                 "wall_impacts": WALL_IMPACT_FIELDS, "stability": STABILITY},
    opt_in=("stability",),
    continuation=True,
    seed_observable="section",
    cycle=IMPACT_CYCLE,      # the u-z impacts
    events_per_impact=40,
    bytes_per_event=BYTES_PER_EVENT,
    # u-z impacts, benchmarks/run.py, Fig. 19(a), one core (benchmarks/results/results.json)
    events_per_second=7.0e5,
    warmups=WARMUPS,
)
