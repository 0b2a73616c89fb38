"""The first process waits for a kernel that the second process of a compile beside has begun
(``_jit.compiling_beside``), instead of compiling it a second time beside it; the second
process says which kernels it has begun and finished.  The markers are files, so the tests
write and read them as the two processes do, and a sleeping process stands for the second."""

import os
import subprocess
import sys
import threading
import time

import numpy as np
import pytest

from cornerbif import _jit


def _double(k0, k1, x, out):
    for k in range(k0, k1):
        out[k] = 2.0 * x[k]


def _kernel():
    """A fresh ItemKernel (nothing compiled in this process: its first call compiles or loads)."""
    return _jit.items_kernel(_double)


def _marker(folder, stage):
    return os.path.join(folder, f"{__name__}._double.{stage}")


@pytest.fixture
def sleeper():
    child = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    yield child
    child.kill()
    child.wait()


@pytest.fixture(autouse=True)
def _no_compile_beside_left():
    yield
    _jit.compiling_beside(None)


def test_a_kernel_the_second_process_has_begun_is_awaited_until_it_is_done(tmp_path, sleeper):
    folder = str(tmp_path)
    open(_marker(folder, "begun"), "w").close()
    _jit.compiling_beside(folder, sleeper)
    done_at = []

    def finish():
        time.sleep(1.0)
        done_at.append(time.monotonic())
        open(_marker(folder, "done"), "w").close()

    writer = threading.Thread(target=finish)
    writer.start()
    x, out = np.arange(4.0), np.zeros(4)
    _kernel()(x, out)
    returned = time.monotonic()
    writer.join()
    assert done_at and returned >= done_at[0]      # it returned only after "done"
    np.testing.assert_array_equal(out, 2.0 * x)


def test_a_kernel_not_begun_there_is_not_awaited(tmp_path, sleeper):
    _jit.compiling_beside(str(tmp_path), sleeper)
    started = time.monotonic()
    x, out = np.arange(3.0), np.zeros(3)
    _kernel()(x, out)
    # nothing to wait for: it compiles or loads here (the deadline only catches a hang)
    assert time.monotonic() - started < 30
    np.testing.assert_array_equal(out, 2.0 * x)


def test_no_wait_for_a_second_process_that_ended(tmp_path):
    """A second process that died (or was stopped) before finishing is not awaited."""
    folder = str(tmp_path)
    open(_marker(folder, "begun"), "w").close()
    ended = subprocess.Popen([sys.executable, "-c", "pass"])
    ended.wait()
    _jit.compiling_beside(folder, ended)
    x, out = np.arange(2.0), np.zeros(2)
    _kernel()(x, out)
    np.testing.assert_array_equal(out, 2.0 * x)


def test_the_second_process_says_begun_and_done(tmp_path):
    folder = str(tmp_path)
    _jit.compiling_beside(folder, report=True)
    seen = []
    k = _kernel()
    real = k._run

    def run(*args):
        seen.append((os.path.exists(_marker(folder, "begun")), os.path.exists(_marker(folder, "done"))))
        return real(*args)

    k._run = run
    k(np.arange(2.0), np.zeros(2))
    assert seen == [(True, False)]                  # begun before its first call, not done
    assert os.path.exists(_marker(folder, "done"))  # done after it
    k(np.arange(2.0), np.zeros(2))                  # compiled: no marker work again
    assert len(seen) == 2


def test_the_command_leaves_no_folder_behind(tmp_path, monkeypatch):
    """``engine.compiling_aside`` removes its folder and ends the compile beside."""
    from cornerbif import config, engine
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path / "cache"))
    monkeypatch.setattr(engine, "cold_compiles", lambda scene, what: [("the flow kernel", 1.0)])
    monkeypatch.setattr(os, "cpu_count", lambda: 2)
    monkeypatch.setenv("CORNERBIF_COMPILE_BESIDE", "1")
    scene = config.load(os.path.join(os.path.dirname(__file__), "..", "..", "configs", "fig06a.toml"))
    with engine.compiling_aside(scene) as child:
        assert child is not None
        folder = _jit._BESIDE["folder"]
        assert os.path.isdir(folder)
    assert not os.path.exists(folder)
    assert _jit._BESIDE == {}
    assert child.poll() is not None
