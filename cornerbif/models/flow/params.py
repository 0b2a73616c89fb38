"""The ``flow`` model's parameters: their declarations and the packed vector.

``PARAMS`` declares each parameter (default, allowed range, doc, equation) and
``OBSTACLES`` each obstacle; config reads them through the registry
(``models/flow/model.py``).  Inside the kernels the parameters live in one float64
vector indexed by the constants below, so every kernel compiles exactly once.

Pure Python (no numba): checking a scene reads these declarations without loading a
kernel.  ``models/flow/packed.py`` adds the jitted views of a packed row the kernels call
(``as_tuple``, ``as_tuple_profile``) and re-exports everything here, as ``P``.
"""

import math

import numpy as np

from ...model import FREQUENCY, Obstacle, Param, anything, frequency, nonnegative, positive, unit_interval

# --- indices into the packed vector --------------------------------------------------
OMEGA = 0      # obstacle frequency omega (eq 8)
KAPPA = 1      # obstacle offset kappa (eq 8)
BETA = 2       # obstacle amplitude beta (eq 8)
R = 3          # coefficient of restitution r (eq 5)
SIGMA = 4      # damping sigma (eq 4)
K = 5          # natural frequency k (eq 4)
F_AMP = 6      # forcing amplitude F: f(t) = F cos(Omega t + phi) (eq 4)
F_OMEGA = 7    # forcing frequency Omega
F_PHI = 8      # forcing phase phi
THETA1 = 9     # triangle: slope magnitude before each corner (eq 7)
THETA2 = 10    # triangle: slope after each corner (eq 7)
OBSTACLE = 11  # obstacle code (below)
TOL = 12       # event-time tolerance
CHATTER = 13   # relative velocity below which a chattering sequence is summed
ESCAPE = 14    # amplitude bound beyond which a run is ESCAPED
SECTION_PIECES = 15  # smooth pieces per Poincare section period
SECTION_AUTO = 16    # 1: put the section corners between the impact clusters (see flow kernel)
STOP_TOL = 17        # > 0: stop once the attractor's period is established (run.stop = "period"),
                     # with this relative tolerance on the state at the corners; 0: never
# obstacle = "profile" (obstacles/profile.py): z = kappa + beta g(omega t), g piecewise in the
# cam angle; per piece m the slots PROFILE0 + m * PIECE_STRIDE + (the PC_* offsets)
PROFILE_NP = 18      # pieces per period
PROFILE_PERIOD = 19  # the period of g, an angle
PROFILE_CORNERS = 20 # 1 when some joint is a corner
PROFILE0 = 21
PROFILE_ROW = 21     # in a profile's tuple (as_tuple_profile): the address of its packed row
PC_SPAN = 0          # the piece's angular span
PC_C0 = 1            # c_0 .. c_7 at PC_C0 .. PC_C0 + 7 (the local angle's powers)
PC_A = 9             # a sin(n phi) + b cos(n phi)
PC_B = 10
PC_N = 11
PC_G_LO = 12         # certified bounds on the piece (profile.bounds): of g, of its second
PC_G_HI = 13         # derivative, and of the magnitudes of its third and fourth
PC_G2_LO = 14
PC_G2_HI = 15
PC_G3 = 16
PC_G4 = 17
PC_CORNER = 18       # 1 when the piece's start is a corner
PC_START = 19        # the angle at which the piece starts
PC_STURM = 20        # an upper bound of k^2 g + omega^2 g'' on the piece (profile.sturm_bound)
PC_DEG = 21          # the polynomial's degree (its highest nonzero coefficient)
PC_LEN = 22          # in time: the piece's length span / omega,
PC_T0 = 23           # its start start / omega within the period,
PC_FLOOR = 24        # the Sturm comparison's floor f_min / k^2 on it (0 when k = 0)
PIECE_STRIDE = 25
PROFILE_MAX = 8      # pieces per period at most (profile.MAX_PIECES)
# the built-in obstacles' rows hold the first NPARAM slots; a profile's rows NPARAM_PROFILE.
# The kernels run on two tuple types: a built-in obstacle's NPARAM floats (as_tuple), and a
# profile's first PROFILE0 floats with its row's address (as_tuple_profile), so that no
# call carries the profile's table (obstacles/dispatch.py, "the two tuple types")
NPARAM = 18
NPARAM_PROFILE = PROFILE0 + PROFILE_MAX * PIECE_STRIDE
# the named parameters of PARAMS (below) and their slots (theta1, theta2: pack)
INDEX = {"omega": OMEGA, "kappa": KAPPA, "beta": BETA, "r": R, "sigma": SIGMA, "k": K,
         "F": F_AMP, "Omega": F_OMEGA, "phi": F_PHI}


def steady_or_frequency(v):
    """Omega: 0 (a constant force) or a frequency."""
    return v == 0.0 or frequency(v)


