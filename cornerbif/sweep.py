"""Run a scene to its HDF5 file: the orchestration of engine, backend and file.

``run_sweep`` takes the output's lock, checks the budget (disk and memory, before
any work), opens or resumes the partial file (``cornerbif.io``), runs the blocks on
a backend (``cornerbif.local`` here, ``cornerbif.distributed`` on Dask; both call
``engine.compute_block``) and finishes the file.  Each block is marked done in the
file once its data are flushed, so an interrupted sweep resumes where it stopped.
"""

from __future__ import annotations

import os

import numpy as np

from . import io, outputs
from .api import simulate as _simulate
from .config import Scene, same_run
from .errors import EXIT_INPUT, SweepError, SweepInterrupted, WriteFailed
from .estimate import estimate_file_bytes, estimate_memory, sure_file_bytes
from .outputs import check_directory

__all__ = ["run_sweep", "check_budget", "simulate", "SweepError", "SweepInterrupted"]




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
        import numba  # start-up: loads numba
        self.before = numba.get_num_threads()
        if self.threads:
            numba.set_num_threads(int(self.threads))

    def __exit__(self, *exc):
        import numba  # start-up: loads numba
        numba.set_num_threads(self.before)


def run_sweep(scene: Scene, out_path: str, threads: int | None = None, resume: bool = False,
              overwrite: bool = False, progress: bool = False, command: str = "",
              block_points: int | None = None, scheduler: str | None = None,
              stats: dict | None = None, inputs=(), echo=None, cancel=None) -> str | None:
    """Run a scene to ``out_path``; return the path of the finished file, or None when
    ``resume`` finds it already finished from this scene (``echo``, a function of one
    line, is told so; the file is left as it is).

    ``scheduler``: None runs the blocks here (numba threads); a Dask scheduler address
    or ``local:N`` runs them on a Dask cluster (``cornerbif.distributed``), with this
    process the only writer of the file either way.  ``threads`` is then the numba
    threads of each worker; ``stats`` (a dict) receives what the Dask backend did
    (chunks submitted, failures, compute seconds per chunk).  ``inputs``: files the
    output must not replace (the scene file).  ``cancel`` (a ``threading.Event``, local
    blocks only): once set, the sweep stops as on Ctrl-C (the block computing is dropped,
    the finished ones are kept in the partial file) and ``SweepInterrupted`` is raised; a
    caller running the sweep in a thread of its own stops it so (``cornerbif explore``'s
    refine).
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
                          command, block_points, scheduler, stats, echo, cancel)
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
                  block_points, scheduler, stats, echo=None, cancel=None):
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
            from .distributed import run_blocks_dask  # start-up: loads numba
            run_blocks_dask(scene, f, scheduler, progress=progress, block_points=block_points,
                            numba_threads=threads, stats=stats)
        else:
            from .local import run_blocks  # start-up: loads numba
            run_blocks(scene, f, progress, block_points, cancel)
    except SweepError as e:
        if getattr(e, "broken", False):
            raise                      # HDF5 failed inside a write: the file is left as it is
        nothing = created and not np.any(f["done"][...])
        f.close()
        if nothing and e.exit_code == EXIT_INPUT:
            outputs.remove_quietly(partial)   # refused before a point was done (an unreachable
            raise                      # --scheduler): no partial file of this run is left
        # a fault (a full disk, a file-size limit, chunks failed on a cluster) keeps the
        # partial file, even before its first point: its message sends the user to --resume
        if getattr(e, "failures", None):
            io.record_failures(partial, e.failures)
        if nothing and isinstance(e, WriteFailed):
            raise WriteFailed(f"{e} (no point was finished yet: {partial} holds the scene "
                              "and its grid)") from None
        raise
    except KeyboardInterrupt:
        none = created and not np.any(f["done"][...])
        f.close()
        raise SweepInterrupted(f"interrupted; finished points are kept in {partial}"
                               + (" (none was finished yet: it holds the scene and its grid)"
                                  if none else "")
                               + "; run again with --resume to complete it") from None
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
    """``cornerbif.simulate(*starts, **kw)`` (the default model, ``registry.DEFAULT_MODEL``)."""
    return _simulate(*starts, **kw)
