"""The explorer's work beside the page: the scene of a window (the file's scene with its
axis range replaced, checked before anything runs), a refine that sweeps it into a side
file in a thread of its own (``sweep.run_sweep``, blocks written as they finish, read back
from the partial file while it runs), and a continuation from one orbit
(``continuation_run.run_to_file``).  A job never raises into the server: what went wrong
is its ``message``.  The file explored is never written."""

from __future__ import annotations

import contextlib
import copy
import math
import os
import re
import shutil
import tempfile
import threading
import time
import tomllib

import numpy as np

from .. import continuation_run, registry
from ..config import SceneError, dumps, loads, set_dotted
from ..errors import SweepInterrupted
from ..estimate import duration, estimate_time
from ..model import cut

# a refine runs at most this long by the time model (``estimate.estimate_time``, its high
# end) and this many runs: past either it is refused with a message
REFINE_SECONDS = 120.0
REFINE_RUNS = 2_000_000
# blocks of a refine: it is drawn as each is written
REFINE_BLOCKS = 8
# the fewest ulps of the window's ends between two of its values
MIN_ULPS = 4


class Refused(ValueError):
    """A window or a request the explorer will not run, with the reason for the page."""


def window_raw(scene_text: str, axis: str, x0: float, x1: float, num: int,
               second=None) -> dict:
    """The file's scene with its swept axis over [x0, x1] at ``num`` values (linear), its
    ``[plot]`` given the window's x-range: what the view's refine sweeps and what a saved
    view reproduces; ``second`` (axis, y0, y1, num): a chart's second axis, likewise, its
    range the ``[plot]``'s y-range.  ``Refused`` for a degenerate window: not finite, of no
    width, or narrower than double precision resolves with ``num`` values."""
    raw = copy.deepcopy(tomllib.loads(scene_text))
    plot = raw.setdefault("plot", {})
    plot.pop("ylim", None)
    for (a, lo, hi, n), lim in zip([(axis, x0, x1, num)] + ([second] if second else []),
                                   ("xlim", "ylim")):
        _check_window(lo, hi, n)
        name = a.removeprefix("initial.")
        key = f"sweep.initial.{name}" if a.startswith("initial.") else f"sweep.{_quoted(a)}"
        set_dotted(raw, key, {"start": float(lo), "stop": float(hi), "num": int(n)})
        plot[lim] = [float(lo), float(hi)]
    sc = raw.setdefault("scene", {})
    sc["name"] = re.sub(r"[^A-Za-z0-9._-]", "_", str(sc.get("name", "scene")))[:60] + "_window"
    return raw


def _check_window(x0, x1, num):
    """``Refused`` for a window [x0, x1] of ``num`` values that is not finite, has no
    width or is below double precision."""
    if not (math.isfinite(x0) and math.isfinite(x1)):
        raise Refused(f"the window [{x0!r}, {x1!r}] is not finite")
    if not x1 > x0:
        raise Refused(f"the window [{x0!r}, {x1!r}] has no width: zoom out")
    step = (x1 - x0) / max(num - 1, 1)
    ulp = math.ulp(max(abs(x0), abs(x1)))
    if step < MIN_ULPS * ulp:
        raise Refused(f"the window [{x0!r}, {x1!r}] is below double precision at {num} values "
                      f"(a step of {step:.3g}, the values' spacing is {ulp:.3g}): zoom out")


def _quoted(key: str) -> str:
    return f'"{key}"' if "." in key else key


def window_scene(scene_text, axis, x0, x1, num, threads=1, second=None):
    """``window_raw`` as a checked ``config.Scene`` and its TOML text; ``Refused`` for a
    scene config refuses or a sweep larger than a refine runs (``REFINE_SECONDS``,
    ``REFINE_RUNS``)."""
    raw = window_raw(scene_text, axis, x0, x1, num, second)
    text = dumps(raw)
    try:
        scene = loads(text)
    except SceneError as e:
        raise Refused("the window's scene is refused: " + "; ".join(e.problems[:3])) from None
    runs = int(num) * (int(second[3]) if second else 1) * scene.n_ic
    if runs > REFINE_RUNS:
        raise Refused(f"a refine of {runs} runs is more than {REFINE_RUNS}: narrow the window "
                      "or sweep the saved scene with cornerbif sweep")
    eta = estimate_time(scene, threads)
    if eta.high > REFINE_SECONDS:
        raise Refused(f"this refine would take up to {duration(eta.high)} (more than "
                      f"{duration(REFINE_SECONDS)}): narrow the window, or save the view as a "
                      "scene and sweep it with cornerbif sweep")
    return scene, text


