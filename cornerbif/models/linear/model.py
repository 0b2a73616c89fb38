"""The ``linear`` model: a linear vibro-impact system that the scene declares in its
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

A run starts at its start time t0 (``[initial] t``, 0 by default) from (x, v); its impacts'
letters are their contacts' names, its period is counted in the system's period T
(``system_period``).  With one contact on a cornered obstacle its words are the paper's
(``paper_words``); with ``[system] words = { impacts = "U", corners = "W" }`` the
two-particle model's (section 6: only U's impacts recorded, each grouped about the W impacts
as that model's u-z impacts about its w-z impacts; ``words_fields``).  A contact that
chatters to rest on a fixed stop is held (sticking: kernel.py, docs/linear.md "Sticking"); a
run held at its budget, or chattering where it cannot be held, is STUCK.  Soft stops (law "spring", on fixed
obstacles) switch the flight while they act; their entries are recorded as impacts with
v+ = v-, and they offer no stability observable and no followed sweep yet.  A
followed sweep carries each run's state in its last recorded flight and its phase
(``_final``, ``starts_from_carry``).  The ``stability`` observable (opt-in) holds the 2N
Floquet multipliers of each run's last recorded cycle and its 2N Lyapunov exponents
(``tangent``: flights' Jacobians and generalised saltation matrices).  ``cornerbif continue``
solves and follows its periodic orbits of impacts on hard contacts (``orbit.LinearOrbit``;
not with soft stops, ``[system] words`` or an autonomous system: ``continuation_refusal``).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from ...continuation import OrbitError
from ...model import Coord, Field, Model, Param, RunResult, Warmup, start_time_problems
from ...observables import (
    ANALYSIS_KERNELS,
    ANALYSIS_SECONDS,
    IMPACT_CYCLE,
    IMPACT_FIELDS,
    stability_fields,
)
from . import cost, declare
from .declare import paper_words, system_period  # (with the declarations: orbit.py reads them)
from .flight import augmented, flight, has_constant_state
from .system import LinearSystem

# cold compile seconds of the linear kernels (the event loop and the cycle detection), as a
# user meets them (the second process compiling half the loop's helpers beside): the whole
# first sweep's compile is 42.3 s by ``python benchmarks/compile_time.py --only linear``
# (2026-11-28, the stability pass compiled beside); announced rounded
COMPILE_SECONDS = 30.0
# cold compile seconds of the stability pass (``tangent.batch_linear_stability``, with the
# event loop's helpers cached): 16.1 s of a first sweep's 63.6 s compiled in one process
# (``benchmarks/compile_plan.py``'s record, 2026-11-28); compiled by the second process beside
# the loop where there is a second core (``compile_plan.PLANS``)
STABILITY_COMPILE_SECONDS = 16.0
# combinations of the swept numbers checked together (matrix entries, gap coefficients),
# all checked at once before a sweep (``declare.refusable``: about 2 microseconds each, and
# each one flagged read whole for its message): more are refused
MAX_CHECKED_COMBINATIONS = 20_000
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

# with the paper's words (``paper_words``): each impact's offset to its nearest corner, as
# the flow's file holds it
CORNER_FIELDS = tuple(f for f in IMPACT_FIELDS if f.name == "impacts/corner_offset")


def words_fields(system: LinearSystem) -> tuple:
    """The impacts' own datasets with the two-particle model's words (``[system] words``,
    ``system.Words``): those of one contact, its height and velocities those of the dofs the
    words name (else along its gap), and each one's offset to its corner impact."""
    w = system.words
    name = system.contacts[w.impacts].name
    corners = system.contacts[w.corners].name
    h = system.dofs[w.height] if w.height >= 0 else None
    v = system.dofs[w.velocity] if w.velocity >= 0 else None
    return (
        BASE_FIELDS[0],
        Field("impacts/contact", "contact", f"the impacting contact (its index in the scene's "
              f"order): always {name}'s, whose impacts alone are recorded ([system] words)",
              dtype="i1", fill=-1),
        Field("impacts/u", "u", f"impact height: {h} at the impact" if h
              else BASE_FIELDS[2].long_name, "length"),
        Field("impacts/v_in", "v_in", f"velocity of {v} just before the impact" if v
              else BASE_FIELDS[3].long_name, "length/time"),
        Field("impacts/v_out", "v_out", f"velocity of {v} just after the impact" if v
              else BASE_FIELDS[4].long_name, "length/time"),
        Field("impacts/corner_offset", "corner_offset", f"offset of the {name} impact to its "
              f"corner, a {corners} impact: to the previous one unless the next is strictly "
              "nearer (then < 0), as the two-particle model's u-z impacts to its w-z impacts "
              "(section 6)", "time"))


