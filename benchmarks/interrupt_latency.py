"""Seconds from Ctrl-C (SIGINT) to the end of ``cornerbif sweep``, at random moments.

    python benchmarks/interrupt_latency.py [--trials 8] [--only LABEL ...] [--seed 1]
    python benchmarks/interrupt_latency.py --cost [--rounds 9] [--scene fig04c]
    python benchmarks/interrupt_latency.py --stability [--count 16]

Each scene of ``SCENES`` is swept through the CLI in a subprocess (numba's cache warmed
first by a tiny run of the same scene), ``--progress`` on; once the progress line shows (the
blocks have started) the sweep gets SIGINT after a random wait, uniform in [0.1, WAIT]
seconds, and the time from the signal to the process's exit is measured.  The table gives
the median and the largest of the trials, and the exit codes seen (130: interrupted; 0: the
sweep had finished first, a trial not counted).  The slow scenes run for many seconds per
run (omega = 1e9: about 1e9 obstacle pieces a run), so the signal lands inside a kernel
call; the normal ones (shipped scenes at full size) land anywhere, in a kernel, the analysis
or a write.  ``dask`` rows run the same through ``--scheduler local:2`` (the driver answers;
the workers' kernels are not stopped, the cluster is closed).

``--cost`` measures what watching costs the kernels: ``run_items`` on a whole scene (one
thread, process CPU time) with the integer settings of a plain call (no control: the loop
counts its passes only) and under a sweep's ``Control`` (the stop flag read every POLL_EVERY
passes, each finished run counted atomically), alternated round by round; the median ratio.
(``benchmarks/ab.py`` compares the plain call against another tree.)

``--stability`` measures whether the stability and Lyapunov pass of a block needs to read the
stop flag, per model (Fig. 4(c) flow, Fig. 19(a) two_particle, Fig. 15(b) map2d): one grid
point of ``--count`` starts recording run.record = MAX_RECORD events each, kept stability,
on this process's numba threads; the pass's seconds (``run_items`` with stability less without,
best of 2) and per recorded event; the largest block this machine's memory admits (a grid of
such blocks: ``estimate.estimate_memory`` of two blocks within ``io.available_memory``) and its
pass at that rate; and the seconds from a stop set halfway through the pass to ``run_items``'
return (``KernelStopped``), or the pass's end where it does not read the flag.
"""

from __future__ import annotations

import argparse
import os
import random
import signal
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

# (label, scene, --set overrides and options, largest wait before the signal in seconds,
#  what the warm-up run keeps beside a tiny grid: the same kernels, none of the slow values)
STAB = 'output.keep=["impacts", "stability"]'
SCENES = [
    ("flow omega=1e9 (slow)", "fig06a", ["--set", "system.omega=1e9", "--set",
                                         "sweep.kappa.num=11", "--set", "initial.count=2"], 6.0,
     []),
    ("two_particle omega0=1e8 (slow)", "fig19a", ["--set", "sweep.omega0={values=[1e8]}",
                                                  "--set", "initial.count=4"], 6.0, []),
    ("map2d transient 4e9 (slow)", "fig15b", ["--set", "sweep.kappa.num=4", "--set",
                                              "initial.count=2", "--set",
                                              "run.transient=4000000000"], 6.0, []),
    ("cam omega=1e6 (slow)", "cam_cycloidal", ["--set", "sweep.omega={values=[1e6]}",
                                               "--set", "initial.count=4"], 6.0, []),
    ("fig06a (normal)", "fig06a", [], 1.5, []),
    ("fig19a (normal)", "fig19a", [], 2.0, []),
    ("fig04c stability (normal)", "fig04c", ["--set", STAB], 1.0, ["--set", STAB]),
    ("fig06a dask local:2", "fig06a", ["--scheduler", "local:2", "--set",
                                       "system.omega=1e7"], 6.0, []),
    # an empty numba cache (its own NUMBA_CACHE_DIR): the signal lands while the flow kernel
    # compiles on its first call (tens of seconds), which nothing can cut short
    ("fig04c during a cold compile", "fig04c", ["COLD"], 6.0, []),
]


