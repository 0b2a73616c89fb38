"""Scenes: TOML text -> frozen, validated ``Scene`` objects.

Every problem of a scene is collected and reported at once, each with its
dotted key, the offending value and what is allowed::

    sweep.omgea: unknown parameter of model 'flow' (did you mean 'omega'?)

``from_dict`` walks the declared tables in order (``READERS``: [scene], [system],
[sweep], [initial], [run], [output], [plot]); the model registry
(``cornerbif.registry``) supplies what [system], [sweep], [initial] and [output]
allow, and each model's own cross-checks (``Model.check``).  No table reader
branches on a model's name.  The public format (keep these names) is documented
in README.md.
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import re
import stat
import tomllib
from dataclasses import dataclass, field

import numpy as np

from . import figures, obstacles, plot_style, registry
from .cycles import parse_word
from .model import IC_PREFIX, KEY_CHARS, automatic_budgets, cut, did_you_mean, shown
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
    "lyapunov_impacts": None,
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
INITIAL_DEFAULTS = {"count": 8, "seed": 1}
# starts given, not drawn: ``points`` (a list of starts) or ``points_file`` (a text file of
# one start per line, read when the scene is loaded; the scene as run lists the points)
INITIAL_LISTS = ("points", "points_file")
# Sizes, checked before anything is allocated (each limit says why it is there):
# values of one axis: the scene as run lists every value (the file's ``scene`` attribute)
MAX_AXIS_VALUES = 100_000
# grid points: the done mask and the block list grow with them (~200 bytes a grid row)
MAX_GRID_POINTS = 100_000_000
# starts per grid point: the counter-based draw keys a start by point * 2^20 + start
# (engine.uniform), so more would repeat starts
MAX_STARTS = 2**20
MAX_POINTS_BYTES = 64 * 2**20   # of an [initial] points_file read
# recorded events: the word of a cycle is a fixed-length string of record // 2 bytes whose
# fill value lives in the dataset's HDF5 object header (at most 64 KiB)
MAX_RECORD = 100_000
# integers the kernels hold in int64 (transient, budgets, seed): below 2^62, so that the
# automatic budgets (a multiple of transient + record) and the time budget in pieces fit
MAX_INT = 2**62
# the time budget: the kernels count it in smooth pieces of the obstacle (a few per period)
MAX_PERIODS = 2**58
# Reading a scene (each limit says why; docs: README "Scenes", the limits of a scene):
# bytes of a scene file or of one --set value: the scene as run of the largest axis
# (100,000 values, every one listed) is 2.3 MB; TOML's reader (pure Python) takes about
# 1.2 s a MB of the worst text, so a scene is read in seconds; read no further (a device, a
# FIFO or a directory is refused by its kind before it is opened)
MAX_SCENE_BYTES = 4 * 2**20
# tables and lists inside one another: a scene needs 6 ([system.profile] pieces' sine
# lists); TOML's reader, and every walk of the scene, recurses once per level
MAX_NESTING = 16
# digits of one integer: Python reads at most 4300 (sys.get_int_max_str_digits), and a
# parameter, a count or a seed is far shorter (a float64 holds up to 309 digits)
MAX_INT_DIGITS = 4300
# a start time t0 (flow: [initial] t, [sweep] initial.t), the obstacle's phase at the
# start: the kernels place it by its period count m and phase t0 - m P, which float64
# resolves to ulp(t0), 1.2e-10 at 1e6 (a phase within the first periods says the same)
MAX_START_TIME = 1e6
# keys of one table (and tables of a scene): the format's tables have about 15, the
# [sweep] at most two axes; past this a scene is refused at once, before a problem is said
# of each key
MAX_TABLE_KEYS = 100
# problems listed at most (the first ones; the count of the rest is said)
MAX_PROBLEMS = 50
# names listed in a problem ("allowed: ..."), each cut to KEY_CHARS (a linear scene declares
# its coordinates' and contacts' names, each of any length): the first ones, the count of
# the rest said
MAX_LISTED_NAMES = 40
# free text, each refused beyond its limit with its key and its length:
# scene.name: a short name that labels the run (info, the default title) and names the
# default output file (its first 100 characters, made safe: outputs.default_output)
MAX_NAME = 200
# scene.title and plot.title: a figure's title, broken into lines of 80-100 characters,
# stored in the file and printed by info; 500 characters are six lines over the figure
MAX_TITLE = 500
# plot.marks: dotted lines on a diagram, each with a label beside it
MAX_MARKS = 100
MAX_MARK_LABEL = 100
# plot.marker_size in points: a marker of 100 pt is 1.4 inches across, more than a figure's
# panel shows; the raster of a large diagram grows every point to a disc of that radius
MAX_MARKER_SIZE = 100.0
# plot.cycles: periods of the obstacle drawn by kind "obstacle" or "timeseries" (each drawn
# from a fixed number of samples, so more would draw no curve)
MAX_PLOT_CYCLES = 10_000
# plot.max_panels: the panels of a time-series figure, one per start
MAX_PANELS = 64
# plot.xlim, ylim: a window matplotlib can draw: both ends finite, within +-MAX_PLOT_LIMIT
# (its ticks and transforms take differences and products of the ends), and the width at
# least MIN_PLOT_WIDTH of the ends' magnitude (a narrower window has no distinct ticks)
MAX_PLOT_LIMIT = 1e100
MIN_PLOT_WIDTH = 1e-12
PLOT_KEYS = ("y", "xlim", "ylim", "marker_size", "title", "kind", "point", "ic", "cycles",
             "max_panels", "color_by", "style", "marks", "orbits", "coordinate", "without")
# [plot] color_by: a diagram's or a chart's colour from the stability observable
PLOT_COLOR_BY = ("lyapunov", "multiplier")
PLOT_ORBITS = ("words", "families", "branches")
PLOT_Y = ("impact_u", "impact_v", "impact_height", "section_u", "section_v", "winding",
          "period")


# [sweep] initial.<coordinate>: an axis over a coordinate of the start (docs/basins.md)


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


# --- the tables derived from the model registry, computed on first use (``_registered``), so
# that importing this module imports no model; read as config.MODELS, config.KEEP, ...
# (module ``__getattr__``).
#   MODELS        the registered models' names
#   KEEP          every observable any model has, in the file's order
#   KEEP_DEFAULT  what a scene without [output] keep keeps: every observable but the opt-in ones
#   OBSTACLES     the default model's obstacles
#   TABLES        each table's keys (None: [sweep], parameter names + 'follow')
#   PLOT_KINDS    the figure kinds of [plot] kind (figures.FIGURE_MODULES)
REGISTERED = ("MODELS", "KEEP", "KEEP_DEFAULT", "OBSTACLES", "TABLES", "PLOT_KINDS")


def _all_models():
    return registry.models().values()


def _registered() -> dict:
    """The tables derived from the registry as it is (``REGISTERED``)."""
    return _derive(registry.names())


@functools.cache
def _derive(names: tuple) -> dict:
    models = [registry.get(n) for n in names]
    keep = _union(m.observables for m in models)
    return {
        "MODELS": names,
        "KEEP": keep,
        "KEEP_DEFAULT": tuple(k for k in keep if not any(k in m.opt_in for m in models)),
        "OBSTACLES": tuple(registry.get(registry.DEFAULT_MODEL).obstacles),
        "PLOT_KINDS": tuple(figures.registered()),
        "TABLES": {
            "scene": ("name", "title", "model"),
            "system": _union(tuple(m.params) + tuple(m.system_extra) for m in models),
            "sweep": None,  # parameter names + 'follow'
            "initial": tuple(INITIAL_DEFAULTS) + INITIAL_LISTS
                       + _union(m.start_names for m in models),
            "run": ("preset",) + tuple(RUN_DEFAULTS),
            "output": ("keep",),
            "plot": PLOT_KEYS,
            "continue": ("parameter", "range", "start", "seed", "seed_file", "ds", "ds_min",
                         "ds_max", "events", "switch", "curve", "curve_range", "over"),
        },
    }


def __getattr__(name):
    if name in REGISTERED:
        return _registered()[name]
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


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
    system : dict of the fixed numeric parameters (every declared parameter; a
        derived default such as theta1 may be None).
    extra : the model's declared non-numeric ``[system]`` keys as read (``Model.system_extra``:
        the flow's ``obstacle`` and ``section_period``, the two particles' ``section_period``;
        None where the scene gives none).
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
    obstacle_table : what the obstacle kind read from its own ``[system]`` tables (a cam's
        checked ``obstacles.profile.Profile``), else None.
    """

    name: str
    title: str
    model: str
    system: dict
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
    extra: dict = field(default_factory=dict)
    obstacle_table: object = None
    points: tuple = None       # [initial] points: the starts given (each in start order)
    lyapunov_impacts: int = 0  # run.lyapunov_impacts: exponents streamed over this many
    #                            impacts (0: over the recorded window)
    # the model as this scene declares it, where its ``[system]`` declares the model itself
    # (``Model.for_system``: the linear model's coordinates and parameters); None: the
    # registered model
    model_spec: object = field(default=None, compare=False, repr=False)

    @property
    def shape(self) -> tuple:
        return tuple(len(a.values) for a in self.axes)

    @property
    def hash(self) -> str:
        return hashlib.sha256(self.text.encode()).hexdigest()

    @property
    def spec(self):
        """The model (``cornerbif.model.Model``): the registered one, or the one this scene's
        ``[system]`` declares (``Model.for_system``)."""
        return self.model_spec if self.model_spec is not None else registry.get(self.model)

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
def _suggest(word, options) -> str:
    """" (did you mean 'x'?)" for a near miss of ``word`` among ``options`` (``model.
    did_you_mean``), never ``word`` itself: a value refused for another reason than its
    spelling (``continue.curve`` naming the continued parameter) is not offered back as
    its own correction.  (A name the tests watch: ``test_scene_hardening``.)"""
    return did_you_mean(word, [o for o in options if o != word])


