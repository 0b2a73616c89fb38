"""``cornerbif continue``: a scene's continuation to a file (docs/continuation.md).

The output locked and its fate decided before any work (``plan_output``, as ``cornerbif
sweep`` decides), the seeds found with the kernel under a stop flag (an interrupt ends it
within about a second), each branch and curve written to the partial file as soon as it is
finished (with the state to go on from), and ``resume`` completing it bitwise as an
uninterrupted run.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import stat
import time
import tomllib
from dataclasses import dataclass, field

import numpy as np

from . import engine, outputs, registry
from ._version import __version__
from .api import simulate
from .config import recorded_obstacle, same_run, scene_difference, sweep_items
from .continuation import (
    ENDING_WORDS,
    MAX_BRANCHES,
    Branch,
    Event,
    OrbitError,
    corner_curve,
    failure_words,
    fold_curve,
    follow_step,
)
from .errors import Fault, SweepError, SweepInterrupted, WriteFailed
from .model import cut
from .outputs import CONTINUATION_FORMAT, is_kind, reason

FORMAT = CONTINUATION_FORMAT         # the root attribute ``format`` (``outputs``)
FORMAT_VERSION = 1
# the version of the resume state a partial file keeps (``resume/state``, JSON)
STATE_VERSION = 1


@dataclass
class Result:
    """What ``cornerbif continue`` found: the branches, their events, the corner curves."""

    scene: object
    branches: list
    curves: list = field(default_factory=list)     # (event index, param, param2 arrays)
    seeds: list = field(default_factory=list)      # the words found at the start


def _matches(word: str, seed: str, alphabet: str | None = None) -> bool:
    """Whether a cycle word is the seed word up to rotation; ``alphabet``: the model's own
    letters (``Model.seed_letters``: a linear system's contacts' names, case kept), else the
    clusters' a, b, g, x."""
    from .analysis import parse_word  # start-up: loads numba
    s = (parse_word(seed, allow_x=True) if alphabet is None
         else parse_word(seed, alphabet=alphabet))
    return len(s) == len(word) and s in word + word


def _seed_file_error(scene, what):
    """The refusal of ``[continue] seed_file`` (bad input: exit 2, before any work)."""
    c = scene.cont
    return SweepError(f"continue.seed_file: {c['seed_file']}: {what}; a seed file is a finished "
                      f"sweep (cornerbif sweep) of model {scene.model!r} over "
                      f"{c['parameter']!r} alone, with this scene's [system]")


def seeds_from_file(scene):
    """The runs of a sweep file (``[continue] seed_file``) at its grid value nearest the
    continuation's start: (word, run dict keyed as the model's run_items outputs) per
    distinct attractor.  The file must be a regular file, a sweep (not a continuation),
    of this model, sweeping the continued parameter alone, with this [system], done at
    that grid point, and keep what the model's seed reads (the impacts for flow, the
    section for two_particle); every other file is refused before any work (SweepError,
    exit 2), naming the key, the path and what is wrong."""

    from .analysis import distinct_attractors  # start-up: loads numba
    from .io import FileFormatError, check_readable  # start-up: loads h5py
    path = scene.cont["seed_file"]
    try:
        st = os.stat(path)
    except (OSError, ValueError) as e:
        raise _seed_file_error(scene, f"cannot be read ({reason(e) if isinstance(e, OSError) else e})"
                               ) from None
    if stat.S_ISDIR(st.st_mode):
        raise _seed_file_error(scene, "is a directory")
    if not stat.S_ISREG(st.st_mode):
        raise _seed_file_error(scene, "is not a regular file (a device, a pipe or a socket)")
    if is_kind(path, "continuation"):
        raise _seed_file_error(scene, "is a continuation file (cornerbif continue), not a sweep")
    try:
        f = check_readable(path)
    except FileFormatError as e:
        raise _seed_file_error(scene, str(e).removeprefix(f"{path}: ")) from None
    except OSError as e:
        raise _seed_file_error(scene, f"cannot be read ({reason(e)})") from None
    try:
        with f:
            run_all, period, words, at = _seed_runs(scene, f)
    except SweepError:
        raise
    except Exception as e:  # noqa: BLE001 - a file crafted past check_readable: say so
        raise _seed_file_error(scene, f"cannot be read as a sweep ({type(e).__name__}: "
                                      f"{cut(e)}): damaged, or not written by cornerbif"
                               ) from None
    series = ([(run_all["u"][None], "impacts"), (run_all["v_in"][None], "impacts")]
              if "u" in run_all else
              [(run_all["su"][None], "section"), (run_all["sv"][None], "section")]
              if "su" in run_all else [])
    labels, count = distinct_attractors(period[None], run_all["ipc"][None], words[None],
                                        series, 100.0 * scene.period_tol)
    found = []
    for k in range(int(count[0])):
        i = int(np.nonzero(labels[0] == k)[0][0])
        found.append((str(words[i]), {key: a[i] for key, a in run_all.items()}))
    return found, at


