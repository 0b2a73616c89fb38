"""The (omega, kappa) chart of the flow (issue 3): wall and CPU time of `cornerbif sweep`.

    python benchmarks/chart.py [--sizes 200 400] [--baseline 60] [--full] [--threads 2]
                               [--out benchmarks/results]

Runs ``configs/chart_flow.toml`` (omega in [1.996, 2.004], kappa in [-0.03, 0.03],
output.keep = [], run.stop = "period" by default) with 8 initial conditions per
point on N x N grids through the real command (kernels, cycle analysis, HDF5
writer), and, on the ``--baseline`` grid, the same scene with run.stop = "none"
(every point runs transient + record impacts): the ratio of the two, measured in
this one run, is the gain of the early stop, and the two files' summaries
(status, period, impacts_per_cycle, symbols) are compared point for point.
The time of the 1000 x 1000 x 8 chart is extrapolated linearly in the number of
items from the largest grid, and measured with ``--full``.  Writes
``chart.json`` and ``chart.md`` to ``--out``.

This machine is shared: wall time depends on what else runs, so the CPU time of
the sweep process (user + system) is reported too; on two otherwise idle cores the
wall time is about half of it.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SCENE = os.path.join(ROOT, "configs", "chart_flow.toml")
FULL = 1000
N_IC = 8


def run_chart(n, out, stop, threads):
    """One `cornerbif sweep` of the chart on an n x n grid; wall and CPU seconds."""
    cmd = [sys.executable, "-m", "cornerbif.cli", "sweep", SCENE, "-o", out, "--overwrite",
           "--no-progress", "--threads", str(threads),
           "--set", f"sweep.omega.num={n}", "--set", f"sweep.kappa.num={n}",
           "--set", f"initial.count={N_IC}", "--set", f'run.stop="{stop}"']
    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    if p.returncode != 0:
        raise RuntimeError(p.stderr)
    cpu = (r1.ru_utime - r0.ru_utime) + (r1.ru_stime - r0.ru_stime)
    items = n * n * N_IC
    return {"grid": n, "items": items, "stop": stop, "threads": threads, "wall_seconds": wall,
            "cpu_seconds": cpu, "wall_per_item_us": wall / items * 1e6,
            "cpu_per_item_us": cpu / items * 1e6,
            "command": " ".join(["cornerbif"] + cmd[3:])}


def summaries_equal(a, b):
    """Points whose status, period, impacts_per_cycle or symbols differ between two files."""
    import h5py
    with h5py.File(a) as fa, h5py.File(b) as fb:
        bad = np.zeros(fa["status"].shape, bool)
        for k in ("status", "period", "impacts_per_cycle", "symbols"):
            bad |= fa[k][...] != fb[k][...]
        periods = fa["period"][...]
        return int(bad.sum()), int(bad.size), int(periods.max()), float(np.mean(periods > 0))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[200, 400])
    ap.add_argument("--baseline", type=int, default=60,
                    help="grid for the run.stop = \"none\" comparison (0: skip)")
    ap.add_argument("--full", action="store_true", help="also run the 1000 x 1000 x 8 chart")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--out", default=os.path.join(HERE, "results"))
    a = ap.parse_args(argv)
    os.makedirs(a.out, exist_ok=True)
    env_note = {"platform": platform.platform(), "cpus": os.cpu_count(),
                "load_before": os.getloadavg()}
    res = {"machine": env_note, "date": time.strftime("%Y-%m-%d %H:%M:%S"), "runs": []}
    with tempfile.TemporaryDirectory() as tmp:
        # warm the numba cache so no run pays compilation
        run_chart(4, os.path.join(tmp, "warm.h5"), "period", a.threads)
        res["warm_none"] = run_chart(4, os.path.join(tmp, "warm.h5"), "none", a.threads)
        if a.baseline:
            f0 = os.path.join(tmp, "base_none.h5")
            f1 = os.path.join(tmp, "base_period.h5")
            print(f"baseline {a.baseline}^2 x {N_IC}, run.stop = none ...", flush=True)
            r_none = run_chart(a.baseline, f0, "none", a.threads)
            print(f"baseline {a.baseline}^2 x {N_IC}, run.stop = period ...", flush=True)
            r_per = run_chart(a.baseline, f1, "period", a.threads)
            nbad, ntot, pmax, share = summaries_equal(f0, f1)
            res["runs"] += [r_none, r_per]
            res["baseline"] = {"grid": a.baseline, "differing_points": nbad, "points": ntot,
                               "max_period": pmax, "share_with_period": share,
                               "gain_wall": r_none["wall_seconds"] / r_per["wall_seconds"],
                               "gain_cpu": r_none["cpu_seconds"] / r_per["cpu_seconds"]}
            print(res["baseline"], flush=True)
        sizes = list(a.sizes) + ([FULL] if a.full else [])
        for n in sizes:
            print(f"chart {n}^2 x {N_IC}, run.stop = period ...", flush=True)
            r = run_chart(n, os.path.join(tmp, f"chart{n}.h5"), "period", a.threads)
            res["runs"].append(r)
            print(r, flush=True)
            os.remove(os.path.join(tmp, f"chart{n}.h5"))
    # extrapolate with the marginal cost per item between the two largest grids (the
    # start-up of the command, ~2 s, is then not multiplied), else proportionally
    per = sorted((r for r in res["runs"] if r["stop"] == "period" and r["grid"] != FULL),
                 key=lambda r: r["items"])
    full_items = FULL * FULL * N_IC
    big = per[-1]
    ext = {"from_grids": [big["grid"]]}
    for k in ("wall", "cpu"):
        slope = big[f"{k}_seconds"] / big["items"]
        if len(per) >= 2 and per[-1]["items"] > per[-2]["items"]:
            d = (big[f"{k}_seconds"] - per[-2][f"{k}_seconds"]) / (big["items"] - per[-2]["items"])
            if d > 0:
                slope = d
                ext["from_grids"] = [per[-2]["grid"], big["grid"]]
        ext[f"{k}_minutes"] = (big[f"{k}_seconds"] + slope * (full_items - big["items"])) / 60
    res["extrapolated_full"] = ext
    if a.baseline:
        none, w = res["runs"][0], res["warm_none"]     # marginal cost: minus the 4 x 4 run
        res["extrapolated_full_without_stop"] = {
            f"{k}_minutes": (none[f"{k}_seconds"] - w[f"{k}_seconds"])
            / (none["items"] - w["items"]) * full_items / 60 for k in ("wall", "cpu")}
    res["machine"]["load_after"] = os.getloadavg()
    with open(os.path.join(a.out, "chart.json"), "w") as fh:
        json.dump(res, fh, indent=2)
    report = render(res)
    with open(os.path.join(a.out, "chart.md"), "w") as fh:
        fh.write(report)
    print(report)


def render(r):
    L = ["# (omega, kappa) chart of the flow: `configs/chart_flow.toml`, 8 starts per point", "",
         f"Machine: {r['machine']['platform']}, {r['machine']['cpus']} CPUs (shared; load "
         f"{r['machine']['load_before'][0]:.1f} before, {r['machine']['load_after'][0]:.1f} "
         f"after); {r['date']}.", "Command: `python benchmarks/chart.py "
         "[--sizes ...] [--baseline N] [--full]`", "",
         "| grid x starts | run.stop | wall | CPU (user+sys) | wall / item | CPU / item |",
         "|---|---|---|---|---|---|"]
    for x in r["runs"]:
        L.append(f"| {x['grid']}^2 x {N_IC} | {x['stop']} | {x['wall_seconds']:.1f} s | "
                 f"{x['cpu_seconds']:.1f} s | {x['wall_per_item_us']:.1f} us | "
                 f"{x['cpu_per_item_us']:.1f} us |")
    L.append("")
    if "baseline" in r:
        b = r["baseline"]
        L += [f"Early stop on the {b['grid']}^2 x {N_IC} grid: {b['gain_wall']:.1f}x less wall "
              f"time, {b['gain_cpu']:.1f}x less CPU than run.stop = \"none\"; "
              f"{b['differing_points']} of {b['points']} items differ in status, period, "
              f"impacts_per_cycle or symbols (max period {b['max_period']}, "
              f"{b['share_with_period'] * 100:.1f} % with a period).", ""]
    e = r["extrapolated_full"]
    L.append(f"1000^2 x {N_IC} extrapolated from the {' and '.join(map(str, e['from_grids']))}"
             " grids (marginal cost per item): "
             f"{e['wall_minutes']:.1f} min wall, {e['cpu_minutes']:.1f} min CPU "
             f"(target: 20 min on 2 cores).")
    if "extrapolated_full_without_stop" in r:
        w = r["extrapolated_full_without_stop"]
        L.append(f"Without early stop (from the baseline grid): {w['wall_minutes']:.1f} min wall, "
                 f"{w['cpu_minutes']:.1f} min CPU.")
    full = [x for x in r["runs"] if x["grid"] == FULL]
    if full:
        L.append(f"Measured 1000^2 x {N_IC}: {full[0]['wall_seconds'] / 60:.1f} min wall, "
                 f"{full[0]['cpu_seconds'] / 60:.1f} min CPU.")
    L.append("")
    return "\n".join(L)


if __name__ == "__main__":
    main()
