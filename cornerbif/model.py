"""What every model provides: the interface the registry holds (``cornerbif.registry``).

A model is one object (a ``Model`` subclass instance) that declares

* its parameters (``Param``: default, allowed range, one-line doc, equation), the
  ``[system]`` table of a scene and the numeric values a ``[sweep]`` may take;
* its state and initial coordinates (``Coord``: the default range of ``[initial]``,
  how a start is drawn, the long names of ``initial/*`` and ``final/*``);
* its observables (the names ``[output] keep`` allows) and the datasets each adds
  to the file (``Field``: name, source array, units, long name);
* its checks (``check``: what a scene of this model must satisfy beyond each value's
  range, e.g. undamped resonance, starts above the obstacle);
* its kernel entry (``pack_values``, ``pack_points``, ``int_settings``, ``run_items``,
  ``kernel``), through which ``cornerbif.simulate(model=name)`` runs it from Python.

Config (``cornerbif.config``), the engine (``cornerbif.engine``), the file schema
(``cornerbif.io``), ``cornerbif info`` and the plots read these declarations; none of
them branches on a model's name.  ``docs/architecture.md`` says which files a new
model or a new obstacle touches.

This module imports neither numba nor h5py: ``cornerbif validate`` stays fast.
"""

from __future__ import annotations

import difflib
import math
import reprlib
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import NamedTuple, Protocol

import numpy as np

# the automatic budgets of a run (config's rule, and a stream's chunks): periods (of the
# slower of the obstacle and the oscillator, see docs/guarantees.md) per transient or
# recorded impact, plus a margin
PERIODS_PER_IMPACT = 50
BUDGET_MARGIN = 1000


def automatic_budgets(events_per_impact: int, impacts: int) -> tuple:
    """(max_events, max_periods) of the automatic rule for ``impacts`` transient and recorded
    impacts of a model with ``events_per_impact`` (uncapped: the callers cap them)."""
    return (events_per_impact * impacts + BUDGET_MARGIN,
            PERIODS_PER_IMPACT * impacts + BUDGET_MARGIN)


# ------------------------------------------------------------------ declarations
@dataclass(frozen=True)
class Param:
    """One numeric parameter of a model's ``[system]`` table (and of ``[sweep]``).

    ``ok`` is the allowed range as a predicate on a finite float; ``allowed`` says
    it in words for messages; ``inf_ok`` admits +inf (the mass ratio mu of law 74);
    ``obstacles`` restricts the parameter to some obstacles (the triangle's slopes);
    a ``default`` of None means "derived from others" (see the model).
    """

    name: str
    default: float | None
    allowed: str
    ok: Callable[[float], bool] = lambda v: True
    doc: str = ""
    equation: str = ""
    inf_ok: bool = False
    obstacles: tuple | None = None

    def problem(self, value, key: str) -> str | None:
        """The message for a bad value at ``key``, or None when the value is allowed."""
        if not is_number(value):
            what = "is too large for a float64" if _is_int(value) else "is not a number"
            return f"{key}: {shown(value)} {what}; {self.name} must be {self.allowed}"
        v = float(value)
        if self.inf_ok and v == math.inf:
            return None
        if not math.isfinite(v):
            return f"{key}: {shown(value)} is not finite; {self.name} must be {self.allowed}"
        if not self.ok(v):
            return f"{key}: {shown(value)} is out of range; {self.name} must be {self.allowed}"
        return None


@dataclass(frozen=True)
class Coord:
    """One coordinate of the state at t = 0 (and of the state a followed sweep carries).

    ``default``: the range ``[initial]`` draws from; ``draw``: the counter of the
    random stream (``engine.uniform``), fixed per coordinate so that starts do not
    depend on the order of declaration; ``floor``: None, ``"wall"`` (drawn above the
    obstacle at t = 0) or the name of another coordinate it is drawn above.
    """

    name: str
    default: tuple
    draw: int
    floor: str | None
    initial_doc: str
    final_doc: str


def start_time_problems(ctx) -> list:
    """A model's ``start_time`` (t0: ``[initial] t``, ``[sweep] initial.t``) must not be
    negative: the problems of a scene's check context ``ctx`` (``config``'s), said with
    their keys."""
    problems = []
    t0 = ctx.ranges.get("t", (0.0, 0.0))
    swept_t = ctx.swept("initial.t")
    if t0[0] < 0.0:
        problems.append(f"initial.t: {list(t0)} must not be negative (the start time t0)")
    if swept_t is not None and min(swept_t.values) < 0.0:
        problems.append(f"sweep.initial.t: {min(swept_t.values)!r} must not be negative "
                        "(the start time t0)")
    return problems


