"""Sweeps on Dask distributed: the same blocks, computed on a cluster.

``cornerbif sweep SCENE.toml --scheduler ADDRESS`` (or ``local:N`` for a local
cluster of N worker processes) runs the sweep's blocks ("chunks") on Dask
workers.  The unit of work is ``engine.compute_block`` - the very function the
local backend calls - so both backends write the same bytes.  Workers do no
I/O: each returns its block's arrays and this process, the driver, is the only
writer of the HDF5 file, with the same done-marks, lock and ``--resume`` as the
local backend (``sweep.run_sweep`` owns the file either way).

Workers
    One Dask thread per worker process is the intended setting (``local:N`` does
    it).  The scene travels once per worker in a worker plugin (``SceneSetup``),
    which also warms the JIT on one grid point before the worker takes work.  The
    numba threads of a worker are ``--threads`` if given, else the environment
    variable ``CORNERBIF_NUMBA_THREADS`` if set on the worker, else its cores
    divided by its Dask threads (``local:N``: the machine's cores // N), so numba
    threads x Dask threads never exceed the cores.  numba's thread count is
    per calling thread, so it is set inside each task; a process-wide lock lets
    only one thread of a worker process run a kernel at a time, so a worker
    started with several Dask threads never calls a parallel kernel from two
    threads at once (numba's default ``workqueue`` layer is not thread-safe).

Faults
    A chunk whose worker dies is re-run by Dask on another worker; after
    ``distributed.scheduler.allowed-failures`` deaths (Dask's default 3) it ends in
    ``KilledWorker``.  A chunk that fails (that way, or by raising) is reported with
    its error while the other chunks complete; its grid points stay not-done, the
    failures are listed in the partial file's attribute ``failed_chunks``, and the
    command exits non-zero telling to ``--resume``.  A killed driver loses nothing
    already written, and ``--resume`` submits only the chunks not marked done.

Followed scenes (``sweep.follow = "up" | "down"``) are a chain: each slab starts
from the previous slab's final states.  They run on the cluster in order, one
chunk in flight, the carry sent with each task; the cluster then brings the
numba threads of one worker, not more workers.

Test-only hook: ``CORNERBIF_TEST_CRASH=DIR`` in a worker's environment makes a
chunk misbehave when ``DIR`` holds a control file for it: ``crash-<i>`` holding
``once`` (or ``always``) makes chunk ``i`` (its position in ``engine.blocks``)
compute and then ``os._exit`` on its first (every) attempt, each attempt
appended to ``DIR/attempts-<i>``; ``hold`` holding ``h`` makes every chunk
``i >= h`` wait while that file exists.  Never set it outside the test suite.
"""

from __future__ import annotations

import os
import sys
import threading
import time
import uuid

from . import io
from .engine import block_carry, blocks, compute_block
from .errors import Fault, SweepError
from .estimate import estimate_seconds
from .local import Progress, block_runs, carry_from_file

try:  # the plugin's base class; the module imports without Dask (the CLI says how to install)
    from distributed import WorkerPlugin as _PluginBase
except ImportError:  # pragma: no cover - exercised only without the extra
    _PluginBase = object

INSTALL_HINT = 'pip install "cornerbif[dask]"'
THREADS_ENV = "CORNERBIF_NUMBA_THREADS"
CRASH_ENV = "CORNERBIF_TEST_CRASH"      # test-only, see the module docstring

_LOCK = threading.Lock()                 # one kernel call at a time per worker process
_SCENES = {}                             # scene hash -> (scene, requested numba threads)


class ChunksFailed(Fault):
    """Some chunks failed on the cluster; the rest are written. ``failures`` lists them
    (a fault after work began: exit 1)."""

    def __init__(self, msg, failures):
        super().__init__(msg)
        self.failures = failures


# ------------------------------------------------------------------ the scheduler option
def parse_scheduler(spec: str):
    """``"local:N"`` -> ("local", N); anything else -> ("address", spec)."""
    spec = (spec or "").strip()
    if not spec:
        raise SweepError("--scheduler: empty; give a Dask scheduler address "
                         "(tcp://host:8786) or local:N")
    if spec == "local" or spec.startswith("local:"):
        n = spec[6:] or str(_cores())
        if not n.isdigit() or int(n) < 1:
            raise SweepError(f"--scheduler {spec!r}: N in local:N must be a whole number >= 1 "
                             f"(got {n!r})")
        if int(n) > _cores():
            raise SweepError(f"--scheduler {spec!r}: local:N starts N worker processes on this "
                             f"machine, which has {_cores()} cores; N is at most {_cores()} "
                             "(more workers than cores only share them)")
        return "local", int(n)
    return "address", spec


def require_dask():
    """Import Dask distributed or say how to install it."""
    try:
        import distributed  # noqa: F401 (optional: cornerbif[dask])
    except ImportError:
        raise SweepError("--scheduler needs Dask distributed, which is not installed; "
                         f"install it with: {INSTALL_HINT}") from None


def _cores():
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


