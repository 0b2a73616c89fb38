"""The orbit of one run of a file, recomputed: its start and parameters read from the file,
run again by ``cornerbif.simulate`` with the scene's run settings, its flight rebuilt by the
model (``Model.time_series``: u(t) over the obstacle z(t)); beside it what the file says
of that run: word, period, stability, attractor and share, branch."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..api import simulate
from ..config import SceneError
from ..plot_base import status_name, word_label
from .points import Runs, _plain


@dataclass
class Orbit:
    """One run's orbit: ``point`` (grid index, a tuple), ``start`` (its index among the
    starts), the first swept axis's value ``x``, the start ``initial`` (the model's start
    coordinates), the impacts
    recomputed (``t``, ``u``, ``v_out``, ``offset``), the flight (``s``, ``us``, ``zs``, ``vs``:
    v = du/dt of the rebuilt flight, between impacts) when the model rebuilds one, and
    ``facts`` (name, value) for the page."""
    point: tuple
    start: int
    x: float
    initial: list
    word: str
    period: int
    impacts: dict
    flight: dict | None
    facts: list = field(default_factory=list)


def _system(dia: Runs, point: tuple) -> dict:
    """The parameters at grid point ``point`` as ``simulate`` takes them: the model's
    numbers (by path for a model its scene declares, ``linear``: with its ``[system]`` as
    ``table``), and its non-numeric keys (the obstacle) from the scene."""
    d = dia.data
    vals = {k: v for k, v in d.parsed.point(point).items() if v is not None}
    spec = d.parsed.spec
    table = d.scene.get("system", {})
    numbers = {k: v for k, v in vals.items() if k in spec.params}
    if spec.for_system is not None:
        return numbers | {"table": table}
    return numbers | {k: table[k] for k in spec.system_extra if k in table}


def _start(dia: Runs, point: tuple, ic: int) -> dict:
    """The start of run (``point``, ``ic``) as ``simulate``'s keywords (``u0=``, ``t0=``)."""
    import h5py  # start-up: loads h5py
    out = {}
    with h5py.File(dia.path, "r", locking=False) as f:
        for c in dia.data.parsed.spec.start_names:
            if c in f["initial"]:
                out[f"{c}0"] = float(f["initial"][c][tuple(point) + (ic,)])
    return out


def recompute(dia: Runs, point: tuple, ic: int, cycles: float = 2.0) -> Orbit:
    """Run (``point``, ``ic``) of ``dia``'s file (``point`` its grid index) again from its
    start and parameters, with its scene's run settings, and rebuild its flight over
    ``cycles`` cycles."""
    point = tuple(int(k) for k in point)
    scene = dia.data.parsed
    system = _system(dia, point)
    start = _start(dia, point, ic)
    # the orbit's stability recomputed with it where the model has a tangent pass
    keep = None if "stability" not in scene.spec.observables else \
        [k for k in scene.spec.observables if k not in scene.spec.opt_in] + ["stability"]
    run = dict(model=scene.model, transient=scene.transient, record=scene.record,
               tol=scene.tol, chatter=scene.chatter, escape=scene.escape,
               period_tol=scene.period_tol, **start, **system)
    try:
        res = simulate(keep=keep, **run)
    except SceneError:
        if keep is None:
            raise
        res = simulate(**run)        # a system whose stability is not run (a soft stop)
    imp = {k: np.asarray(res[k]).reshape(-1) for k in ("t", "u", "v_out", "corner_offset")
           if k in res}
    word = str(np.asarray(res["symbols"]).reshape(-1)[0])
    period = int(np.asarray(res["period"]).reshape(-1)[0])
    ipc = int(np.asarray(res["impacts_per_cycle"]).reshape(-1)[0])
    status = int(np.asarray(res["status"]).reshape(-1)[0])
    flight = _flight(scene, system, imp, ipc, cycles) if scene.spec.timeseries else None
    first = dia.data.axes[0]
    orbit = Orbit(point, ic, float(dia.data.values[first][point[0]]), list(start.values()),
                  word, period, imp, flight)
    orbit.facts = _facts(dia, point, ic, orbit, ipc, status) + _stability_facts(res)
    return orbit


