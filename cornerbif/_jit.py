"""The one jit policy of the package.

Every kernel imports its decorators from here: ``cache=True`` so a second
process starts without compiling, ``error_model="numpy"`` so a division by
zero gives inf/nan instead of raising inside a kernel, and no fastmath at all
(NaN marks "no point" in every output array, and the event location relies on
IEEE rounding).

What a first run waits for is compiling (benchmarks/compile_time.py), so the policy also keeps
that short, without costing the warm kernels anything (``benchmarks/ab.py``):

- ``jit`` and ``jit_inline`` functions are compiled for the kernels that call them, with no
  CPython or C wrapper (numba builds one per function and signature by default: for the
  parameter tuples' 34 floats that was about 60 % of a small function's compile).  A call
  from Python goes to a twin compiled with the wrapper on first use and cached beside it
  (``InnerDispatcher``), so tests and the orbit solvers call them as before;
- ``jit_inline`` asks LLVM to inline (``forceinline``: the ``alwaysinline`` attribute), not
  numba's IR inliner (``inline="always"``), which deep-copied the callee's IR at every call
  site: 35 % of the flow kernel's cold compile (benchmarks/README.md, "First compiles").
"""

import ctypes
import importlib
import os
import threading
import time
import types as pytypes
from concurrent.futures import ThreadPoolExecutor, wait

import numba
import numpy as np
from llvmlite import ir
from numba.core import types
from numba.core.registry import CPUDispatcher
from numba.extending import intrinsic

OPTIONS = dict(error_model="numpy", fastmath=False, nogil=True)


class InnerDispatcher(CPUDispatcher):
    """A jitted function compiled for its jitted callers only (no CPython wrapper).  Called
    from Python, it hands the call to ``python_entry``: a twin of the same function compiled
    with the wrapper, cached under the name ``<function>_py``."""

    @property
    def python_entry(self):
        twin = self.__dict__.get("_python_entry")
        if twin is None:
            f = self.py_func
            copy = pytypes.FunctionType(f.__code__, f.__globals__, f.__name__, f.__defaults__,
                                        f.__closure__)
            copy.__qualname__ = f.__qualname__ + "_py"
            copy.__module__ = f.__module__
            copy.__doc__ = f.__doc__
            twin = numba.njit(cache=True, **OPTIONS)(copy)
            self.__dict__["_python_entry"] = twin
        return twin

    def __call__(self, *args, **kws):
        return self.python_entry(*args, **kws)

    def get_call_template(self, args, kws):
        # one compile per argument types, not one more per constant a caller passes (numba
        # types a constant argument as a literal and compiles a specialisation for it: the
        # flow kernel compiled 17 such duplicates, 1 s of its first compile)
        return super().get_call_template(tuple(types.unliteral(a) for a in args),
                                         {k: types.unliteral(v) for k, v in kws.items()})


def _inner(fn, forceinline):
    if numba.config.DISABLE_JIT:        # NUMBA_DISABLE_JIT=1: plain Python, as numba.njit does
        return fn
    disp = InnerDispatcher(py_func=fn, locals={},
                           targetoptions=dict(OPTIONS, no_cpython_wrapper=True,
                                              no_cfunc_wrapper=True, forceinline=forceinline))
    disp.enable_caching()
    return disp


def jit(fn):
    """A function of the kernels (called from jitted code; from Python through its twin)."""
    # forceinline stated either way: numba passes it on to the callees a caller compiles
    return _inner(fn, False)


def jit_inline(fn):
    """A small function of the hot path that LLVM inlines into its callers (``forceinline``):
    arguments such as the parameter tuples are then not copied at every call."""
    return _inner(fn, True)


