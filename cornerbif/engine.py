"""The sweep engine: grid slabs in, datasets out (pure: no I/O, no global state).

Data flow (docs/architecture.md): scene -> ``blocks`` (grid slabs) -> ``compute_block``
(pack the slab's parameters, draw its starts, run the model's kernel and cycle
analysis through the registry) -> a dict dataset name -> array, which a backend
(``cornerbif.local``, ``cornerbif.distributed``) hands to the file (``cornerbif.io``).
Initial conditions are drawn outside the kernels from a counter-based generator
keyed by (seed, grid point, initial condition, coordinate), so they do not depend
on block size, thread count or resume history.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import subprocess
import sys
import tempfile

import numpy as np

from .compile_plan import HALF_PLANS, PLANS
from .config import Scene
from .observables import ANALYSIS_KERNELS

BLOCK_BYTES = 24 * 2**20     # working memory per block (kernel outputs); the local backend
                             # holds two (one computing, one being written)
CHUNK_BYTES = 256 * 2**10    # uncompressed bytes of one chunk of a per-event dataset
ITEM_OVERHEAD = 128          # bytes per item beyond its recorded events (status, period, the
                             # cycle's signature, ...)


# ------------------------------------------------------------------ initial conditions
def _splitmix64(x):
    x = (x + np.uint64(0x9E3779B97F4A7C15)) & np.uint64(0xFFFFFFFFFFFFFFFF)
    z = x
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def uniform(seed, point, ic, coord):
    """Counter-based uniform numbers in [0, 1) keyed by (seed, point, ic, coord)."""
    with np.errstate(over="ignore"):
        key = (np.asarray(point, np.uint64) * np.uint64(1 << 20) + np.asarray(ic, np.uint64)) \
            * np.uint64(4) + np.uint64(coord)
        z = _splitmix64(_splitmix64(np.uint64(seed) ^ np.uint64(0xC0FFEE)) ^ key)
        z = _splitmix64(z)
    return (z >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0)


def draw_initial(scene: Scene, flat_points: np.ndarray, wall: np.ndarray, params=None):
    """Initial states for grid points ``flat_points`` (shape (n,)): an array
    (n, n_ic, start size) in the model's start order (``Model.starts``: the state, then
    the start time where the model has one).  Given starts (``[initial] points``) are the
    same at every point, with no floor: a start below the obstacle gets the kernel's status.

    A coordinate with a floor is uniform on the part of its ``[initial]`` range strictly
    above it (the same law as drawing on the whole range and redrawing points below):
    ``"wall"`` is the obstacle at the start (``wall``, per point, at t = 0; at each start's
    own time when the start time is not 0 everywhere: ``Model.wall_at`` on ``params``),
    otherwise another coordinate drawn before it (two_particle: w(0) < z <= u).  A
    coordinate swept by the scene (``[sweep] initial.<c>``) takes its cell's value for
    every start, with no floor: a start below the obstacle gets the kernel's status for it.
    """
    spec = scene.spec
    n = flat_points.shape[0]
    if scene.points is not None:          # [initial] points: the same starts at every point
        return np.broadcast_to(np.asarray(scene.points, float),
                               (n, scene.n_ic, len(spec.start_names))).copy()
    pts = np.repeat(flat_points.astype(np.uint64), scene.n_ic)
    ics = np.tile(np.arange(scene.n_ic, dtype=np.uint64), n)
    drawn = {}
    swept = scene.start_axes
    if swept:
        grid_index = np.unravel_index(flat_points.astype(np.int64), scene.shape)
    # the start time first: the wall a start clears is the obstacle at that time
    order = sorted(spec.starts, key=lambda c: c is not spec.start_time)
    for c in order:
        if c.name in swept:
            # a swept start coordinate ([sweep] initial.<c>): the cell's value, every start
            pos, values = swept[c.name]
            drawn[c.name] = np.repeat(values[grid_index[pos]][:, None], scene.n_ic, axis=1)
            continue
        lo, hi = scene.initial[c.name]
        x = uniform(scene.seed, pts, ics, c.draw).reshape(n, scene.n_ic)
        if c.floor is None:
            drawn[c.name] = lo + (hi - lo) * x
            continue
        if c.floor == "wall":
            t0 = drawn.get(spec.start_time.name) if spec.start_time is not None else None
            floor = (spec.wall_at(params, t0) if t0 is not None and np.any(t0 != 0.0)
                     else wall[:, None])
        else:
            floor = drawn[c.floor]
        lo = np.maximum(lo, floor)
        drawn[c.name] = hi - (hi - lo) * x          # in (floor, hi]
    return np.stack([drawn[c] for c in spec.start_names], axis=-1)


# ------------------------------------------------------------------ the model's kernel
def pack_points(scene: Scene, index_list) -> np.ndarray:
    """Packed parameter rows of the scene's model for a list of grid indices."""
    return scene.spec.pack_points(scene, index_list)