def cli(args, tmp, **kw):
    env = dict(os.environ, MPLBACKEND="Agg")
    if "COLD" in args:
        args = [a for a in args if a != "COLD"]
        env["NUMBA_CACHE_DIR"] = tempfile.mkdtemp(dir=tmp)
    # SIGINT as a terminal delivers it: a shell without job control starts background jobs
    # with SIGINT ignored, and Python then keeps it ignored
    return subprocess.Popen([sys.executable, "-m", "cornerbif.cli", *args], cwd=tmp, env=env,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=_sigint_default, **kw)


def _sigint_default():
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def trial(scene, args, wait, rng, tmp):
    out = os.path.join(tmp, "out.h5")
    p = cli(["sweep", os.path.join(ROOT, "configs", scene + ".toml"), "-o", out, "--overwrite",
             "--progress", *args], tmp)
    line = ""
    while not line.startswith("sweep "):
        line = p.stderr.readline()
        if not line:
            p.wait()
            return None, p.returncode
    time.sleep(rng.uniform(0.1, wait))
    t0 = time.monotonic()
    p.send_signal(signal.SIGINT)
    p.communicate(timeout=300)
    return time.monotonic() - t0, p.returncode


def cost(scene_name, rounds):
    sys.path.insert(0, HERE)
    import numba
    import run as R

    from cornerbif import engine
    from cornerbif._jit import Control
    numba.set_num_threads(1)
    sc = R._scene(scene_name)
    prm, ics = R._items(sc)
    plain = engine.int_settings(sc)
    watched = engine.with_control(sc, plain, Control())
    engine.run_items(prm[:8], ics[:8], watched, sc)
    engine.run_items(prm[:8], ics[:8], plain, sc)
    ratios = []
    for i in range(rounds):
        t = {}
        for name, ints in (("plain", plain), ("watched", watched))[::1 if i % 2 else -1]:
            c0 = time.process_time()
            engine.run_items(prm, ics, ints, sc)
            t[name] = time.process_time() - c0
        ratios.append(t["watched"] / t["plain"])
        print(f"round {i}: plain {t['plain']:.3f} s, watched {t['watched']:.3f} s, ratio "
              f"{ratios[-1]:.3f}", flush=True)
    q = statistics.quantiles(ratios, n=4)
    print(f"{scene_name}: watched / plain median {statistics.median(ratios):.3f} "
          f"(quartiles {q[0]:.3f} - {q[2]:.3f}) over {rounds} rounds")


# (model, scene, its first axis, keep with stability, the module and name of the stability
# kernel its run_items calls)
STABILITY_SCENES = [
    ("flow", "fig04c", "omega", 'output.keep=["impacts", "stability"]',
     "cornerbif.models.flow.model", "batch_stability"),
    ("two_particle", "fig19a", "omega0", 'output.keep=["impacts", "stability"]',
     "cornerbif.stability", "batch_two_particle_stability"),
    ("map2d", "fig15b", "kappa", 'output.keep=["section", "stability"]',
     "cornerbif.models.map2d.model", "batch_map_stability")]


def _run_items_to_end(spec, prm, ics, ints, scene, box):
    from cornerbif._jit import KernelStopped
    try:
        spec.run_items(prm, ics, ints, scene)
        box["end"] = "finished"
    except KernelStopped:
        box["end"] = "KernelStopped"


