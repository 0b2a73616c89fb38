"""Ctrl-C and SIGTERM end a sweep whatever a block costs; what was finished is written and
kept, whatever signal comes while it is written; a failed write stops the kernels at once; the
progress counts runs from inside a block.

The blocks compute in a thread of their own while the main thread waits in short steps; on
an interrupt it sets the stop flag of the sweep's ``_jit.Control``, which the kernels read every
few thousand loop passes (``local.run_blocks``).  These tests assert that mechanism (a kernel
returns before finishing its runs, ``KernelStopped``, no done mark for a discarded block, the
runs counted); how fast it is lives in benchmarks/interrupt_latency.py.  Timeouts here are hang
guards only."""

import errno
import os
import signal
import subprocess
import sys
import threading
import time

import h5py
import numpy as np
import pytest

from cornerbif import config, engine, io, local, outputs
from cornerbif._jit import Control, KernelStopped
from cornerbif.errors import WriteFailed

HERE = os.path.dirname(__file__)
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(HERE)))
FIG06A = os.path.join(ROOT, "configs", "fig06a.toml")
FIG19A = os.path.join(ROOT, "configs", "fig19a.toml")
FIG15B = os.path.join(ROOT, "configs", "fig15b.toml")   # map2d, a kappa sweep
TWO_STOPS = os.path.join(ROOT, "configs", "two_stops.toml")   # linear, two contacts
# one run at omega = 1e9 crosses about 1e9 obstacle pieces before it escapes: many seconds
# (benchmarks/estimate_time.py); at omega = 1.999 (Fig. 6(a)) a run takes milliseconds.  Two
# blocks of one run each: the first quick, the second slow
FAST_THEN_SLOW = ["sweep.kappa={values=[0.0]}", "sweep.omega={values=[1.999, 1e9]}",
                  "initial.count=1"]
TINY = ["--set", "sweep.kappa.num=2", "--set", "initial.count=1", "--set", "run.transient=4",
        "--set", "run.record=4"]
# a hang guard: every wait here ends in well under a second when the mechanism works
GUARD = 60.0


def _sets(sets):
    return [x for s in sets for x in ("--set", s)]


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


def _done_marks(partial):
    """The done mask of a sweep's partial file while its sweep writes it (read in
    single-writer/multiple-reader mode), or None while it cannot be read yet."""
    try:
        with h5py.File(partial, "r", swmr=True, locking=False) as f:
            return f["done"][...]
    except Exception:  # noqa: BLE001 - not there yet, or being set up: read it again later
        return None


def _wait_for_a_done_block(p, partial):
    """Wait (GUARD) until the sweep ``p`` has marked a block done: the next one is computing."""
    end = time.monotonic() + GUARD
    while time.monotonic() < end:
        done = _done_marks(partial)
        if done is not None and done.any():
            return
        assert p.poll() is None, p.communicate()
        time.sleep(0.02)
    pytest.fail("no block was marked done")


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_an_interrupt_ends_a_long_kernel_call(tmp_path, sig):
    """SIGINT (Ctrl-C) and SIGTERM while a block's kernel runs a run of many seconds (omega =
    1e9; sent once the quick block before it is marked done) end the sweep with exit 130
    within the hang guard, the finished block kept and the cut one discarded (no done mark):
    its kernel returned before finishing its run.  Before: the signal waited for the block's
    end (212 s for 22 runs)."""
    _warm(tmp_path)
    out = tmp_path / "slow.h5"
    p = _cli(["sweep", FIG06A, "-o", str(out), "--no-progress", "--block-points", "1",
              *_sets(FAST_THEN_SLOW)])
    _wait_for_a_done_block(p, str(out) + ".partial")
    p.send_signal(sig)
    _, err = p.communicate(timeout=GUARD)
    assert p.returncode == 130, err
    assert "interrupted" in err and "--resume" in err and "Traceback" not in err
    with h5py.File(str(out) + ".partial", "r") as f:
        assert f["done"][...].tolist() == [[True, False]]


