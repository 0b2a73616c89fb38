"""The contract every registered model passes (one shared test for every system),
and a model from outside the package registered with one line (docs/architecture.md)."""

import math
import os

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from cornerbif import config, engine, io, registry, simulate
from cornerbif.cli import main
from cornerbif.model import Model


def model_of(name):
    """The registered model, or for a model that its scene declares (the linear model) the
    model of its example system (the [system] of its warm-up scene)."""
    spec = registry.get(name)
    if spec.for_system is not None:
        spec = config.loads(spec.warmups[0].scene).spec
    return spec


def tiny(name, **extra):
    raw = {"scene": {"name": f"tiny_{name}", "model": name},
           "initial": {"count": 2, "seed": 3},
           "run": {"transient": 4, "record": 6}}
    spec = model_of(name)
    first = next(iter(spec.params))
    if spec.system_table is not None:        # its example's system, starts and first axis
        example = config.loads(registry.get(name).warmups[0].scene)
        raw["system"] = dict(spec.system_table)
        raw["initial"].update({c: list(r) for c, r in example.initial.items()})
        first = example.axes[0].name
    p = spec.params[first]
    raw["sweep"] = {first: {"values": [p.default, p.default * 1.001 if p.default else 0.001]}}
    for k, v in extra.items():
        raw.setdefault(k, {}).update(v)
    return config.from_dict(raw)


@pytest.mark.parametrize("name", registry.names())
def test_declarations_are_complete_and_their_defaults_allowed(name):
    spec = model_of(name)
    assert isinstance(spec, Model) and spec.name == name and spec.doc
    for k, p in spec.params.items():
        assert p.name == k and p.allowed and p.doc and p.equation, k
        if p.default is not None:
            assert p.problem(p.default, f"system.{k}") is None, k
        assert p.problem(float("nan"), "x") is not None
    assert spec.state and len(set(spec.coords)) == len(spec.coords)
    for c in spec.state:
        if c.floor not in (None, "wall"):
            assert spec.coords.index(c.floor) < spec.coords.index(c.name)   # drawn before
    names = [f.name for obs in spec.observables.values() for f in obs]
    assert len(set(names)) == len(names)


@pytest.mark.parametrize("name", registry.names())
def test_a_block_fills_exactly_the_schema_and_simulate_agrees(name, tmp_path):
    """compute_block writes every dataset io.create allocates (and nothing else); the
    same starts through cornerbif.simulate give the same numbers."""
    sc = tiny(name)
    spec = sc.spec
    with io.create(str(tmp_path / "s.h5"), sc, sc.n_ic) as f:
        names = []
        f.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        schema = {n: f[n].shape for n in names if not f[n].is_scale and n != "done"}
    block = engine.compute_block(sc, engine.blocks(sc)[0])
    assert set(block) == set(schema)
    for n, a in block.items():
        assert a.shape == schema[n], n
    starts = [block[f"initial/{c}"] for c in spec.coords]
    axis = sc.axes[0]
    res = simulate(*starts, model=name, transient=sc.transient, record=sc.record,
                   table=spec.system_table, **{axis.name: np.array(axis.values)[:, None]})
    assert np.array_equal(res["status"], block["status"])
    assert np.array_equal(res["period"], block["period"])
    for fld in spec.fields(sc.keep):
        # a series may run longer than the file keeps (the w-z table): the file its first rows
        kept = res[fld.source][(Ellipsis,) + tuple(slice(0, k) for k in fld.trailing(sc.record))]
        assert np.array_equal(kept, block[fld.name], equal_nan=True), fld.name
    for i, c in enumerate(spec.coords):
        assert np.array_equal(res["final"][..., i], block[f"final/{c}"], equal_nan=True)


@pytest.mark.parametrize("name", registry.names())
def test_every_observable_opt_in_included_fills_the_schema(name, tmp_path):
    """With every observable kept (the opt-in ones too, e.g. stability) a block holds
    exactly the datasets the file declares, with their shapes and dtypes; without keep
    the opt-in ones are left out."""
    spec = model_of(name)
    sc = tiny(name, output={"keep": list(spec.observables)})
    with io.create(str(tmp_path / "s.h5"), sc, sc.n_ic) as f:
        names = []
        f.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        schema = {n: (f[n].shape, f[n].dtype) for n in names
                  if not f[n].is_scale and n != "done"}
    block = engine.compute_block(sc, engine.blocks(sc)[0])
    assert set(block) == set(schema)
    for n, a in block.items():
        assert a.shape == schema[n][0], n
        assert a.dtype.kind == schema[n][1].kind, n
    assert not set(spec.opt_in) & set(tiny(name).keep)


