"""Scenes: TOML text -> frozen, validated ``Scene`` objects.

Every problem of a scene is collected and reported at once, each with its
dotted key, the offending value and what is allowed (STYLE example 7)::

    sweep.omgea: unknown parameter of model 'flow' (did you mean 'omega'?)

``from_dict`` walks the declared tables in order (``READERS``: [scene], [system],
[sweep], [initial], [run], [output], [plot]); the model registry
(``cornerbif.registry``) supplies what [system], [sweep], [initial] and [output]
allow, and each model's own cross-checks (``Model.check``).  No table reader
branches on a model's name.  The public format (keep these names) is documented
in README.md.
"""

from __future__ import annotations

import difflib
import hashlib
import math
import tomllib
from dataclasses import dataclass, field

import numpy as np

from . import registry
from .model import is_number as _is_number

FOLLOW = ("none", "up", "down")

RUN_DEFAULTS = {
    "transient": 500,
    "record": 100,
    "tol": 1e-12,
    "chatter": 1e-6,
    "escape": 1e6,
    "period_tol": 1e-6,
    "max_events": None,
    "max_periods": None,
    "stop": None,
}
# Accuracy presets (``run.preset``): the speed-accuracy trade made explicit.  Keys given
# explicitly in [run] override the preset.  "paper" is the default and holds the values
# every paper scene was drawn with.  The numbers behind each preset are measured by
# ``benchmarks/run.py`` (sections "transient", "chatter", "tolerance"; see
# benchmarks/README.md): what each preset costs and how far its diagram is from one drawn
# with a very long transient.
PRESETS = {
    "fast": {"transient": 300, "tol": 1e-8, "chatter": 1e-4},
    "paper": {"transient": 500, "tol": 1e-12, "chatter": 1e-6},
    "precise": {"transient": 3000, "tol": 1e-14, "chatter": 1e-6},
}
DEFAULT_PRESET = "paper"
# run.stop: "period" ends each run once its attractor's period is established (the kernel's
# early stop, models with Model.early_stop); the default is "period" for such a scene that
# keeps only the summary (output.keep = []) and "none" otherwise
STOPS = ("none", "period")
# the automatic time budget: periods (of the slower of the obstacle and the oscillator, see
# docs/guarantees.md) per transient or recorded impact, plus a margin
PERIODS_PER_IMPACT = 50
BUDGET_MARGIN = 1000
INITIAL_DEFAULTS = {"count": 8, "seed": 1}
# Sizes, checked before anything is allocated (each limit says why it is there):
# values of one axis: the scene as run lists every value (the file's ``scene`` attribute)
MAX_AXIS_VALUES = 100_000
# grid points: the done mask and the block list grow with them (~200 bytes a grid row)
MAX_GRID_POINTS = 100_000_000
# starts per grid point: the counter-based draw keys a start by point * 2^20 + start
# (engine.uniform), so more would repeat starts
MAX_STARTS = 2**20
# recorded events: the word of a cycle is a fixed-length string of record // 2 bytes whose
# fill value lives in the dataset's HDF5 object header (at most 64 KiB)
MAX_RECORD = 100_000
# integers the kernels hold in int64 (transient, budgets, seed): below 2^62, so that the
# automatic budgets (a multiple of transient + record) and the time budget in pieces fit
MAX_INT = 2**62
# the time budget: the kernels count it in smooth pieces of the obstacle (a few per period)
MAX_PERIODS = 2**58
PLOT_KEYS = ("y", "xlim", "ylim", "marker_size", "title", "kind", "point", "ic", "cycles",
             "max_panels", "color_by", "style", "marks", "orbits")
# [plot] color_by: a diagram's or a chart's colour from the stability observable
PLOT_COLOR_BY = ("lyapunov", "multiplier")
PLOT_Y = ("impact_u", "impact_v", "impact_height", "section_u", "section_v", "winding",
          "period")
# [plot] kind: what ``cornerbif plot`` draws from the file (cornerbif/plot.py)
PLOT_KINDS = ("diagram", "timeseries", "corner_curves", "obstacle", "regions", "return_map",
              "orbit", "fractions")
# the (a0, b1)-plane figures of the corner normal form (sections 4-5)
NORMAL_FORM_KINDS = ("regions", "return_map", "orbit")


# [sweep] initial.<coordinate>: an axis over a coordinate of the start (issue 19)
IC_PREFIX = "initial."


def sweep_items(sweep: dict):
    """The (axis name, spec) pairs of a raw [sweep] table, "follow" aside: parameters by
    name, start coordinates as "initial.<c>" (the TOML ``initial.u = {...}``, a nested
    table)."""
    out = []
    for k, spec in sweep.items():
        if k == "follow":
            continue
        if k == "initial" and isinstance(spec, dict) and all(isinstance(v, dict)
                                                             for v in spec.values()):
            out += [(IC_PREFIX + c, s) for c, s in spec.items()]
        else:
            out.append((k, spec))
    return out


def _union(seqs):
    out = []
    for s in seqs:
        out += [x for x in s if x not in out]
    return tuple(out)


def _all_models():
    return registry.models().values()


MODELS = registry.names()
# every observable any model has, in the file's order
KEEP = _union(m.observables for m in _all_models())
# what a scene without [output] keep keeps: every observable but the opt-in ones
KEEP_DEFAULT = tuple(k for k in KEEP if not any(k in m.opt_in for m in _all_models()))
OBSTACLES = tuple(registry.get(registry.DEFAULT_MODEL).obstacles)
TABLES = {
    "scene": ("name", "title", "model"),
    "system": _union(tuple(m.params) + tuple(m.system_extra) for m in _all_models()),
    "sweep": None,  # parameter names + 'follow'
    "initial": tuple(INITIAL_DEFAULTS) + _union(m.start_names for m in _all_models()),
    "run": ("preset",) + tuple(RUN_DEFAULTS),
    "output": ("keep",),
    "plot": PLOT_KEYS,
    "continue": ("parameter", "range", "start", "seed", "seed_file", "ds", "ds_min", "ds_max",
                 "events", "switch", "curve", "curve_range", "over"),
}
# [continue] events: what cornerbif continue watches on a branch (cornerbif.continuation)
CONTINUE_EVENTS = ("corner", "grazing", "zero_velocity", "fold", "period_doubling", "torus")


