"""The ``flow`` model's packed parameter row: the slot of each value in the float64 vector
the kernels read (one vector, so every kernel compiles exactly once), a cam profile's table
in the longer rows of ``obstacle = "profile"``, and the integer run settings.

Pure constants: the obstacle kinds (``cornerbif/obstacles``) pack into these slots and the
kernels read them as ``P.*`` (``models/flow/packed.py``).
"""

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


# --- integer run settings (a small int64 vector) --------------------------------------
I_TRANSIENT = 0
I_RECORD = 1
I_MAX_EVENTS = 2
I_MAX_PIECES = 3
I_CONTROL = 4      # the address of the sweep's control (``_jit.Control``: stop flag, runs
                   # finished), 0 for none: ``engine.with_control``
NINT = 5


def wide_rows(rows) -> bool:
    """Whether packed rows have the longer layout (NPARAM_PROFILE: an obstacle kind with its
    own kernel, a cam) rather than NPARAM."""
    return rows.shape[1] > NPARAM

# the budgets of a flow run (``FlowModel.int_settings``, config's automatic rule): at most
# PIECES_PER_PERIOD obstacle pieces per period (triangle, sine: 2), EVENTS_PER_IMPACT events
# (impacts, releases, corners crossed stuck) per impact
PIECES_PER_PERIOD = 4
EVENTS_PER_IMPACT = 10
