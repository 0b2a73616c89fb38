"""Where an attractor ends, by brute force (tests/brute_bisection.py: bisection on kappa with
the simulator as the only judge), against the paper's closed forms and against the branch
ends that ``cornerbif.branches`` locates by continuation.

The flow of Fig. 6 (omega = 1.999, r = 0.8, beta = 1, z = kappa + |sin omega t|, sigma = 0,
k = 1) has two corner events (section 3.3): the single-impact orbit ``b`` dies as kappa
increases through kappa_C (eq 11), the double-impact orbit ``a`` (alpha: two impacts either
side of the corner, one cluster per period T) as kappa decreases through kappa_CC (eq 17).
Eqs (11) and (17) are exact for the flow (docs/discrepancies.md), so the brute force must
meet them to its own honest error, ``Edge.trust`` (about 1e-11, from the simulator's event
tolerance: see ``bisect_death``).

For other tests: ``brute_bisection.single_impact_end()`` and ``double_impact_end()`` (cached
per session; import them from any folder under tests/), or the fixtures ``brute_kappa_C``
and ``brute_kappa_CC`` here.  Each is an ``Edge``: ``.at`` the location, ``.trust`` the error
to allow, ``.inside`` / ``.outside`` the bracket, ``.state`` a point of the cycle at
``.inside``.
"""

import math

import h5py
import numpy as np
import pytest
from brute_bisection import (
    FIG6,
    bisect_death,
    double_impact_end,
    double_impact_word,
    follow,
    single_impact_end,
)

import cornerbif
from cornerbif import config, theory

OMEGA, R = FIG6["omega"], FIG6["r"]


@pytest.fixture(scope="session")
def brute_kappa_C():
    """The single-impact orbit's end (kappa_C) by brute force: an ``Edge``."""
    return single_impact_end()


@pytest.fixture(scope="session")
def brute_kappa_CC():
    """The double-impact orbit's end (kappa_CC) by brute force: an ``Edge``."""
    return double_impact_end()


def test_single_impact_orbit_dies_at_kappa_C(brute_kappa_C):
    """``b`` exists at -0.0142 and not at -0.0141; the bisection to 1e-12 lands on eq (11)
    within its honest error (width / 2 + the slack of the event tolerance)."""
    e = brute_kappa_C
    kc = theory.kappa_C(OMEGA, R)
    assert kc == pytest.approx(-0.0141371698509, abs=1e-13)
    assert e.word == "b"
    assert e.inside < e.outside                 # dies as kappa increases
    assert e.width < 1e-12
    assert 0.0 < e.slack < 2e-11                # a corner event: the offsets shrink to it
    assert e.offset_rate == pytest.approx(0.5, rel=0.01)   # offset = (kappa_C - kappa) / 2
    assert abs(e.at - kc) <= e.trust, (e.at, kc, e.trust)


def test_default_tolerance_either_order():
    """The default tol (1e-9) with the bracket given the other way round (the end with the
    attractor second): the same end, within the same kind of error."""
    e = bisect_death(FIG6, "b", -0.0141, -0.0142, (5.0, 3.0))
    kc = theory.kappa_C(OMEGA, R)
    assert e.inside < e.outside                 # the ends sorted out: b is below
    assert e.width < 1e-9
    assert abs(e.at - kc) <= e.trust < 1e-9


def test_double_impact_orbit_is_alpha_and_ab_crosses_kappa_CC():
    """The double-impact period-T orbit (period 1, two impacts per cycle) is reported as
    ``a``.  The period-2T orbit ``ab`` (alpha then beta) is not the one that ends at
    kappa_CC: carried along it exists on both sides of it."""
    word, state = double_impact_word()
    assert word == "a"
    assert all(math.isfinite(x) for x in state)
    kcc = theory.kappa_CC(OMEGA, R)
    u0, v0 = np.meshgrid(np.linspace(1.0, 19.0, 4), np.linspace(-15.0, 15.0, 4))
    res = cornerbif.simulate(u0.ravel(), v0.ravel(), transient=1000, record=200, kappa=-0.0029,
                             **FIG6)
    i = list(res["symbols"]).index("ab")
    values = [-0.0029, -0.0030, -0.0031, -0.0032, -0.0033]
    assert values[0] > kcc > values[-1]
    # ``follow`` raises where the orbit is lost: it is found at every value, both sides
    path = follow(FIG6, "ab", values, (res["final"][i, 0], res["final"][i, 1]))
    assert [t.value for t in path] == values