def listed(names) -> str:
    """Names for a problem's "allowed: ..." list: each cut to KEY_CHARS, at most
    MAX_LISTED_NAMES of them and the count of the rest (a scene may declare names of any
    length and number; a problem stays a few lines)."""
    names = list(names)
    text = ", ".join(cut(n, KEY_CHARS) for n in names[:MAX_LISTED_NAMES])
    more = len(names) - MAX_LISTED_NAMES
    return text + (f", ... and {more} more" if more > 0 else "")


def _is_int(x):
    return isinstance(x, int) and not isinstance(x, bool)


# the name _read_continue's helpers quote a value by (``model.shown``)
_fmt = shown


# the two forms of a [sweep] axis: a --set of one form's key replaces the other form
AXIS_FORMS = (("values",), ("start", "stop", "num"))


def key_parts(key: str) -> list:
    """The parts of a dotted key as TOML reads it: ``system.omega`` -> [system, omega], and a
    quoted part whole, ``sweep."contact.R.kappa".num`` -> [sweep, contact.R.kappa, num] (the
    linear model's parameters are paths); a key TOML cannot read is split at its dots."""
    if '"' in key or "'" in key:
        try:
            node, parts = tomllib.loads(f"{key} = 0"), []
            while isinstance(node, dict) and len(node) == 1:
                (k, node), = node.items()
                parts.append(k)
            if node == 0:
                return parts
        except (tomllib.TOMLDecodeError, ValueError):
            pass
    return key.split(".")


def set_dotted(raw: dict, key: str, value):
    """Apply one ``--set a.b.c=value`` override to a raw TOML dict.

    On a ``[sweep]`` axis a key of one form replaces the other form: ``--set
    sweep.kappa.values=[0.005]`` on a start/stop/num axis drops start, stop and num (and
    ``--set sweep.kappa.num=5`` on a values axis drops values); ``--set
    sweep.kappa={values=[0.005]}`` replaces the whole axis.  A quoted part is one key
    (``key_parts``).  Inside a list the next part picks an entry: by its index
    (``system.forcing.0.F``, ``system.mass.1``) or, in a list of tables, by the entry's
    ``name`` (``system.contact.R.r``: a linear scene's); a part that picks none is refused
    (``SceneError``, naming the key), as is a named key inside a list of numbers.

    Returns the key's parts with each list entry as its index (``system.contact.L.r`` ->
    [system, contact, 0, r]): a problem said of the list names its entries so."""
    parts = key_parts(key)
    indexed = list(parts)
    node = raw
    for k, p in enumerate(parts[:-1]):
        if isinstance(node, list):
            i = _list_entry(node, p, parts, k)
            indexed[k] = str(i)
            node = node[i]
            continue
        nxt = node.get(p)
        if isinstance(nxt, list):
            node = nxt
            continue
        if not isinstance(nxt, dict):
            nxt = {}
            node[p] = nxt
        node = nxt
    if isinstance(node, list):
        i = _list_entry(node, parts[-1], parts, len(parts) - 1)
        indexed[-1] = str(i)
        node[i] = value
        return indexed
    if parts[0] == "sweep" and len(parts) >= 3:
        for form in AXIS_FORMS:
            if parts[-1] in form:
                for other in AXIS_FORMS:
                    if other is not form:
                        for k in other:
                            node.pop(k, None)
    node[parts[-1]] = value
    return indexed


def list_index(part: str, n: int) -> int | None:
    """The entry that a key's part picks in a list of ``n`` by its index: ASCII digits
    naming 0 .. n - 1, else None.  The digits are compared by their count before Python
    reads them (``int`` refuses a text of more than 4300 digits, and a part of a --set key
    may be of any length), so any part is answered."""
    if not (part.isascii() and part.isdigit()):
        return None
    digits = part.lstrip("0") or "0"
    if len(digits) > len(str(n)):
        return None
    i = int(digits)
    return i if i < n else None


def _list_entry(entries: list, part: str, parts: list, k: int) -> int:
    """The index of the entry of ``entries`` that ``part`` (``parts[k]``) picks: an index
    (ASCII digits) in range (``list_index``), or in a list of tables the one whose ``name``
    it is; else a ``SceneError`` naming the key and the part, each cut to a bounded length."""
    i = list_index(part, len(entries))
    if i is not None:
        return i
    named = [i for i, e in enumerate(entries) if isinstance(e, dict) and e.get("name") == part]
    if named:
        return named[0]
    where = ".".join(parts[:k])
    names = [e.get("name") for e in entries if isinstance(e, dict) and "name" in e]
    index = part.isascii() and part.isdigit()
    raise SceneError([f"--set {cut('.'.join(parts))}: {cut(where)} is a list of {len(entries)} "
                      f"entries; {shown(part)} picks none ("
                      + ("an index out of range: " if index else "")
                      + f"an index is 0 .. {len(entries) - 1}"
                      + (f", or a name: {listed(names)}" if names else "") + ")"])


def parse_override(text: str):
    """``key=value`` with value read as a TOML value (strings may be bare).

    Refused (``SceneError``, naming the override): no ``=``, an empty or over-deep key, a
    value longer than MAX_SCENE_BYTES, and a value that TOML cannot hold (an integer of more
    than MAX_INT_DIGITS digits, lists nested past MAX_NESTING); only a value that is not
    TOML at all is read as a bare string."""
    if "=" not in text:
        raise SceneError([f"--set {shown(text)}: expected key=value, e.g. --set system.omega=2.001"])
    key, val = text.split("=", 1)
    key = key.strip()
    val = val.strip()
    parts = key_parts(key)
    if not all(p.strip() for p in parts):
        raise SceneError([f"--set {shown(text)}: the key {shown(key)} has an empty part; keys "
                          "are dotted names such as system.omega"])
    if len(parts) > MAX_NESTING:
        raise SceneError([f"--set {shown(text)}: the key has {len(parts)} parts; at most "
                          f"{MAX_NESTING} (tables inside one another)"])
    if len(val.encode("utf-8", "surrogatepass")) > MAX_SCENE_BYTES:
        raise SceneError([f"--set {key}=...: a value of {len(val)} characters; at most "
                          f"{MAX_SCENE_BYTES} bytes (as a scene file)"])
    try:
        v = parse_toml(f"x = {val}", f"--set {key}")["x"]
    except SceneError as e:
        if not getattr(e, "syntax", False):
            raise
        v = val
    return key, v


def _too_many_digits(text: str):
    """The line and length of the first integer in ``text`` past MAX_INT_DIGITS digits."""
    m = re.search(r"(?:^|[=\[,{\s])[+-]?(?:0[xob])?([0-9A-Fa-f_]{" + str(MAX_INT_DIGITS + 1)
                  + ",})", text, re.M)
    if m is None:
        return None
    return text.count("\n", 0, m.start(1)) + 1, len(m.group(1).replace("_", ""))


def parse_toml(text: str, source: str) -> dict:
    """TOML text -> dict, every failure a ``SceneError`` naming ``source`` and what is
    wrong (never another exception).

    A UTF-8 byte-order mark at the start is skipped; refused: text past MAX_SCENE_BYTES,
    a syntax error (``.syntax`` set on the error), an integer past MAX_INT_DIGITS digits
    (Python reads no longer), and tables or lists nested past Python's recursion (far
    past MAX_NESTING, which ``from_dict`` checks with the key)."""
    if len(text) > MAX_SCENE_BYTES:
        raise SceneError([f"{source}: {len(text)} characters; a scene is at most "
                          f"{MAX_SCENE_BYTES} bytes"])
    text = text.removeprefix("\ufeff")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        err = SceneError([f"{source}: TOML syntax error: {e}"])
        err.syntax = True
        raise err from None
    except RecursionError:
        raise SceneError([f"{source}: tables or lists nested too deeply to read; a scene nests "
                          f"at most {MAX_NESTING} levels"]) from None
    except ValueError as e:
        at = _too_many_digits(text)
        where = (f"an integer of {at[1]} digits" if at else f"a value ({e})")
        if at and not source.startswith("--set"):
            where = f"line {at[0]}: {where}"
        raise SceneError([f"{source}: {where} cannot be read; an integer has at most "
                          f"{MAX_INT_DIGITS} digits (and a number of the scene fits a float64: "
                          "up to about 1.8e308)"]) from None


def nesting_problem(raw, root: str = "") -> str | None:
    """The key at which ``raw`` nests tables or lists past MAX_NESTING levels, or holds an
    integer of more than MAX_INT_DIGITS digits (which a scene file cannot hold, and whose
    text Python refuses to make), as a problem (None when there is none); iterative, so any
    depth is walked without recursion."""
    stack = [(raw, root, 0)]
    while stack:
        node, key, depth = stack.pop()
        if _is_int(node) and node.bit_length() > MAX_INT_DIGITS * 3.33:
            return (f"{key}: {shown(node)}; an integer has at most {MAX_INT_DIGITS} digits (a "
                    "number of the scene fits a float64: up to about 1.8e308)")
        if isinstance(node, dict):
            items = [(v, f"{key}.{cut(k, KEY_CHARS)}" if key else cut(k, KEY_CHARS))
                     for k, v in node.items()]
        elif isinstance(node, list):
            items = [(v, f"{key}[{i}]") for i, v in enumerate(node)]
        else:
            continue
        if depth >= MAX_NESTING and items:
            return (f"{key}: tables or lists nested more than {MAX_NESTING} levels deep; a "
                    "scene needs at most 6 ([system.profile] pieces' sine lists)")
        stack += [(v, k, depth + 1) for v, k in items]
    return None


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
        return "{ " + ", ".join(f"{_toml_key(k)} = {_toml_value(x)}" for k, x in v.items()) + " }"
    raise TypeError(type(v))


