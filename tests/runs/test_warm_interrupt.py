"""``cornerbif warm`` says what is true when interrupted, and how many groups it runs at
a time.

Found by a hostile audit: ``cornerbif warm linear`` interrupted during its cold compile
passed on its warm-up sweep's message, "finished points are kept in
/tmp/cornerbif-warm-XXXX/warm_linear.h5.partial; run again with --resume to complete it",
though that folder is removed on the way out and warm has no --resume; and ``--jobs
100000`` printed "(100000 at a time)" for one group.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time

import pytest
from click.testing import CliRunner

from cornerbif import warm
from cornerbif.cli import main
from cornerbif.errors import EXIT_INTERRUPTED, SweepInterrupted

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def said_truly(output):
    """An interrupted warm's message: no partial file, no --resume, numba's cache and warm
    again."""
    assert "warm keeps no file" in output and "numba's cache" in output, output
    assert "run cornerbif warm again" in output, output
    assert ".partial" not in output and "--resume" not in output, output
    assert "Traceback" not in output, output


@pytest.mark.parametrize("raised", [KeyboardInterrupt, "sweep"])
def test_an_interrupted_warm_up_here_says_what_is_kept(monkeypatch, raised):
    """One group runs in this process: an interrupt during its sweep (Ctrl-C itself, or the
    sweep's own ``SweepInterrupted`` naming a partial file in the temporary folder) ends
    with exit 130 and warm's own message; the temporary folder is gone."""
    folders = []

    def interrupted(w, folder, echo):
        folders.append(folder)
        if raised == "sweep":
            raise SweepInterrupted(f"interrupted; finished points are kept in {folder}/"
                                   "warm_linear.h5.partial; run again with --resume to "
                                   "complete it")
        raise KeyboardInterrupt
    monkeypatch.setattr(warm, "run_warmup", interrupted)
    r = CliRunner().invoke(main, ["warm", "linear"])
    assert r.exit_code == EXIT_INTERRUPTED, r.output
    said_truly(r.output)
    assert folders and not os.path.exists(folders[0])


def test_an_interrupted_child_group_says_it_once(monkeypatch):
    """Groups side by side: a child interrupted (its exit 130) stops the rest and warm says
    the same true message (it counted as a failed group before: "the warm-up of ... failed
    (its message above)", with no message above)."""
    real = subprocess.Popen

    class Child:
        """A warm-up child interrupted on its second poll; any other process is started
        for real (numba asks for some)."""

        def __new__(cls, argv, **kw):
            return super().__new__(cls) if "cornerbif.warm" in argv else real(argv, **kw)

        def __init__(self, argv, **kw):
            self.returncode = None
            self.polled = 0

        def poll(self):
            self.polled += 1
            if self.polled > 1:
                self.returncode = 130
            return self.returncode

        def terminate(self):
            pass

        def wait(self):
            return self.returncode
    monkeypatch.setattr(warm.subprocess, "Popen", Child)
    with pytest.raises(SweepInterrupted) as e:
        warm.warm(["flow"], 2, lambda m: None)
    said_truly(str(e.value))


def test_a_child_group_interrupted_returns_130_without_a_traceback(monkeypatch, capsys):
    """The child's own interrupt (its sweep's ``SweepInterrupted``, not a KeyboardInterrupt)
    ended in a traceback; now exit 130, quietly: the parent says it once."""
    def interrupted(name, warmups, echo):
        raise SweepInterrupted(warm.INTERRUPTED)
    monkeypatch.setattr(warm, "run_group", interrupted)
    assert warm._child(["flow", "--group", "flow"]) == 130
    assert capsys.readouterr().err == ""


def test_jobs_said_are_the_jobs_used(monkeypatch):
    """``--jobs 100000`` with one group runs one at a time, and says so."""
    used = []
    monkeypatch.setattr(warm, "warm", lambda models, n, echo: used.append(n) or 0.0)
    r = CliRunner().invoke(main, ["warm", "--jobs", "100000", "linear"])
    assert r.exit_code == 0, r.output
    assert "(1 at a time)" in r.output and "100000" not in r.output, r.output
    assert used == [1]
    r = CliRunner().invoke(main, ["warm", "--jobs", "100000", "flow"])
    assert "(2 at a time)" in r.output and used[-1] == 2, r.output


@pytest.mark.slow
def test_ctrl_c_during_a_cold_compile(tmp_path):
    """The audit's case, with a real SIGINT: a fresh numba cache, Ctrl-C while the linear
    kernel compiles (which nothing cuts short): exit 130 without waiting for it, the true message,
    and no temporary folder of warm's left."""
    env = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "cache"), TMPDIR=str(tmp_path))
    p = subprocess.Popen([sys.executable, "-m", "cornerbif.cli", "warm", "linear"], cwd=ROOT,
                         stderr=subprocess.PIPE, text=True, env=env)
    seen = ""
    end = time.monotonic() + 300
    while "compiling the linear kernel" not in seen and time.monotonic() < end:
        line = p.stderr.readline()
        if not line:
            break
        seen += line
    p.send_signal(signal.SIGINT)
    err = seen + p.communicate(timeout=300)[1]
    assert p.returncode == EXIT_INTERRUPTED, err
    said_truly(err)
    assert not [n for n in os.listdir(tmp_path) if n.startswith("cornerbif-warm-")]
