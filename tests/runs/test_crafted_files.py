"""Crafted files given to info and plot: a garbage scene attribute, an unknown model, a
wrong dtype or shape, a dataset too large to read: each refused with one message."""

import os

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from cornerbif.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


FIG06A = os.path.join(ROOT, "configs", "fig06a.toml")


SMALL = ["--set", "sweep.kappa.num=3", "--set", "initial.count=2", "--set", "run.transient=10",
         "--set", "run.record=10"]


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def refused(r, *needles):
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output
    for n in needles:
        assert n in r.output, (n, r.output)


# ------------------------------------------------------------------ crafted files
@pytest.fixture
def good(tmp_path):
    out = tmp_path / "good.h5"
    r = run("sweep", FIG06A, "-o", out, *SMALL)
    assert r.exit_code == 0, r.output
    return out


def crafted_refused(path, needle):
    for cmd in ("info", "plot"):
        fig = str(path) + ".png"
        r = run(cmd, path, *(["-o", fig] if cmd == "plot" else []))
        refused(r, needle)
        assert not os.path.exists(fig)


def test_garbage_scene_attribute(good):
    with h5py.File(good, "r+") as f:
        f.attrs["scene"] = "this is [not toml"
    crafted_refused(good, "scene attribute is not a cornerbif scene")


def test_unknown_model(good):
    with h5py.File(good, "r+") as f:
        f.attrs["scene"] = f.attrs["scene"].replace('model = "flow"', 'model = "warp"')
    crafted_refused(good, "model 'warp' is not one this cornerbif knows")


def test_wrong_dtype(good):
    with h5py.File(good, "r+") as f:
        del f["status"]
        f.create_dataset("status", data=np.zeros((3, 2), "f8"))
    crafted_refused(good, "dataset 'status' has dtype float64")


def test_wrong_shape(good):
    with h5py.File(good, "r+") as f:
        del f["period"]
        f.create_dataset("period", data=np.zeros((5, 2), "i4"))
    crafted_refused(good, "does not match the grid")


def test_a_huge_dataset_is_refused_before_it_is_read(good):
    """10^10 float64 values (80 GB, stored as nothing but a fill value): refused by size."""
    with h5py.File(good, "r+") as f:
        del f["impacts/u"]
        f.create_dataset("impacts/u", shape=(10**10,), dtype="f8", chunks=(2**20,))
    crafted_refused(good, "of memory available here")
