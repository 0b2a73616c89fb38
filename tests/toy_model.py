"""A model that is not part of the package: the contract's proof that a new model is its
own files plus one registry line (docs/architecture.md).

The damped rotation map x' = r R(omega) x + (kappa, 0) on (u, v), with R the rotation by
omega: its fixed point is x* = (I - r R)^-1 (kappa, 0), reached from any start for r < 1.
"""

import numba
import numpy as np

from cornerbif import status as S
from cornerbif._jit import pjit
from cornerbif.model import Coord, Field, Model, Param, RunResult, anything, positive


@pjit
def rotate_batch(params, x0, transient, record, out_u, out_v):
    for i in numba.prange(params.shape[0]):
        c, s, r, k = np.cos(params[i, 0]), np.sin(params[i, 0]), params[i, 1], params[i, 2]
        u, v = x0[i, 0], x0[i, 1]
        for n in range(transient + record):
            u, v = r * (c * u - s * v) + k, r * (s * u + c * v)
            if n >= transient:
                out_u[i, n - transient] = u
                out_v[i, n - transient] = v


class ToyModel(Model):
    def wall_at_start(self, params):
        return np.full(params.shape[0], -np.inf)

    def pack_values(self, values, scene):
        return np.array([values["omega"], values["r"], values["kappa"]])

    def int_settings(self, scene):
        return np.array([scene.transient, scene.record], np.int64)

    def kernel(self):
        return rotate_batch

    def run_items(self, params, ics, ints, scene):
        n, rec = params.shape[0], scene.record
        u, v = np.empty((n, rec)), np.empty((n, rec))
        rotate_batch(np.ascontiguousarray(params), np.ascontiguousarray(ics), scene.transient,
                     rec, u, v)
        st = np.full(n, S.OK, np.int8)
        converged = np.abs(np.diff(u, axis=1)[:, -1]) < scene.period_tol
        period = converged.astype(np.int64)
        sym = np.zeros((n, rec), np.uint8)
        sym[converged, 0] = ord("x")
        final = np.stack([u[:, -1], v[:, -1]], 1)
        return RunResult({"su": u, "sv": v}, st, final, period, period.copy(), sym)


MODEL = ToyModel(
    name="toy_rotation",
    doc="a damped rotation map (a test model)",
    params={p.name: p for p in (
        Param("omega", 1.0, "> 0", positive, "rotation angle"),
        Param("r", 0.5, "in (0, 1)", lambda v: 0 < v < 1, "contraction"),
        Param("kappa", 0.1, "any finite number", anything, "shift"))},
    state=(Coord("u", (-1.0, 1.0), 0, None, "initial u", "final u"),
           Coord("v", (-1.0, 1.0), 1, None, "initial v", "final v")),
    observables={"section": (Field("section/u", "su", "u after each step"),
                             Field("section/v", "sv", "v after each step"))},
    bytes_per_event=16,
)