class Job:
    """Work in a thread of its own: ``state`` ("running", "done", "failed", "cancelled"),
    ``message``
    (what the page says), ``result`` (the file written); ``done``/``total``: its
    progress."""

    def __init__(self, what: str):
        self.what = what
        self.state = "running"
        self.message = f"{what}: starting"
        self.result = None
        self.done = 0
        self.total = 0
        self.started = time.perf_counter()
        self._thread = None

    def start(self, work):
        def body():
            try:
                self.result = work()
                self.state = "done"
            except Cancelled:
                self.state = "cancelled"
            except Exception as e:  # noqa: BLE001 - a job never takes the server down
                self.state = "failed"
                self.message = f"{self.what} failed: {type(e).__name__}: {cut(str(e), 400)}"
        self._thread = threading.Thread(target=body, name=f"explore {self.what}", daemon=True)
        self._thread.start()
        return self

    @property
    def running(self) -> bool:
        return self.state == "running"

    def join(self, timeout=None):
        if self._thread is not None:
            self._thread.join(timeout)

    def seconds(self) -> float:
        return time.perf_counter() - self.started


def side_name(side_dir: str, stem: str, what: str) -> str:
    """A new file name in ``side_dir``: ``stem_what_N`` (N the first free)."""
    k = 1
    while any(os.path.exists(os.path.join(side_dir, f"{stem}_{what}_{k}{ext}"))
              for ext in (".h5", ".h5.partial", ".toml", ".png", ".pdf")):
        k += 1
    return os.path.join(side_dir, f"{stem}_{what}_{k}")


@contextlib.contextmanager
def partial_copy(partial):
    """A refine's partial file, being written by its sweep in this process, opened for
    reading through a byte copy (removed after).  HDF5 shares one open file between the
    handles of a process: a handle on the partial file itself (even read-only, SWMR) would
    keep the writer's file open past its close, and the sweep's finishing would then fail
    ("file is already open for write").  The copy is opened as a SWMR reader (the sweep
    writes in SWMR mode: the copy's superblock says so, and a plain reader is refused).  A
    copy cut mid-write fails to open (OSError) or holds fewer blocks done: the page reads
    again at its next poll."""
    import h5py  # start-up: loads h5py
    fd, path = tempfile.mkstemp(suffix=".h5", prefix="refine-read-",
                                dir=os.path.dirname(os.path.abspath(partial)))
    os.close(fd)
    try:
        shutil.copyfile(partial, path)
        # the copy carries the writer's "open for SWMR write" flags: only a SWMR reader
        # opens it (a plain one is refused: "file is already open for write")
        with h5py.File(path, "r", swmr=True) as f:
            yield f
    finally:
        os.remove(path)


def start_refine(scene, out_path, threads=None) -> Job:
    """Sweep ``scene`` (``window_scene``'s) to ``out_path`` in a thread, in
    ``REFINE_BLOCKS`` blocks; the job's ``partial`` is the file being written."""
    from ..sweep import run_sweep  # start-up: loads h5py and numba
    job = Job("refine")
    job.partial = out_path + ".partial"
    job.total = int(np.prod([a.array.size for a in scene.axes]))
    job.cancel = threading.Event()         # set by the page's "Cancel the refine"
    block = max(1, math.ceil(job.total / REFINE_BLOCKS))

    def work():
        job.message = "refine: compiling or starting the kernels"
        try:
            run_sweep(scene, out_path, threads=threads, progress=False, block_points=block,
                      command="cornerbif explore (refine)", echo=lambda m: None,
                      cancel=job.cancel)
        except SweepInterrupted:
            if not job.cancel.is_set():
                raise
            job.message = (f"refine: cancelled after {job.seconds():.1f} s; its finished "
                           f"blocks are kept in {job.partial} (cornerbif sweep --resume with "
                           "its scene completes it)")
            raise Cancelled() from None
        job.message = f"refine: done in {job.seconds():.1f} s, {out_path}"
        return out_path
    return job.start(work)


