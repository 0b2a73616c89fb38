"""Cold compile times of the kernels, per entry: what a first run after an install waits for.

    python benchmarks/compile_time.py [--only LABEL ...] [--json FILE]

Each entry of ``ENTRIES`` is a command (a tiny sweep or continuation through the CLI) run in
a fresh NUMBA_CACHE_DIR of its own, three times: first its ``warm`` prerequisite (untimed: the
kernels an entry shares with another, e.g. the flow kernel under the flow stability kernel),
then the entry cold, then the entry again warm; the compile time is cold less warm (process
start and the tiny run's work cancel).  The numba functions the cold run compiled are the
cache index files it left (``*.nbi``), listed by module and name: what
``engine.announce_compiles`` checks for each entry.  The numbers in the models' declarations
(``COMPILE_SECONDS`` in ``cornerbif/models/*/model.py``) come from this table; users see them
rounded, as the time a compile took on the machine that ran this (``engine.compile_words``).
"""

from __future__ import annotations

import argparse
import glob
import json
import os
import re
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
TINY = ["--set", "initial.count=1", "--set", "run.transient=4", "--set", "run.record=8"]


def sweep(scene, *sets, axis=None):
    cmd = ["sweep", f"configs/{scene}.toml", "-o", "{tmp}/out.h5", "--overwrite", "--no-progress",
           *TINY]
    if axis:
        cmd += ["--set", f"sweep.{axis}.num=2"]
    for s in sets:
        cmd += ["--set", s]
    return cmd


def cont(scene, *sets):
    cmd = ["continue", f"configs/{scene}.toml", "-o", "{tmp}/cont.h5", "--overwrite"]
    for s in sets:
        cmd += ["--set", s]
    return cmd


STAB = 'output.keep=["impacts", "stability"]'
# the cycle analysis and the file's chunk writer alone (every sweep calls them), with the
# argument types a sweep passes (``engine.compile_analysis``, the second process's work)
ANALYSIS = ["python", "from cornerbif.engine import compile_analysis; compile_analysis()"]
# (label, command, warm prerequisite or None)
ENTRIES = [
    ("cycle analysis", ANALYSIS, None),
    ("flow", sweep("fig04c", axis="omega"), ANALYSIS),
    ("flow, a start time t0 (obstacle heights)", sweep("fig04c", "initial.t=[0.0, 1.0]",
                                                       axis="omega"),
     sweep("fig04c", axis="omega")),
    ("flow, a cam profile", sweep("cam_cycloidal", axis="omega"), sweep("fig04c", axis="omega")),
    ("flow stability", sweep("fig04c", STAB, axis="omega"), sweep("fig04c", axis="omega")),
    ("two_particle", sweep("fig19a", axis="omega0"), sweep("fig04c", axis="omega")),
    ("two_particle stability", sweep("fig19a", STAB, axis="omega0"),
     sweep("fig19a", axis="omega0")),
    ("map2d", sweep("fig15b", axis="kappa"), sweep("fig04c", axis="omega")),
    ("map2d stability", sweep("fig15b", 'output.keep=["section", "stability"]', axis="kappa"),
     sweep("fig15b", axis="kappa")),
    ("linear", sweep("bouncing_ball", axis='"contact.T.beta"'), ANALYSIS),
    ("flow continuation", cont("cont_beta"), sweep("fig04c", axis="omega")),
    ("two_particle continuation", cont("cont_fig19"), sweep("fig19a", axis="omega0")),
]


def run(cmd, tmp, env):
    if cmd[0] == "python":
        argv = [sys.executable, "-c", cmd[1]]
    else:
        argv = [sys.executable, "-m", "cornerbif.cli", *[c.replace("{tmp}", tmp) for c in cmd]]
    t0 = time.perf_counter()
    p = subprocess.run(argv, cwd=ROOT, env=env, capture_output=True, text=True)
    dt = time.perf_counter() - t0
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(argv)[:200]}: exit {p.returncode}\n{p.stderr[-1500:]}")
    return dt


def functions(cache):
    """module.function of every cache index file under ``cache``."""
    out = set()
    for f in glob.glob(os.path.join(cache, "**", "*.nbi"), recursive=True):
        m = re.match(r"(.+)-\d+\.py\d+\.nbi$", os.path.basename(f))
        if m:
            out.add(m.group(1))
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--only", nargs="+", default=None)
    ap.add_argument("--json", default=None)
    a = ap.parse_args()
    rows = []
    print(f"{'entry':44s} {'cold s':>8s} {'warm s':>8s} {'compile s':>10s}  functions compiled")
    for label, cmd, warm in ENTRIES:
        if a.only and label not in a.only:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            env = dict(os.environ, NUMBA_CACHE_DIR=os.path.join(tmp, "numba"),
                       MPLBACKEND="Agg", NUMBA_NUM_THREADS="2")
            if warm:
                run(warm, tmp, env)
            before = functions(env["NUMBA_CACHE_DIR"])
            cold = run(cmd, tmp, env)
            new = sorted(functions(env["NUMBA_CACHE_DIR"]) - before)
            hot = run(cmd, tmp, env)
        rows.append({"entry": label, "cold": cold, "warm": hot, "compile": cold - hot,
                     "functions": new})
        print(f"{label:44s} {cold:8.1f} {hot:8.1f} {cold - hot:10.1f}  {', '.join(new)}",
              flush=True)
    if a.json:
        with open(a.json, "w") as fh:
            json.dump(rows, fh, indent=1)


if __name__ == "__main__":
    main()