# --- the declarations (read by config through the registry) ------------------------------
# every obstacle of the flow model: a new one is a line here and its jitted pieces in
# obstacles/dispatch.py (docs/architecture.md)
OBSTACLES = {
    "sine": Obstacle("sine", 0, "kappa + beta sin(omega t) (section 2.2, no corners)",
                     period_pi=2, pieces=2, corners=False),
    "rectified_sine": Obstacle("rectified_sine", 1, "kappa + beta |sin(omega t)| (eq 8), "
                               "corners at k pi / omega", period_pi=1, pieces=1, corners=True,
                               normal_form=True),
    "triangle": Obstacle("triangle", 2, "eq (7) made periodic, period pi / omega: slope "
                         "+theta2 after each corner, -theta1 before it", period_pi=1, pieces=2,
                         corners=True),
    # period, pieces and corners are the scene's profile's (obstacles/profile.py, docs/cams.md)
    "profile": Obstacle("profile", 3, "kappa + beta g(omega t), g a cam profile of "
                        "polynomial and sinusoidal pieces ([system.profile])", period_pi=2,
                        pieces=1, corners=True),
}
# the section corners are put between the impact clusters (models.flow.kernel) for obstacles whose
# attractors near omega = 2 have one cluster every second corner (sections 3-4)
AUTO_SECTION = ("rectified_sine",)

PARAMS = {p.name: p for p in (
    Param("omega", 2.0, FREQUENCY, frequency, "obstacle frequency", "eq 8"),
    Param("kappa", 0.0, "any finite number", anything, "obstacle offset", "eq 8"),
    Param("beta", 1.0, ">= 0", nonnegative, "obstacle amplitude", "eq 8"),
    Param("r", 0.8, "in [0, 1]", unit_interval, "coefficient of restitution", "eq 5"),
    Param("sigma", 0.0, ">= 0", nonnegative, "damping", "eq 4"),
    Param("k", 1.0, ">= 0", nonnegative, "natural frequency", "eq 4"),
    Param("F", 0.0, "any finite number", anything, "forcing amplitude: f = F cos(Omega t + phi)",
          "eq 4"),
    Param("Omega", 1.0, ">= 0 (0: a constant force F cos phi, e.g. a follower's spring "
          "preload; its period 2 pi / value finite otherwise)", steady_or_frequency,
          "forcing frequency", "eq 4"),
    Param("phi", 0.0, "any finite number", anything, "forcing phase", "eq 4"),
    Param("theta1", None, "> 0 (default beta * omega, the slope of eq (8) at its corners)",
          positive, "triangle: slope magnitude before each corner", "eq 7",
          obstacles=("triangle",)),
    Param("theta2", None, "> 0 (default beta * omega)", positive,
          "triangle: slope after each corner", "eq 7", obstacles=("triangle",)),
)}

# the obstacle codes the kernels compare (obstacles/dispatch.py)
SINE = OBSTACLES["sine"].code                      # section 2.2 (smooth, no corners)
RECTIFIED_SINE = OBSTACLES["rectified_sine"].code  # eq (8), corners at k pi / omega
TRIANGLE = OBSTACLES["triangle"].code              # eq (7) made periodic with period pi / omega
PROFILE = OBSTACLES["profile"].code                # a cam profile (obstacles/profile.py)

# --- integer run settings (a small int64 vector) --------------------------------------
I_TRANSIENT = 0
I_RECORD = 1
I_MAX_EVENTS = 2
I_MAX_PIECES = 3
I_CONTROL = 4      # the address of the sweep's control (``_jit.Control``: stop flag, runs
                   # finished), 0 for none: ``engine.with_control``
NINT = 5


def obstacle_period(obstacle: str, omega: float, profile=None) -> float:
    """Forcing period P (``Obstacle.period``): pi/omega for rectified_sine and triangle,
    2 pi/omega for sine, the profile's period / omega for a profile."""
    if obstacle == "profile":
        return profile.period / omega
    return OBSTACLES[obstacle].period(omega)


def pieces_per_period(obstacle: str, profile=None) -> int:
    """Smooth pieces per forcing period (``Obstacle.pieces``; a profile's own).

    ``sine`` is split at its half periods (no corner there, but the sign of z''
    is fixed on each half, which tightens the event-location bound);
    ``triangle`` has a rising and a falling piece.
    """
    if obstacle == "profile":
        return len(profile.pieces)
    return OBSTACLES[obstacle].pieces


def pack(values: dict, obstacle: str, tol: float, chatter: float, escape: float,
         section_period: float | None, stop_tol: float = 0.0, profile=None) -> np.ndarray:
    """Pack named parameters of one grid point into the kernel's float64 vector
    (``pack_many`` for one point)."""
    return pack_many(values, 1, obstacle, tol, chatter, escape, section_period, stop_tol,
                     profile)[0]


