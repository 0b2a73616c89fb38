"""Run a scene to its HDF5 file: the orchestration of engine, backend and file.

``run_sweep`` takes the output's lock, checks the budget (disk and memory, before
any work), opens or resumes the partial file (``cornerbif.io``), runs the blocks on
a backend (``cornerbif.local`` here, ``cornerbif.distributed`` on Dask; both call
``engine.compute_block``) and finishes the file.  Each block is marked done in the
file once its data are flushed, so an interrupted sweep resumes where it stopped.
"""

from __future__ import annotations

import fcntl
import os

import numpy as np

from . import engine, io, outputs, registry
from .config import Scene, same_run
from .errors import SweepError, SweepInterrupted, WriteFailed
from .outputs import check_directory, is_cornerbif_file  # noqa: F401 - the sweep's names

__all__ = ["run_sweep", "check_budget", "estimate_bytes", "estimate_memory", "simulate",
           "SweepError", "SweepInterrupted"]

# bytes per run of the per-run summary: status (1), period and impacts per cycle (4 + 4)
SUMMARY_BYTES = 1 + 4 + 4


def estimate_bytes(scene: Scene) -> int:
    """Upper estimate of the output file size (uncompressed)."""
    spec = registry.get(scene.model)
    n = int(np.prod(scene.shape or (1,))) * scene.n_ic
    per = 2 * 8 * len(spec.state) + SUMMARY_BYTES + max(1, scene.record // 2)
    per += sum(np.dtype(f.dtype).itemsize * int(np.prod(f.trailing(scene.record)))
               for f in spec.fields(scene.keep))
    return n * per


# the peak memory of a sweep's process: its baseline (interpreter, numpy, numba, h5py and the
# compiled kernels: 173 MiB measured for a tiny warm sweep, benchmarks/same_output.py
# --peak-memory; and 26 MiB more at 10^6 starts since the writer is a thread of its own,
# whose allocations glibc serves from another arena) and 1.3 times the blocks of kernel
# outputs alive at once (two: one computing, one being written, cornerbif.local.BlockWriter;
# with the analysis' copies, measured at 10^6 starts by benchmarks/memory_estimate.py)
PROCESS_BASELINE = 200 * 2**20
BLOCK_FACTOR = 1.3
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
    """Time of the sweep on ``threads`` cores: the kernels at the model's measured events per
    second (an upper bound for scenes that stop early, ``run.stop = "period"``) and the
    writer at WRITE_BYTES_PER_SECOND (as if it did not run beside them: an upper bound)."""
    spec = registry.get(scene.model)
    items = int(np.prod(scene.shape or (1,))) * scene.n_ic
    compute = items * (scene.transient + scene.record) / (spec.events_per_second
                                                          * max(1, threads))
    return compute + estimate_bytes(scene) / WRITE_BYTES_PER_SECOND


def duration(seconds: float) -> str:
    """A duration in words: '0.4 s', '12 min', '3.2 h', '41 days'."""
    for unit, size in (("days", 86400), ("h", 3600), ("min", 60)):
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


def _free_bytes(d):
    try:
        st = os.statvfs(d)
        return st.f_bavail * st.f_frsize
    except OSError:
        return None


def check_budget(scene: Scene, out_path: str):
    """Refuse, before any work, a grid whose output would not fit the disk or whose working
    memory would not fit the machine; the message gives the estimate."""
    free = _free_bytes(os.path.dirname(os.path.abspath(out_path)))
    need = estimate_bytes(scene)
    if free is not None and need > free:
        raise SweepError(f"the output needs up to {need / 2**30:.2f} GiB but only "
                         f"{free / 2**30:.2f} GiB are free on its disk; shrink the grid or "
                         "keep less (output.keep)")
    avail = io.available_memory()
    mem = estimate_memory(scene)
    if avail is not None and mem > avail:
        raise SweepError(f"the sweep needs about {mem / 2**30:.2f} GiB of memory but only "
                         f"{avail / 2**30:.2f} GiB are available; shrink the grid")


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
    lock_path = out_path + ".lock"
    if resume and not overwrite and _finished(scene, out_path, partial, inputs, echo):
        return None
    check_output(out_path, overwrite, inputs)
    lock = open(lock_path, "w")
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        lock.close()
        raise SweepError(f"{out_path}: another sweep is writing this output (lock {lock_path} "
                         "is held)") from None
    try:
        with _NumbaThreads(None if scheduler else threads):
            _sweep_locked(scene, out_path, partial, threads, resume, overwrite, progress,
                          command, block_points, scheduler, stats)
        return out_path
    finally:
        fcntl.flock(lock, fcntl.LOCK_UN)
        lock.close()
        try:
            os.remove(lock_path)
        except OSError:
            pass


def _finished(scene, out_path, partial, inputs, echo) -> bool:
    """``--resume`` on an output that exists: True (and say so) when it is a finished sweep
    of this scene (``[plot]`` aside), so that a script may always pass ``--resume``; a
    finished file of another scene, or any other file, is refused (never replaced)."""
    check_directory(out_path)
    if not os.path.exists(out_path) or os.path.isdir(out_path):
        return False
    outputs.check_output(out_path, True, [("the scene file", p) for p in inputs], kind="sweep")
    try:
        with io.check_readable(out_path) as f:
            text = str(f.attrs.get("scene", ""))
            completed = str(f.attrs.get("completed", ""))
    except io.FileFormatError as e:
        raise SweepError(f"{out_path} exists and cannot be resumed ({e}); pass --overwrite "
                         "to replace it") from None
    if not completed:
        return False
    if not same_run(text, scene.text):
        raise SweepError(f"{out_path} is a finished sweep of another scene; --resume completes "
                         "only this scene's sweep: pass --overwrite to replace it, or name "
                         "another output")
    if os.path.exists(partial):
        io.remove_stale(partial)   # killed between the finished file's rename and this removal
    if echo is not None:
        echo(f"{out_path} is already complete (finished {completed} from this scene); nothing "
             "to do")
    return True


def _sweep_locked(scene, out_path, partial, threads, resume, overwrite, progress, command,
                  block_points, scheduler, stats):
    f = None
    if os.path.exists(partial):
        if resume:
            f = io.reopen(partial, scene)
        elif overwrite:
            os.remove(partial)
        else:
            raise SweepError(f"{partial} holds an interrupted sweep; pass --resume to "
                             "complete it or --overwrite to start again")
    if f is None:
        check_budget(scene, out_path)
        try:
            f = io.open_partial(partial, scene, command)
        except OSError as e:
            raise WriteFailed(f"creating {partial} failed ({io.reason(e)}); nothing was "
                              "computed; free space and run the same command again",
                              broken=True) from None
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
        f.close()
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