@dataclass(frozen=True)
class Field:
    """One stored dataset of an observable: ``name`` in the file, ``source`` the key of
    the kernel output (``Model.run_items``) it is read from.

    ``axis`` None: one value per recorded event (dims grid + (ic, record)); otherwise one
    value per run, ``()`` alone (grid + (ic,)) or with a trailing axis ``(name, size)``
    (grid + (ic, name)), e.g. the Floquet multipliers of the run's cycle.  ``dtype`` and
    ``fill`` are the dataset's.
    """

    name: str
    source: str
    long_name: str
    units: str | None = None
    axis: tuple | None = None
    dtype: str = "f8"
    fill: float = float("nan")

    def trailing(self, record: int) -> tuple:
        """The dataset's shape after the grid's and the starts' axes."""
        if self.axis is None:
            return (record,)
        return () if not self.axis else (self.axis[1],)


@dataclass(frozen=True)
class Obstacle:
    """A kind of periodic obstacle z(t) = kappa + beta g(omega t) of the ``flow`` model: its
    declaration and its Python side.  Each kind is one module of ``cornerbif/obstacles``
    (registered in ``obstacles.OBSTACLE_MODULES``) defining ``OBSTACLE``, an instance of this
    class or of a subclass that overrides the methods below; its jitted pieces are
    ``obstacles/dispatch.py``'s branches on its code, the only place that reads a code.

    Declared facts: ``code`` (the packed parameter ``OBSTACLE`` the kernels read),
    ``formula``, ``period_pi`` (the period in units of pi/omega), ``pieces`` (smooth pieces
    per period: the certified search works piece by piece), and what it can do:

    * ``corners``: the slope jumps between pieces (corner offsets and cluster symbols exist);
    * ``normal_form``: the corner normal form of sections 4-5 (the maps alpha, beta, gamma,
      the closed forms of ``theory``: kappa_C, kappa_CC, omega_C, omega_CC) is derived for it;
    * ``auto_section``: its attractors near omega = 2 have one cluster every second corner,
      and the Poincare section's corners are put between the clusters (``models.flow.kernel``);
    * ``word_seeds``: a bare word of cluster letters seeds a periodic orbit (continuation);
    * ``continuation``: the flow's orbit problem applies (``models/flow/orbit.py``);
    * ``corner_wedge``: one corner per period at its start with a slope on each side, the
      wedge of eq (7) (``[plot] kind = "obstacle"``);
    * ``params``: its own ``Param``s (the triangle's slopes); ``tables``: its own
      ``[system]`` tables (a cam's ``profile``), read by ``read_tables``;
    * ``own_kernel``: its packed rows are longer (``NPARAM_PROFILE``) and run on a kernel of
      their own (``models.flow.kernel.run_batch_profile``).
    """

    name: str
    code: int
    formula: str
    period_pi: int
    pieces: int
    corners: bool
    normal_form: bool = False
    auto_section: bool = False
    word_seeds: bool = False
    continuation: bool = True
    corner_wedge: bool = False
    params: tuple = ()
    tables: tuple = ()
    own_kernel: bool = False

    @property
    def corner_each_piece(self) -> bool:
        """Every piece starts at a corner (one smooth piece per period, with corners)."""
        return self.corners and self.pieces == 1

    # ``table`` below is what ``read_tables`` read from the scene (``Scene.obstacle_table``: a
    # cam), None for a kind without tables
    def period(self, omega: float, table=None) -> float:
        """The period of z(t) at frequency omega."""
        return self.period_pi * math.pi / omega

    def pieces_per_period(self, table=None) -> int:
        return self.pieces

    def section_period(self, omega: float, table=None) -> float:
        """The Poincare section's period when the scene gives none: T = 2 pi / omega."""
        return 2.0 * math.pi / omega

    def read_tables(self, system: dict, w) -> None:
        """Read this kind's own ``[system]`` tables into the scene being read (``w``), adding
        each problem to ``w.problems``."""

    def check_scales(self, w, axes) -> None:
        """Problems of the kind at the scene's extreme parameter values (``w.problems``)."""

    def pack_rows(self, rows: np.ndarray, values: dict, table=None) -> None:
        """Write the kind's own slots of packed rows (the triangle's slopes, a cam's table);
        ``values`` maps each named parameter to one value or one per row."""

    def top(self, ctx) -> float | None:
        """The obstacle's highest point over a period at the scene's largest kappa and beta,
        or None when unknown."""
        return max(ctx.values_list("kappa")) + max(ctx.values_list("beta"))

    def height_at_zero(self, ctx, kappa: float) -> tuple:
        """(z(0) at the largest kappa and beta, the words that name it): kappa for a kind whose
        g(0) = 0."""
        return kappa, "kappa"

    def corner_at_start(self, row: np.ndarray, j: int) -> bool:
        """Whether piece j of a packed row starts at a corner (its slope jumps there): every
        joint of a kind with corners, none of one without."""
        return self.corners

    def start_heights(self, rows: np.ndarray) -> np.ndarray | None:
        """z(0) per packed row of this kind, computed without a kernel, where g(0) may differ
        from 0 (a cam); None: z(0) = kappa."""
        return None

    def marks(self, ax, axes: tuple, values: dict, system: dict) -> list:
        """What a diagram of this kind's scene marks on its swept axis beyond the normal form's
        corner points (matplotlib artists on ``ax``; ``axes`` the file's swept names,
        ``values`` their values, ``system`` its [system] table)."""
        return []

    def resonant_amplitude(self, values: dict) -> float | None:
        """The amplitude b of a closed-form orbit u = b |sin t| at these values, where the
        kind has one (the smooth wall's eq 6), else None."""
        return None

    def has_corners(self, table=None) -> bool:
        """Whether its runs have corners (a cam's: where some joint's slope jumps)."""
        return self.corners

    def corner_places(self, rows: np.ndarray, ids: np.ndarray, has: np.ndarray) -> np.ndarray:
        """``impacts/corner``: the place of each impact's corner among its period's corners,
        from the kernel's corner ids (``obstacles.dispatch.corner_of``) where ``has`` (an
        impact with corners): 0 for a kind with one corner per period."""
        return np.zeros(ids.shape, np.int64)

    def speed(self, values: dict, table=None) -> float:
        """The obstacle's largest speed |z'| at one grid point: beta omega for a kind whose
        |g'| is at most 1."""
        return float(values["beta"]) * float(values["omega"])


