"""The writer's trade: write time against file size for the compressors h5py ships.

    python benchmarks/compression.py [--num 1000] [--rounds 3] [--out benchmarks/results]

One block of a Fig. 4(c)-like sweep (omega in [1.5, 2.5], ``--num`` values, 4 starts,
600 impacts: 500 transient + 100 recorded, impacts and section kept) is computed once;
its datasets are then written into fresh files laid out as ``io.create`` lays them out
(the same chunks), once per filter, best of ``--rounds`` (this machine is shared). The
report gives seconds, MB/s of uncompressed data, file size and the ratio to gzip level 4
with shuffle (the setting before this measurement). Readable by any HDF5 reader: gzip
(deflate) and, for h5py and HDF5 builds with it, lzf (h5py's own filter; xarray reads it
through h5netcdf/h5py only).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time

import h5py
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, ROOT)

FILTERS = {
    "gzip 4 + shuffle": dict(compression="gzip", compression_opts=4, shuffle=True),
    "gzip 1 + shuffle": dict(compression="gzip", compression_opts=1, shuffle=True),
    "gzip 1": dict(compression="gzip", compression_opts=1, shuffle=False),
    "lzf + shuffle": dict(compression="lzf", shuffle=True),
    "lzf": dict(compression="lzf", shuffle=False),
    "none": dict(),
}


def block(num):
    from cornerbif import config, engine
    sc = config.load(os.path.join(ROOT, "configs", "fig04c.toml"),
                     [f"sweep.omega.num={num}", "initial.count=4", 'output.keep=["impacts", "section"]',
                      "run.stop=\"none\""])
    return sc, engine.compute_block(sc, (slice(0, num),))


def write(path, blk, opts):
    n_ic_chunk = None
    with h5py.File(path, "w", libver="latest") as f:
        for name, arr in blk.items():
            arr = np.asarray(arr)
            trailing = int(np.prod(arr.shape[1:])) if arr.ndim > 1 else 1
            per = max(1, (256 * 1024) // max(1, trailing * arr.dtype.itemsize))
            chunks = (min(arr.shape[0], per),) + arr.shape[1:]
            f.create_dataset(name, data=arr, chunks=chunks, **opts)
    del n_ic_chunk
    return os.path.getsize(path)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--num", type=int, default=1000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    sc, blk = block(args.num)
    raw = sum(np.asarray(a).nbytes for a in blk.values())
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            for name, opts in FILTERS.items():
                path = os.path.join(tmp, f"{r}.h5")
                t0 = time.perf_counter()
                size = write(path, blk, opts)
                dt = time.perf_counter() - t0
                best = rows.get(name)
                if best is None or dt < best["seconds"]:
                    rows[name] = {"seconds": dt, "bytes": size}
                os.remove(path)
    base = rows["gzip 4 + shuffle"]
    print(f"one block: {args.num} points x 4 starts x 100 recorded impacts, "
          f"{raw / 1e6:.1f} MB uncompressed; best of {args.rounds}")
    print(f"{'filter':18s} {'seconds':>8s} {'MB/s':>8s} {'file MB':>8s} {'time/base':>9s} "
          f"{'size/base':>9s}")
    for name, r in rows.items():
        r["mb_per_s"] = raw / 1e6 / r["seconds"]
        print(f"{name:18s} {r['seconds']:8.3f} {r['mb_per_s']:8.1f} {r['bytes'] / 1e6:8.2f} "
              f"{r['seconds'] / base['seconds']:9.2f} {r['bytes'] / base['bytes']:9.2f}")
    if args.out:
        with open(os.path.join(args.out, "compression.json"), "w") as fh:
            json.dump({"raw_bytes": raw, "num": args.num, "filters": rows}, fh, indent=1)


if __name__ == "__main__":
    main()