@pytest.mark.slow
def test_interrupted_sweep_resumes_bitwise(tmp_path):
    """A sweep interrupted while its blocks compute (SIGINT once its quick first block is
    marked done; the next blocks' runs, at omega = 1e7, take a fraction of a second each),
    then completed by --resume, writes the same bytes as an uninterrupted sweep: the cut block
    was discarded and recomputed whole."""
    _warm(tmp_path)
    args = ["--no-progress", "--block-points", "1",
            *_sets(["sweep.kappa={values=[0.0]}", "sweep.omega={values=[1.999, 1e7, 1.1e7]}",
                    "initial.count=2"])]
    ref, out = tmp_path / "ref.h5", tmp_path / "out.h5"
    p = _cli(["sweep", FIG06A, "-o", str(ref), *args])
    assert p.wait(timeout=600) == 0, p.stderr.read()
    p = _cli(["sweep", FIG06A, "-o", str(out), *args])
    _wait_for_a_done_block(p, str(out) + ".partial")
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=GUARD)
    assert p.returncode == 130, err
    with h5py.File(str(out) + ".partial", "r") as f:
        assert 1 <= f["done"][...].sum() < 3
    p = _cli(["sweep", FIG06A, "-o", str(out), *args, "--resume"])
    _, err = p.communicate(timeout=600)
    assert p.returncode == 0, err
    with h5py.File(ref, "r") as a, h5py.File(out, "r") as b:
        names = []
        a.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        for n in names:
            assert np.array_equal(a[n][...], b[n][...], equal_nan=a[n].dtype.kind == "f"), n


def _compiled(path, axis):
    """The model's kernels compiled (a compile is not what these tests are about)."""
    quick = config.load(path, [f"sweep.{axis}.num=1", "initial.count=1", "run.transient=2",
                               "run.record=2"])
    keep = Control()            # alive while its address is in use
    engine.compute_block(quick, (slice(0, 1),), None,
                         engine.with_control(quick, engine.int_settings(quick), keep))


def _compute_in_thread(scene, blk, control):
    """``engine.compute_block`` of ``blk`` under ``control`` in a thread; (thread, box): the
    box receives the block or what the thread raised."""
    ints = engine.with_control(scene, engine.int_settings(scene), control)
    box = {}

    def go():
        try:
            box["block"] = engine.compute_block(scene, blk, None, ints)
        except BaseException as e:  # noqa: BLE001 - the test reads it
            box["error"] = e
    th = threading.Thread(target=go)
    th.start()
    return th, box


@pytest.mark.parametrize("path,sets,axis", [
    (FIG06A, ["system.omega=1e9", "sweep.kappa.num=1", "initial.count=1"], "kappa"),
    (FIG19A, ["sweep.omega0={values=[1e8]}", "initial.count=1"], "omega0"),
    (FIG15B, ["sweep.kappa.num=1", "initial.count=2", "run.transient=4000000000"], "kappa"),
    (TWO_STOPS, ['system.contact.R.obstacle="rectified_sine"', "system.contact.R.beta=1e-3",
                 "system.contact.R.omega=1e12", 'sweep."forcing.0.Omega".num=1',
                 "initial.count=2"], '"forcing.0.Omega"'),
])
def test_each_model_kernel_stops_on_the_flag(path, sets, axis):
    """The flow, two-particle and map2d kernels read the control's stop flag while a run goes
    on (every POLL_EVERY loop passes, every POLL_STEPS map steps): stopped once the block has
    used half a second of CPU (packing and drawing its starts take milliseconds: its kernel
    is running), the kernel returns before finishing any run (none is counted done) and the
    model's ``run_items`` raises KernelStopped, so nothing half-computed is analysed or
    written.  Every run here takes many seconds (flow and two_particle: about 1e9 obstacle
    pieces or sections a run; map2d: 4e9 steps at 4e8 a second; linear: a stop on an obstacle
    of omega = 1e12, about 3e11 pieces within each chunk of its flight, the flag read every
    STOP_POLL pieces)."""
    _compiled(path, axis)
    scene = config.load(path, sets)
    control = Control()
    cpu = time.process_time()
    th, box = _compute_in_thread(scene, tuple(slice(0, 1) for _ in scene.shape), control)
    end = time.monotonic() + GUARD
    while time.process_time() - cpu < 0.5 and th.is_alive() and time.monotonic() < end:
        time.sleep(0.01)
    assert th.is_alive(), box
    control.stop()
    th.join(GUARD)
    assert not th.is_alive()
    assert isinstance(box.get("error"), KernelStopped), box
    assert control.done == 0


