"""Reference side of the Siconos peer, run with the PROJECT's interpreter.

    python benchmarks/siconos_ref.py IN.json OUT.json

Called by ``benchmarks/peer_siconos.py`` (which runs under the system Python that has
Siconos but neither scipy nor cornerbif).  Reads the peer's queries and writes:

* ``one_step``: for each Siconos post-impact state (t0, u0, v0), the exact next impact
  time from the exhaustive search of ``tests/naive.py`` (independent of cornerbif);
  a state below the obstacle (Moreau-Jean ends its impact step there) is first projected
  onto it (u0 := z(t0), v0 kept); ``null`` if the state cannot be flown off the
  obstacle within 1e-5, ``Infinity`` if
  there is no impact before the Siconos next impact + 1;
* ``grazing``: the first impact time (or ``null``) of each grazing start up to its t_max;
* ``cornerbif``: the ``flow`` throughput of cornerbif on the same Fig. 4(c) scene (same
  w range, kappa, beta, r, start distribution and impacts per run), one numba thread,
  best of 3 after a warm-up call, measured in this session: every impact recorded (as
  the Siconos loop records them) and, as ``bench_flow`` in ``run.py``, only the last 100.
"""

from __future__ import annotations

import json
import math
import os
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, os.path.join(os.path.dirname(HERE), "tests"))

import naive  # noqa: E402


def first_impact(q, t_max):
    """Exact first impact of the flight from (t0, u0, v0), or None."""
    imp = naive.naive_impacts(q["obstacle"], q["omega"], q["kappa"], q["beta"], q["r"],
                              q["u0"], q["v0"], 1, t0=q["t0"], t_max=t_max)
    return float(imp[0, 0]) if len(imp) else None


def one_step(q):
    """Next impact after a post-impact state lying on the obstacle: fly it exactly
    (closed form) a hair off the obstacle, then search exhaustively."""
    z0 = naive.z_obstacle(q["obstacle"], q["t0"], q["omega"], q["kappa"], q["beta"])
    if q["u0"] < z0:              # Moreau-Jean ends a step slightly below: project
        q = dict(q, u0=z0)
    for d in (1e-9, 1e-8, 1e-7, 1e-6, 1e-5):
        t1 = q["t0"] + d
        u1, v1 = naive.free_flight(t1, q["t0"], q["u0"], q["v0"])
        if u1 > naive.z_obstacle(q["obstacle"], t1, q["omega"], q["kappa"], q["beta"]):
            t = first_impact(dict(q, t0=t1, u0=u1, v0=v1), q["t_next"] + 1.0)
            return math.inf if t is None else t
    return None


def cornerbif_throughput(spec):
    import numba
    import numpy as np

    from cornerbif.sweep import simulate
    st = np.array(spec["starts"], float)
    w, u0, v0 = st[:, 0], st[:, 1], st[:, 2]
    kw = dict(transient=0, record=spec["n_impacts"], obstacle="rectified_sine", kappa=0.0,
              beta=1.0, r=0.8)
    numba.set_num_threads(1)
    t0 = time.perf_counter()
    simulate(u0[:4], v0[:4], omega=w[:4], **kw)          # compile / load cache
    warm = time.perf_counter() - t0
    best, n = math.inf, 0
    for _ in range(3):
        t0 = time.perf_counter()
        res = simulate(u0, v0, omega=w, **kw)
        best = min(best, time.perf_counter() - t0)
        n = int(np.isfinite(res["t"]).sum())
    # as benchmarks/run.py's bench_flow: the same impacts, only the last 100 recorded
    m = spec["n_impacts"]
    kw_t = dict(kw, transient=max(m - 100, 0), record=min(m, 100))
    best_t = math.inf
    for _ in range(3):
        t0 = time.perf_counter()
        simulate(u0, v0, omega=w, **kw_t)
        best_t = min(best_t, time.perf_counter() - t0)
    return {"scene": f"fig4c: rectified sine w in [1.5,2.5] x {spec['n_omega']}, "
                     f"{spec['n_starts']} starts, kappa=0 beta=1 r=0.8, "
                     f"{spec['n_impacts']} impacts", "threads": 1,
            "n_impacts": n, "seconds": best, "impacts_per_second": n / best,
            "warmup_seconds": warm,
            "impacts_per_second_last100_recorded": len(w) * m / best_t,
            "ok_fraction": float(np.mean(res["status"] == 0)),
            "api": "cornerbif.sweep.simulate (tol 1e-12)"}


def main(fin, fout):
    with open(fin) as f:
        job = json.load(f)
    out = {"one_step": [one_step(q) for q in job.get("one_step", [])],
           "grazing": [first_impact(q, q["t_max"]) for q in job.get("grazing", [])]}
    if job.get("cornerbif"):
        out["cornerbif"] = cornerbif_throughput(job["cornerbif"])
    with open(fout, "w") as f:
        json.dump(out, f)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
