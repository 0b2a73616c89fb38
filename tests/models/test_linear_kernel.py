"""The linear system's jitted event loop (cornerbif/models/linear/kernel.py, issue 33), which
searches on a ladder of precomputed flights instead of a matrix exponential per step,
against the engine's kernels where the paper's systems are special cases, and against the
pure-numpy run (simulate.py, checked itself against the 30-digit reference)."""

import sys

import numpy as np
import pytest

import cornerbif
from cornerbif.models.linear.kernel import BUDGET, CHATTERS, OK, run_system
from cornerbif.models.linear.simulate import simulate
from cornerbif.models.linear.system import Contact, Forcing, LinearSystem

sys.path.insert(0, __file__.rsplit("/", 2)[0])
from linear_systems import MU, OMEGA1, OMEGA2, impact_damper, one_mass, two_particles  # noqa: E402


@pytest.mark.parametrize("obstacle, omega, extra", [
    ("rectified_sine", 1.8, {}),
    ("rectified_sine", 2.3, {"sigma": 0.05, "k": 1.2, "F": 0.5, "Omega": 1.3, "phi": 0.2}),
    ("triangle", 1.9, {}),
    ("sine", 1.5, {}),
])
def test_one_mass_is_the_flow_kernel(obstacle, omega, extra):
    """20 impacts from (5, 0): times and velocities equal the flow kernel's to 1e-10 (both
    resolve impact times to 1e-12; by the 30th the difference has grown to 1.3e-10 on the
    damped, forced case)."""
    st, out = run_system(one_mass(obstacle, omega, **extra), 0.0, [5.0], [0.0], 20)
    assert st == OK and len(out["t"]) == 20
    ref = cornerbif.simulate(5.0, 0.0, model="flow", obstacle=obstacle, omega=omega, kappa=0.0,
                             beta=1.0, r=0.8, record=20, **extra)
    np.testing.assert_allclose(out["t"], np.ravel(ref["t"]), rtol=0, atol=1e-10)
    np.testing.assert_allclose(out["v_out"][:, 0], np.ravel(ref["v_out"]), rtol=0, atol=1e-10)


def test_two_masses_are_the_two_particle_kernel():
    """Fig. 19(a)'s system at omega0 = 2 (two coordinates, the wall W and the pair U):
    10 u-z and 10 w-z impacts equal the two-particle kernel's to 1e-10, in order."""
    mu, w1, w2 = MU, OMEGA1, OMEGA2
    s = two_particles()
    st, out = run_system(s, 0.0, [1.0, 15.0], [0.5, 0.0], 20)
    assert st == OK
    ref = cornerbif.simulate(1.0, 0.5, 15.0, 0.0, model="two_particle", omega0=2.0, omega1=w1,
                             omega2=w2, mu=mu, r1=0.8, r2=0.8, kappa=0.0, beta=1.0, record=20)
    u = [k for k, c in enumerate(out["contact"]) if c == "U"][:10]
    w = [k for k, c in enumerate(out["contact"]) if c == "W"][:10]
    np.testing.assert_allclose(out["t"][u], np.ravel(ref["t"])[:10], atol=1e-10, rtol=0)
    np.testing.assert_allclose(out["v_out"][u, 1], np.ravel(ref["v_out"])[:10], atol=1e-10,
                               rtol=0)
    np.testing.assert_allclose(out["t"][w], np.ravel(ref["wz_t"])[:10], atol=1e-10, rtol=0)


def test_an_impact_damper_equals_the_numpy_run():
    """The impact damper of test_linear_simulate.py (a forced, damped primary and a free
    mass in its cavity, r = 0.5): both runs find the same 40 impacts on the same contacts,
    impacts 8-27 a chattering sequence on L whose 27th is held (its rebound below run.chatter:
    v+ along the gap 0, docs/linear.md "Sticking"), after which both go on (OK); the first 20
    impacts' times and velocities equal to 1e-9 (a chattering sequence magnifies the 1e-12
    of each impact time: 8e-9 at the 27th)."""
    s = impact_damper()
    st, out = run_system(s, 0.0, [0.0, 0.0], [0.0, 0.0], 40)
    imp, why = simulate(s, [0.0, 0.0], [0.0, 0.0], 0.0, 40)
    assert st == OK and why == "ok" and len(imp) == len(out["t"]) == 40
    assert out["contact"] == [i.contact for i in imp]
    a = s.contacts[[c.name for c in s.contacts].index("L")].gap
    assert out["contact"][26] == "L" and a @ out["v_out"][26] == pytest.approx(0.0, abs=1e-15)
    np.testing.assert_allclose(out["t"][:20], [i.t for i in imp[:20]], atol=1e-9, rtol=0)
    np.testing.assert_allclose(out["v_out"][:20], [i.v_out for i in imp[:20]], atol=1e-9, rtol=0)