@dataclass(frozen=True)
class NormalFormSide:
    """A model's part in the figures of sections 4-5 that set an impacting system beside its
    corner normal form in the (a0, b1) plane (``plot_normal_form``; Figs 9-11, 16).

    ``maps``: this model is the local maps alpha, beta, gamma (else the impacting system they
    are the normal form of); ``panel``: how a figure names its panel; ``order``: its place
    from left to right; ``first_return``: the recorded section slot that holds a start's
    first return A0 (run.transient = 0: a map's slot 0 is its start itself).  A subclass in
    the model's folder says which map acts on what the model recorded (``start_regions``,
    ``point_regions``)."""

    maps: bool
    panel: str
    order: int
    first_return: int

    def start_regions(self, data, omega: float, omega1: float, kappa1: float, r: float) -> tuple:
        """(the letter 'a', 'b', 'g' or 'x' of the map acting on each start of a file, the
        words that say how it was found)."""
        raise NotImplementedError

    def step(self, a: float, b: float, omega1: float, kappa1: float, r: float) -> tuple:
        """One step of the maps from x = (a, b) (the maps' side): (a', b', region code)."""
        raise NotImplementedError

    def region(self, a: float, b: float, omega1: float, kappa1: float, r: float) -> int:
        """The code of the map acting on x = (a, b) (the maps' side)."""
        raise NotImplementedError

    def point_regions(self, a, b, omega1: float, kappa1: float, r: float):
        """The letter of the map acting on each recorded section point (a, b), or None where
        the model has no regions of its own (a flow has only its word)."""
        return None


# a start coordinate's name on a sweep axis or in a file: ``initial.u``, ``initial.t``, ...
IC_PREFIX = "initial."


