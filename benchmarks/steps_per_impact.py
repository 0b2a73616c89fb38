"""Certified search steps per impact, flow against two_particle: the work each kernel does.

    python benchmarks/steps_per_impact.py [--points 3] [--impacts 300]

The kernels run as plain Python (``NUMBA_DISABLE_JIT=1``, set here before numba loads), with
counters wrapped around the functions that make one step of each search, so the counts are
those of the compiled kernels' code paths (the same source, the same branches):

- flow (Fig. 4(c), ``[system]`` of configs/fig04c.toml): a flight's search is ``sturm_clear``
  (a closed-form test that settles most flights without stepping) and, where that does not
  settle it, ``first_impact_free`` whose steps are ``roots.bracket`` calls (``first_root``
  and its ``evaluate`` calls for damped, forced or sticking phases);
- two_particle (Fig. 19(a), configs/fig19a.toml): each search is ``first_root`` (or
  ``first_root_g``), one ``evaluate`` per step (``_evaluate_g``).

Reported per impact of the run (u-z impacts for two_particle, the unit of its throughput in
benchmarks/run.py, with the wall impacts between them counted too).
"""

from __future__ import annotations

import argparse
import collections
import os
import sys

os.environ["NUMBA_DISABLE_JIT"] = "1"
HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.dirname(HERE))

import numpy as np  # noqa: E402

from cornerbif import config, engine  # noqa: E402
from cornerbif.models.flow import kernel as FK  # noqa: E402
from cornerbif.models.two_particle import kernel as TK  # noqa: E402

COUNTS: collections.Counter = collections.Counter()


def counted(module, name, label):
    fn = getattr(module, name)

    def wrapper(*args, **kws):
        COUNTS[label] += 1
        return fn(*args, **kws)
    setattr(module, name, wrapper)


def run(scene_name, axis, points, impacts):
    scene = config.load(os.path.join(os.path.dirname(HERE), "configs", f"{scene_name}.toml"),
                        [f"run.transient={impacts // 2}", f"run.record={impacts - impacts // 2}",
                         "initial.count=2", f"sweep.{axis}.num={points}", "run.stop=\"none\""])
    COUNTS.clear()
    done = 0
    for blk in engine.blocks(scene):
        out = engine.compute_block(scene, blk)
        done += int(np.isfinite(out["t"]).sum()) if "t" in out else 0
    return dict(COUNTS), scene.n_ic * int(np.prod(scene.shape)) * impacts


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--points", type=int, default=3)
    ap.add_argument("--impacts", type=int, default=300)
    a = ap.parse_args()
    counted(FK, "sturm_clear", "flow: Sturm tests")
    counted(FK, "first_impact_free", "flow: stepped searches (free flight)")
    counted(FK, "bracket", "flow: steps (free flight)")
    counted(FK, "first_root", "flow: searches (damped, forced, sticking)")
    counted(FK, "evaluate", "flow: steps (damped, forced, sticking)")
    counted(TK, "first_root", "two_particle: searches")
    counted(TK, "evaluate", "two_particle: steps")
    counted(TK, "first_root_g", "two_particle: searches (damped/forced)")
    counted(TK, "_evaluate_g", "two_particle: steps (damped/forced)")
    for scene, axis, unit in [("fig04c", "omega", "impact"), ("fig19a", "omega0", "u-z impact")]:
        counts, n_imp = run(scene, axis, a.points, a.impacts)
        print(f"{scene}: {n_imp} {unit}s ({a.points} points x 2 starts x {a.impacts})")
        for label, c in sorted(counts.items()):
            print(f"  {label:45s} {c:9d}  {c / n_imp:6.2f} per {unit}")


if __name__ == "__main__":
    main()
