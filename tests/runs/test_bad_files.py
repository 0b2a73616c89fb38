"""Bad files given to info and plot: truncated, of a newer format, missing a dataset, with
external links, virtual datasets or external storage, a garbage scene attribute, an unknown
model, a wrong dtype or shape, a dataset too large to read: each refused on reading with one
message; the provenance a good file carries."""

import os

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from cornerbif.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


FIG06A = os.path.join(ROOT, "configs", "fig06a.toml")


# ---------------------------------------------------------------- bad files for plot and info
def _good_file(tmp_path, name="good.h5"):
    out = tmp_path / name
    r = CliRunner().invoke(main, ["sweep", FIG06A, "-o", str(out), "--set", "sweep.kappa.num=3",
                                  "--set", "initial.count=2", "--set", "run.transient=10",
                                  "--set", "run.record=10"])
    assert r.exit_code == 0, r.output
    return out


def _refused(path, needle):
    for cmd in ("plot", "info"):
        fig = str(path) + ".png"
        r = CliRunner().invoke(main, [cmd, str(path)] + (["-o", fig] if cmd == "plot" else []))
        assert r.exit_code == 2, (cmd, r.output)
        assert needle in r.output, (cmd, r.output)
        assert "Traceback" not in r.output
        assert not os.path.exists(fig)


def test_truncated_file(tmp_path):
    good = _good_file(tmp_path)
    data = good.read_bytes()
    bad = tmp_path / "trunc.h5"
    bad.write_bytes(data[: len(data) // 2])
    _refused(bad, "trunc.h5")


def test_newer_format_version(tmp_path):
    good = _good_file(tmp_path)
    with h5py.File(good, "r+") as f:
        f.attrs["format_version"] = 99
    _refused(good, "newer than this cornerbif reads")


def test_missing_required_dataset(tmp_path):
    good = _good_file(tmp_path)
    with h5py.File(good, "r+") as f:
        del f["status"]
    _refused(good, "required dataset 'status' is missing")


def test_external_link_is_refused(tmp_path):
    good = _good_file(tmp_path)
    other = tmp_path / "other.h5"
    with h5py.File(other, "w") as g:
        g["secret"] = np.arange(3)
    with h5py.File(good, "r+") as f:
        f["sneaky"] = h5py.ExternalLink(str(other), "secret")
    os.remove(other)                     # opening it would fail: it must never be opened
    _refused(good, "refers to other files")


def test_virtual_dataset_and_external_storage_are_refused(tmp_path):
    good = _good_file(tmp_path)
    src = tmp_path / "src.h5"
    with h5py.File(src, "w") as g:
        g["x"] = np.arange(4.0)
    layout = h5py.VirtualLayout(shape=(4,), dtype="f8")
    layout[:] = h5py.VirtualSource(str(src), "x", shape=(4,))
    with h5py.File(good, "r+") as f:
        f.create_virtual_dataset("virt", layout)
    _refused(good, "virtual dataset")
    good2 = _good_file(tmp_path, "good2.h5")
    raw = tmp_path / "raw.bin"
    raw.write_bytes(np.arange(4.0).tobytes())
    with h5py.File(good2, "r+") as f:
        f.create_dataset("ext", shape=(4,), dtype="f8", external=[(str(raw), 0, 32)])
    _refused(good2, "external storage")


# ------------------------------------------------------------------ crafted files
@pytest.fixture
def good(tmp_path):
    return _good_file(tmp_path)


def test_garbage_scene_attribute(good):
    with h5py.File(good, "r+") as f:
        f.attrs["scene"] = "this is [not toml"
    _refused(good, "scene attribute is not a cornerbif scene")


def test_unknown_model(good):
    with h5py.File(good, "r+") as f:
        f.attrs["scene"] = f.attrs["scene"].replace('model = "flow"', 'model = "warp"')
    _refused(good, "model 'warp' is not one this cornerbif knows")


def test_wrong_dtype(good):
    with h5py.File(good, "r+") as f:
        del f["status"]
        f.create_dataset("status", data=np.zeros((3, 2), "f8"))
    _refused(good, "dataset 'status' has dtype float64")


def test_wrong_shape(good):
    with h5py.File(good, "r+") as f:
        del f["period"]
        f.create_dataset("period", data=np.zeros((5, 2), "i4"))
    _refused(good, "does not match the grid")


def test_a_huge_dataset_is_refused_before_it_is_read(good):
    """10^10 float64 values (80 GB, stored as nothing but a fill value): refused by size."""
    with h5py.File(good, "r+") as f:
        del f["impacts/u"]
        f.create_dataset("impacts/u", shape=(10**10,), dtype="f8", chunks=(2**20,))
    _refused(good, "of memory available here")


def test_provenance_in_the_file(tmp_path):
    good = _good_file(tmp_path)
    with h5py.File(good) as f:
        for k in ("scene", "scene_hash", "created", "completed", "command", "cornerbif_version",
                  "numpy_version", "numba_version", "h5py_version"):
            assert f.attrs[k], k
        assert "sweep" in f.attrs["command"]
