"""The sweep's time estimate models the cost per obstacle piece (section period) crossed as
well as per impact, and says when it is uncertain; every first compile is announced with the
kernel's name and about how long it took where it was measured.

Before: ``estimate_seconds`` counted impacts only and said "about 0.0 s" at omega = 1e9, where
22 runs took 212 s; only the very first compile was announced ("compiling the numba
kernels"), the first cam, stability and two-particle compiles sat silent.  These tests check
the model's structure only; its numbers against measured times are
benchmarks/estimate_time.py's (a timed test would fail on a loaded machine)."""

import json
import math
import os
import subprocess
import sys

import pytest
from click.testing import CliRunner

from cornerbif import config, engine
from cornerbif.cli import main
from cornerbif.estimate import estimate_seconds, estimate_time, estimate_words, sample_points

HERE = os.path.dirname(__file__)
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(HERE)))


def _scene(name, *sets):
    return config.load(os.path.join(ROOT, "configs", f"{name}.toml"), list(sets))


GRID = ("sweep.kappa.num=11", "initial.count=2")


def test_a_fast_obstacle_is_estimated_far_above_a_slow_one():
    """The same 22 runs at omega = 1e9 and at omega = 1.999: about 1e9 obstacle pieces
    crossed per impact against 2 makes the first estimate thousands of times the second, and
    over a minute (the issue measured 212 s; before, both were 'about 0.0 s')."""
    slow = estimate_seconds(_scene("fig06a", "system.omega=1e9", *GRID), 2)
    fast = estimate_seconds(_scene("fig06a", *GRID), 2)
    assert slow > 1000 * fast
    assert 60 < slow < 3600


@pytest.mark.parametrize("name,key,values", [
    ("fig06a", "system.omega", [2.0, 20.0, 200.0, 2e3, 2e4]),
    ("fig06a", "system.sigma=0.01 system.omega", [2.0, 200.0, 2e4]),
    ("cam_cycloidal", "sweep.omega", ["{values=[1.0]}", "{values=[100.0]}",
                                      "{values=[1e4]}"]),
    ("fig19a", "sweep.omega0", ["{values=[2.0]}", "{values=[200.0]}", "{values=[2e4]}"]),
])
def test_the_estimate_grows_with_the_pieces_crossed(name, key, values):
    """Below the speed at which runs escape, a faster obstacle (more pieces, or section
    periods for two_particle, between two impacts) costs more, for every kernel path: the
    free flight, the damped (searched) flight, a cam and two_particle."""
    *extra, key = key.split()
    est = [estimate_seconds(_scene(name, *extra, f"{key}={v}", "initial.count=2"), 2)
           for v in values]
    assert all(b > a for a, b in zip(est, est[1:])), est
    assert est[-1] > 100 * est[0], est


def test_runs_that_escape_are_estimated_by_their_few_impacts():
    """At omega = 1e9 every run escapes after about 2 impacts (a flight of pi / k each, about
    1e9 pieces): the estimate counts those, not transient + record = 600 impacts, and says so."""
    est = estimate_time(_scene("fig06a", "system.omega=1e9", *GRID), 2)
    assert any("escape" in r for r in est.reasons)
    per_run = est.seconds * 2 / 22
    assert per_run < 600 * 1e9 * 12.5e-9 / 100     # 600 impacts x 1e9 pieces x 12.5 ns each


def test_uncertain_estimates_say_so_with_a_range():
    """An estimate that rests on the guessed flight time says 'uncertain' with its range and
    reasons; a shipped scene's (impacts dominate) says 'about ...' alone."""
    words = estimate_words(estimate_time(_scene("fig06a", "system.omega=1e9", *GRID), 2))
    assert "uncertain" in words and " to " in words and "obstacle pieces" in words
    assert "uncertain" not in estimate_words(estimate_time(_scene("fig04c"), 2))
    est = estimate_time(_scene("fig04c", 'run.stop="period"'), 2)
    assert est.low < est.seconds / 2 and "run.stop" in estimate_words(est)


def test_dry_run_time_line_is_the_model(tmp_path):
    """``sweep --dry-run`` (and ``validate``) print the time model's words: at omega = 1e9 an
    uncertain range of minutes, never 'about 0.0 s'."""
    r = CliRunner().invoke(main, ["sweep", os.path.join(ROOT, "configs", "fig06a.toml"),
                                  "--dry-run", "-o", str(tmp_path / "x.h5"), "--set",
                                  "system.omega=1e9", "--set", GRID[0], "--set", GRID[1]])
    assert r.exit_code == 0, r.output
    line = next(x for x in r.output.splitlines() if x.startswith("time:"))
    assert "about 0.0 s" not in line and "uncertain" in line and "min" in line