def _seed_runs(scene, f):
    """The runs of an open sweep file at its grid value nearest continue.start: (runs by
    the model's output names, periods, words, that grid value); SweepError where the file
    cannot seed this scene."""

    c = scene.cont
    name = c["parameter"]
    model = f.attrs.get("model", "")
    if model != scene.model:
        raise _seed_file_error(scene, f"is a sweep of model {model!r}, the scene's is "
                                      f"{scene.model!r}")
    theirs_doc = tomllib.loads(str(f.attrs["scene"]))
    axes = [k for k, _ in sweep_items(theirs_doc.get("sweep", {}))]
    if axes != [name] or name not in f or f[name].ndim != 1 or f["period"].ndim != 2:
        raise _seed_file_error(scene, f"sweeps {', '.join(map(repr, axes)) or 'nothing'}, "
                                      f"not {name!r} alone")
    theirs = theirs_doc.get("system", {})
    if scene.spec.system_table is not None:
        # a model its scene declares (linear): the two [system] tables, the parameter aside
        mine, _ = scene.spec.for_system(theirs)
        if mine is None or name not in mine.params or (
                mine.system_table_with({name: 0.0})
                != scene.spec.system_table_with({name: 0.0})):
            raise _seed_file_error(scene, "was swept with another [system] table than the "
                                          f"scene's (beside {name!r})")
    else:
        ours = {k: v for k, v in scene.system.items() if v is not None}
        if "obstacle" in scene.spec.system_extra:
            ours["obstacle"] = recorded_obstacle(scene)
        for k in sorted(set(ours) | set(theirs)):
            if k != name and k != "section_period" and theirs.get(k) != ours.get(k):
                raise _seed_file_error(scene, f"was swept with system.{k} = "
                                              f"{theirs.get(k)!r}, the scene has "
                                              f"{ours.get(k)!r}")
    x = f[name][...]
    if not np.all(np.isfinite(x)):
        raise _seed_file_error(scene, f"its {name!r} values are not all finite")
    g = int(np.argmin(np.abs(x - c["start"])))
    lo, hi = c["range"]
    if not lo <= float(x[g]) <= hi:
        raise _seed_file_error(scene, f"its grid value nearest continue.start, {name} = "
                                      f"{float(x[g])!r}, is outside continue.range {[lo, hi]}")
    if not f["done"][g]:
        raise _seed_file_error(scene, f"its grid point {name} = {float(x[g])!r} (the nearest "
                                      "continue.start) is not done: complete the sweep first "
                                      "(cornerbif sweep --resume)")
    run_all = {"ipc": f["impacts_per_cycle"][g].astype(np.int64)}
    for fld in scene.spec.fields(tuple(scene.spec.observables)):
        if fld.name in f and fld.axis is None:
            run_all[fld.source] = f[fld.name][g]
    need = scene.spec.seed_observable
    if need and not all(fld.source in run_all for fld in scene.spec.observables[need]):
        raise _seed_file_error(scene, f"does not keep {need!r}, which a {scene.model} seed "
                                      f"reads (sweep it with output.keep containing {need!r})")
    return run_all, f["period"][g], f["symbols"][g].astype(str), float(x[g])


def find_seeds(scene, control=None):
    """The distinct attractors reached from the scene's starts at the continuation's start
    (the kernel and ``analysis.distinct_attractors``): a list of (word, one run's record:
    the model's outputs of that run and "ipc", its impacts per cycle).  ``control``
    (``_jit.Control``): the kernel polls its stop flag (``engine.with_control``) and, told
    to stop, returns within milliseconds, raising ``KernelStopped``."""
    from .analysis import distinct_attractors, words  # start-up: loads numba
    c = scene.cont
    run_scene = dataclasses.replace(scene, keep=("impacts",), stop="none",
                                    system=dict(scene.system) | {c["parameter"]: c["start"]})
    spec = scene.spec
    row = spec.pack_values(run_scene.system, run_scene)
    params = np.repeat(row[None], scene.n_ic, axis=0)
    ics = engine.draw_initial(run_scene, np.zeros(1, np.int64),
                              spec.wall_at_start(params[:1]), params[:1]).reshape(scene.n_ic, -1)
    ints = engine.with_control(run_scene, spec.int_settings(run_scene), control)
    run = spec.run_items(params, np.ascontiguousarray(ics), ints, run_scene)
    out, period, ipc = run.fields, run.period, run.ipc
    w = words(run.symbols)
    # the series that tell one attractor from another with the same word: the model's own
    cy = spec.cycle
    per = "impacts" if cy.per == "impacts" else "section"
    series = [(out[cy.a][None], per), (out[cy.b][None], per)]
    labels, count = distinct_attractors(period[None], ipc[None], w[None], series,
                                        100.0 * scene.period_tol)
    found = []
    for k in range(int(count[0])):
        i = int(np.nonzero(labels[0] == k)[0][0])
        found.append((str(w[i]), {key: a[i] for key, a in out.items()} | {"ipc": int(ipc[i])}))
    seeds = c["seed"] if isinstance(c["seed"], list) else [c["seed"]]
    if "all" not in seeds:
        letters = spec.seed_letters()
        found = [f for f in found if any(_matches(f[0], s, letters) for s in seeds)]
    return found


# ------------------------------------------------------------------ the run, unit by unit
# A scene's continuation is a sequence of units, each written to the partial file as soon
# as it is finished: the main branch of each seed (both ways from the start), the branches
# switched to at its corner collisions (breadth first, the down way then the up way, as
# ``follow``), then each two-parameter curve.  Beside the finished units the partial file
# keeps the state to go on from (``resume/state``: the seeds, the branches still to
# continue and the events whose curves are still to continue, every number as written
# by Python, which reads back to the same bits), so --resume continues exactly what an
# uninterrupted run would have.

def _problem_from(doc):
    """The orbit problem its ``to_doc`` wrote (the resume state), rebuilt by its model."""
    name = str(doc["type"])
    if name not in registry.models():
        raise ValueError(f"unknown orbit problem {name!r}")
    return registry.get(name).orbit_from_doc(doc)


def _array(x):
    return np.asarray(x, float).tolist()


def _item_doc(item) -> dict:
    """A branch still to continue (``follow_step``'s (problem, X, param, tangent, origin))."""
    prob, X, lam, T0, origin = item
    return {"problem": prob.to_doc(), "X": _array(X), "lam": float(lam),
            "T0": None if T0 is None else _array(T0), "origin": str(origin)}


def _item_from(doc):
    return (_problem_from(doc["problem"]), np.array(doc["X"], float), float(doc["lam"]),
            None if doc["T0"] is None else np.array(doc["T0"], float), str(doc["origin"]))