@dataclass(frozen=True)
class FigureKind:
    """A ``[plot] kind`` of ``cornerbif plot``: one module of ``cornerbif/figures`` (registered
    in ``figures.FIGURE_MODULES``) defining ``FIGURE``, an instance of a subclass.

    ``doc``: what it draws, in words; ``files``: which files one figure of it draws, checked
    by ``plot.check_together`` before anything is drawn: "diagram" (swept files overlaid, a
    chart or a basin), "one" (one file) or "single_runs" (a file of single runs, or a flow
    beside its map).  ``check`` says what a scene must hold for it (``cornerbif validate``
    asks it); ``draw`` draws the checked files into ``out``.  A kind module's top level
    loads neither matplotlib nor h5py nor a kernel: checking a scene stays fast."""

    name: str
    doc: str
    files: str = "diagram"
    one_axis: bool = False     # its file is swept over exactly one parameter
    same_starts: bool = False  # a flow beside its map: both files run from the same starts
    colors_by: bool = False    # ``[plot] color_by`` colours its points by their stability
    explained: bool = False    # it draws the branch table that ``cornerbif explain`` stores

    def check(self, w) -> list:
        """Problems of the scene being read (``config``'s walk ``w``: its ``spec``, ``axes``,
        ``keep``, ``obstacle``, ``run_setting``) for this kind."""
        return []

    def draw(self, plt, datas: list, out: str, y, title, plot_cfg: dict, color_by, branches):
        """Draw the files ``datas`` (``plot_base.PlotData``; continuation files ``branches``
        over them where the kind draws them) into ``out``, whole or not at all."""
        raise NotImplementedError


@dataclass(frozen=True)
class CycleSeries:
    """What names a run's cycle in the attractor table (``cornerbif.attractors``): two
    recorded series (kernel outputs ``a`` and ``b``, the file's ``names``), read over the
    run's last cycle: ``per`` "impacts" (``impacts_per_cycle`` entries) or "period"
    (``period`` entries, one per section crossing or map iterate); the recorded window
    ends at the first NaN of the output ``end``."""

    end: str
    a: str
    b: str
    per: str
    names: tuple
    long_names: tuple