class SceneError(ValueError):
    """A scene that cannot be run; ``problems`` lists every problem found."""

    def __init__(self, problems):
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))


@dataclass(frozen=True)
class Axis:
    """One swept parameter: its name and its values (in increasing order)."""

    name: str
    values: tuple

    @property
    def array(self) -> np.ndarray:
        return np.asarray(self.values, dtype=float)


@dataclass(frozen=True)
class Scene:
    """A validated scene, every default resolved.

    Attributes
    ----------
    name, title : the ``[scene]`` table (name also names the default output file).
    model : the registered model's name (``cornerbif.registry``).
    obstacle : ``system.obstacle`` for models with obstacles (``flow``), else the
        default obstacle name (unused).
    system : dict of the fixed numeric parameters (every declared parameter; a
        derived default such as theta1 may be None).
    section_period : Poincare section period (None: the model's default).
    axes : tuple of ``Axis``, none, one (a diagram) or two (a parameter plane).
    follow : "none", "up" or "down": carry each attractor along the first axis.
    n_ic, seed : starts per grid point and the seed of their counter-based draw.
    initial : dict coordinate -> (low, high), in the model's state order.
    transient, record : impacts (map steps) discarded, then kept.
    tol, chatter, escape, period_tol : the run tolerances (``[run]``).
    max_events, max_periods : budgets (resolved from the automatic rule when not given).
    keep : the observables stored beyond the per-point summary.
    plot : the ``[plot]`` table as given.
    text : the TOML text as run (defaults made explicit); ``hash`` is its SHA-256.
    preset : the ``run.preset`` the run settings were resolved from.
    stop : ``run.stop`` resolved: "period" (early stop) or "none".
    cont : the ``[continue]`` table resolved (``cornerbif continue``), empty without one.
    profile : the checked cam profile of ``obstacle = "profile"`` (``models.profile.Profile``),
        else None.
    """

    name: str
    title: str
    model: str
    obstacle: str
    system: dict
    section_period: float | None
    axes: tuple
    follow: str
    n_ic: int
    seed: int
    initial: dict
    transient: int
    record: int
    tol: float
    chatter: float
    escape: float
    period_tol: float
    max_events: int
    max_periods: int
    keep: tuple
    plot: dict = field(default_factory=dict)
    text: str = ""
    preset: str = DEFAULT_PRESET
    stop: str = "none"
    cont: dict = field(default_factory=dict)
    profile: object = None

    @property
    def shape(self) -> tuple:
        return tuple(len(a.values) for a in self.axes)

    @property
    def hash(self) -> str:
        return hashlib.sha256(self.text.encode()).hexdigest()

    @property
    def spec(self):
        """The registered model (``cornerbif.model.Model``)."""
        return registry.get(self.model)

    def point(self, index: tuple) -> dict:
        """Named parameter values at a grid index (swept start coordinates aside)."""
        vals = dict(self.system)
        for a, i in zip(self.axes, index):
            if not a.name.startswith(IC_PREFIX):
                vals[a.name] = a.values[i]
        return vals

    @property
    def start_axes(self) -> dict:
        """Swept start coordinates: coordinate -> (axis position, values)."""
        return {a.name[len(IC_PREFIX):]: (i, a.array) for i, a in enumerate(self.axes)
                if a.name.startswith(IC_PREFIX)}


# --------------------------------------------------------------------------- helpers
def _suggest(word, options):
    m = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    return f" (did you mean '{m[0]}'?)" if m else ""


def _is_int(x):
    return isinstance(x, int) and not isinstance(x, bool)


def _fmt(x):
    return repr(x)


def set_dotted(raw: dict, key: str, value):
    """Apply one ``--set a.b.c=value`` override to a raw TOML dict."""
    parts = key.split(".")
    node = raw
    for p in parts[:-1]:
        nxt = node.get(p)
        if not isinstance(nxt, dict):
            nxt = {}
            node[p] = nxt
        node = nxt
    node[parts[-1]] = value


def parse_override(text: str):
    """``key=value`` with value read as a TOML value (strings may be bare)."""
    if "=" not in text:
        raise SceneError([f"--set {text!r}: expected key=value, e.g. --set system.omega=2.001"])
    key, val = text.split("=", 1)
    key = key.strip()
    val = val.strip()
    try:
        v = tomllib.loads(f"x = {val}")["x"]
    except tomllib.TOMLDecodeError:
        v = val
    return key, v


# --------------------------------------------------------------------------- TOML out
# TOML basic strings: backslash, quote and every control character escaped, so any string
# (a title with a NUL or an ESC in it) round-trips and fits an HDF5 attribute
_ESCAPES = {"\\": "\\\\", '"': '\\"', "\b": "\\b", "\t": "\\t", "\n": "\\n", "\f": "\\f",
            "\r": "\\r"}
_ESCAPES.update({chr(c): f"\\u{c:04x}" for c in (*range(0x20), 0x7F) if chr(c) not in _ESCAPES})


