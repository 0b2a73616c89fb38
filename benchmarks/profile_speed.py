"""What a cam profile costs per impact against the built-in rectified sine.

Three obstacles of the same shape on the Fig. 4(c)-like scene (omega in [1.5, 2.5],
kappa = 0, r = 0.8; N omega values x 4 starts, 100 transient and 200 recorded impacts):

* ``rectified_sine``: the built-in obstacle (eq 8), with its sinusoidal fast path;
* ``profile, sine``: the same z written as a profile (one sinusoid piece per period pi);
* ``profile, poly``: |sin| replaced by its degree-6 least-squares polynomial in
  (phi - pi/2)^2 on [0, pi] (even about the hump's top, so continuous with corners at the
  joints; within 2e-5 of sin): a polynomial piece, with the generic certified search;
* ``triangle``: for reference, a built-in obstacle without the sinusoidal fast path
  (slopes 2 and 2, the generic certified search with trivial curvature bounds; another
  shape, so its impacts differ).

Each round times ``run_items`` (kernel and cycle analysis, as a sweep runs them) on one
thread for each obstacle in turn, by process CPU time; the report gives the impacts per
second of each and the median over rounds of the per-round ratios to the rectified sine.
The built-in obstacles share one compiled kernel, the profiles another
(``models.flow.kernel.run_batch_profile``); both are loaded or compiled before the rounds.

    python benchmarks/profile_speed.py [--rounds 7] [--num 200]
    python benchmarks/profile_speed.py --smoke

Writes ``profile_speed.json`` into ``--out`` (default benchmarks/results).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))


def poly_sine():
    """sin(phi) on [0, pi] as a degree-6 polynomial, even about pi/2, in powers of phi."""
    x = np.linspace(0.0, math.pi, 2001)
    y = np.sin(x)
    s = (x - math.pi / 2) ** 2
    a = np.linalg.lstsq(np.stack([s ** k for k in range(4)], 1), y, rcond=None)[0]
    P = np.polynomial.polynomial
    c = np.zeros(1)
    shift = np.array([-math.pi / 2, 1.0])          # phi - pi/2
    sq = P.polymul(shift, shift)
    term = np.array([1.0])
    for k in range(4):
        c = P.polyadd(c, a[k] * term)
        term = P.polymul(term, sq)
    err = float(np.abs(P.polyval(x, c) - y).max())
    return [float(v) for v in c], err


def scenes(num):
    from cornerbif import config
    base = f"""[scene]
name = "speed"
model = "flow"
[system]
omega = 2.0
kappa = 0.0
r = 0.8
%s
[sweep]
omega = {{ start = 1.5, stop = 2.5, num = {num} }}
[initial]
count = 4
seed = 1
[run]
transient = 100
record = 200
[output]
keep = ["impacts"]
"""
    coeffs, err = poly_sine()
    prof_sine = ('obstacle = "profile"\n[system.profile]\nperiod = 3.141592653589793\n'
                 'pieces = [ { span = 3.141592653589793, sine = [1.0, 0.0, 1.0] } ]')
    prof_poly = ('obstacle = "profile"\n[system.profile]\nperiod = 3.141592653589793\n'
                 f'pieces = [ {{ span = 3.141592653589793, poly = {coeffs!r} }} ]')
    return {"rectified_sine": config.loads(base % 'obstacle = "rectified_sine"'),
            "profile, sine": config.loads(base % prof_sine),
            "profile, poly": config.loads(base % prof_poly),
            "triangle": config.loads(base % 'obstacle = "triangle"\ntheta1 = 2.0\ntheta2 = 2.0')}, err


def items(scene):
    from cornerbif import engine, registry
    spec = registry.get(scene.model)
    idx = [(i,) for i in range(scene.shape[0])]
    params = spec.pack_points(scene, idx)
    ics = engine.draw_initial(scene, np.arange(len(idx)), spec.wall_at_start(params), params)
    return (np.repeat(params, scene.n_ic, axis=0),
            np.ascontiguousarray(ics.reshape(-1, ics.shape[-1])), spec.int_settings(scene))


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--rounds", type=int, default=7)
    ap.add_argument("--num", type=int, default=200)
    ap.add_argument("--smoke", action="store_true")
    ap.add_argument("--out", default=os.path.join(HERE, "results"))
    a = ap.parse_args(argv)
    if a.smoke:
        a.rounds, a.num = 2, 8
    import numba

    from cornerbif import registry
    numba.set_num_threads(1)
    sc, err = scenes(a.num)
    prepared = {k: items(s) for k, s in sc.items()}
    spec = registry.get("flow")
    for k, (prm, ics, ints) in prepared.items():          # warm: load or compile once
        spec.run_items(prm[:4], ics[:4], ints, sc[k])
    rates = {k: [] for k in sc}
    for _ in range(a.rounds):
        for k, (prm, ics, ints) in prepared.items():
            t0 = time.process_time()
            out = spec.run_items(prm, ics, ints, sc[k])[0]
            dt = time.process_time() - t0
            impacts = int(np.isfinite(out["t"]).sum()) * (1 + 100 / 200)   # transient too
            rates[k].append(impacts / dt)
    ref = np.array(rates["rectified_sine"])
    res = {"when": time.strftime("%Y-%m-%d %H:%M"), "rounds": a.rounds, "num": a.num,
           "poly_error": err,
           "command": "python benchmarks/profile_speed.py" + (" --smoke" if a.smoke else ""),
           "impacts_per_s": {k: float(np.median(v)) for k, v in rates.items()},
           "cost_vs_rectified_sine": {k: float(np.median(ref / np.array(v)))
                                      for k, v in rates.items()}}
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.out, "profile_speed.json"), "w") as fh:
        json.dump(res, fh, indent=1)
    for k in sc:
        print(f"{k:16s} {res['impacts_per_s'][k] / 1e6:6.2f} M impacts/s, time per impact "
              f"{res['cost_vs_rectified_sine'][k]:.2f}x the rectified sine's")
    print(f"(the polynomial is within {err:.1e} of sin on [0, pi])")


if __name__ == "__main__":
    main()
