"""Scenes, the HDF5 file and the commands, end to end on tiny grids."""

import os

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from cornerbif import config, engine, local
from cornerbif import sweep as sweep_mod
from cornerbif.cli import main

TINY = """
[scene]
name = "tiny"
title = "tiny kappa sweep"
model = "flow"

[system]
obstacle = "rectified_sine"
omega = 1.999
r = 0.8

[sweep]
kappa = { start = -0.016, stop = -0.012, num = 9 }

[initial]
count = 3
seed = 4

[run]
transient = 200
record = 60
"""


@pytest.fixture
def tiny(tmp_path):
    p = tmp_path / "tiny.toml"
    p.write_text(TINY)
    return p


def run(args):
    r = CliRunner().invoke(main, [str(a) for a in args], catch_exceptions=False)
    return r


def test_sweep_info_plot(tiny, tmp_path):
    out = tmp_path / "tiny.h5"
    r = run(["sweep", tiny, "-o", out])
    assert r.exit_code == 0, r.output
    assert out.exists() and not os.path.exists(str(out) + ".partial")
    with h5py.File(out) as f:
        assert f.attrs["format"] == "cornerbif"
        assert f["impacts/u"].shape == (9, 3, 60)
        assert f["section/u"].shape == (9, 3, 60)
        assert f["status"].shape == (9, 3)
        assert f["done"][...].all()
        assert f["kappa"][0] == -0.016
        assert (f["status"][...] == 0).all()
        # the stored scene is the scene as run and reloads to the same hash
        sc = config.loads(f.attrs["scene"])
        assert sc.hash == f.attrs["scene_hash"]
        # every dimension has a scale
        for name in ("impacts/u", "status", "symbols", "initial/u"):
            for dim in f[name].dims:
                assert len(dim) == 1, name
        # below kappa_C: the single-impact orbit, one cluster per cycle
        sym = f["symbols"][0].astype(str)
        assert list(sym) == ["b"] * 3
    r = run(["info", out])
    assert r.exit_code == 0 and "grid points done: 9 / 9" in r.output
    png = tmp_path / "tiny.png"
    r = run(["plot", out, "-o", png])
    assert r.exit_code == 0, r.output
    assert png.stat().st_size > 10000


def test_xarray_opens_root_and_groups(tiny, tmp_path):
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    out = tmp_path / "tiny.h5"
    assert run(["sweep", tiny, "-o", out]).exit_code == 0
    ds = xr.open_dataset(out, engine="h5netcdf")
    assert ds["status"].dims == ("kappa", "ic")
    assert ds["kappa"].size == 9
    imp = xr.open_dataset(out, engine="h5netcdf", group="impacts")
    assert imp["u"].dims == ("kappa", "ic", "record")
    sec = xr.open_dataset(out, engine="h5netcdf", group="section")
    assert sec["v"].dims == ("kappa", "ic", "record")
    # every group carries its coordinates: select by value, as in the root
    k = float(ds["kappa"][3])
    near = imp["u"].sel(kappa=k + 1e-9, method="nearest")
    with h5py.File(out) as f:
        assert np.array_equal(near.values, f["impacts/u"][3], equal_nan=True)
        assert np.array_equal(sec["kappa"].values, f["kappa"][...])
    ini = xr.open_dataset(out, engine="h5netcdf", group="initial")
    assert set(ini["u"].coords) == {"kappa", "ic"}
    # the words read back as text
    assert ds["symbols"].dtype.kind == "U" or isinstance(ds["symbols"].values.flat[0], str)
    # the attractor table and the cycle signatures open too (no dataset named as a root
    # dimension of another length)
    tab = xr.open_dataset(out, engine="h5netcdf", group="attractors")
    with h5py.File(out) as f:
        assert np.array_equal(tab["at_kappa"].values, f["attractors/at_kappa"][...])
    cyc = xr.open_dataset(out, engine="h5netcdf", group="cycle")
    assert cyc["signature"].dims[:2] == ("kappa", "ic")


def test_overrides_and_rerun_reproduces_bitwise(tiny, tmp_path):
    a = tmp_path / "a.h5"
    assert run(["sweep", tiny, "-o", a, "--set", "sweep.kappa.num=5",
                "--set", "system.omega=1.9995"]).exit_code == 0
    with h5py.File(a) as f:
        text = f.attrs["scene"]
        ua = f["impacts/u"][...]
    assert "omega = 1.9995" in text and ua.shape[0] == 5
    # the stored scene reproduces the data bitwise
    b_scene = tmp_path / "b.toml"
    b_scene.write_text(text)
    b = tmp_path / "b.h5"
    assert run(["sweep", b_scene, "-o", b]).exit_code == 0
    with h5py.File(b) as f:
        assert np.array_equal(f["impacts/u"][...], ua, equal_nan=True)


