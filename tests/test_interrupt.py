"""Ctrl-C and SIGTERM take effect within about a second whatever a block costs; the
progress counts runs from inside a block (issue 28).

Before: a block's kernel call ran to its end in the main thread, so at omega = 1e9 (runs of
many seconds each, 22 runs in 212 s) two SIGINTs did nothing; the bar counted blocks.  Now
the blocks compute in a thread of their own, the main thread waits in short steps, and on an
interrupt it sets the stop flag of the sweep's ``_jit.Control``, which the kernels read every
few thousand loop passes (``local.run_blocks``)."""

import os
import re
import signal
import subprocess
import sys
import threading
import time

import h5py
import numpy as np
import pytest

from cornerbif import config, engine
from cornerbif._jit import Control, KernelStopped

HERE = os.path.dirname(__file__)
ROOT = os.path.dirname(HERE)
FIG06A = os.path.join(ROOT, "configs", "fig06a.toml")
FIG19A = os.path.join(ROOT, "configs", "fig19a.toml")
FIG15B = os.path.join(ROOT, "configs", "fig15b.toml")   # map2d, a kappa sweep
# one run at omega = 1e9 crosses about 1e9 obstacle pieces before it escapes: many seconds
# (benchmarks/estimate_time.py), far longer than the latency asked for
SLOW = ["--set", "system.omega=1e9", "--set", "sweep.kappa.num=2", "--set", "initial.count=1"]
TINY = ["--set", "sweep.kappa.num=2", "--set", "initial.count=1", "--set", "run.transient=4",
        "--set", "run.record=4"]
# seconds from the signal to the exit; the kernels stop within milliseconds (measured:
# benchmarks/interrupt_latency.py), the rest is the file's close and the interpreter's exit on
# a shared machine
LATENCY = 3.0


def _cli(args, **kw):
    # SIGINT as a terminal delivers it (a runner started without job control may hand its
    # children SIGINT ignored, which Python then keeps)
    return subprocess.Popen([sys.executable, "-m", "cornerbif.cli", *args], cwd=ROOT,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
                            **kw)


def _warm(tmp_path):
    """The flow kernel compiled into numba's cache (a cold compile is not interruptible)."""
    p = _cli(["sweep", FIG06A, "-o", str(tmp_path / "warm.h5"), "--no-progress", *TINY])
    out, err = p.communicate(timeout=600)
    assert p.returncode == 0, err


def _interrupt_slow(tmp_path, sig):
    out = tmp_path / "slow.h5"
    p = _cli(["sweep", FIG06A, "-o", str(out), "--progress", *SLOW])
    # the progress line is written as the blocks start (after the estimate); the kernel runs
    # a second later
    line = ""
    while not line.startswith("sweep "):
        line = p.stderr.readline()
        assert line, p.communicate()
    time.sleep(1.0)
    t0 = time.monotonic()
    p.send_signal(sig)
    _, err = p.communicate(timeout=60)
    return time.monotonic() - t0, p.returncode, err, out


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupt_ends_a_long_kernel_call_at_once(tmp_path, sig):
    """SIGINT (Ctrl-C) and SIGTERM during a kernel call of many seconds (omega = 1e9, one run
    per block) end the sweep within LATENCY seconds with exit 130, the partial file kept and
    no point of the cut block marked done (it was discarded, never written).  Before: the
    signal waited for the block's end (212 s for 22 runs)."""
    _warm(tmp_path)
    latency, rc, err, out = _interrupt_slow(tmp_path, sig)
    assert rc == 130, err
    assert latency < LATENCY, (latency, err)
    assert "interrupted" in err and "--resume" in err and "Traceback" not in err
    with h5py.File(str(out) + ".partial", "r") as f:
        assert not f["done"][...].any()


def test_interrupted_sweep_resumes_bitwise(tmp_path):
    """A sweep interrupted inside a block (SIGINT while a kernel runs; omega = 1e7: runs of a
    fraction of a second, one grid point a block) then completed by --resume writes the same
    bytes as an uninterrupted sweep: the cut block was discarded and recomputed whole."""
    _warm(tmp_path)
    args = ["--set", "system.omega=1e7", "--set", "sweep.kappa.num=6", "--set",
            "initial.count=2", "--block-points", "1", "--no-progress"]
    ref, out = tmp_path / "ref.h5", tmp_path / "out.h5"
    p = _cli(["sweep", FIG06A, "-o", str(ref), *args])
    assert p.wait(timeout=600) == 0, p.stderr.read()
    p = _cli(["sweep", FIG06A, "-o", str(out), *args])
    time.sleep(2.5)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    if p.returncode == 0:
        pytest.skip("the sweep finished before the interrupt (a fast machine)")
    assert p.returncode == 130, err
    p = _cli(["sweep", FIG06A, "-o", str(out), *args, "--resume"])
    _, err = p.communicate(timeout=600)
    assert p.returncode == 0, err
    with h5py.File(ref, "r") as a, h5py.File(out, "r") as b:
        names = []
        a.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        for n in names:
            assert np.array_equal(a[n][...], b[n][...], equal_nan=a[n].dtype.kind == "f"), n


def _stopped_within(scene, seconds=0.5):
    """Run ``engine.compute_block`` on the scene's first grid point under a Control in a thread,
    stop it after ``seconds`` and return (seconds from the stop to the thread's end, what the
    thread raised)."""
    control = Control()
    ints = engine.with_control(scene, engine.int_settings(scene), control)
    blk = tuple(slice(0, 1) for _ in scene.shape)
    box = {}

    def go():
        try:
            engine.compute_block(scene, blk, None, ints)
        except BaseException as e:  # noqa: BLE001 - the test reads it
            box["error"] = e
    th = threading.Thread(target=go)
    th.start()
    time.sleep(seconds)
    assert th.is_alive(), "the block finished before the stop: make it slower"
    t0 = time.monotonic()
    control.stop()
    th.join(30)
    return time.monotonic() - t0, box.get("error")