def test_runs_are_counted_while_a_block_computes():
    """The kernels count finished runs into the control while their block computes: in one
    block of a quick run (omega = 1.999) and a slow one (omega = 1e9, many seconds), the quick
    run is counted while the slow one still runs; stopped then, the block raises KernelStopped
    and the stopped run is not counted (1 of 2 runs done)."""
    _compiled(FIG06A, "kappa")
    scene = config.load(FIG06A, FAST_THEN_SLOW)
    control = Control()
    th, box = _compute_in_thread(scene, (slice(0, 1), slice(0, 2)), control)
    end = time.monotonic() + GUARD
    while control.done < 1 and th.is_alive() and time.monotonic() < end:
        time.sleep(0.005)
    assert control.done == 1 and th.is_alive(), box
    control.stop()
    th.join(GUARD)
    assert isinstance(box.get("error"), KernelStopped), box
    assert control.done == 1


STAB = {"flow": 'output.keep=["impacts", "stability"]',
        "map2d": 'output.keep=["section", "stability"]'}


@pytest.mark.parametrize("path,sets", [
    (FIG06A, ["sweep.kappa.num=3", "initial.count=2", "run.transient=20", "run.record=20"]),
    (FIG06A, ["sweep.kappa.num=3", "initial.count=2", "run.transient=20", "run.record=20",
              STAB["flow"]]),
    (FIG19A, ["sweep.omega0.num=3", "initial.count=2", "run.transient=20", "run.record=20"]),
    (FIG19A, ["sweep.omega0.num=3", "initial.count=2", "run.transient=20", "run.record=20",
              STAB["flow"]]),
    (FIG15B, ["sweep.kappa.num=3", "initial.count=2", "run.transient=20", "run.record=20"]),
    (FIG15B, ["sweep.kappa.num=3", "initial.count=2", "run.transient=20", "run.record=20",
              STAB["map2d"]]),
])
def test_a_control_changes_no_result(path, sets):
    """Under a control that is never stopped a block (its stability too, where kept) is
    bitwise the block without one, and the control counts every run of it (3 grid points x 2
    starts)."""
    scene = config.load(path, sets)
    blk = tuple(slice(0, n) for n in scene.shape)
    plain = engine.compute_block(scene, blk)
    control = Control()
    ints = engine.with_control(scene, engine.int_settings(scene), control)
    watched = engine.compute_block(scene, blk, None, ints)
    assert control.done == 3 * 2
    for k in plain:
        assert np.array_equal(plain[k], watched[k], equal_nan=plain[k].dtype.kind == "f"), k


# the stability pass of each model: (module holding the name it calls, the batch kernel's name)
STABILITY_KERNELS = {"flow": ("cornerbif.models.flow.model", "batch_stability"),
                     "two_particle": ("cornerbif.models.two_particle.tangent",
                                      "batch_two_particle_stability"),
                     "map2d": ("cornerbif.models.map2d.model", "batch_map_stability")}


@pytest.mark.parametrize("path,sets", [
    (FIG06A, ["sweep.kappa.num=2", "initial.count=2", "run.record=40", STAB["flow"]]),
    (FIG19A, ["sweep.omega0.num=2", "initial.count=2", "run.record=40", STAB["flow"]]),
    (FIG15B, ["sweep.kappa.num=2", "initial.count=2", "run.record=40", STAB["map2d"]]),
])
def test_the_stability_pass_reads_the_stop_flag(path, sets, monkeypatch):
    """The stability and Lyapunov kernels run under the block's control (its address reaches
    them) and read its stop flag before each run's rows (a record of 10^5 events with
    stability kept costs up to seconds a block: benchmarks/interrupt_latency.py --stability).
    With the flag set once the block's kernel has finished, as its stability pass begins,
    every run's rows are left unwritten and the block raises KernelStopped; unstopped, every
    row is written."""
    import importlib
    scene = config.load(path, sets)
    module, name = STABILITY_KERNELS[scene.model]
    module = importlib.import_module(module)
    real = getattr(module, name)
    seen = []

    def stability_pass(*args):
        *arrays, address = args
        status = arrays[-1]           # each run's Lyapunov status: written by every row
        status[...] = 99
        if stop_here:
            control.stop()
        real(*args)
        seen.append((address, status.copy()))
    monkeypatch.setattr(module, name, stability_pass)
    blk = tuple(slice(0, n) for n in scene.shape)
    for stop_here in (False, True):
        control = Control()
        ints = engine.with_control(scene, engine.int_settings(scene), control)
        if stop_here:
            with pytest.raises(KernelStopped):
                engine.compute_block(scene, blk, None, ints)
        else:
            engine.compute_block(scene, blk, None, ints)
        address, status = seen[-1]
        assert address == control.address
        assert (status == 99).all() if stop_here else (status != 99).all()