def test_a_chattering_ball_ends_the_run_saying_so():
    """A ball under gravity on a floor with r = 0.5: its rebounds fall geometrically
    (v_k = 0.5^k v_0) until the first below 1e-6, after ceil(log(1e-6 / v_0) / log 0.5)
    impacts with v_0 = sqrt(2) r (each rebound to 1e-9, or 1e-11 absolute: an impact time's
    1e-12 under gravity 1); that impact holds the ball (v+ = 0, docs/linear.md "Sticking") to
    the budget, which ends the run stuck (CHATTERS)."""
    s = LinearSystem(("u",), np.array([[1.0]]), np.array([[0.0]]), np.array([[0.0]]),
                     (Forcing(0, -1.0),), (Contact("R", np.array([1.0]), "fixed", 0.0, r=0.5),))
    st, out = run_system(s, 0.0, [1.0], [0.0], 200, t_max=50.0)
    v0 = np.sqrt(2.0) * 0.5
    assert st == CHATTERS
    assert len(out["t"]) == int(np.ceil(np.log(1e-6 / v0) / np.log(0.5))) + 1
    np.testing.assert_allclose(out["v_out"][:-1, 0], v0 * 0.5 ** np.arange(len(out["t"]) - 1),
                               rtol=1e-9, atol=1e-11)
    assert out["v_out"][-1, 0] == 0.0


def test_a_run_that_meets_no_impact_ends_on_its_budget():
    """A stiff oscillator (k = 1e4, |A| about 1e4: chunks of 1e-4) that never reaches its stop
    at -2 from (1, 0): the loop crosses the fixed obstacle's piece ends (multiples of pi)
    thousands of times and ends on its time budget.  (Seen in review: at a piece's end t
    rounded into the ended piece, the chunk had length 0, and past t ~ 9000 chunks the loop
    never moved again.)"""
    s = LinearSystem(("u",), np.array([[1.0]]), np.array([[1e4]]), np.array([[0.0]]), (),
                     (Contact("R", np.array([1.0]), "fixed", -2.0),))
    st, out = run_system(s, 0.0, [1.0], [0.0], 5, t_max=5.0)
    assert st == BUDGET and len(out["t"]) == 0


def test_an_impact_resolved_just_before_a_piece_end_is_not_found_again():
    """A ball under gravity (g = 1) dropped from 1.0 onto a fixed floor, its landing put
    1e-12 before pi (a fixed obstacle's piece end) by its start time: an impact resolved to
    tol leaves the gap up to |w| tol below zero at the next piece's start, where the contact
    is leaving.  The kernel and the numpy run find the same impacts, at pi - 1e-12, then
    2.6 pi (the rebound 0.8 v: flight 2 (0.8 v) / g), not a second impact at pi (seen in
    review on the numpy run)."""
    s = LinearSystem(("u",), np.array([[1.0]]), np.array([[0.0]]), np.array([[0.0]]),
                     (Forcing(0, -1.0),), (Contact("R", np.array([1.0]), "fixed", 0.0, r=0.8),))
    t0 = np.pi - 1e-12 - np.sqrt(2.0)
    st, out = run_system(s, t0, [1.0], [0.0], 3)
    imp, why = simulate(s, [1.0], [0.0], t0, 3)
    assert st == OK and why == "ok"
    v = np.sqrt(2.0)
    want = [np.pi - 1e-12, np.pi - 1e-12 + 2 * 0.8 * v, np.pi - 1e-12 + 2 * 0.8 * v * 1.8]
    np.testing.assert_allclose(out["t"], want, atol=1e-9, rtol=0)
    np.testing.assert_allclose([i.t for i in imp], want, atol=1e-9, rtol=0)


