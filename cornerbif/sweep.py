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

from . import engine, io, registry
from .config import Scene
from .errors import SweepError, SweepInterrupted, WriteFailed

__all__ = ["run_sweep", "check_budget", "estimate_bytes", "estimate_memory", "simulate",
           "SweepError", "SweepInterrupted"]

# bytes per run of the per-run summary: status (1), period and impacts per cycle (4 + 4)
SUMMARY_BYTES = 1 + 4 + 4


def estimate_bytes(scene: Scene) -> int:
    """Upper estimate of the output file size (uncompressed)."""
    spec = registry.get(scene.model)
    n = int(np.prod(scene.shape or (1,))) * scene.n_ic
    per = 2 * 8 * len(spec.state) + SUMMARY_BYTES + max(1, scene.record // 2)
    per += 8 * scene.record * len(spec.fields(scene.keep))
    return n * per


def estimate_memory(scene: Scene) -> int:
    """Upper estimate of the sweep's working memory: one block of kernel outputs (bounded
    by BLOCK_BYTES, twice for the copies the writer makes) plus what grows with the grid
    (the done mask and the block list, ~200 bytes a grid row)."""
    points = int(np.prod(scene.shape or (1,)))
    per_item = engine.item_bytes(scene)
    block = min(engine.BLOCK_BYTES, per_item * scene.n_ic * points)
    rows = points if len(scene.shape) < 2 else scene.shape[0] * max(1, scene.shape[1] // max(
        1, engine.BLOCK_BYTES // (per_item * scene.n_ic)))
    return 3 * block + points + 200 * rows


def _available_memory():
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


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
    avail = _available_memory()
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
              stats: dict | None = None) -> str:
    """Run a scene to ``out_path``; return the path of the finished file.

    ``scheduler``: None runs the blocks here (numba threads); a Dask scheduler address
    or ``local:N`` runs them on a Dask cluster (``cornerbif.distributed``), with this
    process the only writer of the file either way.  ``threads`` is then the numba
    threads of each worker; ``stats`` (a dict) receives what the Dask backend did
    (chunks submitted, failures, compute seconds per chunk).
    """
    partial = out_path + ".partial"
    lock_path = out_path + ".lock"
    if os.path.exists(out_path) and not overwrite:
        raise SweepError(f"{out_path} exists; pass --overwrite to replace it")
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
        io.finish(partial, out_path)
    except OSError as e:
        raise WriteFailed(f"finishing {partial} failed ({io.reason(e)}); every point is kept; "
                          "free space and run the same command with --resume") from None


def simulate(*starts, **kw):
    """The ``flow`` model from Python: ``cornerbif.simulate(*starts, model="flow", **kw)``."""
    from .api import simulate as _simulate
    return _simulate(*starts, model="flow", **kw)
