"""What a sweep will cost, said before it runs (``cornerbif sweep --dry-run``, the budget
check, the progress line): the file's bytes, the working memory, the time from each model's
time model (``Model.run_seconds``), and durations said in words."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from . import engine
from .config import Scene

# bytes per run of the per-run summary: status (1), period and impacts per cycle (4 + 4)
SUMMARY_BYTES = 1 + 4 + 4
# the file's fixed part beside its data: HDF5's superblock, object headers and chunk
# indexes, the attributes (the scene as run is counted apart): 31 KB for a one-run file
# (configs/fig02.toml), measured
FILE_OVERHEAD = 64 * 2**10
# per attractor of the table written when the file is finished (cornerbif.attractors): id,
# period, impacts per cycle (4 each), parameter point, runs, share, standard error (8 each),
# the signature (6 x 8) and a point (2 x 8); its word and parameter values come on top
TABLE_BYTES = 3 * 4 + 4 * 8 + 6 * 8 + 2 * 8
# per grid point of the table: the count of each outcome (6 x 8)
OUTCOME_BYTES = 6 * 8


def estimate_bytes(scene: Scene) -> int:
    """Upper bound of the output file's size before compression: per run its start, final
    state, summary, word and kept observables, and (models with a ``CycleSeries``) its
    cycle's signature, point and attractor id; the attractor table at its largest (one
    attractor per run); the dimension scales (a copy in each group); the scene as run
    (an attribute) and the file's fixed part (``FILE_OVERHEAD``).  What the file takes on
    disk is less: ``estimate_file_bytes``."""
    return sum(_byte_parts(scene).values())


def _byte_parts(scene: Scene) -> dict:
    """``estimate_bytes`` by part: "runs" (the per-run datasets), "table", "scales",
    "scene" (the scene as run, twice: an attribute is stored as it is) and "overhead"."""
    spec = scene.spec
    points = int(np.prod(scene.shape or (1,)))
    n = points * scene.n_ic
    word = max(1, scene.record // 2)
    fields = spec.fields(scene.keep)
    per = 8 * len(spec.starts) + 8 * len(spec.state) + SUMMARY_BYTES + word
    per += sum(np.dtype(f.dtype).itemsize * int(np.prod(f.trailing(scene.record)))
               for f in fields)
    table = 0
    if spec.cycle is not None:
        per += 6 * 8 + 2 * 8 + 4                 # cycle/signature, cycle/point, attractor
        mult = next((int(np.prod(f.trailing(scene.record))) for f in fields
                     if f.name == "stability/multiplier_re"), 0)
        params = sum(1 for a in scene.axes if not a.name.startswith("initial."))
        table = n * (TABLE_BYTES + word + 8 * params + 16 * mult) + points * OUTCOME_BYTES
    groups = 1 + len({f.name.split("/")[0] for f in fields if "/" in f.name}) + 3
    scales = groups * (8 * sum(len(a.values) for a in scene.axes) + 4 * scene.record
                       + 4 * scene.n_ic)
    return {"runs": n * per + points, "table": table, "scales": scales,
            "scene": 2 * len(scene.text), "overhead": FILE_OVERHEAD}


def sure_file_bytes(scene: Scene) -> int:
    """Bytes the finished file takes at the very least: its per-run datasets at deflate's
    limit of compression (``RATIO_DEFLATE_LIMIT``) and the scene as run, an attribute
    stored as it is; the attractor table (whose size depends on the attractors found) and
    HDF5's own structures are not counted."""
    parts = _byte_parts(scene)
    return int(RATIO_DEFLATE_LIMIT * parts["runs"]) + len(scene.text)


# the peak memory of a sweep's process: its baseline (interpreter, numpy, numba, h5py and the
# compiled kernels: 173 MiB measured for a tiny warm sweep, benchmarks/same_output.py
# --peak-memory; and 26 MiB more at 10^6 starts since the writer is a thread of its own,
# whose allocations glibc serves from another arena) and 1.4 times the blocks of kernel
# outputs alive at once (two: one computing, one being written, cornerbif.local.BlockWriter;
# with the analysis' copies, measured at 10^6 starts by benchmarks/memory_estimate.py: at 1.3
# map2d's estimate was 1003 MiB against a peak of 996-1007)
PROCESS_BASELINE = 200 * 2**20
BLOCK_FACTOR = 1.4
BLOCKS_IN_FLIGHT = 2


