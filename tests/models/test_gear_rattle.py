"""configs/gear_rattle.toml against closed forms written here: the gear's relative motion in
its backlash, x'' + c x' = P + F cos(Omega t) (m = 1, K = 0: a rigid-body mode, a constant
drag P and a harmonic force), between the drive flank x = -b (contact D) and the coast flank
x = b (contact C), r at both.

In flight x(t) = C1 + C2 exp(-c t) + (P / c) t + a cos(Omega t) + s sin(Omega t) with
a = -F / (Omega^2 + c^2), s = c F / (Omega (Omega^2 + c^2)).  The double-sided orbit CD (one
impact on each flank per period T = 2 pi / Omega) is then four equations in the two impact
times and the two velocities after impact (each flight reaches the other flank, where the
restitution law gives the next velocity); the single-sided orbit D (one drive-flank impact a
period) is two.  Solved here by scipy from the kernel's cycle as the first guess, they must
give the kernel's impacts (times modulo T, velocities before impact) to 1e-9, and every flight
of the solution must stay inside the backlash (sampled), so that it is the orbit the scene's
words name."""

import math
import os
import tomllib

import numpy as np
import pytest
from scipy.optimize import fsolve

import cornerbif

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _scene():
    with open(os.path.join(ROOT, "configs", "gear_rattle.toml"), "rb") as fh:
        return tomllib.load(fh)


def _constants(F):
    s = _scene()["system"]
    c = s["damping"][0]
    P = s["forcing"][0]["F"]
    W = s["forcing"][1]["Omega"]
    b = -s["contact"][0]["kappa"]
    r = s["contact"][0]["r"]
    return c, P, F, W, b, r


def _flight(k, t0, x0, v0, t):
    """(x, v) at t of the flight from (x0, v0) at t0 (the closed form above)."""
    c, P, F, W, _, _ = k
    a, s = -F / (W * W + c * c), c * F / (W * (W * W + c * c))
    xp = lambda t: (P / c) * t + a * math.cos(W * t) + s * math.sin(W * t)       # noqa: E731
    vp = lambda t: P / c - a * W * math.sin(W * t) + s * W * math.cos(W * t)    # noqa: E731
    C2 = -(v0 - vp(t0)) * math.exp(c * t0) / c
    C1 = x0 - C2 * math.exp(-c * t0) - xp(t0)
    return C1 + C2 * math.exp(-c * t) + xp(t), -c * C2 * math.exp(-c * t) + vp(t)


def _inside(k, t0, x0, v0, t1):
    b = k[4]
    return all(-b - 1e-9 <= _flight(k, t0, x0, v0, t)[0] <= b + 1e-9
               for t in np.linspace(t0, t1, 400)[1:-1])


def _run(F, starts=8):
    table = _scene()["system"]
    rng = np.random.default_rng(3)
    return cornerbif.simulate(model="linear", table=table, x0=rng.uniform(-0.9, 0.9, starts),
                              v_x0=rng.uniform(-1.0, 1.0, starts), transient=600, record=40,
                              **{"forcing.1.F": F})


# at xtol = 1e-14 fsolve may say it can make no further progress: the residuals decide
@pytest.mark.filterwarnings("ignore:xtol=:RuntimeWarning")
@pytest.mark.parametrize("F", [0.4, 0.6])
def test_the_double_sided_orbit_CD_is_the_closed_forms(F):
    k = _constants(F)
    c, P, F, W, b, r = k
    T = 2 * math.pi / W
    run = _run(F)
    ok = np.flatnonzero(np.asarray(run["symbols"]) == "CD")
    assert len(ok) >= 4
    i = ok[0]
    t, cont, vin, vout = run["t"][i], run["contact"][i], run["v_in"][i], run["v_out"][i]
    j = int(np.flatnonzero(cont == 0)[0])                # a D impact, then C, then D ...
    # the kernel's impact velocities are along each contact's gap: a . v (D: +x', C: -x')
    guess = [t[j], vout[j], t[j + 1], -vout[j + 1]]

    def equations(X):
        tD, vD, tC, vC = X
        xC, vCm = _flight(k, tD, -b, vD, tC)            # D -> C
        xD, vDm = _flight(k, tC, b, vC, tD + T)         # C -> D, one period on
        return [xC - b, vC + r * vCm, xD + b, vD + r * vDm]

    X = fsolve(equations, guess, xtol=1e-14)
    tD, vD, tC, vC = X
    assert max(abs(e) for e in equations(X)) < 1e-12
    assert _inside(k, tD, -b, vD, tC) and _inside(k, tC, b, vC, tD + T)
    for m in range(j, len(t)):                      # the recorded cycle, impact by impact
        if cont[m] == 0:
            want_t, want_vin = tD, _flight(k, tC, b, vC, tD + T)[1]
        else:
            want_t, want_vin = tC, -_flight(k, tD, -b, vD, tC)[1]
        assert abs(math.remainder(t[m] - want_t, T)) < 1e-9, m
        assert abs(vin[m] - want_vin) < 1e-9, m


@pytest.mark.filterwarnings("ignore:xtol=:RuntimeWarning")
def test_the_single_sided_orbit_D_is_the_closed_forms():
    """At F = 0.12 the gear stays on the drive flank, one impact a period (word D)."""
    F = 0.12
    k = _constants(F)
    c, P, F, W, b, r = k
    T = 2 * math.pi / W
    run = _run(F)
    ok = np.flatnonzero(np.asarray(run["symbols"]) == "D")
    assert len(ok) >= 2
    i = ok[0]
    t, vout = run["t"][i], run["v_out"][i]

    def equations(X):
        tD, vD = X
        xD, vDm = _flight(k, tD, -b, vD, tD + T)
        return [xD + b, vD + r * vDm]

    X = fsolve(equations, [t[-1], vout[-1]], xtol=1e-14)
    tD, vD = X
    assert max(abs(e) for e in equations(X)) < 1e-12
    assert _inside(k, tD, -b, vD, tD + T)
    for m in range(len(t) - 6, len(t)):
        assert abs(math.remainder(t[m] - tD, T)) < 1e-9
        assert abs(run["v_in"][i][m] - _flight(k, tD, -b, vD, tD + T)[1]) < 1e-9