def test_the_loops_obstacle_tuples_are_the_obstacle_functions_tuples():
    """``kernel.contact_tuples`` reads a contact's packed and derived rows off the stacked
    arrays as the tuples of ``flow.packed.as_tuple`` and ``dispatch.derived_tuple`` (the
    types every obstacle function is called with): element for element, for each kind."""
    from cornerbif.models.flow.packed import as_tuple
    from cornerbif.models.linear.kernel import contact_tuples, prepare
    from cornerbif.obstacles.dispatch import derived_tuple
    s = LinearSystem(("x", "y"), np.eye(2), np.eye(2), np.zeros((2, 2)), (),
                     tuple(Contact(n, np.array([1.0, -1.0]), kind, 0.1, 0.7, 1.9, r=0.5)
                           for n, kind in zip("ABC", ("rectified_sine", "sine", "triangle")))
                     + (Contact("D", np.array([0.0, 1.0]), "fixed", -0.2, r=0.5),))
    a = prepare(s, 0.0, np.zeros(2), np.zeros(2))
    for i in range(4):
        row, d = contact_tuples(a["rows"], a["ds"], i)
        assert row == as_tuple(a["rows"][i]) and len(row) == a["rows"].shape[1]
        assert d == derived_tuple(a["ds"][i])


def test_impact_times_do_not_drift_with_the_start_time():
    """An autonomous system (a mass on a spring against a fixed stop, beside a decoupled
    stiff coordinate that makes |A| = 1e4: short chunks) started at t0 gives the impact times
    of the start at 0 shifted by t0, to the rounding of t (1e-12 at t0 = 1e4).  Time summed
    chunk by chunk drifted by 1e-7 at t0 = 1e4 (found in review)."""
    from cornerbif.models.linear.declare import read_system
    s, _ = read_system({"dofs": ["x", "y"], "mass": [1.0, 1.0], "stiffness": [1.0, 1e4],
                        "contact": [{"name": "A", "gap": {"x": 1.0}, "obstacle": "fixed",
                                     "kappa": -0.5, "r": 0.9}]})
    _, ref = run_system(s, 0.0, np.zeros(2), np.array([-1.0, 0.0]), 4)
    # the first impact: x = -sin t reaches -0.5 at pi + asin(0.5)... from x' = -1: x = -sin t
    assert abs(ref["t"][0] - np.arcsin(0.5)) < 1e-11
    for t0 in (1000.0, 1e4):
        _, out = run_system(s, t0, np.zeros(2), np.array([-1.0, 0.0]), 4, t_max=t0 + 100.0)
        np.testing.assert_allclose(out["t"] - t0, ref["t"], rtol=0, atol=5e-12)


def test_a_contact_moving_away_does_not_hide_another_contacts_impact():
    """A start 1e-14 before a triangle's peak corner (beta < 0) with its gap 1e-14 below zero,
    leaving it, and a fixed ceiling 0.05 above: the first impact is on the ceiling, at the
    brute force's time (tests/linear_bruteforce.py).  The free step of the contact moving
    away once skipped every other contact (the ceiling was passed by 0.25; found in review)."""
    import math

    import linear_bruteforce as bf
    beta = -0.1
    t0 = math.pi - 1e-14
    z0 = beta * (-(math.pi / 2 - (t0 - math.pi / 2)))
    x0 = z0 - 1e-14
    table = {"dofs": ["x"], "mass": [1.0], "stiffness": [0.0],
             "forcing": [{"on": "x", "F": -0.01}],
             "contact": [{"name": "A", "gap": {"x": 1.0}, "obstacle": "triangle", "kappa": 0.0,
                          "beta": beta, "omega": 1.0, "r": 0.8},
                         {"name": "W", "gap": {"x": -1.0}, "obstacle": "fixed",
                          "kappa": -(x0 + 0.05), "r": 0.8}]}
    from cornerbif.models.linear.declare import read_system
    s, _ = read_system(table)
    _, out = run_system(s, t0, np.array([x0]), np.array([0.2]), 3, t_max=t0 + 5.0)
    assert out["contact"][0] == "W" and abs(out["x"][0, 0] - (x0 + 0.05)) < 1e-9
    res = bf.check_run(table, t0, [x0], [0.2], count=3, t_max=t0 + 5.0)
    assert res["problems"] == [] and res["bf_contact"][0] == "W"
    assert abs(out["t"][0] - res["bf_t"][0]) < 1e-9
