"""The ``flow`` model's packed parameter vector as the kernels see it.

The declarations (``PARAMS``, ``OBSTACLES``) and ``pack`` are in ``models/flow/params.py``,
the slots of the packed vector in ``models/flow/slots.py``, pure Python, so that checking a
scene loads no numba;
they are re-exported here, where the kernels read them as ``P.KAPPA``, ``P.pack``, ...
beside the jitted views of a packed row below.
"""

from ..._jit import jit
from .params import *  # noqa: F403 (the declarations and slots, read by the kernels as P.*)


@jit
def as_tuple(p):
    """The packed parameter row of a built-in obstacle as a tuple of NPARAM floats.

    A tuple is a value: the kernels' many small calls pass it without the atomic
    reference counting every array argument costs (measured: a fifth of the flow
    kernel's time went to NRT_incref / NRT_decref).
    """
    return (p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9],
            p[10], p[11], p[12], p[13], p[14], p[15], p[16], p[17])


@jit
def as_tuple_profile(p):
    """A profile's packed row (NPARAM_PROFILE floats, a row of the kernel's input) as a
    tuple: its first PROFILE0 floats, then the row's address (``PROFILE_ROW``), through
    which the profile's table is read (``obstacle.profile_slot``).

    The row must be contiguous and outlive the tuple: the kernels pass a row of their
    ``params`` argument (``flow.run_batch_profile``, which checks the layout).  Python
    code calls the obstacle functions with the row itself, never with this tuple."""
    return (p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9],
            p[10], p[11], p[12], p[13], p[14], p[15], p[16], p[17], p[18], p[19],
            p[20], p.ctypes.data)