def _checked_together(path: str) -> bool:
    """Whether a swept number's validity depends on others swept with it: an entry of M, K
    or C (positive-definite, semi-definite; the flight's rates M^-1 K, M^-1 C) or a gap's
    coefficient (not all zero; a^T M^-1 a)."""
    k = path.split(".")
    return k[0] in ("mass", "stiffness", "damping") or (k[0] == "contact" and len(k) == 4 and k[2] == "gap")


def _grows(path: str) -> bool:
    """Whether a swept number enters the flight's rates with the matrices (a force's F or
    Omega: ``declare._scales``, whose bound grows with |F| and Omega), so that the matrices'
    combinations are checked with its largest value too."""
    k = path.split(".")
    return k[0] == "forcing" and k[-1] in ("F", "Omega")


def autonomous(system: LinearSystem) -> bool:
    """No time dependence: no harmonic force and every contact on a fixed stop (a constant
    force is allowed)."""
    return (all(f.Omega == 0.0 for f in system.forcing)
            and all(c.obstacle == declare.FIXED for c in system.contacts))


def phase_of(t: np.ndarray, T: np.ndarray, still: np.ndarray) -> np.ndarray:
    """The phase (t mod T) / T in [0, 1) of times ``t`` in their systems' periods ``T``;
    where T = 0, 0 for an autonomous system (``still``: time does not matter) and NaN for
    one whose periods have no common multiple (no phase to carry)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        ph = np.where(T > 0.0, np.mod(t, np.where(T > 0.0, T, 1.0)) / np.where(T > 0.0, T, 1.0),
                      np.where(still, 0.0, np.nan))
    return np.where(np.isfinite(t), ph, np.nan)


def continuation_refusal(system, table) -> str | None:
    """Why a linear system's orbits cannot be continued (naming the key and the value), or
    None: soft stops, ``[system] words``, or no period T (an autonomous system, whose orbit
    would need a phase condition, or periods without a common multiple)."""
    for c in system.contacts:
        if c.law != "impact":
            return (f"system.contact.{c.name}.law: {c.law!r} (a soft stop): continuation solves "
                    "orbits of impacts on hard contacts (law \"impact\") only; not with soft "
                    "stops yet (docs/linear.md, \"Continuation\")")
    if system.words is not None:
        return (f"system.words: {table.get('words')!r}: continuation names an orbit by all its "
                "impacts, and with the two-particle model's words only one contact's impacts "
                "are recorded; not yet (docs/linear.md, \"Continuation\")")
    if system_period(system) <= 0.0:
        return ("system: no period T (fixed stops and no harmonic force, or periods without a "
                "common multiple): a continued orbit closes after m periods T of the system; "
                "an autonomous system's would need a phase condition, not yet (docs/linear.md, "
                "\"Continuation\")")
    return None


# what a followed sweep carries beside the state: the phase of the final state's time
PHASE = Coord("phase", (0.0, 0.0), -1, None, "",
              "phase (t mod T) / T of the final state's time t in the system's period T (0 for "
              "an autonomous system; NaN where T has none): a followed sweep starts the next "
              "point's run from the final state at t0 = phase T there")


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
        if not system.contacts:
            return None, ["system.contact: none declared; a vibro-impact scene needs at least "
                          "one [[system.contact]] (its gap, obstacle and law)"]
        soft = [c.name for c in system.contacts if c.law == "spring"]
        if soft and system.words is not None:
            return None, [f"system.words: with the soft stop {soft[0]} (law \"spring\"): the "
                          "two-particle model's words name one contact's impacts by the "
                          "other's; not with soft stops yet (docs/linear.md, \"Soft stops\")"]
        paths = declare.numeric_paths(table)
        params = {p: _param(p, v) for p, v in paths.items()}
        state = []
        for k, d in enumerate(system.dofs):
            state.append(Coord(d, (-1.0, 1.0), 2 * k, None, f"initial {d}(0)",
                               f"{d} just after the last impact (a followed sweep: at the "
                               "middle of the last recorded flight)"))
        for k, d in enumerate(system.dofs):
            state.append(Coord(f"v_{d}", (-1.0, 1.0), 2 * k + 1, None, f"initial {d}'(0)",
                               f"{d}' just after the last impact (a followed sweep: at the "
                               "middle of the last recorded flight)"))
        corner_words = paper_words(system)
        if corner_words:
            # z's corners are valleys only for beta > 0: a sweep of beta stays there
            c = system.contacts[0]
            params[f"contact.{c.name}.beta"] = Param(
                f"contact.{c.name}.beta", c.beta, "> 0 (one contact on a cornered obstacle: "
                "its words are the paper's corner clusters, about z's valleys)",
                lambda v: v > 0.0, doc=f"the number at contact.{c.name}.beta of [system]",
                equation="M x'' + C x' + K x = f (docs/linear.md)")
        per_dof = tuple(
            f for d in system.dofs for f in (
                Field(f"impacts/{d}", f"x_{d}", f"{d} at the impact", "length"),
                Field(f"impacts/v_{d}", f"v_{d}", f"{d}' just after the impact", "length/time")))
        start_time = Coord("t", (0.0, 0.0), 2 * system.n, None, "start time t0 of the run (the "
                           "forces' and the obstacles' phase at the start; the state is given "
                           "at t0)", "")
        if soft:
            # soft stops: their entries are recorded as impacts (no jump); the stability pass
            # has no saltation through a soft stop's switch yet, so it is not offered
            observables = {"impacts": BASE_FIELDS + per_dof + (CORNER_FIELDS if corner_words
                                                                else ())}
        elif system.words is not None:
            # the two-particle model's words: one contact's impacts alone are recorded, so
            # neither the stability pass (its saltations need every impact) nor a followed
            # sweep (its flights too) is offered (``check``)
            own = words_fields(system)
            observables = {"impacts": own[:5] + per_dof + own[5:]}
        else:
            observables = {"impacts": BASE_FIELDS + per_dof + (CORNER_FIELDS if corner_words
                                                                else ()),
                           "stability": stability_fields(2 * system.n)}
        return dataclasses.replace(
            self, params=params, state=tuple(state), start_time=start_time, carried=(PHASE,),
            observables=observables,
            opt_in=self.opt_in if "stability" in observables else (),
            contact_words=not (corner_words or system.words is not None),
            keep_hint=(f" with the soft stop {soft[0]} (law \"spring\"): the stability pass has "
                       "no saltation through a soft stop's switch yet (docs/linear.md, \"Soft "
                       "stops\")") if soft else self.keep_hint,
            system_table=table), []

    def system_table_with(self, values: dict) -> dict:
        table = self.system_table
        for path, v in values.items():
            if v != self.params[path].default:
                table = declare.with_value(table, path, v)
        return table

    def seed_letters(self) -> str | None:
        """A ``[continue] seed`` word's letters: the contacts' names (case kept) where the
        words are the contacts' letters; None (the clusters' a, b, g, as the flow's) where
        they are the paper's (``paper_words``) or the two-particle model's."""
        if not self.contact_words or not isinstance(self.system_table, dict):
            return None
        return "".join(c["name"] for c in self.system_table.get("contact", ()))

    def system_of(self, values: dict):
        """(the system at the numbers ``values``, by path; problems): the scene's table with
        the values that differ from it written in (``system_table_with``: a mirrored matrix
        entry at its table value does not write its old value back over its mirror)."""
        return declare.read_system(self.system_table_with(values))

    def run_seconds(self, scene, values):
        """The time model of one run at the numbers ``values`` of a grid point
        (``estimate.estimate_time``): ``cost.run_seconds`` of its system, whose flights last
        about its time scale between impacts and at most its budget (``run.max_periods``
        time scales) in all."""
        system, bad = self.system_of(values)
        if bad:
            return 0.0, 0.0, 0.0, []
        T = time_scale(system)
        return cost.run_seconds(system, scene.transient + scene.record, T, scene.max_periods * T,
                                scene.n_ic)

    def given_problem(self, names) -> str | None:
        """A problem of the numbers given together by name (``cornerbif.simulate``'s
        keywords), or None: a matrix entry and its mirror are one number."""
        for path in names:
            k = path.split(".")
            if k[0] in ("mass", "stiffness") and len(k) == 3 and k[1] != k[2] \
                    and f"{k[0]}.{k[2]}.{k[1]}" in names:
                return (f"{path} and {k[0]}.{k[2]}.{k[1]} given together: one number of the "
                        f"symmetric {k[0]} matrix; give one of them")
        return None

    def check(self, ctx):
        """Every point's system is a valid one, checked before any run: each value by its
        own range (``RANGES``, by config), each axis alone with the others at the table's
        values, and every combination of the swept numbers that are checked together (the
        entries of M, K and C: positive-definite, semi-definite, the flight's rates; a gap's
        coefficients: not all zero, a^T M^-1 a) up to MAX_CHECKED_COMBINATIONS, more refused,
        those combinations again with each swept force's F and Omega at its largest (the
        rates grow with them); a mirrored pair of matrix entries swept together is
        refused.  All the combinations of a group at once
        (``declare.refusable``); the first one refused is said as ``system_of`` says it."""
        problems = start_time_problems(ctx)
        if self.system_table is None:
            return problems
        if getattr(ctx, "continued", False):
            system, bad = declare.read_system(self.system_table)
            why = None if bad else continuation_refusal(system, self.system_table)
            if why:
                problems.append(f"{why} (a scene with [continue])")
        if "words" in self.system_table and ctx.follow not in (None, "none"):
            problems.append(f"sweep.follow: {ctx.follow!r} with [system] words: a followed sweep "
                            "starts each run in its last recorded flight, and with the "
                            "two-particle model's words only one contact's impacts are "
                            "recorded; not yet (docs/linear.md, \"What remains\")")
        soft = [c.get("name") for c in self.system_table.get("contact", [])
                if isinstance(c, dict) and c.get("law") == "spring"]
        if soft and ctx.follow not in (None, "none"):
            problems.append(f"sweep.follow: {ctx.follow!r} with the soft stop {soft[0]} (law "
                            "\"spring\"): a followed sweep starts each run in its last recorded "
                            "flight, which a soft stop's switch may cross; not yet (docs/linear.md, "
                            "\"Soft stops\")")
        swept = [a for a in ctx.axes if a.name in self.params]
        names = {a.name for a in swept}
        for a in swept:
            k = a.name.split(".")
            if k[0] in ("mass", "stiffness") and len(k) == 3 and k[1] < k[2] \
                    and f"{k[0]}.{k[2]}.{k[1]}" in names:
                problems.append(f"sweep.{a.name}: swept with its mirror {k[0]}.{k[2]}.{k[1]}, "
                                f"one number of the symmetric {k[0]} matrix; sweep one of them")
        joint = [a for a in swept if _checked_together(a.name)]
        n_comb = math.prod(len(a.values) for a in joint) if joint else 1
        if n_comb > MAX_CHECKED_COMBINATIONS:
            problems.append(f"sweep: {n_comb} combinations of {', '.join(a.name for a in joint)} "
                            f"(entries of M, K and C, or a gap's coefficients, each combination a "
                            f"system to check before the run); at most {MAX_CHECKED_COMBINATIONS}")
            return problems
        # the combinations of the numbers checked together, then each other axis alone, then
        # the combinations with every force's F and Omega at its largest (the rates)
        groups = [(joint, lambda a, v: v)] if joint else []
        groups += [([a], lambda a, v: v) for a in swept if a not in joint]
        grows = [a for a in swept if a not in joint and _grows(a.name)]
        if grows and (joint or len(grows) > 1):
            groups.append((joint + grows, lambda a, v: v if a in joint else (max(v, key=abs),)))
        for axes, values_of in groups:
            bad = self._first_refused([(a.name, values_of(a, a.values)) for a in axes])
            if bad:
                problems.append(bad)
                break
        return problems

    def _first_refused(self, axes) -> str | None:
        """The problem of the first combination (the last axis fastest) of the
        ``axes`` (name, values) whose system is refused, said as a sweep's, or None: all the
        combinations flagged at once (``declare.refusable``), the flagged ones read whole."""
        names = [name for name, _ in axes]
        grid = np.meshgrid(*[np.asarray(v, float) for _, v in axes], indexing="ij")
        rows = np.stack([g.reshape(-1) for g in grid], -1)
        for index in np.flatnonzero(declare.refusable(self.system_table, names, rows)):
            at = np.unravel_index(index, [len(v) for _, v in axes])
            values = {name: v[i] for (name, v), i in zip(axes, at)}
            _, bad = self.system_of(values)
            if bad:
                where = ", ".join(f"sweep.{k} = {v!r}" for k, v in values.items())
                return f"{bad[0]} (at {where})"
        return None

    def check_point(self, values: dict):
        """The problem of the system at one point (``cornerbif.simulate``'s elements), or
        None."""
        _, bad = self.system_of({k: v for k, v in values.items() if k in self.params})
        return f"linear: {bad[0]}" if bad else None

    def impact_reference(self, system, values, rows, grid, contact):
        """Each impact's own contact's kappa (u - kappa: the height above that contact's
        corners), at each grid point where the sweep varies it (axis "contact.<name>.kappa")."""
        contacts = system.get("contact")
        if contact is None or not isinstance(contacts, list):
            return None
        axes = list(values)
        kap = np.full(grid + (len(contacts) + 1,), np.nan)
        for c, entry in enumerate(contacts):
            name = entry.get("name") if isinstance(entry, dict) else None
            axis = f"contact.{name}.kappa"
            if axis in values:
                pos = axes.index(axis)
                vals = values[axis][rows] if pos == 0 else values[axis]
                kap[..., c] = vals.reshape((-1,) + (1,) * (len(grid) - 1 - pos))
            elif isinstance(entry, dict):
                kap[..., c] = float(entry.get("kappa", 0.0))
        idx = contact.astype(int)
        idx = np.where((idx >= 0) & (idx < len(contacts)), idx, len(contacts))
        kap = kap.reshape(grid + (1, 1, len(contacts) + 1))
        return np.take_along_axis(np.broadcast_to(kap, idx.shape + (len(contacts) + 1,)),
                                  idx[..., None], axis=-1)[..., 0]

    def orbit_seed(self, values, scene, param, word, run):
        """A ``orbit.LinearOrbit`` and its solved unknowns from one run's record (its last
        cycle), refused (OrbitError) for a system whose orbits are not continued
        (``continuation_refusal``) or a cycle that sticks."""
        from .orbit import linear_seed  # start-up: loads numba
        system, bad = declare.read_system(self.system_table)
        why = bad[0] if bad else continuation_refusal(system, self.system_table)
        if why:
            raise OrbitError(why)
        return linear_seed(self.system_table, values, param, run)

    def orbit_from_doc(self, doc):
        from .orbit import LinearOrbit  # start-up: loads numba
        return LinearOrbit.from_doc(doc)

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
        """What a first run of ``scene`` compiles: the file's analysis kernels (a sweep), the
        linear event loop with its cycle detection, and the stability pass (a sweep, whose
        chaos test reruns with it, or a run that keeps "stability")."""
        from ..._jit import dispatchers  # start-up: loads numba
        from .batch import corner_offsets, detect_contact_cycles, run_batch  # start-up: loads numba
        # its cycles: the contacts' (``batch``) or, with the paper's words, the flow's (the
        # corner offsets: ``batch``'s of the obstacle, or the event loop's with [system] words)
        words = isinstance(self.system_table, dict) and "words" in self.system_table
        cycles = ([detect_contact_cycles] if self.contact_words
                  else [] if words else [corner_offsets])
        out = []
        if "sweep" in what:          # the file's analysis
            out.append(("the cycle analysis", ANALYSIS_SECONDS,
                        dispatchers(*(k for k in ANALYSIS_KERNELS
                                      if k != "analysis.detect_cycles" or not self.contact_words))))
        elif not self.contact_words:
            cycles += dispatchers("analysis.detect_cycles")
        if "sweep" in what or "simulate" in what or "continuation" in what:
            # (a continuation's seeds are the scene's starts run by the kernel; its orbit
            # problem, orbit.py, is numpy around the obstacles' functions the kernel compiles)
            out.append(("the linear kernel", COMPILE_SECONDS, [run_batch] + cycles))
        # a sweep's file tests its runs without a cycle for chaos when it finishes
        # (cornerbif.chaos: reruns with the stability pass), whatever it keeps
        if ("stability" in self.observables
                and ("stability" in what or "sweep" in what
                     or ("simulate" in what and "stability" in scene.keep))):
            from .tangent import batch_linear_stability  # start-up: loads numba
            out.append(("the linear stability pass", STABILITY_COMPILE_SECONDS,
                        [batch_linear_stability]))
        return out

    def run_items(self, params, ics, ints, scene):
        """The linear event loop (``batch.run_batch``) on n items, each system prepared once
        (``kernel.prepare``), and each run's cycle (``batch.detect_contact_cycles``; with the
        paper's words, ``batch.corner_offsets`` and the flow's ``analysis.detect_cycles``; with
        ``[system] words``, the event loop's offsets to the corner contact's impacts and
        ``analysis.detect_cycles``, as the two-particle model's ``run_items``).  Systems
        whose augmented states differ in size (a forcing's Omega 0 at some points, > 0 at
        others) run in separate calls, each on its items."""
        from ..._jit import raise_if_stopped  # start-up: loads numba
        from ...numerics.fill import full  # start-up: loads numba
        from . import batch as B  # start-up: loads numba
        n = params.shape[0]
        rec = scene.record
        uniq, which = np.unique(params, axis=0, return_inverse=True)
        which = which.reshape(-1)
        names = list(self.params)
        systems = []
        for row in uniq:
            system, bad = self.system_of(dict(zip(names, row)))
            if bad:              # (config and simulate check every point before a run)
                raise ValueError("; ".join(bad))
            systems.append(system)
        nd = systems[0].n
        o_t = full((n, rec), np.nan)
        o_c = full((n, rec), -1, np.int64)
        o_x, o_vin, o_vout = (full((n, rec, nd), np.nan) for _ in range(3))
        st = np.zeros(n, np.int8)
        final = np.full((n, 2 * nd), np.nan)
        words = systems[0].words          # the two-particle model's (the scene's, every point)
        o_off = full((n, rec if words else 0), np.nan)
        o_corner = full((n, rec if words else 0), -1, np.int64)
        gaps = np.empty((n, len(systems[0].contacts), nd))
        rows0 = ds0 = None                  # each item's first contact's obstacle rows
        shapes = {}
        groups = []                         # (items, their systems' indices, the arrays)
        for k, s in enumerate(systems):
            shapes.setdefault((sum(f.Omega > 0.0 for f in s.forcing),
                               has_constant_state(s)), []).append(k)
        for members in shapes.values():
            items = np.flatnonzero(np.isin(which, members))
            local = np.searchsorted(members, which[items])
            outs = [a[items] for a in (o_t, o_c, o_x, o_vin, o_vout, st, final, o_off, o_corner)]
            g, r0, d0, arrays = self._run_group([systems[k] for k in members], local,
                                                np.ascontiguousarray(ics[items], dtype=float),
                                                ints, scene, outs, B)
            groups.append((items, local, arrays))
            if rows0 is None:
                rows0 = np.empty((n,) + r0.shape[1:])
                ds0 = np.empty((n,) + d0.shape[1:])
            gaps[items], rows0[items], ds0[items] = g, r0, d0
            for a, b in zip((o_t, o_c, o_x, o_vin, o_vout, st, final, o_off, o_corner), outs):
                a[items] = b
        raise_if_stopped(ints[B.I_CONTROL])
        cc = np.where(o_c >= 0, o_c, 0)
        a_k = np.take_along_axis(gaps, cc[:, :, None], axis=1)                   # (n, rec, nd)
        out = {"t": o_t, "contact": np.where(o_c >= 0, o_c, -1).astype(np.int8),
               "u": np.where(o_c >= 0, (a_k * o_x).sum(-1), np.nan),
               "v_in": np.where(o_c >= 0, (a_k * o_vin).sum(-1), np.nan),
               "v_out": np.where(o_c >= 0, (a_k * o_vout).sum(-1), np.nan)}
        if words is not None:   # the words' height and velocity: those of the dofs named
            if words.height >= 0:
                out["u"] = np.where(o_c >= 0, o_x[:, :, words.height], np.nan)
            if words.velocity >= 0:
                out["v_in"] = np.where(o_c >= 0, o_vin[:, :, words.velocity], np.nan)
                out["v_out"] = np.where(o_c >= 0, o_vout[:, :, words.velocity], np.nan)
        for k, d in enumerate(systems[0].dofs):
            out[f"x_{d}"] = np.ascontiguousarray(o_x[:, :, k])
            out[f"v_{d}"] = np.ascontiguousarray(o_vout[:, :, k])
        period_T = np.array([system_period(s) for s in systems], float)[which]
        final = self._final(systems, which, o_t, o_x, o_vout, final, period_T,
                            scene.follow != "none")
        letters = np.array([ord(c.name) for c in systems[0].contacts], np.uint8)
        period = np.zeros(n, np.int64)
        ipc = np.zeros(n, np.int64)
        sym = np.zeros((n, rec), np.uint8)
        if words is not None:
            # the two-particle model's words: its run_items' cycles over the recorded impacts
            # with an offset (the kernel's ``analysis.settle_corner_offsets``)
            from ...analysis import detect_cycles  # start-up: loads numba
            out["corner_offset"] = o_off
            t_off = np.where(np.isnan(o_off), np.nan, o_t)
            detect_cycles(t_off, np.ascontiguousarray(out["v_in"]), o_off, o_corner,
                          np.ones(n, np.bool_), scene.period_tol, period, ipc, sym)
        elif not self.contact_words:      # the model's words, decided once (for_system)
            from ...analysis import detect_cycles  # start-up: loads numba
            off = np.full((n, rec), np.nan)
            corner = np.zeros((n, rec), np.int64)
            B.corner_offsets(o_t, rows0, ds0, off, corner)
            out["corner_offset"] = off
            detect_cycles(o_t, np.ascontiguousarray(out["v_in"]), off, corner, np.ones(n, np.bool_),
                          scene.period_tol, period, ipc, sym)
        else:
            B.detect_contact_cycles(o_t, np.ascontiguousarray(o_c),
                                    np.ascontiguousarray(out["u"]),
                                    np.ascontiguousarray(out["v_in"]), period_T,
                                    scene.period_tol, letters, period, ipc, sym)
        if "stability" in scene.keep:
            self._stability(groups, n, nd, o_t, o_c, o_x, o_vin, o_vout, ipc,
                            ints[B.I_CONTROL], out)
        return RunResult(out, st, final, period, ipc, sym)

    @staticmethod
    def _stability(groups, n, nd, o_t, o_c, o_x, o_vin, o_vout, ipc, control, out):
        """The ``stability`` observable (``tangent.linear_outputs``: the multipliers of each
        run's last recorded cycle and its Lyapunov spectrum, 2N each) into ``out``, each
        group of systems of one augmented size on its stacked arrays."""
        from .tangent import linear_outputs  # start-up: loads numba
        stab = {"mu_re": np.full((n, 2 * nd), np.nan), "mu_im": np.full((n, 2 * nd), np.nan),
                "cycle_duration": np.full(n, np.nan), "stability_status": np.zeros(n, np.int8),
                "lyapunov": np.full((n, 2 * nd), np.nan), "lyapunov_window": np.full(n, np.nan),
                "lyapunov_status": np.zeros(n, np.int8)}
        for items, local, arrays in groups:
            res = linear_outputs(arrays, local, o_t[items], o_c[items], o_x[items],
                                 o_vin[items], o_vout[items], ipc[items], control)
            for k, v in stab.items():
                v[items] = res[k]
        out.update(stab)

    @staticmethod
    def _final(systems, which, o_t, o_x, o_vout, after_last, period_T, followed):
        """``final`` (n, 2N + 1): the state just after each run's last impact, or in a
        followed sweep at the middle of its last recorded flight (from its last impact but
        one, by the exact flight ``flight.flight``: certified free of impacts, so the next
        point's run starts clear of every contact), then its time's phase (``phase_of``).
        NaN where the run recorded too few impacts."""
        n, rec = o_t.shape
        count = np.isfinite(o_t).sum(axis=1)
        t_ref = np.where(count > 0, o_t[np.arange(n), np.maximum(count - 1, 0)], np.nan)
        state = after_last.copy()
        if followed:
            state[:] = np.nan
            t_ref = np.full(n, np.nan)
            A = {}
            for i in np.flatnonzero(count >= 2):
                s, k = which[i], count[i] - 2
                A.setdefault(s, augmented(systems[s]))
                h = 0.5 * (o_t[i, k + 1] - o_t[i, k])
                x, v = flight(systems[s], o_t[i, k], o_x[i, k], o_vout[i, k], h, A[s])
                state[i] = np.concatenate([x, v])
                t_ref[i] = o_t[i, k] + h
        still = np.array([autonomous(s) for s in systems], bool)[which]
        return np.concatenate([state, phase_of(t_ref, period_T, still)[:, None]], axis=1)

    def starts_from_carry(self, carry, ics, wall, params):
        """The previous slab's final states (``_final``: in flight, with their phase), each
        started at t0 = phase T of this point's system, where it is clear of every contact
        at t0; elsewhere the drawn start."""
        from .events import ContactObstacle  # start-up: loads numba (the obstacles' heights)
        n2 = carry.shape[-1] - 1
        names = list(self.params)
        for p, row in enumerate(params):
            system, _ = self.system_of(dict(zip(names, row)))
            T = system_period(system)
            phase = carry[p, :, n2]
            if T > 0.0:
                t0 = phase * T
            else:           # time matters not (autonomous), or has no phase (NaN)
                t0 = np.where(np.isfinite(phase) & autonomous(system), 0.0, np.nan)
            ok = np.isfinite(carry[p]).all(axis=-1) & np.isfinite(t0)
            for i in np.flatnonzero(ok):
                x = carry[p, i, :n2 // 2]
                for c in system.contacts:
                    ob = ContactObstacle(c.obstacle, c.kappa, c.beta, c.omega)
                    j, _ = ob.piece_at(t0[i])
                    if not np.dot(c.gap, x) - ob.state(j, t0[i])[0] > 0.0:
                        ok[i] = False
            ics[p, :, :n2] = np.where(ok[:, None], carry[p, :, :n2], ics[p, :, :n2])
            ics[p, :, n2] = np.where(ok, t0, ics[p, :, n2])
        return ics

    @staticmethod
    def _run_group(systems, which, ics, ints, scene, outs, B):
        """``batch.run_batch`` on the items of systems of one augmented size (``which``:
        each item's index into ``systems``), into ``outs``; each item's gap vectors, its
        first contact's packed obstacle row and derived row (``batch.corner_offsets``), and
        the systems' stacked arrays (``batch.system_arrays``: the stability pass's too)."""
        a = B.system_arrays(systems)
        t_max = np.array([scene.max_periods * time_scale(s) for s in systems], float)
        o_t, o_c, o_x, o_vin, o_vout, st, final, o_off, o_corner = outs
        w = systems[0].words
        period = np.array([system_period(s) for s in systems], float)
        B.run_batch(np.ascontiguousarray(which, dtype=np.int64), a["Es"], a["As"], a["Hs"],
                    a["normAs"], a["cAm"], a["cAsm"], a["Nm"], a["normc"], a["rowsm"], a["dsm"],
                    a["gaps"], a["D"], a["r"], a["soft"], a["f_omega"], a["f_phi"], a["f_const"], ics,
                    ints,
                    scene.tol, scene.chatter, scene.escape, t_max, o_t, o_c, o_x, o_vin, o_vout,
                    st, final, w.impacts if w else -1, w.corners if w else -1, period, o_off,
                    o_corner)
        return a["gaps"][which], a["rows"][which, 0], a["ds"][which, 0], a


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

[output]
keep = ["impacts", "stability"]     # the stability pass, which a sweep's chaos test also runs
"""
# one mass against the rectified sine: the paper's words (``paper_words``: the corner
# offsets and the flow's cycle analysis), which the example's contact letters do not compile
CORNER_WORDS_SCENE = """[scene]
name = "warm_linear_corners"
model = "linear"

[system]
dofs = ["x"]
mass = [1.0]
stiffness = [1.0]

[[system.contact]]
name = "R"
gap = { x = 1.0 }
obstacle = "rectified_sine"
kappa = 0.0
beta = 1.0
omega = 1.8
r = 0.8

[sweep]
"contact.R.kappa" = { values = [0.0, -0.01] }

[initial]
count = 2
seed = 1
x = [1.0, 5.0]
v_x = [-1.0, 1.0]

[run]
transient = 10
record = 8
"""

WARMUPS = (Warmup("linear", "the linear kernel and its stability pass", "sweep", EXAMPLE_SCENE),
           Warmup("linear", "the linear kernel's corner words", "sweep", CORNER_WORDS_SCENE))


MODEL = LinearModel(
    name="linear",
    doc="a linear vibro-impact system declared in the scene's [system] (docs/linear.md)",
    params={},
    state=(),
    system_extra={k: None for k in declare.SYSTEM_KEYS},
    observables={"impacts": BASE_FIELDS},
    opt_in=("stability",),
    continuation=True,
    seed_observable="impacts",
    cycle=IMPACT_CYCLE,
    events_per_impact=40,
    bytes_per_event=8 * 40,
    # impacts per second on one core in a sweep (benchmarks/linear_kernel.py --sweeps: fig06a's
    # system, 1.9 M impacts in 1.7 s on 2 threads, its Python per point included)
    events_per_second=5.5e5,
    warmups=WARMUPS,
    contact_words=True,
)