def _toml_key(k) -> str:
    """A key as TOML writes it: bare where it can be, else quoted (a path such as
    "contact.R.kappa", unquoted, would be read back as nested tables)."""
    k = str(k)
    bare = k and all(c.isascii() and (c.isalnum() or c in "_-") for c in k)
    # a swept start coordinate keeps the dotted form it has always been written in
    # (``sweep_items`` reads ``initial.u`` as the nested table it is)
    if bare or (k.startswith(IC_PREFIX) and _toml_key(k[len(IC_PREFIX):]) == k[len(IC_PREFIX):]):
        return k
    return _toml_value(k)


def dumps(raw: dict) -> str:
    """Serialise a scene dict (tables of scalars, lists and inline tables)."""
    out = []
    for table, body in raw.items():
        if not isinstance(body, dict):
            out.append(f"{table} = {_toml_value(body)}")
            continue
        out.append(f"[{table}]")
        for k, v in body.items():
            out.append(f"{_toml_key(k)} = {_toml_value(v)}")
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


def scene_difference(text_a, text_b, most=4) -> str:
    """What differs between two scenes as run (``[plot]`` aside, as ``config.same_run``):
    'key: A there, B here' for the first few keys; '' when nothing does."""
    a, b = without_plot(text_a), without_plot(text_b)
    if a is None:
        return "its scene text is not a scene"
    if b is None:
        return "the other scene text is not a scene"

    def flat(d, pre=""):
        out = {}
        for k, v in d.items():
            if isinstance(v, dict):
                out |= flat(v, f"{pre}{k}.")
            else:
                out[f"{pre}{k}"] = v
        return out

    fa, fb = flat(a), flat(b)
    keys = sorted(k for k in set(fa) | set(fb) if fa.get(k, ...) != fb.get(k, ...))

    def show(v):
        return "(absent)" if v is ... else shown(v)
    text = "; ".join(f"{k}: {show(fa.get(k, ...))} there, {show(fb.get(k, ...))} here"
                     for k in keys[:most])
    return text + (f"; and {len(keys) - most} more" if len(keys) > most else "")


# --------------------------------------------------------------------------- loading
# what a path that is not a regular file is, by its kind (os.stat's mode)
_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"))


def read_text(path, what="the scene file") -> str:
    """The text of a scene file: a regular file of at most MAX_SCENE_BYTES of UTF-8, read
    no further; anything else is a ``SceneError`` naming the path and what it is (a
    directory, a FIFO, a device: refused by its kind, before it is opened, so that
    /dev/zero is never read and a FIFO never waited on)."""
    def kind_problem(mode):
        kind = next((k for test, k in _KINDS if test(mode)), "not a regular file")
        return SceneError([f"{path}: is {kind}, not {what} (a TOML text file)"])
    try:
        mode = os.stat(path).st_mode
        if stat.S_ISREG(mode):
            with open(path, "rb") as fh:
                mode = os.fstat(fh.fileno()).st_mode   # what was opened, if it changed since
                data = fh.read(MAX_SCENE_BYTES + 1) if stat.S_ISREG(mode) else b""
    except (OSError, ValueError) as e:            # ValueError: a NUL in the path
        why = getattr(e, "strerror", None) or str(e)
        raise SceneError([f"{path}: cannot read {what} ({why})"]) from None
    if not stat.S_ISREG(mode):
        raise kind_problem(mode)
    if len(data) > MAX_SCENE_BYTES:
        raise SceneError([f"{path}: larger than {MAX_SCENE_BYTES} bytes; a scene is at most "
                          f"{MAX_SCENE_BYTES // 2**20} MiB of text (an axis of "
                          f"{MAX_AXIS_VALUES} values listed takes 2.3 MB)"])
    try:
        return data.decode("utf-8")
    except UnicodeDecodeError as e:
        raise SceneError([f"{path}: not UTF-8 text (byte {e.start}: "
                          f"{data[e.start:e.start + 4]!r})"]) from None


def load(path, overrides=()) -> Scene:
    """Read a scene file (``read_text``), apply ``--set`` overrides and validate it."""
    return loads(read_text(path), overrides, source=str(path))


def loads(text: str, overrides=(), source="<scene>") -> Scene:
    """A scene's TOML text (``parse_toml``) with ``--set`` overrides, validated; every
    problem found, a ``SceneError``, each problem that a --set caused saying so."""
    raw = parse_toml(text, source)
    problems = []
    given = []
    for ov in overrides:
        try:
            key, val = parse_override(ov) if isinstance(ov, str) else ov
        except SceneError as e:
            problems += e.problems
            continue
        indexed = ".".join(set_dotted(raw, key, val))
        text_of = cut(ov) if isinstance(ov, str) else f"{key}={shown(val)}"
        plain = ".".join(key_parts(key))
        given.append((plain, text_of, True))
        named = _named_key(raw, key_parts(key))
        if named != plain:                   # problems name a list's entry by its name
            given.append((named, text_of, True))
        if indexed not in (plain, named):
            # or by its index: a contact renamed by its name (system.contact.L.name) to a
            # name another contact holds is said of that one (system.contact.1.name)
            given.append((indexed, text_of, False))
    if problems:
        raise SceneError(problems)
    try:
        return from_dict(raw, source=source)
    except SceneError as e:
        raise SceneError([_from_set(p, given) for p in e.problems]) from None


def _named_key(raw: dict, parts: list) -> str:
    """The dotted key ``parts`` with each index into a list of named tables written as that
    entry's name (``system.contact.0.r`` -> ``system.contact.L.r``: how a problem names it)."""
    out, node = [], raw
    for p in parts:
        i = list_index(p, len(node)) if isinstance(node, list) else None
        if i is not None:
            node = node[i]
            name = node.get("name") if isinstance(node, dict) else None
            out.append(name if isinstance(name, str) else p)
        else:
            out.append(p)
            node = node.get(p) if isinstance(node, dict) else None
    return ".".join(out)


def _from_set(problem: str, given) -> str:
    """Say that a problem comes from a ``--set`` override when its key is one given there
    (an entry of a list named ``key[i]`` or ``key.i``: the same key)."""
    key = re.sub(r"\[(\d+)\]", r".\1", problem.split(":", 1)[0].strip())
    key_parts_ = key.split(".")
    for k, text, given_so in reversed(given):
        if key == k or key.startswith((k + ".", k + "[")) or k.startswith(key + "."):
            return f"{problem} (from --set {text})"
        # an entry of a list set by its index, which the problem names otherwise (a dof's
        # entry of system.mass by the dof's name): the same list; an entry the --set named
        # (``given_so`` false: its index found by ``set_dotted``) only the same key of
        # another entry of that list
        parts = k.split(".")
        at = next((i for i, p in enumerate(parts) if p.isascii() and p.isdigit()), None)
        if (at is not None and len(key_parts_) > at and key_parts_[:at] == parts[:at]
                and (given_so or key_parts_[at + 1:] == parts[at + 1:])):
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

    def run_setting(self, name):
        """A ``[run]`` setting as the scene gives it, else its preset's (once [run] is read)."""
        return self.run_given.get(name, PRESETS[self.preset][name])

    def unknown(self, name, allowed):
        for k in self.table(name):
            if k not in allowed:
                where = [t for t, keys in _registered()["TABLES"].items()
                         if keys and k in keys and t != name]
                hint = f" (it belongs in [{where[0]}])" if where else _suggest(str(k), allowed)
                self.problems.append(f"{name}.{cut(k, KEY_CHARS)}: unknown key{hint}; allowed: "
                                     f"{listed(allowed)}")

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
        self.extra = w.extra
        self.problems = list(w.problems)
        self.drawn = w.drawn
        self.obstacle_table = getattr(w, "obstacle_table", None)
        self.follow = getattr(w, "follow", "none")
        # the scene has a [continue] table (``cornerbif continue``: a model may refuse it)
        self.continued = "continue" in getattr(w, "raw", {})

    def swept(self, name):
        return next((a for a in self.axes if a.name == name), None)

    def key(self, name):
        return f"sweep.{name}" if self.swept(name) else f"system.{name}"

    def values_list(self, name):
        a = self.swept(name)
        return list(a.values) if a else [self.system.get(name)]

    def values(self, name):
        return set(self.values_list(name))


def _text(w, key, text, limit, what):
    """A free-text value of at most ``limit`` characters and no control characters but
    newline and tab (``info`` prints it to a terminal, where an escape sequence would act);
    otherwise a problem naming the key and the length or the character (and "" instead,
    so that nothing downstream carries it)."""
    if len(text) > limit:
        w.problems.append(f"{key}: {shown(text)} is {len(text)} characters; at most {limit} "
                          f"({what})")
        return ""
    bad = next((c for c in text if (ord(c) < 0x20 and c not in "\n\t")
                or 0x7F <= ord(c) <= 0x9F), None)
    if bad is not None:
        w.problems.append(f"{key}: {shown(text)} holds the control character {bad!r} at "
                          f"{text.index(bad)}; free text may hold newlines and tabs, no other "
                          "control characters (it is printed to terminals)")
        return ""
    return text


def _read_scene(w):
    sc = w.table("scene")
    w.unknown("scene", _registered()["TABLES"]["scene"])
    name = sc.get("name", "scene")
    if not isinstance(name, str) or not name:
        w.problems.append(f"scene.name: {shown(name)} must be a non-empty string")
        name = "scene"
    else:
        name = _text(w, "scene.name", name, MAX_NAME, "a short name: the default output file "
                     "takes its first 100 characters, outputs.default_output; put a longer "
                     "text in scene.title") or "scene"
    title = sc.get("title", name)
    if not isinstance(title, str):
        w.problems.append(f"scene.title: {shown(title)} must be a string")
        title = ""
    else:
        title = _text(w, "scene.title", title, MAX_TITLE, "a figure's title, stored in the "
                      "file and printed by info")
        p = undrawable(_title_lines(title), "scene.title") if title else None
        if p:
            w.problems.append(p)
    model = sc.get("model", registry.DEFAULT_MODEL)
    models = _registered()["MODELS"]
    if model not in models:
        w.problems.append(f"scene.model: {shown(model)} is not a model"
                          f"{_suggest(str(model), models)}; allowed: " + ", ".join(models))
        model = registry.DEFAULT_MODEL   # validate the rest as such; the error above stands
    w.name, w.title, w.model = name, title, model
    w.spec = registry.get(model)


