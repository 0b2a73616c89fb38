"""Interrupted and concurrent runs: SIGKILL at random moments then --resume is bitwise
equal, a kill while finishing keeps a resumable partial file, a second writer fails
fast; provenance in the file; a grid too big for the disk or memory refused first."""

import os
import random
import signal
import subprocess
import sys
import time

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from cornerbif import io
from cornerbif import sweep as sweep_mod
from cornerbif.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


FIG06A = os.path.join(ROOT, "configs", "fig06a.toml")


# ---------------------------------------------------------------- interrupted and concurrent runs
def _sweep_args(out, extra=()):
    return [sys.executable, "-m", "cornerbif.cli", "sweep", FIG06A, "-o", str(out), "--no-progress",
            "--set", "sweep.kappa.num=240", "--set", "initial.count=4", "--block-points", "8",
            *extra]


@pytest.mark.slow
def test_sigkill_at_random_moments_then_resume_is_bitwise_equal(tmp_path):
    """10 runs killed with SIGKILL (by process id) at random moments: the partial file always
    opens, every point marked done holds data, and --resume completes to the same bytes.
    The moments are spread over the reference run's own duration (at least 2.2 s): on a
    busy machine its start-up alone can outlast a fixed window."""
    ref = tmp_path / "ref.h5"
    t_ref = time.monotonic()
    subprocess.run(_sweep_args(ref), check=True, capture_output=True)
    t_ref = max(2.2, time.monotonic() - t_ref)
    with h5py.File(ref) as f:
        want = {k: f[k][...] for k in ("impacts/t", "impacts/v_out", "section/u", "status",
                                        "period", "initial/u")}
        want_sym = f["symbols"][...]
    rng = random.Random(42)
    kinds = set()
    for trial in range(10):
        out = tmp_path / f"k{trial}.h5"
        p = subprocess.Popen(_sweep_args(out), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        time.sleep(rng.uniform(0.3, t_ref))
        os.kill(p.pid, signal.SIGKILL)
        p.wait()
        partial = str(out) + ".partial"
        if os.path.exists(partial):
            with io.check_readable(partial) as f:          # opens, is a cornerbif file
                done = f["done"][...].astype(bool)
                st_ = f["status"][...]
                assert (st_[done] >= 0).all()
                assert np.isfinite(f["initial/u"][...][done]).all()
                assert np.isfinite(f["impacts/t"][...][done][..., -1]).all()
                kinds.add("partial" if not done.all() else "all-done")
        elif os.path.exists(out):
            kinds.add("finished")
        else:
            kinds.add("not started")
        if not os.path.exists(out):
            r = subprocess.run(_sweep_args(out, ["--resume"]), capture_output=True, text=True)
            assert r.returncode == 0, (trial, r.stderr)
        with h5py.File(out) as f:
            for k, v in want.items():
                assert np.array_equal(f[k][...], v, equal_nan=True), (trial, k)
            assert (f["symbols"][...] == want_sym).all()
    assert "partial" in kinds


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


@pytest.mark.slow
def test_sigkill_while_finishing_keeps_a_resumable_partial_file(tmp_path):
    """A kill while the finished file is stamped (its attractor table written outside
    single-writer/multiple-reader mode) once left a partial file HDF5 could not open; the
    stamp goes on a copy, so the partial file opens, is all done, and --resume finishes it
    to the same bytes as an uninterrupted run."""
    ref, out = tmp_path / "ref.h5", tmp_path / "k.h5"
    args = _sweep_args(ref)[3:]
    args = [a.replace("240", "24") for a in args]
    subprocess.run([sys.executable, "-m", "cornerbif.cli", *args], check=True,
                   capture_output=True)
    args[args.index(str(ref))] = str(out)
    r = subprocess.run([sys.executable, "-c", KILL_IN_TABLE, *args], capture_output=True)
    assert r.returncode == -signal.SIGKILL
    assert not out.exists()
    with io.check_readable(str(out) + ".partial") as f:
        assert f["done"][...].all()
    r = subprocess.run([sys.executable, "-m", "cornerbif.cli", *args, "--resume"],
                       capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    assert not os.path.exists(str(out) + ".partial")
    assert not os.path.exists(str(out) + ".partial.amend")
    with h5py.File(ref) as a, h5py.File(out) as b:
        for k in ("impacts/t", "status", "period", "attractor", "attractors/id",
                  "attractors/fraction"):
            assert np.array_equal(a[k][...], b[k][...], equal_nan=True), k


@pytest.mark.slow
def test_second_writer_fails_fast(tmp_path):
    out = tmp_path / "c.h5"
    p = subprocess.Popen(_sweep_args(out), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.time() + 20
        while not os.path.exists(str(out) + ".lock") and time.time() < deadline:
            time.sleep(0.05)
        r = subprocess.run(_sweep_args(out, ["--resume"]), capture_output=True, text=True)
        # the first sweep still running when the second returned: the second did not wait
        if p.poll() is None:
            assert r.returncode == 2 and "another sweep is writing" in r.stderr
    finally:
        p.wait()


def test_grid_too_big_for_disk_or_memory_is_refused_before_any_work(tmp_path, monkeypatch):
    out = tmp_path / "big.h5"
    args = ["sweep", FIG06A, "-o", str(out), "--set", "sweep.kappa.num=50"]
    monkeypatch.setattr(sweep_mod, "_free_bytes", lambda d: 1000)
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 2 and "but only" in r.output and "free on its disk" in r.output
    assert not os.path.exists(out) and not os.path.exists(str(out) + ".partial")
    monkeypatch.setattr(sweep_mod, "_free_bytes", lambda d: None)
    monkeypatch.setattr(sweep_mod.io, "available_memory", lambda: 1000)
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 2 and "of memory but only" in r.output
    assert not os.path.exists(out) and not os.path.exists(str(out) + ".partial")
    r = CliRunner().invoke(main, args + ["--dry-run"])      # the estimates, then the refusal
    assert r.exit_code == 2 and "MiB uncompressed" in r.output and "working memory" in r.output
    assert "of memory but only" in r.output
    monkeypatch.setattr(sweep_mod.io, "available_memory", lambda: None)
    r = CliRunner().invoke(main, args + ["--dry-run"])
    assert r.exit_code == 0 and "ok: the sweep can start" in r.output
