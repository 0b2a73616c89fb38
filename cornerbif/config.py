"""Scenes: TOML text -> frozen, validated ``Scene`` objects.

Every problem of a scene is collected and reported at once, each with its
dotted key, the offending value and what is allowed (STYLE example 7)::

    sweep.omgea: unknown parameter of model 'flow' (did you mean 'omega'?)

The public format (keep these names) is documented in README.md.
"""

from __future__ import annotations

import difflib
import hashlib
import math
import tomllib
from dataclasses import dataclass, field

import numpy as np

MODELS = ("flow", "map2d", "two_particle")
PLANNED_MODELS = ()
OBSTACLES = ("sine", "rectified_sine", "triangle")
KEEP = ("impacts", "section", "wall_impacts")
FOLLOW = ("none", "up", "down")

# system parameters of model 'flow': default (paper scenes), and the allowed range
FLOW_PARAMS = {
    "omega": (2.0, "> 0"),
    "kappa": (0.0, "any finite number"),
    "beta": (1.0, ">= 0"),
    "r": (0.8, "in [0, 1]"),
    "sigma": (0.0, ">= 0"),
    "k": (1.0, ">= 0"),
    "F": (0.0, "any finite number"),
    "Omega": (1.0, "> 0"),
    "phi": (0.0, "any finite number"),
    "theta1": (None, "> 0 (default beta * omega, the slope of eq (8) at its corners)"),
    "theta2": (None, "> 0 (default beta * omega)"),
}
SYSTEM_OTHER = {"obstacle": "rectified_sine", "section_period": None}
# model 'map2d' (section 5): the local maps with epsilon = 1, omega1 = omega - 2, kappa1 = kappa
MAP2D_PARAMS = {
    "omega": (1.999, "> 0 (the map uses omega1 = omega - 2)"),
    "kappa": (-0.01, "any finite number (kappa1 = kappa)"),
    "r": (0.8, "in (0, 1]"),
}
# model 'two_particle' (section 6): wall w = kappa + beta sin(omega0 t) (eq 72), heavy z and
# light u harmonic with omega1, omega2 (eq 73), impacts by law (5) (r1) and eq (74) (r2, mu)
TWO_PARTICLE_PARAMS = {
    "omega0": (2.0, "> 0"),
    "omega1": (1.001, "> 0"),
    "omega2": (1.0, "> 0"),
    "mu": (1000.0, "> 0 (inf allowed: law (74) becomes law (5))"),
    "r1": (0.8, "in [0, 1]"),
    "r2": (0.8, "in [0, 1]"),
    "kappa": (0.0, "any finite number"),
    "beta": (1.0, ">= 0"),
    # beyond the paper: damping and forcing per particle as in 'flow' (eq 4)
    "sigma1": (0.0, ">= 0"),
    "sigma2": (0.0, ">= 0"),
    "F1": (0.0, "any finite number"),
    "Omega1": (1.0, "> 0"),
    "phi1": (0.0, "any finite number"),
    "F2": (0.0, "any finite number"),
    "Omega2": (1.0, "> 0"),
    "phi2": (0.0, "any finite number"),
}
MODEL_PARAMS = {"flow": FLOW_PARAMS, "map2d": MAP2D_PARAMS, "two_particle": TWO_PARTICLE_PARAMS}
MODEL_INITIAL = {"flow": {"u": [0.0, 20.0], "v": [-20.0, 20.0]},
                 "map2d": {"u": [0.0, 20.0], "v": [-0.05, 0.05]},
                 "two_particle": {"z": [0.0, 2.0], "y": [-2.0, 2.0], "u": [0.0, 20.0],
                                  "v": [-20.0, 20.0]}}