def test_progress_shows_runs_rate_and_time_left():
    """The bar counts runs, with their rate and the time left once a run has finished, and
    the estimate before (``local.Progress``, on a clock the test sets: 4 runs in 2 s is 2
    runs a second, and 6 runs left take 3 s)."""
    import io as _io

    from cornerbif.local import Progress
    scene = config.load(FIG06A, ["sweep.kappa.num=5", "initial.count=2"])
    s = _io.StringIO()
    now = [100.0]
    bar = Progress(scene, 10, 0, estimate=30.0, stream=s, clock=lambda: now[0])
    assert "0/10 runs" in s.getvalue() and "estimate is 30.0 s" in s.getvalue()
    now[0] += 2.0
    bar.update(4, force=True)
    assert s.getvalue().splitlines()[-1] == ("sweep fig06a: 4/10 runs (40 %), 2 runs/s, about "
                                             "3.0 s left")
    now[0] += 1.0
    bar.update(10)
    bar.close()
    assert s.getvalue().splitlines()[-1] == "sweep fig06a: 10/10 runs (100 %), 3.0 s"


def _main_thread_waits_in(code):
    """Whether the main thread is inside the function of ``code`` and blocked in a wait of
    ``threading`` there."""
    frame = sys._current_frames().get(threading.main_thread().ident)
    if frame is None or os.path.basename(frame.f_code.co_filename) != "threading.py":
        return False
    while frame is not None:
        if frame.f_code is code:
            return True
        frame = frame.f_back
    return False


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_while_the_last_block_is_written_keeps_it(tmp_path, monkeypatch, sig):
    """A signal (a real SIGINT or SIGTERM) that comes while the writer writes the last block,
    the main thread waiting for it in ``BlockWriter.close``, waits for the write (half a
    second here: a slow disk): the block, computed before the signal, is written and marked
    done, and then the interrupt is raised.  Before: ``close``'s
    ``Thread.join`` was cut short, the caller closed the file under the running writer, and
    the block was lost (done stayed 0)."""
    scene = config.load(FIG06A, ["sweep.kappa.num=2", "initial.count=1", "run.transient=4",
                                 "run.record=4"])
    partial = str(tmp_path / "out.h5.partial")
    f = io.open_partial(partial, scene)
    real = io.write_pending

    def slow_write(f, pending):
        end = time.monotonic() + GUARD
        while not _main_thread_waits_in(local.BlockWriter.close.__code__):
            assert time.monotonic() < end, "the main thread never waited for the writer"
            time.sleep(0.005)
        os.kill(os.getpid(), sig)
        time.sleep(0.5)
        real(f, pending)
    monkeypatch.setattr(io, "write_pending", slow_write)
    handlers = outputs.install_signal_handlers()     # SIGTERM as an interrupt, as a command
    try:
        with pytest.raises(outputs.Terminated if sig == signal.SIGTERM else KeyboardInterrupt):
            local.run_blocks(scene, f)
        assert f["done"][...].all()
    finally:
        outputs.restore_signal_handlers(handlers)
        f.close()
    with h5py.File(partial, "r") as g:
        assert g["done"][...].all()


def test_a_failed_write_stops_the_kernels_at_once(tmp_path, monkeypatch):
    """A write that fails (here ENOSPC, as on a full disk) while the next block computes stops
    that block's kernel (KernelStopped: its run at omega = 1e9 would take many seconds) and
    the write's error goes on at once, not when the block would have ended."""
    _compiled(FIG06A, "kappa")
    scene = config.load(FIG06A, FAST_THEN_SLOW)
    f = io.open_partial(str(tmp_path / "out.h5.partial"), scene)
    slow_started = threading.Event()
    ended = []
    real = engine.compute_block

    def compute(scene, blk, carry=None, ints=None):
        if blk[1].start == 1:
            slow_started.set()
        try:
            block = real(scene, blk, carry, ints)
        except BaseException as e:
            ended.append(e)
            raise
        ended.append("finished")
        return block

    def full_disk(f, pending):
        assert slow_started.wait(GUARD)
        raise WriteFailed(f"writing {f.filename} failed ({os.strerror(errno.ENOSPC)})")
    monkeypatch.setattr(engine, "compute_block", compute)
    monkeypatch.setattr(io, "write_pending", full_disk)
    try:
        with pytest.raises(WriteFailed, match="No space left"):
            local.run_blocks(scene, f, block_points=1)
    finally:
        f.close()
    assert ended == ["finished", ended[1]] and isinstance(ended[1], KernelStopped), ended