# ------------------------------------------------------------------ the interface
@dataclass(frozen=True)
class Model:
    """The interface every model implements (one instance per model in the registry).

    Data (declared): ``name``, ``doc``, ``params`` (name -> Param, in the order of
    the scene's ``[system]``), ``state`` (the Coords, in the kernel's state order),
    ``observables`` (keep name -> tuple of Fields), ``system_extra`` (non-numeric
    ``[system]`` keys: name -> default), ``obstacles`` (name -> Obstacle, ``flow``
    only), ``events_per_impact`` (the automatic event budget per recorded or transient
    impact), ``early_stop`` (``run.stop = "period"`` is implemented), ``streams_lyapunov``
    (``run.lyapunov_impacts`` is implemented: ``run_items`` streams the exponents),
    ``timeseries``
    (``[plot] kind = "timeseries"`` can rebuild its flights), ``normal_form``
    (a ``NormalFormSide`` or None: its part in the flow-against-map figures of sections 4-5),
    ``default_y`` (the diagram's default y), ``keep_hint`` (said when a scene asks for
    an observable the model lacks), ``bytes_per_event`` (working memory per item and
    recorded event, counted from the arrays ``run_items`` allocates; the peak memory of a
    large sweep against the estimate: ``benchmarks/same_output.py --peak-memory``),
    ``events_per_second`` (impacts, or map steps, per second on one core, as
    ``benchmarks/run.py`` measured them: the time estimate of ``--dry-run``), ``opt_in``
    (observables kept only when ``[output] keep`` names them: a scene without ``keep``
    keeps the others), ``continuation`` (``cornerbif continue`` solves and continues the
    model's periodic orbits: ``cornerbif.continuation``), ``seed_observable`` (what a
    sweep file must keep for ``orbit_seed`` to read a run: ``[continue] seed_file``),
    ``cycle`` (``CycleSeries``: the recorded values that tell one attractor from another
    with the same word, ``cycle/signature`` and ``cycle/point`` in the file),
    ``start_time`` (a ``Coord`` for the time t0 at which each run starts, the obstacle's
    phase at the start: a start coordinate beside the state, ``[initial] t`` and
    ``[sweep] initial.t``, the kernel's last start column; not carried by ``follow``),
    ``axis_labels`` (a figure's labels of its own axes and diagram values where they are not
    the flow's: the maps' start (a_0, b_1) and section (a_n, b_n)), ``warmups`` (``Warmup``s:
    tiny scenes whose runs compile what a first run of the model compiles, for ``cornerbif
    warm``), ``contact_words`` (its words are its contacts' names, a linear system's, not
    the corner clusters' a, b, g, x: no winding number).

    Methods (implemented by each model): ``check`` (and ``check_point``, the same checks
    at one point, for ``simulate``), ``wall_at_start``, ``pack_values``, ``pack_points``,
    ``int_settings``, ``run_items``, ``kernel``.  From Python every model runs through
    the one ``cornerbif.simulate(*starts, model=name, ...)`` (``cornerbif/api.py``), which
    validates as a scene and calls these methods.
    """

    name: str
    doc: str
    params: dict
    state: tuple
    observables: dict
    system_extra: dict = field(default_factory=dict)
    obstacles: dict = field(default_factory=dict)
    events_per_impact: int = 10
    early_stop: bool = False
    streams_lyapunov: bool = False     # run.lyapunov_impacts: its stability pass streams the
    #                                    exponents over any number of impacts (run_items)
    timeseries: bool = False
    normal_form: NormalFormSide | None = None
    default_y: str | None = None
    keep_hint: str = ""
    bytes_per_event: int = 72
    events_per_second: float = 1e6
    opt_in: tuple = ()
    continuation: bool = False
    seed_observable: str = ""
    cycle: CycleSeries | None = None
    start_time: Coord | None = None
    axis_labels: dict = field(default_factory=dict)
    warmups: tuple = ()
    contact_words: bool = False
    carried: tuple = ()        # Coords written as final/<c> after the state's, carried by
    #                            follow with it (the linear model's phase of its final state)
    # the obstacle kind whose corners, corner curves and marks a figure draws for a file of
    # this model whose [system] names none (None: the model has no one obstacle, linear's)
    drawn_obstacle: str | None = None
    # a model declared by its scene's [system] (the linear model): its method
    # ``for_system(table)`` gives (the model of that table, problems); ``system_table`` is that
    # table, which the scene as run writes back (``system_table_with``).  None for a model
    # declared once for all scenes.
    for_system = None
    system_table: dict | None = None

    def given_problem(self, names) -> str | None:
        """A problem of the parameters ``names`` given together (``cornerbif.simulate``'s
        keywords), or None (a model declared by its scene: a matrix entry and its mirror)."""
        return None

    def system_table_with(self, values: dict) -> dict:
        """The ``[system]`` table of a model declared by its scene, with ``values`` (its
        numbers by path) written in: the scene as run."""
        raise NotImplementedError

    def seed_letters(self) -> str | None:
        """The letters of a ``[continue] seed`` word where the model's words are not the
        corner clusters' a, b, g, x (a linear system's contacts' names), read case kept by
        ``cycles.parse_word(..., alphabet=...)``; None (every model but those): the clusters'
        letters."""
        return None

    # --- declared facts, derived ------------------------------------------------------
    @property
    def coords(self) -> tuple:
        return tuple(c.name for c in self.state)

    @property
    def finals(self) -> tuple:
        """What ``final/<c>`` holds and a followed sweep carries: the state, then
        ``carried``."""
        return self.state + self.carried

    @property
    def starts(self) -> tuple:
        """The start coordinates: the state's, then the start time where the model has one."""
        return self.state + ((self.start_time,) if self.start_time is not None else ())

    @property
    def start_names(self) -> tuple:
        return tuple(c.name for c in self.starts)

    def coord(self, name: str) -> Coord:
        return next(c for c in self.starts if c.name == name)

    def fields(self, keep) -> list:
        """The per-event datasets of the observables in ``keep``, in the file's order."""
        return [f for k in self.observables if k in keep for f in self.observables[k]]

    def obstacle_of(self, scene):
        """The scene's Obstacle declaration (None for a model without obstacles)."""
        return self.obstacles.get(scene.extra.get("obstacle")) if self.obstacles else None

    def has_normal_form(self, obstacle: str | None) -> bool:
        """Whether the (a0, b1)-plane figures of sections 4-5 apply to this model and
        obstacle."""
        if self.normal_form is None:
            return False
        if self.normal_form.maps:
            return True
        ob = self.obstacles.get(obstacle) if self.obstacles else None
        return ob is not None and ob.normal_form

    # --- behaviour: every model implements these -------------------------------------
    def check(self, ctx) -> list:
        """Problems of a scene beyond each value's own range (``config.CheckContext``)."""
        return []

    def check_point(self, values: dict) -> str | None:
        """The problem of the parameter values at one point, or None."""
        return None

    def wall_at_start(self, params: np.ndarray) -> np.ndarray:
        """Per packed row, the height of the obstacle at t = 0 (starts are drawn above it)."""
        raise NotImplementedError

    def wall_at(self, params: np.ndarray, t0: np.ndarray) -> np.ndarray:
        """Per packed row and start time (shape (n, n_ic)), the obstacle's height at t0
        (models with a ``start_time``)."""
        raise NotImplementedError

    def starts_from_carry(self, carry, ics, wall, params) -> np.ndarray:
        """A followed sweep's starts at a slab: ``ics`` (points, n_ic, start size) as drawn,
        where ``carry`` (points, n_ic, len(finals)), the previous slab's final states, lies
        above the obstacle at t = 0 (``wall``, per point), replaced by it, started at t = 0
        (a section corner: the flow's final state is at a section)."""
        ok = np.isfinite(carry).all(axis=-1) & (carry[..., 0] > wall[:, None])
        ns = carry.shape[-1]
        ics[..., :ns] = np.where(ok[..., None], carry, ics[..., :ns])
        ics[..., ns:] = np.where(ok[..., None], 0.0, ics[..., ns:])
        return ics

    def pack_values(self, values: dict, scene) -> np.ndarray:
        """The packed parameter row of named values at one point."""
        raise NotImplementedError

    def impact_reference(self, system: dict, values: dict, rows, grid: tuple, contact):
        """For a diagram's impact heights: per recorded impact, the height it is measured
        from, where the model's own differs from the scene's ``kappa`` (None: u - kappa, the
        height above the corners of z = kappa + beta |sin omega t|).  ``system``: the file's
        ``[system]``; ``values``: each swept axis's values, in the file's axis order; ``rows``:
        the slab of the first axis drawn; ``grid``: that slab's grid shape; ``contact``: its
        ``impacts/contact`` (grid + (starts, record)), None where the file has none."""
        return None

    def pack_points(self, scene, index_list) -> np.ndarray:
        """Packed parameter rows (n, NPARAM) for grid indices: ``pack_values`` at each."""
        return np.stack([self.pack_values(scene.point(idx), scene) for idx in index_list])

    def int_settings(self, scene) -> np.ndarray:
        """The kernel's integer settings (transient, record, budgets)."""
        raise NotImplementedError

    def run_items(self, params, ics, ints, scene) -> RunResult:
        """Kernel and cycle analysis on n items (``RunResult``)."""
        raise NotImplementedError

    def kernel(self):
        """The compiled kernel entry (for the cold-cache notice)."""
        raise NotImplementedError

    def time_series(self, scene, values: dict, t, u, v_out, t_start: float, t_stop: float) -> dict:
        """A recorded run's flights rebuilt between its impacts (models with ``timeseries``):
        ``t``, ``u`` and the obstacle ``z`` sampled over [t_start, t_stop], ``meet`` the
        distance of each flight's end from the next recorded impact, ``p``, ``d`` the packed
        row and its derived constants."""
        raise NotImplementedError

    def word_seed(self, values: dict, scene, param: str, word: str, simulate):
        """A periodic-orbit problem and its solved unknowns for a cycle word that no start
        reached (stable or not), where the model can build one; ``simulate`` is
        ``cornerbif.simulate``, handed down by the caller (a model runs no scene itself)."""
        raise NotImplementedError(f"model {self.name!r} seeds orbits from attractors only")

    def orbit_seed(self, values: dict, scene, param: str, word: str, run: dict):
        """A periodic-orbit problem of ``cornerbif.continuation`` and its solved unknowns,
        from one run's record at the continuation's start (models with
        ``continuation = True``)."""
        raise NotImplementedError

    def orbit_from_doc(self, doc: dict):
        """The periodic-orbit problem that the problem's ``to_doc`` wrote (a partial file's
        resume state)."""
        raise NotImplementedError