MODEL_KEEP = {"flow": ("impacts", "section"), "map2d": ("section",),
              "two_particle": ("impacts", "section", "wall_impacts")}

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
# run.stop: "period" ends each run of the flow once its attractor's period is established
# (the kernel's early stop, cornerbif.kernels.flow); the default is "period" for a flow scene
# that keeps only the summary (output.keep = []) and "none" otherwise
STOPS = ("none", "period")
INITIAL_DEFAULTS = {"count": 8, "seed": 1, "u": [0.0, 20.0], "v": [-20.0, 20.0]}
TABLES = {
    "scene": ("name", "title", "model"),
    "system": tuple(FLOW_PARAMS) + tuple(SYSTEM_OTHER),
    "sweep": None,  # parameter names + 'follow'
    "initial": tuple(INITIAL_DEFAULTS) + ("z", "y"),
    "run": ("preset",) + tuple(RUN_DEFAULTS),
    "output": ("keep",),
    "plot": ("y", "xlim", "ylim", "marker_size", "title", "kind", "point", "ic", "cycles",
             "max_panels"),
}
PLOT_Y = ("impact_u", "impact_v", "section_u", "section_v", "winding", "period")
# [plot] kind: what ``cornerbif plot`` draws from the file (cornerbif/plot.py)
PLOT_KINDS = ("diagram", "timeseries", "corner_curves", "regions", "return_map", "orbit")


class SceneError(ValueError):
    """A scene that cannot be run; ``problems`` lists every problem found."""

    def __init__(self, problems):
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))


@dataclass(frozen=True)
class Axis:
    name: str
    values: tuple

    @property
    def array(self) -> np.ndarray:
        return np.asarray(self.values, dtype=float)


@dataclass(frozen=True)
class Scene:
    name: str
    title: str
    model: str
    obstacle: str
    system: dict            # fixed numeric values (theta1/theta2 may be None)
    section_period: float | None
    axes: tuple             # tuple of Axis, one or two
    follow: str
    n_ic: int
    seed: int
    u_range: tuple
    v_range: tuple
    z_range: tuple | None
    y_range: tuple | None
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
    text: str = ""          # the TOML text as run (overrides applied)
    preset: str = DEFAULT_PRESET   # run.preset the run settings were resolved from
    stop: str = "none"      # run.stop: "period" (early stop, flow only) or "none"

    @property
    def shape(self) -> tuple:
        return tuple(len(a.values) for a in self.axes)

    @property
    def hash(self) -> str:
        return hashlib.sha256(self.text.encode()).hexdigest()

    def point(self, index: tuple) -> dict:
        """Named parameter values at a grid index."""
        vals = dict(self.system)
        for a, i in zip(self.axes, index):
            vals[a.name] = a.values[i]
        return vals


# --------------------------------------------------------------------------- helpers
def _suggest(word, options):
    m = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    return f" (did you mean '{m[0]}'?)" if m else ""


def _is_number(x):
    return isinstance(x, (int, float)) and not isinstance(x, bool)


def _is_int(x):
    return isinstance(x, int) and not isinstance(x, bool)


def _fmt(x):
    return repr(x)


def _check_param(name, value, key, problems, model="flow"):
    allowed = MODEL_PARAMS.get(model, FLOW_PARAMS)[name][1]
    if not _is_number(value):
        problems.append(f"{key}: {_fmt(value)} is not a number; {name} must be {allowed}")
        return False
    v = float(value)
    if not math.isfinite(v) and not (name == "mu" and v == math.inf):
        problems.append(f"{key}: {_fmt(value)} is not finite; {name} must be {allowed}")
        return False
    if name == "mu" and v == math.inf:
        return True
    bad = ((name in ("omega", "Omega", "theta1", "theta2", "omega0", "omega1", "omega2", "mu",
                     "Omega1", "Omega2") and v <= 0)
           or (name in ("beta", "sigma", "k", "sigma1", "sigma2") and v < 0)
           or (name in ("r", "r1", "r2") and not 0.0 <= v <= 1.0)
           or (name == "r" and model == "map2d" and v == 0.0))
    if bad:
        problems.append(f"{key}: {_fmt(value)} is out of range; {name} must be {allowed}")
        return False
    return True


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
        return '"' + v.replace("\\", "\\\\").replace('"', '\\"') + '"'
    if isinstance(v, (list, tuple)):
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
    for ov in overrides:
        try:
            key, val = parse_override(ov) if isinstance(ov, str) else ov
        except SceneError as e:
            problems += e.problems
            continue
        set_dotted(raw, key, val)
    if problems:
        raise SceneError(problems)
    return from_dict(raw)