def _toml_value(v):
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        if math.isnan(v):
            return "nan"
        if math.isinf(v):
            return "inf" if v > 0 else "-inf"
        return repr(v)
    if isinstance(v, str):
        return '"' + "".join(_ESCAPES.get(c, c) for c in v) + '"'
    if isinstance(v, (list, tuple)):
        if all(type(x) is float for x in v):      # an axis: up to 10^6 values, one repr each
            return "[" + ", ".join(map(repr, v)) + "]"
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, dict):
        return "{ " + ", ".join(f"{k} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


def dumps(raw: dict) -> str:
    """Serialise a scene dict (tables of scalars, lists and inline tables)."""
    out = []
    for table, body in raw.items():
        if not isinstance(body, dict):
            out.append(f"{table} = {_toml_value(body)}")
            continue
        out.append(f"[{table}]")
        for k, v in body.items():
            out.append(f"{k} = {_toml_value(v)}")
        out.append("")
    return "\n".join(out)


def without_plot(text: str):
    """A scene text as a dict without its ``[plot]`` table (None when it is not TOML):
    what a sweep computes, figure settings aside."""
    try:
        d = tomllib.loads(str(text))
    except (tomllib.TOMLDecodeError, RecursionError, ValueError):
        return None
    d.pop("plot", None)
    return d


def same_run(text_a: str, text_b: str) -> bool:
    """Whether two scene texts (as run) compute the same file: equal but for ``[plot]``,
    which only says how the file is drawn, so a figure setting never blocks a resume or
    forces a new sweep."""
    a = without_plot(text_a)
    return a is not None and a == without_plot(text_b)


# --------------------------------------------------------------------------- loading
def load(path, overrides=()) -> Scene:
    """Read a scene file, apply ``--set`` overrides and validate it."""
    try:
        with open(path, "rb") as fh:
            data = fh.read()
    except OSError as e:
        raise SceneError([f"{path}: cannot read the scene file ({e.strerror})"]) from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise SceneError([f"{path}: not UTF-8 text"]) from None
    return loads(text, overrides, source=str(path))


def loads(text: str, overrides=(), source="<scene>") -> Scene:
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise SceneError([f"{source}: TOML syntax error: {e}"]) from None
    problems = []
    given = []
    for ov in overrides:
        try:
            key, val = parse_override(ov) if isinstance(ov, str) else ov
        except SceneError as e:
            problems += e.problems
            continue
        set_dotted(raw, key, val)
        given.append((key, ov if isinstance(ov, str) else f"{key}={val!r}"))
    if problems:
        raise SceneError(problems)
    try:
        return from_dict(raw)
    except SceneError as e:
        raise SceneError([_from_set(p, given) for p in e.problems]) from None


def _from_set(problem: str, given) -> str:
    """Say that a problem comes from a ``--set`` override when its key is one given there."""
    key = problem.split(":", 1)[0].strip()
    for k, text in reversed(given):
        if key == k or key.startswith(k + ".") or k.startswith(key + "."):
            return f"{problem} (from --set {text})"
    return problem


# --------------------------------------------------------------------------- the walk
class _Walk:
    """What the table readers share: the raw tables, the problems found so far and the
    values resolved so far (each reader adds its own)."""

    def __init__(self, raw, drawn=True):
        self.raw = raw
        self.problems = []
        self.drawn = drawn        # starts are drawn from [initial] ranges (not given)

    def table(self, name):
        b = self.raw.get(name, {})
        return b if isinstance(b, dict) else {}

    def unknown(self, name, allowed):
        for k in self.table(name):
            if k not in allowed:
                where = [t for t, keys in TABLES.items() if keys and k in keys and t != name]
                hint = f" (it belongs in [{where[0]}])" if where else _suggest(str(k), allowed)
                self.problems.append(f"{name}.{k}: unknown key{hint}; allowed: {', '.join(allowed)}")

    def param(self, name, value, key):
        p = self.spec.params[name].problem(value, key)
        if p:
            self.problems.append(p)
        return p is None


class CheckContext:
    """What ``Model.check`` sees of a scene: its fixed values, axes, start ranges, the
    problems found so far, and helpers that name a parameter's key and its values."""

    def __init__(self, w):
        self.system = w.system
        self.axes = w.axes
        self.ranges = w.ranges
        self.obstacle = w.obstacle
        self.problems = list(w.problems)
        self.drawn = w.drawn
        self.profile = getattr(w, "profile", None)

    def swept(self, name):
        return next((a for a in self.axes if a.name == name), None)

    def key(self, name):
        return f"sweep.{name}" if self.swept(name) else f"system.{name}"

    def values_list(self, name):
        a = self.swept(name)
        return list(a.values) if a else [self.system.get(name)]

    def values(self, name):
        return set(self.values_list(name))


def _read_scene(w):
    sc = w.table("scene")
    w.unknown("scene", TABLES["scene"])
    name = sc.get("name", "scene")
    if not isinstance(name, str) or not name:
        w.problems.append(f"scene.name: {_fmt(name)} must be a non-empty string")
        name = "scene"
    title = sc.get("title", name)
    if not isinstance(title, str):
        w.problems.append(f"scene.title: {_fmt(title)} must be a string")
        title = str(title)
    model = sc.get("model", registry.DEFAULT_MODEL)
    if model not in MODELS:
        w.problems.append(f"scene.model: {_fmt(model)} is not a model"
                          f"{_suggest(str(model), MODELS)}; allowed: " + ", ".join(MODELS))
        model = registry.DEFAULT_MODEL   # validate the rest as such; the error above stands
    w.name, w.title, w.model = name, title, model
    w.spec = registry.get(model)


def _read_system(w):
    sy = w.table("system")
    spec = w.spec
    w.unknown("system", tuple(spec.params) + tuple(spec.system_extra))
    default_obstacle = registry.get(registry.DEFAULT_MODEL).system_extra["obstacle"]
    obstacle = sy.get("obstacle", spec.system_extra.get("obstacle", default_obstacle))
    if spec.obstacles and not (isinstance(obstacle, str) and obstacle in spec.obstacles):
        allowed = tuple(spec.obstacles)
        w.problems.append(f"system.obstacle: {_fmt(obstacle)} is not an obstacle"
                          f"{_suggest(str(obstacle), allowed)}; allowed: {', '.join(allowed)}")
        obstacle = spec.system_extra["obstacle"]
    system = {}
    for p, decl in spec.params.items():
        v = sy.get(p, decl.default)
        if v is None and decl.default is None:    # a derived default (theta1 = beta omega)
            system[p] = None
            continue
        system[p] = float(v) if w.param(p, v, f"system.{p}") else decl.default
    section_period = sy.get("section_period") if "section_period" in spec.system_extra else None
    if section_period is not None:
        if not _is_number(section_period) or not math.isfinite(section_period) or section_period <= 0:
            w.problems.append(f"system.section_period: {_fmt(section_period)} must be a positive number")
            section_period = None
        else:
            section_period = float(section_period)
    w.profile, w.profile_table = None, None
    if "profile" in spec.system_extra:
        table = sy.get("profile")
        if obstacle == "profile":
            from .models.profile import ProfileError, read
            if table is None:
                w.problems.append("system.profile: obstacle = \"profile\" needs a "
                                  "[system.profile] table (period, pieces; docs/cams.md)")
            else:
                try:
                    w.profile = read(table)
                    w.profile_table = {"period": float(table.get("period", w.profile.period)),
                                       "pieces": table["pieces"]}
                    if "corners" in table:
                        w.profile_table["corners"] = table["corners"]
                except ProfileError as e:
                    w.problems += e.problems
        elif table is not None:
            w.problems.append(f"system.profile: given, but system.obstacle is {obstacle!r}; "
                              "a profile is the obstacle \"profile\"")
    w.obstacle, w.system, w.section_period = obstacle, system, section_period


def _finite_value(w, key):
    """A check of an axis value that is any finite number (a start coordinate)."""
    def check(_, v, where):
        if _is_number(v) and math.isfinite(v):
            return True
        w.problems.append(f"{where}: {_fmt(v)} must be a finite number")
        return False
    return check


def _read_axis(w, k, spec, check=None):
    """The values of one ``[sweep]`` axis, or None after a problem; ``check(name, value,
    key)`` validates a value (default: the parameter's range)."""
    key = f"sweep.{k}"
    check = check or w.param
    if not isinstance(spec, dict):
        w.problems.append(f"{key}: {_fmt(spec)} must be {{ start = .., stop = .., num = .. }} "
                          "or { values = [...] }")
        return None
    extra = set(spec) - {"start", "stop", "num", "values"}
    for e in sorted(extra):
        w.problems.append(f"{key}.{e}: unknown key{_suggest(e, ('start', 'stop', 'num', 'values'))}; "
                          "allowed: start, stop, num, values")
    if "values" in spec:
        if {"start", "stop", "num"} & set(spec):
            w.problems.append(f"{key}: give either values or start/stop/num, not both")
        vals = spec["values"]
        if not isinstance(vals, list) or not vals:
            w.problems.append(f"{key}.values: {_fmt(vals)[:80]} must be a non-empty list of numbers")
            return None
        if len(vals) > MAX_AXIS_VALUES:
            w.problems.append(f"{key}.values: {len(vals)} values on one axis; at most "
                              f"{MAX_AXIS_VALUES}")
            return None
        good = all(check(k, v, f"{key}.values") for v in vals)
        return tuple(float(v) for v in vals) if good else None
    ok = True
    for part in ("start", "stop", "num"):
        if part not in spec:
            w.problems.append(f"{key}.{part}: missing; an axis needs start, stop and num")
            ok = False
    if not ok:
        return None
    num = spec["num"]
    if not _is_int(num):
        w.problems.append(f"{key}.num: {_fmt(num)} must be an integer >= 1")
        ok = False
    elif num < 1:
        w.problems.append(f"{key}.num: {num} must be an integer >= 1")
        ok = False
    elif num > MAX_AXIS_VALUES:
        w.problems.append(f"{key}.num: {num} values on one axis; at most {MAX_AXIS_VALUES} "
                          "(the scene as run lists every value)")
        ok = False
    a = check(k, spec["start"], f"{key}.start")
    b = check(k, spec["stop"], f"{key}.stop")
    if not (ok and a and b):
        return None
    lo, hi = float(spec["start"]), float(spec["stop"])
    if hi < lo:
        w.problems.append(f"{key}: stop {hi!r} < start {lo!r}; axes run upwards "
                          "(use sweep.follow = \"down\" to follow downwards)")
    elif num > 1 and hi == lo:
        w.problems.append(f"{key}: start = stop = {lo!r} with num = {num}; use num = 1")
    else:
        return tuple(float(x) for x in np.linspace(lo, hi, num))
    return None


def _read_sweep(w):
    sw = w.table("sweep")
    params = w.spec.params
    follow = sw.get("follow", "none")
    if follow not in FOLLOW:
        w.problems.append(f"sweep.follow: {_fmt(follow)} is not allowed; allowed: {', '.join(FOLLOW)}")
        follow = "none"
    axes = []
    for k, spec in sweep_items(sw):
        if k.startswith(IC_PREFIX):
            c = k[len(IC_PREFIX):]
            if c not in w.spec.start_names:
                w.problems.append(f"sweep.{k}: {c!r} is not a start coordinate of model "
                                  f"{w.model!r}; allowed: "
                                  + ", ".join(IC_PREFIX + x for x in w.spec.start_names))
                continue
            values = _read_axis(w, k, spec, _finite_value(w, k))
            if values is not None:
                axes.append(Axis(k, values))
            continue
        if k not in params:
            w.problems.append(f"sweep.{k}: {k!r} is not a parameter of model {w.model!r}"
                              f"{_suggest(str(k), params)}; allowed: {', '.join(params)}")
            continue
        values = _read_axis(w, k, spec)
        if values is not None:
            only = params[k].obstacles
            if only and w.obstacle not in only:
                w.problems.append(f"sweep.{k}: {k} is a parameter of the {' and '.join(only)} "
                                  f"obstacle only (system.obstacle is {w.obstacle!r})")
            axes.append(Axis(k, values))
    if "sweep" in w.raw and w.raw.get("sweep") is not None and not axes:
        if not [k for k in sw if k != "follow"]:
            w.problems.append("sweep: no axis given; add e.g. "
                              "kappa = { start = -0.02, stop = 0.0, num = 101 }")
    if len(axes) > 2:
        w.problems.append(f"sweep: {len(axes)} axes ({', '.join(a.name for a in axes)}); at most two")
    points = math.prod(len(a.values) for a in axes)
    if points > MAX_GRID_POINTS:
        w.problems.append(f"sweep: {' x '.join(str(len(a.values)) for a in axes)} = {points} grid "
                          f"points; at most {MAX_GRID_POINTS} (the done mask and the block list "
                          "grow with the grid)")
    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        w.problems.append(f"sweep: two axes name one parameter ({', '.join(names)})")
    if follow != "none" and not axes:
        w.problems.append(f"sweep.follow: {follow!r} needs a swept parameter")
    if follow != "none" and any(a.name.startswith(IC_PREFIX) for a in axes):
        w.problems.append(f"sweep.follow: {follow!r} carries the final state along an axis, "
                          "which a swept start coordinate (sweep.initial.*) contradicts; "
                          "use follow = \"none\"")
    sp = w.section_period
    if sp is not None and any(a.name == "omega" for a in axes):
        w.problems.append("system.section_period: cannot be fixed while omega is swept "
                          "(the default T = 2 pi / omega follows omega)")
    ob = w.spec.obstacles.get(w.obstacle) if w.spec.obstacles else None
    if ob is not None and ob.name == "profile" and getattr(w, "profile", None) is None:
        ob = None                       # no valid profile: its problem is reported already
    if sp is not None and ob is not None and w.system.get("omega"):
        per = (w.profile.period / w.system["omega"] if ob.name == "profile"
               else ob.period(w.system["omega"]))
        m = sp / per
        if abs(m - round(m)) > 1e-9 * max(1.0, m) or round(m) < 1:
            w.problems.append(f"system.section_period: {sp!r} is not a whole number of "
                              f"obstacle periods (P = {per!r})")
    w.axes, w.follow = axes, follow


def _fixed(rng) -> bool:
    """A start range that draws one value (a number, or [a, a])."""
    return _is_number(rng) or (isinstance(rng, list) and len(rng) == 2 and rng[0] == rng[1])


def _read_initial(w):
    ini = w.table("initial")
    w.unknown("initial", TABLES["initial"])
    n_ic = ini.get("count", INITIAL_DEFAULTS["count"])
    if not _is_int(n_ic) or not 1 <= n_ic <= MAX_STARTS:
        w.problems.append(f"initial.count: {_fmt(n_ic)} must be an integer in 1..{MAX_STARTS} "
                          "(starts are keyed by point * 2^20 + start)")
        n_ic = 1
    seed = ini.get("seed", INITIAL_DEFAULTS["seed"])
    if not _is_int(seed) or not 0 <= seed < MAX_INT:
        w.problems.append(f"initial.seed: {_fmt(seed)} must be an integer in 0..2^62 - 1")
        seed = 0
    coords = w.spec.start_names
    for c in TABLES["initial"][len(INITIAL_DEFAULTS):]:
        if c in ini and c not in coords:
            w.problems.append(f"initial.{c}: not an initial coordinate of model {w.model!r}; "
                              f"allowed: {', '.join(coords)}")
    swept = [a.name[len(IC_PREFIX):] for a in getattr(w, "axes", ())
             if a.name.startswith(IC_PREFIX)]
    for c in swept:
        if c in ini:
            w.problems.append(f"initial.{c}: {_fmt(ini[c])} but sweep.initial.{c} sweeps it; "
                              "give one of the two")
    # every start coordinate swept or fixed (a range [a, a]): one start per cell
    if swept and all(c in swept or _fixed(ini.get(c, list(w.spec.coord(c).default)))
                     for c in coords):
        if "count" in ini and n_ic != 1:
            w.problems.append(f"initial.count: {n_ic} with every start coordinate swept "
                              f"(sweep.initial.*) or fixed: each cell is one start; use "
                              "count = 1")
        n_ic = 1
    ranges = {}
    for c in coords:                                        # the model's state order
        default = list(w.spec.coord(c).default)
        rng = ini.get(c, default)
        if _is_number(rng):
            rng = [rng, rng]
        if (not isinstance(rng, list) or len(rng) != 2 or not all(_is_number(x) for x in rng)
                or not all(math.isfinite(x) for x in rng)):
            w.problems.append(f"initial.{c}: {_fmt(rng)} must be a range [low, high] of finite numbers")
            rng = default
        elif rng[1] < rng[0]:
            w.problems.append(f"initial.{c}: {_fmt(rng)} has high < low")
        ranges[c] = (float(rng[0]), float(rng[1]))
    w.n_ic, w.seed, w.ranges = n_ic, seed, ranges


def _read_run(w):
    rn = w.table("run")
    w.unknown("run", TABLES["run"])
    preset = rn.get("preset", DEFAULT_PRESET)
    if not isinstance(preset, str) or preset not in PRESETS:
        w.problems.append(f"run.preset: {_fmt(preset)} is not a preset"
                          f"{_suggest(str(preset), PRESETS)}; allowed: {', '.join(PRESETS)}")
        preset = DEFAULT_PRESET
    run = {}
    for k, default in RUN_DEFAULTS.items():
        default = PRESETS[preset].get(k, default)
        v = rn.get(k, default)
        if k == "stop":
            if v is not None and v not in STOPS:
                w.problems.append(f"run.stop: {_fmt(v)} is not allowed; allowed: {', '.join(STOPS)}")
                v = None
            elif v == "period" and not w.spec.early_stop:
                which = " or ".join(repr(m.name) for m in _all_models() if m.early_stop)
                w.problems.append(f"run.stop: 'period' is implemented for model {which} only, "
                                  f"not {w.model!r}; allowed here: none")
                v = None
            run[k] = v
            continue
        if k in ("transient", "record", "max_events", "max_periods"):
            if v is None and k in ("max_events", "max_periods"):
                run[k] = None         # automatic budget (below)
                continue
            lo = 0 if k == "transient" else 1
            hi = {"record": MAX_RECORD, "max_periods": MAX_PERIODS}.get(k, MAX_INT - 1)
            if not _is_int(v) or not lo <= v <= hi:
                why = (" (the cycle's word is a fixed-length string in the file)" if k == "record"
                       else " (held in int64 by the kernels)")
                w.problems.append(f"run.{k}: {_fmt(v)} must be an integer in {lo}..{hi}"
                                  + (why if _is_int(v) and v > hi else ""))
                v = default if default is not None else 1
        else:
            if not _is_number(v) or not math.isfinite(v) or v <= 0:
                w.problems.append(f"run.{k}: {_fmt(v)} must be a positive finite number")
                v = default
            elif k == "tol" and v > 1e-3:
                w.problems.append(f"run.tol: {v!r} is too coarse; the event-time tolerance must be <= 1e-3")
            v = float(v)
        run[k] = v
    need = run["transient"] + run["record"]
    if run["max_events"] is None:
        run["max_events"] = min(w.spec.events_per_impact * need + BUDGET_MARGIN, MAX_INT - 1)
    if run["max_periods"] is None:
        run["max_periods"] = min(PERIODS_PER_IMPACT * need + BUDGET_MARGIN, MAX_PERIODS)
    w.preset, w.run, w.run_given = preset, run, rn


def _read_output(w):
    outp = w.table("output")
    w.unknown("output", TABLES["output"])
    keep = outp.get("keep", list(KEEP_DEFAULT))
    if not isinstance(keep, list) or not all(isinstance(x, str) for x in keep):
        w.problems.append(f"output.keep: {_fmt(keep)} must be a list drawn from {list(KEEP)}")
        keep = list(KEEP)
    for x in keep:
        if x not in KEEP:
            w.problems.append(f"output.keep: {x!r} is not an observable{_suggest(x, KEEP)}; "
                              f"allowed: {', '.join(KEEP)}")
    keep = tuple(x for x in KEEP if x in keep)
    allowed_keep = tuple(w.spec.observables)
    for x in keep:
        if x not in allowed_keep and "keep" in outp:
            w.problems.append(f"output.keep: {x!r} is not an observable of model {w.model!r}"
                              f"{w.spec.keep_hint}; allowed: {', '.join(allowed_keep)}")
    w.keep = tuple(x for x in keep if x in allowed_keep)
    if w.run["stop"] is None:
        w.run["stop"] = "period" if (w.spec.early_stop and not w.keep) else "none"


def _plain(v) -> bool:
    """A value the scene as run can hold: a string, a finite-width number, or a list of them
    (not a date, a table or None)."""
    if isinstance(v, list):
        return all(_plain(x) for x in v)
    return isinstance(v, (str, bool)) or _is_number(v)


def _normal_form_needs():
    """Which models (and obstacles) the (a0, b1)-plane figures accept, in words."""
    parts = []
    for m in sorted(_all_models(), key=lambda m: m.normal_form_role != "map"):
        if m.normal_form_role == "map":
            parts.append(f"model {m.name!r}")
        elif m.normal_form_role == "flow":
            obs = [o for o, d in m.obstacles.items() if d.normal_form]
            parts.append(f"{m.name!r} with obstacle " + " or ".join(repr(o) for o in obs))
    return " or ".join(parts)


def _read_plot(w):
    pl = w.table("plot")
    w.unknown("plot", TABLES["plot"])
    plot = dict(pl)
    problems = w.problems
    if "color_by" in plot:
        if plot["color_by"] not in PLOT_COLOR_BY:
            problems.append(f"plot.color_by: {_fmt(plot['color_by'])} is not allowed; allowed: "
                            + ", ".join(PLOT_COLOR_BY))
        elif "stability" not in w.keep:
            problems.append("plot.color_by: colours come from the stability datasets; "
                            "output.keep must contain \"stability\"")
    if "y" in plot and plot["y"] not in PLOT_Y:
        problems.append(f"plot.y: {_fmt(plot['y'])} is not allowed; allowed: {', '.join(PLOT_Y)}")
    for lim in ("xlim", "ylim"):
        if lim in plot:
            v = plot[lim]
            if not (isinstance(v, list) and len(v) == 2 and all(_is_number(x) for x in v) and v[0] < v[1]):
                problems.append(f"plot.{lim}: {_fmt(v)} must be [low, high] with low < high")
    for k, v in plot.items():
        if not _plain(v):
            problems.append(f"plot.{k}: {_fmt(v)[:60]} must be a string, a number or a list "
                            "of them")
    if "marks" in plot:
        v = plot["marks"]
        if not (isinstance(v, list) and all(isinstance(m, list) and len(m) == 2
                                            and _is_number(m[0]) and math.isfinite(m[0])
                                            and isinstance(m[1], str) for m in v)):
            problems.append(f"plot.marks: {_fmt(v)[:80]} must be a list of [value, \"label\"] "
                            "pairs (values on the swept axis, marked by dotted lines)")
        elif len(w.axes) != 1:
            problems.append("plot.marks: marks values on a diagram's one swept axis; this scene "
                            f"sweeps {len(w.axes)} axes")
        else:
            lo, hi = min(w.axes[0].values), max(w.axes[0].values)
            for x, lab in v:
                if not lo <= x <= hi:
                    problems.append(f"plot.marks: {x!r} ({lab}) is outside the swept "
                                    f"{w.axes[0].name} range [{lo!r}, {hi!r}]")
    if "orbits" in plot and plot["orbits"] not in ("words", "families"):
        problems.append(f"plot.orbits: {_fmt(plot['orbits'])} must be \"words\" (a colour per "
                        "orbit) or \"families\" (one per family such as beta^N gamma)")
    if "style" in plot and not (isinstance(plot["style"], str) and plot["style"]):
        problems.append(f"plot.style: {_fmt(plot['style'])[:60]} must be a matplotlib style "
                        "name or the path of a .mplstyle file")
    if "title" in plot and not isinstance(plot["title"], str):
        problems.append(f"plot.title: {_fmt(plot['title'])[:60]} must be a string")
    kind = plot.get("kind", "diagram")
    if kind in NORMAL_FORM_KINDS:
        if not w.spec.has_normal_form(w.obstacle):
            problems.append(f"plot.kind: {kind!r} draws the corner normal form of z = kappa + "
                            f"beta |sin omega t| (sections 4-5): it needs {_normal_form_needs()} "
                            f"(this scene: model {w.model!r}"
                            + (f", obstacle {w.obstacle!r}" if w.spec.obstacles else "") + ")")
        if w.axes:
            problems.append(f"plot.kind: {kind!r} draws a scene without sweep axes; this one "
                            f"sweeps {', '.join(a.name for a in w.axes)}")
        if kind == "return_map" and w.run_given.get("transient", PRESETS[w.preset]["transient"]) != 0:
            problems.append("plot.kind: 'return_map' needs run.transient = 0 (A0 is the first "
                            "section value after the start)")
    if kind not in PLOT_KINDS:
        problems.append(f"plot.kind: {_fmt(kind)} is not a plot kind{_suggest(str(kind), PLOT_KINDS)}; "
                        f"allowed: {', '.join(PLOT_KINDS)}")
    if kind == "timeseries":
        if not w.spec.timeseries:
            which = " or ".join(repr(m.name) for m in _all_models() if m.timeseries)
            problems.append(f"plot.kind: 'timeseries' needs model {which} (the scene's model is "
                            f"{w.model!r})")
        if "impacts" not in w.keep:
            problems.append("plot.kind: 'timeseries' is rebuilt from the impacts; "
                            "output.keep must contain \"impacts\"")
    if kind == "obstacle" and (w.model != "flow"
                               or w.obstacle not in ("rectified_sine", "triangle")):
        problems.append("plot.kind: 'obstacle' draws z(t) with its corners at the period's "
                        "start and the wedge of eq (7) (Fig. 2): it needs model 'flow' with "
                        "obstacle 'rectified_sine' or 'triangle' (this scene: model "
                        f"{w.model!r}" + (f", obstacle {w.obstacle!r}" if w.model == "flow"
                                            else "") + ")")
    if kind == "fractions" and (len(w.axes) != 1 or w.axes[0].name.startswith(IC_PREFIX)):
        problems.append("plot.kind: 'fractions' draws the share of the starts reaching each "
                        "attractor against one swept parameter; this scene sweeps "
                        + (", ".join(a.name for a in w.axes) or "nothing"))
    if "ic" in plot:
        v = plot["ic"]
        if not (v == "distinct" or (isinstance(v, list) and v and all(_is_int(i) and 0 <= i < w.n_ic
                                                                       for i in v))):
            problems.append(f"plot.ic: {_fmt(v)} must be \"distinct\" or a list of start indices "
                            f"in 0..{w.n_ic - 1}")
    if "point" in plot:
        v = plot["point"]
        shape = [len(a.values) for a in w.axes]
        if not (isinstance(v, list) and len(v) == len(shape)
                and all(_is_int(i) and 0 <= i < n for i, n in zip(v, shape))):
            problems.append(f"plot.point: {_fmt(v)} must be a grid index with one entry per swept "
                            f"axis ({len(shape)}), each in 0..len-1 (grid {tuple(shape)})")
    for k, lo in (("cycles", 0), ("max_panels", 1)):
        if k in plot and not (_is_number(plot[k]) and plot[k] > lo and math.isfinite(plot[k])):
            problems.append(f"plot.{k}: {_fmt(plot[k])} must be a number > {lo}")
    w.plot = plot


def _read_continue(w):
    """``[continue]``: one-parameter continuation of the periodic orbits found at the
    start (``cornerbif continue``, cornerbif.continuation)."""
    w.cont = {}
    if "continue" not in w.raw:
        return
    c = w.table("continue")
    w.unknown("continue", TABLES["continue"])
    pr = w.problems
    if not w.spec.continuation:
        which = " or ".join(repr(m.name) for m in _all_models() if m.continuation)
        pr.append(f"continue: model {w.model!r} has no orbit solver yet; continuation runs "
                  f"model {which}")
        return
    if w.obstacle == "profile":
        pr.append("continue: obstacle 'profile' has no orbit solver yet (it takes two pieces "
                  "per obstacle period); sweep it, or continue a built-in obstacle")
        return
    name = c.get("parameter")
    numeric = [k for k in w.spec.params]
    if name not in numeric:
        pr.append(f"continue.parameter: {_fmt(name)} is not a numeric parameter of model "
                  f"{w.model!r}{_suggest(str(name), numeric)}; allowed: {', '.join(numeric)}")
        return
    if any(a.name == name for a in w.axes):
        pr.append(f"continue.parameter: {name!r} is also swept ([sweep] {name}); continue "
                  "from one point: remove the axis")
    out = {"parameter": name}
    forced = [k for k in numeric if k.startswith("F") and w.system.get(k) not in (0, 0.0, None)]
    if forced and name.lower().startswith("omega"):
        pr.append(f"continue.parameter: {name!r} with forcing {forced[0]} = "
                  f"{_fmt(w.system[forced[0]])}: a periodic orbit needs the forcing's period "
                  "and the wall's commensurate, which continuing a frequency breaks; "
                  "continue another parameter, or set the forcing to 0")
    rng = c.get("range")
    if not (isinstance(rng, list) and len(rng) == 2 and all(_is_number(x) for x in rng)
            and all(math.isfinite(x) for x in rng) and rng[0] < rng[1]):
        pr.append(f"continue.range: {_fmt(rng)} must be [low, high], finite, low < high")
        return
    for x in rng:
        w.param(name, x, "continue.range")
    out["range"] = [float(rng[0]), float(rng[1])]
    start = c.get("start", w.system.get(name))
    if not _is_number(start) or not rng[0] <= start <= rng[1]:
        pr.append(f"continue.start: {_fmt(start)} must be a number within continue.range "
                  f"{_fmt(rng)} (default: system.{name})")
        return
    w.param(name, start, "continue.start")
    out["start"] = float(start)
    seed = c.get("seed", "all")
    seeds = seed if isinstance(seed, list) else [seed]
    if not seeds or not all(isinstance(s, str) and s for s in seeds):
        pr.append(f"continue.seed: {_fmt(seed)} must be \"all\" or a cycle word (or a list "
                  "of words), e.g. \"b\", \"a\", \"b^5 g\"")
    else:
        from .analysis import parse_word
        for s in seeds:
            if s != "all" and set(s) != {"x"}:      # x: a cluster of a smooth obstacle
                try:
                    parse_word(s)
                except ValueError as e:
                    pr.append(f"continue.seed: {s!r}: {e} (or x for a smooth obstacle)")
    out["seed"] = seed
    width = out["range"][1] - out["range"][0]
    for k, default in (("ds", width / 200.0), ("ds_min", width * 1e-9),
                       ("ds_max", width / 20.0)):
        v = c.get(k, default)
        if not (_is_number(v) and math.isfinite(v) and v > 0):
            pr.append(f"continue.{k}: {_fmt(v)} must be a number > 0")
        out[k] = float(v) if _is_number(v) else default
    if not out["ds_min"] <= out["ds"] <= out["ds_max"]:
        pr.append(f"continue.ds: ds_min {out['ds_min']!r} <= ds {out['ds']!r} <= ds_max "
                  f"{out['ds_max']!r} must hold")
    ev = c.get("events", list(CONTINUE_EVENTS))
    if not (isinstance(ev, list) and all(x in CONTINUE_EVENTS for x in ev)):
        pr.append(f"continue.events: {_fmt(ev)} must be a list drawn from "
                  + ", ".join(CONTINUE_EVENTS))
    out["events"] = list(ev) if isinstance(ev, list) else list(CONTINUE_EVENTS)
    sw = c.get("switch", True)
    if not isinstance(sw, bool):
        pr.append(f"continue.switch: {_fmt(sw)} must be true or false")
    out["switch"] = bool(sw)
    if "curve" in c:
        cv = c["curve"]
        if cv not in numeric or cv == name:
            pr.append(f"continue.curve: {_fmt(cv)} must be another numeric parameter of "
                      f"model {w.model!r} (the second parameter of the corner-collision "
                      "curves)")
        crng = c.get("curve_range")
        if not (isinstance(crng, list) and len(crng) == 2 and all(_is_number(x) for x in crng)
                and crng[0] < crng[1] and crng[0] <= w.system.get(cv, math.nan) <= crng[1]):
            pr.append(f"continue.curve_range: {_fmt(crng)} must be [low, high] around "
                      f"system.{cv} = {_fmt(w.system.get(cv))}")
        out["curve"] = cv
        out["curve_range"] = crng
    if "seed_file" in c:
        sf = c["seed_file"]
        if not isinstance(sf, str) or not sf:
            pr.append(f"continue.seed_file: {_fmt(sf)} must be the path of a sweep file "
                      f"(cornerbif sweep) of this model over {name!r}")
        out["seed_file"] = sf
    if "curve_range" in c and "curve" not in c:
        pr.append(f"continue.curve_range: {_fmt(c['curve_range'])} without continue.curve "
                  "(the second parameter of the curves)")
    if "over" in c:
        if not isinstance(c["over"], str):
            pr.append(f"continue.over: {_fmt(c['over'])} must be the name of a scene")
        out["over"] = c["over"]
    w.cont = out


def _read_model_checks(w):
    """The model's own cross-checks (``Model.check``)."""
    w.problems += w.spec.check(CheckContext(w))


# the declared tables, walked in this order
READERS = (("scene", _read_scene), ("system", _read_system), ("sweep", _read_sweep),
           ("initial", _read_initial), ("run", _read_run), ("output", _read_output),
           ("plot", _read_plot), ("continue", _read_continue), (None, _read_model_checks))


def from_dict(raw, drawn_starts: bool = True) -> Scene:
    """Validate a raw scene dict; raise ``SceneError`` listing every problem.

    ``drawn_starts=False`` (``simulate``, which is given its starts) skips the checks of
    the ``[initial]`` ranges against the obstacle.
    """
    if not isinstance(raw, dict):
        raise SceneError([f"scene: expected a table, got {type(raw).__name__}"])
    w = _Walk(raw, drawn_starts)
    for t, body in raw.items():
        if t not in TABLES:
            w.problems.append(f"{t}: unknown table{_suggest(str(t), TABLES)}; allowed: "
                              + ", ".join(f"[{x}]" for x in TABLES))
        elif not isinstance(body, dict):
            w.problems.append(f"{t}: {_fmt(body)} must be a table [{t}]")
    for _, read in READERS:
        read(w)
    if w.problems:
        raise SceneError(w.problems)
    return _scene(w)


def _scene(w) -> Scene:
    """The scene as run: defaults made explicit, so the file says everything."""
    run, spec = w.run, w.spec
    system_text = {}
    if "obstacle" in spec.system_extra:
        system_text["obstacle"] = w.obstacle
    system_text |= {k: v for k, v in w.system.items() if v is not None}
    as_run = {
        "scene": {"name": w.name, "title": w.title, "model": w.model},
        "system": system_text,
        "sweep": {**{a.name: {"values": list(a.values)} for a in w.axes}, "follow": w.follow},
        "initial": {"count": w.n_ic, "seed": w.seed,
                    **{c: list(r) for c, r in w.ranges.items()
                       if not any(a.name == IC_PREFIX + c for a in w.axes)}},
        "run": {**({"preset": w.preset} if "preset" in w.run_given else {}),
                **{k: v for k, v in run.items()
                   if v is not None and k not in ("stop", "max_events", "max_periods")},
                "max_events": run["max_events"], "max_periods": run["max_periods"],
                "stop": run["stop"]},
        "output": {"keep": list(w.keep)},
    }
    if not w.axes:
        del as_run["sweep"]
    if w.section_period is not None:
        as_run["system"]["section_period"] = w.section_period
    if getattr(w, "profile_table", None) is not None:
        as_run["system"]["profile"] = w.profile_table
    if w.plot:
        as_run["plot"] = w.plot
    if w.cont:
        as_run["continue"] = w.cont
    return Scene(name=w.name, title=w.title, model=w.model, obstacle=w.obstacle,
                 system=w.system, section_period=w.section_period, axes=tuple(w.axes),
                 follow=w.follow, n_ic=w.n_ic, seed=w.seed, initial=w.ranges,
                 transient=run["transient"], record=run["record"], tol=run["tol"],
                 chatter=run["chatter"], escape=run["escape"], period_tol=run["period_tol"],
                 max_events=run["max_events"], max_periods=run["max_periods"], keep=w.keep,
                 plot=w.plot, text=dumps(as_run), preset=w.preset, stop=run["stop"],
                 cont=w.cont, profile=getattr(w, "profile", None))
