"""The local backend: the sweep's blocks computed in this process (numba threads).

Every unfinished block of the file in execution order goes through
``engine.compute_block`` in a thread of its own (``compute_blocks``), and one writer thread
(``BlockWriter``, the file's single writer) writes the finished blocks through
``io.write_pending`` while the next ones compute: the kernels release the GIL, so the
file's compression runs beside them instead of after them.  The calling (main) thread
waits, shows the progress and answers Ctrl-C and SIGTERM at once (``run_blocks``); what
was handed to the writer is written whatever signal comes meanwhile (``BlockWriter.close``).
A followed sweep carries each slab's final states to the next.  The Dask backend
(``cornerbif.distributed``) runs the same blocks on a cluster.
"""

from __future__ import annotations

import atexit
import math
import os
import sys
import threading
import time

from . import engine, io, outputs
from ._jit import Control, KernelStopped
from .errors import EXIT_FAULT, EXIT_INTERRUPTED
from .estimate import about, duration, estimate_seconds

FOLLOW_BATCH = 256   # followed slabs written together at most
# seconds the main thread waits at a time while the blocks compute (the progress bar's
# tick); Ctrl-C and SIGTERM end the wait at once (Python runs signal handlers in the main
# thread only, which is why the blocks compute in another)
WAIT = 0.05
# after Ctrl-C, seconds the blocks' thread gets to see the stop flag and return (its kernels
# read the flag every few thousand loop passes: milliseconds); a thread still busy after that
# (numba compiling a kernel on its first call, which nothing can cut short) is left behind,
# its block unwritten, and the process ends without it (``_left_behind``)
STOP_GRACE = 1.0
# items a numba thread takes at a time from a block (dynamic scheduling): the writer thread
# takes a core from the kernels' threads now and then, and with the default static split
# the whole block waits for the thread it slowed
PARALLEL_CHUNK = 16


class Progress:
    """The sweep's progress on stderr, counted in runs (grid points x starts): runs done of
    all, their rate, and the time left, e.g. ``sweep fig06a: 5120/16008 runs (32 %), 410
    runs/s, about 27 s left``.

    ``update(done)`` is called by the waiting main thread a few times a second
    (``run_blocks``: the kernels count finished runs into the sweep's control while a block
    computes), so a one-block sweep shows progress too.  The rate is that of this session's
    runs; before the first run has finished the time left is the estimate
    (``estimate.estimate_seconds``), said as such.  On a terminal the line is redrawn at most
    every ``REDRAW`` seconds; elsewhere a line is written every ``LOG_EVERY`` seconds.
    ``clock``: the seconds it reads (``time.monotonic``)."""

    REDRAW = 0.25
    LOG_EVERY = 10.0

    def __init__(self, scene, total, already=0, estimate=None, stream=None,
                 clock=time.monotonic):
        self.label = f"sweep {scene.name}"
        self.total = int(total)
        self.already = int(already)
        self.done = int(already)
        self.estimate = estimate
        self.stream = stream if stream is not None else sys.stderr
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self.clock = clock
        self.start = clock()
        self.shown = -math.inf
        self.width = 0
        self.update(self.done, force=True)

    def line(self) -> str:
        now = self.clock() - self.start
        new = self.done - self.already
        text = f"{self.label}: {self.done}/{self.total} runs"
        if self.total:
            text += f" ({100.0 * self.done / self.total:.0f} %)"
        left = self.total - self.done
        if left <= 0:
            return text + f", {duration(now)}"
        if new > 0 and now > 0:
            rate = new / now
            text += f", {_rate(rate)} runs/s, {about(left / rate)} left"
        elif self.estimate is not None:
            text += (f", no run finished yet ({duration(now)}); the estimate is "
                     f"{duration(self.estimate)} in all")
        return text

    def update(self, done, force=False):
        """Show ``done`` runs (of all, finished ones included) if it is time to."""
        self.done = max(self.done, min(int(done), self.total))
        now = self.clock()
        if not force and now - self.shown < (self.REDRAW if self.tty else self.LOG_EVERY):
            return
        self.shown = now
        text = self.line()
        try:
            if self.tty:
                self.stream.write("\r" + text.ljust(self.width))
                self.width = len(text)
            else:
                self.stream.write(text + "\n")
            self.stream.flush()
        except (OSError, ValueError):      # a closed or broken stderr: no progress, no error
            pass

    def close(self):
        self.update(self.done, force=True)
        if self.tty:
            try:
                self.stream.write("\n")
                self.stream.flush()
            except (OSError, ValueError):
                pass