def from_dict(raw) -> Scene:
    """Validate a raw scene dict; raise ``SceneError`` listing every problem."""
    problems = []
    if not isinstance(raw, dict):
        raise SceneError([f"scene: expected a table, got {type(raw).__name__}"])
    for t, body in raw.items():
        if t not in TABLES:
            problems.append(f"{t}: unknown table{_suggest(str(t), TABLES)}; allowed: "
                            + ", ".join(f"[{x}]" for x in TABLES))
        elif not isinstance(body, dict):
            problems.append(f"{t}: {_fmt(body)} must be a table [{t}]")

    def table(name):
        b = raw.get(name, {})
        return b if isinstance(b, dict) else {}

    def unknown(name, allowed):
        for k in table(name):
            if k not in allowed:
                where = [t for t, keys in TABLES.items() if keys and k in keys and t != name]
                hint = f" (it belongs in [{where[0]}])" if where else _suggest(str(k), allowed)
                problems.append(f"{name}.{k}: unknown key{hint}; allowed: {', '.join(allowed)}")

    # [scene]
    sc = table("scene")
    unknown("scene", TABLES["scene"])
    name = sc.get("name", "scene")
    if not isinstance(name, str) or not name:
        problems.append(f"scene.name: {_fmt(name)} must be a non-empty string")
        name = "scene"
    title = sc.get("title", name)
    if not isinstance(title, str):
        problems.append(f"scene.title: {_fmt(title)} must be a string")
        title = str(title)
    model = sc.get("model", "flow")
    if model not in MODELS:
        if model in PLANNED_MODELS:
            problems.append(f"scene.model: {_fmt(model)} is not implemented yet; allowed: "
                            + ", ".join(MODELS))
        else:
            problems.append(f"scene.model: {_fmt(model)} is not a model"
                            f"{_suggest(str(model), MODELS + PLANNED_MODELS)}; allowed: "
                            + ", ".join(MODELS))
        model = "flow"   # validate the rest as a flow scene; the error above stands

    # [system]
    sy = table("system")
    mparams = MODEL_PARAMS.get(model, FLOW_PARAMS)
    if model in ("map2d", "two_particle"):
        unknown("system", tuple(mparams))
    else:
        unknown("system", TABLES["system"])
    obstacle = sy.get("obstacle", SYSTEM_OTHER["obstacle"])
    if obstacle not in OBSTACLES:
        problems.append(f"system.obstacle: {_fmt(obstacle)} is not an obstacle"
                        f"{_suggest(str(obstacle), OBSTACLES)}; allowed: {', '.join(OBSTACLES)}")
        obstacle = "rectified_sine"
    system = {}
    for p, (default, _) in mparams.items():
        v = sy.get(p, default)
        if v is None:
            system[p] = None
            continue
        if _check_param(p, v, f"system.{p}", problems, model):
            system[p] = float(v)
        else:
            system[p] = default
    section_period = sy.get("section_period")
    if section_period is not None:
        if not _is_number(section_period) or not math.isfinite(section_period) or section_period <= 0:
            problems.append(f"system.section_period: {_fmt(section_period)} must be a positive number")
            section_period = None
        else:
            section_period = float(section_period)

    # [sweep]
    sw = table("sweep")
    follow = sw.get("follow", "none")
    if follow not in FOLLOW:
        problems.append(f"sweep.follow: {_fmt(follow)} is not allowed; allowed: {', '.join(FOLLOW)}")
        follow = "none"
    axes = []
    for k, spec in sw.items():
        if k == "follow":
            continue
        key = f"sweep.{k}"
        if k not in mparams:
            hint = _suggest(str(k), mparams)
            problems.append(f"{key}: {k!r} is not a parameter of model {model!r}{hint}; "
                            f"allowed: {', '.join(mparams)}")
            continue
        if not isinstance(spec, dict):
            problems.append(f"{key}: {_fmt(spec)} must be {{ start = .., stop = .., num = .. }} "
                            "or { values = [...] }")
            continue
        extra = set(spec) - {"start", "stop", "num", "values"}
        for e in sorted(extra):
            problems.append(f"{key}.{e}: unknown key{_suggest(e, ('start', 'stop', 'num', 'values'))}; "
                            "allowed: start, stop, num, values")
        values = None
        if "values" in spec:
            if {"start", "stop", "num"} & set(spec):
                problems.append(f"{key}: give either values or start/stop/num, not both")
            vals = spec["values"]
            if not isinstance(vals, list) or not vals:
                problems.append(f"{key}.values: {_fmt(vals)} must be a non-empty list of numbers")
            else:
                good = all(_check_param(k, v, f"{key}.values", problems, model) for v in vals)
                if good:
                    values = tuple(float(v) for v in vals)
        else:
            ok = True
            for part in ("start", "stop", "num"):
                if part not in spec:
                    problems.append(f"{key}.{part}: missing; an axis needs start, stop and num")
                    ok = False
            if ok:
                num = spec["num"]
                if not _is_int(num):
                    problems.append(f"{key}.num: {_fmt(num)} must be an integer >= 1")
                    ok = False
                elif num < 1:
                    problems.append(f"{key}.num: {num} must be an integer >= 1")
                    ok = False
                a = _check_param(k, spec["start"], f"{key}.start", problems, model)
                b = _check_param(k, spec["stop"], f"{key}.stop", problems, model)
                if ok and a and b:
                    lo, hi = float(spec["start"]), float(spec["stop"])
                    if hi < lo:
                        problems.append(f"{key}: stop {hi!r} < start {lo!r}; axes run upwards "
                                        "(use sweep.follow = \"down\" to follow downwards)")
                    elif num > 1 and hi == lo:
                        problems.append(f"{key}: start = stop = {lo!r} with num = {num}; use num = 1")
                    else:
                        values = tuple(float(x) for x in np.linspace(lo, hi, num))
        if values is not None:
            if k in ("theta1", "theta2") and obstacle != "triangle":
                problems.append(f"{key}: {k} is a parameter of the triangle obstacle only "
                                f"(system.obstacle is {obstacle!r})")
            axes.append(Axis(k, values))
    if raw.get("sweep") is not None and not axes and "sweep" in raw:
        if not [k for k in sw if k != "follow"]:
            problems.append("sweep: no axis given; add e.g. kappa = { start = -0.02, stop = 0.0, num = 101 }")
    if len(axes) > 2:
        problems.append(f"sweep: {len(axes)} axes ({', '.join(a.name for a in axes)}); at most two")
    if not axes and "sweep" not in raw:
        axes = []
    if section_period is not None and any(a.name == "omega" for a in axes):
        problems.append("system.section_period: cannot be fixed while omega is swept "
                        "(the default T = 2 pi / omega follows omega)")
    if section_period is not None and model == "map2d":
        problems.append(f"system.section_period: not a parameter of model {model!r}")
        section_period = None
    if section_period is not None and system.get("omega"):
        per = (2 if obstacle == "sine" else 1) * math.pi / system["omega"]
        m = section_period / per
        if abs(m - round(m)) > 1e-9 * max(1.0, m) or round(m) < 1:
            problems.append(f"system.section_period: {section_period!r} is not a whole number of "
                            f"obstacle periods (P = {per!r})")

    # [initial]
    ini = table("initial")
    unknown("initial", TABLES["initial"])
    n_ic = ini.get("count", INITIAL_DEFAULTS["count"])
    if not _is_int(n_ic) or n_ic < 1:
        problems.append(f"initial.count: {_fmt(n_ic)} must be an integer >= 1")
        n_ic = 1
    seed = ini.get("seed", INITIAL_DEFAULTS["seed"])
    if not _is_int(seed) or seed < 0:
        problems.append(f"initial.seed: {_fmt(seed)} must be an integer >= 0")
        seed = 0
    ranges = {}
    coords = tuple(MODEL_INITIAL.get(model, INITIAL_DEFAULTS).keys() & {"z", "y", "u", "v"})
    coords = tuple(c for c in ("z", "y", "u", "v") if c in coords)
    for c in ("z", "y"):
        if c in ini and c not in coords:
            problems.append(f"initial.{c}: not an initial coordinate of model {model!r}; "
                            f"allowed: {', '.join(coords)}")
    for c in coords:
        rng = ini.get(c, MODEL_INITIAL.get(model, INITIAL_DEFAULTS)[c])
        if _is_number(rng):
            rng = [rng, rng]
        if (not isinstance(rng, list) or len(rng) != 2 or not all(_is_number(x) for x in rng)
                or not all(math.isfinite(x) for x in rng)):
            problems.append(f"initial.{c}: {_fmt(rng)} must be a range [low, high] of finite numbers")
            rng = INITIAL_DEFAULTS[c]
        elif rng[1] < rng[0]:
            problems.append(f"initial.{c}: {_fmt(rng)} has high < low")
        ranges[c] = (float(rng[0]), float(rng[1]))

    # [run]
    rn = table("run")
    unknown("run", TABLES["run"])
    preset = rn.get("preset", DEFAULT_PRESET)
    if not isinstance(preset, str) or preset not in PRESETS:
        problems.append(f"run.preset: {_fmt(preset)} is not a preset"
                        f"{_suggest(str(preset), PRESETS)}; allowed: {', '.join(PRESETS)}")
        preset = DEFAULT_PRESET
    run = {}
    for k, default in RUN_DEFAULTS.items():
        default = PRESETS[preset].get(k, default)
        v = rn.get(k, default)
        if k == "stop":
            if v is not None and v not in STOPS:
                problems.append(f"run.stop: {_fmt(v)} is not allowed; allowed: {', '.join(STOPS)}")
                v = None
            elif v == "period" and model != "flow":
                problems.append(f"run.stop: 'period' is implemented for model 'flow' only, "
                                f"not {model!r}; allowed here: none")
                v = None
            run[k] = v
            continue
        if k in ("transient", "record", "max_events", "max_periods"):
            if v is None and k in ("max_events", "max_periods"):
                run[k] = None         # automatic budget (below)
                continue
            lo = 0 if k == "transient" else 1
            if not _is_int(v) or v < lo:
                problems.append(f"run.{k}: {_fmt(v)} must be an integer >= {lo}")
                v = default if default is not None else 1
        else:
            if not _is_number(v) or not math.isfinite(v) or v <= 0:
                problems.append(f"run.{k}: {_fmt(v)} must be a positive finite number")
                v = default
            elif k == "tol" and v > 1e-3:
                problems.append(f"run.tol: {v!r} is too coarse; the event-time tolerance must be <= 1e-3")
            v = float(v)
        run[k] = v
    need = run["transient"] + run["record"]
    per_event = 40 if model == "two_particle" else 10
    max_events = run["max_events"] if run["max_events"] is not None else per_event * need + 1000
    max_periods = run["max_periods"] if run["max_periods"] is not None else 50 * need + 1000

    # [output]
    outp = table("output")
    unknown("output", TABLES["output"])
    keep = outp.get("keep", list(KEEP))
    if not isinstance(keep, list) or not all(isinstance(x, str) for x in keep):
        problems.append(f"output.keep: {_fmt(keep)} must be a list drawn from {list(KEEP)}")
        keep = list(KEEP)
    for x in keep:
        if x not in KEEP:
            problems.append(f"output.keep: {x!r} is not an observable{_suggest(x, KEEP)}; "
                            f"allowed: {', '.join(KEEP)}")
    keep = tuple(x for x in KEEP if x in keep)
    allowed_keep = MODEL_KEEP.get(model, KEEP)
    for x in keep:
        if x not in allowed_keep and "keep" in outp:
            extra = (" (the map's iterates are stored as section/u = a_n, section/v = b_n)"
                     if model == "map2d" else "")
            problems.append(f"output.keep: {x!r} is not an observable of model {model!r}{extra}; "
                            f"allowed: {', '.join(allowed_keep)}")
    keep = tuple(x for x in keep if x in allowed_keep)
    if run["stop"] is None:
        run["stop"] = "period" if (model == "flow" and not keep) else "none"

    # [plot]
    pl = table("plot")
    unknown("plot", TABLES["plot"])
    plot = dict(pl)
    if "y" in plot and plot["y"] not in PLOT_Y:
        problems.append(f"plot.y: {_fmt(plot['y'])} is not allowed; allowed: {', '.join(PLOT_Y)}")
    for lim in ("xlim", "ylim"):
        if lim in plot:
            v = plot[lim]
            if not (isinstance(v, list) and len(v) == 2 and all(_is_number(x) for x in v) and v[0] < v[1]):
                problems.append(f"plot.{lim}: {_fmt(v)} must be [low, high] with low < high")

    kind = plot.get("kind", "diagram")
    if kind in ("regions", "return_map", "orbit"):
        # the (a0, b1)-plane figures of the rectified-sine normal form (sections 4-5)
        if model not in ("map2d", "flow") or (model == "flow" and obstacle != "rectified_sine"):
            problems.append(f"plot.kind: {kind!r} draws the corner normal form of z = kappa + "
                            f"beta |sin omega t| (sections 4-5): it needs model 'map2d' or 'flow' "
                            f"with obstacle 'rectified_sine' (this scene: model {model!r}"
                            + (f", obstacle {obstacle!r}" if model == "flow" else "") + ")")
        if axes:
            problems.append(f"plot.kind: {kind!r} draws a scene without sweep axes; this one "
                            f"sweeps {', '.join(a.name for a in axes)}")
        if kind == "return_map" and rn.get("transient", PRESETS[preset]["transient"]) != 0:
            problems.append("plot.kind: 'return_map' needs run.transient = 0 (A0 is the first "
                            "section value after the start)")
    if kind not in PLOT_KINDS:
        problems.append(f"plot.kind: {_fmt(kind)} is not a plot kind{_suggest(str(kind), PLOT_KINDS)}; "
                        f"allowed: {', '.join(PLOT_KINDS)}")
    if kind == "timeseries":
        if model != "flow":
            problems.append(f"plot.kind: 'timeseries' needs model 'flow' (the scene's model is {model!r})")
        if "impacts" not in keep:
            problems.append("plot.kind: 'timeseries' is rebuilt from the impacts; "
                            "output.keep must contain \"impacts\"")
    if "ic" in plot:
        v = plot["ic"]
        if not (v == "distinct" or (isinstance(v, list) and v and all(_is_int(i) and 0 <= i < n_ic
                                                                       for i in v))):
            problems.append(f"plot.ic: {_fmt(v)} must be \"distinct\" or a list of start indices "
                            f"in 0..{n_ic - 1}")
    if "point" in plot:
        v = plot["point"]
        shape = [len(a.values) for a in axes]
        if not (isinstance(v, list) and len(v) == len(shape)
                and all(_is_int(i) and 0 <= i < n for i, n in zip(v, shape))):
            problems.append(f"plot.point: {_fmt(v)} must be a grid index with one entry per swept "
                            f"axis ({len(shape)}), each in 0..len-1 (grid {tuple(shape)})")
    for k, lo in (("cycles", 0), ("max_panels", 1)):
        if k in plot and not (_is_number(plot[k]) and plot[k] > lo and math.isfinite(plot[k])):
            problems.append(f"plot.{k}: {_fmt(plot[k])} must be a number > {lo}")

    # cross checks
    names = [a.name for a in axes]
    if len(set(names)) != len(names):
        problems.append(f"sweep: two axes name one parameter ({', '.join(names)})")
    if follow != "none" and not axes:
        problems.append(f"sweep.follow: {follow!r} needs a swept parameter")
    if not any(a.name == "kappa" for a in axes) and not problems:
        kap = [system["kappa"]]
    else:
        kap = list(next((a.values for a in axes if a.name == "kappa"), [system["kappa"]]))
    if model == "two_particle" and "z" in ranges and "u" in ranges:
        if ranges["z"][1] <= max(kap):
            problems.append(f"initial.z: {list(ranges['z'])} lies on or below the wall at t = 0 "
                            f"(w(0) = kappa up to {max(kap)!r}); the upper end must exceed it")
        if ranges["u"][1] <= ranges["z"][1]:
            problems.append(f"initial.u: {list(ranges['u'])} must reach above initial.z "
                            f"{list(ranges['z'])} (u >= z)")
    if model == "two_particle" and not problems:
        # undamped exact resonance of a particle or of the stuck pair (models.two_particle.pack
        # refuses it per point): checked here over every combination of the values of the
        # parameters it involves, so that a sweep is refused before any kernel runs
        from .models import two_particle as TP
        involved = ("F1", "F2", "sigma1", "sigma2", "Omega1", "Omega2", "omega1", "omega2", "mu")
        swept = [a for a in axes if a.name in involved]
        n_comb = math.prod(len(set(a.values)) for a in swept) if swept else 1
        if n_comb <= 200_000:
            import itertools
            for combo in itertools.product(*[sorted(set(a.values)) for a in swept]):
                vals = dict(system) | {a.name: v for a, v in zip(swept, combo)}
                try:
                    TP.pack({k: v for k, v in vals.items() if v is not None})
                except ValueError as e:
                    if "resonance" in str(e):
                        where = ", ".join(f"sweep.{a.name} = {v!r}" for a, v in zip(swept, combo))
                        problems.append(f"system/sweep: {e}" + (f" (at {where})" if where else ""))
                        break
    if model == "flow" and not problems:
        # models.oscillator's particular solution divides by k^2 - Omega^2 when undamped
        def vals(n):
            return set(next((a.values for a in axes if a.name == n), [system.get(n)]))
        res = vals("Omega") & vals("k")
        if any(x not in (0, 0.0, None) for x in vals("F")) and 0.0 in vals("sigma") and res:
            def key(n):
                return f"sweep.{n}" if any(a.name == n for a in axes) else f"system.{n}"
            problems.append(f"{key('Omega')}: {_fmt(sorted(res)[0])} equals {key('k')} with "
                            f"sigma = 0 and F != 0 (undamped exact resonance: no bounded "
                            "closed-form flight); change Omega or k, or add damping sigma > 0")
    if model == "flow" and ranges.get("u") and kap and all(_is_number(x) for x in kap):
        if ranges["u"][1] <= max(kap):
            problems.append(f"initial.u: {list(ranges['u'])} lies on or below the obstacle at t = 0 "
                            f"(z(0) = kappa up to {max(kap)!r}); the upper end must exceed it")
    if problems:
        raise SceneError(problems)

    # the scene as run: defaults made explicit, so the file says everything
    as_run = {
        "scene": {"name": name, "title": title, "model": model},
        "system": ({"obstacle": obstacle} if model == "flow" else {})
        | {k: v for k, v in system.items() if v is not None},
        "sweep": {**{a.name: {"values": list(a.values)} for a in axes}, "follow": follow},
        "initial": {"count": n_ic, "seed": seed, **{c: list(ranges[c]) for c in coords}},
        "run": {**({"preset": preset} if "preset" in rn else {}),
                **{k: v for k, v in run.items() if v is not None and k != "stop"},
                "max_events": max_events, "max_periods": max_periods, "stop": run["stop"]},
        "output": {"keep": list(keep)},
    }
    if not axes:
        del as_run["sweep"]
    if section_period is not None:
        as_run["system"]["section_period"] = section_period
    if plot:
        as_run["plot"] = plot
    return Scene(name=name, title=title, model=model, obstacle=obstacle, system=system,
                 section_period=section_period, axes=tuple(axes), follow=follow, n_ic=n_ic,
                 seed=seed, u_range=ranges["u"], v_range=ranges["v"],
                 z_range=ranges.get("z"), y_range=ranges.get("y"), transient=run["transient"],
                 record=run["record"], tol=run["tol"], chatter=run["chatter"], escape=run["escape"],
                 period_tol=run["period_tol"], max_events=max_events, max_periods=max_periods,
                 keep=keep, plot=plot, text=dumps(as_run), preset=preset,
                 stop=run["stop"])
