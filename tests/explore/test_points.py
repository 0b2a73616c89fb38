"""The explorer's raster, read from the file a slab at a time (``points.raster``), against a
brute force written here: every point of the file read whole with h5py, each put into its
pixel by a Python loop over the points with the pixel's rule (the highest code of a labelled
colouring, the mean of a colour scale); and the click's nearest point against an argmin
over all points."""

from __future__ import annotations

import h5py
import numpy as np
import pytest
from explore_server import explore_extra_missing, small_file  # noqa: F401 (a fixture)

pytestmark = pytest.mark.skipif(explore_extra_missing() is not None,
                                reason=str(explore_extra_missing()))

W, H = 61, 37


def all_points(path, n_ic):
    """(x, y, run) of every finite impact height u of the file, read whole."""
    with h5py.File(path, "r") as f:
        u = f["impacts/u"][...]
        kappa = f["kappa"][...]
    k, ic, _ = np.nonzero(np.isfinite(u))
    return kappa[k], u[np.isfinite(u)], k * n_ic + ic


def brute_raster(x, y, c, xr, yr, labelled):
    """Each pixel's value by a loop over the points (the rule stated, not vectorised)."""
    (x0, x1), (y0, y1) = xr, yr
    cells = {}
    for xi, yi, ci in zip(x, y, c):
        if not (x0 <= xi <= x1 and y0 <= yi <= y1) or not np.isfinite(ci):
            continue
        i = min(int((xi - x0) / (x1 - x0) * W), W - 1)
        j = min(int((yi - y0) / (y1 - y0) * H), H - 1)
        cells.setdefault((j, i), []).append(float(ci))
    img = np.full((H, W), np.nan)
    for (j, i), vals in cells.items():
        img[j, i] = max(vals) if labelled else sum(vals) / len(vals)
    return img


@pytest.fixture(scope="module")
def diagram(small_file):  # noqa: F811
    from cornerbif.explorer.points import Diagram
    return Diagram(small_file, "impact_u")


@pytest.mark.parametrize("what", ["attractor", "period"])
@pytest.mark.parametrize("window", [None, ((-0.012, -0.004), (-0.01, 0.02))])
def test_the_raster_read_in_slabs_is_the_brute_force(diagram, small_file, what, window,  # noqa: F811
                                                     monkeypatch):
    from cornerbif import plot_style
    from cornerbif.explorer import points as P
    monkeypatch.setattr(plot_style, "RASTER_VALUES", 5000)     # many slabs: their joins tested
    x, y, run = all_points(small_file, diagram.n_ic)
    assert diagram.size == x.size > 50_000
    xr, yr = window or ((float(x.min()), float(x.max())), (float(y.min()), float(y.max())))
    col = diagram.colouring(what)
    c = P.codes(col, run)
    img = P.raster(diagram, col, xr, yr, W, H)
    want = brute_raster(x, y, c, xr, yr, col.layer is not None)
    assert np.array_equal(np.isnan(img), np.isnan(want))
    assert np.isfinite(img).sum() > 100
    np.testing.assert_allclose(img[np.isfinite(img)], want[np.isfinite(want)], rtol=1e-6)


def test_a_window_reads_only_its_rows(diagram, small_file):  # noqa: F811
    x, y, run = all_points(small_file, diagram.n_ic)
    xr = (-0.011, -0.0075)
    got = [np.concatenate(a) for a in zip(*diagram.chunks(xr))]
    inside = (x >= xr[0]) & (x <= xr[1])
    order = np.lexsort((y[inside], run[inside]))
    gorder = np.lexsort((got[1], got[2]))
    assert np.array_equal(got[2][gorder], run[inside][order])
    assert np.array_equal(got[1][gorder], y[inside][order])


def test_the_nearest_point_is_the_argmin_over_all_points(diagram, small_file):  # noqa: F811
    from cornerbif.explorer.points import nearest
    x, y, run = all_points(small_file, diagram.n_ic)
    xr, yr = (-0.015, -0.002), (-0.02, 0.03)
    rng = np.random.default_rng(3)
    for px, py in zip(rng.uniform(*xr, 5), rng.uniform(*yr, 5)):
        inside = (x >= xr[0]) & (x <= xr[1]) & (y >= yr[0]) & (y <= yr[1])
        d2 = ((x - px) / (xr[1] - xr[0])) ** 2 + ((y - py) / (yr[1] - yr[0])) ** 2
        d2[~inside] = np.inf
        i = int(np.argmin(d2))
        src, gx, gy, grun = nearest(px, py, xr, yr, [diagram, None])
        assert (src, gx, gy) == (0, x[i], y[i]) and grun == run[i]
