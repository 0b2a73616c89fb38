"""The sweep's time estimate against measured times, and the time model's coefficients.

    python benchmarks/estimate_time.py [--threads 2] [--only NAME ...]
    python benchmarks/estimate_time.py --calibrate

Default: each scene of ``SCENES`` (shipped scenes, some with ``--set`` overrides that make
runs cross many obstacle pieces or section periods per impact) is swept in a subprocess
(``sweep.run_sweep`` timed alone, after a tiny sweep of the same scene has loaded its
kernels) and the table gives the measured wall seconds (and the process's CPU seconds over
the threads: this machine is shared, and other users' load stretches the wall time) beside
``estimate.estimate_time``'s middle, range and reasons, and their ratio; last, the CPU time per
impact asked for (transient + record, every run): a cam's ``COST_IMPACT`` is that of the
shipped cam_cycloidal sweep (``--only cam_cycloidal``).

``--calibrate`` measures the coefficients of the time model (``COST_IMPACT``,
``COST_PIECE`` in ``models/flow/model.py``, ``COST_IMPACT``, ``COST_SECTION`` in
``models/two_particle/model.py``): runs of 300 impacts from t = 0 (transient 0, so the last
impact's time is the run's span), one numba thread, process CPU time, best of 2, at three
speeds of the obstacle per scene; pieces crossed = span / piece length (section periods for
two_particle).  The per-piece cost is read at the fastest obstacle (pieces dominate), the
per-impact cost at the slowest, less its pieces, per impact asked for (300: a run that ends
early, e.g. on its event budget, still counts 300).
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)

# (label, scene, --set overrides)
SCENES = [
    ("fig06a", "fig06a", []),
    ("fig04c", "fig04c", []),
    ("fig19a", "fig19a", []),
    ("cam_cycloidal", "cam_cycloidal", []),
    ("fig09_map", "fig09_map", []),
    ("fig04c stability", "fig04c", ['output.keep=["impacts", "stability"]']),
    ("fig19a stability", "fig19a", ['output.keep=["impacts", "stability"]',
                                    "sweep.omega0.num=201"]),
    ("fig06a omega=2e4 sigma=0.01", "fig06a",
     ["system.omega=2e4", "system.sigma=0.01", "sweep.kappa.num=6", "initial.count=2"]),
    ("fig06a omega=1e7", "fig06a", ["system.omega=1e7", "sweep.kappa.num=11",
                                    "initial.count=2"]),
    ("fig06a omega=1e9", "fig06a", ["system.omega=1e9", "sweep.kappa.num=2",
                                    "initial.count=2"]),
    ("fig19a omega0=2e3", "fig19a", ["sweep.omega0={start=2000, stop=2001, num=8}",
                                     "initial.count=2"]),
    ("cam_cycloidal omega=1e3", "cam_cycloidal", ["sweep.omega={start=1000, stop=1001, num=4}",
                                                  "initial.count=2"]),
    ("two_stops", "two_stops", []),
    ("bouncing_ball", "bouncing_ball", []),
    ("fig06a_linear", "fig06a_linear", []),
    ("two_stops k=1e4", "two_stops", ["system.stiffness=[1e4]",
                                      'sweep."forcing.0.Omega".num=2', "initial.count=2"]),
    ("two_stops omega=1e4", "two_stops", ['system.contact.R.obstacle="rectified_sine"',
                                          "system.contact.R.beta=1e-3",
                                          "system.contact.R.omega=1e4",
                                          'sweep."forcing.0.Omega".num=2', "initial.count=2"]),
]

CHILD = r"""
import json, os, sys, time
sys.path.insert(0, {root!r})
from cornerbif import config
from cornerbif.estimate import estimate_time
from cornerbif.sweep import run_sweep
import numpy as np
path = os.path.join({root!r}, "configs", {scene!r} + ".toml")
tiny_sets = list({sets!r}) + ["initial.count=1", "run.transient=2", "run.record=2"]
sc0 = config.load(path, tiny_sets)
for a in sc0.axes:     # one grid point: the tiny sweep loads the same kernels
    tiny_sets.append(f'sweep."{{a.name}}"={{{{values=[{{float(a.values[0])!r}}]}}}}')
sc0 = config.load(path, tiny_sets)
run_sweep(sc0, os.path.join({tmp!r}, "tiny.h5"), threads={threads}, overwrite=True)
sc = config.load(path, {sets!r})
est = estimate_time(sc, {threads})
t0 = time.perf_counter()
c0 = time.process_time()
run_sweep(sc, os.path.join({tmp!r}, "out.h5"), threads={threads}, overwrite=True)
print(json.dumps({{"measured": time.perf_counter() - t0, "estimate": est.seconds,
                  "cpu": time.process_time() - c0,
                  "low": est.low, "high": est.high, "reasons": list(est.reasons),
                  "runs": int(np.prod(sc.shape or (1,))) * sc.n_ic,
                  "asked": sc.transient + sc.record}}))
