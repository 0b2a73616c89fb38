"""The memory estimate against the measured peak: one grid point with 10^6 starts per model,
and a grid of many blocks (the local backend's writer holds two at once).

    python benchmarks/memory_estimate.py [--starts 1000000] [--out benchmarks/results]

For each model (flow, map2d, two_particle) a scene of one grid point with ``--starts``
starts (transient 20, record 20, every observable kept) is swept by the command under
``/usr/bin/time -v`` (peak resident memory of the whole process), after a warm-up that fills
numba's cache; ``cornerbif sweep --dry-run`` gives the estimate (``estimate.estimate_memory``,
which includes the process's own baseline).  The grid scene (``flow grid``: 40 000 values of
omega, 4 starts, 100 impacts recorded, impacts and section kept) runs many blocks, so one is
written while the next computes.  The report gives estimate / peak: the issue of
reliability asks for it within 1.5x, and an estimate below the peak is the dangerous side.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

SCENES = {
    "flow": '[scene]\nname = "m"\nmodel = "flow"\n[system]\nomega = 1.999\nkappa = -0.014\n',
    "map2d": '[scene]\nname = "m"\nmodel = "map2d"\n[system]\nomega = 1.999\nkappa = -0.01\n',
    "two_particle": '[scene]\nname = "m"\nmodel = "two_particle"\n[system]\nomega0 = 1.999\n',
}


def cli(*args, timed=False):
    cmd = [sys.executable, "-m", "cornerbif.cli", *args]
    if timed:
        cmd = ["/usr/bin/time", "-v", *cmd]
    r = subprocess.run(cmd, capture_output=True, text=True)
    if r.returncode != 0:
        raise SystemExit(f"{' '.join(args)} failed ({r.returncode}):\n{r.stderr[-2000:]}")
    return r


GRID = ('[scene]\nname = "g"\nmodel = "flow"\n[system]\nkappa = 0.0\n[sweep]\n'
        'omega = { start = 1.5, stop = 2.5, num = 40000 }\n[initial]\ncount = 4\n'
        '[run]\ntransient = 20\nrecord = 100\n[output]\nkeep = ["impacts", "section"]\n')


def measure(model, starts, tmp):
    name = model.replace(" ", "_")
    scene = os.path.join(tmp, f"{name}.toml")
    with open(scene, "w") as fh:
        if model == "flow grid":
            fh.write(GRID)
            starts = 40000 * 4
        else:
            fh.write(SCENES[model] + f"[initial]\ncount = {starts}\n[run]\ntransient = 20\n"
                     "record = 20\n")
    out = os.path.join(tmp, f"{name}.h5")
    cli("sweep", scene, "-o", out, "--overwrite", "--set", "initial.count=2",      # warm-up
        *(["--set", "sweep.omega.num=2"] if model == "flow grid" else []))
    dry = cli("sweep", scene, "-o", out, "--overwrite", "--dry-run").stdout
    est = float(re.search(r"working memory: about ([\d.]+) MiB", dry).group(1))
    r = cli("sweep", scene, "-o", out, "--overwrite", "--no-progress", timed=True)
    peak = int(re.search(r"Maximum resident set size \(kbytes\): (\d+)", r.stderr).group(1))
    wall = re.search(r"Elapsed \(wall clock\) time.*: ([\d:.]+)", r.stderr).group(1)
    return {"model": model, "starts": starts, "estimate_mib": est,
            "peak_mib": round(peak / 1024, 1), "ratio": round(est / (peak / 1024), 3),
            "wall": wall}


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--starts", type=int, default=1_000_000)
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for model in [*SCENES, "flow grid"]:
            rows.append(measure(model, args.starts, tmp))
            r = rows[-1]
            print(f"{model:13s} starts {r['starts']}: estimate {r['estimate_mib']:8.1f} MiB, "
                  f"peak {r['peak_mib']:8.1f} MiB, estimate/peak {r['ratio']:.2f} "
                  f"({r['wall']})", flush=True)
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        with open(os.path.join(args.out, "memory_estimate.json"), "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
