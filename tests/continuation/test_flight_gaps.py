"""The grazing monitor samples each flight in one jitted call (``kernel.flight_gaps``): the
same sum, term for term, as the orbit's one-time gap (``FlowOrbit._gap``, the closed-form
flight ``FlowOrbit._flight`` less the obstacle), so the two must agree bit for bit."""

import numpy as np
import pytest

import cornerbif
from cornerbif.models.flow import orbit as FO
from cornerbif.models.flow.kernel import flight_gaps


@pytest.mark.parametrize("obstacle, vals, u0", [
    ("sine", dict(omega=2.5, kappa=0.5, beta=0.0, r=0.8, sigma=0.0, F=1.0, Omega=2.5), 1.5),
    ("sine", dict(omega=2.0, kappa=-0.2, beta=1.0, r=0.8, sigma=0.05), 1.0),
    ("triangle", dict(omega=1.9, kappa=-0.1, beta=1.0, r=0.8, sigma=0.05), 1.0)])
def test_flight_gaps_equal_the_one_time_gap_bit_for_bit(obstacle, vals, u0):
    res = cornerbif.simulate([u0], [0.0], obstacle=obstacle, transient=400, record=40, **vals)
    m = int(res["impacts_per_cycle"][0])
    assert m >= 1
    prob, X = FO.seed_from_run(vals, obstacle, "kappa", res["t"][0], res["v_out"][0],
                               res["corner_offset"][0], m)
    lam = vals["kappa"]
    p, d = prob.packed(lam)
    imp = prob.impacts(X, lam)
    D = prob.duration(lam)
    s = np.linspace(0.0, 1.0, 50)[1:-1]
    for i in range(prob.n):
        n = (i + 1) % prob.n
        t0, t1 = imp["t"][i], imp["t"][n] + (D if n == 0 else 0.0)
        ts = t0 + s * (t1 - t0)
        got = flight_gaps(p, d, t0, imp["u"][i], imp["v_out"][i], ts, np.empty(len(ts)))
        want = [prob._gap(p, d, t0, imp["u"][i], imp["v_out"][i], t) for t in ts]
        assert np.array_equal(got, want)
        assert got.min() > -1e-9      # a flight of a simulated orbit stays above the obstacle
