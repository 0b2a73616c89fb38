"""A sweep's message that says its partial file is kept is true: the file is there, and
``--resume`` completes it.

Found by a hostile audit: under ``ulimit -f 200`` a sweep whose first block did not fit
said "uf.h5.partial: no room ... every finished point is kept; ... run the same command
with --resume" (exit 1), and no uf.h5.partial was left: a sweep stopped before its first
point removed its partial file, whatever stopped it.  Now only a refusal (exit 2: an
unreachable --scheduler) removes it; a fault or an interrupt keeps it, and says so of a
file without a finished point.
"""

from __future__ import annotations

import os
import re
import resource
import subprocess
import sys

import pytest
from click.testing import CliRunner

from cornerbif import local
from cornerbif.cli import main
from cornerbif.errors import EXIT_FAULT, EXIT_INPUT, EXIT_INTERRUPTED, Fault, SweepError, WriteFailed

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FIG06A = os.path.join(ROOT, "configs", "fig06a.toml")
BALL = os.path.join(ROOT, "configs", "bouncing_ball.toml")
TINY = ["--set", "sweep.kappa.num=4", "--set", "initial.count=2", "--set", "run.transient=10",
        "--set", "run.record=10", "--no-progress"]


def kept_is_true(message):
    """Every partial file a message says is kept exists."""
    named = re.findall(r"(\S+\.h5\.partial)", message)
    if "kept" in message:
        assert named, message
    for path in named:
        assert os.path.exists(path.rstrip(";:,)")), message


@pytest.mark.parametrize("error, code", [
    (WriteFailed("x.h5.partial: no room for the next block (9 KiB needed, 1 KiB left); "
                 "every finished point is kept; free space and run the same command with "
                 "--resume"), EXIT_FAULT),
    (Fault("2 of 2 chunks failed on the cluster; every other chunk is written; run the same "
           "command again with --resume to retry the missing chunks"), EXIT_FAULT),
    (KeyboardInterrupt(), EXIT_INTERRUPTED),
])
def test_a_sweep_stopped_before_its_first_point_keeps_what_it_says(tmp_path, monkeypatch,
                                                                  error, code):
    """A full disk, failed chunks or an interrupt before the first point: the partial file
    (the scene and its grid) is kept, the message's --resume completes the sweep."""
    def stopped(*a, **kw):
        raise error
    monkeypatch.setattr(local, "run_blocks", stopped)
    out = tmp_path / "x.h5"
    monkeypatch.chdir(tmp_path)
    r = CliRunner().invoke(main, ["sweep", FIG06A, "-o", "x.h5", *TINY])
    assert r.exit_code == code, r.output
    assert "--resume" in r.output and (tmp_path / "x.h5.partial").exists(), r.output
    kept_is_true(r.output)
    if not isinstance(error, Fault):
        assert "none was finished yet" in r.output or "no point was finished yet" in r.output
    monkeypatch.undo()
    r = CliRunner().invoke(main, ["sweep", FIG06A, "-o", str(out), *TINY, "--resume"])
    assert r.exit_code == 0 and out.exists(), r.output
    assert not (tmp_path / "x.h5.partial").exists()


def test_a_refusal_before_the_first_point_leaves_no_partial_file(tmp_path, monkeypatch):
    """A refusal (exit 2; an unreachable --scheduler is one) still leaves nothing: its
    message sends no one to --resume."""
    def refused(*a, **kw):
        raise SweepError("--scheduler tcp://nowhere: cannot reach a Dask scheduler there")
    monkeypatch.setattr(local, "run_blocks", refused)
    out = tmp_path / "x.h5"
    r = CliRunner().invoke(main, ["sweep", FIG06A, "-o", str(out), *TINY])
    assert r.exit_code == EXIT_INPUT, r.output
    assert not os.path.exists(str(out) + ".partial") and "--resume" not in r.output


@pytest.mark.slow
def test_the_audits_file_size_limit_keeps_the_partial_file_it_names(tmp_path):
    """The audit's case, a real ``ulimit -f``: the partial file (48 KB) is created, the
    first block (about 260 KiB) does not fit; exit 1, the message names the partial file
    kept, and it exists; without the limit --resume completes the sweep.  (With numba's cache
    cold, a clean install's, the limit is met inside the write: EFBIG, the same promise.)"""
    cap = 100 * 1024

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (cap, cap))
    args = [sys.executable, "-m", "cornerbif.cli", "sweep", BALL, "-o", "uf.h5",
            "--set", 'sweep."contact.T.beta".num=6', "--set", "initial.count=16",
            "--set", "run.transient=100", "--set", "run.record=2000", "--block-points", "2",
            "--no-progress"]
    r = subprocess.run(args, cwd=tmp_path, capture_output=True, text=True, timeout=600,
                       preexec_fn=limit)
    assert r.returncode == EXIT_FAULT, r.stderr[-2000:]
    # refused before the block's write ("no room"), or, where the limit is met inside the write
    # (a first compile's cache files change what the process has written), by the write itself
    assert ("no room" in r.stderr or "EFBIG" in r.stderr) and "Traceback" not in r.stderr, \
        r.stderr[-2000:]
    assert "uf.h5.partial" in r.stderr and "kept" in r.stderr, r.stderr[-2000:]
    assert (tmp_path / "uf.h5.partial").exists(), r.stderr[-2000:]
    r = CliRunner().invoke(main, [*args[3:], "-o", str(tmp_path / "uf.h5"), "--resume"])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "uf.h5").exists() and not (tmp_path / "uf.h5.partial").exists()
