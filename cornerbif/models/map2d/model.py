"""The ``map2d`` model (sections 4-5): the local piecewise-linear maps alpha, beta, gamma.

The maps (eqs 56-60, with P_alpha from (52)-(53): the printed (58) is a misprint, see
docs/discrepancies.md) act on x = (a0, b1) with epsilon = 1, so omega1 = omega - 2 and
kappa1 = kappa.  The iterates are stored where the flow stores its section values
(``section/u`` = a_n, ``section/v`` = b_n), so flow and map files compare dataset by
dataset.  The kernels are in ``cornerbif/models/map2d/maps.py``.
"""

from __future__ import annotations

import numpy as np

from ... import obstacles
from ... import status as S
from ...model import Coord, CycleSeries, Field, Model, Param, RunResult, Warmup, anything, positive
from ...observables import SECTION_FIELDS, STABILITY_FIELDS, U
from .normal_form import SIDE

# The kernels (models/map2d/maps.py, the stability pass) are imported by the methods that run them:
# importing this module, as checking a scene does, loads no numba.

PARAMS = {p.name: p for p in (
    Param("omega", 1.999, "> 0 (the map uses omega1 = omega - 2)", positive,
          "obstacle frequency; omega1 = omega - 2", "eq 20"),
    Param("kappa", -0.01, "any finite number (kappa1 = kappa)", anything,
          "obstacle offset; kappa1 = kappa", "eq 20"),
    Param("r", 0.8, "in (0, 1]", lambda v: 0.0 < v <= 1.0, "coefficient of restitution",
          "eq 5"),
)}
V = Coord("v", (-0.05, 0.05), 1, None, "initial velocity v(0)", "v at the last section crossed")
# the flow's stability datasets, durations in iterates of the map
PER_ITERATE = {"cycle_duration": ("period of the cycle in iterates", None),
               "lyapunov": ("Lyapunov exponents over the recorded iterates, per iterate "
                            "(exact: the maps' linear parts share an invariant direction, "
                            "docs/stability.md)", "1/iterate"),
               "lyapunov_window": ("iterates over which the exponents are averaged", None)}
STABILITY = tuple(Field(f.name, f.source, *PER_ITERATE[f.source], axis=f.axis)
                  if f.source in PER_ITERATE else f for f in STABILITY_FIELDS)
NO_OBSTACLE = -np.inf   # any (a0, b1) is a start
I_CONTROL = 2           # int_settings: the address of the sweep's control (``_jit.Control``)


# cold compile seconds, measured by ``python benchmarks/compile_time.py`` (announced rounded,
# as the time they took there: ``engine.compile_words``); ``cornerbif continue`` compiles
# nothing more for this model (the maps' orbits are solved in numpy, cornerbif.theory)
COMPILE_SECONDS = {"map2d": 0.8, "stability": 0.6}


