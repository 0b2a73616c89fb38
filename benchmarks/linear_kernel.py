"""The linear model's jitted event loop (cornerbif/models/linear/kernel.py, issue 33) against
the flow kernel on the same system, measured in one run:

    python benchmarks/linear_kernel.py [--impacts N] [--rounds R]

One mass against the rectified sine at omega = 1.8 (Fig. 4's obstacle, a period-4 orbit)
from (5, 0): N impacts by each kernel, one thread, compiled before timing; the median of R
paired rounds and the ratio linear / flow.  The linear loop resolves each impact by halving
on its ladder of flights (about 40 levels); the flow kernel by its certified closed-form
search.

    python benchmarks/linear_kernel.py --dofs [--impacts N]

The throughput against the number of coordinates N = 1 .. 6 (MAX_DOFS): a chain of N unit
masses (K tridiagonal 2, -1: springs between neighbours and to the ground at both ends),
the first against the rectified sine at omega = 1.8, r = 0.8, from rest at x_1 = 5: the
augmented state has 2N coordinates, and each flight's ladder products grow as N^2."""

from __future__ import annotations

import argparse
import statistics
import time

import numba
import numpy as np

import cornerbif
from cornerbif.models.linear.kernel import run_system
from cornerbif.models.linear.system import Contact, LinearSystem


def main(argv=None):
    ap = argparse.ArgumentParser()
    ap.add_argument("--impacts", type=int, default=5000)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--dofs", action="store_true", help="throughput against N = 1 .. 6")
    a = ap.parse_args(argv)
    numba.set_num_threads(1)
    if a.dofs:
        return scan_dofs(a.impacts)
    s = LinearSystem(("u",), np.array([[1.0]]), np.array([[1.0]]), np.array([[0.0]]), (),
                     (Contact("R", np.array([1.0]), "rectified_sine", 0.0, 1.0, 1.8, r=0.8),))
    flow = dict(model="flow", obstacle="rectified_sine", omega=1.8, kappa=0.0, beta=1.0, r=0.8)
    t0 = time.perf_counter()
    run_system(s, 0.0, [5.0], [0.0], 10)
    compile_linear = time.perf_counter() - t0
    cornerbif.simulate(5.0, 0.0, record=10, **flow)
    rows = []
    for _ in range(a.rounds):
        t0 = time.perf_counter()
        st, out = run_system(s, 0.0, [5.0], [0.0], a.impacts, t_max=1e12)
        lin = time.perf_counter() - t0
        t0 = time.perf_counter()
        ref = cornerbif.simulate(5.0, 0.0, record=a.impacts, **flow)
        fl = time.perf_counter() - t0
        assert len(out["t"]) == a.impacts and np.isfinite(np.ravel(ref["t"])).all()
        rows.append((a.impacts / lin, a.impacts / fl))
    lin = statistics.median(r[0] for r in rows)
    fl = statistics.median(r[1] for r in rows)
    print(f"linear kernel: {lin / 1e6:.3f} M impacts/s; flow kernel (cornerbif.simulate, with "
          f"its analysis): {fl / 1e6:.3f} M impacts/s; ratio {lin / fl:.3f} "
          f"({a.impacts} impacts, median of {a.rounds} rounds, one thread; the linear loop's "
          f"first call took {compile_linear:.1f} s with its compile, if not cached)")



def scan_dofs(impacts):
    """Impacts per second of the linear loop for chains of N = 1 .. 6 masses (module doc)."""
    from cornerbif.models.linear.system import MAX_DOFS
    run_system(chain(1), 0.0, [5.0], [0.0], 10)            # compiled (or loaded) first
    print("| N | impacts/s | per impact, us |\n|---|---|---|")
    for n in range(1, MAX_DOFS + 1):
        s = chain(n)
        x0, v0 = np.zeros(n), np.zeros(n)
        x0[0] = 5.0
        t0 = time.perf_counter()
        st, out = run_system(s, 0.0, x0, v0, impacts, t_max=1e12)
        dt = time.perf_counter() - t0
        k = len(out["t"])
        print(f"| {n} | {k / dt / 1e6:.3f} M | {dt / k * 1e6:.1f} |")


def chain(n):
    """N unit masses, springs 1 between neighbours and to the ground at both ends; the first
    against the rectified sine (omega = 1.8, r = 0.8)."""
    K = 2.0 * np.eye(n) - np.eye(n, k=1) - np.eye(n, k=-1)
    gap = np.zeros(n)
    gap[0] = 1.0
    return LinearSystem(tuple(f"x{i}" for i in range(n)), np.eye(n), K, np.zeros((n, n)), (),
                        (Contact("R", gap, "rectified_sine", 0.0, 1.0, 1.8, r=0.8),))


if __name__ == "__main__":
    main()
