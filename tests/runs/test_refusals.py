"""Refusals before the work: sizes, integer widths, paths, threads and outputs (exit 2,
one clear message naming the key or the path, no traceback, no file left behind), and
what validate and --dry-run say of any grid, in bounded memory and time."""

import os
import shutil
import subprocess
import sys

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from cornerbif import config, estimate, outputs, sweep
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


# ------------------------------------------------------------------ sizes and integer widths
@pytest.mark.parametrize("override, needle", [
    ("sweep.kappa.num=1000000000", "sweep.kappa.num: 1000000000 values on one axis; at most"),
    ("initial.count=10000000", "initial.count: 10000000 must be an integer in 1..1048576"),
    ("initial.seed=18446744073709551616", "initial.seed: 18446744073709551616"),
    ("run.transient=100000000000000000000", "run.transient: 100000000000000000000"),
    ("run.max_events=99999999999999999999", "run.max_events: 99999999999999999999"),
    ("run.max_periods=4611686018427387904", "run.max_periods: 4611686018427387904"),
    ("run.record=10000000", "run.record: 10000000 must be an integer in 1..100000"),
])
def test_sizes_and_widths_are_refused_fast_in_bounded_memory(override, needle):
    """In a child limited to 3 GiB of address space (the subprocess timeout only guards
    against a hang): the refusal names the key (and says it came from --set) without
    allocating the grid."""
    code = ("import resource, sys; "
            "resource.setrlimit(resource.RLIMIT_AS, (3 * 2**30, 3 * 2**30)); "
            "from cornerbif.cli import main; sys.argv = ['cornerbif'] + sys.argv[1:]; main()")
    for cmd in (["validate", FIG06A], ["sweep", FIG06A, "-o", "/tmp/never.h5", "--dry-run"]):
        r = subprocess.run([sys.executable, "-c", code, *cmd, "--set", override],
                           capture_output=True, text=True, timeout=60)
        assert r.returncode == 2, r.stderr
        assert needle in r.stderr and f"(from --set {override})" in r.stderr, r.stderr
        assert "Traceback" not in r.stderr


def test_two_large_axes_refused_by_their_product():
    r = run("validate", FIG06A, "--set", "sweep.omega={ start = 1.9, stop = 2.1, num = 100000 }",
            "--set", "sweep.kappa.num=100000")
    refused(r, "grid points; at most")


def test_a_big_valid_grid_is_described_with_time_and_memory():
    r = run("validate", FIG06A, "--set", "sweep.kappa.num=100000", "--set", "initial.count=64")
    assert r.exit_code == 0, r.output
    assert r.output.startswith("ok: ") and "100000 grid points x 64 starts" in r.output
    assert "time: about" in r.output and "working memory: about" in r.output
    # the scene as run (every value listed) only on request
    assert "values = [" not in r.output
    assert "values = [" in run("validate", FIG06A, "--toml").output


def test_many_starts_at_one_point_are_counted_in_the_memory_estimate():
    """A block holds at least one grid point with all its starts: 10^6 starts at one point
    of fig06a (record 100) need gigabytes, and the estimate says so."""
    sc = config.load(FIG06A, ["initial.count=1000000"])
    per_start = sc.record * sc.spec.bytes_per_event
    assert estimate.estimate_memory(sc) > 1e6 * per_start


# ------------------------------------------------------------------ threads
def test_threads_above_the_cores_are_refused(tmp_path):
    import numba
    n = numba.config.NUMBA_NUM_THREADS + 1
    refused(run("sweep", FIG06A, "-o", tmp_path / "x.h5", *SMALL, "--threads", n),
            f"--threads {n}: numba can use at most")
    assert not list(tmp_path.iterdir())


# ------------------------------------------------------------------ paths
def test_outputs_that_cannot_or_must_not_be_written_are_refused(tmp_path):
    refused(run("sweep", FIG06A, "-o", tmp_path / "missing" / "x.h5", *SMALL),
            "does not exist")
    scene = tmp_path / "s.toml"
    shutil.copy(FIG06A, scene)
    refused(run("sweep", scene, "-o", scene, "--overwrite", *SMALL), "the scene file itself")
    assert scene.read_text() == open(FIG06A).read()
    other = tmp_path / "notes.h5"
    other.write_text("my notes")
    refused(run("sweep", FIG06A, "-o", other, "--overwrite", *SMALL),
            "is not a cornerbif HDF5 file")
    assert other.read_text() == "my notes"
    refused(run("sweep", FIG06A, "-o", tmp_path / ("x" * 300 + ".h5"), *SMALL), "too long")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.h5", "s.toml"]


