"""A/B throughput of a scene's kernel: two source trees, alternated in one run.

    python benchmarks/ab.py TREE_A TREE_B [--rounds 41] [--num 50] [--scene fig04c]
    python benchmarks/ab.py TREE_A TREE_B --scene fig19a     # two_particle (its first axis)
    python benchmarks/ab.py TREE_A TREE_B --speedup --num 1000 [--rounds 25]

``--speedup`` compares how the two trees scale instead: in each turn a worker (not pinned)
runs the scene on one thread and then on two, and the report gives each tree's median
ratio of the wall times; both trees meet the same neighbours, turn by turn.

Two worker processes, one per tree (each with its tree first on ``sys.path``, its
numba cache warmed), take turns: each round times ``run_items`` (kernel + cycle
analysis, as benchmarks/run.py's ``bench_flow``, one thread, by process CPU time)
on the scene once in A, then once in B, and records B / A.  Short alternating
turns expose both trees to the same machine load: this machine is shared, and
the load of its other users moves throughput by +-30 % within minutes, so the
report gives the median ratio with its quartiles.  Both workers are pinned to one
CPU (``--cpu``): unpinned, each kept to its own core, and the two cores of this
machine differed by up to 1.3x for minutes, which flipped a comparison of one
change from 1.16x to 0.87x.  TREE may be a git commit (exported with
``git archive`` to a temporary folder) or a directory; each worker compiles into
a fresh numba cache (numba's cache does not notice an edited callee in another
module, so a tree's own cache may hold stale machine code).
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
import json, os, sys
sys.path.insert(0, {tree!r})
sys.path.insert(1, {bench!r})
import cornerbif
assert cornerbif.__file__.startswith({tree!r}), cornerbif.__file__
import run as R
import tomllib
with open(os.path.join(R.ROOT, "configs", {scene!r} + ".toml"), "rb") as fh:
    axis = next(k for k in tomllib.load(fh)["sweep"] if k != "follow")   # the first axis
key = f'"{{axis}}"' if "." in axis else axis          # a linear scene's path, quoted
sc = R._scene({scene!r}, **{{f"sweep.{{key}}.num": {num}}})
import time, numba
sweep = R.engine()
numba.set_num_threads(1)
prm, ics = R._items(sc)
ints = sweep.int_settings(sc)
sweep.run_items(prm[:8], ics[:8], ints, sc)
n_imp = len(prm) * (sc.transient + sc.record)
if {speedup!r}:
    numba.set_num_threads(2)
    sweep.run_items(prm[:64], ics[:64], ints, sc)
print("ready", flush=True)
for line in sys.stdin:
    if {speedup!r}:
        # wall time on one thread, then on two, back to back
        wall = []
        for th in (1, 2):
            numba.set_num_threads(th)
            t0 = time.perf_counter()
            sweep.run_items(prm, ics, ints, sc)
            wall.append(time.perf_counter() - t0)
        print(json.dumps({{"speedup": wall[0] / wall[1]}}), flush=True)
        continue
    c0 = time.process_time()
    sweep.run_items(prm, ics, ints, sc)
    print(json.dumps({{"impacts": n_imp, "cpu_seconds": time.process_time() - c0}}), flush=True)
"""


def _tree(spec, tmp):
    if os.path.isdir(spec):
        return os.path.abspath(spec)
    out = os.path.join(tmp, spec)
    os.makedirs(out)
    arch = subprocess.run(["git", "-C", ROOT, "archive", spec], check=True, capture_output=True)
    subprocess.run(["tar", "-x", "-C", out], input=arch.stdout, check=True)
    return out


def _child(tree, scene, num, cpu, cache, speedup=False):
    """A process on ``cpu`` (on every CPU with ``speedup``) that has imported ``tree`` and
    warmed its kernels (compiled into the numba cache folder ``cache``); each line sent to
    it runs the scene once and answers with the CPU time (with ``speedup``: once on one
    thread and once on two, answering with the ratio of the wall times)."""
    code = CHILD.format(tree=tree, bench=os.path.join(ROOT, "benchmarks"), scene=scene, num=num,
                        speedup=speedup)
    env = dict(os.environ, PYTHONPATH=tree, NUMBA_CACHE_DIR=cache)
    pin = None if speedup else (lambda: os.sched_setaffinity(0, {cpu}))
    p = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE,
                         stdout=subprocess.PIPE, text=True, env=env, preexec_fn=pin)
    if p.stdout.readline().strip() != "ready":
        raise RuntimeError(f"the child for {tree} did not start")
    return p


def _once(child):
    child.stdin.write("go\n")
    child.stdin.flush()
    r = json.loads(child.stdout.readline())
    return r["speedup"] if "speedup" in r else r["impacts"] / r["cpu_seconds"]


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("a")
    ap.add_argument("b")
    ap.add_argument("--rounds", type=int, default=41)
    ap.add_argument("--num", type=int, default=50)
    ap.add_argument("--scene", default="fig04c")
    ap.add_argument("--cpu", type=int, default=min(os.sched_getaffinity(0)),
                    help="the CPU both workers run on (default: the first allowed)")
    ap.add_argument("--speedup", action="store_true",
                    help="compare the 2-thread speed-ups (wall time, workers not pinned)")
    a = ap.parse_args(argv)
    with tempfile.TemporaryDirectory() as tmp:
        ta, tb = _tree(a.a, tmp), _tree(a.b, tmp)
        ca = _child(ta, a.scene, a.num, a.cpu, os.path.join(tmp, "cache_a"), a.speedup)
        cb = _child(tb, a.scene, a.num, a.cpu, os.path.join(tmp, "cache_b"), a.speedup)
        ratios = []
        sa, sb = [], []
        try:
            for k in range(a.rounds):
                ra = _once(ca)
                rb = _once(cb)
                ratios.append(rb / ra)
                if a.speedup:
                    sa.append(ra)
                    sb.append(rb)
                    print(f"round {k}: speed-up A {ra:.2f}, B {rb:.2f}", flush=True)
                    continue
                print(f"round {k}: A {ra / 1e6:.3f} M/s, B {rb / 1e6:.3f} M/s, "
                      f"B/A {ratios[-1]:.3f}", flush=True)
        finally:
            ca.stdin.close()
            cb.stdin.close()
            ca.wait()
            cb.wait()
    if a.speedup:
        print(f"median 2-thread speed-up over {a.rounds} rounds: A {statistics.median(sa):.3f}, "
              f"B {statistics.median(sb):.3f}")
        return
    q = statistics.quantiles(ratios, n=4) if len(ratios) > 1 else ratios * 3
    print(f"median B/A over {a.rounds} rounds: {statistics.median(ratios):.3f} "
          f"(quartiles {q[0]:.3f} - {q[2]:.3f}; min {min(ratios):.3f}, max {max(ratios):.3f})")


if __name__ == "__main__":
    main()
