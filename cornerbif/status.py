"""Status codes: the one table through which kernels report how a run ended.

Kernels never raise; every run ends with exactly one of these codes and the
Python layer decides what is an error.
"""

OK = 0              # the requested impacts were recorded
NO_IMPACT = 1       # time budget spent without the requested impacts (free flight misses the obstacle)
STUCK = 2           # the particle stuck to the obstacle and never left within the time budget
MAX_EVENTS = 3      # event budget spent (e.g. an unresolved chattering sequence)
ESCAPED = 4         # amplitude beyond the escape bound (energy pumped in, r = 1)
BELOW_OBSTACLE = 5  # the initial state lies below the obstacle
STEP_LIMIT = 6      # the certified root search did not close within its step budget
NONFINITE = 7       # a non-finite state appeared

NAMES = {
    OK: "OK",
    NO_IMPACT: "NO_IMPACT",
    STUCK: "STUCK",
    MAX_EVENTS: "MAX_EVENTS",
    ESCAPED: "ESCAPED",
    BELOW_OBSTACLE: "BELOW_OBSTACLE",
    STEP_LIMIT: "STEP_LIMIT",
    NONFINITE: "NONFINITE",
}