def _read_system(w):
    sy = w.table("system")
    if w.spec.for_system is not None:
        if not isinstance(w.raw.get("system", {}), dict):
            # said already ("system: ... must be a table"): no system to read, so no
            # problem of each of its keys besides
            raise SceneError(w.problems)
        # a model whose [system] declares the model itself (the linear model's coordinates,
        # matrices and contacts): its own reader, which names each problem's key and value
        specific, problems = w.spec.for_system(sy)
        if specific is None:
            # the rest of the scene (its axes, its starts) is read against the system it
            # declares: said once the system is valid, not against a model with none
            raise SceneError(w.problems + problems)
        w.spec = specific
    spec = w.spec
    w.unknown("system", tuple(spec.params) + tuple(spec.system_extra))
    obstacle = sy.get("obstacle", spec.system_extra.get("obstacle", obstacles.DEFAULT))
    if spec.obstacles and not (isinstance(obstacle, str) and obstacle in spec.obstacles):
        allowed = tuple(spec.obstacles)
        w.problems.append(f"system.obstacle: {shown(obstacle)} is not an obstacle"
                          f"{_suggest(str(obstacle), allowed)}; allowed: {', '.join(allowed)}")
        obstacle = spec.system_extra["obstacle"]
    system = {}
    for p, decl in spec.params.items():
        if p in sy and not _applies(w, decl, obstacle, f"system.{p}"):
            system[p] = decl.default
            continue
        v = sy.get(p, decl.default)
        if v is None and decl.default is None:    # a derived default (theta1 = beta omega)
            system[p] = None
            continue
        system[p] = float(v) if w.param(p, v, f"system.{p}") else decl.default
    section_period = sy.get("section_period") if "section_period" in spec.system_extra else None
    if section_period is not None:
        if not _is_number(section_period) or not math.isfinite(section_period) or section_period <= 0:
            w.problems.append(f"system.section_period: {shown(section_period)} must be a positive number")
            section_period = None
        else:
            section_period = float(section_period)
    # an obstacle kind's own tables (a cam's [system.profile]): read by the kind, refused
    # under another
    w.obstacle_table, w.obstacle_tables = None, {}
    kind = spec.obstacles.get(obstacle) if spec.obstacles else None
    for other in (spec.obstacles or {}).values():
        for key in other.tables:
            if other is not kind and sy.get(key) is not None:
                w.problems.append(f"system.{key}: given, but system.obstacle is {obstacle!r}; "
                                  f"a {key} is the obstacle \"{other.name}\"")
    if kind is not None:
        kind.read_tables(sy, w)
    w.obstacle, w.system, w.section_period = obstacle, system, section_period
    w.extra = {k: v for k, v in (("obstacle", obstacle), ("section_period", section_period))
               if k in spec.system_extra}


def _applies(w, decl, obstacle, key) -> bool:
    """Whether a parameter given at ``key`` applies to the scene's obstacle (``Param.
    obstacles``: the triangle's slopes mean nothing on another); a problem naming the
    obstacles it applies to when it does not."""
    only = decl.obstacles
    if not only or not w.spec.obstacles or obstacle in only:
        return True
    if obstacle not in w.spec.obstacles:
        return True                          # the obstacle's own problem is reported
    which = " and ".join(repr(o) for o in only)
    w.problems.append(f"{key}: {decl.name} is a parameter of obstacle {which} only "
                      f"({decl.doc}), and system.obstacle is {obstacle!r}: remove it, or "
                      f"choose obstacle {which}")
    return False


def _start_time_problem(w, c, values, key):
    """A start time (``Model.start_time``) past MAX_START_TIME, as a problem (else None)."""
    st = w.spec.start_time
    if st is None or c != st.name:
        return None
    big = [x for x in values if abs(x) > MAX_START_TIME]
    if not big:
        return None
    return (f"{key}: {big[0]!r} is past the start times allowed, |t0| <= {MAX_START_TIME:g}: "
            "the kernels place a start by its obstacle period and phase t0 - m P, which "
            "float64 resolves only to about 1e-10 there; give the phase within the first "
            "periods instead")


def _finite_value(w, key):
    """A check of an axis value that is any finite number (a start coordinate; a start
    time within MAX_START_TIME)."""
    c = key[len(IC_PREFIX):]

    def check(_, v, where):
        if _is_number(v) and math.isfinite(v):
            p = _start_time_problem(w, c, [float(v)], where)
            if p is None:
                return True
            w.problems.append(p)
            return False
        w.problems.append(f"{where}: {shown(v)} must be a finite number")
        return False
    return check


def _read_axis(w, k, spec, check=None):
    """The values of one ``[sweep]`` axis, or None after a problem; ``check(name, value,
    key)`` validates a value (default: the parameter's range)."""
    key = f"sweep.{k}"
    check = check or w.param
    if not isinstance(spec, dict):
        w.problems.append(f"{key}: {shown(spec)} must be {{ start = .., stop = .., num = .. }} "
                          "or { values = [...] }")
        return None
    extra = set(spec) - {"start", "stop", "num", "values"}
    for e in sorted(extra):
        w.problems.append(f"{key}.{cut(e, KEY_CHARS)}: unknown key"
                          f"{_suggest(e, ('start', 'stop', 'num', 'values'))}; "
                          "allowed: start, stop, num, values")
    if "values" in spec:
        if {"start", "stop", "num"} & set(spec):
            w.problems.append(f"{key}: give either values or start/stop/num, not both")
        vals = spec["values"]
        if not isinstance(vals, list) or not vals:
            w.problems.append(f"{key}.values: {shown(vals)} must be a non-empty list of numbers")
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
        w.problems.append(f"{key}.num: {shown(num)} must be an integer >= 1")
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
    elif not math.isfinite(hi - lo):
        w.problems.append(f"{key}: from {lo!r} to {hi!r}: stop - start overflows float64 (the "
                          "axis's values are start + i (stop - start) / (num - 1)); the two "
                          "must lie within about 1.8e308 of each other")
    else:
        values = np.linspace(lo, hi, num)
        if not np.isfinite(values).all():
            w.problems.append(f"{key}: from {lo!r} to {hi!r} in {num} values gives non-finite "
                              "values; narrow the range")
        elif num > 1 and not (np.diff(values) > 0).all():
            w.problems.append(f"{key}: {num} values from {lo!r} to {hi!r} are not distinct in "
                              f"float64 (a step of {(hi - lo) / (num - 1)!r} is below the "
                              "resolution at these values); use fewer values or a wider range")
        else:
            return tuple(float(x) for x in values)
    return None


def _read_sweep(w):
    sw = w.table("sweep")
    params = w.spec.params
    follow = sw.get("follow", "none")
    if follow not in FOLLOW:
        w.problems.append(f"sweep.follow: {shown(follow)} is not allowed; allowed: {', '.join(FOLLOW)}")
        follow = "none"
    axes = []
    for k, spec in sweep_items(sw):
        if k.startswith(IC_PREFIX):
            c = k[len(IC_PREFIX):]
            if c not in w.spec.start_names:
                w.problems.append(f"sweep.{cut(k, KEY_CHARS)}: {shown(c)} is not a start coordinate of model "
                                  f"{w.model!r}; allowed: "
                                  + listed(IC_PREFIX + x for x in w.spec.start_names))
                continue
            values = _read_axis(w, k, spec, _finite_value(w, k))
            if values is not None:
                axes.append(Axis(k, values))
            continue
        if k not in params:
            w.problems.append(f"sweep.{cut(k, KEY_CHARS)}: {shown(k)} is not a parameter of model {w.model!r}"
                              f"{_suggest(str(k), params)}; allowed: {listed(params)}")
            continue
        if not _applies(w, params[k], w.obstacle, f"sweep.{k}"):
            continue
        values = _read_axis(w, k, spec)
        if values is not None:
            axes.append(Axis(k, values))
    if isinstance(w.raw.get("sweep"), dict) and not axes:
        if not [k for k in sw if k != "follow"]:
            w.problems.append("sweep: no axis given; add e.g. "
                              "kappa = { start = -0.02, stop = 0.0, num = 101 }")
    if len(axes) > 2:
        w.problems.append(f"sweep: {len(axes)} axes ({listed(a.name for a in axes)}); at most two")
    points = math.prod(len(a.values) for a in axes)
    if points > MAX_GRID_POINTS:
        w.problems.append(f"sweep: {' x '.join(str(len(a.values)) for a in axes)} = {points} grid "
                          f"points; at most {MAX_GRID_POINTS} (the done mask and the block list "
                          "grow with the grid)")
    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        w.problems.append(f"sweep: two axes name one parameter ({listed(names)})")
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
    if ob is not None and any(t not in w.obstacle_tables for t in ob.tables):
        ob = None                       # a table not read: its problem is reported already
    if sp is not None and ob is not None and w.system.get("omega"):
        per = ob.period(w.system["omega"], w.obstacle_table)
        m = sp / per
        if not m < 2**52:
            w.problems.append(f"system.section_period: {sp!r} is {m:.3g} obstacle periods "
                              f"(P = {per!r}); at most 2^52, the whole numbers float64 holds")
        elif abs(m - round(m)) > 1e-9 * max(1.0, m) or round(m) < 1:
            w.problems.append(f"system.section_period: {sp!r} is not a whole number of "
                              f"obstacle periods (P = {per!r})")
    if ob is not None:
        ob.check_scales(w, axes)
    w.axes, w.follow = axes, follow


