"""``cornerbif.simulate``: run any registered model from Python, one or many starts."""

from __future__ import annotations

import sys

import numpy as np

from . import engine, registry
from .config import SceneError, from_dict

RUN_KEYS = ("tol", "chatter", "escape", "period_tol")


def simulate(*starts, model=registry.DEFAULT_MODEL, transient=0, record=100, tol=1e-12, chatter=1e-6,
             escape=1e6, period_tol=1e-6, max_events=None, max_periods=None, stop="none",
             keep=None, table=None, **system):
    """Run ``model`` for one or many initial states at t = 0 (``flow``: at ``t0``).

    ``starts`` are the state coordinates at t = 0 in the model's order
    (``flow``, ``map2d``: u0, v0; ``two_particle``: z0, y0, u0, v0), positionally or
    by keyword (``u0=...``); ``flow`` also takes the start time ``t0=`` (default 0: the
    state is then at the obstacle's phase omega t0).  ``system`` takes the names of the model's ``[system]``
    table (e.g. omega, kappa, r; ``obstacle`` and ``section_period`` where the model
    has them), each a scalar or an array broadcast against the starts.  Parameters are
    validated exactly as a scene's, every element of every array included.

    Returns a dict of arrays: the kernel's per-event outputs (``flow``: t, u, v_in,
    v_out, corner_offset, su, sv; ``two_particle`` adds sz, sy and the wall impacts
    wz_*; ``map2d`` stores a_n, b_n in su, sv) shaped ``shape + (record,)``, and
    status, final (``shape + (state size,)``), period, impacts_per_cycle, symbols.
    ``keep`` names observables as a scene's ``[output] keep`` does; the opt-in ones add
    their per-run arrays (``keep=["stability"]``: mu_re, mu_im (``shape + (2,)``;
    ``two_particle``: 4, ``linear``: 2N), cycle_duration, stability_status, lyapunov,
    lyapunov_window, lyapunov_status).

    A model that its scene declares (``linear``) takes its ``[system]`` as ``table`` (the
    dict a scene's TOML gives), its starts by its coordinates (``x0=``, ``v_x0=``), and any
    of the table's numbers by path as arrays (``**{"contact.T.beta": betas}``).
    """
    from .analysis import words  # start-up: loads numba
    if model not in registry.models():
        raise ValueError(f"simulate(model={model!r}): not a model; allowed: "
                         + ", ".join(registry.models()))
    spec = registry.get(model)
    if spec.for_system is not None:          # a model its scene declares (docs/linear.md)
        if table is None:
            raise TypeError(f"simulate(model={model!r}) needs table=, the scene's [system] "
                            "table as a dict")
        spec, problems = spec.for_system(table)
        if problems:
            raise SceneError(problems)
    elif table is not None:
        raise TypeError(f"simulate(model={model!r}): table= is for a model declared by its "
                        "scene (linear); give the parameters by name")
    coords = spec.coords
    named = {c: system.pop(f"{c}0") for c in coords if f"{c}0" in system}
    if len(starts) + len(named) != len(coords) or any(c in named for c in coords[:len(starts)]):
        raise TypeError(f"simulate(model={model!r}) needs the starts "
                        + ", ".join(f"{c}0" for c in coords))
    named.update(zip(coords, starts))
    if spec.start_time is not None and f"{spec.start_time.name}0" in system:
        # the start time (flow: t0, the obstacle's phase at the start), 0 when not given
        t0 = system.pop(f"{spec.start_time.name}0")
        if not np.all(np.isfinite(t0)) or np.any(np.asarray(t0) < 0):
            raise ValueError(f"simulate(): {spec.start_time.name}0 must be finite and >= 0")
        named[spec.start_time.name] = t0
        coords = coords + (spec.start_time.name,)
    extra = {k: system.pop(k) for k in list(system) if k in spec.system_extra}
    unknown = [k for k in system if k not in spec.params]
    if unknown:
        raise TypeError(f"simulate() got an unknown parameter {unknown[0]!r} of model "
                        f"{model!r}; allowed: {', '.join(spec.params)}")
    raw = {"scene": {"model": model},
           "system": (dict(table) if table is not None else
                      {k: v for k, v in extra.items() if v is not None}),
           "run": {"transient": transient, "record": record, "tol": tol, "chatter": chatter,
                   "escape": escape, "period_tol": period_tol, "stop": stop}}
    if max_events is not None:
        raw["run"]["max_events"] = max_events
    if max_periods is not None:
        raw["run"]["max_periods"] = max_periods
    if keep is not None:
        raw["output"] = {"keep": list(keep)}
    arrays = {k: np.atleast_1d(np.asarray(v, float)) for k, v in system.items() if v is not None}
    x0 = [np.atleast_1d(np.asarray(named[c], float)) for c in coords]
    shape = np.broadcast_shapes(*[a.shape for a in x0], *[a.shape for a in arrays.values()])
    if 0 in shape:
        raise ValueError(f"simulate(): nothing to run (the starts and parameters broadcast to "
                         f"shape {shape})")
    flat = {k: np.broadcast_to(a, shape).ravel() for k, a in arrays.items()}
    n = int(np.prod(shape))
    problem = spec.given_problem(list(flat))
    if problem:
        raise SceneError([f"simulate(): {problem}"])
    first = {k: float(a[0]) for k, a in flat.items()}
    raw["system"] = _with(spec, raw["system"], first)
    scene = from_dict(raw, drawn_starts=False)
    # every value is checked as a scene's would be, not only the first of each array:
    # ranges per distinct value (their extremes when there are many), then the model's
    # point checks (undamped resonance) on every distinct combination
    for k, a in flat.items():
        vals = np.unique(a)
        for v in (vals if vals.size <= 2000 else vals[[0, -1]]):
            from_dict({**raw, "system": _with(spec, raw["system"], {**first, k: float(v)})},
                      drawn_starts=False)
    spec = scene.spec
    names = list(flat)
    table = np.stack([flat[k] for k in names], -1) if names else np.zeros((n, 0))
    rows, first = np.unique(table, axis=0, return_index=True) if n else (table, [])
    for row, i in zip(rows, first):
        problem = spec.check_point(dict(scene.system) | dict(zip(names, map(float, row))))
        if problem:
            raise SceneError([f"{problem} (at element {int(i)})"])
    params = np.stack([spec.pack_values(dict(scene.system)
                                        | {k: float(flat[k][i]) for k in names}, scene)
                       for i in range(n)]) if n else np.zeros((0, 0))
    ics = np.stack([np.broadcast_to(a, shape).ravel() for a in x0], -1)
    # a first call compiles the model's kernels: said on stderr, as the commands say it
    engine.announce_compiles(scene, lambda m: print(m, file=sys.stderr, flush=True),
                             ("simulate",))
    run = spec.run_items(np.ascontiguousarray(params), np.ascontiguousarray(ics),
                         spec.int_settings(scene), scene)
    res = {k: v.reshape(shape + v.shape[1:]) for k, v in run.fields.items()}
    res.update(status=run.status.reshape(shape),
               final=run.final.reshape(shape + (len(spec.finals),)),
               period=run.period.reshape(shape), impacts_per_cycle=run.ipc.reshape(shape),
               symbols=words(run.symbols).reshape(shape))
    return res



def _with(spec, system: dict, values: dict) -> dict:
    """A scene's ``[system]`` with the parameters ``values``: by name, or by their paths in
    the table of a model its scene declares (``Model.system_table_with``)."""
    if spec.system_table is not None:
        known = {k: v for k, v in values.items() if k in spec.params}
        return {**spec.system_table_with(known),
                **{k: v for k, v in values.items() if k not in spec.params}}
    return {**system, **values}
