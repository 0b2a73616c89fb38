"""The ``linear`` model (issue 33): a linear vibro-impact system that the scene declares in its
``[system]`` table (docs/linear.md): N coordinates with mass, stiffness and damping matrices,
harmonic and constant forces, and contacts with impacts by the generalised Newton law.

The registered ``MODEL`` has no coordinates and no parameters of its own: a scene's table
declares them, and ``for_system`` gives the model of that table (``declare.read_system``
checks it), with

- the state: each dof ``x`` and its velocity ``v_x``, in the order of ``dofs``;
- the parameters: every number of the table by its path (``declare.numeric_paths``:
  ``"forcing.0.Omega"``, ``"contact.R.kappa"``, ``"mass.y"``), each a sweep axis;
- the impacts: time, contact, the impact height u = a . x and velocities v = a . v along the
  contact's gap (for one coordinate against a moving obstacle: the flow model's u, v), and
  each coordinate's position and velocity just after the impact.

A run starts at t = 0 from (x, v); its impacts' letters are their contacts' names, its period
is counted in the system's period T (``system_period``).  Chattering ends a run (status STUCK:
sticking is not followed yet), as do soft stops (not run yet: refused).  Not yet: stability,
continuation, a start time, a followed sweep (docs/linear.md, "What remains").
"""

from __future__ import annotations

import dataclasses
import itertools
import math

import numpy as np

from ... import obstacles
from ...model import Coord, Field, Model, Param, RunResult, Warmup
from ...observables import ANALYSIS_KERNELS, ANALYSIS_SECONDS, IMPACT_CYCLE
from . import declare
from .system import LinearSystem

# cold compile seconds of the linear kernels (the event loop and the cycle detection),
# measured by ``python benchmarks/compile_time.py`` (announced rounded)
COMPILE_SECONDS = 14.0
# combinations of swept values checked one by one before a sweep (beyond: each axis alone)
MAX_CHECKED_COMBINATIONS = 10_000
# the time budget of a run: run.max_periods units of the system's time scale
# (``time_scale``)

BASE_FIELDS = (
    Field("impacts/t", "t", "impact time t", "time"),
    Field("impacts/contact", "contact", "the impacting contact (its index in the scene's "
          "order; its name is the letter in words)", dtype="i1", fill=-1),
    Field("impacts/u", "u", "impact height u = a . x of the impacting contact's gap (the "
          "obstacle's height z(t) there)", "length"),
    Field("impacts/v_in", "v_in", "velocity a . v along the contact's gap just before the "
          "impact", "length/time"),
    Field("impacts/v_out", "v_out", "velocity a . v along the gap just after the impact "
          "(the generalised Newton law)", "length/time"),
)


def system_at(table: dict, values: dict) -> LinearSystem:
    """The system of ``table`` with its numbers at ``values`` (paths, ``numeric_paths``)."""
    for path, v in values.items():
        table = declare.with_value(table, path, v)
    system, problems = declare.read_system(table)
    if problems:
        raise ValueError("; ".join(problems))
    return system


def system_period(system: LinearSystem) -> float:
    """The period T of the system's time dependence: the common period of its harmonic
    forces (2 pi / Omega) and moving obstacles (their ``shape`` period over omega); 0 when
    there is none (an autonomous system: periods are then counted in impacts) or when those
    periods have no common multiple within 1000 of the longest (to 1e-9)."""
    periods = [2.0 * math.pi / f.Omega for f in system.forcing if f.Omega > 0.0]
    kinds = obstacles.registered()
    periods += [kinds[c.obstacle].period(c.omega) for c in system.contacts
                if c.obstacle != declare.FIXED]
    if not periods:
        return 0.0
    longest = max(periods)
    for mult in range(1, 1001):
        T = mult * longest
        if all(abs(T / p - round(T / p)) <= 1e-9 * (T / p) for p in periods):
            return T
    return 0.0


def time_scale(system: LinearSystem) -> float:
    """The unit of a run's time budget: the system's period, else its slowest natural period
    (2 pi / the smallest nonzero sqrt of an eigenvalue of M^-1 K), else 1."""
    T = system_period(system)
    if T > 0.0:
        return T
    w2 = np.linalg.eigvals(np.linalg.solve(system.mass, system.stiffness)).real
    w2 = w2[w2 > 1e-12 * max(1.0, float(np.max(np.abs(w2))))]
    return 2.0 * math.pi / math.sqrt(float(w2.min())) if w2.size else 1.0