def estimate_memory(scene: Scene) -> int:
    """Upper estimate of the sweep's peak memory (the whole process): its baseline, two
    blocks of kernel outputs (each bounded by BLOCK_BYTES, but never less than one grid point
    with all its starts) times BLOCK_FACTOR, and what grows with the grid (the done mask and the
    block list, ~200 bytes a grid row)."""
    points = int(np.prod(scene.shape or (1,)))
    per_item = engine.item_bytes(scene)
    per_point = per_item * scene.n_ic
    most = max(1, engine.block_points_max(scene))
    block = per_point * min(points, most)
    in_flight = min(BLOCKS_IN_FLIGHT, -(-points // most))
    rows = points if len(scene.shape) < 2 else scene.shape[0] * max(1, scene.shape[1] // most)
    return int(PROCESS_BASELINE + BLOCK_FACTOR * in_flight * block) + points + 200 * rows


# writing the file (shuffle and deflate of whole chunks by ISA-L, cornerbif.chunkwrite): about
# 1.3 GB of uncompressed data a second of the writer thread's CPU on this machine (93 MB of a
# Fig. 4(c)-like sweep in 73 ms); the estimate keeps 400 MB/s, an upper bound
# for slower disks and the per-block costs of small blocks
WRITE_BYTES_PER_SECOND = 400e6


def estimate_seconds(scene: Scene, threads: int) -> float:
    """Time of the sweep on ``threads`` cores, in seconds: the middle of ``estimate_time``."""
    return estimate_time(scene, threads).seconds


# grid points the time model reads at most (evenly spread over the grid, both ends included)
ESTIMATE_SAMPLES = 64
# seconds of one core per run beside its kernel (its start drawn, its cycle analysed, its
# rows handed to the writer): fig09_map's 20000 runs of 2 map steps took 0.06 s of CPU on two
# threads (benchmarks/estimate_time.py)
RUN_OVERHEAD = 3e-6


class Estimate(NamedTuple):
    """A sweep's time: ``seconds`` the middle, ``low`` .. ``high`` the range it may take, and
    ``reasons`` why the range is wide (empty: the model is close, within a few tens of per cent
    on this machine, benchmarks/estimate_time.py)."""

    seconds: float
    low: float
    high: float
    reasons: tuple


def estimate_time(scene: Scene, threads: int) -> Estimate:
    """The sweep's time on ``threads`` cores: the kernels by the model's time model of a run
    (``Model.run_seconds``: per impact and per obstacle piece or section period crossed,
    measured on this machine) over up to ESTIMATE_SAMPLES grid points, RUN_OVERHEAD a run
    beside the kernel, and the writer at WRITE_BYTES_PER_SECOND (as if it did not run beside
    them: an upper bound).  Runs spread over the threads, but a sweep takes at least its
    slowest run.  A model without a time model runs at its measured ``events_per_second``
    per impact."""
    spec = scene.spec
    runs = int(np.prod(scene.shape or (1,))) * scene.n_ic
    threads = max(1, int(threads))
    model = getattr(spec, "run_seconds", None)
    if model is None:
        per = (scene.transient + scene.record) / spec.events_per_second
        costs, reasons = [(per, per, per)], []
    else:
        costs, reasons = [], []
        for idx in sample_points(scene.shape, ESTIMATE_SAMPLES):
            sec, lo, hi, why = model(scene, scene.point(idx))
            costs.append((sec, lo, hi))
            reasons += [w for w in why if w not in reasons]
    mean = np.mean(np.asarray(costs, float), axis=0) + RUN_OVERHEAD
    top = np.max(np.asarray(costs, float), axis=0)
    write = estimate_bytes(scene) / WRITE_BYTES_PER_SECOND
    sec, lo, hi = (float(max(runs * m / threads, t) + write) for m, t in zip(mean, top))
    return Estimate(sec, lo, hi, tuple(reasons))


def sample_points(shape, most):
    """Up to ``most`` grid indices evenly spread over a grid of ``shape`` (row-major order, the
    first and the last included)."""
    n = int(np.prod(shape or (1,)))
    flat = np.unique(np.linspace(0, n - 1, min(n, most)).round().astype(np.int64))
    return [tuple(int(i) for i in np.unravel_index(f, shape)) if shape else () for f in flat]


def estimate_words(est: Estimate) -> str:
    """An estimate in words: 'about 3.5 min', or with its range and reasons when it is
    uncertain: 'about 3.5 min, uncertain: 1.2 min to 10.5 min (runs escape ...)'."""
    text = about(est.seconds)
    if est.reasons and est.high > 1.5 * est.low:
        text += (f", uncertain: {duration(est.low)} to {duration(est.high)} "
                 f"({'; '.join(est.reasons)})")
    return text


YEAR = 365.25 * 86400


def about(seconds: float) -> str:
    """An estimated duration in words: 'about 3.5 min', or 'more than a thousand years'."""
    words = duration(seconds)
    return words if words.startswith("more than") else f"about {words}"


def duration(seconds: float) -> str:
    """A duration in words: '0.4 s', '12 min', '3.2 h', '41 days', '3.1 years'; past a
    thousand years (or not finite: an estimate of a sweep that cannot end) 'more than a
    thousand years'."""
    if not seconds < 1000 * YEAR:
        return "more than a thousand years"
    for unit, size in (("years", YEAR), ("days", 86400), ("h", 3600), ("min", 60)):
        if seconds >= 2 * size:
            return f"{seconds / size:.1f} {unit}"
    return f"{seconds:.1f} s"


# what a file takes on disk against ``estimate_bytes`` (its size before compression): on the
# 47 shipped scenes' files, from 0.023 (basin_maps) to 0.49 (fig01b, a one-point file),
# median 0.15 (the sweeps of configs/*.toml: file size / estimate_bytes)
RATIO_MEASURED = (0.02, 0.15, 0.5)
# deflate's limit: a stream never holds more than about 1032 bytes per byte stored, so no file
# is smaller than this share of its data (the one refusal that is sure to be true)
RATIO_DEFLATE_LIMIT = 1.0 / 1032


def estimate_file_bytes(scene: Scene, written=None) -> tuple:
    """(low, typical, high) bytes the finished file will take on disk: the bound
    ``estimate_bytes`` times the compression ratios measured on the shipped scenes
    (``RATIO_MEASURED``), or, when ``written`` = (file bytes, share of the grid done) comes
    from a partial file, its own ratio so far (low = typical = high)."""
    bound = estimate_bytes(scene)
    if written is not None and written[1] > 0:
        size, share = written
        guess = int(FILE_OVERHEAD + max(size - FILE_OVERHEAD, 0) / share)
        return guess, guess, guess
    return tuple(int(FILE_OVERHEAD + r * (bound - FILE_OVERHEAD)) for r in RATIO_MEASURED)
