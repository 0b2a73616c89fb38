"""The Dask backend against the local one: throughput and per-chunk overhead (issue 7).

    python benchmarks/dask_bench.py [--smoke] [--out DIR]

writes DIR/dask_bench.json and prints a table.  Everything is measured in one run
(the machine is shared: compare the ratios, not the seconds across runs), each time
the best of ``--repeat`` runs, the JIT warm (a first untimed sweep of each kind).

1. Throughput: the Fig. 6(a) scene (flow, rectified sine) on a smaller grid, through
   ``run_sweep`` end to end (kernels, analysis, HDF5 file), on the local backend with
   1 numba thread and with all cores, and on a local Dask cluster of 1 and 2 worker
   processes (one Dask thread each, numba threads = cores // workers).  Cluster
   start-up is excluded there and measured on its own (``--scheduler local:N`` on a
   one-chunk scene, start to teardown).
2. Overhead per chunk: one worker with one numba thread against the local backend
   with one numba thread, the same scene cut into chunks of 1 ... 64 grid points.
   ``overhead`` = (T_dask - T_local) / chunks at each size, and a straight-line fit
   of T_dask - T_local against the number of chunks over all sizes: its slope is
   the cost of one more chunk (scheduling, transfer of the block to the driver),
   its intercept the fixed cost of a run on a running cluster (connecting, setting
   up and warming the workers).  ``compute`` is the workers' own kernel time per
   chunk, ``write`` the driver's time to write and mark one chunk (HDF5, gzip).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import shutil
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)


def _scene(num, count, transient, record):
    from cornerbif import config
    return config.load(os.path.join(ROOT, "configs", "fig06a.toml"),
                       [f"sweep.kappa.num={num}", f"initial.count={count}",
                        f"run.transient={transient}", f"run.record={record}"])


def _sweep(scene, tmp, block_points, threads=None, scheduler=None, repeat=1):
    """Best wall time of ``repeat`` sweeps, and the Dask stats of that run."""
    from cornerbif.sweep import run_sweep
    best, best_stats = float("inf"), None
    for _ in range(repeat):
        out = os.path.join(tmp, "b.h5")
        stats = {}
        t0 = time.perf_counter()
        run_sweep(scene, out, threads=threads, overwrite=True, block_points=block_points,
                  scheduler=scheduler, stats=stats)
        dt = time.perf_counter() - t0
        os.remove(out)
        if dt < best:
            best, best_stats = dt, stats
    return best, best_stats


def _cluster(n, numba_threads):
    import dask
    from distributed import LocalCluster
    with dask.config.set({"distributed.scheduler.worker-saturation": 1.0}):
        return LocalCluster(n_workers=n, threads_per_worker=1, processes=True,
                            dashboard_address=None, silence_logs=50,
                            env={"CORNERBIF_NUMBA_THREADS": str(numba_threads)})


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--smoke", action="store_true", help="tiny sizes (a CI smoke test)")
    ap.add_argument("--out", default=os.path.join(HERE, "results"))
    ap.add_argument("--repeat", type=int, default=2)
    a = ap.parse_args(argv)
    import numba

    from cornerbif.distributed import _cores
    cores = _cores()
    if a.smoke:
        thr = dict(num=16, count=2, transient=100, record=20)
        ovh = dict(num=8, count=2, transient=100, record=20)
        sizes, thr_chunk, repeat = [1, 8], 4, 1
    else:
        thr = dict(num=384, count=4, transient=500, record=100)
        ovh = dict(num=128, count=4, transient=200, record=40)
        sizes, thr_chunk, repeat = [1, 4, 16, 64], 16, a.repeat
    s_thr, s_ovh = _scene(**thr), _scene(**ovh)
    impacts = thr["num"] * thr["count"] * (thr["transient"] + thr["record"])
    tmp = tempfile.mkdtemp(prefix="dask-bench-")
    res = {"machine": {"cores": cores, "python": platform.python_version(),
                       "numba": numba.__version__, "platform": platform.platform()},
           "throughput_scene": thr, "throughput_chunk_points": thr_chunk,
           "overhead_scene": ovh, "throughput": {}, "startup_s": {}, "overhead": []}
    try:
        _sweep(s_thr, tmp, thr_chunk, threads=1)                        # warm the JIT cache
        for label, kw in (("local, 1 thread", dict(threads=1)),
                          (f"local, {cores} threads", dict(threads=cores))):
            t, _ = _sweep(s_thr, tmp, thr_chunk, repeat=repeat, **kw)
            res["throughput"][label] = {"seconds": t, "impacts_per_s": impacts / t}
        one = _scene(num=1, count=1, transient=10, record=10)
        for n in (1, 2):
            t, _ = _sweep(one, tmp, 1, scheduler=f"local:{n}")
            res["startup_s"][f"local:{n}"] = t
            lc = _cluster(n, max(1, cores // n))
            try:
                _sweep(s_thr, tmp, thr_chunk, scheduler=lc.scheduler_address)   # warm
                t, st = _sweep(s_thr, tmp, thr_chunk, scheduler=lc.scheduler_address,
                               repeat=repeat)
            finally:
                lc.close()
            res["throughput"][f"dask local:{n} ({max(1, cores // n)} numba threads each)"] = {
                "seconds": t, "impacts_per_s": impacts / t, "chunks": st["submitted"],
                "compute_s": sum(st["compute_seconds"])}
        lc = _cluster(1, 1)
        try:
            _sweep(s_ovh, tmp, sizes[-1], scheduler=lc.scheduler_address)          # warm
            for b in sizes:
                tl, _ = _sweep(s_ovh, tmp, b, threads=1, repeat=repeat)
                td, st = _sweep(s_ovh, tmp, b, scheduler=lc.scheduler_address, repeat=repeat)
                n = st["submitted"]
                res["overhead"].append({
                    "chunk_points": b, "chunks": n, "local_s": tl, "dask_s": td,
                    "overhead_ms_per_chunk": 1e3 * (td - tl) / n,
                    "compute_ms_per_chunk": 1e3 * sum(st["compute_seconds"]) / n,
                    "driver_write_ms_per_chunk": 1e3 * sum(st["write_seconds"]) / n})
        finally:
            lc.close()
        import numpy as np
        n = np.array([r["chunks"] for r in res["overhead"]], float)
        d = np.array([r["dask_s"] - r["local_s"] for r in res["overhead"]])
        slope, icpt = np.polyfit(n, d, 1)
        res["overhead_fit"] = {"ms_per_chunk": 1e3 * slope, "fixed_s_per_run": icpt}
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    os.makedirs(a.out, exist_ok=True)
    path = os.path.join(a.out, "dask_bench.json")
    with open(path, "w") as fh:
        json.dump(res, fh, indent=1)
    base = res["throughput"][f"local, {cores} threads"]["impacts_per_s"]
    print(f"throughput: fig06a, {thr['num']} points x {thr['count']} starts x "
          f"{thr['transient'] + thr['record']} impacts, chunks of {thr_chunk} points")
    print(f"{'backend':44s} {'s':>7s} {'M impacts/s':>12s} {'vs local all cores':>19s}")
    for k, v in res["throughput"].items():
        print(f"{k:44s} {v['seconds']:7.2f} {v['impacts_per_s'] / 1e6:12.2f} "
              f"{v['impacts_per_s'] / base:19.2f}")
    for k, v in res["startup_s"].items():
        print(f"start-up + teardown of --scheduler {k}: {v:.1f} s")
    print(f"\noverhead per chunk: 1 worker x 1 numba thread vs local 1 thread, fig06a "
          f"{ovh['num']} points x {ovh['count']} x {ovh['transient'] + ovh['record']}")
    print(f"{'points/chunk':>12s} {'chunks':>7s} {'local s':>8s} {'dask s':>8s} "
          f"{'overhead ms':>12s} {'compute ms':>11s} {'write ms':>9s}")
    for r in res["overhead"]:
        print(f"{r['chunk_points']:12d} {r['chunks']:7d} {r['local_s']:8.2f} {r['dask_s']:8.2f} "
              f"{r['overhead_ms_per_chunk']:12.1f} {r['compute_ms_per_chunk']:11.1f} "
              f"{r['driver_write_ms_per_chunk']:9.1f}")
    fit = res["overhead_fit"]
    print(f"fit T_dask - T_local = fixed + per_chunk * chunks: per chunk "
          f"{fit['ms_per_chunk']:.1f} ms, fixed {fit['fixed_s_per_run']:.2f} s per run")
    print(f"\nwrote {path}")
    return res


if __name__ == "__main__":
    sys.exit(0 if main() else 1)
