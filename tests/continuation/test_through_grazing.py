"""Continuation through a grazing (issue 31): at a located grazing the orbit with the impact
the grazing gives birth to is solved (``continuation._across_grazing``) and continued.

The case: cont_fold's system (u'' + u = cos 2.5t against the wall u = kappa, r = 0.8).  The
period-one saddle ends in a grazing at kappa_g = 0.35932586574; across it the orbit with a
second, slow impact per cycle goes on up in kappa (and ends in a grazing of its own, and so
on: a cascade).  Checked against the kernel alone: the new orbit is a trajectory of the flow
(the kernel from just after its first impact meets the wall at its impacts), and the
velocity laws near the grazing are measured on kernel runs.

What the velocity laws are (measured here; the paper says nothing of them): a *trajectory*
that starts on the old orbit past the grazing meets the wall with w- ~ sqrt(distance)
(Nordmark's square root: its flight dips below the wall by a depth linear in the distance,
and meets it with the speed of a parabola of that depth).  The *periodic orbit* with the new
impact has w- linear in the distance: w- = -0.8103 (kappa - kappa_g) here, to 2e-6 relative
from 1e-4 to 1e-8; the impact's own effect on the orbit (linear in w-) balances the
depth's square root.
"""

import math

import numpy as np
import pytest

import cornerbif
from cornerbif import continuation as C
from cornerbif.models.flow import orbit as FO

VALS = dict(omega=2.5, kappa=0.5, beta=0.0, r=0.8, sigma=0.0, F=1.0, Omega=2.5)


@pytest.fixture(scope="module")
def branches():
    res = cornerbif.simulate([1.5], [0.0], obstacle="sine", transient=3000, record=60, **VALS)
    prob, X = FO.seed_from_run(VALS, "sine", "kappa", res["t"][0], res["v_out"][0],
                               res["corner_offset"][0], int(res["impacts_per_cycle"][0]))
    return C.follow(prob, X, 0.5, (-0.5, 1.6), +1, ds=0.01, max_branches=3)


def _kernel_impacts(problem, X, lam, count):
    """The kernel's first ``count`` impacts from just after the orbit's first impact."""
    imp = problem.impacts(X, lam)
    p, d = problem.packed(lam)
    t0 = imp["t"][0]
    t1 = imp["t"][1] if problem.n > 1 else t0 + problem.duration(lam)
    ts = t0 + 1e-4 * (t1 - t0)
    u, v, _ = problem._flight(p, d, t0, imp["u"][0], imp["v_out"][0], ts)
    return cornerbif.simulate([u], [v], t0=ts, obstacle="sine", transient=0, record=count,
                              **dict(VALS, kappa=lam))


def test_the_grazing_switches_to_the_orbit_with_the_new_impact(branches):
    main, born = branches[0], branches[1]
    graze = main.events[-1]
    assert graze.kind == "grazing" and "the orbit with the new impact is continued" in graze.detail
    assert born.problem.n == main.problem.n + 1
    assert 0.0 < born.points[0].lam - graze.lam < 1e-3
    assert all(p.admissible for p in born.points)
    assert born.points[-1].lam > graze.lam                  # it goes on up in kappa


def test_the_new_orbit_is_a_trajectory_of_the_flow(branches):
    """At points along the new branch the kernel, run from just after the orbit's first
    impact, meets the wall at the orbit's impacts (times and velocities to 1e-8) for two
    cycles: no impact missing, none extra."""
    born = branches[1]
    for pt in born.points[2:-1:8]:
        imp = pt.problem.impacts(pt.X, pt.lam)
        D = pt.problem.duration(pt.lam)
        run = _kernel_impacts(pt.problem, pt.X, pt.lam, 4)
        want_t = np.array([imp["t"][1], imp["t"][0] + D, imp["t"][1] + D, imp["t"][0] + 2 * D])
        want_v = np.array([imp["v_out"][1], imp["v_out"][0]] * 2)
        assert np.abs(run["t"][0] - want_t).max() < 1e-8, (pt.lam, run["t"][0], want_t)
        assert np.abs(run["v_out"][0] - want_v).max() < 1e-8


def test_velocity_laws_near_the_grazing(branches):
    """The periodic orbit's new impact arrives with w- linear in kappa - kappa_g (slope
    -0.8103 to 1e-5 relative over 1e-4 .. 1e-8, its second-order term 1.6e-6 at 1e-4; the
    kernel, run from just after the orbit's first impact, meets the wall with the orbit's w-
    to 2e-9 down to 1e-7); a trajectory started
    on the old orbit past the grazing meets the wall with |w-| proportional to the square
    root of the distance (|w-| / sqrt(distance) converges to 1.6954 over 1e-4 .. 1e-8, its
    correction shrinking by sqrt(10) a decade)."""
    main, born = branches[0], branches[1]
    kg = main.events[-1].lam
    k = int(np.argmin(np.abs(born.problem.impacts(born.points[0].X, born.points[0].lam)["w"])))
    X = born.points[0].X
    slopes, roots = [], []
    graze = main.events[-1]
    for dist in (1e-4, 1e-5, 1e-6, 1e-7, 1e-8):
        X = C.newton(born.problem, X, kg + dist)
        imp = born.problem.impacts(X, kg + dist)
        run = _kernel_impacts(born.problem, X, kg + dist, 1)
        # the kernel's first impact is the new one, with the orbit's arrival velocity
        # (the kernel locates an impact to rounding in the gap, ~1e-16: at w- = 8e-8 that
        # is 2e-9 in time and 1e-9 in velocity, measured)
        if dist >= 1e-7:            # below, the kernel's rounding floor is w- itself
            assert abs(run["t"][0][0] - imp["t"][k]) < 1e-8
            assert abs(run["v_in"][0][0] - imp["v_in"][k]) < 2e-9
        slopes.append(imp["w"][k] / dist)
        # the old (one-impact) orbit just past its grazing, on its own side of kappa_g: the
        # flight from its impact dips below the wall, and the kernel meets it there
        old = graze.problem
        Xo = C.newton(old, graze.X, kg - dist)
        first = _kernel_impacts(old, Xo, kg - dist, 1)
        w_new = first["v_in"][0][0]                            # the wall is fixed: w = v
        assert first["t"][0][0] < old.impacts(Xo, kg - dist)["t"][0] + old.duration(kg - dist)
        roots.append(abs(w_new) / math.sqrt(dist))
    assert max(slopes) - min(slopes) <= 1e-5 * abs(np.mean(slopes)), slopes
    assert abs(np.mean(slopes) + 0.8103) < 1e-3
    # |w-| / sqrt(distance) converges (to 1.6954), its correction shrinking by sqrt(10) a
    # decade: |w-| = c sqrt(distance) (1 + O(sqrt(distance))), Nordmark's square root
    steps = np.diff(roots)
    assert np.all(steps > 0.0) and np.all((steps[:-1] / steps[1:] > 2.5)
                                          & (steps[:-1] / steps[1:] < 4.0)), roots
    assert steps[-1] < 1e-4 * roots[-1]
