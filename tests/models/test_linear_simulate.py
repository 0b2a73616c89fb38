"""The linear model's pieces together (cornerbif/models/linear/simulate.py: exact flights,
certified events, the generalised Newton law; issue 33) against the engine's kernels where
the paper's systems are special cases, and against the 30-digit reference
(tests/linear_reference.py) on a system the kernels cannot run."""

import sys

import numpy as np
import pytest

import cornerbif
from cornerbif.models.linear.simulate import simulate
from cornerbif.models.linear.system import Contact, Forcing, LinearSystem

sys.path.insert(0, __file__.rsplit("/", 2)[0])
from linear_reference import Reference  # noqa: E402
from linear_systems import MU, OMEGA1, OMEGA2, impact_damper, one_mass, two_particles  # noqa: E402


@pytest.mark.parametrize("obstacle, omega, extra", [
    ("rectified_sine", 1.8, {}),                        # Fig. 4's obstacle, a period-4 orbit
    ("rectified_sine", 2.3, {"sigma": 0.05, "k": 1.2, "F": 0.5, "Omega": 1.3, "phi": 0.2}),
    ("triangle", 1.9, {}),                              # eq (7): corners and flat pieces
    ("sine", 1.5, {}),                                  # the smooth wall of section 2.2
])
def test_one_mass_is_the_flow_kernel(obstacle, omega, extra):
    """20 impacts from (5, 0): times and velocities equal the flow kernel's to 1e-10."""
    imp, why = simulate(one_mass(obstacle, omega, **extra), [5.0], [0.0], 0.0, 20)
    assert why == "ok" and len(imp) == 20
    out = cornerbif.simulate(5.0, 0.0, model="flow", obstacle=obstacle, omega=omega, kappa=0.0,
                             beta=1.0, r=0.8, record=20, **extra)
    for name, got in (("t", [i.t for i in imp]), ("v_in", [i.v_in[0] for i in imp]),
                      ("v_out", [i.v_out[0] for i in imp])):
        np.testing.assert_allclose(got, np.ravel(out[name]), rtol=0, atol=1e-10, err_msg=name)


def test_two_masses_are_the_two_particle_kernel():
    """Fig. 19(a)'s system at omega0 = 2 as two coordinates and two contacts (the wall W and
    the pair U, as tests/models/test_linear_reference.py builds it): 8 u-z and 8 w-z impacts
    equal the two-particle kernel's to 1e-10, in the same order."""
    mu, w1, w2 = MU, OMEGA1, OMEGA2
    s = two_particles()
    imp, why = simulate(s, [1.0, 15.0], [0.5, 0.0], 0.0, 16)
    assert why == "ok"
    out = cornerbif.simulate(1.0, 0.5, 15.0, 0.0, model="two_particle", omega0=2.0, omega1=w1,
                             omega2=w2, mu=mu, r1=0.8, r2=0.8, kappa=0.0, beta=1.0, record=16)
    zu = [i for i in imp if i.contact == "U"][:8]
    wz = [i for i in imp if i.contact == "W"][:8]
    np.testing.assert_allclose([i.t for i in zu], np.ravel(out["t"])[:8], atol=1e-10, rtol=0)
    np.testing.assert_allclose([i.v_out[1] for i in zu], np.ravel(out["v_out"])[:8], atol=1e-10,
                               rtol=0)
    np.testing.assert_allclose([i.t for i in wz], np.ravel(out["wz_t"])[:8], atol=1e-10, rtol=0)
    np.testing.assert_allclose([i.v_out[0] for i in wz], np.ravel(out["wz_y_out"])[:8],
                               atol=1e-10, rtol=0)


def test_an_impact_damper_equals_the_30_digit_reference():
    """A forced, damped primary mass x (m = 1, k = 1) with a free mass y (m = 0.1) in a
    cavity of clearance 2 x 0.4 (contacts R: y - x >= -0.4 and L: x - y >= -0.4, r = 0.5),
    from rest: the first 10 impacts, their order, times and velocities, equal the mpmath
    reference's to 1e-9 (flights there at 30 digits, impacts by sampling and bisection)."""
    s = impact_damper()
    imp, why = simulate(s, [0.0, 0.0], [0.0, 0.0], 0.0, 10)
    assert why == "ok"
    ref = Reference(s).impacts(0.0, [0.0, 0.0], [0.0, 0.0], 10)
    assert [i.contact for i in imp] == [r[1] for r in ref]
    np.testing.assert_allclose([i.t for i in imp], [r[0] for r in ref], atol=1e-9, rtol=0)
    np.testing.assert_allclose([i.v_out for i in imp], [r[4] for r in ref], atol=1e-9, rtol=0)


def test_a_chattering_run_says_so():
    """A ball (k = 0) under gravity on a fixed floor with r = 0.5 chatters to rest: at the
    impact whose rebound is below run.chatter it is held (v+ = 0; docs/linear.md,
    "Sticking") to the horizon, and says so.  Beside a soft stop (which the hold does not
    handle yet) the run stops at that impact, and says so."""
    s = LinearSystem(("u",), np.array([[1.0]]), np.array([[0.0]]), np.array([[0.0]]),
                     (Forcing(0, -1.0),), (Contact("R", np.array([1.0]), "fixed", 0.0, r=0.5),))
    imp, why = simulate(s, [1.0], [0.0], 0.0, 200, horizon=20.0)
    assert "held on contact R" in why and imp[-1].v_out[0] == 0.0 and imp[-2].v_out[0] > 1e-6
    soft = Contact("S", np.array([-1.0]), "fixed", -5.0, law="spring", k=10.0)
    s = LinearSystem(("u",), np.array([[1.0]]), np.array([[0.0]]), np.array([[0.0]]),
                     (Forcing(0, -1.0),), (Contact("R", np.array([1.0]), "fixed", 0.0, r=0.5), soft))
    imp, why = simulate(s, [1.0], [0.0], 0.0, 200)
    assert "chatters on contact R" in why and imp[-1].v_out[0] <= 1e-6 < imp[-2].v_out[0]