def _rate(x):
    return f"{x:.3g}" if x < 1000 else f"{x:.0f}"


def block_runs(scene, blk) -> int:
    """The runs of a grid slab: its grid points times the starts."""
    n = scene.n_ic
    for s in blk:
        n *= s.stop - s.start
    return n


def carry_from_file(scene, f, every, first_todo):
    """On resume of a followed sweep: the final states of the slab before ``first_todo``."""
    i = every.index(first_todo)
    if i == 0:
        return None
    return engine.block_carry(scene, io.read_block(f, every[i - 1], engine.carry_names(scene)))


def block_nbytes(block):
    """Bytes of a computed block's arrays."""
    return sum(a.nbytes for a in block.values())


class BlockWriter:
    """The file's one writer while blocks compute: a thread that writes finished blocks,
    in the order they were handed over, while the caller computes the next.

    Memory stays bounded: ``wait_for_room`` lets the caller start a block only while the
    blocks waiting to be written take less than ``engine.BLOCK_BYTES`` together with it
    (a full-size block thus waits until the writer has taken the one before: one block
    is written while the next computes, never more).  Thin followed slabs queue up to
    that size and are written together (``batch``, FOLLOW_BATCH, in one write at most):
    writing each alone costs more than computing it.  A write that fails stops the writer
    and tells ``control`` (the sweep's ``_jit.Control``) to stop, so the kernels computing
    the next block return at once (a full disk is said within milliseconds, not when that
    block ends); the caller gets the write's exception from the next ``wait_for_room`` or
    from ``close``, and every block marked done before it stays in the file.
    """

    def __init__(self, f, batch=1, control=None):
        self.f = f
        self.batch = batch         # blocks written together at most (FOLLOW_BATCH: thin slabs)
        self.control = control     # told to stop when a write fails
        self.queue = []            # (block index, block, bytes) handed over, not yet taken
        self.queued = 0            # their bytes
        self.closing = False
        self.error = None
        self.cv = threading.Condition()
        self.finished = threading.Event()   # the thread has ended (waited for by ``close``)
        self.thread = threading.Thread(target=self._run, name="cornerbif-writer")
        self.thread.start()

    def _run(self):
        try:
            self._write_all()
        finally:
            self.finished.set()

    def _write_all(self):
        while True:
            with self.cv:
                while not self.queue and not self.closing:
                    self.cv.wait()
                if not self.queue:
                    return
                take = self.queue[:self.batch]
                del self.queue[:self.batch]
                self.queued -= sum(n for *_, n in take)
                self.cv.notify_all()
            try:
                io.write_pending(self.f, [(index, block) for index, block, _ in take])
            except BaseException as e:  # noqa: BLE001 - handed to the caller's thread
                if self.control is not None:
                    self.control.stop()      # the block computing is dropped at once
                with self.cv:
                    self.error = e
                    self.queue.clear()
                    self.queued = 0
                    self.cv.notify_all()
                return

    def _raise(self):
        if self.error is not None:
            err, self.error = self.error, None
            raise err

    def wait_for_room(self, nbytes):
        """Block until a new block of ``nbytes`` fits beside the ones waiting to be written;
        raises the writer's error if a write failed."""
        with self.cv:
            while (self.error is None and self.queue
                   and self.queued + nbytes > engine.BLOCK_BYTES):
                self.cv.wait()
            self._raise()

    def put(self, index, block, nbytes=None):
        """Hand a finished block (of ``nbytes``, default counted here) to the writer."""
        nbytes = block_nbytes(block) if nbytes is None else nbytes
        with self.cv:
            self._raise()
            self.queue.append((index, block, nbytes))
            self.queued += nbytes
            self.cv.notify_all()

    def close(self):
        """Write every block handed over, end the thread, and raise a failed write's error.

        Called by the main thread, it waits with SIGINT and SIGTERM deferred
        (``wait_deferring_signals``): an interrupt meanwhile is remembered, the writer
        finishes what it was handed (each block computed before the signal is written and
        marked done), and the interrupt is raised then, or a failed write's error in its
        place (the file then is not to be closed normally).  Python's ``Thread.join`` cut
        short by Ctrl-C would return with the writer still writing, and the caller would
        close the file under it."""
        try:
            with outputs.signals_deferred():
                with self.cv:
                    self.closing = True
                    self.cv.notify_all()
                wait_deferring_signals(self.finished)
        finally:
            self._raise()              # the thread has ended: no lock needed