LEFT_BEHIND = r"""
import atexit, os, signal, sys, threading, time
from cornerbif import cli, engine


def deaf(scene, blk, carry=None, ints=None):
    # a block that never reads the stop flag (as numba compiling a kernel on its first call,
    # which nothing cuts short): it outlives the stop grace by far
    os.kill(os.getpid(), int(os.environ["SIGNAL"]))
    end = time.monotonic() + 120
    while time.monotonic() < end:
        time.sleep(0.01)


def at_shutdown():
    if any(t.name == "cornerbif-work" and t.is_alive() for t in threading.enumerate()):
        print("the interpreter shut down beside a running block", file=sys.stderr, flush=True)


engine.compute_block = deaf
atexit.register(at_shutdown)
sys.argv = ["cornerbif", *sys.argv[1:]]
cli.main()
"""


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_a_block_still_busy_after_the_stop_grace_does_not_hold_the_exit(tmp_path, sig):
    """A block that does not stop (numba compiling a kernel cannot be cut short) is left
    behind after STOP_GRACE: the sweep says what was kept and exits 130 at once, without a
    traceback, and the interpreter never shuts down beside the running block (a shutdown hook
    registered before the sweep, which would say so, never runs: the process ends before
    it).  Before, the interpreter tore its modules, numba's threads and LLVM down under it."""
    out = tmp_path / "out.h5"
    p = subprocess.Popen([sys.executable, "-c", LEFT_BEHIND, "sweep", FIG06A, "-o", str(out),
                          "--no-progress", *TINY], cwd=ROOT, stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True,
                         env=dict(os.environ, SIGNAL=str(int(sig))),
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    _, err = p.communicate(timeout=GUARD)
    assert p.returncode == 130, err
    assert "interrupted; finished points are kept" in err, err
    assert "Traceback" not in err and "shut down beside" not in err, err


@pytest.mark.slow
def test_dask_driver_answers_an_interrupt_at_once(tmp_path):
    """With ``--scheduler local:2`` the driver answers SIGINT with exit 130 and the partial
    file kept, without waiting for the chunk its workers compute (8 runs at omega = 1e9, many
    seconds each: it would outlast the hang guard; the workers warm up on the first grid
    point, at omega = 1.999): it kills its own workers (their kernels are not watched; the
    cluster's close would wait for them).  The signal is sent once the workers compute (their
    CPU time grows after the progress line)."""
    pytest.importorskip("distributed")
    psutil = pytest.importorskip("psutil")
    _warm(tmp_path)
    out = tmp_path / "dask.h5"
    p = _cli(["sweep", FIG06A, "-o", str(out), "--progress", "--scheduler", "local:2",
              *_sets(FAST_THEN_SLOW[:2] + ["initial.count=8"])])
    line = ""
    while not line.startswith("sweep "):
        line = p.stderr.readline()
        assert line, p.communicate()

    def workers_cpu():
        total = 0.0
        for c in psutil.Process(p.pid).children(recursive=True):
            try:
                t = c.cpu_times()
                total += t.user + t.system
            except psutil.Error:
                pass
        return total
    cpu = workers_cpu()
    end = time.monotonic() + GUARD
    while workers_cpu() - cpu < 0.5:
        assert time.monotonic() < end and p.poll() is None, p.communicate()
        time.sleep(0.05)
    workers = psutil.Process(p.pid).children(recursive=True)
    p.send_signal(signal.SIGINT)
    _, err = p.communicate(timeout=GUARD)
    assert p.returncode == 130, err
    assert os.path.exists(str(out) + ".partial")
    gone, alive = psutil.wait_procs(workers, timeout=GUARD)
    assert not alive