def _event_doc(b, e) -> dict:
    """A located corner collision or fold of branch b whose curve is still to continue."""
    return {"branch": int(b), "kind": e.kind, "lam": float(e.lam), "X": _array(e.X),
            "detail": e.detail, "problem": e.problem.to_doc()}


def _seed_stage(scene, log):
    """The work before the first branch: the attractors at the start (the scene's starts
    run by the kernel, or ``seed_file``'s runs), the seed words no start reached solved
    directly, each seed's orbit solved and checked admissible (a seed that cannot be is
    said and skipped).  Returns the run's state (``_units``) holding the seeds.

    It runs in a thread of its own (``local.run_interruptibly``) with the kernel under a
    stop flag (``find_seeds``), so that SIGINT and SIGTERM end it within about a second
    whatever the scene (at omega = 1e9 the starts' runs take minutes): the interrupt is
    raised here, as ``KeyboardInterrupt``, with nothing written."""
    from ._jit import Control  # start-up: loads numba
    from .local import run_interruptibly  # start-up: loads numba
    control = Control()
    state = run_interruptibly(lambda: _seeds(scene, log, control), control)
    if state is None:                   # the kernel was told to stop (``KernelStopped``)
        raise KeyboardInterrupt
    return state


def _seeds(scene, log, control):
    """``_seed_stage``'s work, the kernel under ``control``."""
    c = scene.cont
    values = {k: v for k, v in scene.system.items() if v is not None}
    start = c["start"]
    wanted = c["seed"] if isinstance(c["seed"], list) else [c["seed"]]
    letters = scene.spec.seed_letters()
    if "seed_file" in c:
        found, at = seeds_from_file(scene)
        if at != start:
            log(f"seeds from {c['seed_file']} at {c['parameter']} = {at!r} (the grid value "
                f"nearest continue.start)")
            start = at
        if "all" not in wanted:
            found = [f for f in found if any(_matches(f[0], s, letters) for s in wanted)]
    else:
        found = find_seeds(scene, control)
    values[c["parameter"]] = start
    for s in wanted:
        if s != "all" and not any(_matches(f[0], s, letters) for f in found):
            # not an attractor from these starts: the orbit of the word itself, stable or not
            found.append((s, {"word_seed": True}))
    if not found:
        log(f"no attractor {'with word ' + repr(c['seed']) + ' ' if c['seed'] != 'all' else ''}"
            f"was found from the {scene.n_ic} starts at {c['parameter']} = {start!r}")
    seeds = []
    for word, run in found:
        try:
            if run.get("word_seed"):
                prob, X = scene.spec.word_seed(values, scene, c["parameter"], word, simulate)
            else:
                prob, X = scene.spec.orbit_seed(values, scene, c["parameter"], word, run)
            ok, why = prob.admissible(X, start)
            if not ok:
                raise OrbitError(f"its orbit is not admissible at the start ({why})")
        except (OrbitError, NotImplementedError, np.linalg.LinAlgError, ArithmeticError,
                ValueError) as e:
            log(f"seed {word!r}: {failure_words(e)}")
            continue
        seeds.append({"word": word, "problem": prob.to_doc(), "X": _array(X)})
    return {"version": STATE_VERSION, "start": float(start),
            "seeds_found": [f[0] for f in found], "seeds": seeds, "seed": 0,
            "phase": "main", "queues": {"down": [], "up": []}, "counts": {"down": 0, "up": 0},
            "branches": 0, "curve_jobs": [], "curve_next": 0}


def _units(scene, state, log):
    """The continuation from ``state`` on, one finished unit at a time: yields
    ("branch", (index, Branch)) and ("curve", the curve or None where it failed both
    ways), each once ``state`` says it is done, so that the state saved with a unit goes
    on right after it.  Every problem, unknown and tangent is taken from the state's
    plain data, in a run never interrupted as in a resumed one: both compute the same
    numbers, bit for bit."""
    c = scene.cont
    rng = tuple(c["range"])
    kw = dict(ds=c["ds"], ds_min=c["ds_min"], ds_max=c["ds_max"], events=tuple(c["events"]))
    switch = c["switch"]
    start = state["start"]
    seeds = state["seeds"]
    while state["seed"] < len(seeds):
        sd = seeds[state["seed"]]
        phase = state["phase"]
        if phase == "main":
            prob, X = _problem_from(sd["problem"]), np.array(sd["X"], float)
            up, up_more = follow_step(prob, X, start, None, "start", rng, 1.0, switch,
                                      room=MAX_BRANCHES - 1, **kw)
            down, down_more = follow_step(prob, X, start, None, "start", rng, -1.0, switch,
                                          room=MAX_BRANCHES - 1, **kw)
            word = sd["word"]
            main = Branch(prob, down.points[::-1] + up.points[1:],
                          down.events[::-1] + up.events, word,
                          f"the attractor {word!r} at {c['parameter']} = {start!r}",
                          stops=[down.events[-1], up.events[-1]])
            state["queues"] = {"down": [_item_doc(m) for m in down_more],
                               "up": [_item_doc(m) for m in up_more]}
            state["counts"] = {"down": 1, "up": 1}
            state["phase"] = "down"
            yield "branch", _branch_done(scene, state, main)
            continue
        queue = state["queues"][phase]
        if queue and state["counts"][phase] < MAX_BRANCHES:
            item = _item_from(queue.pop(0))
            state["counts"][phase] += 1
            br, more = follow_step(*item, rng, -1.0 if phase == "down" else 1.0, switch,
                                   room=MAX_BRANCHES - state["counts"][phase] - len(queue),
                                   **kw)
            queue += [_item_doc(m) for m in more]
            yield "branch", _branch_done(scene, state, br)
            continue
        if phase == "down":
            state["phase"] = "up"
        else:
            state.update(seed=state["seed"] + 1, phase="main",
                         queues={"down": [], "up": []}, counts={"down": 0, "up": 0})
    state["phase"] = "curves"
    while state["curve_next"] < len(state["curve_jobs"]):
        curve = _curve(scene, state["curve_jobs"][state["curve_next"]], log)
        state["curve_next"] += 1
        yield "curve", curve
    state["phase"] = "done"


