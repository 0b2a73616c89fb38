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


@pytest.mark.parametrize("n,most,taper", [(4000, 891, 81), (1000, 891, 81), (100, 891, 81),
                                          (61, 8, 2), (7, 3, 1), (5, 1, 1)])
def test_the_grids_last_slabs_halve_in_whole_chunks(n, most, taper):
    """``engine.slab_bounds``: the slabs tile [0, n) in order, none larger than ``most``;
    every boundary but n is a whole number of chunks (the writer compresses whole chunks);
    the slabs never grow, and the last is at most a quarter of ``most`` (or one chunk)."""
    cuts = engine.slab_bounds(n, most, taper)
    sizes = [b - a for a, b in cuts]
    assert cuts[0][0] == 0 and cuts[-1][1] == n
    assert all(b == c for (_, b), (c, _) in zip(cuts, cuts[1:]))
    assert max(sizes) <= most and all(b % taper == 0 for _, b in cuts[:-1])
    assert all(x >= y for x, y in zip(sizes, sizes[1:]))
    assert sizes[-1] <= max(taper, most // 4)
    assert engine.slab_bounds(n, most) == [(a, min(n, a + most)) for a in range(0, n, most)]


def test_tapered_slabs_write_the_same_file_as_even_ones(tmp_path, monkeypatch, configs_dir):
    """The default slabs (the last ones halving) and even slabs of ``--block-points`` write
    the same values in every dataset (each run is independent of the others in its
    block)."""
    import h5py

    from cornerbif import config
    from cornerbif.sweep import run_sweep
    monkeypatch.setattr(engine, "CHUNK_BYTES", 2 * 2 * 20 * 8)      # 2 points a chunk
    sc = config.load(f"{configs_dir}/fig04c.toml",
                     ["sweep.omega.num=61", "initial.count=2", "run.transient=50",
                      "run.record=20"])
    monkeypatch.setattr(engine, "BLOCK_BYTES", 8 * engine.item_bytes(sc) * sc.n_ic)
    tapered = [b[0].stop - b[0].start for b in engine.blocks(sc)]
    assert tapered[-5:] == [8, 6, 4, 2, 1] and len(engine.blocks(sc, 8)) == 8
    files = [run_sweep(sc, str(tmp_path / f"{k}.h5"), block_points=bp)
             for k, bp in (("tapered", None), ("even", 8))]
    with h5py.File(files[0]) as a, h5py.File(files[1]) as b:
        names = []
        a.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        assert len(names) > 20
        for n in names:
            assert np.array_equal(a[n][...], b[n][...], equal_nan=a[n].dtype.kind == "f"), n