class Cancelled(KeyboardInterrupt):
    """A sweep stopped because its caller set its ``cancel`` event (``run_blocks``): handled
    as Ctrl-C is (the block computing dropped, the finished ones kept)."""


def run_blocks(scene, f, progress=False, block_points=None, cancel=None):
    """Every unfinished block of ``f`` in order, computed and written by a
    ``BlockWriter`` while the next computes.

    The blocks compute in a thread of their own (``run_interruptibly``; the kernels release
    the GIL) while this thread, the main one, waits in short steps: Python runs the handlers
    of SIGINT and SIGTERM there, so an interrupt is seen at once whatever a block costs.  It
    then sets the stop flag of the sweep's ``Control``, which the kernels read every few
    thousand loop passes: the block being computed is discarded (never written, never marked
    done), every block finished before it is written (``BlockWriter.close``, whatever signal
    comes while it writes), and the interrupt goes on to the caller (``sweep.run_sweep`` says
    what was kept).  A failed write stops the kernels the same way, and its error goes on.
    While it waits the main thread shows the progress (``Progress``) from the runs the
    kernels count into the same control.  ``cancel`` (a ``threading.Event`` or None): once
    set, the waiting thread raises ``Cancelled`` at its next step, an interrupt as above (a
    sweep run in a thread of its own, where no signal reaches it, is stopped so)."""
    ints = engine.int_settings(scene)
    every = engine.blocks(scene, block_points)
    todo = [every[i] for i in io.unfinished(every, f)]
    total = sum(block_runs(scene, b) for b in every)
    control = Control()
    ints = engine.with_control(scene, ints, control)
    carry = None  # follow: final states of the previous grid slab
    if scene.follow != "none" and todo:
        carry = carry_from_file(scene, f, every, todo[0])
    # full blocks are written one by one (each marked done as soon as it is written);
    # thin followed slabs together
    writer = BlockWriter(f, FOLLOW_BATCH if scene.follow != "none" else 1, control)
    state = {"done": total - sum(block_runs(scene, b) for b in todo), "block": 0}
    bar = tick = None
    if progress:
        import numba  # start-up: loads numba

        bar = Progress(scene, total, state["done"], estimate_seconds(scene,
                                                                      numba.get_num_threads()))

        def tick():
            bar.update(state["done"] + min(control.done, state["block"]))
    if cancel is not None:
        shown = tick

        def tick():
            if cancel.is_set():
                raise Cancelled()
            if shown is not None:
                shown()
    try:
        run_interruptibly(lambda: compute_blocks(scene, todo, carry, ints, writer, control,
                                                 state), control, tick)
    finally:
        try:
            writer.close()        # finished blocks are kept on an interrupt too
        finally:
            if bar is not None:
                bar.close()


def compute_blocks(scene, todo, carry, ints, writer, control, state):
    """The blocks' work of ``run_blocks`` (in ``run_interruptibly``'s thread): each block of
    ``todo`` through ``engine.compute_block`` (under ``control``), handed to ``writer``;
    stops before the next block, or inside one (``KernelStopped``: the block is dropped),
    once ``control`` is told to stop.  ``state`` counts the runs done for the progress."""
    import numba  # start-up: loads numba
    numba.set_parallel_chunksize(PARALLEL_CHUNK)   # per thread in numba: this one's
    last = 0
    for blk in todo:
        writer.wait_for_room(last)
        if control.stopped:
            return
        state["block"] = block_runs(scene, blk)
        control.reset()
        block = engine.compute_block(scene, blk, carry, ints)
        if control.stopped:
            return                 # computed as the flag was set: not trusted, dropped
        if scene.follow != "none":
            carry = engine.block_carry(scene, block)
        last = block_nbytes(block)
        writer.put(blk, block, last)
        state["done"] += state["block"]
        state["block"] = 0