def _branch_done(scene, state, br):
    """Number a finished branch and queue the curves of its corner collisions and folds
    (``[continue] curve``): (index, branch)."""
    b = state["branches"]
    state["branches"] += 1
    if "curve" in scene.cont:
        state["curve_jobs"] += [_event_doc(b, e) for e in br.events
                                if e.kind in ("corner", "fold")]
    return b, br


def _curve(scene, job, log):
    """A located corner collision or fold (``_event_doc``) continued both ways in the
    second parameter: (branch, param, what, param2 values, param values, kind, ends), or
    None where it failed both ways (said in the log)."""
    c = scene.cont
    e = Event(job["kind"], float(job["lam"]), np.array(job["X"], float), job["detail"],
              _problem_from(job["problem"]))
    b = job["branch"]
    follow_curve = corner_curve if e.kind == "corner" else fold_curve
    what = e.detail.split(";")[0] if e.kind == "corner" else "fold"
    parts, ends = [], []
    for direction in (1.0, -1.0):
        try:
            x2, x1, _, _, evs = follow_curve(
                e, c["curve"], tuple(c["curve_range"]), direction,
                ds=abs(c["curve_range"][1] - c["curve_range"][0]) / 100.0)
            parts.append((x2, x1))
            ends += [f"{v.kind} at {c['curve']} = {v.lam:.10g}"
                     + (f" ({v.detail})" if v.detail else "") for v in evs]
        except (OrbitError, np.linalg.LinAlgError, ArithmeticError, ValueError) as err:
            ends.append(f"failed: {err}")
            log(f"{e.kind} curve of branch {b} at {e.lam!r}: {err}")
    if not parts:
        return None
    x2 = np.concatenate([p[0][::-1] for p in parts[1:]] + [parts[0][0]])
    x1 = np.concatenate([p[1][::-1] for p in parts[1:]] + [parts[0][1]])
    return (b, e.lam, what, x2, x1, e.kind, "; ".join(ends))


def _curve_line(curve, scene) -> str:
    """What the console says of a finished curve."""
    b, _, what, x2, _, kind, ends = curve
    return (f"{kind} curve of branch {b} ({what}): {len(x2)} points over "
            f"{scene.cont['curve']} in [{x2.min():.6g}, {x2.max():.6g}]; ends: {ends}")


def stop_reason(e, param, switch=True) -> str:
    """Why a branch stopped at ``e``, its last event one way, in words: the range's end,
    the step budget, the step below ds_min, a failed step, a corner collision or a grazing
    (continued across it, or why not), a zero-velocity impact, or where its orbit stops
    being admissible."""
    if e.kind == "end":
        why = e.detail
    elif e.kind == "corner":
        why = f"a corner collision of {e.detail}"
        if not switch:
            why += "; not continued across it (continue.switch = false)"
    elif e.kind in ENDING_WORDS:
        why = ENDING_WORDS[e.kind] + ": the orbit of this itinerary ends there" + e.detail
        if e.kind == "grazing" and not switch:
            why += "; not continued across it (continue.switch = false)"
    else:
        why = e.kind
    return f"{param} = {e.lam:.12g}: {why}"


def _branch_lines(b, br, scene) -> str:
    """What the console says of a finished branch: its word, range, points, events, and
    why each of its ends stopped."""
    c = scene.cont
    p = c["parameter"]
    lams = [pt.lam for pt in br.points]
    stable = sum(bool(np.all(np.abs(pt.mu) < 1.0)) for pt in br.points)
    ends = br.ends()
    inner = [e for e in br.events if not any(e is s for s in ends)]
    lines = [f"branch {b}: {br.word or '?'} over {p} in [{min(lams):.10g}, {max(lams):.10g}], "
             f"{len(br.points)} points ({stable} stable); events: "
             + (", ".join(f"{e.kind} at {e.lam:.12g}" for e in inner) or "none")]
    lines += [f"  stopped at {stop_reason(e, p, c['switch'])}" for e in ends]
    return "\n".join(lines)


# ------------------------------------------------------------------ the file
def _branch_record(br, scene) -> dict:
    """What the file keeps of a branch (docs/continuation.md, "The file"): its datasets,
    its attributes and its events' rows."""
    c = scene.cont
    section = scene.extra.get("section_period")
    pts = br.points
    mu = np.array([pt.mu for pt in pts])
    rows = [pt.problem.store(pt.X, pt.lam, section) for pt in pts]
    data = {"param": np.array([pt.lam for pt in pts])}
    for key in rows[0]:
        data[key] = np.array([r_[key] for r_ in rows])
    data["multiplier_re"] = mu.real
    data["multiplier_im"] = mu.imag
    with np.errstate(invalid="ignore"):
        data["stable"] = (np.abs(mu).max(axis=1) < 1.0).astype(np.uint8)
    data["admissible"] = np.array([pt.admissible for pt in pts], np.uint8)
    data["admissibility_margin"] = np.array([pt.margin for pt in pts], float)
    with np.errstate(all="ignore"):
        data["condition_number"] = np.array([pt.condition for pt in pts], float)
    attrs = dict(word=br.word, origin=br.origin, points_per_cycle=pts[0].problem.n,
                 itinerary=pts[0].problem.itinerary(),
                 stops=[stop_reason(e, c["parameter"], c["switch"]) for e in br.ends()])
    events = []
    for e in br.events:
        got = e.problem.store(e.X, e.lam, section)
        # each event's state, as the branch stores it (the smallest over the cycle's
        # impacts where there are several), and the orbit located there, whole
        events.append((e.kind, float(e.lam), e.detail,
                       {k: float(np.min(v)) for k, v in got.items()}, event_orbit(e, got)))
    return {"data": data, "attrs": attrs, "events": events}