def int_settings(scene: Scene) -> np.ndarray:
    """The kernel's integer settings (transient, record, budgets)."""
    return scene.spec.int_settings(scene)


def with_control(scene: Scene, ints: np.ndarray, control) -> np.ndarray:
    """The kernel's integer settings under a sweep's control (``_jit.Control``: the stop flag
    its kernels poll and the runs they finished): a copy with the control's address in the
    model's ``control_slot``.  A model without one runs as before (it stops between blocks
    only).  The result holds an address: only this process may use it, and only while
    ``control`` is alive (the caller keeps a reference to it)."""
    slot = getattr(scene.spec, "control_slot", None)
    ints = np.array(ints, np.int64)
    if slot is not None and control is not None:
        ints[slot] = control.address
    return ints


def run_items(params: np.ndarray, ics: np.ndarray, ints: np.ndarray, scene: Scene):
    """The model's kernel and cycle analysis on n items (rows of params / ics):
    ``Model.run_items``'s ``RunResult``."""
    return scene.spec.run_items(params, ics, ints, scene)


def cold_compiles(scene: Scene, what=("sweep",)) -> list:
    """The kernels of ``scene`` that compile on their first call here (``_jit.cache_is_cold``),
    as (name, seconds) with the model's measured cold compile time (``Model.compiles``,
    benchmarks/compile_time.py).  ``what``: "sweep" (the sweep's kernels, with the stability
    kernels: a finished sweep's runs without a cycle are tested for chaos with them,
    ``cornerbif.chaos``), "stability" (those whatever keep says),
    "continuation" (what ``cornerbif continue`` compiles), "simulate" (what
    ``cornerbif.simulate`` compiles: the sweep's kernels but the file's)."""
    from ._jit import cache_is_cold  # start-up: loads numba
    compiles = getattr(scene.spec, "compiles", None)
    if compiles is None:
        return []
    return [(name, seconds) for name, seconds, kernels in compiles(scene, tuple(what))
            if any(cache_is_cold(k) for k in kernels)]


def announce_compiles(scene: Scene, echo, what=("sweep",)) -> float:
    """Say, before any work, each kernel of ``scene`` that compiles first (``cold_compiles``),
    one line each through ``echo`` (``compile_words``).  Returns the seconds announced (0:
    every kernel is cached)."""
    total = 0.0
    for name, seconds in cold_compiles(scene, what):
        echo(compile_words(name, seconds))
        total += seconds
    return total


