"""Where are the folds of Fig. 1(a)'s period-one orbits?  (docs/continuation.md)

Continues the smooth wall's period-one orbits (one impact per obstacle period, and per two
periods) in omega from omega = 2.2 and 4.0 both ways, and in kappa, r and beta from
omega = 2.2, printing every located event; then searches exhaustively for period-one
orbits at omega = 2.2 and 2.6 by Newton from a grid of 2 pieces x 25 impact times x 21
velocities, printing each distinct solution and whether it is admissible.

    python benchmarks/sine_wall_folds.py
"""

import numpy as np

import cornerbif
from cornerbif import continuation as C
from cornerbif.models.flow import orbit as FO


def seeded(omega, param):
    res = cornerbif.simulate([5.0], [0.0], omega=omega, kappa=0.0, obstacle="sine", r=0.8,
                             transient=1500, record=60)
    vals = dict(omega=omega, kappa=0.0, beta=1.0, r=0.8)
    return FO.seed_from_run(vals, "sine", param, res["t"][0], res["v_out"][0],
                           res["corner_offset"][0], int(res["impacts_per_cycle"][0])), vals


def main():
    ranges = {"omega": (1.0, 6.0), "kappa": (-3.0, 3.0), "r": (0.05, 0.999),
              "beta": (0.01, 5.0)}
    for omega, params in ((2.2, ("omega", "kappa", "r", "beta")), (4.0, ("omega",))):
        for param in params:
            (prob, X), vals = seeded(omega, param)
            for d in (1, -1):
                br = C.follow(prob, X, vals[param], ranges[param], d, ds=0.01)[0]
                print(f"omega = {omega}, {param} {'up' if d > 0 else 'down'} "
                      f"(m = {prob.m}): "
                      + ", ".join(f"{e.kind} at {e.lam:.10g}" for e in br.events))
    for omega in (2.2, 2.6):
        found = {}
        for j0 in (0, 1):
            prob = FO.FlowOrbit(dict(omega=omega, kappa=0.0, beta=1.0, r=0.8), "sine",
                               "omega", np.array([j0]), 1)
            L = np.pi / omega
            for tau in np.linspace(0.02, 0.98, 25) * L:
                for v in np.linspace(-20, 20, 21):
                    try:
                        X = C.newton(prob, np.array([tau, v]), omega)
                    except (C.OrbitError, np.linalg.LinAlgError):
                        continue
                    pr, X = prob.reindex(X, omega)
                    key = round(pr.times(X, omega)[0] % (2 * np.pi / omega), 6)
                    found.setdefault(key, (pr.admissible(X, omega), X[1]))
        print(f"omega = {omega}: {len(found)} distinct period-one solutions from 1050 "
              "guesses:")
        for key, ((ok, why), v) in sorted(found.items()):
            print(f"   impact phase {key}, v+ = {v:.5f}: "
                  + ("admissible" if ok else f"not admissible ({why})"))


if __name__ == "__main__":
    main()
