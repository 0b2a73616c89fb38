"""A disk that fills, or a file-size limit, in the middle of a sweep: one clear message, exit 1,
every finished block kept, and --resume completes the file bitwise equal to an uninterrupted
run (issue: reliability at the edges).

Three ways in: a real small filesystem (a tmpfs, where this machine lets us mount one), a real
file-size limit (``ulimit -f``, RLIMIT_FSIZE, in a child process), and a write that fails
inside HDF5 itself (a disk filled by someone else between the room check and the write),
simulated in a child process, since the command then ends at once without HDF5's clean-up.
"""

import os
import signal
import subprocess
import sys
import textwrap

import h5py
import pytest
from click.testing import CliRunner
from conftest import FILL_DISK_SOURCE

from cornerbif import io
from cornerbif.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FIG06A = os.path.join(ROOT, "configs", "fig06a.toml")
SETS = ["--set", "sweep.kappa.num=24", "--set", "initial.count=3", "--set", "run.transient=20",
        "--set", "run.record=200", "--block-points", "2", "--no-progress"]


def sweep(out, *extra, **kw):
    return subprocess.run([sys.executable, "-m", "cornerbif.cli", "sweep", FIG06A, "-o", str(out),
                           *SETS, *extra], capture_output=True, text=True, timeout=600, **kw)


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    out = tmp_path_factory.mktemp("ref") / "ref.h5"
    r = sweep(out)
    assert r.returncode == 0, r.stderr
    return out


def assert_same(a, b):
    with h5py.File(a) as f, h5py.File(b) as g:
        names = []
        f.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        for n in names:
            x, y = f[n][...], g[n][...]
            assert x.dtype == y.dtype and x.shape == y.shape, n
            assert x.tobytes() == y.tobytes(), n


def one_clear_message(r):
    assert "Traceback" not in r.stderr and "Exception ignored" not in r.stderr, r.stderr[-2000:]
    lines = [x for x in r.stderr.splitlines() if x.startswith("error:")]
    assert len(lines) == 1, r.stderr
    assert "--resume" in lines[0]
    return lines[0]


def test_room_refuses_a_block_the_disk_cannot_take(tmp_path, monkeypatch, reference):
    """The room check in the writer: a block that does not fit stops the sweep before it is
    written; the file is closed cleanly and resumes bitwise."""
    out = tmp_path / "d.h5"
    real = io.room
    calls = {"n": 0}

    def shrinking(path, size=None):
        calls["n"] += 1
        return 1000 if calls["n"] >= 4 else real(path, size)     # the disk fills for good

    monkeypatch.setattr(io, "room", shrinking)
    args = ["sweep", FIG06A, "-o", str(out), *SETS]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 1 and "no room for the next block" in r.output and "--resume" in r.output
    with h5py.File(str(out) + ".partial") as f:
        done = f["done"][...]
        assert 0 < done.sum() < done.size
    monkeypatch.setattr(io, "room", real)
    r = CliRunner().invoke(main, args + ["--resume"])
    assert r.exit_code == 0, r.output
    assert_same(reference, out)


@pytest.mark.slow
def test_a_real_full_disk_stops_at_once_and_resumes_bitwise(tmpfs, reference):
    """A real small filesystem, filled by another file while the sweep runs (the sweep's own
    budget check at the start sees room, as on a shared disk that others fill)."""
    mnt = tmpfs("8M")
    out = mnt / "d.h5"
    filler = mnt / "filler"
    # the sweep writes 2 grid points a block; after its file exists, the disk is filled
    code = FILL_DISK_SOURCE + textwrap.dedent(f"""
        import os, sys
        from cornerbif import io
        real = io.write_block
        n = [0]
        def fill_then_write(f, index, block):
            n[0] += 1
            if n[0] == 3:      # another process takes the rest of the disk
                fill_disk({str(filler)!r})
            real(f, index, block)
        io.write_block = fill_then_write
        from cornerbif.cli import main
        sys.argv = ["cornerbif", "sweep", {FIG06A!r}, "-o", {str(out)!r}] + {SETS!r}
        main()
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                       timeout=600)
    assert r.returncode == 1, r.stderr[-3000:]
    msg = one_clear_message(r)
    assert "no room" in msg
    assert not out.exists() and (mnt / "d.h5.partial").exists()
    os.remove(filler)
    r = sweep(out, "--resume")
    assert r.returncode == 0, r.stderr
    assert_same(reference, out)


@pytest.mark.slow
def test_a_file_size_limit_stops_at_once_and_resumes_bitwise(tmp_path, reference):
    """``ulimit -f``: the room check reads RLIMIT_FSIZE, so the block that would pass the limit
    is refused before HDF5 writes it (the kernel would send SIGXFSZ)."""
    import resource
    out = tmp_path / "d.h5"
    cap = io.WRITE_RESERVE + os.path.getsize(reference) // 2    # room for about half the blocks

    def limit():
        resource.setrlimit(resource.RLIMIT_FSIZE, (cap, cap))

    r = sweep(out, preexec_fn=limit)
    assert r.returncode == 1, r.stderr[-3000:]
    one_clear_message(r)
    assert not out.exists() and os.path.getsize(str(out) + ".partial") <= cap
    with h5py.File(str(out) + ".partial") as f:
        assert 0 < f["done"][...].sum() < f["done"].size
    r = sweep(out, "--resume")
    assert r.returncode == 0, r.stderr
    assert_same(reference, out)


@pytest.mark.slow
def test_a_write_failing_inside_hdf5_ends_at_once_without_a_flood(tmp_path, reference):
    """A disk filled between the room check and the write: HDF5 itself fails. The command
    says so in one line and ends at once (exit 1, no traceback, no segfault); the blocks
    marked done before are kept and --resume completes the file bitwise."""
    out = tmp_path / "d.h5"
    code = textwrap.dedent(f"""
        import errno, sys
        from cornerbif import io
        real = io.write_block
        n = [0]
        def failing(f, index, block):
            n[0] += 1
            if n[0] == 3:
                raise OSError(errno.ENOSPC, "No space left on device")
            real(f, index, block)
        io.write_block = failing
        from cornerbif.cli import main
        sys.argv = ["cornerbif", "sweep", {FIG06A!r}, "-o", {str(out)!r}] + {SETS!r}
        main()
    """)
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert r.returncode == 1 and r.returncode != -signal.SIGSEGV, r.stderr[-3000:]
    msg = one_clear_message(r)
    assert "ENOSPC" in msg
    r = sweep(out, "--resume")
    assert r.returncode == 0, r.stderr
    assert_same(reference, out)
