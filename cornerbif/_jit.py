"""The one jit policy of the package (STYLE example 1).

Every kernel imports its decorators from here: ``cache=True`` so a second
process starts without compiling, ``error_model="numpy"`` so a division by
zero gives inf/nan instead of raising inside a kernel, and no fastmath at all
(NaN marks "no point" in every output array, and the event location relies on
IEEE rounding).
"""

import numba
from llvmlite import ir
from numba.core import types
from numba.extending import intrinsic

jit = numba.njit(cache=True, error_model="numpy", fastmath=False, nogil=True)


def pjit(fn):
    """Parallel kernel: ``prange`` over independent items only."""
    return numba.njit(cache=True, error_model="numpy", fastmath=False, parallel=True, nogil=True)(fn)


def jit_inline(fn):
    """A small function of the hot path inlined into its callers at numba's IR level:
    arguments such as the parameter tuples are then not copied at every call."""
    return numba.njit(cache=True, error_model="numpy", fastmath=False, nogil=True,
                      inline="always")(fn)


def cache_is_cold(dispatcher) -> bool:
    """Whether numba's on-disk cache holds nothing for this kernel yet, so that its first call
    compiles (tens of seconds for the event loops).  False when it cannot tell."""
    import os
    try:
        return not os.path.exists(dispatcher._cache._cache_file._index_path)
    except Exception:        # numba's cache internals moved: say nothing
        return False



@intrinsic
def load_f64(typingctx, address, i):
    """The float64 at ``address + 8 i`` (a read through a row's ``ctypes.data``).

    Lets a parameter tuple carry a reference to its packed row (a cam profile's table,
    models/obstacle.py) without the reference counting of an array argument; the caller
    keeps the row alive while the tuple is in use."""
    sig = types.float64(types.uintp, types.intp)

    def codegen(context, builder, signature, args):
        ptr = builder.inttoptr(args[0], ir.DoubleType().as_pointer())
        return builder.load(builder.gep(ptr, [args[1]]))
    return sig, codegen