def run_interruptibly(work, control, tick=None):
    """``work()`` in a thread of its own, its result returned, while this thread (the main
    one) waits in steps of WAIT seconds, calling ``tick()`` after each: Ctrl-C and SIGTERM
    are seen at once (Python runs signal handlers in the main thread only).  On an interrupt
    (or any exception here) ``control`` is told to stop, so the kernels that ``work`` calls
    under it (``engine.with_control``) return within milliseconds and raise
    ``KernelStopped``, which ends ``work`` quietly; after at most STOP_GRACE seconds the
    interrupt goes on (a thread still busy then is left behind: ``_left_behind``).  The
    thread runs on this thread's numba thread count.  An exception of ``work`` is raised
    here.

    Any command may run its long kernel calls so, e.g. ``cornerbif continue``: build the
    kernel's integer settings with ``engine.with_control(scene, ints, control)`` and keep
    ``control`` alive for the call."""
    import numba  # start-up: loads numba
    threads = numba.get_num_threads()
    finished = threading.Event()   # not Thread.join: in Python 3.11 a join cut short by
    box = {}                       # Ctrl-C marks the thread stopped while it still runs

    def target():
        try:
            numba.set_num_threads(threads)          # per thread in numba
            box["value"] = work()
        except KernelStopped:
            pass
        except BaseException as e:  # noqa: BLE001 - handed to the waiting thread
            box["error"] = e
        finally:
            finished.set()
    thread = threading.Thread(target=target, name="cornerbif-work", daemon=True)
    try:
        thread.start()
        while not finished.wait(WAIT):
            if tick is not None:
                tick()
    except BaseException as e:
        control.stop()              # the kernels return within milliseconds
        try:
            wait_deferring_signals(finished, STOP_GRACE)
        finally:
            if not finished.is_set():
                _left_behind(finished, e)
        raise
    if "error" in box:
        raise box["error"]
    return box.get("value")


def wait_deferring_signals(event, grace=None):
    """Wait until ``event`` is set, at most ``grace`` seconds (None: as long as it takes),
    with SIGINT and SIGTERM deferred (``outputs.signals_deferred``): a signal meanwhile does
    not cut the wait short; it is raised once the wait is over."""
    end = None if grace is None else time.monotonic() + grace
    with outputs.signals_deferred():
        while not event.is_set() and (end is None or time.monotonic() < end):
            event.wait(WAIT)


# the threads left behind by ``run_interruptibly`` (each its ``finished`` event) and the exit
# status the process ends with if one is still running at its exit
_LEFT = {"threads": [], "status": None}


def _left_behind(finished, cause):
    """A thread of ``run_interruptibly`` still busy after the stop grace (numba compiling a
    kernel on its first call, which nothing can cut short): the command goes on to say what
    was kept and exits, but the interpreter must not shut down beside it (numba and LLVM
    would run on while the modules, numba's threading layer and LLVM's state are torn down
    under them).  At the process's exit, if such a thread still runs, the standard streams
    are flushed and the process ends at once (``os._exit``) with the status the command's
    exception gives (``cli.Commands``): 130 after an interrupt, 1 after another error."""
    if not _LEFT["threads"]:
        atexit.register(_end_beside_left_threads)
    _LEFT["threads"].append(finished)
    if _LEFT["status"] is None:
        _LEFT["status"] = EXIT_INTERRUPTED if isinstance(cause, KeyboardInterrupt) else EXIT_FAULT


def _end_beside_left_threads():
    """At exit (``atexit``, before the interpreter shuts down): end the process at once while
    a thread left behind by ``run_interruptibly`` still runs (``_left_behind``)."""
    if all(f.is_set() for f in _LEFT["threads"]):
        return
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError, AttributeError):
            pass
    os._exit(_LEFT["status"])