# the range each number of [system] must lie in by itself, by its path's pattern (the system
# they make is then checked whole: ``declare.read_system``)
RANGES = (
    (lambda k: k[0] == "mass" and (len(k) == 2 or k[1] == k[2]), "> 0 (a diagonal entry of M)",
     lambda v: v > 0.0),
    (lambda k: k[0] == "stiffness" and (len(k) == 2 or k[1] == k[2]),
     ">= 0 (a diagonal entry of K)", lambda v: v >= 0.0),
    (lambda k: k[0] == "forcing" and k[-1] == "Omega", ">= 0 (0: a constant force)",
     lambda v: v >= 0.0),
    (lambda k: k[0] == "contact" and k[-1] == "r", "in [0, 1] (restitution)",
     lambda v: 0.0 <= v <= 1.0),
    (lambda k: k[0] == "contact" and k[-1] == "omega", "> 0 (the obstacle's frequency)",
     lambda v: v > 0.0),
)


def _param(path: str, value: float) -> Param:
    """The declaration of the number at ``path`` of a scene's [system] (``RANGES``)."""
    k = path.split(".")
    allowed, ok = next(((a, f) for match, a, f in RANGES if match(k)),
                       ("a finite number", lambda v: True))
    return Param(path, value, allowed, ok, doc=f"the number at {path} of [system]",
                 equation="M x'' + C x' + K x = f (docs/linear.md)")


