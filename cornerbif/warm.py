"""``cornerbif warm``: compile ahead of time what a first run would compile.

Each model declares tiny scenes (``Model.warmups``, each a ``model.Warmup``) that go through the
commands a user runs (``sweep``, ``continue``), so they compile exactly what a user's first run
compiles, with the same signatures, into numba's cache.  The warm-ups of one group run in
order in one process (they share kernels); groups run side by side in child processes,
``jobs`` at a time (numba compiles one function at a time in a process: a second core halves
the wait for ``--all``).  Nothing is written but numba's cache and files in a temporary folder
that is removed.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import tempfile
import time

from . import config, engine, registry
from .errors import SweepInterrupted
from .model import Warmup

# what an interrupted warm says (exit 130): its sweeps' files were temporary, so there is no
# partial file to resume (the sweep's own message would name one in a folder already
# removed); each kernel that finished compiling is in numba's cache
INTERRUPTED = ("interrupted; warm keeps no file (its warm-up sweeps ran in a temporary folder, "
               "now removed), but every kernel that finished compiling stays in numba's "
               "cache: run cornerbif warm again to compile the rest")


def groups(models) -> dict:
    """The warm-up groups of ``models`` (names): group name -> list of ``Warmup``, in the
    models' order."""
    out: dict = {}
    for name in models:
        for w in registry.get(name).warmups:
            out.setdefault(w.group, []).append(w)
    return out


def expected_seconds(warmups) -> float:
    """The compile seconds the models declare for these warm-ups (``Model.compiles``, measured
    by benchmarks/compile_time.py), cached or not: the longest groups start first."""
    total = 0.0
    for w in warmups:
        scene = config.loads(w.scene, source=f"<warm-up {w.label!r}>")
        what = ("continuation",) if w.command == "continue" else ("sweep",)
        compiles = getattr(scene.spec, "compiles", None)
        total += sum(s for _, s, _ in compiles(scene, what)) if compiles else 0.0
    return total


def run_warmup(w: Warmup, folder: str, echo) -> float:
    """Run one warm-up here (its scene through ``sweep`` or ``continue`` into ``folder``),
    each first compile announced through ``echo`` (``engine.announce_compiles``); the
    seconds it took."""
    from . import continuation_run, sweep  # start-up: loads numba, at first use
    scene = config.loads(w.scene, source=f"<warm-up {w.label!r}>")
    out = os.path.join(folder, f"{scene.name}.h5")
    t0 = time.perf_counter()
    if w.command == "continue":
        engine.announce_compiles(scene, echo, ("continuation",))
        continuation_run.run_to_file(scene, out, overwrite=True, log=lambda m: None)
    else:
        engine.announce_compiles(scene, echo, ("sweep",))
        sweep.run_sweep(scene, out, overwrite=True, progress=False)
    return time.perf_counter() - t0


def run_group(name: str, warmups, echo) -> float:
    """The warm-ups of one group, in order, in this process; the seconds they took.  An
    interrupt (Ctrl-C, or a sweep's ``SweepInterrupted``, whose message names a partial file
    in the temporary folder removed here) is ``SweepInterrupted`` saying what is true of a
    warm-up (``INTERRUPTED``)."""
    total = 0.0
    try:
        with tempfile.TemporaryDirectory(prefix="cornerbif-warm-") as folder:
            for w in warmups:
                seconds = run_warmup(w, folder, lambda m, w=w: echo(f"[{name}] {m}"))
                echo(f"[{name}] {w.label}: ready ({seconds:.1f} s)")
                total += seconds
    except (KeyboardInterrupt, SweepInterrupted):
        raise SweepInterrupted(INTERRUPTED) from None
    return total


def warm(models, jobs: int, echo) -> float:
    """Warm every group of ``models``: the groups in child processes (``python -m
    cornerbif.warm GROUP``, with this environment: the same numba cache), ``jobs`` at a time;
    one group with ``jobs`` = 1 runs here.  Returns the seconds it took.  Raises
    ``RuntimeError`` naming the groups that failed; an interrupt (here, or of a child: its
    exit 130) stops every child and is ``SweepInterrupted`` (``INTERRUPTED``)."""
    todo = groups(models)
    t0 = time.perf_counter()
    if len(todo) == 1 and jobs == 1:
        (name, ws), = todo.items()
        run_group(name, ws, echo)
        return time.perf_counter() - t0
    pending = sorted(todo, key=lambda g: -expected_seconds(todo[g]))
    running: dict = {}
    failed = []
    try:
        while pending or running:
            while pending and len(running) < jobs:
                name = pending.pop(0)
                running[name] = subprocess.Popen(
                    [sys.executable, "-m", "cornerbif.warm", *models, "--group", name])
            time.sleep(0.05)
            for name, proc in list(running.items()):
                if proc.poll() is not None:
                    del running[name]
                    if proc.returncode in CHILD_INTERRUPTED:
                        raise SweepInterrupted(INTERRUPTED)
                    if proc.returncode != 0:
                        failed.append(name)
    except KeyboardInterrupt:
        raise SweepInterrupted(INTERRUPTED) from None
    finally:
        for proc in running.values():
            proc.terminate()
            proc.wait()
    if failed:
        raise RuntimeError(f"the warm-up of {', '.join(failed)} failed (its message above)")
    return time.perf_counter() - t0


def _child(argv) -> int:
    """``python -m cornerbif.warm MODEL ... --group GROUP``: one group of ``warm``."""
    models, group = argv[:-2], argv[-1]
    echo = lambda m: print(m, file=sys.stderr, flush=True)     # noqa: E731
    try:
        run_group(group, groups(models)[group], echo)
    except (KeyboardInterrupt, SweepInterrupted):
        return 130                    # the parent says so (``INTERRUPTED``), once
    return 0


# a child's exit status when interrupted: its own 130, or killed by SIGINT or SIGTERM
CHILD_INTERRUPTED = (130, -signal.SIGINT, -signal.SIGTERM)


if __name__ == "__main__":
    sys.exit(_child(sys.argv[1:]))
