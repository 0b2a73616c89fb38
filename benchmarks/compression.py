"""The writer's trade: CPU time of writing against file size, per compressor.

    python benchmarks/compression.py [--num 4000] [--rounds 3] [--out benchmarks/results]

The first block of the Fig. 4(c)-like scene of the end-to-end benchmark (omega in
[1.5, 2.5], ``--num`` values, 4 starts, 600 impacts: 500 transient + 100 recorded,
impacts and section kept; ``engine.blocks`` lays it out) is computed once; its datasets
are then written into fresh files laid out as ``io.create`` lays them out (the same
chunks), once per way of writing, best of ``--rounds``.  The CPU time is the process's
(the writer is one thread; it competes with the kernels for the cores, so CPU time, not
wall time, is what it costs a sweep).  The ways of writing:

* HDF5's own filters, as h5py ships them: gzip (deflate) levels 4 and 1 with shuffle,
  lzf with shuffle, none;
* the writer's path (``cornerbif.chunkwrite``): whole chunks shuffled and deflated at
  level 1 by ISA-L (``isal``), and by zlib for comparison; the same filters in the file,
  so any HDF5 reader reads them;
* plugins from ``hdf5plugin`` when it is installed (LZ4 and Zstandard level 1, with
  shuffle): files then need the plugin to be read.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
import zlib

import h5py
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, ROOT)

GZIP = dict(compression="gzip", shuffle=True)
WAYS = {
    "hdf5 gzip 4 + shuffle": dict(GZIP, compression_opts=4),
    "hdf5 gzip 1 + shuffle": dict(GZIP, compression_opts=1),
    "hdf5 lzf + shuffle": dict(compression="lzf", shuffle=True),
    "hdf5 none": dict(),
    "chunkwrite isal 1 + shuffle": dict(GZIP, compression_opts=1, direct="isal"),
    "chunkwrite zlib 1 + shuffle": dict(GZIP, compression_opts=1, direct="zlib"),
}
try:
    import hdf5plugin
    WAYS["plugin lz4 + shuffle"] = dict(**hdf5plugin.LZ4(), shuffle=True)
    WAYS["plugin zstd 1 + shuffle"] = dict(**hdf5plugin.Zstd(clevel=1), shuffle=True)
except ImportError:
    pass


def block(num):
    from cornerbif import config, engine
    sc = config.load(os.path.join(ROOT, "configs", "fig04c.toml"),
                     [f"sweep.omega.num={num}", "initial.count=4", "run.transient=500",
                      "run.record=100", 'output.keep=["impacts", "section"]'])
    blk = engine.blocks(sc)[0]
    return sc, blk, engine.compute_block(sc, blk)


def write(path, sc, blk, data, opts):
    """Write the block as the sweep would into a fresh file; returns its size."""
    from cornerbif import chunkwrite, engine
    opts = dict(opts)
    direct = opts.pop("direct", None)
    saved = chunkwrite._deflate, chunkwrite.DEFLATE
    if direct == "zlib":
        chunkwrite._deflate, chunkwrite.DEFLATE = zlib, "zlib"
    try:
        with h5py.File(path, "w", libver="latest") as f:
            for name, arr in data.items():
                shape = (sc.shape[0],) + arr.shape[1:]
                per = engine.event_chunk_points(sc) if arr.ndim > 2 else 8192
                kw = opts if arr.dtype.kind != "S" else dict(GZIP, compression_opts=1)
                ds = f.create_dataset(name, shape=shape, dtype=arr.dtype,
                                      chunks=(min(per, shape[0]),) + arr.shape[1:], **kw)
                if direct:
                    chunkwrite.write_slab(ds, blk, arr)
                else:
                    ds[blk] = arr
    finally:
        chunkwrite._deflate, chunkwrite.DEFLATE = saved
    return os.path.getsize(path)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--num", type=int, default=4000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    sc, blk, data = block(args.num)
    raw = sum(np.asarray(a).nbytes for a in data.values())
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            for name, opts in WAYS.items():
                path = os.path.join(tmp, f"{r}.h5")
                c0, t0 = time.process_time(), time.perf_counter()
                size = write(path, sc, blk, data, opts)
                cpu, wall = time.process_time() - c0, time.perf_counter() - t0
                best = rows.get(name)
                if best is None or cpu < best["cpu_seconds"]:
                    rows[name] = {"cpu_seconds": cpu, "wall_seconds": wall, "bytes": size}
                os.remove(path)
    base = rows["hdf5 gzip 4 + shuffle"]
    points = blk[0].stop - blk[0].start
    print(f"one block: {points} points x 4 starts x 100 recorded impacts, "
          f"{raw / 1e6:.1f} MB uncompressed; best of {args.rounds}")
    print(f"{'way of writing':28s} {'CPU s':>7s} {'MB/s':>7s} {'file MB':>8s} {'ratio':>6s} "
          f"{'CPU/base':>8s} {'size/base':>9s}")
    for name, r in rows.items():
        r["mb_per_cpu_second"] = raw / 1e6 / r["cpu_seconds"]
        r["compression_ratio"] = raw / r["bytes"]
        print(f"{name:28s} {r['cpu_seconds']:7.3f} {r['mb_per_cpu_second']:7.0f} "
              f"{r['bytes'] / 1e6:8.2f} {r['compression_ratio']:6.1f} "
              f"{r['cpu_seconds'] / base['cpu_seconds']:8.2f} {r['bytes'] / base['bytes']:9.2f}")
    if args.out:
        with open(os.path.join(args.out, "compression.json"), "w") as fh:
            json.dump({"raw_bytes": raw, "points": points, "ways": rows}, fh, indent=1)


if __name__ == "__main__":
    main()
