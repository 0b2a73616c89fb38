"""Output arrays filled by numba's threads instead of numpy's one.

A block's outputs are tens of MB prefilled with NaN ("no event"); ``np.full`` fills them in
one thread, a serial few per cent of a sweep on two threads.  ``full`` is ``np.full`` with
the filling spread over the threads (the values are the same).
"""

import numpy as np

from .._jit import items_kernel

SPAN = 1 << 16      # elements one thread fills at a time


@items_kernel(count=lambda flat, value: (flat.shape[0] + SPAN - 1) // SPAN)
def _fill(k0, k1, flat, value):
    n = flat.shape[0]
    for c in range(k0, k1):
        flat[c * SPAN:min(n, (c + 1) * SPAN)] = value


def full(shape, value, dtype=np.float64) -> np.ndarray:
    """``np.full(shape, value, dtype)``, filled in parallel."""
    a = np.empty(shape, dtype)
    _fill(a.reshape(-1), a.dtype.type(value))
    return a
