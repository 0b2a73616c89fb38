"""How long `cornerbif plot` takes on a diagram of millions of points, and its peak memory.

A Fig. 4(c)-like omega sweep (omega in [1.5, 2.5], N values x 8 starts, 160 recorded
impacts: 5.1 M points at N = 4000) is swept once; then `cornerbif plot` draws it to PNG and
to PDF, each in its own process (wall time; the peak RSS that process reports),
beside the same for a 1/10 of the points and for each further N given (how time and
memory grow with the count: past plot_style.RASTER_POINTS values the diagram is one image
and its values are read a slab at a time, so the peak should not grow).  The diagram is
coloured by orbit (the file's attractor table), as the gallery draws it.

    python benchmarks/plot_speed.py [--num 4000 [10000 ...]] [--out benchmarks/results]
    python benchmarks/plot_speed.py --smoke

Writes ``plot_speed.json`` into ``--out``.
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
SCENE = os.path.join(ROOT, "configs", "fig04c.toml")


CODE = ("import resource, sys\nfrom cornerbif.cli import main\ntry:\n    main(sys.argv[1:])\n"
        "except SystemExit as e:\n    if e.code:\n        raise\n"
        "print('MAXRSS', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss)")


def run(args):
    """(wall seconds, peak RSS in MiB) of ``cornerbif ARGS`` in a process of its own."""
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", CODE, *args], capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(p.stderr)
    rss = [int(line.split()[1]) for line in p.stdout.splitlines() if line.startswith("MAXRSS")]
    return dt, rss[-1] / 1024


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--num", type=int, nargs="+", default=[4000],
                    help="omega values of the sweeps (the first's 1/10 is swept too)")
    ap.add_argument("--smoke", action="store_true")
    ap.add_argument("--out", default=os.path.join(HERE, "results"))
    a = ap.parse_args(argv)
    if a.smoke:
        a.num = [100]
    res = {"when": time.strftime("%Y-%m-%d %H:%M"), "command": "python benchmarks/plot_speed.py"
           + (" --smoke" if a.smoke else " --num " + " ".join(map(str, a.num))), "sizes": []}
    with tempfile.TemporaryDirectory() as tmp:
        for num in sorted({a.num[0] // 10, *a.num}):
            h5 = os.path.join(tmp, f"d{num}.h5")
            sets = [f"sweep.omega={{start=1.5, stop=2.5, num={num}}}", "initial.count=8",
                    "run.transient=300", "run.record=160", 'output.keep=["impacts"]']
            sweep_s, _ = run(["sweep", SCENE, "-o", h5, "--no-progress", "--overwrite",
                              *sum((["--set", s] for s in sets), [])])
            import h5py
            import numpy as np
            with h5py.File(h5) as f:
                points = int(np.isfinite(f["impacts/u"][...]).sum())
            row = {"omega_values": num, "points": points, "sweep_seconds": sweep_s}
            for ext in ("png", "pdf"):
                fig = os.path.join(tmp, f"d{num}.{ext}")
                row[f"plot_{ext}_seconds"], row[f"peak_mib_{ext}"] = run(["plot", h5, "-o", fig])
                row[f"{ext}_mib"] = os.path.getsize(fig) / 2**20
            res["sizes"].append(row)
            print(", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}"
                            for k, v in row.items()), flush=True)
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.out, "plot_speed.json"), "w") as fh:
        json.dump(res, fh, indent=1)


if __name__ == "__main__":
    main()
