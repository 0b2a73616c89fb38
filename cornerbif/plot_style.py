"""The look of every figure: one style, marker sizes from the point count, robust y-ranges.

What is logic here (the y-window, the marker size) is tested without pixels
(tests/test_plot_style.py); the style is matplotlib's rcParams, which a user replaces by
their own style sheet (``[plot] style`` or ``cornerbif plot --style``).
"""

from __future__ import annotations

import contextlib
import os

import numpy as np

# one style for every figure: serif text in the paper's sizes, thin frames, vector fonts
# embedded as text (Type 42) so that a journal's PDF checks accept them, rasterised point
# clouds at 300 dpi inside vector output
STYLE = {
    "font.family": "serif",
    "mathtext.fontset": "dejavuserif",
    "font.size": 8,
    "axes.titlesize": 9,
    "axes.labelsize": 9,
    "legend.fontsize": 7,
    "xtick.labelsize": 8,
    "ytick.labelsize": 8,
    "axes.linewidth": 0.6,
    "xtick.major.width": 0.6,
    "ytick.major.width": 0.6,
    "lines.linewidth": 1.0,
    "savefig.dpi": 300,
    "pdf.fonttype": 42,
    "ps.fonttype": 42,
    "svg.fonttype": "none",
}
# the categorical colours are plot_attractors.PALETTE (keyed by the orbit's label); the
# magnitudes' colour map is this one
MAGNITUDE_CMAP = "viridis"

# a share of the finite values at each end that may fall outside the y-window
TAIL = 1e-3
# the window drops the tails only when the full range is this many times the tails' window
SQUEEZE = 2.0
# values beyond which the tails are read from a strided sample (robust_range)
SAMPLE = 1_000_000


@contextlib.contextmanager
def style(user=None):
    """The project's style, then the user's style sheet (a name matplotlib knows or a
    .mplstyle path) over it; a sheet that is neither raises ValueError (``check_style``)."""
    import matplotlib.pyplot as plt
    problem = check_style(user)
    if problem:
        raise ValueError(problem)
    sheets = [STYLE] + ([user] if user else [])
    with plt.style.context(sheets):
        yield


def check_style(user) -> str | None:
    """A problem with a user's style sheet, or None: a name of matplotlib's or a file."""
    if user is None:
        return None
    import matplotlib.style as mstyle
    if not isinstance(user, str) or not user:
        return f"style: {user!r} must be a style name or the path of a .mplstyle file"
    if user in mstyle.available or os.path.isfile(user):
        return None
    return (f"style: {user!r} is neither a file nor one of matplotlib's styles "
            f"({', '.join(sorted(mstyle.available)[:6])}, ...)")


def robust_range(values, tail=TAIL, squeeze=SQUEEZE, pad=0.04):
    """The y-window of a diagram: (low, high, outside).

    The full range of the finite values, unless it is more than ``squeeze`` times the
    range of all but a share ``tail`` at each end (a few outlying points would press the
    structure into a thin band): then that central range.  Padded by ``pad`` of its width
    on each side; ``outside`` counts the values the window leaves out (said on the
    figure).  None when no value is finite (infinities are not).  Past SAMPLE values the
    tails are read from a random sample of SAMPLE positions (a fixed seed: the same window
    for the same file; not a stride, which could fall in step with a cycle's period and miss
    a branch), the count outside is exact: memory stays a few bytes per value.
    """
    v = np.asarray(values, dtype=float).ravel()
    fin = np.isfinite(v)
    n = int(np.count_nonzero(fin))
    if n == 0:
        return None
    lo = float(np.min(v, where=fin, initial=np.inf))
    hi = float(np.max(v, where=fin, initial=-np.inf))
    if n >= 1.0 / tail:
        if v.size > SAMPLE:
            sample = v[np.random.default_rng(0).integers(0, v.size, SAMPLE)]
            sample = sample[np.isfinite(sample)]
        else:
            sample = v[fin]
        if sample.size < 1.0 / tail:
            sample = v[fin]
        qlo, qhi = (float(x) for x in np.quantile(sample, [tail, 1.0 - tail]))
        if qhi > qlo and hi - lo > squeeze * (qhi - qlo):
            lo, hi = qlo, qhi
    span = hi - lo if hi > lo else max(abs(hi), 1.0) * 1e-3
    lo, hi = lo - pad * span, hi + pad * span
    with np.errstate(invalid="ignore"):
        outside = int(np.count_nonzero(fin & ((v < lo) | (v > hi))))
    return lo, hi, outside


