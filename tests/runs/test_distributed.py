"""Sweeps on Dask distributed (issue 7): same bytes as the local backend, and faults.

Every expected array comes from the local backend run on the same scene (the path
tests/runs/test_cli_io.py and tests/runs/test_kill_and_resume.py check); the cluster must give
the same bytes.  Fault tests use the test-only hook of ``cornerbif.distributed``
(``CORNERBIF_TEST_CRASH``: a control directory read on the workers).
Skipped when Dask distributed is not installed (``pip install ".[test]"`` has it).
"""

import importlib.util
import os
import signal
import subprocess
import sys
import time

import h5py
import pytest
from click.testing import CliRunner

from cornerbif.cli import main

HAS_DASK = importlib.util.find_spec("distributed") is not None
needs_dask = pytest.mark.skipif(not HAS_DASK, reason="dask[distributed] is not installed")
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

TINY = """
[scene]
name = "tiny"
model = "flow"

[system]
obstacle = "rectified_sine"
omega = 1.999
r = 0.8

[sweep]
kappa = { start = -0.016, stop = -0.010, num = NUM }

[initial]
count = 2
seed = 4

[run]
transient = 60
record = 20
"""
ALLOWED_FAILURES = 1     # the test cluster gives up on a chunk after 2 worker deaths


def _scene(tmp_path, num=9):
    p = tmp_path / f"tiny{num}.toml"
    p.write_text(TINY.replace("NUM", str(num)))
    return p


def _run(args):
    return CliRunner().invoke(main, [str(a) for a in args])


def _datasets(path):
    with h5py.File(path) as f:
        out = {}
        f.visititems(lambda n, o: out.__setitem__(n, o[...].tobytes())
                     if isinstance(o, h5py.Dataset) else None)
        return out, dict(f.attrs)


def _same_bytes(a, b):
    da, _ = _datasets(a)
    db, _ = _datasets(b)
    assert sorted(da) == sorted(db)
    differ = [k for k in da if da[k] != db[k]]
    assert not differ, differ


def _reference(tmp_path, scene, extra=()):
    ref = tmp_path / f"ref-{os.path.basename(str(scene))}.h5"
    if not ref.exists():
        r = _run(["sweep", scene, "-o", ref, "--block-points", "2", "--no-progress", *extra])
        assert r.exit_code == 0, r.output
    return ref


# ---------------------------------------------------------------- without a cluster
def test_without_dask_the_option_says_how_to_install(tmp_path, monkeypatch):
    import cornerbif.distributed  # noqa: F401 - loaded first, as it would be without Dask
    monkeypatch.setitem(sys.modules, "distributed", None)      # import distributed fails
    r = _run(["sweep", _scene(tmp_path), "-o", tmp_path / "x.h5", "--scheduler", "local:2"])
    assert r.exit_code == 2
    assert 'pip install "cornerbif[dask]"' in r.output and "Traceback" not in r.output
    assert not (tmp_path / "x.h5.partial").exists()


@pytest.mark.parametrize("spec", ["local:0", "local:two", ""])
def test_bad_scheduler_is_refused_naming_the_value(tmp_path, spec):
    r = _run(["sweep", _scene(tmp_path), "-o", tmp_path / "x.h5", "--scheduler", spec])
    assert r.exit_code == 2 and "--scheduler" in r.output, r.output
    assert "Traceback" not in r.output


def test_numba_threads_times_dask_threads_stay_within_the_cores(monkeypatch):
    from cornerbif import distributed as D
    monkeypatch.delenv(D.THREADS_ENV, raising=False)
    monkeypatch.setattr(D, "_cores", lambda: 8)
    monkeypatch.setattr("numba.config.NUMBA_NUM_THREADS", 8)
    assert D._numba_threads(None, 1) == 8         # one Dask thread: all the cores
    assert D._numba_threads(None, 3) == 2         # 3 Dask threads: 8 // 3
    assert D._numba_threads(None, 16) == 1        # never below one
    monkeypatch.setenv(D.THREADS_ENV, "4")
    assert D._numba_threads(None, 1) == 4         # the worker's environment
    assert D._numba_threads(2, 1) == 2            # --threads wins
    assert D._numba_threads(64, 1) == 8           # capped at numba's pool