class Warmup(NamedTuple):
    """A tiny scene that ``cornerbif warm`` runs to compile a model's kernels ahead of a first
    run (``cornerbif.warm``): ``group`` (warm-ups of one group run in order in one process,
    groups side by side), ``label`` (what it compiles, as said to the user), ``command``
    ("sweep" or "continue") and ``scene`` (its TOML text: a few runs, the kernels' real
    argument types)."""

    group: str
    label: str
    command: str
    scene: str


# ------------------------------------------------------------------ a run's result
class RunResult(NamedTuple):
    """What ``Model.run_items`` returns for n items.

    ``fields``: the run's recorded series, keyed by the ``source`` of the model's ``Field``s
    (and of its ``CycleSeries``), each an array of n rows: a model keeps only what it
    declares; ``status`` (n,) the ``status`` codes; ``final`` (n, state size) the state at
    the last section crossed, in the model's ``state`` order; ``period`` (n,) and ``ipc`` (n,)
    the cycle's period and its impacts per cycle (``analysis.detect_cycles``); ``symbols``
    (n, record) the cycle's letters."""

    fields: dict
    status: np.ndarray
    final: np.ndarray
    period: np.ndarray
    ipc: np.ndarray
    symbols: np.ndarray


# ------------------------------------------------------------------ orbit problems
class OrbitProblem(Protocol):
    """What ``cornerbif.continuation`` asks of a model's periodic-orbit problem (one
    itinerary of one model: ``models/<name>/orbit.py``), built by the model's
    ``orbit_seed``, ``word_seed`` and ``orbit_from_doc``.  X is the problem's unknowns (2 per
    impact or event), ``lam`` the value of the continued parameter ``param``; ``values`` holds
    the scene's other [system] values.

    * the equations: ``residual(X, lam)`` (length len(X)), ``jacobian(X, lam)`` (dR/dX),
      ``d_param(X, lam)`` (dR/dlam); ``n`` the number of impacts of one cycle;
    * the monitors along a branch: ``floquet(X, lam)`` -> (multipliers, monodromy),
      ``corner_distances(X, lam)`` (one signed distance per impact to its corner; a sign
      change is a corner collision), ``smallest_gap(X, lam)`` (the smallest gap of a flight to
      the obstacle: grazing), ``impacts(X, lam)`` (a dict of arrays ``t``, ``v_in``, ...),
      ``admissible(X, lam)`` -> (ok, why not);
    * the attractor table's series (``Model.cycle``) over one cycle of the orbit:
      ``cycle_series(X, lam)`` -> (a, b), which ``cornerbif.branches`` compares with the
      table's signatures;
    * the itinerary: ``word(X, lam)``, ``itinerary()``, ``reindex(X, lam)`` (bookkeeping that
      is not an event) and ``across(q, X, lam)`` (the problem with impact q on the far side of
      the corner it reached, and its X);
    * the file: ``store(X, lam, section)`` (a point's record), ``to_doc()`` (plain data with
      ``type`` = the model's name, read back by ``Model.orbit_from_doc``);
    * two-parameter curves (``continuation.corner_curve``, ``fold_curve``) need nothing more:
      a problem that has ``piece_length(q, lam)`` (the flow) holds its impact at the corner
      exactly, any other adds its corner distance = 0 as an equation (``EventCurve``);
      ``rebased(values, param)`` where ``dataclasses.replace`` of ``values`` and ``param``
      is not enough.
    """

    param: str
    values: dict
    n: int

    def residual(self, X: np.ndarray, lam: float) -> np.ndarray: ...

    def jacobian(self, X: np.ndarray, lam: float) -> np.ndarray: ...

    def d_param(self, X: np.ndarray, lam: float) -> np.ndarray: ...

    def floquet(self, X: np.ndarray, lam: float): ...

    def corner_distances(self, X: np.ndarray, lam: float) -> np.ndarray: ...

    def smallest_gap(self, X: np.ndarray, lam: float) -> float: ...

    def impacts(self, X: np.ndarray, lam: float) -> dict: ...

    def admissible(self, X: np.ndarray, lam: float) -> tuple: ...

    def cycle_series(self, X: np.ndarray, lam: float) -> tuple: ...

    def word(self, X: np.ndarray, lam: float) -> str: ...

    def itinerary(self) -> str: ...

    def reindex(self, X: np.ndarray, lam: float) -> tuple: ...

    def across(self, q: int, X: np.ndarray, lam: float) -> tuple: ...

    def store(self, X: np.ndarray, lam: float, section) -> dict: ...

    def to_doc(self) -> dict: ...


