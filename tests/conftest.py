import inspect
import os
import shutil
import subprocess
import sys

import pytest

HERE = os.path.dirname(__file__)
ROOT = os.path.dirname(HERE)
sys.path.insert(0, HERE)


@pytest.fixture
def configs_dir():
    return os.path.join(ROOT, "configs")

# property tests: reproducible examples in CI (a red CI must be reproducible); random locally
from hypothesis import settings as _hsettings  # noqa: E402

_hsettings.register_profile("ci", derandomize=True, deadline=None)
if os.environ.get("CI"):
    _hsettings.load_profile("ci")


# ------------------------------------------------------------------ a small, full disk
def mount_tmpfs(path, options):
    """Mount a tmpfs at ``path`` (a folder it creates) with the mount ``options`` ("size=8M",
    "ro,size=1M"): a real small filesystem for the full-disk tests.  The test is skipped
    where this machine does not let us mount one (not root, no mount(8), refused); whoever
    mounts unmounts (``tmpfs`` does)."""
    if os.geteuid() != 0 or not shutil.which("mount"):
        pytest.skip("mounting a tmpfs needs root and mount(8)")
    path.mkdir()
    r = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)],
                       capture_output=True, text=True)
    if r.returncode != 0:
        pytest.skip(f"this machine does not let us mount a tmpfs ({r.stderr.strip()})")


@pytest.fixture
def tmpfs(tmp_path):
    """``tmpfs("8M")`` mounts a tmpfs of that size at ``tmp_path / "mnt"`` and returns the
    folder (``tmpfs("1M", "ro", name="ro")``: read-only, at ``tmp_path / "ro"``); every
    one mounted is unmounted when the test ends, passed or failed (``mount_tmpfs``)."""
    mounted = []

    def mount(size, options="", name="mnt"):
        path = tmp_path / name
        mount_tmpfs(path, ",".join(x for x in (options, f"size={size}") if x))
        mounted.append(path)
        return path
    yield mount
    for path in reversed(mounted):
        subprocess.run(["umount", str(path)], capture_output=True)


def fill_disk(path, chunk=65536):
    """Write the file ``path`` until its filesystem is full, as another process taking the
    rest of the disk: unbuffered writes of ``chunk`` bytes (the last one short) until the
    filesystem refuses one (ENOSPC).  The file is kept: removing it frees the disk."""
    with open(path, "wb", buffering=0) as fh:
        try:
            while True:
                fh.write(b"x" * chunk)
        except OSError:
            pass


# ``fill_disk`` as source text, for the scripts of child processes (a command that ends
# at once on a failed write is run in a child): FILL_DISK_SOURCE + "...fill_disk(path)..."
FILL_DISK_SOURCE = inspect.getsource(fill_disk) + "\n\n"