def test_a_read_only_directory_is_refused(tmp_path):
    """A directory without write permission, or (as root, who ignores permissions) a
    read-only filesystem where this machine lets us mount one."""
    d = tmp_path / "ro"
    d.mkdir()
    if os.geteuid() != 0:
        d.chmod(0o555)
    else:
        r = subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=1M", "tmpfs", str(d)],
                           capture_output=True, text=True)
        if r.returncode != 0:
            pytest.skip(f"cannot mount a read-only tmpfs here ({r.stderr.strip()})")
    try:
        refused(run("sweep", FIG06A, "-o", d / "x.h5", *SMALL), "not writable")
        refused(run("plot", FIG06A, "-o", d / "f.png"), "not writable")
    finally:
        if os.geteuid() == 0:
            subprocess.run(["umount", str(d)])


def test_default_output_names_stay_in_the_working_directory(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for name, expected in (("../x", "x.h5"), ("/etc/passwd", "passwd.h5"), ("a b*c", "a_b_c.h5"),
                           ("..", "scene.h5"), ("y" * 200, "y" * 100 + ".h5")):
        sc = config.load(FIG06A, [f"scene.name={name!r}"])
        assert outputs.default_output(sc) == expected, name
    scene = tmp_path / "s.toml"
    scene.write_text(open(FIG06A).read().replace('name = "fig06a"', 'name = "../escape"'))
    r = run("sweep", scene, *SMALL, "--no-progress")
    assert r.exit_code == 0, r.output
    assert (tmp_path / "escape.h5").exists() and not (tmp_path.parent / "escape.h5").exists()


def test_plot_outputs_are_checked(tmp_path):
    r = run("sweep", FIG06A, "-o", tmp_path / "g.h5", *SMALL)
    assert r.exit_code == 0, r.output
    refused(run("plot", tmp_path / "g.h5", "-o", tmp_path / "no" / "f.png"), "does not exist")
    refused(run("plot", tmp_path / "g.h5", "-o", tmp_path / "g.h5"), "must be .png")


# ------------------------------------------------------------------ the room on the disk
def test_the_room_on_the_disk_is_read_in_one_place(tmp_path, monkeypatch):
    """The free space and this process's file-size limit are read by ``io.free_space`` and
    ``io.size_limit`` alone: the room a block has (``io.room``: the free space, or the limit
    less the file's size, whichever is less), the note of a file that will not fit
    (``io.RoomWatch``) and the sweep's budget (``sweep._free_bytes``, ``_size_limit``) all
    follow them.  Before, each read statvfs and RLIMIT_FSIZE itself: RoomWatch ignored a
    disk that ``free_space`` said was full."""
    from cornerbif import io
    assert sweep._free_bytes is io.free_space and sweep._size_limit is io.size_limit
    grown = tmp_path / "grown.bin"
    grown.write_bytes(b"x" * 100)
    monkeypatch.setattr(io, "free_space", lambda d: 12345)
    monkeypatch.setattr(io, "size_limit", lambda: None)
    assert io.room(str(grown)) == 12345
    monkeypatch.setattr(io, "size_limit", lambda: 1000)
    assert io.room(str(grown)) == 900 and io.room(str(grown), size=500) == 500
    monkeypatch.setattr(io, "free_space", lambda d: None)
    monkeypatch.setattr(io, "size_limit", lambda: None)
    assert io.room(str(grown)) is None
    said = []
    with h5py.File(tmp_path / "w.h5", "w") as f:
        f.create_dataset("done", shape=(100,), dtype="u1")
        watch = io.RoomWatch(f, said.append)
        f.create_dataset("data", data=np.arange(10000.0))
        f.flush()
        watch.wrote(f, 10)                     # 10 of 100 points, a roomy disk: no note
        assert said == []
        monkeypatch.setattr(io, "free_space", lambda d: 1000)
        watch.wrote(f, 10)
    assert len(said) == 1 and "more than its disk or the file-size limit leaves" in said[0]
