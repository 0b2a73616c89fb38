"""Bad files: truncated, of a newer format, missing a dataset, with external links,
virtual datasets or external storage: each refused on reading."""

import os
import sys

import h5py
import numpy as np
from click.testing import CliRunner
from hypothesis import strategies as st

from cornerbif import config, registry
from cornerbif.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


FIG06A = os.path.join(ROOT, "configs", "fig06a.toml")


KEYS = st.sampled_from(list(config.TABLES) + list(registry.get("flow").params)
                       + ["obstacle", "follow", "start", "stop", "num", "values", "count",
                          "seed", "u", "v", "transient", "record", "tol", "keep", "model",
                          "name", "y", "xlim", "omgea", ""])


SCALARS = (st.none() | st.booleans() | st.integers(-10**6, 10**6) | st.floats(allow_nan=True)
           | st.text(max_size=12) | st.sampled_from(["flow", "sine", "rectified_sine", "up"]))


VALUES = st.recursive(SCALARS, lambda c: st.lists(c, max_size=4) | st.dictionaries(KEYS, c, max_size=5),
                      max_leaves=20)


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


# ---------------------------------------------------------------- interrupted and concurrent runs
def _sweep_args(out, extra=()):
    return [sys.executable, "-m", "cornerbif.cli", "sweep", FIG06A, "-o", str(out), "--no-progress",
            "--set", "sweep.kappa.num=240", "--set", "initial.count=4", "--block-points", "8",
            *extra]


KILL_IN_TABLE = """
import os, signal, sys
import cornerbif.attractors as A
def killed(g, scene):                    # the table half written, then SIGKILL
    g.create_group("attractors").create_dataset("id", data=[0, 1, 2])
    g.flush()
    os.kill(os.getpid(), signal.SIGKILL)
A.tabulate = killed
from cornerbif.cli import main
sys.argv = ["cornerbif"] + sys.argv[1:]
main()
"""