# ---------------------------------------------------------------- on a local cluster
@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    """Two worker processes, one Dask thread and one numba thread each, the test hook's
    control directory in their environment, and a chunk given up after 2 deaths."""
    if not HAS_DASK:
        pytest.skip("dask[distributed] is not installed")
    import dask
    from distributed import LocalCluster
    ctrl = tmp_path_factory.mktemp("ctrl")
    # the nannies pass this environment to every worker they start, restarts included
    env = {"CORNERBIF_TEST_CRASH": str(ctrl), "CORNERBIF_NUMBA_THREADS": "1"}
    with dask.config.set({"distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
                          "distributed.scheduler.worker-saturation": 1.0}):
        lc = LocalCluster(n_workers=2, threads_per_worker=1, processes=True,
                          dashboard_address=None, silence_logs=50, env=env)
    try:
        yield lc.scheduler_address, ctrl
    finally:
        lc.close()


def _clear(ctrl):
    for name in os.listdir(ctrl):
        os.remove(os.path.join(ctrl, name))


@pytest.mark.slow
@needs_dask
def test_local_cluster_gives_the_local_backends_bytes(tmp_path):
    """`--scheduler local:2` (its own cluster) against the local backend, same scene."""
    scene = _scene(tmp_path)
    ref = _reference(tmp_path, scene)
    out = tmp_path / "dask.h5"
    r = _run(["sweep", scene, "-o", out, "--block-points", "2", "--no-progress",
              "--scheduler", "local:2"])
    assert r.exit_code == 0, r.output
    assert "submitting 5 of 5 chunks" in r.output       # ceil(9 points / 2 per chunk)
    _same_bytes(ref, out)
    _, attrs = _datasets(out)
    assert "--scheduler local:2" in attrs["command"]


@pytest.mark.slow
@needs_dask
def test_followed_scene_runs_as_a_chain_with_the_same_bytes(tmp_path, cluster):
    """Fig. 7(b) followed up: each slab starts from the previous one's final states."""
    address, _ = cluster
    scene = os.path.join(ROOT, "configs", "fig07b_up.toml")
    sets = ["--set", "sweep.kappa.num=6", "--set", "initial.count=2", "--set",
            "run.transient=60", "--set", "run.record=20"]
    ref = tmp_path / "ref.h5"
    assert _run(["sweep", scene, "-o", ref, *sets]).exit_code == 0
    out = tmp_path / "dask.h5"
    r = _run(["sweep", scene, "-o", out, *sets, "--scheduler", address])
    assert r.exit_code == 0, r.output
    assert "one chunk at a time, in order" in r.output
    _same_bytes(ref, out)


@pytest.mark.slow
@needs_dask
def test_a_linear_scene_gives_the_local_backends_bytes(tmp_path, cluster):
    """A linear scene (configs/two_stops.toml: two contacts, contact words, its own datasets
    per coordinate; with start times drawn in [0, 2]) on the cluster: the local backend's
    bytes."""
    address, _ = cluster
    scene = os.path.join(ROOT, "configs", "two_stops.toml")
    sets = ["--set", 'sweep."forcing.0.Omega".num=5', "--set", "initial.count=2", "--set",
            "run.transient=40", "--set", "run.record=16", "--set", "initial.t=[0.0, 2.0]",
            "--block-points", "2"]
    ref = tmp_path / "ref.h5"
    r = _run(["sweep", scene, "-o", ref, "--no-progress", *sets])
    assert r.exit_code == 0, r.output
    out = tmp_path / "dask.h5"
    r = _run(["sweep", scene, "-o", out, "--no-progress", *sets, "--scheduler", address])
    assert r.exit_code == 0, r.output
    _same_bytes(ref, out)
    with h5py.File(out) as f:
        assert "impacts/x" in f and (f["initial/t"][...] > 0.0).any()