# ------------------------------------------------------------------ small shared helpers
# a value quoted in a message is cut to this many characters (a 50 MB title, a list of a
# million entries or an integer of 4000 digits is named by its start and its size)
SHOWN_CHARS = 80
# a key as a message names it (a key of a megabyte is a key)
KEY_CHARS = 60


def _is_int(x) -> bool:
    return isinstance(x, int) and not isinstance(x, bool)


class _Shown(reprlib.Repr):
    """``reprlib`` with the sizes said: a long string, list or table is cut and its length
    given; an integer past ``maxlong`` digits is named by its number of digits."""

    def __init__(self, limit):
        super().__init__()
        self.maxlevel = 3
        self.maxlist = self.maxtuple = self.maxdict = self.maxset = 8
        self.maxstring = self.maxother = self.maxlong = limit

    def repr_int(self, x, level):
        if x.bit_length() > 4 * self.maxlong:       # no repr past 4300 digits, and slow
            d = int(x.bit_length() * math.log10(2)) + 1     # exact, or one too many
            d -= abs(x) < 10 ** (d - 1)
            return f"<an integer of {d} digits>"
        return super().repr_int(x, level)

    def repr_str(self, x, level):
        return cut(x, self.maxstring, quote=True)

    def repr_list(self, x, level):
        s = super().repr_list(x, level)
        return s[:-1] + f" <{len(x)} entries>]" if len(x) > self.maxlist else s

    def repr_dict(self, x, level):
        s = super().repr_dict(x, level)
        return s[:-1] + f" <{len(x)} keys>}}" if len(x) > self.maxdict else s