def event_orbit(e, got) -> dict:
    """The orbit located at an event, as the file keeps it (``events/orbits/NNNN``): its
    unknowns X, its word, its Floquet multipliers and ``store``'s arrays (every impact, the
    section state, the cycle's duration)."""
    with np.errstate(all="ignore"):     # a degenerate end (a zero-velocity impact): inf, NaN
        try:
            mu = np.asarray(e.problem.floquet(e.X, e.lam)[0], complex)
        except (ArithmeticError, ValueError, np.linalg.LinAlgError):
            mu = np.full(2, complex(math.nan, math.nan))
    out = {k: np.atleast_1d(np.asarray(v, float)) for k, v in got.items()}
    out.update(X=np.asarray(e.X, float).copy(), multiplier_re=mu.real.copy(),
               multiplier_im=mu.imag.copy(), word=e.problem.word(e.X, e.lam))
    return out


def _curve_record(curve, scene) -> dict:
    c = scene.cont
    b, lam, what, x2, x1, kind, ends = curve
    return {"param": x2, "event_param": x1,
            "attrs": dict(kind=kind, branch=b, at=lam, what=what, param_name=c["curve"],
                          event_param_name=c["parameter"], ends=ends)}


def _image(scene, head, branches, curves, state=None) -> bytes:
    """The continuation file, whole, as bytes (HDF5 in memory: a failed write of them to
    disk is an OSError of Python's, never a broken HDF5 state): the finished file, or with
    ``state`` a partial one that --resume goes on from.  ``head``: the root attributes
    ``created``, ``seeds``, ``command`` (the command line that made it; optional) and, when
    finished, ``completed``."""

    import h5py  # start-up: loads h5py

    c = scene.cont
    with h5py.File("continuation.h5", "w", driver="core", backing_store=False) as f:
        f.attrs.update(format=FORMAT, format_version=FORMAT_VERSION, scene=scene.text,
                       model=scene.model, obstacle=recorded_obstacle(scene), parameter=c["parameter"],
                       cornerbif_version=__version__, created=head["created"],
                       seeds=head["seeds"], command=head.get("command", ""))
        for b, rec in enumerate(branches):
            g = f.create_group(f"branches/{b:03d}")
            for key, v in rec["data"].items():
                g[key] = v
            g["param"].attrs["name"] = c["parameter"]
            g.attrs.update(rec["attrs"])
        rows = [(b, *e) for b, rec in enumerate(branches) for e in rec["events"]]
        ev = f.create_group("events")
        ev["branch"] = np.array([r[0] for r in rows], np.int32)
        ev["kind"] = np.array([r[1] for r in rows], dtype=h5py.string_dtype())
        ev["param"] = np.array([r[2] for r in rows], float)
        ev["detail"] = np.array([r[3] for r in rows], dtype=h5py.string_dtype())
        for key in sorted({k for r in rows for k in r[4]}):
            ev[key] = np.array([r[4].get(key, math.nan) for r in rows], float)
        for i, r in enumerate(rows):
            if not r[5]:                # an event read from a file written before orbits
                continue
            g = ev.create_group(f"orbits/{i:04d}")
            for key, v in r[5].items():
                if key == "word":
                    g.attrs["word"] = v
                else:
                    g[key] = v
        for k, rec in enumerate(curves):
            g = f.create_group(f"curves/{k:03d}")
            g["param"] = rec["param"]
            g["param"].attrs["name"] = c["curve"]
            g["event_param"] = rec["event_param"]
            g["event_param"].attrs["name"] = c["parameter"]
            g.attrs.update(rec["attrs"])
        if state is None:
            f.attrs["completed"] = head["completed"]
        else:
            f["resume/state"] = json.dumps(state)
        f.flush()
        return f.id.get_file_image()


def _load(path):
    """A continuation file (finished or partial) as its records: (root attributes,
    branches, curves, resume state or None), each record as ``_branch_record`` and
    ``_curve_record`` make it (the numbers read back bit for bit)."""

    import h5py  # start-up: loads h5py
    with h5py.File(path, "r", locking=False) as f:
        attrs = {k: _plain(v) for k, v in f.attrs.items()}
        names = sorted(f["branches"]) if "branches" in f else []
        ev = f["events"]
        extra = [k for k in ev if k not in ("branch", "kind", "param", "detail", "orbits")]
        cols = {k: ev[k][...] for k in ev if k != "orbits"}
        events = [[] for _ in names]
        for i in range(cols["param"].shape[0]):
            g = ev.get(f"orbits/{i:04d}")
            orbit = ({k: g[k][...] for k in g} | {"word": _plain(g.attrs.get("word", ""))}
                     if g is not None else {})
            events[int(cols["branch"][i])].append(
                (_plain(cols["kind"][i]), float(cols["param"][i]), _plain(cols["detail"][i]),
                 {k: float(cols[k][i]) for k in extra}, orbit))
        branches = []
        for name, evs in zip(names, events):
            g = f["branches"][name]
            branches.append({"data": {k: g[k][...] for k in g},
                             "attrs": {k: _plain(v) for k, v in g.attrs.items()},
                             "events": evs})
        curves = []
        for name in sorted(f["curves"]) if "curves" in f else []:
            g = f["curves"][name]
            curves.append({"param": g["param"][...], "event_param": g["event_param"][...],
                           "attrs": {k: _plain(v) for k, v in g.attrs.items()}})
        state = json.loads(_plain(f["resume/state"][()])) if "resume/state" in f else None
    return attrs, branches, curves, state


