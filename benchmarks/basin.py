"""A basin image of the flow at one parameter point, 1000 x 1000 starts, end to end.

``cornerbif sweep configs/basin_hysteresis.toml`` with its start axes refined to N x N
(omega = 2.001, kappa = 0.008, 3000 transient impacts and 60 recorded per start, nothing
but the per-run summary kept), timed as a user runs it, with its peak memory (the
process's maximum resident set, /usr/bin/time), at N = 250 and N = 1000 (16 times the
runs: blocks keep the memory flat). Then the attractor table's pass alone
(``attractors.tabulate`` on the finished file, which it rewrites), and the basin image
(``cornerbif plot``).

    python benchmarks/basin.py                 # N = 250 and 1000 (a few minutes here)
    python benchmarks/basin.py --smoke         # N = 40 and 80 (CI)
    python benchmarks/basin.py --convergence   # the basin scenes at 101, 201, 401 per side
                                               # against 20000 random starts each

Writes ``basin.json`` (or ``basin_convergence.json``) into ``--out`` (default
benchmarks/results).  The convergence table: per scene and resolution each attractor's
share of the cells, beside the share of ``RANDOM`` random starts on the same rectangle with
its standard error; the attractors found at each resolution.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SCENE = os.path.join(ROOT, "configs", "basin_hysteresis.toml")


def timed(cmd):
    """Wall seconds and peak resident MiB of one command (GNU time)."""
    with tempfile.NamedTemporaryFile("r", suffix=".time") as tf:
        t0 = time.perf_counter()
        subprocess.run(["/usr/bin/time", "-f", "%M", "-o", tf.name, *cmd], check=True,
                       stdout=subprocess.DEVNULL)
        wall = time.perf_counter() - t0
        peak_kib = int(tf.read().split()[-1])
    return wall, peak_kib / 1024


def run(n, tmp):
    out = os.path.join(tmp, f"basin{n}.h5")
    sweep = [sys.executable, "-m", "cornerbif.cli", "sweep", SCENE, "-o", out, "--overwrite",
             "--no-progress", "--set", f"sweep.initial.u.num={n}",
             "--set", f"sweep.initial.v.num={n}"]
    wall, peak = timed(sweep)
    import h5py

    from cornerbif import attractors, config
    sc = config.load(SCENE, [f"sweep.initial.u.num={n}", f"sweep.initial.v.num={n}"])
    with h5py.File(out, "r+") as f:
        t0 = time.perf_counter()
        attractors.tabulate(f, sc)
        table_s = time.perf_counter() - t0
    t = attractors.read_table(out)
    plot_s, plot_peak = timed([sys.executable, "-m", "cornerbif.cli", "plot", out, "-o",
                               os.path.join(tmp, f"basin{n}.png")])
    return {"n": n, "runs": n * n, "sweep_s": wall, "sweep_peak_mib": peak,
            "runs_per_s": n * n / wall, "table_s": table_s, "plot_s": plot_s,
            "plot_peak_mib": plot_peak, "file_mib": os.path.getsize(out) / 2**20,
            "attractors": {w: float(f) for w, f in zip(t["word"], t["fraction"])}}


BASIN_SCENES = ("basin_hysteresis", "basin_census", "basin_maps")
RANDOM = 20000


def convergence(tmp, sides=(101, 201, 401), scenes=BASIN_SCENES, random=RANDOM):
    """Shares at three resolutions and from random starts (module doc)."""
    import tomllib

    from cornerbif import attractors, config
    from cornerbif.sweep import run_sweep
    out = {}
    for name in scenes:
        path = os.path.join(ROOT, "configs", f"{name}.toml")
        rows = {}
        for n in sides:
            sc = config.load(path, [f"sweep.initial.u.num={n}", f"sweep.initial.v.num={n}"])
            h5 = os.path.join(tmp, f"{name}{n}.h5")
            run_sweep(sc, h5, overwrite=True)
            t = attractors.read_table(h5)
            rows[n] = {w: float(f) for w, f in zip(t["word"], t["fraction"])}
        with open(path, "rb") as fh:
            raw = tomllib.load(fh)
        swept = raw.pop("sweep")["initial"]
        raw["initial"] = {"count": random, "seed": 11,
                          **{c: [swept[c]["start"], swept[c]["stop"]] for c in swept}}
        h5 = os.path.join(tmp, f"{name}_random.h5")
        run_sweep(config.from_dict(raw), h5, overwrite=True)
        t = attractors.read_table(h5)
        rnd = {w: (float(f), float(e)) for w, f, e in zip(t["word"], t["fraction"],
                                                         t["standard_error"])}
        out[name] = {"grid": rows, "random": rnd}
        words = sorted(set().union(*rows.values(), rnd))
        print(f"{name}: " + "; ".join(
            f"{w}: " + ", ".join(f"{n}^2 {rows[n].get(w, 0):.4f}" for n in sides)
            + (f", random {rnd[w][0]:.4f} +- {rnd[w][1]:.4f}" if w in rnd else ", random -")
            for w in words))
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--smoke", action="store_true", help="N = 40 and 80 (CI)")
    ap.add_argument("--out", default=os.path.join(HERE, "results"))
    ap.add_argument("--convergence", action="store_true",
                    help="shares at three resolutions against random starts")
    a = ap.parse_args(argv)
    if a.convergence:
        os.makedirs(a.out, exist_ok=True)
        with tempfile.TemporaryDirectory() as tmp:
            res = convergence(tmp)
        res = {"when": time.strftime("%Y-%m-%d %H:%M"),
               "command": "python benchmarks/basin.py --convergence", "scenes": res}
        with open(os.path.join(a.out, "basin_convergence.json"), "w") as fh:
            json.dump(res, fh, indent=1)
        return
    sizes = (40, 80) if a.smoke else (250, 1000)
    os.makedirs(a.out, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        # a first small run loads numba's cache (or compiles) so that it is not timed
        subprocess.run([sys.executable, "-m", "cornerbif.cli", "sweep", SCENE, "-o",
                        os.path.join(tmp, "warm.h5"), "--no-progress", "--set",
                        "sweep.initial.u.num=4", "--set", "sweep.initial.v.num=4"],
                       check=True, stdout=subprocess.DEVNULL)
        rows = [run(n, tmp) for n in sizes]
    res = {"when": time.strftime("%Y-%m-%d %H:%M"), "cores": os.cpu_count(),
           "command": "python benchmarks/basin.py" + (" --smoke" if a.smoke else ""),
           "rows": rows,
           "peak_ratio": rows[-1]["sweep_peak_mib"] / rows[0]["sweep_peak_mib"],
           "runs_ratio": rows[-1]["runs"] / rows[0]["runs"]}
    with open(os.path.join(a.out, "basin.json"), "w") as fh:
        json.dump(res, fh, indent=1)
    for r in rows:
        print(f"{r['n']} x {r['n']}: sweep {r['sweep_s']:.1f} s ({r['runs_per_s']:.0f} runs/s), "
              f"peak {r['sweep_peak_mib']:.0f} MiB; table {r['table_s']:.2f} s; plot "
              f"{r['plot_s']:.1f} s, peak {r['plot_peak_mib']:.0f} MiB; file "
              f"{r['file_mib']:.1f} MiB; shares "
              + ", ".join(f"{w} {f:.4f}" for w, f in r["attractors"].items()))
    print(f"runs x{res['runs_ratio']:.0f}, peak memory x{res['peak_ratio']:.2f}")


if __name__ == "__main__":
    main()