def test_resume_after_interruption_is_bitwise_equal(tiny, tmp_path, monkeypatch):
    full = tmp_path / "full.h5"
    assert run(["sweep", tiny, "-o", full]).exit_code == 0
    # 2 points a block
    monkeypatch.setattr(engine, "BLOCK_BYTES", 2 * 3 * engine.item_bytes(config.load(tiny)))
    calls = {"n": 0}
    real = sweep_mod.io.write_block

    def flaky(f, index, block):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        real(f, index, block)

    monkeypatch.setattr(sweep_mod.io, "write_block", flaky)
    part = tmp_path / "part.h5"
    r = run(["sweep", tiny, "-o", part])
    assert r.exit_code == 130 and "--resume" in r.output
    assert os.path.exists(str(part) + ".partial")
    with h5py.File(str(part) + ".partial", "r") as f:
        assert f["done"][...].sum() == 4
    r = run(["sweep", tiny, "-o", part])
    assert r.exit_code == 2 and "--resume" in r.output      # refuses to start over silently
    monkeypatch.setattr(sweep_mod.io, "write_block", real)
    r = run(["sweep", tiny, "-o", part, "--resume"])
    assert r.exit_code == 0, r.output
    with h5py.File(full) as f, h5py.File(part) as g:
        for name in ("impacts/t", "impacts/u", "section/v", "status", "period", "initial/u"):
            assert np.array_equal(f[name][...], g[name][...], equal_nan=True), name
        assert list(f["symbols"][...].ravel()) == list(g["symbols"][...].ravel())


def test_resume_with_changed_scene_is_refused(tiny, tmp_path, monkeypatch):
    monkeypatch.setattr(sweep_mod.io, "write_block",
                        lambda *a: (_ for _ in ()).throw(KeyboardInterrupt()))
    part = tmp_path / "p.h5"
    run(["sweep", tiny, "-o", part])
    r = run(["sweep", tiny, "-o", part, "--resume", "--set", "system.r=0.7"])
    assert r.exit_code == 2 and "differs" in r.output


def test_existing_output_needs_overwrite(tiny, tmp_path):
    out = tmp_path / "o.h5"
    assert run(["sweep", tiny, "-o", out]).exit_code == 0
    r = run(["sweep", tiny, "-o", out])
    assert r.exit_code == 2 and "--overwrite" in r.output
    assert run(["sweep", tiny, "-o", out, "--overwrite"]).exit_code == 0


def test_follow_carries_the_attractor(tmp_path):
    """omega = 2.001: followed upwards the single-impact orbit survives past kappa_CC,
    followed downwards the double-impact one survives below kappa_C (hysteresis, Fig. 7b)."""
    text = TINY.replace('kappa = { start = -0.016, stop = -0.012, num = 9 }',
                        'kappa = { start = -0.004, stop = 0.02, num = 13 }\nfollow = "up"')
    text = text.replace("omega = 1.999", "omega = 2.001").replace("count = 3", "count = 2")
    up = tmp_path / "up.toml"
    up.write_text(text)
    down = tmp_path / "down.toml"
    down.write_text(text.replace('follow = "up"', 'follow = "down"'))
    assert run(["sweep", up, "-o", tmp_path / "up.h5"]).exit_code == 0
    assert run(["sweep", down, "-o", tmp_path / "down.h5"]).exit_code == 0
    with h5py.File(tmp_path / "up.h5") as f, h5py.File(tmp_path / "down.h5") as g:
        k = f["kappa"][...]
        i = int(np.argmin(abs(k - 0.008)))        # kappa_CC = 0.0031 < 0.008 < kappa_C = 0.0141
        assert set(f["symbols"][i].astype(str)) == {"b"}
        assert set(g["symbols"][i].astype(str)) == {"a"}


@pytest.mark.parametrize("follow", ["up", "down"])
def test_followed_slabs_written_together_equal_slab_by_slab_and_survive_interrupt(
        tmp_path, monkeypatch, follow):
    """A followed sweep writes its thin slabs in batches (local.FOLLOW_BATCH); the file must
    be bitwise the one written slab by slab, and an interrupt must keep every finished slab
    (the pending batch is written on the way out) and resume to the same file."""
    text = TINY.replace('kappa = { start = -0.016, stop = -0.012, num = 9 }',
                        f'kappa = {{ start = -0.004, stop = 0.02, num = 13 }}\nfollow = "{follow}"')
    text = text.replace("omega = 1.999", "omega = 2.001").replace("count = 3", "count = 2")
    sc = tmp_path / "s.toml"
    sc.write_text(text)
    assert run(["sweep", sc, "-o", tmp_path / "batched.h5"]).exit_code == 0
    monkeypatch.setattr(local, "FOLLOW_BATCH", 1)
    assert run(["sweep", sc, "-o", tmp_path / "single.h5"]).exit_code == 0
    monkeypatch.setattr(local, "FOLLOW_BATCH", 256)
    real = engine.compute_block
    calls = {"n": 0}

    def interrupted(*a, **k):
        calls["n"] += 1
        if calls["n"] == 6:
            raise KeyboardInterrupt
        return real(*a, **k)

    monkeypatch.setattr(engine, "compute_block", interrupted)
    part = tmp_path / "part.h5"
    assert run(["sweep", sc, "-o", part]).exit_code == 130
    with h5py.File(str(part) + ".partial", "r") as f:
        assert f["done"][...].sum() == 5            # the five slabs computed before the interrupt
    monkeypatch.setattr(engine, "compute_block", real)
    assert run(["sweep", sc, "-o", part, "--resume"]).exit_code == 0
    names = ("impacts/t", "section/v", "status", "period", "final/u", "final/v", "done")
    with h5py.File(tmp_path / "batched.h5") as a, h5py.File(tmp_path / "single.h5") as b, \
            h5py.File(part) as c:
        for n in names:
            assert np.array_equal(a[n][...], b[n][...], equal_nan=True), n
            assert np.array_equal(a[n][...], c[n][...], equal_nan=True), n
        assert list(a["symbols"][...].ravel()) == list(c["symbols"][...].ravel())