@pytest.mark.parametrize("path,sets,axis", [
    (FIG06A, ["system.omega=1e9", "sweep.kappa.num=1", "initial.count=1"], "kappa"),
    (FIG19A, ["sweep.omega0={values=[1e8]}", "initial.count=1"], "omega0"),
    (FIG15B, ["sweep.kappa.num=1", "initial.count=2", "run.transient=4000000000"], "kappa"),
])
def test_each_model_kernel_stops_on_the_flag(path, sets, axis):
    """The flow, two-particle and map2d kernels read the control's stop flag while a run goes
    on (every POLL_EVERY loop passes, every POLL_STEPS map steps) and return within a fraction
    of a second; the model's ``run_items`` then raises KernelStopped, so nothing half-computed
    is analysed or written.  The runs here take many seconds each (flow and two_particle:
    about 1e9 obstacle pieces or sections per run; map2d: 4e9 steps at 4e8 a second)."""
    # the kernel compiled first, on a quick scene (a compile is not what is timed here)
    quick = config.load(path, [f"sweep.{axis}.num=1", "initial.count=1", "run.transient=2",
                               "run.record=2"])
    keep = Control()            # alive while its address is in use
    engine.compute_block(quick, (slice(0, 1),), None,
                         engine.with_control(quick, engine.int_settings(quick), keep))
    scene = config.load(path, sets)
    latency, err = _stopped_within(scene)
    assert isinstance(err, KernelStopped), err
    assert latency < 1.0, latency


@pytest.mark.parametrize("path,sets", [
    (FIG06A, ["sweep.kappa.num=3", "initial.count=2", "run.transient=20", "run.record=20"]),
    (FIG19A, ["sweep.omega0.num=3", "initial.count=2", "run.transient=20", "run.record=20"]),
    (FIG15B, ["sweep.kappa.num=3", "initial.count=2", "run.transient=20", "run.record=20"]),
])
def test_a_control_changes_no_result(path, sets):
    """Under a control that is never stopped a block is bitwise the block without one, and
    the control counts every run of it (runs done: grid points x starts)."""
    scene = config.load(path, sets)
    blk = tuple(slice(0, n) for n in scene.shape)
    plain = engine.compute_block(scene, blk)
    control = Control()
    ints = engine.with_control(scene, engine.int_settings(scene), control)
    watched = engine.compute_block(scene, blk, None, ints)
    assert control.done >= 3 * 2
    for k in plain:
        assert np.array_equal(plain[k], watched[k], equal_nan=plain[k].dtype.kind == "f"), k


def test_runs_are_counted_while_a_block_computes():
    """The kernels count finished runs into the control while their block computes, so a
    one-block sweep shows progress before the block ends (runs of a few tenths of a second at
    omega = 1e7 with k = 1, one block of 8 runs on one thread)."""
    import numba
    scene = config.load(FIG06A, ["system.omega=1e7", "sweep.kappa.num=4", "initial.count=2"])
    control = Control()
    ints = engine.with_control(scene, engine.int_settings(scene), control)
    blk = (slice(0, 4),)
    seen = set()
    th = threading.Thread(target=lambda: (numba.set_num_threads(1),
                                          engine.compute_block(scene, blk, None, ints)))
    th.start()
    while th.is_alive():
        seen.add(control.done)
        time.sleep(0.01)
    assert control.done == 8
    assert seen & set(range(1, 8)), seen


def test_progress_shows_runs_rate_and_time_left():
    """The bar counts runs, with their rate and the time left once a run has finished, and
    the estimate before (``local.Progress``)."""
    import io as _io

    from cornerbif.local import Progress
    scene = config.load(FIG06A, ["sweep.kappa.num=5", "initial.count=2"])
    s = _io.StringIO()
    bar = Progress(scene, 10, 0, estimate=30.0, stream=s)
    assert "0/10 runs" in s.getvalue() and "estimate is 30.0 s" in s.getvalue()
    bar.start -= 2.0
    bar.update(4, force=True)
    assert re.search(r"4/10 runs \(40 %\), (1\.9\d*|2) runs/s, about 3\.\d s left", s.getvalue())
    bar.update(10)
    bar.close()
    assert s.getvalue().splitlines()[-1].startswith("sweep fig06a: 10/10 runs (100 %)")


def test_dask_driver_answers_an_interrupt_at_once(tmp_path):
    """With ``--scheduler local:2`` the driver ends within LATENCY seconds of SIGINT with exit
    130: its own workers are killed (their kernels are not watched, and the cluster's close
    waited about 4 s for them, benchmarks/interrupt_latency.py), the partial file kept."""
    pytest.importorskip("distributed")
    _warm(tmp_path)
    out = tmp_path / "dask.h5"
    p = _cli(["sweep", FIG06A, "-o", str(out), "--progress", "--scheduler", "local:2",
              "--set", "system.omega=1e7"])
    line = ""
    while not line.startswith("sweep "):
        line = p.stderr.readline()
        assert line, p.communicate()
    time.sleep(1.0)
    t0 = time.monotonic()
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 130, err
    assert time.monotonic() - t0 < LATENCY, err
    assert os.path.exists(str(out) + ".partial")