def _plain(v):
    """An HDF5 value as Python: bytes as str, arrays of strings as lists of str."""
    if isinstance(v, bytes):
        return v.decode()
    if isinstance(v, np.ndarray) and v.dtype.kind in "OSU":
        return [_plain(x) for x in v.tolist()]
    return v


def _write_bytes(path, image, kept):
    """Write ``image`` to ``path`` whole or not at all (``outputs.replacing``: a temporary
    name, flushed to disk, renamed), with SIGINT and SIGTERM deferred until it is done; a
    full disk or a file-size limit is ``WriteFailed`` naming the file and what is ``kept``."""
    with outputs.signals_deferred():
        with outputs.replacing(path, kept) as tmp:
            with open(tmp, "wb") as fh:
                fh.write(image)
                fh.flush()
                os.fsync(fh.fileno())


def write(res, path):
    """The continuation file of a ``Result`` (HDF5, docs/continuation.md): one group per
    branch, the events table, the curves; written whole or not at all."""
    now = time.strftime("%Y-%m-%dT%H:%M:%S")
    head = {"created": now, "completed": now, "seeds": ", ".join(res.seeds)}
    _write_bytes(str(path), _image(res.scene, head,
                                   [_branch_record(b, res.scene) for b in res.branches],
                                   [_curve_record(cv, res.scene) for cv in res.curves]),
                 "the previous file, if any, is unchanged")
    return path


def read(path):
    """A continuation file (finished, or the partial file of an interrupted run) as plain
    Python: {"parameter", "scene", "attrs", "branches": [dict], "events": [dict],
    "curves": [dict]}; ValueError for a file that is not one."""
    try:
        attrs, branches, curves, _ = _load(path)
    except (OSError, KeyError, ValueError, IndexError, TypeError) as e:
        raise ValueError(f"{path}: not a readable cornerbif continuation file ({e})") from None
    if attrs.get("format") != FORMAT:
        raise ValueError(f"{path}: not a cornerbif continuation file")
    out = {"parameter": str(attrs["parameter"]), "scene": str(attrs["scene"]),
           "attrs": attrs, "branches": [], "events": [], "curves": []}
    for b, rec in enumerate(branches):
        out["branches"].append(dict(rec["data"]) | rec["attrs"])
        for kind, lam, detail, extra, orbit in rec["events"]:
            out["events"].append({"branch": b, "kind": kind, "param": lam, "detail": detail}
                                 | extra | {"orbit": orbit})
    for rec in curves:
        out["curves"].append({"param": rec["param"], "event_param": rec["event_param"]}
                             | rec["attrs"])
    return out


# ------------------------------------------------------------------ the command
def run_scene(scene, log=print):
    """Seed, continue both ways, switch at corners, continue located corner collisions in
    the second parameter: the ``Result`` of a scene's ``[continue]``, in memory
    (``run_to_file`` writes it as it goes)."""
    state = _seed_stage(scene, log)
    res = Result(scene, [], seeds=list(state["seeds_found"]))
    for kind, unit in _units(scene, state, log):
        if kind == "branch":
            res.branches.append(unit[1])
            log(_branch_lines(*unit, scene))
        elif unit is not None:
            res.curves.append(unit)
            log(_curve_line(unit, scene))
    return res


def run_to_file(scene, out_path, *, resume=False, overwrite=False, log=print, inputs=(),
                command="") -> str | None:
    """Run a scene's ``[continue]`` to ``out_path``, writing each branch and each curve to
    ``out_path.partial`` as soon as it is finished; return ``out_path``, or None when
    ``resume`` finds it already finished from this scene (``[plot]`` aside; ``log`` is
    told so).

    Before any work: no file written beside the output (its partial file, its lock, their
    temporaries) may be one of ``inputs`` or ``continue.seed_file``; the output's lock
    ``out_path.lock`` is taken (``outputs.output_lock``: another command writing it is
    refused); then ``plan_output`` decides, as ``cornerbif sweep`` does, whether there is
    nothing to do, a partial file to resume or a run to start, and refuses what it must.
    Each unit rewrites the partial file whole through ``outputs.replacing`` (a new HDF5
    file under a temporary name, renamed): every state on disk is a complete, readable
    file, even after SIGKILL.  ``resume`` goes on from the partial file of the same scene
    and completes the file bit for bit as an uninterrupted run (every dataset; the times
    aside).  ``command``: the command line, kept in the file (root attribute ``command``,
    as a sweep's); a resumed file keeps the one it was started with.

    Interrupted (SIGINT, SIGTERM; within about a second while the seeds are found too):
    ``SweepInterrupted`` saying what was kept where.  A full disk or a file-size limit:
    ``WriteFailed``, the same.  Bad input: ``SweepError``.
    """
    out_path = str(out_path)
    log = _quiet_on_closed(log)
    if not scene.cont:
        raise SweepError(f"scene {scene.name!r} has no [continue] table (parameter, range, "
                         "...: docs/continuation.md)")
    _inputs(scene, out_path, inputs)       # before the lock: its file is never an input
    with outputs.output_lock(out_path):
        plan = plan_output(scene, out_path, resume, overwrite, inputs, locked=True)
        if plan == "done":
            partial = out_path + ".partial"
            left = _partial_state(partial, scene)[0] == "ours"
            if left:
                os.remove(partial)          # this scene's too: the output holds all of it
            log(f"{out_path} is already complete (finished {_finished(out_path)[1]} from this "
                "scene); nothing to do" + (f" (removed {partial}, an interrupted run of the "
                                           "same scene)" if left else ""))
            return None
        return _run_locked(scene, out_path, plan, log, command)