def recorded_obstacle(scene) -> str:
    """The obstacle a file records (its root attribute ``obstacle``): the scene's, or, for a
    model without obstacles, the default kind's name (format version 1 names one in every
    file)."""
    return scene.extra.get("obstacle", obstacles.DEFAULT)


def _fixed(rng) -> bool:
    """A start range that draws one value (a number, or [a, a])."""
    return _is_number(rng) or (isinstance(rng, list) and len(rng) == 2 and rng[0] == rng[1])


def _read_points(w, ini):
    """``[initial] points`` (or ``points_file``): the starts given, each a list of the
    model's start coordinates in order (``Model.start_names``; the start time, where the
    model has one, may be left out: 0), every one of them used at every grid point; a tuple
    of tuples, or None when the scene draws its starts.  Problems are added to the walk."""
    given = [k for k in INITIAL_LISTS if k in ini]
    if not given:
        return None
    names = w.spec.start_names
    if len(given) > 1:
        w.problems.append("initial.points and initial.points_file: give one of the two")
        return None
    if given[0] == "points_file":
        path = ini["points_file"]
        if not isinstance(path, str) or not path:
            w.problems.append(f"initial.points_file: {shown(path)} must be a path (text: one "
                              f"start per line, {listed(names)})")
            return None
        full = path if os.path.isabs(path) or w.source.startswith("<") else os.path.join(
            os.path.dirname(w.source), path)
        try:
            if not stat.S_ISREG(os.stat(full).st_mode):
                raise ValueError("not a regular file (a folder, a pipe or a device is never "
                                 "read: it may never end)")
            with open(full, encoding="utf-8") as fh:
                text = fh.read(MAX_POINTS_BYTES + 1)
            if len(text) > MAX_POINTS_BYTES:
                raise ValueError(f"more than {MAX_POINTS_BYTES} characters")
            rows = [[float(x) for x in line.replace(",", " ").split()]
                    for line in text.splitlines()
                    if line.strip() and not line.lstrip().startswith("#")]
        except (OSError, ValueError, UnicodeDecodeError) as e:
            w.problems.append(f"initial.points_file: {shown(path)} cannot be read as starts "
                              f"({type(e).__name__}: {cut(str(e))})")
            return None
        key, pts = "initial.points_file", rows
    else:
        key, pts = "initial.points", ini["points"]
    others = [k for k in ("count", "seed", *names) if k in ini]
    if others:
        w.problems.append(f"{key}: the starts are given, so initial.{others[0]} has no use; "
                          "give one or the other")
    swept = [a.name for a in getattr(w, "axes", ()) if a.name.startswith(IC_PREFIX)]
    if swept:
        w.problems.append(f"{key}: the starts are given, so sweep.{swept[0]} (a swept start "
                          "coordinate) has no use; give one or the other")
    full_len, state_len = len(names), len(w.spec.coords)
    if (not isinstance(pts, list) or not 1 <= len(pts) <= MAX_STARTS
            or not all(isinstance(p, list) and len(p) in (state_len, full_len)
                       and all(_is_number(x) and math.isfinite(x) for x in p) for p in pts)):
        w.problems.append(f"{key}: {shown(pts)} must be a list of 1..{MAX_STARTS} starts, each "
                          f"[{listed(names)}] of finite numbers"
                          + (f" (or without {cut(names[-1], KEY_CHARS)}: 0)"
                             if full_len > state_len else ""))
        return None
    out = tuple(tuple(float(x) for x in p) + (0.0,) * (full_len - len(p)) for p in pts)
    if full_len > state_len:                 # the start time: the ranges' rule, per start
        for p in out:
            why = _start_time_problem(w, names[-1], [p[-1], p[-1]], key)
            if why:
                w.problems.append(why)
                return None
    return out


