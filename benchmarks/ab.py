"""A/B throughput of the flow kernel: two source trees, alternated in one run.

    python benchmarks/ab.py TREE_A TREE_B [--rounds 5] [--num 200] [--scene fig04c]

Each round times ``run_items`` (kernel + cycle analysis, as benchmarks/run.py's
``bench_flow``, one thread, best of 3 by process CPU time, which the other users
of this shared machine disturb less than wall time) on the scene in a fresh
process for tree A, then for tree B,
with each tree first on ``sys.path``; the numba cache of each tree is warmed
first.  Alternating the two in one run exposes both to the same machine load
(this machine is shared); the report gives each round's ratio B / A and the
median.  TREE may be a git commit (exported with ``git archive`` to a temporary
folder) or a directory.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

CHILD = r"""
import json, sys
sys.path.insert(0, {tree!r})
sys.path.insert(1, {bench!r})
import cornerbif
assert cornerbif.__file__.startswith({tree!r}), cornerbif.__file__
import run as R
sc = R._scene({scene!r}, **{{"sweep.omega.num": {num}}}) if {scene!r} == "fig04c" else \
     R._scene({scene!r}, **{{"sweep.kappa.num": {num}}})
import time, numba
from cornerbif import sweep
numba.set_num_threads(1)
prm, ics = R._items(sc)
ints = sweep.int_settings(sc)
sweep.run_items(prm[:8], ics[:8], ints, sc)
best = float("inf")
for _ in range(3):
    c0 = time.process_time()
    sweep.run_items(prm, ics, ints, sc)
    best = min(best, time.process_time() - c0)
n_imp = len(prm) * (sc.transient + sc.record)
print(json.dumps({{"impacts_per_second": n_imp / best, "cpu_seconds": best}}))
"""


def _tree(spec, tmp):
    if os.path.isdir(spec):
        return os.path.abspath(spec)
    out = os.path.join(tmp, spec)
    os.makedirs(out)
    arch = subprocess.run(["git", "-C", ROOT, "archive", spec], check=True, capture_output=True)
    subprocess.run(["tar", "-x", "-C", out], input=arch.stdout, check=True)
    return out


def _bench(tree, scene, num):
    code = CHILD.format(tree=tree, bench=os.path.join(ROOT, "benchmarks"), scene=scene, num=num)
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       env=dict(os.environ, PYTHONPATH=tree))
    if p.returncode != 0:
        raise RuntimeError(p.stderr)
    return json.loads(p.stdout.strip().splitlines()[-1])


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--num", type=int, default=200)
    ap.add_argument("--scene", default="fig04c")
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        ta, tb = _tree(a.a, tmp), _tree(a.b, tmp)
        _bench(ta, a.scene, 4)
        _bench(tb, a.scene, 4)          # warm both numba caches
        ratios = []
        for k in range(a.rounds):
            ra = _bench(ta, a.scene, a.num)
            rb = _bench(tb, a.scene, a.num)
            ratios.append(rb["impacts_per_second"] / ra["impacts_per_second"])
            print(f"round {k}: A {ra['impacts_per_second'] / 1e6:.3f} M/s, "
                  f"B {rb['impacts_per_second'] / 1e6:.3f} M/s, B/A {ratios[-1]:.3f}", flush=True)
    print(f"median B/A over {a.rounds} rounds: {statistics.median(ratios):.3f} "
          f"(min {min(ratios):.3f}, max {max(ratios):.3f})")


if __name__ == "__main__":
    main()