def pack_many(values: dict, n: int, obstacle: str, tol: float, chatter: float,
              escape: float, section_period: float | None, stop_tol: float = 0.0,
              profile=None) -> np.ndarray:
    """Pack n grid points into rows of the kernel's float64 vector: ``values`` maps each
    named parameter to one value or to n values (a swept one).

    Missing values take their declared defaults (``PARAMS``); theta1 and theta2 default
    to beta * omega (None or NaN).  ``stop_tol`` > 0 turns the kernel's early stop on
    (``run.stop = "period"``).  ``profile``: the checked ``Profile`` of ``obstacle =
    "profile"`` (obstacles/profile.py), written to the PROFILE_* slots of each row.
    """
    p = np.zeros((n, NPARAM_PROFILE if obstacle == "profile" else NPARAM))

    def column(name):
        v = values.get(name, PARAMS[name].default)
        return np.full(n, np.nan) if v is None else np.broadcast_to(np.asarray(v, float), n)
    for name, index in INDEX.items():
        p[:, index] = column(name)
    for name, index in (("theta1", THETA1), ("theta2", THETA2)):
        t = column(name)
        p[:, index] = np.where(np.isnan(t), p[:, BETA] * p[:, OMEGA], t)
    p[:, OBSTACLE] = OBSTACLES[obstacle].code
    p[:, TOL] = tol
    p[:, CHATTER] = chatter
    p[:, ESCAPE] = escape
    if obstacle == "profile":
        for row in p:
            pack_profile(row, profile)
    omegas, at = np.unique(p[:, OMEGA], return_inverse=True)
    p[:, SECTION_PIECES] = np.array([section_pieces(obstacle, float(w), section_period,
                                                    profile) for w in omegas])[at.ravel()]
    p[:, SECTION_AUTO] = 1.0 if (obstacle in AUTO_SECTION and section_period is None) else 0.0
    p[:, STOP_TOL] = stop_tol
    return p


def section_pieces(obstacle: str, omega: float, section_period: float | None,
                   profile=None) -> int:
    """Smooth pieces per Poincare section period (default T = 2 pi / omega; a profile's:
    its own period)."""
    P = obstacle_period(obstacle, omega, profile)
    if section_period is None:
        sp = P if obstacle == "profile" else 2.0 * math.pi / omega
    else:
        sp = section_period
    return max(1, round(sp / P)) * pieces_per_period(obstacle, profile)


def pack_profile(p, profile):
    """Write a checked ``Profile`` (obstacles/profile.py) into the PROFILE_* slots of ``p``."""
    from ...obstacles.profile import bounds, sturm_bound
    p[PROFILE_NP] = len(profile.pieces)
    p[PROFILE_PERIOD] = profile.period
    p[PROFILE_CORNERS] = 1.0 if profile.has_corners else 0.0
    start = 0.0
    for m, pc in enumerate(profile.pieces):
        o = PROFILE0 + m * PIECE_STRIDE
        p[o + PC_SPAN] = pc.span
        p[o + PC_C0:o + PC_C0 + 8] = pc.poly
        p[o + PC_A], p[o + PC_B], p[o + PC_N] = pc.a, pc.b, pc.n
        p[o + PC_G_LO:o + PC_G4 + 1] = bounds(pc)
        p[o + PC_CORNER] = 1.0 if profile.corners[m] else 0.0
        p[o + PC_START] = start
        p[o + PC_STURM] = sturm_bound(pc, p[K], p[OMEGA])
        p[o + PC_LEN] = pc.span / p[OMEGA]
        p[o + PC_T0] = start / p[OMEGA]
        if p[K] > 0.0:
            p[o + PC_FLOOR] = -p[KAPPA] - p[BETA] * p[o + PC_STURM] / (p[K] * p[K])
        nz = np.flatnonzero(np.array(pc.poly))
        p[o + PC_DEG] = nz[-1] if nz.size else 0
        start += pc.span


# --- a profile's bounds, read from its packed row as obstacles/dispatch.py's jitted functions
# read them, in Python: ``profile.scale_problem`` checks a scene with these, loading no numba
# (tests/test_validate_imports.py checks that both give the same numbers)
def row_bound(row, *slots):
    """The largest |row[o + slot]| over the pieces o of a profile's packed row (``pack``)
    and the ``slots`` given: ``obstacle._profile_max(row, slot)`` for one slot,
    ``obstacle.profile_g2_abs(row)`` for PC_G2_LO and PC_G2_HI."""
    n = np.int64(row[PROFILE_NP])
    m = 0.0
    for i in range(n):
        o = PROFILE0 + i * PIECE_STRIDE
        for slot in slots:
            m = max(m, abs(row[o + slot]))
    return m


def npp_bound(beta, w, sigma, k, g2, g3, g4):
    """``obstacle.npp_bound``: beta omega^2 (omega^2 g4 + 2 sigma omega g3 + k^2 g2), the
    bound of the contact force's |N''| less the forcing's share."""
    return beta * w * w * (w * w * g4 + 2.0 * sigma * w * g3 + k * k * g2)
