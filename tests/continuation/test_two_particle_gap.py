"""The two-particle grazing monitor, certified (issue 31): between samples, a stretch whose
gaps the bound of their second derivative does not prove positive is halved until it does
(``TwoParticleOrbit._flight_gap``).  Checked: the bound against dense central differences
of the gaps (written here), and the monitor with no samples at all."""

import numpy as np
import pytest

from cornerbif import continuation as C
from cornerbif.models.two_particle import orbit as TO
from cornerbif.models.two_particle import packed as TPM

X0 = [0.18982259867467574, 16.49606490380678, 1.7221809107866082, 149.66189899401783]


def _orbit(**extra):
    vals = {k: p.default for k, p in TPM.PARAMS.items()} | {"omega0": 2.0} | extra
    return TO.two_particle_seed(vals, "omega0", X0, 1)


@pytest.mark.parametrize("extra", [{}, {"sigma1": 0.05, "sigma2": 0.02},
                                   {"F1": 0.4, "Omega1": 2.0, "mu": 50.0}])
def test_the_curvature_bound_holds_on_every_flight(extra):
    prob, X = _orbit(**extra)
    N, D = prob.n, prob.duration(2.0)
    h = 1e-4
    for k in range(N):
        t0 = X[5 * k]
        t1 = X[5 * ((k + 1) % N)] + (D if k == N - 1 else 0.0)
        xk = X[5 * k + 1:5 * k + 5]
        M = prob._gap_curvature(2.0, t0, xk, t1)

        def g(t, t0=t0, xk=xk):
            return prob._gaps(2.0, t0, xk, t)[0]
        second = np.array([(g(t + h) - 2.0 * g(t) + g(t - h)) / (h * h)
                           for t in np.linspace(t0, t1, 2001)[1:-1]])
        assert np.all(np.abs(second).max(axis=0) <= M * (1.0 + 1e-6) + 1e-6), (k, M)


def test_with_no_samples_the_monitor_still_sees_a_crossing(monkeypatch):
    """Across Fig. 19's corner collision at omega0_C the swapped itinerary's orbit has u fly
    166 below z.  With no samples at all per flight, the samples say nothing (+inf); the
    certified halving finds the crossing (< -100).  On the admissible orbit at omega0 = 2
    it stays positive."""
    prob, X = _orbit()
    ev = C.follow(prob, X, 2.0, (1.9995, 2.002), -1, ds=1e-4, switch=False)[0].events[-1]
    q = int(ev.detail.split(";")[0].split()[-1])
    new, Xs = ev.problem.across(q, ev.X, ev.lam)
    Xn = C.newton(new, Xs, ev.lam)
    monkeypatch.setattr(TO, "GAP_SAMPLES", 0)
    assert new.smallest_gap(Xn, ev.lam) < -100.0
    assert prob.smallest_gap(X, 2.0) > 0.0
    monkeypatch.setattr(TO.TwoParticleOrbit, "_gap_curvature",
                        lambda *a: np.array([np.inf, np.inf]))
    assert new.smallest_gap(Xn, ev.lam) == np.inf