def test_dry_run_writes_nothing(tiny, tmp_path):
    out = tmp_path / "d.h5"
    r = run(["sweep", tiny, "-o", out, "--dry-run"])
    assert r.exit_code == 0 and "27 runs" in r.output
    assert not out.exists()


@pytest.mark.parametrize("edit, needle", [
    (("omega = 1.999", "omgea = 1.999"), "did you mean 'omega'"),
    (("r = 0.8", 'r = "0.8"'), "system.r"),
    (("r = 0.8", "r = 1.5"), "system.r: 1.5 is out of range"),
    (("r = 0.8", "r = nan"), "not finite"),
    (("num = 9", "num = 3.0"), "sweep.kappa.num: 3.0 must be an integer"),
    (("num = 9", "num = true"), "sweep.kappa.num: True must be an integer"),
    (('obstacle = "rectified_sine"', 'obstacle = "rectified"'), "did you mean 'rectified_sine'"),
    (('model = "flow"', 'model = "flw"'), "scene.model"),
    (("start = -0.016, stop = -0.012", "start = -0.012, stop = -0.016"), "stop"),
    (("transient = 200", "transient = 200\nomega = 2.0"), "run.omega: unknown key (it belongs in [system])"),
    (("seed = 4", "seed = 4\nu = [30.0, 40.0]\nbogus = 1"), "initial.bogus"),
])
def test_bad_scenes_are_refused_with_key_and_value(tiny, tmp_path, edit, needle):
    p = tmp_path / "bad.toml"
    p.write_text(TINY.replace(*edit))
    out = tmp_path / "bad.h5"
    r = CliRunner().invoke(main, ["sweep", str(p), "-o", str(out)])
    assert r.exit_code == 2, r.output
    assert needle in r.output, r.output
    assert "Traceback" not in r.output
    assert not out.exists() and not os.path.exists(str(out) + ".partial")


def test_all_problems_reported_at_once():
    with pytest.raises(config.SceneError) as e:
        config.loads(TINY.replace("r = 0.8", "r = -1").replace("count = 3", "count = 0"))
    assert len(e.value.problems) == 2


def test_toml_syntax_error_names_line():
    with pytest.raises(config.SceneError) as e:
        config.loads("[system]\nomega = = 2\n")
    assert "line 2" in str(e.value)


def test_plot_refuses_non_cornerbif_files(tmp_path):
    junk = tmp_path / "junk.h5"
    junk.write_bytes(b"not hdf5 at all")
    r = CliRunner().invoke(main, ["plot", str(junk)])
    assert r.exit_code == 2 and "not an HDF5 file" in r.output
    empty = tmp_path / "empty.h5"
    empty.write_bytes(b"")
    r = CliRunner().invoke(main, ["info", str(empty)])
    assert r.exit_code == 2 and "empty" in r.output
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as f:
        f["x"] = 1
    r = CliRunner().invoke(main, ["info", str(other)])
    assert r.exit_code == 2 and "not a cornerbif file" in r.output


def test_initial_conditions_are_above_the_obstacle():
    sc = config.loads(TINY.replace("count = 3", "count = 50").replace(
        "seed = 4", "seed = 4\nu = [-1.0, 0.5]"))
    flat = np.arange(9)
    kap = sc.axes[0].array
    ics = engine.draw_initial(sc, flat, kap)
    assert (ics[..., 0] > kap[:, None]).all()
    assert (ics[..., 0] <= 0.5).all()
    # the draw depends only on (seed, point, start): the same for a sub-range
    again = engine.draw_initial(sc, flat[3:5], kap[3:5])
    assert np.array_equal(again, ics[3:5])


def test_kernels_compile_one_signature(tiny, tmp_path):
    from cornerbif.analysis import detect_cycles
    from cornerbif.models.flow.kernel import run_batch
    assert run(["sweep", tiny, "-o", tmp_path / "s.h5"]).exit_code == 0
    assert len(run_batch.signatures) == 1
    assert len(detect_cycles.signatures) == 1