class ItemKernel:
    """A kernel over independent items, called from Python: ``fn(k0, k1, *args)`` handles items
    k0 <= k < k1 (a ``range``, each item writing only its own rows) and the call
    ``kernel(*args)`` runs all n of them, split into one contiguous range per numba thread
    of the calling thread (``numba.get_num_threads()``, which ``numba.set_num_threads``
    sets): the calling thread runs the first, the threads of ``_pool`` the others (the kernels
    release the GIL: ``nogil``).

    Why not numba's ``prange``: a ``parallel=True`` kernel compiles through numba's parfor
    passes and a gufunc of its own, which cost the flow kernel 2 s of its first compile
    (benchmarks/README.md, "First compiles"); the split here is the one ``prange`` made
    (equal contiguous ranges), so the results and the threads' work are the same.

    ``count(*args)`` gives n (default: the first argument's rows); ``_direct`` is the jitted
    range kernel, for a call on one thread."""

    def __init__(self, fn, count=None):
        self._direct = numba.njit(cache=True, **OPTIONS)(fn)
        self.count = count or first_rows
        self.__name__ = fn.__name__
        self.__qualname__ = fn.__qualname__
        self.__module__ = fn.__module__
        self.__doc__ = fn.__doc__
        self.__wrapped__ = fn

    @property
    def signatures(self):
        return self._direct.signatures

    def __call__(self, *args, **kws):
        if _BESIDE and not self._direct.signatures:      # a first call, with a compile beside
            _await_or_report(self)
            try:
                return self._run(*args, **kws)
            finally:
                _reported(self)
        return self._run(*args, **kws)

    def _run(self, *args, **kws):
        n = int(self.count(*args, **kws))
        threads = max(1, min(numba.get_num_threads(), n))
        if threads == 1:
            return self._direct(0, n, *args, **kws)
        bounds = [n * j // threads for j in range(threads + 1)]
        pool = _pool()
        runs = [pool.submit(self._direct, bounds[j], bounds[j + 1], *args, **kws)
                for j in range(1, threads)]
        try:
            self._direct(bounds[0], bounds[1], *args, **kws)     # the calling thread's range
        finally:
            wait(runs)                  # no thread left writing when this call returns
        for run in runs:
            run.result()
        return None


_POOL: dict = {}
_POOL_LOCK = threading.Lock()


def _pool() -> ThreadPoolExecutor:
    """The kernels' threads besides the calling one, started once per process (as numba's own
    workers are; threads started for each call cost 5 % of a two-thread sweep, measured with
    ``benchmarks/ab.py --speedup``): one fewer than numba may use.  A forked child, which
    inherits the pool but not its threads, starts its own."""
    with _POOL_LOCK:
        pool = _POOL.get(os.getpid())
        if pool is None:
            pool = _POOL[os.getpid()] = ThreadPoolExecutor(
                max(1, numba.config.NUMBA_NUM_THREADS - 1), thread_name_prefix="cornerbif-kernel")
        return pool


def first_rows(*args, **kws) -> int:
    """The items of an ``ItemKernel`` call by default: its first argument's rows."""
    return args[0].shape[0]


def items_kernel(fn=None, *, count=None):
    """Decorator of an ``ItemKernel`` (``fn(k0, k1, *args)``; ``count``: see there)."""
    if fn is None:
        return lambda f: items_kernel(f, count=count)
    if numba.config.DISABLE_JIT:
        def plain(*args, **kws):
            return fn(0, int((count or first_rows)(*args, **kws)), *args, **kws)
        plain.__wrapped__ = fn
        return plain
    return ItemKernel(fn, count)


def cache_is_cold(dispatcher) -> bool:
    """Whether this kernel's first call in this process compiles (tens of seconds for the
    event loops): nothing compiled here yet, and numba's on-disk cache holds no entry for it
    that is fresh (its index is dropped when the source file changed) and built for this
    machine.  An ``InnerDispatcher`` is cold when neither it nor its Python twin is cached
    (either means the kernels that call it were compiled).  False when it cannot tell."""
    if isinstance(dispatcher, InnerDispatcher):
        return _cold(dispatcher) and _cold(dispatcher.python_entry)
    if isinstance(dispatcher, ItemKernel):
        dispatcher = dispatcher._direct
    return _cold(dispatcher)


def _cold(dispatcher) -> bool:
    try:
        if dispatcher.signatures:
            return False
        index = dispatcher._cache._cache_file._load_index()
        magic = dispatcher.targetctx.codegen().magic_tuple()
        return not any(len(key) > 1 and key[1] == magic for key in index)
    except Exception:        # numba's cache internals moved: say nothing
        return False


# ------------------------------------------------------------------ compiling beside
# ``engine.compiling_aside`` runs a second process that compiles into numba's cache what this
# one will call.  That process says which kernels (``ItemKernel``s) it has begun and finished
# to compile, as empty files "<module.function>.begun" and ".done" in a folder of its own
# (``_BESIDE["report"]``).  This process (``_BESIDE["folder"]``, ``_BESIDE["child"]``), about to
# compile a kernel the other has begun, waits for it and loads it from the cache instead of
# compiling it a second time beside it.
_BESIDE: dict = {}


def compiling_beside(folder, child=None, report=False):
    """From now on, this process waits for (``report=False``: ``child`` is the second
    process) or reports to (``report=True``: this is the second process) the folder of a
    compile beside; ``compiling_beside(None)`` ends it."""
    _BESIDE.clear()
    if folder is not None:
        _BESIDE.update(report=folder) if report else _BESIDE.update(folder=folder, child=child)


def _marker(folder, kernel, stage):
    return os.path.join(folder, f"{kernel.__module__}.{kernel.__qualname__}.{stage}")


def _await_or_report(kernel):
    """Before the first call of ``kernel`` here (which compiles it): in the second process,
    say that it has begun (``_reported`` says when it is done); in the first, wait while the
    second compiles it (it has begun, is not done, and is still running)."""
    report = _BESIDE.get("report")
    if report is not None:
        open(_marker(report, kernel, "begun"), "w").close()
        return
    folder, child = _BESIDE["folder"], _BESIDE["child"]
    begun, done = _marker(folder, kernel, "begun"), _marker(folder, kernel, "done")
    while (os.path.exists(begun) and not os.path.exists(done)
           and (child is None or child.poll() is None)):
        time.sleep(0.01)


def _reported(kernel):
    """In the second process: say that ``kernel`` is compiled (and in numba's cache)."""
    report = _BESIDE.get("report")
    if report is not None:
        open(_marker(report, kernel, "done"), "w").close()


def compile_listed(functions):
    """Compile each ``(module.function, argument types)`` (as ``compile_plan.PLANS`` lists
    them; the types as numba prints them) into numba's cache, skipping what the cache holds."""
    names = dict(vars(types), bool=types.boolean)
    for name, args in functions:
        module, _, fn = name.rpartition(".")
        twin = fn.endswith("_py") and fn not in vars(importlib.import_module(f"{__package__}.{module}"))
        disp, = dispatchers(f"{module}.{fn.removesuffix('_py')}" if twin else name)
        if twin:
            disp = disp.python_entry           # a function called from Python: its twin
        sig = eval(args[:-1] + ",)", {"__builtins__": {}}, names)   # noqa: S307 - our own file
        if isinstance(disp, ItemKernel):
            if _BESIDE and not disp._direct.signatures:
                _await_or_report(disp)
            disp._direct.compile(sig)
            _reported(disp)
        else:
            disp.compile(sig)


def dispatchers(*names):
    """The jitted functions named ``module.function`` under the package (e.g.
    ``"models.flow.kernel.run_batch"``), for ``cache_is_cold``: imported when asked for."""
    out = []
    for name in names:
        module, _, fn = name.rpartition(".")
        out.append(getattr(importlib.import_module(f"{__package__}.{module}"), fn))
    return out


@intrinsic
def load_f64(typingctx, address, i):
    """The float64 at ``address + 8 i`` (a read through a row's ``ctypes.data``).

    Lets a parameter tuple carry a reference to its packed row (a cam profile's table,
    obstacles/dispatch.py) without the reference counting of an array argument; the caller
    keeps the row alive while the tuple is in use."""
    sig = types.float64(types.uintp, types.intp)

    def codegen(context, builder, signature, args):
        ptr = builder.inttoptr(args[0], ir.DoubleType().as_pointer())
        return builder.load(builder.gep(ptr, [args[1]]))
    return sig, codegen


# ------------------------------------------------------------------ a sweep's control
# The kernels of a sweep poll a small int64 array, the ``Control`` of their call, through its
# address in their integer settings (0: none, as for ``simulate`` and the Dask workers): the
# stop flag (``cornerbif.local`` sets it on Ctrl-C or SIGTERM; the kernels then return within
# a few thousand loop passes, and the block they were computing is discarded, never written;
# the stability kernels read it before each run's rows) and the number of runs finished (the
# progress bar reads it while a block computes).
C_STOP = 0          # nonzero: stop now
C_DONE = 1          # runs finished (added to by the kernels' threads, atomically; a run cut
                    # short by the stop flag is not: it did not finish)
C_SIZE = 2
POLL_EVERY = 4096   # passes of a run's event loop between two reads of the stop flag (a power
                    # of 2: a mask; a few microseconds to milliseconds of a run)
STOPPED = -2        # the status of a run cut short by the stop flag (never stored: its block
                    # is discarded)


@intrinsic
def load_i64_atomic(typingctx, address, i):
    """The int64 at ``address + 8 i``, read by an atomic (monotonic) load: LLVM neither
    hoists it out of a loop nor merges two of them, so a flag another thread sets is seen."""
    sig = types.int64(types.int64, types.int64)

    def codegen(context, builder, signature, args):
        ptr = builder.inttoptr(args[0], ir.IntType(64).as_pointer())
        return builder.load_atomic(builder.gep(ptr, [args[1]]), "monotonic", 8)
    return sig, codegen


@intrinsic
def add_i64_atomic(typingctx, address, i, value):
    """Add ``value`` to the int64 at ``address + 8 i`` atomically (monotonic); the old value."""
    sig = types.int64(types.int64, types.int64, types.int64)

    def codegen(context, builder, signature, args):
        ptr = builder.inttoptr(args[0], ir.IntType(64).as_pointer())
        return builder.atomic_rmw("add", builder.gep(ptr, [args[1]]), args[2], "monotonic")
    return sig, codegen


@jit_inline
def stop_requested(control):
    """Whether the control at address ``control`` (0: none) asks the kernels to stop."""
    return control != 0 and load_i64_atomic(control, C_STOP) != 0


@jit_inline
def count_done(control):
    """One more run finished under the control at ``control`` (0: none, nothing counted)."""
    if control != 0:
        add_i64_atomic(control, C_DONE, 1)


class Control:
    """The control of a sweep's kernel calls (see above): its ``address`` travels in the
    kernels' integer settings (``engine.with_control``); ``stop`` asks every kernel call
    under it to return at once; ``done`` is the runs finished since ``reset``."""

    def __init__(self):
        self.array = np.zeros(C_SIZE, np.int64)

    @property
    def address(self) -> int:
        return int(self.array.ctypes.data)

    def stop(self):
        self.array[C_STOP] = 1

    @property
    def stopped(self) -> bool:
        return bool(self.array[C_STOP])

    @property
    def done(self) -> int:
        return int(self.array[C_DONE])

    def reset(self):
        """Count runs from 0 again (a new block); the stop flag stays."""
        self.array[C_DONE] = 0


class KernelStopped(Exception):
    """A kernel call cut short by its control's stop flag: its outputs are incomplete."""


def raise_if_stopped(address):
    """After a kernel call: raise ``KernelStopped`` when the control at ``address`` (0:
    none) was told to stop, so that no half-computed output goes on to be analysed."""
    if address and ctypes.c_int64.from_address(int(address) + 8 * C_STOP).value:
        raise KernelStopped()
