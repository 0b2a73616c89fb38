"""The jit policy's helpers (cornerbif._jit)."""

import importlib
import sys

from cornerbif._jit import cache_is_cold


def test_cache_is_cold_until_the_first_compile(tmp_path, monkeypatch):
    """``cornerbif sweep`` announces a cold numba cache (the event loops then compile for tens
    of seconds): a cached kernel is cold before its first call and warm after it; an object
    without numba's cache internals reads as warm (nothing is said)."""
    (tmp_path / "tiny_kernel.py").write_text(
        "import numba\n\n@numba.njit(cache=True)\ndef twice(x):\n    return 2.0 * x\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    mod = importlib.import_module("tiny_kernel")
    try:
        assert cache_is_cold(mod.twice)
        assert mod.twice(1.5) == 3.0
        assert not cache_is_cold(mod.twice)
    finally:
        sys.modules.pop("tiny_kernel", None)
    assert not cache_is_cold(object())
