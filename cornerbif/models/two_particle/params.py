"""The ``two_particle`` model of section 6: wall w, heavy particle z, light particle u.

Equations (paper section 6.1)::

    w(t)  = kappa + beta sin(omega0 t)                       (72)
    z'' + omega1^2 z = 0,   u'' + omega2^2 u = 0  in flight   (73)
    w <= z <= u at all times

Beyond the paper, each particle may carry damping and harmonic forcing per unit
mass as the ``flow`` oscillator (eq 4):
z'' + 2 sigma1 z' + omega1^2 z = F1 cos(Omega1 t + phi1) and
u'' + 2 sigma2 u' + omega2^2 u = F2 cos(Omega2 t + phi2); all default to 0
(Omega to 1), which is (73) exactly.  Flights reuse the closed forms of
``numerics.oscillator``.

* w-z impacts (z = w): law (5) with restitution r1, the wall having infinite
  mass: y+ = (1 + r1) w'(t) - r1 y-.
* z-u impacts (u = z): law (74) with restitution r2 and mass ratio mu = M/m:
  momentum M y + m v is conserved and the relative velocity is reversed and
  scaled by r2; ``mu = inf`` gives exactly law (5) for u against z (y+ = y-).

Parameters have names in Python and live in one packed float64 vector inside
the kernels, indexed by the constants below.

Pure Python (no numba): checking a scene reads these declarations without loading a
kernel.  ``models/two_particle/packed.py`` adds the jitted pieces the kernels call (``as_tuple``,
the impact law ``mass_ratio_impact``) and re-exports everything here.
"""

import math

import numpy as np

from ...model import FREQUENCY, Param, anything, frequency, nonnegative, positive, unit_interval

# --- the declarations (read by config through the registry) ------------------------------
PARAMS = {p.name: p for p in (
    Param("omega0", 2.0, FREQUENCY, frequency, "wall frequency", "eq 72"),
    Param("omega1", 1.001, FREQUENCY, frequency, "natural frequency of the heavy particle z", "eq 73"),
    Param("omega2", 1.0, FREQUENCY, frequency, "natural frequency of the light particle u", "eq 73"),
    Param("mu", 1000.0, "> 0 (inf allowed: law (74) becomes law (5))", positive,
          "mass ratio M/m", "eq 74", inf_ok=True),
    Param("r1", 0.8, "in [0, 1]", unit_interval, "restitution of w-z impacts", "eq 5"),
    Param("r2", 0.8, "in [0, 1]", unit_interval, "restitution of z-u impacts", "eq 74"),
    Param("kappa", 0.0, "any finite number", anything, "wall offset", "eq 72"),
    Param("beta", 1.0, ">= 0", nonnegative, "wall amplitude", "eq 72"),
    # beyond the paper: damping and forcing per particle as in 'flow' (eq 4)
    Param("sigma1", 0.0, ">= 0", nonnegative, "damping of z", "eq 4"),
    Param("sigma2", 0.0, ">= 0", nonnegative, "damping of u", "eq 4"),
    Param("F1", 0.0, "any finite number", anything, "forcing of z per unit mass", "eq 4"),
    Param("Omega1", 1.0, FREQUENCY, frequency, "forcing frequency of z", "eq 4"),
    Param("phi1", 0.0, "any finite number", anything, "forcing phase of z", "eq 4"),
    Param("F2", 0.0, "any finite number", anything, "forcing of u per unit mass", "eq 4"),
    Param("Omega2", 1.0, FREQUENCY, frequency, "forcing frequency of u", "eq 4"),
    Param("phi2", 0.0, "any finite number", anything, "forcing phase of u", "eq 4"),
)}

# --- indices into the packed vector --------------------------------------------------
OMEGA0 = 0    # wall frequency omega0 (eq 72)
OMEGA1 = 1    # natural frequency of the heavy particle z (eq 73)
OMEGA2 = 2    # natural frequency of the light particle u (eq 73)
MU = 3        # mass ratio mu = M/m (eq 74); inf allowed (law 5)
R1 = 4        # restitution of w-z impacts (law 5)
R2 = 5        # restitution of z-u impacts (law 74)
KAPPA = 6     # wall offset kappa (eq 72)
BETA = 7      # wall amplitude beta (eq 72)
TOL = 8       # event-time tolerance
CHATTER = 9   # relative velocity below which a chattering sequence is summed
ESCAPE = 10   # amplitude bound beyond which a run is ESCAPED
SECTION = 11  # Poincare section period in time (default 2 pi / omega0)
SIGMA1 = 12   # damping of z (eq 4 applied to z)
SIGMA2 = 13   # damping of u
F1 = 14       # forcing of z per unit mass: F1 cos(Omega1 t + phi1)
OMF1 = 15
PHI1 = 16
F2 = 17       # forcing of u per unit mass: F2 cos(Omega2 t + phi2)
OMF2 = 18
PHI2 = 19
NPARAM = 20