def test_sample_points_cover_the_grid():
    """The model reads at most ESTIMATE_SAMPLES grid points, evenly spread, both ends kept."""
    pts = sample_points((10, 30), 64)
    assert len(pts) <= 64 and pts[0] == (0, 0) and pts[-1] == (9, 29)
    assert sample_points((3,), 64) == [(0,), (1,), (2,)]
    assert sample_points((), 64) == [()]


COLD = r"""
import json, sys
from cornerbif import config, engine
out = {}
for name, sets, what in json.loads(sys.argv[1]):
    sc = config.load(name, sets)
    out[name + " " + " ".join(sets) + " " + ",".join(what)] = engine.cold_compiles(sc, what)
print(json.dumps(out))
"""


def test_every_first_compile_is_named_with_its_time(tmp_path):
    """With an empty numba cache (a fresh NUMBA_CACHE_DIR), each kind of first run names what
    it will compile and about how long it takes: the flow kernel, the cam's, the stability
    kernels, the two-particle kernel, the map2d kernels and what a continuation compiles
    (the seconds measured by benchmarks/compile_time.py; before, one generic line for the
    very first sweep only)."""
    c = lambda n: os.path.join(ROOT, "configs", n + ".toml")  # noqa: E731
    stab = 'output.keep=["impacts", "stability"]'
    cases = [(c("fig04c"), [], ["sweep"]), (c("cam_cycloidal"), [], ["sweep"]),
             (c("fig04c"), [stab], ["sweep"]), (c("fig19a"), [], ["sweep"]),
             (c("fig19a"), [stab], ["sweep"]), (c("fig15b"), [], ["sweep"]),
             (c("cont_beta"), [], ["continuation"]), (c("cont_fig19"), [], ["continuation"])]
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"))
    p = subprocess.run([sys.executable, "-c", COLD, json.dumps(cases)], env=env,
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    got = {k: dict(v) for k, v in json.loads(p.stdout).items()}
    names = list(got.values())
    assert "the flow kernel" in names[0] and "the cycle analysis" in names[0]
    assert "the flow kernel for a cam profile" in names[1]
    assert "the flow stability kernel" in names[2]
    assert "the two-particle kernel" in names[3]
    assert "the two-particle stability kernel" in names[4]
    assert "the map2d kernels" in names[5]
    assert any("continuation" in n for n in names[6]) and any("continuation" in n
                                                              for n in names[7])
    assert all(s > 0 for v in names for s in v.values())


def test_announce_says_nothing_once_cached():
    """Once a scene's kernels are compiled (here, in this process) nothing is announced."""
    sc = _scene("fig06a", "sweep.kappa.num=2", "initial.count=1", "run.transient=2",
                "run.record=2")
    engine.compute_block(sc, (slice(0, 2),))
    import numpy as np

    from cornerbif.chunkwrite import _shuffle_bytes  # the writer's, called beside
    _shuffle_bytes(np.zeros(16, np.uint8), 8, np.empty(16, np.uint8))
    said = []
    assert engine.announce_compiles(sc, said.append, ("sweep",)) == 0 and said == []


def test_compile_times_are_said_rounded_as_measured_elsewhere(monkeypatch):
    """A compile time in the models' declarations was measured on one machine
    (benchmarks/compile_time.py) and is shown on any: the announcement rounds it (whole
    seconds below 10 s, multiples of 5 s below a minute) and says it is the time taken where it
    was measured, longer on a slower or busier machine.  Before: "about 25.1 s", as if
    measured here."""
    monkeypatch.setattr(engine, "cold_compiles", lambda scene, what: [
        ("the flow kernel", 25.1), ("the flow kernel for a cam profile", 28.8),
        ("the obstacle's heights at the start times", 1.4), ("the cycle analysis", 0.3),
        ("the flow stability kernel", 4.0), ("a kernel", 130.0)])
    said = []
    total = engine.announce_compiles(_scene("fig06a"), said.append)
    assert total == pytest.approx(25.1 + 28.8 + 1.4 + 0.3 + 4.0 + 130.0)
    assert [line.split("about ")[1].split(" on ")[0] for line in said] == [
        "25 s", "30 s", "1 s", "1 s", "4 s", "2 min"]
    for line in said:
        assert line.startswith("compiling ") and line.endswith(" ...")
        assert "on the machine it was timed on, longer on a slower or busier one" in line
        assert not any(x in line for x in ("25.1", "28.8", "1.4", "4.0"))


def test_durations_are_said_in_bounded_words():
    """An estimate of a sweep that cannot end in any time (a swept frequency of 1.8e308 made
    it inf: before, "about inf days") or of 1e300 s is said as 'more than a thousand years';
    finite ones in the largest unit they fill twice: 1e8 s = 3.17 years (1e8 / 31 557 600),
    1e7 s = 115.7 days (1e7 / 86 400)."""
    from cornerbif.estimate import about, duration
    for s in (math.inf, math.nan, 1e300, 1000 * 365.25 * 86400):
        assert duration(s) == "more than a thousand years"
        assert about(s) == "more than a thousand years"
    assert duration(1e8) == "3.2 years"
    assert duration(1e7) == "115.7 days"
    assert about(700.0) == "about 11.7 min"


LINEAR_GRID = ('sweep."forcing.0.Omega".num=2', "initial.count=2")


def test_the_linear_estimate_counts_chunks_between_impacts():
    """The linear model's own time model (models/linear/cost.py): its flights go in chunks of
    1 / |A|, so a stiff system (k = 1e4: |A| about 1e4) whose runs may fly their whole budget
    between impacts can take over 100 times the shipped system's (k = 1), and says why.
    Before, every linear run was priced at (transient + record) impacts alone: 'about 0.0 s'
    where one run took 31 s."""
    base = estimate_time(_scene("two_stops", *LINEAR_GRID), 2)
    stiff = estimate_time(_scene("two_stops", *LINEAR_GRID, "system.stiffness=[1e4]"), 2)
    assert stiff.high > 100 * base.high, (stiff, base)
    assert any("time budget" in r and "chunks of 1/|A|" in r for r in stiff.reasons)
    assert "uncertain" in estimate_words(stiff)


def test_the_linear_estimate_counts_obstacle_pieces():
    """A contact on a fast obstacle is searched piece by piece: the oscillator between two
    stops, one stop now a rectified sine of omega = 1e4 (2e4 pieces a forcing period), has a
    high end over 10 times the fixed stops', and the reason names the pieces."""
    fixed = estimate_time(_scene("two_stops", *LINEAR_GRID), 2)
    fast = estimate_time(_scene("two_stops", *LINEAR_GRID, 'system.contact.R.obstacle="rectified_sine"',
                                "system.contact.R.beta=1e-3", "system.contact.R.omega=1e4"), 2)
    assert fast.high > 10 * fixed.high, (fast, fixed)
    assert any("obstacle pieces" in r for r in fast.reasons)


def test_the_linear_estimate_counts_the_corner_contacts_impacts():
    """With ``[system] words`` a run counts one contact's impacts (U's, Fig. 19(a) as a linear
    scene) and resolves the other's (W's, the corners: 0.85 per U impact in its sweep) between
    them: each run is priced for both contacts' impacts (``cost.resolved_per_counted``: one
    impact a time scale per contact), the same system without words for the impacts it
    counts alone.  Before, 2.9 s was estimated for a sweep that took 14.7 s; the other
    linear scenes' estimates do not move (a factor of 1)."""
    from cornerbif.models.linear.cost import COST_IMPACT, resolved_per_counted
    words = _scene("fig19a_linear")
    text = open(os.path.join(ROOT, "configs", "fig19a_linear.toml")).read()
    plain = config.loads(text.replace("words = {", "# words = {"))
    assert plain.spec.system_table.get("words") is None
    at = words.point((0,))
    w = words.spec.run_seconds(words, at)
    p = plain.spec.run_seconds(plain, at)
    n = words.transient + words.record
    assert w[0] - p[0] == pytest.approx(n * COST_IMPACT, rel=1e-12), (w, p)
    assert w[1] > p[1] and w[2] > p[2]
    system, _ = words.spec.system_of(at)
    assert resolved_per_counted(system) == 2.0
    for name in ("two_stops", "impact_damper", "bouncing_ball", "fig06a_linear", "gear_rattle",
                 "soft_stop", "cont_beta_linear"):
        sc = _scene(name)
        system, _ = sc.spec.system_of(sc.point((0,) * len(sc.shape)))
        assert resolved_per_counted(system) == 1.0, name