class LinearModel(Model):
    """The linear model: the registered one (no system) and, by ``for_system``, each scene's."""

    # the slot of int_settings that carries a sweep's control (batch.I_CONTROL, named here
    # without loading numba; tests/models/test_linear_model.py checks that they agree)
    control_slot = 2

    def for_system(self, table):
        """(the model of the ``[system]`` ``table``, problems): None and the problems of
        ``declare.read_system`` when the table is not a valid system."""
        if not isinstance(table, dict):
            return None, [f"system: {table!r} must be a table"]
        system, problems = declare.read_system(table)
        if problems:
            return None, problems
        soft = [c.name for c in system.contacts if c.law != "impact"]
        if soft:
            return None, [f"system.contact.{soft[0]}.law: \"spring\" (a soft stop) is declared "
                          "but not run yet by the linear model (docs/linear.md, \"What "
                          "remains\"); use law = \"impact\""]
        paths = declare.numeric_paths(table)
        params = {p: _param(p, v) for p, v in paths.items()}
        state = []
        for k, d in enumerate(system.dofs):
            state.append(Coord(d, (-1.0, 1.0), 2 * k, None, f"initial {d}(0)",
                               f"{d} just after the last impact"))
        for k, d in enumerate(system.dofs):
            state.append(Coord(f"v_{d}", (-1.0, 1.0), 2 * k + 1, None, f"initial {d}'(0)",
                               f"{d}' just after the last impact"))
        per_dof = tuple(
            f for d in system.dofs for f in (
                Field(f"impacts/{d}", f"x_{d}", f"{d} at the impact", "length"),
                Field(f"impacts/v_{d}", f"v_{d}", f"{d}' just after the impact", "length/time")))
        return dataclasses.replace(
            self, params=params, state=tuple(state),
            observables={"impacts": BASE_FIELDS + per_dof},
            system_table=table), []

    def system_table_with(self, values: dict) -> dict:
        table = self.system_table
        for path, v in values.items():
            if v != self.params[path].default:
                table = declare.with_value(table, path, v)
        return table

    def check(self, ctx):
        """Every point's system is a valid one (each combination of swept values, or each
        axis's values alone beyond MAX_CHECKED_COMBINATIONS), of one shape (no forcing's
        Omega swept through 0); a followed sweep is refused (a run ends at an impact, not at
        a section)."""
        problems = []
        if self.system_table is None:
            return problems
        if getattr(ctx, "follow", "none") not in (None, "none"):
            problems.append("sweep.follow: the linear model does not follow attractors yet "
                            "(its runs end at an impact, not at a section); remove it")
        swept = [a for a in ctx.axes if a.name in self.params]
        n_comb = math.prod(len(a.values) for a in swept) if swept else 1
        if n_comb <= MAX_CHECKED_COMBINATIONS:
            combos = itertools.product(*[a.values for a in swept])
        else:
            combos = ([v if b is a else self.params[b.name].default for b in swept]
                      for a in swept for v in a.values)
        for combo in combos:
            values = dict(zip((a.name for a in swept), combo))
            table = self.system_table
            for path, v in values.items():
                table = declare.with_value(table, path, v)
            system, bad = declare.read_system(table)
            where = ", ".join(f"sweep.{k} = {v!r}" for k, v in values.items())
            if bad:
                problems.append(f"{bad[0]} (at {where})")
                break
            zero = [f"forcing.{i}.Omega" for i, f in enumerate(system.forcing)
                    if (f.Omega == 0.0) != (self.params.get(f"forcing.{i}.Omega",
                                                            Param("", 0.0, "")).default == 0.0)]
            if zero:
                problems.append(f"sweep.{zero[0]}: Omega = 0 (a constant force) and Omega > 0 "
                                f"(a harmonic one) in one sweep (at {where}); sweep one side")
                break
        return problems

    def orbit_seed(self, values, scene, param, word, run):
        raise NotImplementedError("the linear model does not solve its periodic orbits yet "
                                  "(docs/linear.md, \"What remains\")")

    def wall_at_start(self, params):
        return np.full(params.shape[0], -np.inf)      # no start is drawn above an obstacle

    def pack_values(self, values: dict, scene) -> np.ndarray:
        return np.array([float(values[p]) for p in self.params], dtype=float)

    def int_settings(self, scene):
        from .batch import I_CONTROL, I_RECORD, I_TRANSIENT, NINT  # start-up: loads numba
        ints = np.zeros(NINT, np.int64)
        ints[I_TRANSIENT] = scene.transient
        ints[I_RECORD] = scene.record
        ints[I_CONTROL] = 0
        return ints


    def kernel(self):
        from .batch import run_batch  # start-up: loads numba
        return run_batch

    def compiles(self, scene, what):
        """What a first run of ``scene`` compiles: the file's analysis kernels (a sweep) and
        the linear event loop with its cycle detection."""
        from ..._jit import dispatchers  # start-up: loads numba
        from .batch import detect_contact_cycles, run_batch  # start-up: loads numba
        out = []
        if "sweep" in what:          # the file's analysis but the flow's cycles (its own here)
            out.append(("the cycle analysis", ANALYSIS_SECONDS,
                        dispatchers(*(k for k in ANALYSIS_KERNELS if k != "analysis.detect_cycles"))))
        if "sweep" in what or "simulate" in what:
            out.append(("the linear kernel", COMPILE_SECONDS, [run_batch, detect_contact_cycles]))
        return out

    def run_items(self, params, ics, ints, scene):
        """The linear event loop (``batch.run_batch``) on n items, each system prepared once
        (``kernel.prepare``), and each run's cycle (``batch.detect_contact_cycles``)."""
        from ..._jit import raise_if_stopped  # start-up: loads numba
        from ...numerics.fill import full  # start-up: loads numba
        from . import batch as B  # start-up: loads numba
        from .kernel import prepare  # start-up: loads numba
        n = params.shape[0]
        rec = scene.record
        uniq, which = np.unique(params, axis=0, return_inverse=True)
        which = np.ascontiguousarray(which.reshape(-1), dtype=np.int64)
        names = list(self.params)
        systems = [system_at(self.system_table, dict(zip(names, row))) for row in uniq]
        nd = systems[0].n
        prepared = [prepare(s, 0.0, np.zeros(nd), np.zeros(nd)) for s in systems]

        def stack(key, dtype=float):
            return np.ascontiguousarray(np.stack([np.asarray(a[key], dtype) for a in prepared]))

        harmonic = [[f for f in s.forcing if f.Omega > 0.0] for s in systems]
        f_omega = np.array([[f.Omega for f in h] for h in harmonic], float).reshape(len(systems), -1)
        f_phi = np.array([[f.phi for f in h] for h in harmonic], float).reshape(len(systems), -1)
        f_const = np.array([any(f.Omega == 0.0 for f in s.forcing) for s in systems], np.bool_)
        t_max = np.array([scene.max_periods * time_scale(s) for s in systems], float)
        o_t = full((n, rec), np.nan)
        o_c = full((n, rec), -1, np.int64)
        o_x, o_vin, o_vout = (full((n, rec, nd), np.nan) for _ in range(3))
        st = np.zeros(n, np.int8)
        final = np.full((n, 2 * nd), np.nan)
        B.run_batch(which, stack("E"), np.array([a["H"] for a in prepared]),
                    np.array([a["normA"] for a in prepared]), stack("cA"), stack("normc"),
                    stack("rows"), stack("ds"), stack("gaps"), stack("D"), stack("r"), f_omega,
                    f_phi, f_const, np.ascontiguousarray(ics, dtype=float), ints, scene.tol,
                    scene.chatter, scene.escape, t_max, o_t, o_c, o_x, o_vin, o_vout, st, final)
        raise_if_stopped(ints[B.I_CONTROL])
        gaps = np.stack([np.asarray(a["gaps"], float) for a in prepared])[which]   # (n, nc, nd)
        cc = np.where(o_c >= 0, o_c, 0)
        a_k = np.take_along_axis(gaps, cc[:, :, None], axis=1)                   # (n, rec, nd)
        out = {"t": o_t, "contact": np.where(o_c >= 0, o_c, -1).astype(np.int8),
               "u": np.where(o_c >= 0, (a_k * o_x).sum(-1), np.nan),
               "v_in": np.where(o_c >= 0, (a_k * o_vin).sum(-1), np.nan),
               "v_out": np.where(o_c >= 0, (a_k * o_vout).sum(-1), np.nan)}
        for k, d in enumerate(systems[0].dofs):
            out[f"x_{d}"] = np.ascontiguousarray(o_x[:, :, k])
            out[f"v_{d}"] = np.ascontiguousarray(o_vout[:, :, k])
        period_T = np.array([system_period(s) for s in systems], float)[which]
        letters = np.array([ord(c.name) for c in systems[0].contacts], np.uint8)
        period = np.zeros(n, np.int64)
        ipc = np.zeros(n, np.int64)
        sym = np.zeros((n, rec), np.uint8)
        B.detect_contact_cycles(o_t, np.ascontiguousarray(o_c), np.ascontiguousarray(out["u"]),
                                np.ascontiguousarray(out["v_in"]), period_T, scene.period_tol,
                                letters, period, ipc, sym)
        return RunResult(out, st, final, period, ipc, sym)