# ------------------------------------------------------------------ on the workers
class SceneSetup(_PluginBase):
    """Worker plugin: holds the scene on every worker (also ones that join or restart
    later) and warms the JIT on the scene's first grid point before any chunk runs."""

    def __init__(self, scene, numba_threads=None):
        self.scene = scene
        self.numba_threads = numba_threads
        self.name = f"cornerbif-scene-{scene.hash[:16]}"

    def setup(self, worker):
        _SCENES[self.scene.hash] = (self.scene, self.numba_threads)
        first = tuple(slice(0, 1) for _ in self.scene.shape)
        with _LOCK:
            _set_numba_threads(self.numba_threads, worker.state.nthreads)
            compute_block(self.scene, first)

    def teardown(self, worker):
        _SCENES.pop(self.scene.hash, None)


def _numba_threads(requested, dask_threads):
    import numba  # start-up: loads numba
    if requested:
        n = int(requested)
    elif os.environ.get(THREADS_ENV, "").strip():
        n = int(os.environ[THREADS_ENV])
    else:
        n = _cores() // max(1, dask_threads)
    return max(1, min(n, numba.config.NUMBA_NUM_THREADS))


def _set_numba_threads(requested, dask_threads):
    import numba  # start-up: loads numba
    n = _numba_threads(requested, dask_threads)
    numba.set_num_threads(n)      # per calling thread in numba: set in the task's thread
    return n


def compute_chunk(scene_hash, i, blk, carry=None):
    """The task: chunk ``i`` (slab ``blk``) of the scene held by ``SceneSetup``.

    Returns (block dict as ``engine.compute_block``, seconds spent computing, numba
    threads used).  No I/O (apart from the test-only hook)."""
    from distributed import get_worker  # optional: cornerbif[dask]
    try:
        scene, requested = _SCENES[scene_hash]
    except KeyError:
        raise RuntimeError(f"scene {scene_hash[:12]} is not set up on this worker "
                           "(its SceneSetup plugin did not run)") from None
    _test_hold(i)
    with _LOCK:
        n = _set_numba_threads(requested, get_worker().state.nthreads)
        t0 = time.perf_counter()
        block = compute_block(scene, blk, carry)
        secs = time.perf_counter() - t0
    _test_crash(i)
    return block, secs, n


def _test_hold(i):
    d = os.environ.get(CRASH_ENV)
    if not d:
        return
    hold = os.path.join(d, "hold")
    try:
        with open(hold) as fh:
            h = int(fh.read().strip())
    except (OSError, ValueError):
        return
    deadline = time.monotonic() + 120
    while i >= h and os.path.exists(hold) and time.monotonic() < deadline:
        time.sleep(0.05)


def _test_crash(i):
    d = os.environ.get(CRASH_ENV)
    if not d:
        return
    try:
        with open(os.path.join(d, f"crash-{i}")) as fh:
            mode = fh.read().strip()
    except OSError:
        return
    log = os.path.join(d, f"attempts-{i}")
    first = not os.path.exists(log)
    with open(log, "a") as fh:
        fh.write(f"{os.getpid()}\n")
    if mode == "always" or (mode == "once" and first):
        os._exit(1)


# ------------------------------------------------------------------ the driver
def describe(scene, blk):
    """A chunk in the scene's terms, e.g. ``kappa[3:4]`` or ``omega[2:3], kappa[0:64]``."""
    return ", ".join(f"{a.name}[{s.start}:{s.stop}]" for a, s in zip(scene.axes, blk)) or "(point)"


def _log(msg):
    print(f"cornerbif: {msg}", file=sys.stderr, flush=True)


def _connect(kind, arg):
    import dask  # optional: cornerbif[dask]
    from distributed import Client, LocalCluster  # optional: cornerbif[dask]
    if kind == "local":
        # exactly one task per worker thread at a time: a task is only counted against a
        # worker that dies while it is running it, not while it waits in its queue
        with dask.config.set({"distributed.scheduler.worker-saturation": 1.0}):
            cluster = LocalCluster(n_workers=arg, threads_per_worker=1, processes=True,
                                   dashboard_address=None, silence_logs=50)
        return Client(cluster), cluster
    try:
        return Client(arg, timeout="30s"), None
    except (OSError, TimeoutError, ValueError) as e:
        raise SweepError(f"--scheduler {arg}: cannot reach a Dask scheduler there ({e}); "
                         "give a running scheduler's address (tcp://host:8786) or local:N") \
            from None


def _kill_workers(cluster):
    """End the worker processes of a local cluster at once (after Ctrl-C)."""
    for nanny in list(getattr(cluster, "workers", {}).values()):
        try:
            nanny.auto_restart = False
            pid = nanny.process.pid
            if pid:
                os.kill(pid, 9)
        except (AttributeError, OSError):   # gone already, or not a local process
            pass


