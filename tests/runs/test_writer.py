"""The local backend's writer thread (cornerbif/local.py, BlockWriter).

The kernels run in the calling thread while the writer writes the block before: the
tests hand it blocks with a write that takes a known time and check the promises of its
docstring: blocks written in the order handed over, a write overlapping the next block's
computation, never more than one block waiting beside the one being written (memory),
thin slabs written together, and a failed write raised in the caller's thread with the
blocks before it kept.
"""

import threading
import time

import numpy as np
import pytest

from cornerbif import engine, io, local
from cornerbif.errors import WriteFailed


class Log:
    def __init__(self, seconds, fail_at=None):
        self.seconds = seconds
        self.fail_at = fail_at
        self.calls = []          # (start, end, [block ids]) of each write
        self.lock = threading.Lock()

    def write_pending(self, f, pending):
        items = list(pending)
        pending.clear()
        ids = [int(b["id"][0]) for _, b in items]
        if self.fail_at is not None and self.fail_at in ids:
            raise WriteFailed("disk full (test)")
        t0 = time.monotonic()
        time.sleep(self.seconds)
        with self.lock:
            self.calls.append((t0, time.monotonic(), ids))


def _block(i, nbytes):
    return {"id": np.full(max(1, nbytes // 8), i, np.int64)}


def _run(monkeypatch, log, n, nbytes, compute_seconds, budget, batch=1):
    monkeypatch.setattr(io, "write_pending", log.write_pending)
    monkeypatch.setattr(engine, "BLOCK_BYTES", budget)
    w = local.BlockWriter(f=None, batch=batch)
    computed = []       # (start, end) of each computation
    alive = []          # blocks handed over and not yet written, when each computation starts
    try:
        last = 0
        for i in range(n):
            w.wait_for_room(last)
            with log.lock:
                written = sum(len(ids) for *_, ids in log.calls)
            alive.append(i - written)
            t0 = time.monotonic()
            time.sleep(compute_seconds)
            blk = _block(i, nbytes)
            computed.append((t0, time.monotonic()))
            last = local.block_nbytes(blk)
            w.put((slice(i, i + 1),), blk)
    finally:
        w.close()
    return computed, alive


def test_full_blocks_overlap_in_order_and_two_at_most(monkeypatch):
    """Blocks of 60 % of BLOCK_BYTES, computing 50 ms and writing 50 ms: written in order,
    each write overlapping the next computation, at most one block unwritten when a
    computation starts (so two alive: that one and the one computing)."""
    log = Log(0.05)
    computed, alive = _run(monkeypatch, log, 6, 600, 0.05, 1000)
    order = [i for *_, ids in log.calls for i in ids]
    assert order == list(range(6))
    assert max(alive) <= 1
    overlapped = sum(1 for k, (s, e, ids) in enumerate(log.calls[:-1])
                     if s < computed[ids[-1] + 1][1] and computed[ids[-1] + 1][0] < e)
    assert overlapped >= 4, (log.calls, computed)


def test_thin_slabs_are_written_together(monkeypatch):
    """Followed slabs of 1 % of BLOCK_BYTES computed faster than one write: the writer takes
    what waits, many slabs in one write, and never holds more than BLOCK_BYTES waiting."""
    log = Log(0.05)
    _, alive = _run(monkeypatch, log, 60, 10, 0.002, 1000, batch=local.FOLLOW_BATCH)
    order = [i for *_, ids in log.calls for i in ids]
    assert order == list(range(60))
    assert max(len(ids) for *_, ids in log.calls) > 5
    assert max(alive) * 10 <= 1000 + 10


def test_full_blocks_are_written_one_by_one(monkeypatch):
    """Blocks computed faster than they are written are still written one per write (each
    marked done at once: a disk that fills loses at most the block being written)."""
    log = Log(0.05)
    _run(monkeypatch, log, 8, 100, 0.0, 1000)
    assert [ids for *_, ids in log.calls] == [[i] for i in range(8)]


def test_a_failed_write_reaches_the_caller_and_keeps_the_blocks_before(monkeypatch):
    log = Log(0.01, fail_at=2)
    with pytest.raises(WriteFailed, match="disk full"):
        _run(monkeypatch, log, 6, 600, 0.02, 1000)
    assert [i for *_, ids in log.calls for i in ids] == [0, 1]


def test_an_interrupt_in_the_writer_reaches_the_caller(monkeypatch):
    """A KeyboardInterrupt raised inside a write (the writer thread) is raised again in the
    caller's thread, as the command's Ctrl-C handling expects."""
    def interrupted(f, pending):
        pending.clear()
        raise KeyboardInterrupt
    monkeypatch.setattr(io, "write_pending", interrupted)
    w = local.BlockWriter(f=None)
    w.put((slice(0, 1),), _block(0, 8))
    with pytest.raises(KeyboardInterrupt):
        w.close()