class Cancelled(Exception):
    """A job stopped at the page's request (``Job``: state "cancelled")."""


def continue_raw(scene_text: str, axis: str, x: float, start: list, lo: float, hi: float,
                 fixed=None, curve=None) -> dict:
    """The file's scene made a continuation from one run: its parameter ``axis`` from ``x``
    over [lo, hi], seeded by the attractor the start ``start`` reaches there (``initial
    points``), no sweep; ``fixed`` (name -> value) the run's other swept parameters, and
    ``curve`` (name, lo, hi) a second parameter in which the located corner collisions and
    folds are continued as curves (``[continue] curve``).  ``Refused`` when the axis is a
    start coordinate, or the range is degenerate."""
    if axis.startswith("initial."):
        raise Refused("continuation follows a parameter; this file sweeps a start "
                      f"coordinate ({axis})")
    if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi and lo <= x <= hi):
        raise Refused(f"the range [{lo:.6g}, {hi:.6g}] of {axis} must be finite, increasing "
                      f"and hold the orbit's value {x:.6g}")
    raw = copy.deepcopy(tomllib.loads(scene_text))
    for k in ("sweep", "plot", "continue"):
        raw.pop(k, None)
    numbers = {axis: float(x)} | {name: float(v) for name, v in (fixed or {}).items()}
    spec = registry.models().get(str(raw.get("scene", {}).get("model", "")))
    if spec is not None and spec.for_system is not None:
        # a model its scene declares (``linear``): its numbers by path, written into its
        # [system] table where they are (``Model.system_table_with``)
        model, problems = spec.for_system(raw.get("system", {}))
        if model is None:
            raise Refused("the file's [system] is refused: " + "; ".join(problems[:3]))
        raw["system"] = model.system_table_with(numbers)
    else:
        raw.setdefault("system", {}).update(numbers)
    raw["initial"] = {"points": [[float(s) for s in start]]}
    raw["continue"] = {"parameter": axis, "range": [float(lo), float(hi)], "start": float(x),
                       "seed": "all"}
    if curve is not None:
        raw["continue"]["curve"] = curve[0]
        raw["continue"]["curve_range"] = [float(curve[1]), float(curve[2])]
    sc = raw.setdefault("scene", {})
    sc["name"] = re.sub(r"[^A-Za-z0-9._-]", "_", str(sc.get("name", "scene")))[:60] + "_continue"
    return raw


def start_continuation(raw: dict, out_path: str) -> Job:
    """Run ``raw`` (``continue_raw``'s) to ``out_path`` in a thread; the job's ``lines``
    are what it said, its result the continuation as ``plot_data.read_continuation`` reads
    it."""
    from ..plot_data import read_continuation  # start-up: loads h5py
    job = Job("continuation")
    job.lines = []
    try:
        scene = loads(dumps(raw))
    except SceneError as e:
        raise Refused("the continuation's scene is refused: " + "; ".join(e.problems[:3])) \
            from None

    def log(line):
        job.lines.append(str(line))
        job.message = "continuation: " + cut(str(line).splitlines()[0], 200)

    def work():
        job.message = "continuation: finding the orbit (the first run compiles its kernels)"
        continuation_run.run_to_file(scene, out_path, log=log,
                                     command="cornerbif explore (continue from here)")
        cont = read_continuation(out_path)
        job.message = (f"continuation: {len(cont['branches'])} branch(es), "
                       f"{len(cont['events'])} event(s) in {job.seconds():.1f} s, {out_path}")
        return cont
    return job.start(work)
