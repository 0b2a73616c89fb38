"""The two-particle orbit problem's Jacobian in closed form (``TwoParticleOrbit.jacobian``:
flight matrices, the free flights' field, the impact laws' derivatives) against central
differences of its residual, written here (issue 31: it was central differences itself)."""

import numpy as np
import pytest

from cornerbif import continuation as C
from cornerbif.models.two_particle import orbit as TO
from cornerbif.models.two_particle import packed as TPM

X0 = [0.18982259867467574, 16.49606490380678, 1.7221809107866082, 149.66189899401783]


def central(residual, X, lam, h=1e-6):
    """dR/dX column by column, steps relative to each unknown (the reference)."""
    out = np.empty((len(X), len(X)))
    for c in range(len(X)):
        e = np.zeros(len(X))
        e[c] = h * max(1.0, abs(X[c]))
        out[:, c] = (residual(X + e, lam) - residual(X - e, lam)) / (2.0 * e[c])
    return out


@pytest.mark.parametrize("extra", [
    {},                                                    # Fig. 19: mu = 1000, no damping
    {"sigma1": 0.05, "sigma2": 0.02},                      # damped flights
    {"F1": 0.4, "Omega1": 2.0, "mu": 50.0, "r2": 0.6},     # forced, a lighter mass ratio
])
def test_the_closed_form_jacobian_is_the_central_differences(extra):
    vals = {k: p.default for k, p in TPM.PARAMS.items()} | {"omega0": 2.0} | extra
    prob, X = TO.two_particle_seed(vals, "omega0", X0, 1)
    assert set(prob.kinds) == {"U", "W"}
    # at the orbit and off it (a point where the residual is not zero)
    for Y in (X, X + 1e-3 * np.sin(np.arange(len(X)) + 1.0)):
        J = prob.jacobian(Y, 2.0)
        ref = central(prob.residual, Y, 2.0)
        scale = np.abs(ref).max()
        assert np.abs(J - ref).max() <= 1e-6 * scale, np.abs(J - ref).max() / scale
    # Newton on the closed form converges to the same orbit, quadratically
    Xn = C.newton(prob, X + 1e-6, 2.0)
    assert np.abs(Xn - X).max() <= 1e-9 * (1.0 + np.abs(X).max())
