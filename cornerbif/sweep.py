"""Run a scene to its HDF5 file: the orchestration of engine, backend and file.

``run_sweep`` takes the output's lock, checks the budget (disk and memory, before
any work), opens or resumes the partial file (``cornerbif.io``), runs the blocks on
a backend (``cornerbif.local`` here, ``cornerbif.distributed`` on Dask; both call
``engine.compute_block``) and finishes the file.  Each block is marked done in the
file once its data are flushed, so an interrupted sweep resumes where it stopped.
"""

from __future__ import annotations

import os
from typing import NamedTuple

import numpy as np

from . import engine, io, outputs, registry
from .config import Scene, same_run
from .errors import SweepError, SweepInterrupted, WriteFailed
from .outputs import check_directory

__all__ = ["run_sweep", "check_budget", "estimate_bytes", "estimate_memory", "simulate",
           "SweepError", "SweepInterrupted"]

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
    spec = registry.get(scene.model)
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
# Fig. 4(c)-like sweep in 73 ms, 2026-11-24); the estimate keeps 400 MB/s, an upper bound
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
    spec = registry.get(scene.model)
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


DEFAULT_NAME_MAX = 100


def default_output(scene: Scene) -> str:
    """The default output ``NAME.h5`` for a scene, in the working directory: the last path
    component of ``scene.name``, other characters than letters, digits, '.', '_' and '-'
    replaced by '_', no leading dot, at most 100 characters (a name such as ``../x`` or
    ``/etc/x`` cannot place the file elsewhere)."""
    import re
    base = os.path.basename(scene.name.replace("\\", "/").rstrip("/"))
    base = re.sub(r"[^A-Za-z0-9._-]", "_", base).lstrip(".")[:DEFAULT_NAME_MAX]
    return (base or "scene") + ".h5"


def check_output(out_path: str, overwrite: bool, inputs=()):
    """Refuse, before any work, an output the sweep could not write or should not replace
    (``outputs.check_output``, the guard every command shares): a missing or read-only
    directory, a name too long for the filesystem (with the ``.partial.rebuild`` suffix a
    sweep may need), the scene file itself (or another input), an existing file without
    ``--overwrite``, or an existing file that is not a cornerbif sweep file."""
    outputs.check_output(out_path, overwrite, [("the scene file", p) for p in inputs],
                         kind="sweep")


# the room on the output's disk and under ``ulimit -f`` (io's, the one place; names of their
# own here, which tests replace)
_free_bytes = io.free_space
_size_limit = io.size_limit


# what a file takes on disk against ``estimate_bytes`` (its size before compression): on the
# 47 shipped scenes' files, from 0.023 (basin_maps) to 0.49 (fig01b, a one-point file),
# median 0.15 (2026-11-27; the sweeps of configs/*.toml, file size / estimate_bytes)
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


def check_budget(scene: Scene, out_path: str, written=None) -> list:
    """Refuse, before any work, a grid whose output cannot fit the disk or whose working
    memory would not fit the machine (the message gives the estimate); return notes for the
    user when the output may not fit (a full disk then stops the sweep, every finished point
    kept, and --resume completes it: nothing is lost by starting).

    The disk holds the file and, while the file is finished, a copy of it (``io._amend``);
    the file-size limit (``ulimit -f``) holds one file.  The refusal is sure to be true: it
    counts the file at its least (``sure_file_bytes``), and on a resume (``written`` =
    (bytes of the partial file, share of the grid done)) at least at the size it has; the
    notes count the ratios measured on the shipped scenes, or on a resume the ratio of what
    is written."""
    free = _free_bytes(os.path.dirname(os.path.abspath(out_path)))
    limit = _size_limit()
    have = 0 if written is None else written[0]
    sure = max(sure_file_bytes(scene), have)
    low, typical, high = estimate_file_bytes(scene, written)
    notes = []
    for room, need, likely, where in ((free, 2 * sure - have, 2 * high - have, "free on its disk"),
                                      (limit, sure, high, "allowed per file (ulimit -f)")):
        if room is None:
            continue
        if need > room:
            raise SweepError(f"the output needs at least {_mib(sure)}"
                             + (" on its disk (and as much again for its copy when it is "
                                "finished)" if where.startswith("free") else "")
                             + f" but only {_mib(room)} are {where}; "
                             + ("free space (or raise the limit) and run the same command "
                                "again: the finished points are kept in the partial file"
                                if written is not None else
                                "shrink the grid or keep less (output.keep)"))
        if likely > room and not notes:
            how = (f"about {_mib(typical)}, at the compression of the points written so far"
                   if written else f"{_mib(low)} to {_mib(high)}, typically {_mib(typical)} (the "
                   "compression ratios measured on the shipped scenes)")
            notes.append(f"the output may not fit: it will take {how}"
                         + (", and as much again for its copy when it is finished"
                            if where.startswith("free") else "")
                         + f"; {_mib(room)} are {where}. A full disk stops the sweep with every "
                         "finished point kept: free space and run the same command with "
                         "--resume")
    avail = io.available_memory()
    mem = estimate_memory(scene)
    if avail is not None and mem > avail:
        raise SweepError(f"the sweep needs about {mem / 2**30:.2f} GiB of memory but only "
                         f"{avail / 2**30:.2f} GiB are available (free memory, or what the "
                         "address-space limit, ulimit -v, leaves); shrink the grid")
    return notes