def run_blocks_dask(scene, f, scheduler, progress=False, block_points=None, numba_threads=None,
                    max_in_flight=None, stats=None):
    """Compute the unfinished blocks of ``f`` on a Dask cluster and write them here.

    ``max_in_flight``: chunks submitted and not yet written (default twice the
    cluster's Dask threads, at least 2; 1 for a followed scene).  ``stats``: a dict
    filled with what happened (chunks submitted, failures, the workers' compute
    seconds and the driver's write seconds per chunk).
    """
    require_dask()
    from distributed import as_completed  # optional: cornerbif[dask]
    kind, arg = parse_scheduler(scheduler)
    every = blocks(scene, block_points)
    todo = [(i, every[i]) for i in io.unfinished(every, f)]
    stats = {} if stats is None else stats
    stats.update(chunks=len(every), submitted=0, failed=[], compute_seconds=[],
                 write_seconds=[])
    if not todo:
        return stats
    if kind == "local" and not numba_threads:
        numba_threads = max(1, _cores() // arg)
    client, cluster = _connect(kind, arg)
    plugin = SceneSetup(scene, numba_threads)
    token = uuid.uuid4().hex[:8]
    bar = None
    interrupted = False
    try:
        nthreads = client.nthreads()
        if not nthreads:
            client.wait_for_workers(1, timeout=120)
            nthreads = client.nthreads()
        dask_threads = sum(nthreads.values())
        client.register_plugin(plugin)            # sets up and warms every worker
        followed = scene.follow != "none"
        window = 1 if followed else max(2, int(max_in_flight or 2 * dask_threads))
        _log(f"dask scheduler {client.scheduler.address}: {len(nthreads)} workers, "
             f"{dask_threads} Dask threads; submitting {len(todo)} of {len(every)} chunks "
             f"({len(every) - len(todo)} already done), at most {window} in flight"
             + ("; followed scene: one chunk at a time, in order" if followed else ""))
        if progress:
            # runs, counted per finished chunk (the workers' kernels are not watched)
            total = sum(block_runs(scene, b) for b in every)
            bar = Progress(scene, total, total - sum(block_runs(scene, b) for _, b in todo),
                           estimate_seconds(scene, max(1, dask_threads * (numba_threads or 1))))

        def submit(i, blk, carry=None):
            stats["submitted"] += 1
            return client.submit(compute_chunk, scene.hash, i, blk, carry, pure=False,
                                 key=f"cornerbif-chunk-{i}-{scene.hash[:8]}-{token}")

        def written(blk, result):
            block, secs, _ = result
            t0 = time.perf_counter()
            io.write_block(f, blk, block)
            stats["write_seconds"].append(time.perf_counter() - t0)
            stats["compute_seconds"].append(secs)
            if bar is not None:
                bar.update(bar.done + block_runs(scene, blk))
            return block

        failed = stats["failed"]
        if followed:
            carry = carry_from_file(scene, f, every, todo[0][1])
            for i, blk in todo:
                fut = submit(i, blk, carry)
                try:
                    result = fut.result()
                except Exception as e:  # noqa: BLE001 - any task error ends the chain here
                    failed.append((i, blk, f"{type(e).__name__}: {e}"))
                    break
                carry = block_carry(scene, written(blk, result))
                del fut, result
        else:
            pending = iter(todo)
            meta = {}
            ac = as_completed()
            for i, blk in pending:
                fut = submit(i, blk)
                meta[fut.key] = (i, blk)
                ac.add(fut)
                if len(meta) >= window:
                    break
            for fut in ac:
                i, blk = meta.pop(fut.key)
                try:
                    result = fut.result()
                except Exception as e:  # noqa: BLE001 - recorded, the rest goes on
                    failed.append((i, blk, f"{type(e).__name__}: {e}"))
                else:
                    written(blk, result)
                    del result
                fut.release()
                nxt = next(pending, None)
                if nxt is not None:
                    nf = submit(*nxt)
                    meta[nf.key] = nxt
                    ac.add(nf)
    except BaseException:
        interrupted = True          # Ctrl-C, SIGTERM, or an error of the driver's own
        raise
    finally:
        if bar is not None:
            bar.close()
        if interrupted and cluster is not None:
            # this process's own workers are ended now: their kernels would run their chunks
            # to the end, and the cluster's close wait for them (4 s and more after Ctrl-C)
            _kill_workers(cluster)
        else:
            try:
                client.unregister_worker_plugin(plugin.name)
            except Exception:  # noqa: BLE001 - the cluster may be gone; nothing to clean then
                pass
        client.close()
        if cluster is not None:
            cluster.close()
    if failed:
        lines = [f"  chunk {i} ({describe(scene, blk)}): {err.splitlines()[0] if err else ''}"
                 for i, blk, err in failed]
        not_run = ""
        if scene.follow != "none":
            left = len(todo) - stats["submitted"]
            not_run = f"; the followed chain stopped there ({left} later chunks not run)"
        raise ChunksFailed(
            f"{len(failed)} of {len(todo)} chunks failed on the cluster{not_run}:\n"
            + "\n".join(lines)
            + "\nevery other chunk is written; run the same command again with --resume to "
              "retry the missing chunks",
            [{"chunk": i, "block": [[s.start, s.stop] for s in blk], "error": err}
             for i, blk, err in failed])
    return stats