NAMES = ("omega0", "omega1", "omega2", "mu", "r1", "r2", "kappa", "beta",
         "sigma1", "sigma2", "F1", "Omega1", "phi1", "F2", "Omega2", "phi2")
# the slots of the named parameters (declared in PARAMS above)
INDEX = {"omega0": OMEGA0, "omega1": OMEGA1, "omega2": OMEGA2, "mu": MU, "r1": R1,
         "r2": R2, "kappa": KAPPA, "beta": BETA, "sigma1": SIGMA1, "sigma2": SIGMA2,
         "F1": F1, "Omega1": OMF1, "phi1": PHI1, "F2": F2, "Omega2": OMF2, "phi2": PHI2}
# optional keys (damping and forcing beyond the paper) and their declared defaults
OPTIONAL = {k: PARAMS[k].default for k in ("sigma1", "sigma2", "F1", "Omega1", "phi1", "F2",
                                              "Omega2", "phi2")}

# --- integer run settings (a small int64 vector) --------------------------------------
I_TRANSIENT = 0    # z-u impacts skipped before recording
I_RECORD = 1       # z-u impacts recorded
I_MAX_EVENTS = 2   # budget of events (impacts, stick and release)
I_MAX_PERIODS = 3  # budget of section periods
I_CONTROL = 4      # the address of the sweep's control (``_jit.Control``), 0 for none
NINT = 5


def pack(values: dict, tol: float = 1e-12, chatter: float = 1e-6, escape: float = 1e6,
         section_period: float | None = None) -> np.ndarray:
    """Pack named parameters of one point into the kernel's float64 vector.

    ``values`` holds omega0, omega1, omega2, mu, r1, r2, kappa, beta (all
    required), optionally the damping and forcing keys of ``OPTIONAL`` and
    ``section_period``.  Every value is checked here,
    before any kernel runs: NaN or out-of-range values raise ``ValueError``
    naming the key and the value.
    """
    unknown = set(values) - set(NAMES) - {"section_period"}
    if unknown:
        raise ValueError(f"two_particle: unknown parameter(s) {sorted(unknown)}; "
                         f"allowed: {', '.join(NAMES)}, section_period")
    p = np.zeros(NPARAM)
    problems = []
    for k, decl in PARAMS.items():
        if k not in values and k not in OPTIONAL:
            problems.append(f"{k}: missing")
            continue
        v = values.get(k, decl.default)
        problem = decl.problem(v, k)
        if problem:
            problems.append(problem)
        else:
            p[INDEX[k]] = float(v)
    if not problems:
        problem = resonance_problem(p)
        if problem:
            problems.append(problem)
    sp = values.get("section_period", section_period)
    if sp is None and p[OMEGA0] > 0.0:
        sp = 2.0 * math.pi / p[OMEGA0]
    if sp is None or not (math.isfinite(sp) and sp > 0.0):
        problems.append(f"section_period: {sp!r} must be finite and > 0")
    for name, v in (("tol", tol), ("chatter", chatter), ("escape", escape)):
        if not (math.isfinite(v) and v > 0.0):
            problems.append(f"{name}: {v!r} must be finite and > 0")
    if problems:
        raise ValueError("two_particle: " + "; ".join(problems))
    p[TOL] = tol
    p[CHATTER] = chatter
    p[ESCAPE] = escape
    p[SECTION] = sp
    return p


def resonance_problem(p: np.ndarray) -> str | None:
    """The undamped exact resonance of a particle or of the stuck pair in the packed row
    ``p``, in words, or None: the closed forms of numerics.oscillator need a non-resonant
    forcing when undamped (F cos(Omega t) with Omega equal to the undamped frequency of z,
    of u, or of the stuck pair, whose frequency and damping are mass-weighted)."""
    mu = p[MU]
    mui = 0.0 if mu == math.inf else 1.0 / (1.0 + mu)
    with np.errstate(over="ignore", invalid="ignore"):   # frequencies near 1e308: inf, nan
        om_pair = math.sqrt(p[OMEGA1] ** 2 + (p[OMEGA2] ** 2 - p[OMEGA1] ** 2) * mui)
    sig_pair = p[SIGMA1] + (p[SIGMA2] - p[SIGMA1]) * mui
    muf = 1.0 if mu == math.inf else mu / (1.0 + mu)
    for amp, wk, sig, k, who in (
            (p[F1], "Omega1", p[SIGMA1], p[OMEGA1], "omega1"),
            (p[F2], "Omega2", p[SIGMA2], p[OMEGA2], "omega2"),
            (p[F1] * muf, "Omega1", sig_pair, om_pair, "the stuck pair's Omega"),
            (p[F2] * mui, "Omega2", sig_pair, om_pair, "the stuck pair's Omega")):
        if amp != 0.0 and sig == 0.0 and p[INDEX[wk]] == k:
            return (f"{wk}: {float(p[INDEX[wk]])!r} equals {who} with no damping "
                    f"(undamped resonance, unbounded flight); change {wk} or add damping")
    return None
