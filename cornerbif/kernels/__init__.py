"""Numba kernels: pure functions of arrays and scalars, no I/O (docs/architecture.md)."""