@pytest.mark.parametrize("name", registry.names())
def test_the_cycle_signature_is_the_last_recorded_cycles(name):
    """A model's CycleSeries names outputs of its kernel: each run's cycle/signature is the
    mean, least and largest of the two series over the last cycle of its record, counted
    here in numpy from cornerbif.simulate's arrays; NaN exactly where there is no cycle."""
    spec = model_of(name)
    if spec.cycle is None:
        pytest.skip("no cycle series")
    sc = tiny(name, run={"transient": 400, "record": 40}, initial={"count": 4})
    block = engine.compute_block(sc, engine.blocks(sc)[0])
    starts = [block[f"initial/{c}"] for c in spec.coords]
    axis = sc.axes[0]
    res = simulate(*starts, model=name, transient=sc.transient, record=sc.record,
                   table=spec.system_table, **{axis.name: np.array(axis.values)[:, None]})
    assert np.array_equal(res["period"], block["period"])
    cs = spec.cycle
    count = res["impacts_per_cycle"] if cs.per == "impacts" else res["period"]
    sig = block["cycle/signature"]
    assert (res["period"] > 0).any()
    for idx in np.ndindex(count.shape):
        if res["period"][idx] <= 0:
            assert np.isnan(sig[idx]).all()
            continue
        n = int(np.argmax(~np.isfinite(res[cs.end][idx]))) if not np.isfinite(
            res[cs.end][idx]).all() else res[cs.end][idx].size
        a = res[cs.a][idx][n - count[idx]:n]
        b = res[cs.b][idx][n - count[idx]:n]
        want = [a.mean(), b.mean(), a.min(), a.max(), b.min(), b.max()]
        assert np.allclose(sig[idx], want, rtol=1e-14, atol=0), idx


@pytest.mark.parametrize("name", registry.names())
def test_bad_values_name_key_value_and_range(name):
    spec = model_of(name)
    k, p = next((k, p) for k, p in spec.params.items() if p.ok(-1.0) is False)
    if spec.system_table is not None:
        # a number of a declared system, by its path: the table's own refusal names the key
        # (system.mass) and the value
        with pytest.raises(config.SceneError) as e:
            tiny(name, system=spec.system_table_with({k: -1.0}))
        assert f"system.{k.split('.')[0]}" in str(e.value) and "-1.0" in str(e.value)
    else:
        with pytest.raises(config.SceneError) as e:
            tiny(name, system={k: -1.0})
        assert f"system.{k}: -1.0 is out of range; {k} must be {p.allowed}" in str(e.value)
    with pytest.raises(config.SceneError) as e:
        tiny(name, system={k + "x": 1.0})
    assert f"system.{k}x: unknown key" in str(e.value)


@pytest.fixture
def toy_registered(monkeypatch):
    """Register the plug-in model of tests/plugins (a contracting rotation) in this process:
    the one line a new model adds to the registry (tests/architecture/test_extension_recipes.py
    registers it by its entry point instead, in a fresh process)."""
    monkeypatch.syspath_prepend(os.path.join(os.path.dirname(os.path.dirname(
        os.path.abspath(__file__))), "plugins"))
    monkeypatch.setattr(registry, "MODEL_MODULES",
                        registry.MODEL_MODULES + ("cornerbif_toys.rotation",))
    monkeypatch.setattr(registry, "_MODELS", {})
    monkeypatch.setattr(config, "MODELS", registry.names())
    monkeypatch.setitem(config.TABLES, "initial", config.TABLES["initial"])
    yield registry.get("toy_rotation_plugin")


def test_a_model_from_outside_the_package_sweeps_to_a_file(toy_registered, tmp_path):
    scene = tmp_path / "toy.toml"
    scene.write_text('[scene]\nname = "toy"\nmodel = "toy_rotation_plugin"\n[system]\nr = 0.5\n'
                     '[sweep]\nomega = { start = 0.5, stop = 1.5, num = 3 }\n'
                     '[initial]\ncount = 2\n[run]\ntransient = 60\nrecord = 4\n')
    r = CliRunner().invoke(main, ["sweep", str(scene), "-o", str(tmp_path / "toy.h5")])
    assert r.exit_code == 0, r.output
    with h5py.File(tmp_path / "toy.h5") as f:
        omega = f["omega"][...]
        u = f["section/u"][...]
        assert f["done"][...].all() and (f["period"][...] == 1).all()
    # the fixed point x* = (I - r R)^-1 (kappa, 0), in closed form
    for i, w in enumerate(omega):
        A = np.eye(2) - 0.5 * np.array([[math.cos(w), -math.sin(w)], [math.sin(w), math.cos(w)]])
        x = np.linalg.solve(A, [0.1, 0.0])
        assert np.allclose(u[i, :, -1], x[0], atol=1e-12)
    r = CliRunner().invoke(main, ["validate", str(scene), "--set", "system.r=1.5"])
    assert r.exit_code == 2 and "system.r: 1.5 is out of range; r must be in (0, 1)" in r.output


def test_flow_packs_a_block_as_point_by_point():
    """FlowModel.pack_points (the swept values as columns, params.pack_many) equals the
    generic Model.pack_points (scene.point, one row at a time), bit for bit: two swept
    parameters, theta by default and given, a swept start coordinate, and a profile."""
    import numpy as np

    from cornerbif import config
    from cornerbif.model import Model
    spec = registry.get("flow")
    scenes = [
        config.load("configs/fig06a.toml", ["sweep.kappa.num=4",
                                            "sweep.omega={start=1.9, stop=2.1, num=3}"]),
        config.load("configs/fig06a.toml", ['system.obstacle="triangle"', "system.theta1=1.5",
                                            "sweep.kappa.num=3"]),
        config.load("configs/basin_hysteresis.toml", ["sweep.initial.u.num=3",
                                                      "sweep.initial.v.num=2"]),
        config.load("configs/cam_cycloidal.toml", ["sweep.omega.num=5"]),
    ]
    for sc in scenes:
        idx = [tuple(i) for i in np.ndindex(*sc.shape)]
        a = spec.pack_points(sc, idx)
        b = Model.pack_points(spec, sc, idx)
        assert a.shape == b.shape and np.array_equal(a, b), sc.name