class Map2dModel(Model):
    # the slot of int_settings that carries the address of a sweep's control (the stop flag
    # and runs finished, ``_jit.Control``; ``engine.with_control``)
    control_slot = I_CONTROL

    def wall_at_start(self, params):
        return np.full(params.shape[0], NO_OBSTACLE)

    def pack_values(self, values: dict, scene) -> np.ndarray:
        """The map's row [omega1, kappa1, r] with epsilon = 1."""
        return np.array([values["omega"] - 2.0, values["kappa"], values["r"]], dtype=float)

    def int_settings(self, scene):
        """(transient, record, the address of the sweep's control: 0 for none,
        ``engine.with_control``)."""
        return np.array([scene.transient, scene.record, 0], np.int64)

    def kernel(self):
        # start-up: the kernels load numba here, at first use (validation loads none)
        from .maps import iterate_batch
        return iterate_batch

    def compiles(self, scene, what):
        """What a first run of ``scene`` compiles (as ``FlowModel.compiles``)."""
        # start-up: the kernels load numba here, at first use (validation loads none)
        from ..._jit import dispatchers
        from .maps import detect_map_cycles, iterate_batch  # start-up: loads numba
        from .tangent import batch_map_stability  # start-up: loads numba
        out = []
        files = "sweep" in what or "continuation" in what     # "simulate": no file
        if files or "simulate" in what:
            out.append(("the map2d kernels", COMPILE_SECONDS["map2d"],
                        [iterate_batch, detect_map_cycles]
                        + (dispatchers("analysis.cycle_signatures", "chunkwrite._shuffle_bytes")
                           if files else [])))
        # a sweep's file tests its runs without a cycle for chaos when it finishes
        # (cornerbif.chaos: reruns with the stability pass), whatever it keeps
        if "stability" in what or "sweep" in what or ("simulate" in what
                                                      and "stability" in scene.keep):
            out.append(("the map2d stability kernel", COMPILE_SECONDS["stability"],
                        [batch_map_stability]))
        return out

    def run_seconds(self, scene, values):
        """The time model of one run (``estimate.estimate_time``): its transient + record map
        steps at ``events_per_second``; (seconds, low, high, reasons): within a factor 1.5,
        never uncertain."""
        seconds = (scene.transient + scene.record) / self.events_per_second
        return seconds, seconds / 1.5, seconds * 1.5, []

    def orbit_from_doc(self, doc):
        from .orbit import MapOrbit  # start-up: loads numba
        return MapOrbit.from_doc(doc)

    def orbit_seed(self, values, scene, param, word, run):
        from .orbit import map_seed  # start-up: loads numba
        return map_seed(values, param, word)

    def word_seed(self, values, scene, param, word, simulate):
        from .orbit import map_seed  # start-up: loads numba
        return map_seed(values, param, word)

    def run_items(self, params, ics, ints, scene):
        """Iterate the local maps (56) on n items: the iterates x_n = (a_n, b_n) are the
        section's series (su, sv), as the flow's section values (u, v)(nT); a run is OK
        unless an iterate is not finite."""
        # start-up: the kernels load numba here, at first use (validation loads none)
        from ..._jit import raise_if_stopped
        from ...stability import new_outputs  # start-up: loads numba
        from .maps import detect_map_cycles, iterate_batch  # start-up: loads numba
        n = params.shape[0]
        rec = scene.record
        a = np.empty((n, rec))
        b = np.empty((n, rec))
        reg = np.empty((n, rec), np.int8)
        control = int(ints[I_CONTROL]) if ints.shape[0] > I_CONTROL else 0
        iterate_batch(np.ascontiguousarray(params), np.ascontiguousarray(ics), scene.transient,
                      rec, a, b, reg, control)
        raise_if_stopped(control)
        period = np.zeros(n, np.int64)
        sym = np.zeros((n, max(1, rec // 2)), np.uint8)
        detect_map_cycles(reg, a, b, scene.period_tol, period, sym)
        ipc = ((sym == ord("a")) * 2 + (sym == ord("b")) + (sym == ord("g"))).sum(axis=1)
        ok = np.isfinite(b).all(axis=1) & np.isfinite(a).all(axis=1)
        st = np.where(ok, S.OK, S.NONFINITE).astype(np.int8)
        out = {"su": a, "sv": b}
        final = np.stack([a[:, -1], b[:, -1]], axis=1)
        sym_full = np.zeros((n, rec), np.uint8)
        sym_full[:, :sym.shape[1]] = sym
        if "stability" in scene.keep:
            stab = new_outputs(n)
            batch_map_stability(np.ascontiguousarray(params), reg, period, *stab.values(),
                                control)
            raise_if_stopped(control)
            out.update(stab)
        return RunResult(out, st, final, period, ipc, sym_full)


def batch_map_stability(*args):
    """``models.map2d.tangent.batch_map_stability``, imported at its first call (numba-free
    validation): the stability pass of a block (``run_items``), a name of this module that
    a test may replace."""
    from .tangent import batch_map_stability as kernel  # start-up: loads numba
    return kernel(*args)


# ``cornerbif warm``: what a first sweep (with stability) compiles
WARMUPS = (
    Warmup("map2d", "the map2d kernels and their stability", "sweep", """
[scene]
name = "warm_map2d"
model = "map2d"
[system]
omega = 1.999
kappa = -0.01
r = 0.8
[sweep]
kappa = { start = -0.0141, stop = -0.0139, num = 2 }
[initial]
count = 2
seed = 1
u = [0.0, 20.0]
v = [-0.02, 0.02]
[run]
transient = 10
record = 8
[output]
keep = ["section", "stability"]
"""),
)


MODEL = Map2dModel(
    name="map2d",
    doc="the local maps alpha, beta, gamma near (omega, kappa) = (2, 0) (sections 4-5, "
        "eqs 56-60)",
    params=PARAMS,
    state=(U, V),
    observables={"section": SECTION_FIELDS, "stability": STABILITY},
    opt_in=("stability",),
    continuation=True,
    # an attractor's identity beside its word: its iterates (a_n, b_n) over one cycle
    cycle=CycleSeries(end="su", a="su", b="sv", per="period", names=("a", "b"),
                      long_names=("iterate a_n", "iterate b_n")),
    normal_form=SIDE,
    drawn_obstacle=obstacles.DEFAULT,     # the maps are the normal form of its corners
    # the maps' start is the point x = (a_0, b_1) of their plane (section 4, Fig. 9), their
    # section (a_n, b_n)
    axis_labels={"initial.u": r"start $a_0$", "initial.v": r"start $b_1$",
                 "section_u": r"$a_n$", "section_v": r"$b_n$"},
    default_y="section_v",
    keep_hint=" (the map's iterates are stored as section/u = a_n, section/v = b_n)",
    # per item and recorded step: a, b, the region, the word, and the flow-shaped NaN rows
    bytes_per_event=3 * 8 + 2,
    # map steps, benchmarks/run.py, one core (benchmarks/results/results.json)
    events_per_second=4.0e8,
    warmups=WARMUPS,
)