def _mib(n) -> str:
    """A size in words: '812 KiB', '31.4 MiB', '2.15 GiB'."""
    if n >= 2**30:
        return f"{n / 2**30:.2f} GiB"
    return f"{n / 2**20:.1f} MiB" if n >= 2**20 else f"{max(n, 0) / 2**10:.0f} KiB"


class _NumbaThreads:
    """Set numba's thread count for the sweep and restore it afterwards."""

    def __init__(self, threads):
        self.threads = threads

    def __enter__(self):
        import numba
        self.before = numba.get_num_threads()
        if self.threads:
            numba.set_num_threads(int(self.threads))

    def __exit__(self, *exc):
        import numba
        numba.set_num_threads(self.before)


def run_sweep(scene: Scene, out_path: str, threads: int | None = None, resume: bool = False,
              overwrite: bool = False, progress: bool = False, command: str = "",
              block_points: int | None = None, scheduler: str | None = None,
              stats: dict | None = None, inputs=(), echo=None) -> str | None:
    """Run a scene to ``out_path``; return the path of the finished file, or None when
    ``resume`` finds it already finished from this scene (``echo``, a function of one
    line, is told so; the file is left as it is).

    ``scheduler``: None runs the blocks here (numba threads); a Dask scheduler address
    or ``local:N`` runs them on a Dask cluster (``cornerbif.distributed``), with this
    process the only writer of the file either way.  ``threads`` is then the numba
    threads of each worker; ``stats`` (a dict) receives what the Dask backend did
    (chunks submitted, failures, compute seconds per chunk).  ``inputs``: files the
    output must not replace (the scene file).
    """
    partial = out_path + ".partial"
    d = check_directory(out_path)
    outputs.check_name_length(out_path, d)
    outputs.check_side_files(out_path, [("the scene file", p) for p in inputs])
    # the lock first: a sweep still finishing this output is "another sweep", not a
    # finished file
    with outputs.output_lock(out_path, "sweep"):
        if plan_output(scene, out_path, resume, overwrite, inputs, locked=True) == "done":
            if io.partial_scene(partial) is not None and same_run(io.partial_scene(partial),
                                                                  scene.text):
                io.remove_stale(partial)  # killed between the finished file's rename and this
            if echo is not None:
                echo(f"{out_path} is already complete (finished from this scene); nothing to do")
            return None
        with _NumbaThreads(None if scheduler else threads):
            _sweep_locked(scene, out_path, partial, threads, resume, overwrite, progress,
                          command, block_points, scheduler, stats, echo)
        return out_path


def plan_output(scene: Scene, out_path: str, resume: bool, overwrite: bool, inputs=(),
                locked: bool = False) -> str:
    """What a sweep will do with its output, decided before any work (and by ``--dry-run``):
    "done" (``--resume`` of an output finished from this scene, ``[plot]`` aside: nothing
    to do, so that a script may always pass ``--resume``), "resume" (a partial file of this
    scene to complete) or "start"; raises ``SweepError`` for what it must refuse: an output
    or a partial file of another scene (naming what differs, and never replaced without
    ``--overwrite``), an input, a file of another kind, an output another sweep is writing
    (unless ``locked``: this process holds the lock)."""
    if not locked:
        outputs.check_unlocked(out_path, "sweep")
    partial = out_path + ".partial"
    named = [("the scene file", p) for p in inputs]
    outputs.check_side_files(out_path, named)
    state, theirs = io.partial_state(partial)
    if state == "foreign":
        raise SweepError(f"{partial}: is in the way and is not a cornerbif sweep's partial file "
                         "(remove it yourself, or name another output)")
    if state == "damaged":
        if resume or not overwrite:
            raise SweepError(f"{partial}: holds a sweep that cannot be read (cut short); pass "
                             "--overwrite (without --resume) to start again")
        return "start"
    mine = theirs is not None and same_run(theirs, scene.text)
    if resume and not overwrite and os.path.lexists(out_path):
        outputs.check_output(out_path, True, named, kind="sweep")
        try:
            with io.check_readable(out_path) as f:
                text = str(f.attrs.get("scene", ""))
                completed = str(f.attrs.get("completed", ""))
        except io.FileFormatError as e:
            raise SweepError(f"{out_path} exists and cannot be resumed ({e}); pass --overwrite "
                             "to replace it") from None
        if completed and same_run(text, scene.text):
            return "done"
        if mine:
            raise SweepError(f"{out_path} is a finished sweep of another scene and {partial} "
                             "holds an interrupted sweep of this one: pass --resume --overwrite "
                             f"to complete it (it then replaces {out_path}), or name another "
                             "output")
        raise SweepError(f"{out_path} is a finished sweep of another scene"
                         f"{io.scene_difference(text, scene.text)}; --resume completes only "
                         "this scene's sweep: pass --overwrite to replace it, or name another "
                         "output")
    check_output(out_path, overwrite, inputs)
    if theirs is None:
        return "start"
    if resume:
        if not mine:
            raise SweepError(f"{partial}: the scene differs from the one this file was started "
                             f"with{io.scene_difference(theirs, scene.text)}; --resume needs the "
                             "same scene ([plot] aside), or --overwrite to start again")
        return "resume"
    if overwrite:
        return "start"
    raise SweepError(f"{partial} holds an interrupted sweep; pass --resume to complete it or "
                     "--overwrite to start again")