def test_double_impact_orbit_lost_below_kappa_CC(brute_kappa_CC):
    """``a``, carried down from kappa = -0.001 to -0.0030, is lost before -0.0032; the
    bisection to 1e-12 lands on eq (17) within its honest error."""
    e = brute_kappa_CC
    kcc = theory.kappa_CC(OMEGA, R)
    assert kcc == pytest.approx(-0.0031032811868, abs=1e-13)
    assert e.word == "a"
    assert e.outside < e.inside                 # lost as kappa decreases
    assert e.width < 1e-12
    assert 0.0 < e.slack < 2e-11
    assert abs(e.at - kcc) <= e.trust, (e.at, kcc, e.trust)


# ------------------------------------------------ against cornerbif.branches (when it exists)
SMALL_FIG06A = """
[scene]
name = "fig06a_small"
title = "Fig. 6(a) near kappa_C, 5 values"
model = "flow"

[system]
obstacle = "rectified_sine"
omega = 1.999
kappa = 0.0
beta = 1.0
r = 0.8
sigma = 0.0
k = 1.0

[sweep]
kappa = { start = -0.0142, stop = -0.0138, num = 5 }
follow = "none"

[initial]
count = 8
seed = 1
u = [0.0, 20.0]
v = [-20.0, 20.0]

[run]
transient = 500
record = 100
tol = 1e-12

[output]
keep = ["impacts", "section"]
"""


@pytest.fixture(scope="module")
def small_fig06a(tmp_path_factory):
    """A small Fig. 6(a) sweep (kappa from -0.0142 to -0.0138, 5 values, 8 starts) and its
    branches: (branches, table, kappa grid, per-run attractor ids, per-run final states)."""
    from cornerbif import branches
    from cornerbif.attractors import read_table
    from cornerbif.sweep import run_sweep
    out = str(tmp_path_factory.mktemp("fig06a_small") / "fig06a_small.h5")
    run_sweep(config.loads(SMALL_FIG06A), out)
    with h5py.File(out, "r") as f:
        scene = config.loads(str(f.attrs["scene"]))
        br = branches.build(f, scene)
        tab = read_table(f)
        grid = f["kappa"][...]
        ids = f["attractor"][...]
        final = np.stack([f["final/u"][...], f["final/v"][...]], -1)
    return br, tab, grid, ids, final


@pytest.mark.slow
def test_branch_of_b_ends_at_the_brute_force_corner(small_fig06a, brute_kappa_C):
    """The branch of ``b`` ends above in a corner collision, located where the brute force
    puts it (within its ``trust``, about 1e-11)."""
    br, tab, *_ = small_fig06a
    of_b = [i for i, rows in enumerate(br.rows) if tab["word"][rows[0]] == "b"]
    assert len(of_b) == 1
    end = br.high[of_b[0]]
    assert end.kind == "corner", end
    assert abs(end.at - brute_kappa_C.at) <= brute_kappa_C.trust, (end.at, brute_kappa_C.at)


@pytest.mark.slow
def test_every_corner_end_inside_the_range_matches_the_brute_force(small_fig06a):
    """Every branch end named a corner collision (the beta^N gamma plateaus' ends as well as
    beta's) is where the brute force, bisecting between the branch's last grid value and the
    next one from a run of the sweep that ended on it, finds the word's end."""
    br, tab, grid, ids, final = small_fig06a
    checked = 0
    for i, rows in enumerate(br.rows):
        points = [int(tab["parameter_point"][r]) for r in rows]
        for side, end, p, step in (("low", br.low[i], min(points), -1),
                                   ("high", br.high[i], max(points), +1)):
            if end.kind != "corner":
                continue
            row = rows[points.index(p)]
            j = int(np.flatnonzero(ids[p] == tab["id"][row])[0])
            e = bisect_death(FIG6, str(tab["word"][row]), float(grid[p]), float(grid[p + step]),
                             tuple(final[p, j]), tol=1e-12)
            assert abs(end.at - e.at) <= e.trust, (i, side, tab["word"][row], end.at, e.at)
            checked += 1
    # at least b's upper end and both ends of the b^N g plateaus the 5-value grid samples
    # inside the range (measured: 8 corner ends)
    assert checked >= 5