def _stability_facts(res) -> list:
    """The recomputed run's multipliers (the monodromy's eigenvalues over its cycle) and
    Lyapunov exponents, as ``simulate`` gives them with ``keep=["stability"]``; none where
    the model has no tangent pass."""
    from ..stability import REASONS  # start-up: loads numba
    if "mu_re" not in res:
        return []
    re, im = (np.asarray(res[k]).reshape(-1) for k in ("mu_re", "mu_im"))
    st = int(np.asarray(res["stability_status"]).reshape(-1)[0])
    if np.isfinite(re).any():
        mult = ", ".join(f"{a:.5g}" + (f" {'+' if b >= 0 else '-'} {abs(b):.4g}i" if b else "")
                         + f" (|μ| {math.hypot(a, b):.4g})" for a, b in zip(re, im))
    else:
        mult = REASONS.get(st, f"none (status {st})")
    out = [("multipliers (recomputed)", mult)]
    lam = np.asarray(res["lyapunov"]).reshape(-1)
    if np.isfinite(lam).any():
        out.append(("Lyapunov exponents (recomputed)", ", ".join(f"{v:.5g}" for v in lam)))
    return out


def _flight(scene, system, imp, ipc, cycles):
    """u(t), z(t) of the recomputed impacts over ``cycles`` cycles (``Model.time_series``),
    from the section before the first recorded impact; v = du/dt between impacts."""
    t, u, vo = imp["t"], imp["u"], imp["v_out"]
    ok = np.isfinite(t)
    t, u, vo = t[ok], u[ok], vo[ok]
    if t.size < 2:
        return None
    T = 2.0 * math.pi / system["omega"] if "omega" in system else 1.0
    t0 = math.floor(t[0] / T + 1e-9) * T
    span = cycles * (t[ipc] - t[0]) + (t[0] - t0) if 0 < ipc < t.size else t[min(10, t.size - 1)] - t0
    t1 = min(t0 + span, t[-1])
    fl = scene.spec.time_series(scene, system, t, u, vo, t0, t1)
    s, us = fl["t"], fl["u"]
    vs = np.full(s.shape, np.nan)
    cuts = np.searchsorted(s, t[(t > t0) & (t < t1)])
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, s.size]):
        if b - a >= 3:
            vs[a:b - 1] = np.gradient(us[a:b - 1], s[a:b - 1])
    return {"s": s - t0, "u": us, "z": fl["z"], "v": vs, "t0": t0}


def _facts(dia: Runs, point, ic, orbit, ipc, status) -> list:
    """What the page says of the run: the recomputed word and period beside the file's,
    its stability values, its attractor (id, label, share) and branch where the file holds
    them."""
    d = dia.data
    facts = [(a, f"{float(d.values[a][k]):.10g}") for a, k in zip(d.axes, point)]
    facts += [("grid point, start", ", ".join(map(str, point + (ic,)))),
             ("start", ", ".join(f"{v:.6g}" for v in orbit.initial)),
             ("word (recomputed)", _plain(word_label(orbit.word)) if orbit.word else "no cycle"),
             ("period, impacts per cycle", f"{orbit.period}, {ipc}"),
             ("status", status_name(status))]
    run = point + (ic,)
    file_word = str(d.symbols[run])
    facts.append(("word in the file", _plain(word_label(file_word)) if file_word else "no cycle"))
    for what, name in (("lyapunov", "largest Lyapunov exponent"),
                       ("multiplier", "largest |multiplier|")):
        if what in d.stability:
            facts.append((name, f"{d.stability[what][run]:.6g}"))
    if dia.table is not None:
        aid = int(dia.table["ids"][run])
        if aid >= 0:
            facts.append(("attractor id", str(aid)))
            facts.append(("share of the starts", f"{float(dia.table['fraction'][aid]):.3g}"))
            if "branch" in dia.table:
                facts += _branch_facts(dia, int(dia.table["branch"][aid]))
        else:
            facts.append(("attractor", "none (no cycle)"))
    return facts


def _branch_facts(dia: Runs, b: int) -> list:
    """The run's branch (``cornerbif explain``'s table): its number and word, where it
    begins and ends and why (the events located by continuation)."""
    if b < 0:
        return [("branch (cornerbif explain)", "none")]
    tab = dia.branches()
    if tab is None or b >= len(tab["id"]):
        return [("branch (cornerbif explain)", str(b))]
    word = _plain(word_label(str(tab["word"][b])))
    return [("branch (cornerbif explain)", f"{b}: {word}, period {int(tab['period'][b])}"),
            ("branch begins", f"{tab['low_kind'][b]}: {tab['low_detail'][b]}"),
            ("branch ends", f"{tab['high_kind'][b]}: {tab['high_detail'][b]}")]
