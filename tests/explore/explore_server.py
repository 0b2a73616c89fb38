"""The explorer's fixtures: a small sweep of Fig. 6(a) and a ``cornerbif explore`` server
over it (a subprocess, as a user starts it) per module; the browser's steps are one test,
so that one server and one browser serve them all.  Imported by the test modules that use
them (``from explore_server import ...``): a ``conftest.py`` here would be imported as the
module ``conftest`` and shadow tests/conftest.py, which other tests import by name."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import time

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ENTRY = "from cornerbif._entry import main; main()"
# the small file: Fig. 6(a)'s cascade, 241 values x 4 starts (about 100 000 points)
SMALL = ("--set", "sweep.kappa.num=241", "--set", "initial.count=4")


def cornerbif(*args, timeout=600, **kw):
    """Run the ``cornerbif`` command (this Python) in the project's folder."""
    return subprocess.run([sys.executable, "-c", ENTRY, *args], cwd=ROOT, capture_output=True,
                          text=True, timeout=timeout, **kw)


def explore_extra_missing() -> str | None:
    for mod in ("panel", "holoviews", "datashader"):
        try:
            __import__(mod)
        except ImportError:
            return f"the explore extra is not installed ({mod}): pip install \".[explore]\""
    return None


@pytest.fixture(scope="session")
def small_file(tmp_path_factory):
    out = str(tmp_path_factory.mktemp("explore") / "fig06a_small.h5")
    r = cornerbif("sweep", "configs/fig06a.toml", "-o", out, "--no-progress", *SMALL)
    assert r.returncode == 0, r.stderr
    return out


class Server:
    """A ``cornerbif explore FILE --no-browser`` subprocess: its ``url`` (with the token),
    ``base`` (without), ``port``, ``side_dir``, ``proc``."""

    def __init__(self, path, tmp):
        # its side folder (a temporary one) inside the test's
        env = dict(os.environ, TMPDIR=str(tmp))
        self.proc = subprocess.Popen([sys.executable, "-c", ENTRY, "explore", path,
                                      "--no-browser"], cwd=ROOT, stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True, env=env)
        self.lines = []
        end = time.time() + 120
        self.url = self.side_dir = None
        while time.time() < end and (self.url is None or self.side_dir is None):
            line = self.proc.stdout.readline()
            if not line:
                if self.proc.poll() is not None:
                    break
                continue
            self.lines.append(line)
            if m := re.search(r"(http://\S+\?token=\S+)", line):
                self.url = m.group(1)
            if m := re.search(r"side files .* in (\S+)", line):
                self.side_dir = m.group(1)
        assert self.url, "the server said no URL:\n" + "".join(self.lines)
        self.base = self.url.split("?")[0]
        self.port = int(re.search(r":(\d+)/", self.url).group(1))
        self.token = self.url.split("token=")[1]

    def stop(self):
        self.proc.terminate()
        try:
            self.proc.wait(20)
        except subprocess.TimeoutExpired:
            self.proc.kill()


@pytest.fixture(scope="module")
def server(small_file, tmp_path_factory):
    why = explore_extra_missing()
    if why:
        pytest.skip(why)
    srv = Server(small_file, tmp_path_factory.mktemp("server"))
    yield srv
    srv.stop()
