"""The local backend: the sweep's blocks computed in this process (numba threads).

Every unfinished block of the file in execution order goes through
``engine.compute_block`` in the calling thread, and one writer thread (``BlockWriter``,
the file's single writer) writes the finished blocks through ``io.write_pending`` while
the next ones compute: the kernels release the GIL, so the file's compression runs
beside them instead of after them.  A followed sweep carries each slab's final states
to the next.  The Dask backend (``cornerbif.distributed``) runs the same blocks on a
cluster.
"""

from __future__ import annotations

import sys
import threading

from . import engine, io

FOLLOW_BATCH = 256   # followed slabs written together at most
# items a numba thread takes at a time from a block (dynamic scheduling): the writer thread
# takes a core from the kernels' threads now and then, and with the default static split
# the whole block waits for the thread it slowed
PARALLEL_CHUNK = 16


def progress_bar(scene, total, already):
    """The sweep's progress bar on stderr (click), advanced past the finished blocks."""
    import click
    bar = click.progressbar(length=total, label=f"sweep {scene.name}", file=sys.stderr,
                            show_pos=True, show_eta=True)
    bar.__enter__()
    bar.update(already)
    return bar


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
    writing each alone costs more than computing it.  A write that fails stops the writer; the
    caller gets its exception from the next ``wait_for_room`` or from ``close``, and
    every block marked done before it stays in the file.
    """

    def __init__(self, f, batch=1):
        self.f = f
        self.batch = batch         # blocks written together at most (FOLLOW_BATCH: thin slabs)
        self.queue = []            # (block index, block, bytes) handed over, not yet taken
        self.queued = 0            # their bytes
        self.closing = False
        self.error = None
        self.cv = threading.Condition()
        self.thread = threading.Thread(target=self._run, name="cornerbif-writer")
        self.thread.start()

    def _run(self):
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
        """Write every block handed over, stop the thread, and raise a failed write's error."""
        with self.cv:
            self.closing = True
            self.cv.notify_all()
        self.thread.join()
        with self.cv:
            self._raise()


def run_blocks(scene, f, progress=False, block_points=None):
    """Every unfinished block of ``f`` in order, computed here and written by a
    ``BlockWriter`` while the next computes."""
    ints = engine.int_settings(scene)
    every = engine.blocks(scene, block_points)
    todo = [every[i] for i in io.unfinished(every, f)]
    bar = progress_bar(scene, len(every), len(every) - len(todo)) if progress else None
    carry = None  # follow: final states of the previous grid slab
    if scene.follow != "none" and todo:
        carry = carry_from_file(scene, f, every, todo[0])
    import numba
    # full blocks are written one by one (each marked done as soon as it is written);
    # thin followed slabs together
    writer = BlockWriter(f, FOLLOW_BATCH if scene.follow != "none" else 1)
    last = 0
    chunk = numba.get_parallel_chunksize()
    numba.set_parallel_chunksize(PARALLEL_CHUNK)
    try:
        for blk in todo:
            writer.wait_for_room(last)
            block = engine.compute_block(scene, blk, carry, ints)
            if scene.follow != "none":
                carry = engine.block_carry(scene, block)
            last = block_nbytes(block)
            writer.put(blk, block, last)
            if bar is not None:
                bar.update(1)
    finally:
        numba.set_parallel_chunksize(chunk)
        try:
            writer.close()        # finished blocks are kept on an interrupt too
        finally:
            if bar is not None:
                bar.__exit__(None, None, None)