# ``cornerbif warm``: what a first sweep compiles; its [system] is also the model's example
# (the contract tests' system: tests/models/test_registry.py)
EXAMPLE_SCENE = """[scene]
name = "warm_linear"
model = "linear"

[system]
dofs = ["x"]
mass = [1.0]
stiffness = [0.0]
forcing = [{ on = "x", F = -1.0 }]

[[system.contact]]
name = "T"
gap = { x = 1.0 }
obstacle = "sine"
kappa = 0.0
beta = 0.036
omega = 6.0
r = 0.5

[sweep]
"contact.T.beta" = { values = [0.036, 0.037] }

[initial]
count = 2
seed = 1
x = [0.02, 0.04]     # near the period-one orbit (docs/linear.md): every start reaches it
v_x = [0.45, 0.6]

[run]
transient = 10
record = 8
"""
WARMUPS = (Warmup("linear", "the linear kernel", "sweep", EXAMPLE_SCENE),)


MODEL = LinearModel(
    name="linear",
    doc="a linear vibro-impact system declared in the scene's [system] (docs/linear.md)",
    params={},
    state=(),
    system_extra={k: None for k in declare.SYSTEM_KEYS},
    observables={"impacts": BASE_FIELDS},
    cycle=IMPACT_CYCLE,
    events_per_impact=40,
    bytes_per_event=8 * 40,
    # impacts per second on one core, benchmarks/linear_kernel.py (one mass, rectified sine)
    events_per_second=1.1e5,
    warmups=WARMUPS,
)