def _read_initial(w):
    ini = w.table("initial")
    initial_keys = _registered()["TABLES"]["initial"]
    # with the coordinates a scene's [system] declares (the linear model's)
    w.unknown("initial", initial_keys + tuple(c for c in w.spec.start_names if c not in initial_keys))
    n_ic = ini.get("count", INITIAL_DEFAULTS["count"])
    if not _is_int(n_ic) or not 1 <= n_ic <= MAX_STARTS:
        w.problems.append(f"initial.count: {shown(n_ic)} must be an integer in 1..{MAX_STARTS} "
                          "(starts are keyed by point * 2^20 + start)")
        n_ic = 1
    seed = ini.get("seed", INITIAL_DEFAULTS["seed"])
    if not _is_int(seed) or not 0 <= seed < MAX_INT:
        w.problems.append(f"initial.seed: {shown(seed)} must be an integer in 0..2^62 - 1")
        seed = 0
    coords = w.spec.start_names
    w.points = _read_points(w, ini)
    if w.points is not None:
        n_ic = len(w.points)
    for c in initial_keys[len(INITIAL_DEFAULTS) + len(INITIAL_LISTS):]:
        if c in ini and c not in coords:
            w.problems.append(f"initial.{c}: not an initial coordinate of model {w.model!r}; "
                              f"allowed: {listed(coords)}")
    swept = [a.name[len(IC_PREFIX):] for a in getattr(w, "axes", ())
             if a.name.startswith(IC_PREFIX)]
    for c in swept:
        if c in ini:
            w.problems.append(f"initial.{c}: {shown(ini[c])} but sweep.initial.{c} sweeps it; "
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
            w.problems.append(f"initial.{c}: {shown(rng)} must be a range [low, high] of finite numbers")
            rng = default
        elif rng[1] < rng[0]:
            w.problems.append(f"initial.{c}: {shown(rng)} has high < low")
        elif not math.isfinite(float(rng[1]) - float(rng[0])):
            w.problems.append(f"initial.{c}: {shown(rng)}: high - low overflows float64 (a start "
                              "is drawn as low + (high - low) x, x in [0, 1)); the ends must "
                              "lie within about 1.8e308 of each other")
            rng = default
        elif _start_time_problem(w, c, [float(x) for x in rng], f"initial.{c}"):
            w.problems.append(_start_time_problem(w, c, [float(x) for x in rng], f"initial.{c}"))
            rng = default
        ranges[c] = (float(rng[0]), float(rng[1]))
    w.n_ic, w.seed, w.ranges = n_ic, seed, ranges


def _read_run(w):
    rn = w.table("run")
    w.unknown("run", _registered()["TABLES"]["run"])
    preset = rn.get("preset", DEFAULT_PRESET)
    if not isinstance(preset, str) or preset not in PRESETS:
        w.problems.append(f"run.preset: {shown(preset)} is not a preset"
                          f"{_suggest(str(preset), PRESETS)}; allowed: {', '.join(PRESETS)}")
        preset = DEFAULT_PRESET
    run = {}
    for k, default in RUN_DEFAULTS.items():
        default = PRESETS[preset].get(k, default)
        v = rn.get(k, default)
        if k == "stop":
            if v is not None and v not in STOPS:
                w.problems.append(f"run.stop: {shown(v)} is not allowed; allowed: {', '.join(STOPS)}")
                v = None
            elif v == "period" and not w.spec.early_stop:
                which = " or ".join(repr(m.name) for m in _all_models() if m.early_stop)
                w.problems.append(f"run.stop: 'period' is implemented for model {which} only, "
                                  f"not {w.model!r}; allowed here: none")
                v = None
            run[k] = v
            continue
        if k == "lyapunov_impacts":
            run[k] = _lyapunov_impacts(w, v)
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
                w.problems.append(f"run.{k}: {shown(v)} must be an integer in {lo}..{hi}"
                                  + (why if _is_int(v) and v > hi else ""))
                v = default if default is not None else 1
        else:
            if not _is_number(v) or not math.isfinite(v) or v <= 0:
                w.problems.append(f"run.{k}: {shown(v)} must be a positive finite number")
                v = default
            elif k == "tol" and v > 1e-3:
                w.problems.append(f"run.tol: {v!r} is too coarse; the event-time tolerance must be <= 1e-3")
            v = float(v)
        run[k] = v
    events, periods = automatic_budgets(w.spec.events_per_impact,
                                        run["transient"] + run["record"])
    if run["max_events"] is None:
        run["max_events"] = min(events, MAX_INT - 1)
    if run["max_periods"] is None:
        run["max_periods"] = min(periods, MAX_PERIODS)
    w.preset, w.run, w.run_given = preset, run, rn


def _lyapunov_impacts(w, v):
    """``run.lyapunov_impacts``: the exponents averaged over this many impacts streamed by the
    kernel (none stored, any number: docs/stability.md), for a model that streams them;
    None (the default): over the recorded window."""
    if v is None:
        return None
    if not _is_int(v) or not 1 <= v <= MAX_INT - 1:
        w.problems.append(f"run.lyapunov_impacts: {shown(v)} must be an integer in "
                          f"1..{MAX_INT - 1}")
        return None
    if not w.spec.streams_lyapunov:
        which = " or ".join(repr(m.name) for m in _all_models() if m.streams_lyapunov)
        w.problems.append(f"run.lyapunov_impacts = {v}: exponents streamed over any number "
                          f"of impacts are implemented for model {which}, not {w.model!r}; "
                          "without the key they are averaged over the recorded window")
        return None
    return v


def _read_output(w):
    outp = w.table("output")
    w.unknown("output", _registered()["TABLES"]["output"])
    known = _registered()["KEEP"]
    keep = outp.get("keep", list(_registered()["KEEP_DEFAULT"]))
    if isinstance(keep, list) and len(keep) > len(known):
        w.problems.append(f"output.keep: {shown(keep)}: {len(keep)} entries; it lists each "
                          f"observable at most once: {', '.join(w.spec.observables)}")
        keep = list(w.spec.observables)
    if not isinstance(keep, list) or not all(isinstance(x, str) for x in keep):
        hint = f' (a list: keep = ["{keep}"])' if isinstance(keep, str) and keep in known else ""
        w.problems.append(f"output.keep: {shown(keep)} must be a list drawn from "
                          f"{', '.join(w.spec.observables)}{hint}")
        # one problem: nothing more is said of it (every observable, so that no check that
        # needs one, such as plot.kind's, adds a second)
        keep = list(w.spec.observables)
    for x in keep:
        if x not in known:
            w.problems.append(f"output.keep: {x!r} is not an observable{_suggest(x, known)}; "
                              f"allowed: {', '.join(known)}")
    keep = tuple(x for x in known if x in keep)
    allowed_keep = tuple(w.spec.observables)
    for x in keep:
        if x not in allowed_keep and "keep" in outp:
            w.problems.append(f"output.keep: {x!r} is not an observable of model {w.model!r}"
                              f"{w.spec.keep_hint}; allowed: {', '.join(allowed_keep)}")
    w.keep = tuple(x for x in keep if x in allowed_keep)
    if w.run.get("lyapunov_impacts") is not None and "stability" not in w.keep:
        w.problems.append(f"run.lyapunov_impacts: {w.run['lyapunov_impacts']} streams the "
                          "Lyapunov exponents of the stability observable; output.keep must "
                          'contain "stability"')
    if w.run["stop"] is None:
        w.run["stop"] = "period" if (w.spec.early_stop and not w.keep) else "none"


def _plain(v) -> bool:
    """A value the scene as run can hold: a string, a finite-width number, or a list of them
    (not a date, a table or None)."""
    if isinstance(v, list):
        return all(_plain(x) for x in v)
    return isinstance(v, (str, bool)) or _is_number(v)


def undrawable(text: str, key: str) -> str | None:
    """A problem when matplotlib cannot draw ``text`` (a title or a label: its mathtext,
    between $ signs, does not parse, or nests past what its parser can recurse), else None
    (``plot_style.mathtext_problem``, which imports matplotlib only when some line of the
    text is mathtext)."""
    found = plot_style.mathtext_problem(text)
    if found is None:
        return None
    line, why = found
    return (f"{key}: {shown(text)}: matplotlib cannot draw {shown(line)} ({why}); the text "
            "between $ signs is matplotlib's mathtext (a literal dollar is \\$)")


def _plot_window(pl, lim, problems):
    """``[plot] xlim`` or ``ylim``: [low, high] that matplotlib can draw (MAX_PLOT_LIMIT,
    MIN_PLOT_WIDTH)."""
    v = pl[lim]
    if not (isinstance(v, list) and len(v) == 2 and all(_is_number(x) for x in v)):
        problems.append(f"plot.{lim}: {shown(v)} must be [low, high], two numbers")
        return
    lo, hi = float(v[0]), float(v[1])
    if not all(math.isfinite(x) and abs(x) <= MAX_PLOT_LIMIT for x in (lo, hi)):
        problems.append(f"plot.{lim}: {shown(v)} must be finite, within +-{MAX_PLOT_LIMIT:g} "
                        "(matplotlib's ticks and transforms take differences and products "
                        "of the ends)")
    elif not lo < hi:
        problems.append(f"plot.{lim}: {shown(v)} must be [low, high] with low < high")
    elif hi - lo < max(MIN_PLOT_WIDTH * max(abs(lo), abs(hi)), 1.0 / MAX_PLOT_LIMIT):
        problems.append(f"plot.{lim}: {shown(v)} is {hi - lo!r} wide; a window must be at least "
                        f"{MIN_PLOT_WIDTH:g} of its ends' magnitude (and {1.0 / MAX_PLOT_LIMIT:g})"
                        " wide, or its ticks and pixels are not distinct")


def _read_plot(w):
    """``[plot]``: how ``cornerbif plot`` draws the file.  Every key is checked here, before
    any work, with its key and value: types, finite numbers, windows matplotlib can draw,
    sizes within their limits (MAX_MARKER_SIZE, MAX_PLOT_CYCLES, MAX_PANELS), free text
    within its (MAX_TITLE, MAX_MARKS, MAX_MARK_LABEL) and drawable, the style sheet a
    name matplotlib knows or a file of at most MAX_STYLE_BYTES."""
    pl = w.table("plot")
    before = len(w.problems)
    w.unknown("plot", _registered()["TABLES"]["plot"])
    plot = dict(pl)
    problems = w.problems
    if "color_by" in plot:
        if plot["color_by"] not in PLOT_COLOR_BY:
            problems.append(f"plot.color_by: {shown(plot['color_by'])} is not allowed; allowed: "
                            + ", ".join(PLOT_COLOR_BY))
        elif "stability" not in w.keep:
            problems.append("plot.color_by: colours come from the stability datasets; "
                            "output.keep must contain \"stability\"")
    if "y" in plot and plot["y"] not in PLOT_Y:
        problems.append(f"plot.y: {shown(plot['y'])} is not allowed; allowed: {', '.join(PLOT_Y)}")
    for lim in ("xlim", "ylim"):
        if lim in plot:
            _plot_window(plot, lim, problems)
    if "marker_size" in plot:
        v = plot["marker_size"]
        if not (_is_number(v) and math.isfinite(v) and 0 < v <= MAX_MARKER_SIZE):
            problems.append(f"plot.marker_size: {shown(v)} must be a number of points in (0, "
                            f"{MAX_MARKER_SIZE:g}] (a marker's size; default: from the number "
                            "of points drawn)")
    _read_plot_text(w, plot)
    if "orbits" in plot and plot["orbits"] not in PLOT_ORBITS:
        problems.append(f"plot.orbits: {shown(plot['orbits'])} must be \"words\" (a colour per "
                        "orbit), \"families\" (one per family such as beta^N gamma) or "
                        "\"branches\" (one per branch of cornerbif explain)")
    if "style" in plot:
        p = plot_style.style_problem(plot["style"], "plot.style")
        if p:
            problems.append(p)
    _read_plot_kind(w, plot)
    _read_plot_runs(w, plot)
    # what the scene as run cannot hold (a date, a table), said of a key only where its own
    # check above said nothing: one problem a key (marks = [{at = 1}] was said twice, in two
    # ways)
    said = {re.split(r"[:\[]", p, maxsplit=1)[0] for p in problems[before:]}
    for k, v in plot.items():
        key = f"plot.{cut(k, KEY_CHARS)}"
        if not _plain(v) and key not in said:
            problems.append(f"{key}: {shown(v)} must be a string, a number or a list of them")
    w.plot = plot


def _read_plot_text(w, plot):
    """``[plot] title`` and ``marks``: free text within its limits (MAX_TITLE, MAX_MARKS,
    MAX_MARK_LABEL) that matplotlib can draw (``undrawable``), marks on the one swept axis
    within its range."""
    problems = w.problems
    if "title" in plot:
        if not isinstance(plot["title"], str):
            problems.append(f"plot.title: {shown(plot['title'])} must be a string")
        elif _text(w, "plot.title", plot["title"], MAX_TITLE, "a figure's title"):
            p = undrawable(_title_lines(plot["title"]), "plot.title")
            if p:
                problems.append(p)
    if "marks" in plot:
        v = plot["marks"]
        if isinstance(v, list) and len(v) > MAX_MARKS:
            problems.append(f"plot.marks: {len(v)} marks; at most {MAX_MARKS} (dotted lines on "
                            "one diagram)")
        elif not (isinstance(v, list) and all(isinstance(m, list) and len(m) == 2
                                              and _is_number(m[0]) and math.isfinite(m[0])
                                              and isinstance(m[1], str) for m in v)):
            problems.append(f"plot.marks: {shown(v)} must be a list of [value, \"label\"] "
                            "pairs (values on the swept axis, marked by dotted lines)")
        elif len(w.axes) != 1:
            problems.append("plot.marks: marks values on a diagram's one swept axis; this scene "
                            f"sweeps {len(w.axes)} axes")
        else:
            lo, hi = min(w.axes[0].values), max(w.axes[0].values)
            for i, (x, lab) in enumerate(v):
                key = f"plot.marks[{i}]"
                if not lo <= x <= hi:
                    problems.append(f"{key}: {x!r} ({shown(lab)}) is outside the swept "
                                    f"{w.axes[0].name} range [{lo!r}, {hi!r}]")
                if _text(w, key, lab, MAX_MARK_LABEL, "a label beside a dotted line"):
                    p = undrawable(f"{lab} = {x:.10g}", key)     # as the legend draws it
                    if p:
                        problems.append(p)


def _read_plot_kind(w, plot):
    """``[plot] kind``: one of the registered figure kinds (``registry.figures``), whose own
    ``check`` says what of the scene it needs."""
    kinds = figures.registered()
    kind = plot.get("kind", figures.DEFAULT)
    if not (isinstance(kind, str) and kind in kinds):
        w.problems.append(f"plot.kind: {shown(kind)} is not a plot kind"
                          f"{_suggest(str(kind)[:100], kinds)}; allowed: {', '.join(kinds)}")
        return
    w.problems += kinds[kind].check(w)


def _read_plot_runs(w, plot):
    """``[plot] ic``, ``point``, ``cycles`` and ``max_panels``: which starts and grid point a
    figure of single runs shows, over how many periods, in how many panels."""
    problems = w.problems
    if "ic" in plot:
        v = plot["ic"]
        if not (v == "distinct" or (isinstance(v, list) and 0 < len(v) <= w.n_ic
                                    and all(_is_int(i) and 0 <= i < w.n_ic for i in v))):
            problems.append(f"plot.ic: {shown(v)} must be \"distinct\" or a list of at most "
                            f"{w.n_ic} start indices in 0..{w.n_ic - 1}")
    if "point" in plot:
        v = plot["point"]
        shape = [len(a.values) for a in w.axes]
        if not (isinstance(v, list) and len(v) == len(shape)
                and all(_is_int(i) and 0 <= i < n for i, n in zip(v, shape))):
            problems.append(f"plot.point: {shown(v)} must be a grid index with one entry per swept "
                            f"axis ({len(shape)}), each in 0..len-1 (grid {tuple(shape)})")
    if "cycles" in plot:
        v = plot["cycles"]
        if not (_is_number(v) and math.isfinite(v) and 0 < v <= MAX_PLOT_CYCLES):
            problems.append(f"plot.cycles: {shown(v)} must be a number in (0, {MAX_PLOT_CYCLES}] "
                            "(periods drawn, each from a fixed number of samples)")
    if "max_panels" in plot:
        v = plot["max_panels"]
        if not (_is_int(v) and 1 <= v <= MAX_PANELS):
            problems.append(f"plot.max_panels: {shown(v)} must be an integer in 1..{MAX_PANELS} "
                            "(a time-series figure's panels, one per start)")


def _title_lines(text: str) -> str:
    """A title as ``cornerbif plot`` draws it: in the paper's notation (``plot_style.
    title_tex``, which imports no matplotlib); its line breaks never fall inside a formula,
    so each formula is checked whole.  A title without a $ of its own is returned as it is:
    the notation's formulas ($\\omega$, $\\kappa_{CC}$) are well formed, and the check then
    imports no matplotlib (a quarter of a second at every command's start)."""
    if "$" not in text:
        return text
    return plot_style.title_tex(text)


def _read_continue(w):
    """``[continue]``: one-parameter continuation of the periodic orbits found at the
    start (``cornerbif continue``, cornerbif.continuation).  Every key is checked here, so
    that ``validate`` refuses what ``continue`` could not run: numbers finite and within
    their parameter's own bounds, steps that can move the parameter in double precision
    (``_continue_steps``), seed words of the model's letters and of bounded length
    (``analysis.parse_word``), a second parameter whose curves can be made
    (``_continue_curve``), and paths and names as text (``_continue_names``)."""
    w.cont = {}
    if "continue" not in w.raw:
        return
    c = w.table("continue")
    w.unknown("continue", _registered()["TABLES"]["continue"])
    pr = w.problems
    if not w.spec.continuation:
        which = " or ".join(repr(m.name) for m in _all_models() if m.continuation)
        pr.append(f"continue: model {w.model!r} has no orbit solver yet; continuation runs "
                  f"model {which}")
        return
    kind = w.spec.obstacles.get(w.obstacle) if w.spec.obstacles else None
    if kind is not None and not kind.continuation:
        which = ", ".join(repr(o.name) for o in w.spec.obstacles.values() if o.continuation)
        pr.append(f"continue: obstacle {w.obstacle!r} has no orbit solver yet; sweep it, or "
                  f"continue one of the obstacles {which}")
        return
    name = c.get("parameter")
    numeric = list(w.spec.params)
    if not isinstance(name, str) or name not in numeric:
        pr.append(f"continue.parameter: {_fmt(name)} is not a numeric parameter of model "
                  f"{w.model!r}{_suggest(str(name), numeric)}; allowed: {listed(numeric)}")
        return
    if any(a.name == name for a in w.axes):
        pr.append(f"continue.parameter: {name!r} is also swept ([sweep] {name}); continue "
                  "from one point: remove the axis")
    out = {"parameter": name}
    # a forcing F with its frequency Omega = 0 is a constant force (a follower's preload):
    # periodic with any wall
    forced = [k for k in numeric if k.startswith("F") and w.system.get(k) not in (0, 0.0, None)
              and w.system.get("Omega" + k[1:]) not in (0, 0.0)]
    if forced and name.lower().startswith("omega"):
        pr.append(f"continue.parameter: {name!r} with forcing {forced[0]} = "
                  f"{_fmt(w.system[forced[0]])}: a periodic orbit needs the forcing's period "
                  "and the wall's commensurate, which continuing a frequency breaks; "
                  "continue another parameter, or set the forcing to 0")
    rng = _continue_range(w, c, "range", name)
    if rng is None:
        return
    out["range"] = rng
    start = c.get("start", w.system.get(name))
    if not _is_number(start) or not rng[0] <= start <= rng[1]:
        pr.append(f"continue.start: {_fmt(start)} must be a number within continue.range "
                  f"{_fmt(c.get('range'))} (default: system.{name})")
        return
    w.param(name, start, "continue.start")
    out["start"] = float(start)
    seed = c.get("seed", "all")
    seeds = seed if isinstance(seed, list) else [seed]
    if not seeds or not all(isinstance(s, str) and s for s in seeds):
        pr.append(f"continue.seed: {_fmt(seed)} must be \"all\" or a cycle word (or a list "
                  "of words), e.g. \"b\", \"a\", \"b^5 g\"")
    else:
        for s in seeds:
            if s != "all":
                _check_seed_word(w, s)
    out["seed"] = seed
    _continue_steps(w, c, rng[1] - rng[0], out)
    ev = c.get("events", list(CONTINUE_EVENTS))
    if not (isinstance(ev, list) and all(isinstance(x, str) and x in CONTINUE_EVENTS
                                         for x in ev)
            and len(set(ev)) == len(ev)):
        pr.append(f"continue.events: {_fmt(ev)} must be a list drawn from "
                  + ", ".join(CONTINUE_EVENTS) + ", each at most once (a corner collision, "
                  "a grazing and a zero-velocity impact end a branch whether listed or not)")
        ev = list(CONTINUE_EVENTS)
    out["events"] = list(ev)
    sw = c.get("switch", True)
    if not isinstance(sw, bool):
        pr.append(f"continue.switch: {_fmt(sw)} must be true or false")
    out["switch"] = bool(sw) if isinstance(sw, bool) else True
    _continue_curve(w, c, numeric, out)
    _continue_names(w, c, out)
    w.cont = out


def _continue_steps(w, c, width, out):
    """``[continue] ds``, ``ds_min``, ``ds_max`` into ``out``: numbers > 0 (defaults: the
    range's ``width`` / 200, * 1e-9, / 20), ds_min <= ds <= ds_max, ds_max within the range,
    ds_min a step that moves the parameter in double precision (``MIN_CONTINUE_STEP``)."""
    pr = w.problems
    for k, default in (("ds", width / 200.0), ("ds_min", width * 1e-9),
                       ("ds_max", width / 20.0)):
        v = c.get(k, default)
        if not (_is_number(v) and math.isfinite(v) and v > 0):
            pr.append(f"continue.{k}: {_fmt(v)} must be a number > 0")
            v = default
        out[k] = float(v)
    if out["ds_max"] > width:
        pr.append(f"continue.ds_max: {_fmt(out['ds_max'])} must be at most the width of "
                  f"continue.range ({width:.6g}): a longer step leaves the range at once")
    if out["ds_min"] < MIN_CONTINUE_STEP * width:
        pr.append(f"continue.ds_min: {_fmt(out['ds_min'])} must be at least "
                  f"{MIN_CONTINUE_STEP:g} times the width of continue.range "
                  f"({MIN_CONTINUE_STEP * width:.3g}): a smaller step cannot move the parameter "
                  "in double precision (the steps are halved down to it, each a failed "
                  "Newton solve)")
    if not out["ds_min"] <= out["ds"] <= out["ds_max"]:
        pr.append(f"continue.ds: ds_min {out['ds_min']!r} <= ds {out['ds']!r} <= ds_max "
                  f"{out['ds_max']!r} must hold")


# the events whose located points ``[continue] curve`` continues in the second parameter
CURVE_EVENTS = ("corner", "fold")


def _continue_curve(w, c, numeric, out):
    """``[continue] curve`` and ``curve_range`` into ``out``: the curves of the located
    corner collisions and folds (``CURVE_EVENTS``) in a second numeric parameter, not
    swept, over a range holding its value; each key needs the other, and the curves need
    one of their events in ``continue.events`` (a corner collision not listed there still
    ends its branch, but is not located as an event: no curve would be made)."""
    pr = w.problems
    name = out["parameter"]
    if "curve" not in c:
        if "curve_range" in c:
            pr.append(f"continue.curve_range: {_fmt(c['curve_range'])} without continue.curve "
                      "(the second parameter of the curves)")
        return
    cv = c["curve"]
    if cv == name:
        pr.append(f"continue.curve: {cv!r} is the parameter continued (continue.parameter); "
                  "the curves of its corner collisions and folds run in a second one, "
                  f"another numeric parameter of model {w.model!r}; allowed: "
                  + listed(k for k in numeric if k != name))
        return
    if not isinstance(cv, str) or cv not in numeric:
        pr.append(f"continue.curve: {_fmt(cv)} must be another numeric parameter of "
                  f"model {w.model!r} (the second parameter of the corner-collision "
                  f"curves){_suggest(str(cv), [k for k in numeric if k != name])}; allowed: "
                  + listed(k for k in numeric if k != name))
        return
    if any(a.name == cv for a in w.axes):
        pr.append(f"continue.curve: {cv!r} is also swept ([sweep] {cv}); remove the axis")
        return
    at = w.system.get(cv)
    if "curve_range" not in c:
        pr.append(f"continue.curve_range is missing: continue.curve = {cv!r} needs the range "
                  f"of its curves, [low, high] holding system.{cv} = {_fmt(at)} (where they "
                  "start)")
        return
    if not any(e in out["events"] for e in CURVE_EVENTS):
        pr.append(f"continue.curve: {cv!r} continues the located "
                  + " and ".join(map(repr, CURVE_EVENTS)) + " events, but continue.events "
                  f"{_fmt(out['events'])} lists neither, so no curve would be made: add "
                  "one of them to continue.events, or remove continue.curve")
    crng = _continue_range(w, c, "curve_range", cv)
    if crng is not None and not (_is_number(at) and crng[0] <= at <= crng[1]):
        pr.append(f"continue.curve_range: {_fmt(c.get('curve_range'))} must hold "
                  f"system.{cv} = {_fmt(at)} (the curves start there)")
    out["curve"] = cv
    out["curve_range"] = c.get("curve_range")


def _continue_names(w, c, out):
    """``[continue] seed_file`` (a path: text without NUL, at most MAX_STYLE_PATH bytes)
    and ``over`` (a scene's name: printable, at most MAX_OVER_NAME characters) into
    ``out``."""
    pr = w.problems
    if "seed_file" in c:
        sf = c["seed_file"]
        if (not isinstance(sf, str) or not sf or "\0" in sf
                or len(os.fsencode(sf)) > plot_style.MAX_STYLE_PATH):
            pr.append(f"continue.seed_file: {_fmt(sf)} must be the path of a sweep file "
                      f"(cornerbif sweep) of this model over {out['parameter']!r} (text "
                      f"without NUL characters, at most {plot_style.MAX_STYLE_PATH} bytes)")
        else:
            out["seed_file"] = sf
    if "over" in c:
        ov = c["over"]
        if (not isinstance(ov, str) or not ov or len(ov) > MAX_OVER_NAME
                or any(not ch.isprintable() for ch in ov)):
            pr.append(f"continue.over: {_fmt(ov)} must be the name of a scene (printable "
                      f"text of at most {MAX_OVER_NAME} characters)")
        else:
            out["over"] = ov


# [continue] ds_min: the smallest step, relative to the range's width (the continuation's
# steps are fractions of the width; 1e-14 is a few units in the last place of a double)
MIN_CONTINUE_STEP = 1e-14
# [continue] over: a scene's name (the gallery draws the branches over its sweep)
MAX_OVER_NAME = 200


def _continue_range(w, c, key, name):
    """``[continue] range`` or ``curve_range``: [low, high], both finite numbers within the
    parameter's own bounds, low < high and the width finite; None (and a problem) if not."""
    rng = c.get(key)
    if not (isinstance(rng, list) and len(rng) == 2 and all(_is_number(x) for x in rng)
            and all(math.isfinite(x) for x in rng) and rng[0] < rng[1]
            and math.isfinite(float(rng[1]) - float(rng[0]))):
        w.problems.append(f"continue.{key}: {_fmt(rng)} must be [low, high], both finite, "
                          "low < high (and high - low finite)")
        return None
    ok = all([w.param(name, x, f"continue.{key}") for x in rng])
    return [float(rng[0]), float(rng[1])] if ok else None


def _check_seed_word(w, s):
    """A ``[continue] seed`` word: on a smooth obstacle (no corners: every cluster is x)
    a word of x only; elsewhere letters a, b, g (x names a smooth obstacle's cluster and
    has no orbit to solve there); at most ``analysis.MAX_WORD_LETTERS`` letters, counted
    without expanding the word.  A model whose words are its own letters
    (``Model.seed_letters``: a linear system's contacts' names) reads the word in them, case
    kept."""
    alphabet = w.spec.seed_letters()
    if alphabet is not None:
        try:
            parse_word(s, alphabet=alphabet)
        except ValueError as e:
            w.problems.append(f"continue.seed: {_fmt(s)}: {e}; a seed word of this "
                              f"{w.model} system is its contacts' names, case kept (e.g. "
                              f"\"{alphabet}\"), or \"all\" (every attractor)")
        return
    obstacle = w.spec.obstacles.get(w.obstacle) if w.spec.obstacles else None
    smooth = obstacle is not None and not obstacle.corners
    try:
        letters = parse_word(s, allow_x=True)
    except ValueError as e:
        w.problems.append(f"continue.seed: {_fmt(s)}: {e}")
        return
    if smooth and set(letters) != {"x"}:
        w.problems.append(f"continue.seed: {_fmt(s)}: on the smooth obstacle "
                          f"{w.obstacle!r} every cluster is x; seed \"all\" or a word of x "
                          "(\"x\", \"xx\", \"x^3\"), the clusters per cycle")
    elif not smooth and "x" in letters:
        where = f"obstacle {w.obstacle!r}" if obstacle is not None else f"model {w.model!r}"
        w.problems.append(f"continue.seed: {_fmt(s)}: x is the cluster of a smooth "
                          f"obstacle (sine); on {where} a seed word is letters a, b, g "
                          "(e.g. \"b\", \"a\", \"b^5 g\"); \"all\" continues every "
                          "attractor whatever its word")


def _read_model_checks(w):
    """The model's own cross-checks (``Model.check``)."""
    w.problems += w.spec.check(CheckContext(w))


# the declared tables, walked in this order
READERS = (("scene", _read_scene), ("system", _read_system), ("sweep", _read_sweep),
           ("initial", _read_initial), ("run", _read_run), ("output", _read_output),
           ("plot", _read_plot), ("continue", _read_continue), (None, _read_model_checks))


def _wide_tables(raw: dict) -> list:
    """A problem for each table of ``raw`` (and its top level) past MAX_TABLE_KEYS keys."""
    return [f"{t}: {len(b)} keys; a table of a scene has at most {MAX_TABLE_KEYS} (the "
            "format's tables have about 15)" for t, b in
            [("the scene's top level", raw)] + [(cut(t, KEY_CHARS), b) for t, b in raw.items()
                                                 if isinstance(b, dict)]
            if len(b) > MAX_TABLE_KEYS]


def kind_problems(text: str, kind: str) -> list | None:
    """What the figure kind ``kind`` (``figures.registered``) says of a file's scene as run
    ``text`` (its own ``check``, as ``validate`` asks it of ``[plot] kind``), its problems
    without their "plot.kind: " key: a kind given in place of the one the file was swept
    with (``cornerbif plot --kind``) is checked against the file's scene before anything
    is drawn.  The tables it reads are walked as ``from_dict`` walks them, [plot] aside (the
    file's own [plot] is not this kind's); None when the scene cannot be walked that far (a
    file's trouble its readers say)."""
    fk = figures.registered().get(kind)
    try:
        raw = parse_toml(str(text), "<the file's scene>")
        if fk is None or nesting_problem(raw) is not None or _wide_tables(raw):
            return None
        w = _Walk(raw)
        w.source = "<the file's scene>"
        for table, read in READERS:
            if table == "plot":
                break
            read(w)
        said = fk.check(w)
    except (SceneError, RecursionError):
        return None
    return [p.removeprefix("plot.kind:").strip() for p in said]


def from_dict(raw, drawn_starts: bool = True, source: str = "<scene>") -> Scene:
    """Validate a raw scene dict; raise ``SceneError`` listing every problem.

    ``drawn_starts=False`` (``simulate``, which is given its starts) skips the checks of
    the ``[initial]`` ranges against the obstacle.  ``source``: the scene file's path (an
    ``[initial] points_file`` is read beside it), or a name in angle brackets.
    """
    if not isinstance(raw, dict):
        raise SceneError([f"scene: expected a table, got {type(raw).__name__}"])
    deep = nesting_problem(raw)
    if deep:                 # before any reader walks it (each may recurse per level)
        raise SceneError([deep])
    wide = _wide_tables(raw)
    if wide:                 # before a problem is said of each key (unknown, misspelt)
        raise SceneError(wide)
    w = _Walk(raw, drawn_starts)
    w.source = str(source)
    tables = _registered()["TABLES"]
    for t, body in raw.items():
        if t not in tables:
            w.problems.append(f"{cut(t, KEY_CHARS)}: unknown table{_suggest(str(t), tables)}; allowed: "
                              + ", ".join(f"[{x}]" for x in tables))
        elif not isinstance(body, dict):
            w.problems.append(f"{t}: {shown(body)} must be a table [{t}]")
    for _, read in READERS:
        read(w)
    if w.problems:
        more = len(w.problems) - MAX_PROBLEMS
        raise SceneError(w.problems[:MAX_PROBLEMS] + ([f"... and {more} more problems (fix "
                                                       "these first)"] if more > 0 else []))
    return _scene(w)


def _scene(w) -> Scene:
    """The scene as run: defaults made explicit, so the file says everything."""
    run, spec = w.run, w.spec
    system_text = {}
    if "obstacle" in spec.system_extra:
        system_text["obstacle"] = w.obstacle
    system_text |= {k: v for k, v in w.system.items() if v is not None}
    if spec.system_table is not None:          # a [system] that declares the model: as given
        system_text = spec.system_table_with(w.system)
    as_run = {
        "scene": {"name": w.name, "title": w.title, "model": w.model},
        "system": system_text,
        "sweep": {**{a.name: {"values": list(a.values)} for a in w.axes}, "follow": w.follow},
        "initial": ({"points": [list(p) for p in w.points]} if w.points is not None else
                    {"count": w.n_ic, "seed": w.seed,
                     **{c: list(r) for c, r in w.ranges.items()
                        if not any(a.name == IC_PREFIX + c for a in w.axes)}}),
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
    for key, table in getattr(w, "obstacle_tables", {}).items():
        as_run["system"][key] = table
    if w.plot:
        as_run["plot"] = w.plot
    if w.cont:
        as_run["continue"] = w.cont
    return Scene(name=w.name, title=w.title, model=w.model, system=w.system, axes=tuple(w.axes),
                 follow=w.follow, n_ic=w.n_ic, seed=w.seed, initial=w.ranges,
                 transient=run["transient"], record=run["record"], tol=run["tol"],
                 chatter=run["chatter"], escape=run["escape"], period_tol=run["period_tol"],
                 max_events=run["max_events"], max_periods=run["max_periods"], keep=w.keep,
                 plot=w.plot, text=dumps(as_run), preset=w.preset, stop=run["stop"],
                 cont=w.cont, extra=w.extra, obstacle_table=getattr(w, "obstacle_table", None),
                 points=w.points, lyapunov_impacts=run["lyapunov_impacts"] or 0,
                 model_spec=spec if spec is not registry.get(w.model) else None)