def _sweep_locked(scene, out_path, partial, threads, resume, overwrite, progress, command,
                  block_points, scheduler, stats, echo=None):
    f = None
    notes = []
    created = False                    # the partial file is this run's (nothing in it yet)
    if os.path.exists(partial):
        if resume:
            f = io.reopen(partial, scene)
            try:
                done = f["done"][...]
                share = float(np.count_nonzero(done)) / max(1, done.size)
                notes = check_budget(scene, out_path, (f.id.get_filesize(), share))
            except SweepError:
                f.close()
                raise
        elif overwrite:
            os.remove(partial)
        else:
            raise SweepError(f"{partial} holds an interrupted sweep; pass --resume to "
                             "complete it or --overwrite to start again")
    if f is None:
        notes = check_budget(scene, out_path)
        try:
            f = io.open_partial(partial, scene, command)
        except OSError as e:
            if e.errno is not None and e.errno not in outputs.SPACE_ERRNOS:
                raise SweepError(f"{partial}: cannot be created ({io.reason(e)}); nothing "
                                 "was computed") from None
            raise WriteFailed(f"creating {partial} failed ({io.reason(e)}); nothing was "
                              "computed; free space and run the same command again",
                              broken=True) from None
        created = True
    for note in notes:
        if echo is not None:
            echo(f"note: {note}")
    io.watch_room(f, echo)
    try:
        if scheduler:
            from .distributed import run_blocks_dask
            run_blocks_dask(scene, f, scheduler, progress=progress, block_points=block_points,
                            numba_threads=threads, stats=stats)
        else:
            from .local import run_blocks
            run_blocks(scene, f, progress, block_points)
    except SweepError as e:
        if getattr(e, "broken", False):
            raise                      # HDF5 failed inside a write: the file is left as it is
        nothing = created and not np.any(f["done"][...])
        f.close()
        if nothing:
            outputs.remove_quietly(partial)   # refused before a point was done (an unreachable
            raise                      # --scheduler): no partial file of this run is left
        if getattr(e, "failures", None):
            io.record_failures(partial, e.failures)
        raise
    except KeyboardInterrupt:
        f.close()
        raise SweepInterrupted(f"interrupted; finished points are kept in {partial}; "
                               "run again with --resume to complete it") from None
    except OSError as e:
        # a write failed inside HDF5 (a disk filled by someone else between our check and
        # the write, an I/O error): the file on disk is as it was after the last block
        # marked done (single-writer/multiple-reader flush order), but this process's HDF5
        # state is not, so the file is not closed (closing would flush into the error)
        raise WriteFailed(f"writing {partial} failed ({io.reason(e)}); every finished point "
                          "is kept; free space and run the same command with --resume",
                          broken=True) from None
    f.close()
    try:
        io.finish(partial, out_path, scene)
    except KeyboardInterrupt:
        if os.path.exists(out_path) and not os.path.exists(partial):
            outputs.note_late_interrupt()   # the file was whole: it is done
            return
        raise SweepInterrupted(f"interrupted while the finished file was stamped; every point "
                               f"is kept in {partial}; run again with --resume to finish it"
                               ) from None
    except OSError as e:
        raise WriteFailed(f"finishing {partial} failed ({io.reason(e)}); every point is kept; "
                          "free space and run the same command with --resume") from None


def simulate(*starts, **kw):
    """The ``flow`` model from Python: ``cornerbif.simulate(*starts, model="flow", **kw)``."""
    from .api import simulate as _simulate
    kw.setdefault("model", "flow")
    return _simulate(*starts, **kw)