def plan_output(scene, out_path, resume, overwrite, inputs=(), locked=False) -> str:
    """What ``cornerbif continue`` will do with its output, decided before any work (and
    before anything is said), as ``sweep.plan_output`` decides a sweep's: "done"
    (``resume`` of an output finished from this scene, ``[plot]`` aside: nothing to do, so
    that a script may always pass --resume), "resume" (the partial file of this scene to
    complete; with ``overwrite`` also where it waits behind another scene's finished
    output, which it then replaces) or "start".  ``SweepError`` for what it must refuse:
    the output or a file beside it being an input, an existing output without
    ``overwrite`` or not a continuation file, an output another command is writing (unless
    ``locked``: this process holds the lock), a partial file that is not a continuation's
    (never removed), and another scene's or a damaged partial file without ``overwrite``
    (never removed by --resume, which completes only this scene's)."""
    named = _inputs(scene, out_path, inputs)
    if not locked:
        outputs.check_unlocked(out_path)
    partial = out_path + ".partial"
    what, got = _partial_state(partial, scene)
    if what == "foreign":
        raise SweepError(f"{partial}: is in the way ({got}); remove it yourself, or name "
                         "another output")
    tmp = outputs.temporary_name(partial)
    if os.path.lexists(tmp) and (os.path.islink(tmp) or not os.path.isfile(tmp)):
        raise SweepError(f"{tmp}: is in the way of the partial file's rewrites (a link, a "
                         "directory or a device); remove it yourself, or name another output")
    if resume and not overwrite and os.path.lexists(out_path):
        outputs.check_output(out_path, True, named, kind="continuation")
        text, completed = _finished(out_path)
        if completed and same_run(text, scene.text):
            return "done"
        whose = ("is a finished continuation of another scene" if completed else
                 "exists and is not a finished continuation (it cannot be read, or was never "
                 "completed)")
        if what == "ours":
            raise SweepError(f"{out_path} {whose} and {partial} holds an interrupted "
                             "continuation of this scene: pass --resume --overwrite to complete "
                             f"it (it then replaces {out_path}), or name another output")
        diff = f" ({scene_difference(text, scene.text)})" if completed else ""
        raise SweepError(f"{out_path} {whose}{diff}; --resume completes only this scene's "
                         "continuation: pass --overwrite to replace it, or name another output")
    outputs.check_output(out_path, overwrite, named, kind="continuation")
    if what in ("none", "empty"):
        return "start"
    if what == "ours" and resume:
        return "resume"
    if overwrite and not resume:
        return "start"
    if what == "ours":
        _, branches, curves, _ = got
        raise SweepError(f"{partial} holds an interrupted continuation of this scene: "
                         f"{_kept(partial, (len(branches), len(curves)))}; pass --resume to "
                         "complete it, or --overwrite to start again")
    again = "--overwrite (without --resume)" if resume else "--overwrite"
    if what == "other":
        raise SweepError(f"{partial} holds an interrupted continuation of another scene ({got}); "
                         "--resume completes only the same scene's ([plot] aside): run it with "
                         f"that scene, or pass {again} to start again")
    raise SweepError(f"{partial} cannot be resumed ({got}); pass {again} to start again")


def _inputs(scene, out_path, inputs) -> list:
    """The command's inputs named (``outputs._named``; ``continue.seed_file`` too), once the
    output's folder and name are checked (``outputs.check_directory``,
    ``check_name_length``) and no file written beside the output (its partial file, its
    lock, their temporaries) is one of them."""
    outputs.check_name_length(out_path, outputs.check_directory(out_path))
    named = list(outputs._named(inputs))
    if "seed_file" in scene.cont:
        named.append(("continue.seed_file", scene.cont["seed_file"]))
    partial = out_path + ".partial"
    for side in (partial, out_path + ".lock", outputs.temporary_name(partial)):
        for what, p in named:
            if outputs.same_file(side, p):
                raise SweepError(f"-o {out_path}: {side}, which this command writes beside "
                                 f"it, is {what}; name another output")
    return named


def _quiet_on_closed(log):
    """``log`` that falls silent once its stream is closed (a console piped to ``head``):
    what cannot be shown never stops the work, nor loses it."""
    closed = []

    def say(msg):
        if not closed:
            try:
                log(msg)
            except OSError:
                closed.append(True)
    return say


def _finished(path) -> tuple:
    """(scene text, completion time) of an existing continuation file; the time is '' when
    it was never completed or cannot be read."""
    import h5py  # start-up: loads h5py
    try:
        with h5py.File(path, "r", locking=False) as f:
            return (str(_plain(f.attrs.get("scene", ""))),
                    str(_plain(f.attrs.get("completed", ""))))
    except Exception:  # noqa: BLE001 - damaged or crafted: not a finished file
        return "", ""


def _partial_state(partial, scene):
    """What the partial file beside an output holds: ("none"), ("empty"), ("foreign", why:
    not a regular file, or not a continuation's), ("damaged", why), ("other", what differs)
    or ("ours", records) where records are ``_load``'s (attrs, branches, curves, state)."""
    if not os.path.lexists(partial):
        return "none", None
    kind = "a symbolic link" if os.path.islink(partial) else outputs.not_a_regular_file(partial)
    if kind:
        return "foreign", f"it is {kind}"
    if os.path.getsize(partial) == 0:
        return "empty", None
    if outputs.hdf5_format(partial) != FORMAT:
        return "foreign", "it is not a cornerbif continuation's partial file"
    try:
        loaded = _load(partial)
        attrs, branches, curves, state = loaded
        diff = scene_difference(attrs.get("scene", ""), scene.text)
        if diff:
            return "other", diff
        if state is None and not attrs.get("completed"):
            raise ValueError("it holds no resume state")
        if state is not None and (state.get("version") != STATE_VERSION
                                  or state["branches"] != len(branches)):
            raise ValueError("its resume state does not match its branches")
    except Exception as e:  # noqa: BLE001 - crafted or damaged: said, never a traceback
        return "damaged", f"{type(e).__name__}: {cut(e)}"
    return "ours", loaded