def cut(text, limit: int = SHOWN_CHARS, *, quote: bool = False, mark: str | None = None) -> str:
    """``text`` (a str, or what ``str`` makes of anything else) for a message or a figure:
    its first ``limit`` characters on one line, line breaks, tabs and other control
    characters (a terminal's escapes) as spaces, or quoted as ``repr`` quotes them
    (``quote``); a longer text ends with ``mark`` (default: "...<N characters>", its
    length).  Reads no more of ``text`` than it shows (a key of a megabyte costs nothing)."""
    if not isinstance(text, str):
        try:
            text = str(text)
        except (ValueError, RecursionError):    # an integer past 4300 digits, a deep list
            return f"<a {type(text).__name__} too large to show>"
    head = text[:limit]
    head = repr(head) if quote else "".join(c if c.isprintable() else " " for c in head)
    if len(text) <= limit:
        return head
    return head + (f"...<{len(text)} characters>" if mark is None else mark)


def did_you_mean(word, options) -> str:
    """ " (did you mean 'x'?)" for a near miss among ``options``; nothing for a word far
    longer than any option (difflib's cost grows with it)."""
    if len(word) > 100:
        return ""
    m = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    return f" (did you mean '{m[0]}'?)" if m else ""


def shown(x, limit: int = SHOWN_CHARS) -> str:
    """``repr(x)`` for a message, cut to about ``limit`` characters with the size of what
    was cut: never the whole of a huge value, and never an error of its own (an integer
    past Python's 4300 digits has no repr; a list nested thousands deep overflows it)."""
    try:
        s = _Shown(limit).repr(x)
    except (ValueError, RecursionError):
        return f"<a {type(x).__name__} too large to show>"
    return s if len(s) <= 2 * limit else s[:2 * limit] + "...>"


def shown_path(path, limit: int = SHOWN_CHARS) -> str:
    """A path for a message, quoted: whole up to ``limit`` characters, else its start and
    its end around the size of what was cut (a file is known by its name: a long temporary
    folder must not hide it)."""
    text = str(path)
    if len(text) <= limit:
        return repr(text)
    k = limit // 2
    return f"{cut(text, k, quote=True, mark='')}...<{len(text)} characters>...{cut(text[-k:], k, quote=True)}"


def is_number(x) -> bool:
    """An int or a float (not a bool) that a float can hold (10**400 cannot)."""
    if not isinstance(x, (int, float)) or isinstance(x, bool):
        return False
    try:
        float(x)
    except OverflowError:
        return False
    return True


def positive(v):
    return v > 0


def frequency(v):
    """A frequency: positive, with a finite period (2 pi / 5e-324 overflows to inf)."""
    return v > 0 and math.isfinite(2.0 * math.pi / v)


FREQUENCY = "> 0 (its period 2 pi / value finite)"


def nonnegative(v):
    return v >= 0


def unit_interval(v):
    return 0.0 <= v <= 1.0


def anything(v):
    return True