"""


def check(threads, only):
    rows = []
    for label, scene, sets in SCENES:
        if only and label.split()[0] not in only and label not in only:
            continue
        with tempfile.TemporaryDirectory() as tmp:
            code = CHILD.format(root=ROOT, scene=scene, sets=sets, tmp=tmp, threads=threads)
            p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        if p.returncode != 0:
            print(f"{label}: failed\n{p.stderr[-2000:]}", flush=True)
            continue
        r = json.loads(p.stdout.strip().splitlines()[-1])
        r["label"] = label
        rows.append(r)
        ratio = r["estimate"] / r["measured"]
        inside = r["low"] <= r["measured"] <= r["high"]
        print(f"{label:28s} {r['runs']:6d} runs  measured {r['measured']:8.2f} s (CPU/threads "
              f"{r['cpu'] / threads:7.2f} s)  estimate "
              f"{r['estimate']:9.2f} s ({r['low']:.3g} .. {r['high']:.3g})  estimate/measured "
              f"{ratio:6.2f}  {'in range' if inside else 'OUT of range'}  "
              f"{r['cpu'] / (r['runs'] * r['asked']) * 1e9:.0f} ns CPU an impact asked for"
              + (f"  [{'; '.join(r['reasons'])}]" if r["reasons"] else ""), flush=True)
    return rows


CAL = r"""
import json, sys, time
sys.path.insert(0, {root!r}); sys.path.insert(0, {bench!r})
import numpy as np, numba
import run as R
from cornerbif import engine
numba.set_num_threads(1)
name, axis, v, extra = {name!r}, {axis!r}, {v!r}, {extra!r}
over = {{"initial.count": 8, "run.transient": 0, "run.record": 300, **extra}}
if axis == "kappa":
    over["system.omega"] = v
    over["sweep.kappa.num"] = 4
else:
    over[f"sweep.{{axis}}"] = f"{{{{start={{v}}, stop={{v * 1.001}}, num=4}}}}"
sc = R._scene(name, **over)
prm, ics = R._items(sc)
ints = engine.int_settings(sc)
engine.run_items(prm[:1], ics[:1], ints, sc)
best = 1e9
for _ in range(2):
    c0 = time.process_time()
    out, st, *_ = engine.run_items(prm, ics, ints, sc)
    best = min(best, time.process_time() - c0)
t = out["t"]
n = np.isfinite(t).sum(1)
span = np.nanmax(np.where(np.isfinite(t), t, -np.inf), 1)
span = np.where(np.isfinite(span), span, 0.0)
if sc.model == "flow":
    kind = sc.spec.obstacles[sc.extra["obstacle"]]
    L = kind.period(v, sc.obstacle_table) / kind.pieces_per_period(sc.obstacle_table)
else:
    L = 2 * np.pi / v
print(json.dumps({{"per_run": best / len(prm), "impacts": float(n.mean()),
                  "pieces": float((span / L).mean()),
                  "span_per_impact": float((span / np.maximum(n, 1)).mean()),
                  "status": np.bincount(st.astype(int) + 2, minlength=10)[2:].tolist()}}))
"""


def calibrate():
    cases = [("flow free (fig06a)", "fig06a", "kappa", [2.0, 200.0, 2e4], {}),
             ("flow searched (fig06a, sigma 0.01)", "fig06a", "kappa", [2.0, 200.0, 2e4],
              {"system.sigma": 0.01}),
             ("flow profile (cam_cycloidal)", "cam_cycloidal", "omega", [1.0, 100.0, 1e4], {}),
             ("two_particle (fig19a)", "fig19a", "omega0", [2.0, 200.0, 2e4], {})]
    for label, name, axis, speeds, extra in cases:
        res = []
        for v in speeds:
            code = CAL.format(root=ROOT, bench=HERE, name=name, axis=axis, v=v, extra=extra)
            p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
            if p.returncode != 0:
                print(f"{label} at {v}: failed\n{p.stderr[-1500:]}")
                break
            r = json.loads(p.stdout.strip().splitlines()[-1])
            res.append((v, r))
            print(f"{label:36s} speed {v:8g}: {r['per_run'] * 1e6:10.1f} us a run, "
                  f"{r['impacts']:.0f} impacts, {r['pieces']:.4g} pieces, span per impact "
                  f"{r['span_per_impact']:.3g}, status {r['status']}", flush=True)
        if len(res) == len(speeds):
            fast = res[-1][1]
            slow = res[0][1]
            c_piece = fast["per_run"] / fast["pieces"]
            c_imp = (slow["per_run"] - slow["pieces"] * c_piece) / 300.0
            print(f"  -> {c_imp * 1e9:.0f} ns an impact, {c_piece * 1e9:.1f} ns a piece "
                  "(section period for two_particle)", flush=True)


CAL_LINEAR = r"""
import json, sys, time
sys.path.insert(0, {root!r})
import numba
import numpy as np
import cornerbif
numba.set_num_threads(1)
table = {table!r}
kw = dict(model="linear", table=table, transient=0, record={record}, max_periods={periods})
cornerbif.simulate(x0=[0.0], v_x0=[0.1], **kw)          # compiled, not timed
x0 = np.linspace(-0.05, 0.05, 8)
best = 1e9
for _ in range(2):
    c0 = time.process_time()
    r = cornerbif.simulate(x0=x0, v_x0=np.zeros(8), **kw)
    best = min(best, time.process_time() - c0)
