"""Chaotic attractors in the attractor table (cornerbif.chaos, issue 32): the chaotic window
of Fig. 1(a) is an attractor with a positive exponent whose interval excludes 0, checked
against Benettin's two-trajectory estimate on the slow exhaustive simulator
(tests/fd_reference.py on tests/naive.py); a periodic window has cycles and no chaos; a run
merely too short for its cycle, or on a long orbit through sticking, stays "no cycle within
the record", not chaos."""

import math

import fd_reference as FD
import h5py
import numpy as np

import cornerbif
from cornerbif import config
from cornerbif.attractors import NO_CYCLE, read_table
from cornerbif.chaos import CHAOTIC
from cornerbif.sweep import run_sweep

SMOOTH = """
[scene]
name = "chaos_fig01a"
model = "flow"
[system]
obstacle = "sine"
omega = 2.0
kappa = 0.0
beta = 1.0
r = 0.8
[sweep]
omega = {{ start = {lo}, stop = {hi}, num = {num} }}
[initial]
count = 8
seed = 1
u = [0.0, 20.0]
v = [-20.0, 20.0]
[run]
transient = {transient}
record = {record}
[output]
keep = ["impacts"]
"""


def _table(tmp_path, name, threads=None, **kw):
    out = str(tmp_path / f"{name}.h5")
    run_sweep(config.loads(SMOOTH.format(**kw)), out, threads=threads)
    with h5py.File(out) as f:
        return read_table(f)


def test_the_chaotic_window_of_fig1a_is_a_chaotic_attractor(tmp_path):
    """omega = 2.80 .. 2.84 (Fig. 1(a), the file's runs find no cycle): every start reaches
    one chaotic attractor per point, with lambda > 0 and its interval above 0; at 2.84 its
    exponent agrees with Benettin's on the independent simulator within 0.03 (the spread of
    one window's estimate is about 0.01, docs/stability.md; measured 0.1950, interval
    [0.1884, 0.2016], against Benettin's 0.2035 over 400 periods)."""
    tab = _table(tmp_path, "chaos", lo=2.80, hi=2.84, num=3, transient=500, record=100)
    assert list(tab["word"]) == [CHAOTIC] * 3
    assert np.all(tab["runs"] == 8) and np.all(tab["period"] == 0)
    assert np.all(tab["lyapunov_low"] > 0) and np.all(tab["lyapunov"] > 0.1)
    assert np.all(tab["lyapunov_low"] <= tab["lyapunov"])
    assert np.all(tab["lyapunov"] <= tab["lyapunov_high"])
    assert np.all(tab["outcomes"][:, 0] == 8) and np.all(tab["outcomes"][:, 1] == 0)
    omega = 2.84
    res = cornerbif.simulate(5.0, 0.0, transient=500, record=600, obstacle="sine",
                             omega=omega, kappa=0.0, beta=1.0, r=0.8)
    T = 2 * math.pi / omega
    su, sv = res["su"][0], res["sv"][0]
    n_sec = int(np.isfinite(su).sum())
    ref = FD.benettin(omega, su[n_sec - 1], sv[n_sec - 1], n_sec * T, 400)
    assert ref > 0.1
    assert abs(tab["lyapunov"][-1] - ref) < 0.03, (tab["lyapunov"][-1], ref)


def test_a_periodic_window_has_cycles_and_no_chaos(tmp_path):
    """omega = 1.4 .. 1.6 (Fig. 1(a)'s period-1 window): every run reaches a cycle."""
    tab = _table(tmp_path, "periodic", lo=1.4, hi=1.6, num=3, transient=500, record=100)
    assert CHAOTIC not in set(tab["word"])
    assert np.all(tab["outcomes"][:, 0] == 8)
    assert np.all(np.isnan(tab["lyapunov"]))


def test_runs_too_short_for_their_cycle_are_not_chaos(tmp_path):
    """omega = 2.86 and 2.88: with a record of 100 the runs find no cycle (and the
    Lyapunov exponent of a long window is -inf: they stick), so they stay NO_CYCLE, "no
    cycle within the record"; run long enough (transient and record 3000) the same starts
    find cycles of period 6 (64 impacts) and 11 (71 impacts): long orbits through
    chattering and sticking, not chaos (a stick releases at one state, so what follows
    repeats)."""
    short = _table(tmp_path, "short", lo=2.86, hi=2.88, num=2, transient=500, record=100)
    assert CHAOTIC not in set(short["word"])
    assert np.all(short["outcomes"][:, 1 + (-NO_CYCLE - 1)] == 8)
    # and the table says why: every one sticks within the long window (REASONS[1])
    assert np.all(short["no_cycle"][:, 1] == 8), short["no_cycle"]
    long = _table(tmp_path, "long", lo=2.86, hi=2.88, num=2, transient=3000, record=3000)
    assert sorted(zip(long["period"], long["impacts_per_cycle"])) == [(6, 64), (11, 71)]
    assert np.all(long["outcomes"][:, 0] == 8)


def test_chaotic_ids_do_not_depend_on_threads(tmp_path):
    """The chaos pass reruns each run alone: the same table on 1 and 2 threads."""
    one = _table(tmp_path, "one", threads=1, lo=2.72, hi=2.76, num=3, transient=500,
                 record=100)
    two = _table(tmp_path, "two", threads=2, lo=2.72, hi=2.76, num=3, transient=500,
                 record=100)
    for k in ("word", "runs", "lyapunov", "lyapunov_low", "lyapunov_high", "ids"):
        np.testing.assert_array_equal(one[k], two[k])


ONE_POINT = """
[scene]
name = "chaos_many"
model = "flow"
[system]
obstacle = "sine"
omega = 2.84
kappa = 0.0
beta = 1.0
r = 0.8
[initial]
count = 100
seed = 1
u = [0.0, 20.0]
v = [-20.0, 20.0]
[run]
transient = 500
record = 20
[output]
keep = []
"""


def test_runs_past_the_first_64_join_the_chaotic_attractor(tmp_path):
    """100 starts at omega = 2.84 (Fig. 1(a)'s chaotic window), a record of 20 that keeps
    nothing: the first 64 are rerun with the stability pass and find the attractor, the
    other 36 are rerun without it and join it (their window's points in its cloud's cells):
    every start is on it, whatever the file keeps and in whatever order."""
    out = str(tmp_path / "many.h5")
    run_sweep(config.loads(ONE_POINT), out)
    with h5py.File(out) as f:
        tab = read_table(f)
    assert list(tab["word"]) == [CHAOTIC] and list(tab["runs"]) == [100]
    assert tab["no_cycle"].sum() == 0
    assert np.isnan(tab["share_low"]).sum() == 0       # random starts: a Wilson interval


def test_an_all_chaotic_file_is_summarised_as_such(tmp_path):
    """``cornerbif info`` of a file whose every run is on a chaotic attractor says so (it
    said "no run finished": no cycle, and no run left without one)."""
    from click.testing import CliRunner

    from cornerbif.cli import main
    out = str(tmp_path / "all.h5")
    run_sweep(config.loads(ONE_POINT.replace("count = 100", "count = 8")), out)
    r = CliRunner().invoke(main, ["info", out])
    assert r.exit_code == 0, r.output
    assert "no run finished" not in r.output
    assert "8 runs at 1 points on chaotic attractors" in r.output, r.output