@contextlib.contextmanager
def compiling_aside(scene: Scene, what=("sweep",)):
    """While the body runs, compile in a second process (when there is a second core) what of
    ``scene``'s first compile can be compiled beside the kernel: the helpers that
    ``compile_plan.PLANS`` lists for each kernel that compiles first (``cold_compiles``), and
    the cycle analysis (``observables.ANALYSIS_KERNELS``) when it and another kernel compile
    first.  numba compiles one function at a time in a process; a function the second process
    has put in numba's cache is loaded, not compiled, when this one reaches it (one it has
    not yet: compiled here as before), and a kernel it is compiling when this one calls it
    is awaited (``_jit.compiling_beside``: the second process says which kernels it has begun
    and finished, as empty files in a folder of its own).  Nothing else is shared; the child
    writes only numba's cache and that folder, and is stopped at the end of the body if it
    is still running.  The environment variable CORNERBIF_COMPILE_BESIDE=0 turns it off."""
    from ._jit import cache_is_cold, compiling_beside, dispatchers  # start-up: loads numba
    child = folder = None
    cold = [name for name, _ in cold_compiles(scene, what)]
    # in the order this process reaches them: a kernel's helpers, whole kernels of their own
    # (a stability kernel the scene keeps runs right after the kernel: compiled here, the
    # short analysis would keep this process waiting for it), the cycle analysis, and last
    # a stability kernel only the finish's chaos test uses
    planned = sorted((name for name in cold if name in PLANS), key=lambda n: n not in HALF_PLANS)
    late = [] if "stability" in scene.keep or "stability" in what else [
        name for name, _, _ in getattr(scene.spec, "compiles",
                                       lambda *a: [])(scene, ("stability",))]
    analysis = any(cache_is_cold(k) for k in dispatchers(*ANALYSIS_KERNELS)) and len(cold) > 1
    order = ([n for n in planned if n not in late] + ["the cycle analysis"] * analysis
             + [n for n in planned if n in late])
    if ((os.cpu_count() or 1) > 1 and (planned or analysis)
            and os.environ.get("CORNERBIF_COMPILE_BESIDE", "1") != "0"):
        folder = tempfile.mkdtemp(prefix="cornerbif-compiling-")
        child = subprocess.Popen([sys.executable, "-c", "import sys; from cornerbif.engine import "
                                  "compile_beside; compile_beside(sys.argv[1:])", *order],
                                 stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL,
                                 stderr=subprocess.DEVNULL,
                                 env=dict(os.environ, CORNERBIF_COMPILING_REPORT=folder))
        compiling_beside(folder, child)     # a kernel it has begun is awaited, not compiled again
    try:
        yield child
    finally:
        compiling_beside(None)
        if child is not None and child.poll() is None:
            child.terminate()
            child.wait()
        if folder is not None:
            shutil.rmtree(folder, ignore_errors=True)


def compile_beside(names):
    """What ``compiling_aside``'s second process compiles, in the order given: for each
    kernel name its functions in ``compile_plan.PLANS``, and "the cycle analysis"
    (``compile_analysis``) where it is named."""
    from ._jit import compile_listed, compiling_beside  # start-up: loads numba
    report = os.environ.get("CORNERBIF_COMPILING_REPORT")
    if report:      # say which kernels are begun and done (``_jit.compiling_beside``)
        compiling_beside(report, report=True)
    for name in names:
        if name in PLANS:
            compile_listed(PLANS[name])
        elif name == "the cycle analysis":
            compile_analysis()


def compile_analysis():
    """Compile the cycle analysis and the file's chunk writer (``observables.ANALYSIS_KERNELS``)
    for the argument types a sweep passes them (``Model.run_items``, ``cycle_signatures``,
    ``chunkwrite``), on a tiny block: what ``compiling_aside`` runs in its second process."""
    from .analysis import SIGNATURE, cycle_signatures, detect_cycles  # start-up: loads numba
    from .chunkwrite import shuffle  # start-up: loads numba
    from .numerics.fill import full  # start-up: loads numba
    n, rec = 2, 8
    t = full((n, rec), np.nan)
    period, ipc = np.zeros(n, np.int64), np.zeros(n, np.int64)
    detect_cycles(t, t, t, np.zeros((n, rec), np.int64), np.ones(n, np.bool_), 1e-6, period,
                  ipc, np.zeros((n, rec), np.uint8))
    cycle_signatures(t, t, t, ipc, np.empty((n, len(SIGNATURE))), np.empty((n, 2)))
    shuffle(t)


