"""The slow reference for linear vibro-impact systems (tests/linear_reference.py, issue 33)
against the engine's own kernels, where the paper's systems are special cases of a linear
system: one mass against an obstacle is the ``flow`` model (law 5), and two masses with a
wall and a contact between them are the ``two_particle`` model (laws 5 and 74).  The
reference shares no code with either (mpmath flights of the augmented system, impacts found
by sampling and bisection, the generalised Newton law written out), so agreement to 1e-10
checks both the kernels and the reference the linear model's kernel will be tested against.
"""

import sys

import numpy as np
import pytest

import cornerbif

sys.path.insert(0, __file__.rsplit("/", 2)[0])
from linear_reference import Reference  # noqa: E402
from linear_systems import MU, OMEGA1, OMEGA2, one_mass, two_particles  # noqa: E402


@pytest.mark.parametrize("obstacle, omega, extra, count", [
    ("rectified_sine", 1.8, {}, 10),                                 # a period-4 orbit
    # Fig. 1(a), chaotic: the kernel's event tolerance (run.tol = 1e-12: 5e-13 at the
    # first impact) grows about 3x an impact (measured: 8e-10 in v+ at the 10th), so 5
    ("sine", 2.84, {}, 5),
    ("rectified_sine", 2.3, {"sigma": 0.05, "k": 1.2, "F": 0.5, "Omega": 1.3, "phi": 0.2}, 10),
])
def test_one_mass_is_the_flow_model(obstacle, omega, extra, count):
    """u'' + 2 sigma u' + k^2 u = F cos(Omega t + phi) against the obstacle, from (5, 0):
    the first impacts' times, heights and velocities equal the flow kernel's to 1e-10."""
    ref = Reference(one_mass(obstacle, omega, **extra)).impacts(0.0, [5.0], [0.0], count)
    out = cornerbif.simulate(5.0, 0.0, model="flow", obstacle=obstacle, omega=omega, kappa=0.0,
                             beta=1.0, r=0.8, record=count, **extra)
    got = np.array([np.ravel(out[k])[:count] for k in ("t", "u", "v_in", "v_out")])
    want = np.array([[i[0] for i in ref], [i[2][0] for i in ref], [i[3][0] for i in ref],
                     [i[4][0] for i in ref]])
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-10)


def test_two_masses_are_the_two_particle_model():
    """Fig. 19(a)'s system at omega0 = 2: z (mass 1, z'' + omega1^2 z = 0) above the wall
    w = kappa + beta sin(omega0 t) (gap z - w, law 5 with r1) and u (mass 1/mu,
    u'' + omega2^2 u = 0) above z (gap u - z, law 74 with r2), as a linear system of two
    coordinates and two contacts: the first 6 u-z and 6 w-z impacts equal the two-particle
    kernel's to 1e-10."""
    mu, w1, w2 = MU, OMEGA1, OMEGA2
    s = two_particles()
    ref = Reference(s).impacts(0.0, [1.0, 15.0], [0.5, 0.0], 12)
    out = cornerbif.simulate(1.0, 0.5, 15.0, 0.0, model="two_particle", omega0=2.0, omega1=w1,
                             omega2=w2, mu=mu, r1=0.8, r2=0.8, kappa=0.0, beta=1.0, record=12)
    zu = [i for i in ref if i[1] == "U"][:6]
    wz = [i for i in ref if i[1] == "W"][:6]
    np.testing.assert_allclose(np.ravel(out["t"])[:6], [i[0] for i in zu], atol=1e-10, rtol=0)
    np.testing.assert_allclose(np.ravel(out["u"])[:6], [i[2][1] for i in zu], atol=1e-10, rtol=0)
    np.testing.assert_allclose(np.ravel(out["v_out"])[:6], [i[4][1] for i in zu], atol=1e-10,
                               rtol=0)
    np.testing.assert_allclose(np.ravel(out["wz_t"])[:6], [i[0] for i in wz], atol=1e-10, rtol=0)
    np.testing.assert_allclose(np.ravel(out["wz_y_out"])[:6], [i[4][0] for i in wz], atol=1e-10,
                               rtol=0)
