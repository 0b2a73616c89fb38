"""The flow's grazing monitor is guarded by the kernel's certified event search (issue 31):
from just after each impact the kernel must meet the obstacle first at the orbit's next
impact; where it meets it earlier, the monitor is the (negative) gap of that dip, however
few samples the flight has (``FlowOrbit._missed_crossings``)."""

import math

import pytest

import cornerbif
from cornerbif import continuation as C
from cornerbif.models.flow import orbit as FO


def _fold_saddle_follow(monkeypatch, samples, guard=True):
    """cont_fold's system (u'' + u = cos 2.5t against the wall u = kappa, r = 0.8): the
    period-one orbit continued up in kappa through its fold and down its saddle branch,
    which ends in a grazing; ``samples`` per flight in the monitor."""
    vals = dict(omega=2.5, kappa=0.5, beta=0.0, r=0.8, sigma=0.0, F=1.0, Omega=2.5)
    res = cornerbif.simulate([1.5], [0.0], obstacle="sine", transient=3000, record=60, **vals)
    prob, X = FO.seed_from_run(vals, "sine", "kappa", res["t"][0], res["v_out"][0],
                               res["corner_offset"][0], int(res["impacts_per_cycle"][0]))
    monkeypatch.setattr(FO, "GAP_SAMPLES", samples)
    if not guard:
        monkeypatch.setattr(FO.FlowOrbit, "_missed_crossings", lambda *a: math.inf)
    br = C.follow(prob, X, 0.5, (-3.0, 3.0), +1, ds=0.01)[0]
    monkeypatch.undo()
    return br


def _grazing(br):
    (g,) = [e for e in br.events if e.kind == "grazing"]
    return g


@pytest.fixture(scope="module")
def reference():
    mp = pytest.MonkeyPatch()
    return _grazing(_fold_saddle_follow(mp, 48)).lam


@pytest.mark.parametrize("samples", [1, 2])
def test_the_grazing_is_located_with_one_or_two_samples_per_flight(monkeypatch, reference,
                                                                   samples):
    """With the guard, one or two samples per flight locate the saddle's grazing where 48
    do (to 1e-8; kappa = 0.35932587), and every stored point is admissible; without it the
    same samples put it 1e-3 to 2e-2 away (measured: 0.3582 and 0.3438), with every point
    past the true grazing wrongly called admissible."""
    br = _fold_saddle_follow(monkeypatch, samples)
    assert abs(_grazing(br).lam - reference) < 1e-8
    unguarded = _fold_saddle_follow(monkeypatch, samples, guard=False)
    assert abs(_grazing(unguarded).lam - reference) > 1e-4
    assert min(p.lam for p in unguarded.points) < reference - 1e-4


def test_the_guard_sees_a_dip_between_samples(monkeypatch, reference):
    """Just past the grazing (kappa_g - 1e-6: the dip is 2.3e-6 deep and a few 1e-3 wide),
    two samples per flight see no dip; the guard returns the dip's depth, equal to what 48
    samples and their parabola give (to 1e-9 relative)."""
    br = _fold_saddle_follow(monkeypatch, 48)
    g = _grazing(br)
    lam = g.lam - 1e-6
    X = C.newton(g.problem, g.X, lam)
    want = g.problem.smallest_gap(X, lam)
    assert -3e-6 < want < -1e-6
    monkeypatch.setattr(FO, "GAP_SAMPLES", 2)
    got = g.problem.smallest_gap(X, lam)
    monkeypatch.setattr(FO.FlowOrbit, "_missed_crossings", lambda *a: math.inf)
    assert g.problem.smallest_gap(X, lam) > 0.0          # the samples alone: no dip
    assert abs(got - want) <= 1e-9 * abs(want)