def compile_words(name: str, seconds: float) -> str:
    """The announcement of a first compile, e.g. "compiling the flow kernel (once per install,
    then cached; about 25 s on the machine it was timed on, longer on a slower or busier one)
    ...": ``seconds`` is a time measured elsewhere (``Model.compiles``,
    benchmarks/compile_time.py), said rounded (``rough_seconds``) and as what it is."""
    return (f"compiling {name} (once per install, then cached; about {rough_seconds(seconds)} "
            "on the machine it was timed on, longer on a slower or busier one) ...")


def rough_seconds(seconds: float) -> str:
    """A time measured on another machine in round words: whole seconds below 10 s (at least
    1), multiples of 5 s below a minute, whole minutes above."""
    if seconds < 10:
        return f"{max(1, round(seconds))} s"
    if seconds < 60:
        return f"{5 * round(seconds / 5)} s"
    return f"{round(seconds / 60)} min"


def symbol_bytes(sym, record):
    """uint8 word rows -> fixed-length byte strings for the file (no Python objects)."""
    L = max(1, record // 2)
    return np.ascontiguousarray(sym[:, :L]).view(f"S{L}").reshape(sym.shape[0])


# ------------------------------------------------------------------ blocks
def item_bytes(scene: Scene) -> int:
    """Working memory of one item (one start at one grid point) in a block."""
    return scene.record * scene.spec.bytes_per_event + ITEM_OVERHEAD


def points_fit(scene: Scene) -> int:
    """Grid points whose kernel output fits in BLOCK_BYTES (at least one)."""
    return max(1, BLOCK_BYTES // (item_bytes(scene) * scene.n_ic))


def block_points_max(scene: Scene) -> int:
    """Grid points a block holds at most: as many as fit in BLOCK_BYTES of kernel output
    (at least one), a whole number of event chunks (``event_chunk_points``)."""
    fit = points_fit(scene)
    return fit - fit % event_chunk_points(scene)


def event_chunk_points(scene: Scene) -> int:
    """Grid points (along the last axis) of one chunk of a per-event dataset: about
    CHUNK_BYTES, and never more than a block holds.  Blocks are whole numbers of chunks,
    so the writer compresses whole chunks itself (``cornerbif.chunkwrite``)."""
    per_point = max(1, scene.n_ic * scene.record * 8)
    return max(1, min(CHUNK_BYTES // per_point, points_fit(scene)))


def blocks(scene: Scene, block_points: int | None = None):
    """Grid slabs in execution order: list of index tuples (of slices).

    A slab holds at most ``block_points`` grid points (default: ``block_points_max``);
    a followed sweep runs one value of the first axis at a time, in the direction of
    ``follow``.
    """
    G = scene.shape
    max_points = block_points_max(scene)
    if block_points:
        max_points = min(max_points, int(block_points))
    if not G:
        return [()]
    if scene.follow != "none":
        order = range(G[0]) if scene.follow == "up" else range(G[0] - 1, -1, -1)
        if len(G) == 1:
            return [(slice(i, i + 1),) for i in order]
        return [(slice(i, i + 1), slice(0, G[1])) for i in order]
    if len(G) == 1:
        return [(slice(a, min(a + max_points, G[0])),) for a in range(0, G[0], max_points)]
    out = []
    for i in range(G[0]):
        for a in range(0, G[1], max_points):
            out.append((slice(i, i + 1), slice(a, min(a + max_points, G[1]))))
    return out


def block_indices(scene, blk):
    """The grid indices of a slab (row-major) and the slab's shape."""
    ranges = [range(s.start, s.stop) for s in blk]
    grid = np.stack(np.meshgrid(*[np.arange(r.start, r.stop) for r in ranges], indexing="ij"),
                    axis=-1).reshape(-1, len(ranges)) if ranges else np.zeros((1, 0), int)
    return [tuple(int(x) for x in row) for row in grid], [len(r) for r in ranges]


def compute_block(scene: Scene, blk, carry=None, ints=None) -> dict:
    """The one unit of work of every backend: a grid slab in, its datasets out.

    Pure (no I/O, no global state): packs the slab's parameters, draws its initial
    conditions (``draw_initial``; a followed sweep replaces them by ``carry``, the
    previous slab's final states, where those lie above the obstacle), runs the
    model's kernels and the cycle analysis (``run_items``), and returns a dict from
    dataset name (``io`` schema) to an array shaped ``slab shape + (n_ic, ...)``,
    ready for ``io.write_block``.  The local loop and the Dask workers
    (``cornerbif.distributed``) both call it, so both write the same bytes.
    """
    spec = scene.spec
    if ints is None:
        ints = spec.int_settings(scene)
    G = scene.shape
    idx, sub = block_indices(scene, blk)
    params = spec.pack_points(scene, idx)
    flat = (np.ravel_multi_index(tuple(np.asarray(idx, np.int64).reshape(len(idx), -1).T), G)
            if G else np.zeros(len(idx), np.int64))
    wall = spec.wall_at_start(params)
    ics = draw_initial(scene, flat, wall, params)
    if carry is not None:       # the previous slab's final states, where they can start
        ics = spec.starts_from_carry(carry, ics, wall, params)
    n = len(idx) * scene.n_ic
    prm = np.repeat(params, scene.n_ic, axis=0)
    run = spec.run_items(prm, ics.reshape(n, ics.shape[-1]), ints, scene)
    out, st, final, period, ipc, sym = (run.fields, run.status, run.final, run.period, run.ipc,
                                        run.symbols)
    shape = tuple(sub) + (scene.n_ic,)
    block = {}
    for i, c in enumerate(spec.start_names):
        block[f"initial/{c}"] = ics[..., i].reshape(shape)
    for i, c in enumerate(spec.finals):
        block[f"final/{c.name}"] = final[:, i].reshape(shape)
    block.update({"status": st.reshape(shape), "period": period.reshape(shape),
                  "impacts_per_cycle": ipc.reshape(shape),
                  "symbols": symbol_bytes(sym, scene.record).reshape(shape)})
    for fld in spec.fields(scene.keep):
        trail = fld.trailing(scene.record)
        # a series may run longer than the file keeps (the w-z table): its first rows
        kept = out[fld.source][(slice(None),) + tuple(slice(0, k) for k in trail)]
        block[fld.name] = kept.reshape(shape + trail)
    if spec.cycle is not None:
        sig, pt = cycle_signatures(spec.cycle, out, period, ipc)
        block["cycle/signature"] = sig.reshape(shape + sig.shape[1:])
        block["cycle/point"] = pt.reshape(shape + pt.shape[1:])
    return block


def cycle_signatures(series, out, period, ipc):
    """Per run, the signature of its cycle and a point of it (``analysis.cycle_signatures``
    on the model's ``CycleSeries``): what tells two attractors with one word apart in the
    file's attractor table (``cornerbif.attractors``)."""
    from .analysis import SIGNATURE  # start-up: loads numba
    from .analysis import cycle_signatures as kernel  # start-up: loads numba
    n = period.shape[0]
    sig = np.empty((n, len(SIGNATURE)))
    pt = np.empty((n, 2))
    count = np.ascontiguousarray(ipc if series.per == "impacts" else period, dtype=np.int64)
    kernel(np.ascontiguousarray(out[series.end]), np.ascontiguousarray(out[series.a]),
           np.ascontiguousarray(out[series.b]), count, sig, pt)
    return sig, pt


def carry_names(scene: Scene) -> list:
    """The datasets a followed sweep carries to the next slab (the final states)."""
    return [f"final/{c.name}" for c in scene.spec.finals]


def block_carry(scene: Scene, block: dict) -> np.ndarray:
    """What a followed sweep carries to the next slab: the slab's final states,
    shape (points, n_ic, state size), in the kernel's state order."""
    names = carry_names(scene)
    return np.stack([block[n] for n in names], -1).reshape(-1, scene.n_ic, len(names))