@needs_dask
def test_a_worker_killed_once_mid_chunk_has_its_chunk_rerun(tmp_path, cluster):
    address, ctrl = cluster
    _clear(ctrl)
    scene = _scene(tmp_path)
    ref = _reference(tmp_path, scene)
    (ctrl / "crash-2").write_text("once")
    out = tmp_path / "dask.h5"
    try:
        r = _run(["sweep", scene, "-o", out, "--block-points", "2", "--scheduler", address])
    finally:
        os.remove(ctrl / "crash-2")
    assert r.exit_code == 0, r.output
    pids = (ctrl / "attempts-2").read_text().split()
    assert len(pids) == 2 and pids[0] != pids[1]        # died once, re-run on another process
    _same_bytes(ref, out)


@pytest.mark.slow
@needs_dask
def test_a_poison_chunk_is_marked_failed_and_the_rest_completes(tmp_path, cluster):
    address, ctrl = cluster
    _clear(ctrl)
    scene = _scene(tmp_path)
    ref = _reference(tmp_path, scene)
    (ctrl / "crash-1").write_text("always")
    out = tmp_path / "dask.h5"
    args = ["sweep", scene, "-o", out, "--block-points", "2", "--scheduler", address]
    try:
        r = _run(args)
    finally:
        os.remove(ctrl / "crash-1")
    assert r.exit_code == 1, r.output
    assert "1 of 5 chunks failed" in r.output and "chunk 1 (kappa[2:4])" in r.output
    assert "KilledWorker" in r.output and "--resume" in r.output
    # it killed a worker each time it ran: allowed-failures + 1 times
    assert len((ctrl / "attempts-1").read_text().split()) == ALLOWED_FAILURES + 1
    partial = str(out) + ".partial"
    with h5py.File(partial, "r") as f:
        done = f["done"][...]
        assert list(done) == [1, 1, 0, 0, 1, 1, 1, 1, 1]    # chunk 1 = points 2, 3
        assert '"chunk": 1' in f.attrs["failed_chunks"]
        assert "KilledWorker" in f.attrs["failed_chunks"]
    r = _run(args + ["--resume"])
    assert r.exit_code == 0, r.output
    assert "submitting 1 of 5 chunks (4 already done)" in r.output
    _same_bytes(ref, out)
    _, attrs = _datasets(out)
    assert "failed_chunks" not in attrs


@pytest.mark.slow
@needs_dask
def test_driver_killed_mid_run_then_resume_submits_only_the_missing_chunks(tmp_path, cluster):
    """The driver (a separate process) is SIGKILLed after chunks 0-4 of 12 are written
    while chunks >= 5 are held on the workers; --resume must submit exactly 12 - 5."""
    address, ctrl = cluster
    _clear(ctrl)
    scene = _scene(tmp_path, num=12)
    ref = _reference(tmp_path, scene, ["--block-points", "1"])
    out = tmp_path / "dask.h5"
    partial = str(out) + ".partial"
    args = [sys.executable, "-m", "cornerbif.cli", "sweep", str(scene), "-o", str(out),
            "--block-points", "1", "--no-progress", "--scheduler", address]
    (ctrl / "hold").write_text("5")
    p = subprocess.Popen(args, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        deadline = time.time() + 90
        n_done = 0
        while time.time() < deadline and n_done < 5:
            time.sleep(0.2)
            try:
                with h5py.File(partial, "r", swmr=True, locking=False) as f:
                    n_done = int(f["done"][...].sum())
            except (OSError, KeyError):
                pass
        assert n_done == 5, n_done
        time.sleep(0.5)                       # chunks >= 5 are held: nothing more is written
    finally:
        os.kill(p.pid, signal.SIGKILL)
        p.wait()
        os.remove(ctrl / "hold")
    with h5py.File(partial, "r", swmr=True, locking=False) as f, h5py.File(ref) as g:
        assert list(f["done"][...]) == [1] * 5 + [0] * 7       # nothing finished is lost
        for k in ("impacts/t", "status", "initial/u", "symbols"):
            assert f[k][:5].tobytes() == g[k][:5].tobytes(), k
    r = subprocess.run(args + ["--resume"], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    assert "submitting 7 of 12 chunks (5 already done)" in r.stderr
    _same_bytes(ref, out)