def stability_pass(count):
    import dataclasses
    import importlib
    import threading

    import numpy as np

    from cornerbif import config, engine, io, registry
    from cornerbif._jit import Control
    from cornerbif.config import MAX_RECORD
    from cornerbif.estimate import PROCESS_BASELINE, estimate_memory
    avail = io.available_memory()
    print(f"{'model':13s} {'events':>9s} {'pass s':>7s} {'ns/event':>9s} {'largest block':>14s} "
          f"{'its pass s':>10s}  stop -> return s")
    for model, name, axis, keep, module, kernel in STABILITY_SCENES:
        sets = [f"sweep.{axis}.num=1", f"initial.count={count}", "run.transient=100",
                f"run.record={MAX_RECORD}", keep]
        sc = config.load(os.path.join(ROOT, "configs", name + ".toml"), sets)
        spec = registry.get(sc.model)
        idx, _ = engine.block_indices(sc, (slice(0, 1),))
        params = spec.pack_points(sc, idx)
        ics = engine.draw_initial(sc, np.zeros(1, np.int64), spec.wall_at_start(params), params)
        prm, ics = np.repeat(params, count, axis=0), ics.reshape(count, -1)
        ints = engine.int_settings(sc)
        spec.run_items(prm[:2], ics[:2], ints, sc)
        # the stability kernel timed, and its start told, from inside run_items
        mod = importlib.import_module(module)
        real = getattr(mod, kernel)
        began = threading.Event()
        spent = []

        def timed(*args, real=real, began=began, spent=spent):
            began.set()
            t0 = time.perf_counter()
            real(*args)
            spent.append(time.perf_counter() - t0)
        setattr(mod, kernel, timed)
        try:
            for _ in range(2):
                spec.run_items(prm, ics, ints, sc)
            seconds = min(spent)
            events = count * MAX_RECORD
            # the starts of one grid point whose two blocks (a grid of them) fit the memory
            lo, hi = 1, 2**20
            while lo < hi:
                mid = (lo + hi + 1) // 2
                two = 2 * estimate_memory(dataclasses.replace(sc, n_ic=mid)) - PROCESS_BASELINE
                lo, hi = (mid, hi) if avail is None or two <= avail else (lo, mid - 1)
            largest = lo * MAX_RECORD
            control = Control()
            box = {}
            began.clear()
            th = threading.Thread(target=_run_items_to_end, args=(
                spec, prm, ics, engine.with_control(sc, ints, control), sc, box))
            th.start()
            began.wait()
            time.sleep(seconds / 2)
            t0 = time.perf_counter()
            control.stop()
            th.join()
            stop = time.perf_counter() - t0
        finally:
            setattr(mod, kernel, real)
        print(f"{model:13s} {events:9d} {seconds:7.3f} {seconds / events * 1e9:9.1f} "
              f"{largest:14.3g} {largest * seconds / events:10.1f}  {stop:.3f} ({box.get('end')})",
              flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--cost", action="store_true")
    ap.add_argument("--stability", action="store_true")
    ap.add_argument("--count", type=int, default=16)
    ap.add_argument("--rounds", type=int, default=9)
    ap.add_argument("--scene", default="fig04c")
    ap.add_argument("--trials", type=int, default=8)
    ap.add_argument("--only", nargs="+", default=None)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    if a.cost:
        return cost(a.scene, a.rounds)
    if a.stability:
        return stability_pass(a.count)
    rng = random.Random(a.seed)
    print(f"{'scene':34s} {'trials':>6s} {'median s':>9s} {'max s':>7s}  exit codes")
    for label, scene, args, wait, warm_args in SCENES:
        if a.only and not any(o in label for o in a.only):
            continue
        with tempfile.TemporaryDirectory() as tmp:
            warm = cli(["sweep", os.path.join(ROOT, "configs", scene + ".toml"), "-o",
                        os.path.join(tmp, "warm.h5"), "--no-progress", *warm_args,
                        "--set", "initial.count=1", "--set", "run.transient=2",
                        "--set", "run.record=2"], tmp)
            warm.communicate()
            lat, codes = [], []
            for _ in range(a.trials):
                dt, rc = trial(scene, args, wait, rng, tmp)
                codes.append(rc)
                if rc == 130 and dt is not None:
                    lat.append(dt)
        med = statistics.median(lat) if lat else float("nan")
        print(f"{label:34s} {len(lat):6d} {med:9.3f} {max(lat, default=float('nan')):7.3f}  "
              f"{sorted(set(codes))}", flush=True)


if __name__ == "__main__":
    main()
