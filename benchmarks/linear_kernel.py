"""The linear model's jitted event loop (cornerbif/models/linear/kernel.py, issue 33) against
the paper's kernels on the same systems, measured in one run:

    python benchmarks/linear_kernel.py [--impacts N] [--rounds R]

Two rows, each the median of R paired rounds (one thread, compiled before timing) and the
ratio linear / other in impacts per second:

* one mass against the rectified sine at omega = 1.8 (Fig. 4's obstacle, a period-4 orbit)
  from (5, 0), against the flow kernel (through ``cornerbif.simulate``, with its analysis):
  N impacts each;
* Fig. 19(a)'s two particles at omega0 = 2 (z on the wall W, u on z), against the
  two-particle kernel: the two-particle kernel records N u-z impacts and resolves the w-z
  impacts between them (both counted: its recorded u-z and w-z impacts over the same time);
  the linear loop resolves both contacts' impacts alike, N of them.

The linear loop resolves each impact by certified steps on a chunk's gap polynomial
(kernel.py).

    python benchmarks/linear_kernel.py --sweeps [--rounds R] [--points P]

Whole sweeps (``sweep.run_sweep``: kernels, cycle analysis, the HDF5 file; the machine's
threads), paired rounds in one process: Fig. 6(a) (configs/fig06a.toml) against
configs/fig06a_linear.toml, Fig. 4(c) (configs/fig04c.toml) against the same system
written as a linear scene, and Fig. 19(a) (configs/fig19a.toml, the two-particle model)
against configs/fig19a_linear.toml (its words by ``[system] words``), each on P points of
its axis (default 400) with its own starts and run settings; the ratio of the sweeps' rates,
linear / the paper's model.

    python benchmarks/linear_kernel.py --dofs [--impacts N]

The throughput against the number of coordinates N = 1 .. 6 (MAX_DOFS): a chain of N unit
masses (K tridiagonal 2, -1: springs between neighbours and to the ground at both ends),
the first against the rectified sine at omega = 1.8, r = 0.8, from rest at x_1 = 5: the
augmented state has 2N coordinates."""

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
    ap.add_argument("--sweeps", action="store_true", help="whole sweeps, flow against linear")
    ap.add_argument("--points", type=int, default=400)
    a = ap.parse_args(argv)
    if a.sweeps:
        return compare_sweeps(a.rounds, a.points)
    numba.set_num_threads(1)
    if a.dofs:
        return scan_dofs(a.impacts)
    s = LinearSystem(("x",), np.array([[1.0]]), np.array([[1.0]]), np.array([[0.0]]), (),
                     (Contact("R", np.array([1.0]), "rectified_sine", 0.0, 1.0, 1.8, r=0.8),))
    flow = dict(model="flow", obstacle="rectified_sine", omega=1.8, kappa=0.0, beta=1.0, r=0.8)
    tp = dict(model="two_particle", omega0=2.0, omega1=OMEGA1, omega2=OMEGA2, mu=MU, r1=0.8,
              r2=0.8, kappa=0.0, beta=1.0)
    t0 = time.perf_counter()
    run_system(s, 0.0, [5.0], [0.0], 10)
    compile_linear = time.perf_counter() - t0
    cornerbif.simulate(5.0, 0.0, record=10, **flow)
    cornerbif.simulate(1.0, 0.5, 15.0, 0.0, record=10, **tp)
    pair = two_particles()
    rows = []
    for _ in range(a.rounds):
        t0 = time.perf_counter()
        st, out = run_system(s, 0.0, [5.0], [0.0], a.impacts, t_max=1e12)
        lin = time.perf_counter() - t0
        t0 = time.perf_counter()
        ref = cornerbif.simulate(5.0, 0.0, record=a.impacts, **flow)
        fl = time.perf_counter() - t0
        assert len(out["t"]) == a.impacts and np.isfinite(np.ravel(ref["t"])).all()
        t0 = time.perf_counter()
        st, out2 = run_system(pair, 0.0, [1.0, 15.0], [0.5, 0.0], a.impacts, t_max=1e12)
        lin2 = time.perf_counter() - t0
        t0 = time.perf_counter()
        ref2 = cornerbif.simulate(1.0, 0.5, 15.0, 0.0, record=a.impacts // 2, **tp)
        tp_s = time.perf_counter() - t0
        assert len(out2["t"]) == a.impacts
        uz = np.ravel(ref2["t"])
        wz = np.ravel(ref2["wz_t"])
        tp_impacts = np.isfinite(uz).sum() + np.count_nonzero(wz <= uz[-1])
        rows.append((a.impacts / lin, a.impacts / fl, a.impacts / lin2, tp_impacts / tp_s))
    m = [statistics.median(r[k] for r in rows) for k in range(4)]
    print(f"| system | linear loop | other kernel | ratio |\n|---|---|---|---|\n"
          f"| one mass, rectified sine (flow) | {m[0] / 1e6:.3f} M/s | {m[1] / 1e6:.3f} M/s | "
          f"{m[0] / m[1]:.3f} |\n"
          f"| Fig. 19(a)'s two particles (two_particle) | {m[2] / 1e6:.3f} M/s | "
          f"{m[3] / 1e6:.3f} M/s | {m[2] / m[3]:.3f} |\n"
          f"(impacts per second, every contact's; {a.impacts} impacts, median of {a.rounds} "
          f"rounds, one thread; the linear loop's first call took {compile_linear:.1f} s with "
          f"its compile, if not cached)")



def scan_dofs(impacts):
    """Impacts per second of the linear loop for chains of N = 1 .. 6 masses (module doc)."""
    from cornerbif.models.linear.kernel import prepare
    from cornerbif.models.linear.system import MAX_DOFS
    run_system(chain(1), 0.0, [5.0], [0.0], 10)            # compiled (or loaded) first
    print("| N | impacts/s | per impact, us | impacts (the run's end) | preparing the system, ms |"
          "\n|---|---|---|---|---|")
    for n in range(1, MAX_DOFS + 1):
        s = chain(n)
        x0, v0 = np.zeros(n), np.zeros(n)
        x0[0] = 5.0
        t0 = time.perf_counter()
        prepare(s, 0.0, x0, v0)
        prep = time.perf_counter() - t0
        t0 = time.perf_counter()
        st, out = run_system(s, 0.0, x0, v0, impacts, t_max=1e12)
        dt = time.perf_counter() - t0 - prep           # the loop's time alone
        k = len(out["t"])
        end = "all" if k == impacts else f"{k} (chatters to rest)" if st == 1 else f"{k} (status {st})"
        print(f"| {n} | {k / dt / 1e6:.3f} M | {dt / k * 1e6:.2f} | {end} | {prep * 1e3:.2f} |")




def fig04c_linear(root):
    """Fig. 4(c) (configs/fig04c.toml) as a linear scene: configs/fig06a_linear.toml's
    system at kappa = 0, swept over omega in [1.5, 2.5] from 4 starts."""
    import os
    text = open(os.path.join(root, "configs", "fig06a_linear.toml")).read()
    for old, new in (('"contact.R.kappa" = { start = -0.02, stop = 0.002, num = 2001 }',
                      '"contact.R.omega" = { start = 1.5, stop = 2.5, num = 1000 }'),
                     ("name = \"fig06a_linear\"", "name = \"fig04c_linear\""),
                     ("count = 8", "count = 4")):
        assert old in text, old
        text = text.replace(old, new)
    return text


def compare_sweeps(rounds, points):
    """Whole sweeps of the paper's flow scenes against the same systems as linear scenes
    (module docstring): seconds each, median of ``rounds`` paired rounds, and the ratio of
    rates linear / flow."""
    import os
    import tempfile

    from cornerbif import config
    from cornerbif.sweep import run_sweep
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

    def scene(text, axis):
        return config.loads(text, [f"sweep.{axis}.num={points}"])

    pairs = []
    for name, flow_axis, lin_text, lin_axis in (
            ("fig06a", "kappa", open(os.path.join(root, "configs", "fig06a_linear.toml")).read(),
             '"contact.R.kappa"'),
            ("fig04c", "omega", fig04c_linear(root), '"contact.R.omega"'),
            ("fig19a", "omega0", open(os.path.join(root, "configs", "fig19a_linear.toml")).read(),
             '"contact.W.omega"')):
        flow_text = open(os.path.join(root, "configs", f"{name}.toml")).read()
        pairs.append((name, scene(flow_text, flow_axis), scene(lin_text, lin_axis)))
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "s.h5")
        for _, f, lin in pairs:                       # compiled (or loaded) first
            run_sweep(f, out, overwrite=True)
            run_sweep(lin, out, overwrite=True)
        print("| sweep | points x starts | the paper's model | linear | ratio of rates |\n"
              "|---|---|---|---|---|")
        for name, f, lin in pairs:
            times = []
            for _ in range(rounds):
                t0 = time.perf_counter()
                run_sweep(f, out, overwrite=True)
                t1 = time.perf_counter()
                run_sweep(lin, out, overwrite=True)
                times.append((t1 - t0, time.perf_counter() - t1))
            tf = statistics.median(t[0] for t in times)
            tl = statistics.median(t[1] for t in times)
            print(f"| {name} | {points} x {f.n_ic} | {tf:.2f} s | {tl:.2f} s | {tf / tl:.3f} |")
    print(f"(median of {rounds} paired rounds, {numba.get_num_threads()} threads, whole "
          "sweeps with their files)")


MU, OMEGA1, OMEGA2 = 1000.0, 1.001, 1.0      # Fig. 19(a)'s two particles


def two_particles(omega0=2.0):
    """Fig. 19(a)'s system (tests/linear_systems.py): z (mass 1, omega1) above the wall
    sin(omega0 t) (contact W, law 5) and u (mass 1 / mu, omega2) above z (contact U, law
    74), r1 = r2 = 0.8."""
    return LinearSystem(("z", "x"), np.diag([1.0, 1.0 / MU]),
                        np.diag([OMEGA1 * OMEGA1, OMEGA2 * OMEGA2 / MU]), np.zeros((2, 2)), (),
                        (Contact("W", np.array([1.0, 0.0]), "sine", 0.0, 1.0, omega0, r=0.8),
                         Contact("U", np.array([-1.0, 1.0]), "fixed", 0.0, r=0.8)))


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
