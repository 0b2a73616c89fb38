"""``stability.sort_nan_last`` (the Lyapunov spectrum's sort, in place of numba's quicksort)
against numpy's sort, NaN last, on random short arrays with NaNs and ties."""

import numpy as np

from cornerbif.stability import sort_nan_last


def test_sort_nan_last_equals_numpy_sort():
    rng = np.random.default_rng(1)
    for _ in range(2000):
        a = rng.normal(size=rng.integers(1, 7))
        a[rng.random(a.size) < 0.3] = np.nan
        if rng.random() < 0.2:
            a = np.round(a)
        b = a.copy()
        sort_nan_last(b)
        assert np.array_equal(b, np.sort(a), equal_nan=True), a
