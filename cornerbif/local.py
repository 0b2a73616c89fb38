"""The local backend: the sweep's blocks computed in this process (numba threads).

Every unfinished block of the file in execution order goes through
``engine.compute_block`` and is written by ``io.write_pending``; a followed sweep
carries each slab's final states to the next.  The Dask backend
(``cornerbif.distributed``) runs the same blocks on a cluster.
"""

from __future__ import annotations

import sys
import time

from . import engine, io

FOLLOW_BATCH = 256   # followed slabs written together at most


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


def run_blocks(scene, f, progress=False, block_points=None):
    """Every unfinished block of ``f`` in order, computed here and written."""
    ints = engine.int_settings(scene)
    every = engine.blocks(scene, block_points)
    todo = [every[i] for i in io.unfinished(every, f)]
    bar = progress_bar(scene, len(every), len(every) - len(todo)) if progress else None
    carry = None  # follow: final states of the previous grid slab
    if scene.follow != "none" and todo:
        carry = carry_from_file(scene, f, every, todo[0])
    # a followed sweep computes one thin slab at a time; writing each alone costs more
    # than computing it, so consecutive slabs are written together, at least once a second
    pending = []
    last = time.monotonic()
    try:
        for blk in todo:
            block = engine.compute_block(scene, blk, carry, ints)
            pending.append((blk, block))
            if scene.follow != "none":
                carry = engine.block_carry(scene, block)
            if (scene.follow == "none" or len(pending) >= FOLLOW_BATCH
                    or time.monotonic() - last > 1.0):
                io.write_pending(f, pending)
                last = time.monotonic()
            if bar is not None:
                bar.update(1)
    finally:
        try:
            io.write_pending(f, pending)       # finished slabs are kept on an interrupt too
        finally:
            if bar is not None:
                bar.__exit__(None, None, None)