n = np.isfinite(r["t"]).sum(1)
span = float(np.nanmax(r["t"], axis=1).mean())
print(json.dumps({{"per_run": best / 8, "impacts": float(n.mean()), "span": span,
                  "status": np.bincount(np.asarray(r["status"]).astype(int) + 2,
                                        minlength=10)[2:].tolist()}}))
"""


def _linear_case(k, contact, record, periods):
    """A one-coordinate linear system x'' + k x = 0.5 cos t (undamped, k != 1: off resonance)
    with ``contact``."""
    return {"dofs": ["x"], "mass": [1.0], "stiffness": [k], "damping": [0.0],
            "forcing": [{"on": "x", "F": 0.5, "Omega": 1.0}],
            "contact": [dict({"name": "S", "gap": {"x": 1.0}, "r": 0.8}, **contact)]}


def calibrate_linear():
    """The linear model's time model (``COST_IMPACT``, ``COST_CHUNK``, ``COST_PIECE`` in
    ``models/linear/model.py``): per run of 8, one numba thread, process CPU time, best of 2.
    A chunk: a run that never meets its stop (kappa = -100) flies its whole budget in chunks of
    1 / |A| (|A| about k); a piece: the same with a rectified sine of omega = 1e4 far below
    (pieces walked: budget omega / pi); an impact: the stop at x = -0.1 met about once a forcing
    period (300 impacts; the span is read off the run), less that span's chunks."""
    import math

    import numpy as np
    sys.path.insert(0, ROOT)
    from cornerbif.models.linear import declare
    from cornerbif.models.linear.flight import augmented
    periods = 200
    cases = {
        "chunk": (_linear_case(1e4, {"kappa": -100.0}, 10, periods), 10),
        "piece": (_linear_case(4.0, {"kappa": -100.0, "obstacle": "rectified_sine",
                                     "beta": 0.1, "omega": 1e4}, 10, periods), 10),
        "impact": (_linear_case(4.0, {"kappa": -0.1}, 300, 10**6), 300),
    }
    res = {}
    for name, (table, record) in cases.items():
        code = CAL_LINEAR.format(root=ROOT, table=table, record=record,
                                 periods=periods if name != "impact" else 10**6)
        p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
        if p.returncode != 0:
            print(f"linear {name}: failed\n{p.stderr[-1500:]}")
            return
        res[name] = json.loads(p.stdout.strip().splitlines()[-1])
        print(f"linear {name:7s}: {res[name]['per_run'] * 1e6:10.1f} us a run, "
              f"{res[name]['impacts']:.0f} impacts over t = {res[name]['span']:.4g}, status "
              f"{res[name]['status']}", flush=True)
    budget = periods * 2 * math.pi          # max_periods of the system's period 2 pi
    sys_c, _ = declare.read_system(cases["chunk"][0])
    normA = float(np.linalg.norm(augmented(sys_c), 2))
    c_chunk = res["chunk"]["per_run"] / (budget * normA)
    sys_p, _ = declare.read_system(cases["piece"][0])
    normA_p = float(np.linalg.norm(augmented(sys_p), 2))
    pieces = budget * 1e4 / math.pi
    c_piece = (res["piece"]["per_run"] - budget * normA_p * c_chunk) / pieces
    span = res["impact"]["span"]
    sys_i, _ = declare.read_system(cases["impact"][0])
    normA_i = float(np.linalg.norm(augmented(sys_i), 2))
    c_imp = (res["impact"]["per_run"] - span * normA_i * c_chunk) / 300.0
    print(f"  -> {c_imp * 1e9:.0f} ns an impact, {c_chunk * 1e9:.1f} ns a chunk, "
          f"{c_piece * 1e9:.1f} ns a piece", flush=True)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--only", nargs="+", default=None)
    ap.add_argument("--calibrate", action="store_true")
    a = ap.parse_args()
    if a.calibrate:
        calibrate()
        calibrate_linear()
    else:
        check(a.threads, a.only)


if __name__ == "__main__":
    main()