def marker_size(n_points, lo=0.5, hi=3.0):
    """Marker size (points) of a point cloud of ``n_points``: large for a few thousand
    points, shrinking as the fourth root of the count, never below ``lo`` (at 300 dpi a
    marker of 0.5 pt still covers two pixels)."""
    if n_points <= 0:
        return hi
    return float(np.clip(2.4 / (n_points / 2e4) ** 0.25, lo, hi))


# where an inset may go, in axes fractions (x, y, width, height): the four corners
INSET_CORNERS = {"lower left": (0.07, 0.08), "upper left": (0.07, 0.56),
                 "lower right": (0.59, 0.08), "upper right": (0.59, 0.56)}


def emptiest_corner(ax, x, y, size=(0.34, 0.36), avoid=("upper right",)):
    """The inset rectangle [x0, y0, w, h] (axes fractions) over the fewest of the data
    points (x, y), among the axes' corners (``avoid``: corners kept for a legend); the
    first in ``INSET_CORNERS``' order on a tie.  The axes' limits must be final."""
    pts = ax.transLimits.transform(np.column_stack([np.ravel(x), np.ravel(y)]))
    ok = np.isfinite(pts).all(axis=1)
    pts = pts[ok]
    best, count = None, None
    for name, (x0, y0) in INSET_CORNERS.items():
        if name in avoid:
            continue
        inside = ((pts[:, 0] >= x0) & (pts[:, 0] <= x0 + size[0])
                  & (pts[:, 1] >= y0) & (pts[:, 1] <= y0 + size[1]))
        n = int(inside.sum())
        if count is None or n < count:
            best, count = name, n
    x0, y0 = INSET_CORNERS[best]
    return [x0, y0, size[0], size[1]]


# point clouds of more values than this are drawn as one image (``raster_runs``)
RASTER_POINTS = 1_000_000
RASTER_VALUES = 1 << 18   # values put into the image at a time


def raster_runs(ax, x, y, layer, colors, xlim, ylim, ms, dpi):
    """A diagram's point cloud as one RGBA image at ``dpi``, for millions of points.

    ``x`` (n,) the swept values, ``y`` (n, starts, record) the drawn values, ``layer``
    (n, starts) each run's layer (an index into ``colors``, -1: not drawn); a higher layer
    is drawn over a lower one.  Each value sets its pixel, then the image is grown to a
    marker of ``ms`` points.  The rows go in slabs of RASTER_VALUES: besides the drawn
    values themselves, memory is the image's (an int16 and 4 floats per pixel) and one
    slab's, whatever the number of points.  Sets the axes' limits to ``xlim``, ``ylim``."""
    from matplotlib.colors import to_rgba
    fig = ax.figure
    pos = ax.get_position()
    W = max(16, int(round(pos.width * fig.get_figwidth() * dpi)))
    H = max(16, int(round(pos.height * fig.get_figheight() * dpi)))
    (x0, x1), (y0, y1) = xlim, ylim
    top = np.full((H, W), -1, np.int16)
    rows = max(1, RASTER_VALUES // max(1, int(np.prod(y.shape[1:]))))
    for a in range(0, y.shape[0], rows):
        ys = y[a:a + rows]
        lay = np.broadcast_to(layer[a:a + rows, :, None], ys.shape)
        xs = np.broadcast_to(x[a:a + rows, None, None], ys.shape)
        ok = (lay >= 0) & np.isfinite(ys) & (ys >= y0) & (ys <= y1) & (xs >= x0) & (xs <= x1)
        px = np.minimum(((xs[ok] - x0) * (W / (x1 - x0))).astype(np.int32), W - 1)
        py = np.minimum(((ys[ok] - y0) * (H / (y1 - y0))).astype(np.int32), H - 1)
        np.maximum.at(top, (py, px), lay[ok].astype(np.int16))
    r = int(round(ms * dpi / 72.0 / 2.0))            # the marker's radius in pixels
    if r > 0:
        grown = top.copy()
        for dy in range(-r, r + 1):
            for dx in range(-r, r + 1):
                if dx * dx + dy * dy > r * r or (dx == 0 and dy == 0):
                    continue
                src = top[max(-dy, 0):H - max(dy, 0), max(-dx, 0):W - max(dx, 0)]
                dst = grown[max(dy, 0):H - max(-dy, 0), max(dx, 0):W - max(-dx, 0)]
                np.maximum(dst, src, out=dst)
        top = grown
    rgba = np.zeros((H, W, 4), np.float32)
    drawn = top >= 0
    rgba[drawn] = np.array([to_rgba(c) for c in colors], np.float32)[top[drawn]]
    ax.imshow(rgba, extent=(x0, x1, y0, y1), origin="lower", aspect="auto",
              interpolation="nearest", zorder=2)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
