"""Early stop of the flow kernel (run.stop = "period", issue 3: "a point stops as soon as its
period is established").

The reference is the same run without early stop (transient + record impacts, the
period read afterwards by ``analysis.detect_cycle``): early stop must change no
answer, point for point (status, period, impacts per cycle, word), and must
actually stop early.
"""

import os

import numba
import numpy as np
import pytest

from cornerbif import config, engine, sweep, theory
from cornerbif.models.flow import packed as P
from cornerbif.models.flow.kernel import run_batch
from cornerbif.models.flow.model import STOP_TOL_FACTOR

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CHART = os.path.join(ROOT, "configs", "chart_flow.toml")


def _chart_items(stop, n=14, count=3, extra=()):
    sc = config.load(CHART, [f"sweep.omega.num={n}", f"sweep.kappa.num={n}",
                             f"initial.count={count}", f'run.stop="{stop}"', *extra])
    idx = [tuple(i) for i in np.ndindex(*sc.shape)]
    params = engine.pack_points(sc, idx)
    ics = engine.draw_initial(sc, np.arange(len(idx)), params[:, P.KAPPA])
    ics = ics.reshape(-1, ics.shape[-1])
    return sc, np.repeat(params, sc.n_ic, axis=0), np.ascontiguousarray(ics)


def _first_recorded(prm, ics, sc):
    """Kernel only: the number of each item's first recorded impact."""
    n, rec = len(prm), sc.record
    o = [np.full((n, rec), np.nan) for _ in range(7)]
    rec0 = np.zeros(n, np.int64)
    run_batch(prm, engine.int_settings(sc), ics, *o[:5], np.zeros((n, rec), np.int64), o[5], o[6],
              np.zeros(n, np.int8), np.zeros((n, 2)), rec0)
    return rec0


def _summary(sc, prm, ics):
    _, st, _, period, ipc, sym = engine.run_items(prm, ics, engine.int_settings(sc), sc)
    return st, period, ipc, sym


def _assert_same(a, b):
    for name, x, y in zip(("status", "period", "impacts_per_cycle", "symbols"), a, b):
        bad = np.flatnonzero((x != y).reshape(len(x), -1).any(axis=1))
        assert bad.size == 0, f"{name} differs at items {bad[:10]}"


def test_default_is_period_for_summary_only_flow_charts():
    assert config.load(CHART).stop == "period"                       # keep = []
    assert config.load(CHART, ['output.keep=["section"]']).stop == "none"
    assert config.load(os.path.join(ROOT, "configs", "fig06a.toml")).stop == "none"
    assert config.load(os.path.join(ROOT, "configs", "chart_map2d.toml")).stop == "none"
    sc = config.load(CHART, ['run.stop="none"'])
    assert sc.stop == "none" and 'stop = "none"' in sc.text


def test_bad_stop_values_are_refused_with_key_value_and_allowed():
    with pytest.raises(config.SceneError) as e:
        config.load(CHART, ['run.stop="early"'])
    assert "run.stop: 'early' is not allowed; allowed: none, period" in str(e.value)
    with pytest.raises(config.SceneError) as e:
        config.load(os.path.join(ROOT, "configs", "chart_map2d.toml"), ['run.stop="period"'])
    assert "run.stop: 'period' is implemented for model 'flow' only" in str(e.value)


def test_chart_grid_answers_equal_without_early_stop_point_for_point():
    """14 x 14 points of the chart scene's (omega, kappa) box around (2, 0), 3 starts each."""
    sc0, prm0, ics = _chart_items("none")
    sc1, prm1, _ = _chart_items("period")
    a = _summary(sc0, prm0, ics)
    b = _summary(sc1, prm1, ics)
    _assert_same(a, b)
    period = a[1]
    assert (period > 0).mean() > 0.9 and period.max() >= 10      # the grid is not trivial
    rec0 = _first_recorded(prm1, ics, sc1)
    # it does stop early: most items start recording long before impact 1500
    assert np.mean(rec0 < sc1.transient) > 0.95
    assert np.median(rec0) < 300
    assert np.all(_first_recorded(prm0, ics, sc0) == sc0.transient)


def test_long_periods_near_kappa_C_are_unchanged_by_early_stop():
    """omega = 1.999: above kappa_C (eq 11) the beta^N gamma periods grow as kappa -> kappa_C;
    kappa - kappa_C from 1e-7 (period 62) to 1e-3."""
    kc = theory.kappa_C(1.999, 0.8)
    kap = np.repeat(kc + np.logspace(-7, -3, 16), 3)
    rng = np.random.default_rng(3)
    u0 = rng.uniform(0.5, 20.0, kap.size)
    v0 = rng.uniform(-20.0, 20.0, kap.size)
    res = {stop: sweep.simulate(u0, v0, transient=1500, record=240, omega=1.999, kappa=kap,
                                r=0.8, stop=stop) for stop in ("none", "period")}
    a, b = res["none"], res["period"]
    for k in ("status", "period", "impacts_per_cycle", "symbols"):
        assert np.array_equal(a[k], b[k]), k
    assert a["period"].max() >= 60                       # the long periods are covered
    # the long cycles are caught early too: recording starts long before impact 1500
    sc = config.from_dict({"system": {"omega": 1.999, "r": 0.8},
                           "run": {"transient": 1500, "record": 240, "stop": "period"},
                           "output": {"keep": []}})
    prm = np.array([P.pack(dict(sc.system, kappa=k), "rectified_sine", sc.tol, sc.chatter,
                           sc.escape, None, STOP_TOL_FACTOR * sc.period_tol) for k in kap])
    rec0 = _first_recorded(prm, np.ascontiguousarray(np.stack([u0, v0], -1)), sc)
    assert np.all(rec0[a["period"] >= 30] < 600)


def test_early_stop_identical_with_one_and_two_threads():
    sc, prm, ics = _chart_items("period", n=6, count=2)
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        one = _summary(sc, prm, ics)
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        two = _summary(sc, prm, ics)
    finally:
        numba.set_num_threads(old)
    _assert_same(one, two)


def test_a_forced_oscillator_never_stops_early():
    """With forcing F cos(Omega t) the state at the corners does not fix the future (the
    forcing's phase differs), so the kernel must not watch for cycles."""
    sc, prm, ics = _chart_items("period", n=2, count=2, extra=["system.F=0.1",
                                                                "system.Omega=1.3"])
    assert np.all(_first_recorded(prm, ics, sc) == sc.transient)