def _finished_units(done) -> str:
    """'2 finished branches and 1 curve' of ``done`` = (branches, curves)."""
    nb, nc = done
    return (f"{nb} finished branch{'es' if nb != 1 else ''}"
            + (f" and {nc} curve{'s' if nc != 1 else ''}" if nc else ""))


def _kept(partial, done) -> str:
    """What is on disk, for a message: ``done`` = (branches, curves) in the partial file,
    or None when there is none."""
    if done is None:
        return "nothing was kept (no branch had finished)"
    one = done[0] == 1 and not done[1]
    return f"the {_finished_units(done)} {'is' if one else 'are'} kept in {partial}"


def _run_locked(scene, out_path, plan, log, command):
    """``run_to_file`` once the output is locked and ``plan_output`` said "resume" or
    "start": the partial file resumed (``_resumed``) or started afresh (``_started``), its
    units written (``_write_units``), the file renamed to ``out_path``."""
    partial = out_path + ".partial"
    tmp = outputs.temporary_name(partial)
    if os.path.isfile(tmp) and not os.path.islink(tmp):
        os.remove(tmp)              # a partial file's rewrite cut by a kill: never whole
    if plan == "resume":
        head, branches, curves, state = _resumed(scene, partial, log)
        done = (len(branches), len(curves))
    else:
        if os.path.lexists(partial):
            os.remove(partial)      # plan_output: empty, or to start again (--overwrite)
        state = _started(scene, log)
        head = {"created": time.strftime("%Y-%m-%dT%H:%M:%S"),
                "seeds": ", ".join(state["seeds_found"]), "command": command}
        branches, curves, done = [], [], None
    if state is not None:
        done = _write_units(scene, partial, head, branches, curves, state, done, log)
    _rename(partial, out_path, done)
    nev = sum(len(b["events"]) for b in branches)
    log(f"wrote {out_path}: {len(branches)} branches, {nev} events, {len(curves)} curves")
    return out_path


def _resumed(scene, partial, log):
    """The partial file of this scene as ``_write_units`` goes on from it: (head, branches,
    curves, state); state None when it is finished (killed before its rename)."""
    attrs, branches, curves, state = _partial_state(partial, scene)[1]
    head = {"created": attrs.get("created", ""), "seeds": attrs.get("seeds", ""),
            "command": attrs.get("command", "")}
    if state is None:
        log(f"{partial} is complete; finishing it")
    else:
        log(f"resuming {partial}: {_finished_units((len(branches), len(curves)))} before")
    return head, branches, curves, state


def _started(scene, log):
    """The state of a new run: its seeds (``_seed_stage``), said; an interrupt meanwhile is
    ``SweepInterrupted`` (nothing is written yet), no seed at all a ``Fault``."""
    try:
        state = _seed_stage(scene, log)
    except KeyboardInterrupt:
        raise SweepInterrupted("interrupted while the seeds were found; nothing was kept; "
                               "run the same command again") from None
    if not state["seeds"]:
        raise Fault("no branch to continue (see above): nothing written")
    c = scene.cont
    log(f"continuing {len(state['seeds'])} seed(s) in {c['parameter']} over "
        f"{c['range']} from {state['start']!r}: "
        + ", ".join(repr(s["word"]) for s in state["seeds"]))
    return state


def _write_units(scene, partial, head, branches, curves, state, done, log):
    """Continue from ``state``, rewriting the partial file whole after each finished unit
    (the unit and the state after it, in one file) and, at the end, as a finished file;
    return ``done`` = (branches, curves) on disk.  An interrupt waits for a write under
    way and is ``SweepInterrupted`` saying what is kept; a failed write is ``WriteFailed``
    (``outputs.replacing``), an exhausted memory a ``Fault``, the same."""
    again = "run the same command with --resume to complete it"
    room = "free space (or raise the file-size limit) and " + again
    try:
        for kind, unit in _units(scene, state, log):
            if kind == "branch":
                branches.append(_branch_record(unit[1], scene))
                line = _branch_lines(*unit, scene)
            else:
                line = None if unit is None else _curve_line(unit, scene)
                if unit is not None:
                    curves.append(_curve_record(unit, scene))
            with outputs.signals_deferred():    # what is said kept is what is on disk
                _write_bytes(partial, _image(scene, head, branches, curves, state),
                             f"{_kept(partial, done)}; {room}")
                done = (len(branches), len(curves))
                if line:
                    # said once it is on disk, and before an interrupt that came during the
                    # write ends the run: every branch said kept was shown
                    log(line)
        head["completed"] = time.strftime("%Y-%m-%dT%H:%M:%S")
        _write_bytes(partial, _image(scene, head, branches, curves),
                     f"{_kept(partial, done)}; {room}")
    except KeyboardInterrupt:
        raise SweepInterrupted(f"interrupted; {_kept(partial, done)}; "
                               + (again if done else "run the same command again")) from None
    except MemoryError:
        raise Fault(f"out of memory while continuing; {_kept(partial, done)}") from None
    except SweepError:
        raise
    except Exception:
        log(f"stopped by an unexpected error; {_kept(partial, done)}")
        raise                       # a bug: ``cli.Commands`` says so, in its one message
    return done


def _rename(partial, out_path, done):
    """The finished partial file becomes ``out_path`` (one atomic rename, signals deferred:
    an interrupt raised once it is done finds the output whole, and the run ends as done)."""
    try:
        with outputs.signals_deferred():
            os.replace(partial, out_path)
    except KeyboardInterrupt:
        outputs.note_late_interrupt()   # the rename was done: nothing is left to keep
    except OSError as e:
        raise WriteFailed(f"renaming {partial} to {out_path} failed ({outputs.reason(e)}); "
                          f"{_kept(partial, done)}; run the same command with --resume to "
                          "finish it") from None
