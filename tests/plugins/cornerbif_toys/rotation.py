"""A model from outside the package: the contracting rotation x -> r R(omega) x + (kappa, 0)
of the plane (R the rotation by omega), whose fixed point x* = (I - r R)^-1 (kappa, 0) and
multipliers r e^(+-i omega) are known in closed form.  It declares its parameters, state,
observables (the section and the ``stability`` datasets), the series that tell its attractors
apart, its tangent (the map's Jacobian r R) and its orbit problem for continuation."""

import math
from dataclasses import dataclass

import numpy as np

from cornerbif import status as S
from cornerbif.continuation import central_d_param, newton
from cornerbif.model import Coord, CycleSeries, Model, Param, RunResult, anything, positive
from cornerbif.observables import SECTION_FIELDS, STABILITY_FIELDS


def jacobian(omega, r):
    """The map's Jacobian r R(omega)."""
    c, s = math.cos(omega), math.sin(omega)
    return r * np.array([[c, -s], [s, c]])


def iterate(params, ics, transient, record):
    """The iterates after ``transient`` steps: (n, record) each of u and v."""
    n = params.shape[0]
    x = ics[:, 0].astype(float).copy()
    y = ics[:, 1].astype(float).copy()
    w, r, k = params[:, 0], params[:, 1], params[:, 2]
    c, s = np.cos(w), np.sin(w)
    u, v = np.empty((n, record)), np.empty((n, record))
    for step in range(transient + record):
        x, y = r * (c * x - s * y) + k, r * (s * x + c * y)
        if step >= transient:
            u[:, step - transient], v[:, step - transient] = x, y
    return u, v


def tangent(params, record):
    """The ``stability`` datasets of each run: the eigenvalues of the Jacobian r R (the
    multipliers of the fixed point, by decreasing modulus) and the exponents log |mu|."""
    n = params.shape[0]
    out = {"mu_re": np.empty((n, 2)), "mu_im": np.empty((n, 2)), "cycle_duration": np.ones(n),
           "stability_status": np.zeros(n, np.int8), "lyapunov": np.empty((n, 2)),
           "lyapunov_window": np.full(n, float(record)),
           "lyapunov_status": np.zeros(n, np.int8)}
    for i in range(n):
        mu = np.linalg.eigvals(jacobian(params[i, 0], params[i, 1]))
        mu = mu[np.argsort(-np.abs(mu), kind="stable")]
        out["mu_re"][i], out["mu_im"][i] = mu.real, mu.imag
        out["lyapunov"][i] = np.log(np.abs(mu))
    return out


@dataclass
class RotationOrbit:
    """The fixed point of the rotation map as an orbit problem (``model.OrbitProblem``):
    X = (u, v), R(X) = X - (r R X + (kappa, 0))."""

    values: dict
    param: str
    n: int = 1

    def _at(self, lam):
        v = dict(self.values, **{self.param: float(lam)})
        return v["omega"], v["r"], v["kappa"]

    def residual(self, X, lam):
        w, r, k = self._at(lam)
        return X - (jacobian(w, r) @ X + np.array([k, 0.0]))

    def jacobian(self, X, lam):
        w, r, _ = self._at(lam)
        return np.eye(2) - jacobian(w, r)

    def d_param(self, X, lam):
        return central_d_param(self.residual, X, lam)

    def floquet(self, X, lam):
        w, r, _ = self._at(lam)
        J = jacobian(w, r)
        mu = np.linalg.eigvals(J)
        return mu[np.argsort(-np.abs(mu), kind="stable")], J

    def corner_distances(self, X, lam):
        return np.empty(0)            # no corners

    def smallest_gap(self, X, lam):
        return math.inf               # no flights

    def impacts(self, X, lam):
        return {"w": -np.ones(self.n)}   # no impact velocities to vanish

    def admissible(self, X, lam):
        return bool(np.isfinite(X).all()), ""

    def word(self, X, lam):
        return "x"

    def itinerary(self):
        return "the fixed point"

    def reindex(self, X, lam):
        return self, X

    def across(self, q, X, lam):
        raise ValueError("the rotation map has no corners")

    def store(self, X, lam, section):
        return {"section_u": X[0::2].copy(), "section_v": X[1::2].copy(),
                "cycle_duration": 1.0}

    def to_doc(self):
        return {"values": dict(self.values), "param": self.param, "type": "toy_rotation_plugin"}


class RotationModel(Model):
    def wall_at_start(self, params):
        return np.full(params.shape[0], -np.inf)

    def pack_values(self, values, scene):
        return np.array([values["omega"], values["r"], values["kappa"]])

    def int_settings(self, scene):
        return np.array([scene.transient, scene.record], np.int64)

    def kernel(self):
        return iterate

    def run_items(self, params, ics, ints, scene):
        u, v = iterate(params, ics, scene.transient, scene.record)
        n = params.shape[0]
        st = np.where(np.isfinite(u).all(axis=1), S.OK, S.NONFINITE).astype(np.int8)
        converged = np.abs(u[:, -1] - u[:, -2]) < scene.period_tol
        period = converged.astype(np.int64)
        sym = np.zeros((n, scene.record), np.uint8)
        sym[converged, 0] = ord("x")
        fields = {"su": u, "sv": v}
        if "stability" in scene.keep:
            fields.update(tangent(params, scene.record))
        return RunResult(fields, st, np.stack([u[:, -1], v[:, -1]], 1), period, period.copy(),
                         sym)

    def orbit_seed(self, values, scene, param, word, run):
        prob = RotationOrbit(dict(values), param)
        n = int(np.isfinite(run["su"]).sum())
        X = np.array([run["su"][n - 1], run["sv"][n - 1]])
        return prob, newton(prob, X, values[param])

    def orbit_from_doc(self, doc):
        return RotationOrbit(dict(doc["values"]), str(doc["param"]))


MODEL = RotationModel(
    name="toy_rotation_plugin",
    doc="a contracting rotation of the plane (a plug-in from outside the package)",
    params={p.name: p for p in (
        Param("omega", 1.0, "> 0", positive, "rotation angle"),
        Param("r", 0.5, "in (0, 1)", lambda v: 0 < v < 1, "contraction"),
        Param("kappa", 0.1, "any finite number", anything, "offset"),
    )},
    state=(Coord("u", (-1.0, 1.0), 0, None, "u(0)", "u at the last iterate"),
           Coord("v", (-1.0, 1.0), 1, None, "v(0)", "v at the last iterate")),
    observables={"section": SECTION_FIELDS, "stability": STABILITY_FIELDS},
    opt_in=("stability",),
    default_y="section_u",
    continuation=True,
    seed_observable="section",
    cycle=CycleSeries(end="su", a="su", b="sv", per="period", names=("a", "b"),
                      long_names=("iterate u", "iterate v")),
)
