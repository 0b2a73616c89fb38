"""A sweep's file as the explorer draws it: a diagram (one swept parameter: every finite
value a point (x, y, run), read a slab of rows at a time, ``plot_style.row_slabs``) or a
chart or basin (two swept axes: a cell per grid point), each run coloured as ``cornerbif
plot`` colours it: the attractor's label, its family or its branch (``plot_attractors``:
the same colour for the same orbit in every figure), or its period or stability value on a
colour scale."""

from __future__ import annotations

import os
import re
import threading
from dataclasses import dataclass, field

import numpy as np

from .. import plot_attractors
from ..attractors import read_branches, read_table
from ..plot_base import COLOR_BY, word_label
from ..plot_data import PlotData
from ..plot_style import robust_range, row_slabs, slab_rows

# the labels named and coloured (``plot_attractors.draw_diagram_by_label``'s ``shown``)
SHOWN = 8
NO_CYCLE, OTHER = "no cycle", "other cycles"
NO_CYCLE_COLOR, OTHER_COLOR = "#c7c7c7", "#000000"     # plot_attractors' "0.78" and "k"
# what colours the points: by label (categories) or by a value per run (a colour scale)
LABELLED = {"attractor": "attractor (word)", "family": "family of words",
            "branch": "branch (cornerbif explain)", "word": "cycle word (no table)"}
SCALED = {"period": ("period (map iterates)", None), **COLOR_BY}


@dataclass
class Colouring:
    """Each run's colour: ``layer`` (per run, an index into ``names`` and ``colors``) for a
    labelled colouring, or ``value`` (per run, a float) with its colour scale's centre."""
    what: str
    layer: np.ndarray | None = None
    names: list = field(default_factory=list)
    colors: list = field(default_factory=list)
    value: np.ndarray | None = None
    centre: float | None = None

    def legend(self) -> list:
        """(name, colour) of each layer shown, the named labels first."""
        return list(zip(self.names, self.colors))[::-1]


class Runs:
    """A sweep's file as the explorer reads it: its ``PlotData`` (``data``), its attractor
    table (``table``, None when it has none) and its runs' colours (``colouring``)."""

    def __init__(self, path, data=None):
        self.data = PlotData(path) if data is None else data
        self.path = str(path)
        self.table = read_table(path) if self.data.has_table else None
        self.mtime = _stamp(path)

    def choices(self) -> list:
        """The colourings this file offers (``colouring``'s ``what``)."""
        out = ["attractor", "family"] if self.table is not None else ["word"]
        if self.table is not None and "branch" in self.table:
            out.append("branch")
        out.append("period")
        return out + [k for k in COLOR_BY if k in self.data.stability]

    def colouring(self, what: str) -> Colouring:
        """The runs' colours by ``what`` (``choices``)."""
        if what in LABELLED:
            return self._labelled(what)
        if what == "period":
            return Colouring(what, value=np.where(self.data.period > 0, self.data.period,
                                                  np.nan).astype(float).ravel())
        if what in self.data.stability:
            return Colouring(what, value=self.data.stability[what].ravel(),
                             centre=COLOR_BY[what][1])
        raise ValueError(f"{self.path}: cannot colour by {what!r}; this file offers "
                         + ", ".join(self.choices()))

    def _labelled(self, what):
        if what == "word" or self.table is None:
            return word_colouring(self.data.symbols, self.data.period)
        names, row = plot_attractors.label_rows(self.table, what == "family", what == "branch")
        counts, _ = plot_attractors.label_counts(self.table["ids"], row, len(names))
        idx = plot_attractors.run_index(self.table["ids"], row)
        return _layers(what, names, counts, idx)

    def branches(self):
        """The file's branch table (``attractors.read_branches``), read once; None without."""
        if not hasattr(self, "_branches"):
            self._branches = read_branches(self.path) if self.table is not None else None
        return self._branches

    def changed(self) -> bool:
        """Whether the file changed on disk since it was read."""
        return _stamp(self.path) != self.mtime


class Diagram(Runs):
    """A file of one swept parameter as points (x, y, run): x the swept value, y a finite
    value of the y kind ``kind``, run its run (grid index * starts + start).  The points
    are never held: each render, zoom or click reads the rows of the window from the file a
    slab at a time (``slabs``, ``chunks``), so that the server's memory does not grow with
    the file.  ``size`` (the finite values) and the x extent are read in one pass when the
    file is opened, the y window (``plot_style.robust_range``) at its first use.
    ``ValueError`` for a file this view cannot draw."""

    def __init__(self, path, kind=None, data=None):
        super().__init__(path, data)
        d = self.data
        if len(d.axes) != 1:
            raise ValueError(f"{path}: a diagram has one swept parameter; this file sweeps "
                             f"{len(d.axes)} ({', '.join(d.axes)})")
        self.axis = d.axes[0]
        self.kind = kind or d.default_y()
        rows = d.y_rows(self.kind) if self.kind else None
        if rows is None or rows.ndim != 3:
            raise ValueError(f"{path}: the file holds no recorded values to draw (output.keep "
                             "of its scene: impact values need \"impacts\", section values "
                             "\"section\")")
        self.rows = rows
        self.xv = np.asarray(d.values[self.axis], float)
        self.n_ic = rows.shape[1]
        has = np.zeros(self.xv.size, bool)      # the grid rows with a point
        self.size = 0
        for a, block in row_slabs(rows):
            ok = np.isfinite(block)
            self.size += int(ok.sum())
            has[a:a + block.shape[0]] = ok.any(axis=(1, 2))
        self._x_extent = ((float(self.xv[has].min()), float(self.xv[has].max())) if has.any()
                          else None)
        self._y_window = False
        self._images = {}
        self._lock = threading.Lock()

    def x_extent(self) -> tuple:
        """(lowest, highest) swept value of a row with a point, or None without a point."""
        return self._x_extent

    def slabs(self, x_range=None):
        """The file's rows whose x is in ``x_range`` (all without one; only the window's
        rows are read where the grid is increasing), a slab at a time, as arrays that
        broadcast together: x (rows, 1, 1), y (rows, starts, record), run (rows, starts, 1);
        y NaN where no point is."""
        lo, hi = 0, self.xv.size
        if x_range is not None and self.xv.size > 1 and np.all(np.diff(self.xv) >= 0):
            lo = int(np.searchsorted(self.xv, x_range[0], side="left"))
            hi = int(np.searchsorted(self.xv, x_range[1], side="right"))
        if hi <= lo or self.changed():      # a file changed on disk is not read again: its
            return                          # runs' colours are the file's as it was read
        with self.rows.opened():
            for rows in slab_rows((hi - lo,) + self.rows.shape[1:]):
                a, b = lo + rows.start, lo + rows.stop
                y = np.asarray(self.rows[a:b])
                k = np.arange(a, b)
                run = k[:, None, None] * self.n_ic + np.arange(self.n_ic)[None, :, None]
                yield self.xv[a:b, None, None], y, run

    def chunks(self, x_range=None):
        """(x, y, run) of each point whose x is in ``x_range``, flat, a slab at a time."""
        for x, y, run in self.slabs(x_range):
            ok = np.isfinite(y)
            if x_range is not None:
                ok &= (x >= x_range[0]) & (x <= x_range[1])
            yield (np.broadcast_to(x, y.shape)[ok], y[ok], np.broadcast_to(run, y.shape)[ok])

    def image(self, colouring: Colouring, x_range, y_range, width: int, height: int):
        """``raster`` of the file's points; the last ``KEPT_IMAGES`` images are kept (the
        file's sessions share them: a new page's first view, a reset, a zoom back out are not
        read again; memory: at most that many images, whatever the file)."""
        key = (colouring.what, tuple(colouring.names), tuple(colouring.colors),
               tuple(map(float, x_range)), tuple(map(float, y_range)), width, height)
        with self._lock:
            if key in self._images:
                self._images[key] = self._images.pop(key)         # the most recent last
                return self._images[key]
        img = raster(self, colouring, x_range, y_range, width, height)
        with self._lock:
            self._images[key] = img
            while len(self._images) > KEPT_IMAGES:
                self._images.pop(next(iter(self._images)))
        return img

    def y_window(self):
        """``plot_style.robust_range`` of the values: (low, high, outside), None without;
        read once (the file's sessions share it)."""
        if self._y_window is False:
            self._y_window = robust_range(self.rows) if self.size else None
        return self._y_window

    def run_of(self, run: int) -> tuple:
        """(grid index, start) of run ``run``."""
        k, ic = divmod(int(run), self.n_ic)
        return (k,), ic


KEPT_IMAGES = 8       # a diagram's last rasters kept (``Diagram.image``): 8 x 1.6 MB


class Cloud:
    """Points held in memory (a refine's finished blocks, read from its partial file): the
    same ``chunks`` and ``run_of`` as a ``Diagram``."""

    def __init__(self, x, y, run, n_ic):
        self.x, self.y, self.run, self.n_ic = x, y, run, n_ic

    @property
    def size(self) -> int:
        return int(self.x.size)

    def chunks(self, x_range=None):
        keep = (slice(None) if x_range is None
                else (self.x >= x_range[0]) & (self.x <= x_range[1]))
        yield self.x[keep], self.y[keep], self.run[keep]

    slabs = chunks
    run_of = Diagram.run_of

    def image(self, colouring: Colouring, x_range, y_range, width: int, height: int):
        return raster(self, colouring, x_range, y_range, width, height)


def raster(points, colouring: Colouring, x_range, y_range, width: int, height: int):
    """The points of ``points`` (a ``Diagram`` or a ``Cloud``) in the window ``x_range`` x
    ``y_range`` as an image of ``width`` x ``height`` pixels (row 0 at the lowest y), read a
    slab at a time: each pixel the highest of its points' ``codes`` (a labelled colouring:
    the highest layer wins, as ``cornerbif plot``'s raster) or their mean (a colour scale);
    NaN where no point falls.  Memory: the image's and one slab's."""
    (x0, x1), (y0, y1) = x_range, y_range
    if not (x1 > x0 and y1 > y0):
        return np.full((height, width), np.nan, np.float32)
    n = width * height
    labelled = colouring.layer is not None
    top = np.full(n, -np.inf, np.float32)
    total = np.zeros(n)
    count = np.zeros(n)
    for x, y, run in points.slabs(x_range):
        c = codes(colouring, run)
        # NaN compares false: a missing value, or a run without a value, is no point
        ok = (y >= y0) & (y <= y1) & (x >= x0) & (x <= x1) & np.isfinite(c)
        ix = np.clip(((x - x0) * (width / (x1 - x0))).astype(np.int64), 0, width - 1)
        iy = np.clip(((np.where(ok, y, y0) - y0) * (height / (y1 - y0))).astype(np.int64), 0,
                     height - 1)
        pixel = (iy * width + ix)[ok]
        value = np.broadcast_to(c, ok.shape)[ok]
        if labelled:
            np.maximum.at(top, pixel, value)
        else:
            total += np.bincount(pixel, weights=value, minlength=n)
            count += np.bincount(pixel, minlength=n)
    if labelled:
        img = np.where(np.isfinite(top), top, np.nan)
    else:
        with np.errstate(invalid="ignore", divide="ignore"):
            img = np.where(count > 0, total / count, np.nan)
    return img.reshape(height, width).astype(np.float32)


def _neighbourhood_max(img, px: int):
    """Each pixel's highest value over the (2 px + 1)^2 pixels around it (NaN: none)."""
    out = img.copy()
    h, w = img.shape
    for dy in range(-px, px + 1):
        for dx in range(-px, px + 1):
            if dx == 0 and dy == 0:
                continue
            src = img[max(0, -dy):h - max(0, dy), max(0, -dx):w - max(0, dx)]
            dst = out[max(0, dy):h - max(0, -dy), max(0, dx):w - max(0, -dx)]
            np.fmax(dst, src, out=dst)
    return out


def _has_neighbour(drawn):
    """The drawn pixels with a drawn pixel among their 8 neighbours."""
    pad = np.pad(drawn, 1)
    h, w = drawn.shape
    around = np.zeros(drawn.shape, bool)
    for dy in (0, 1, 2):
        for dx in (0, 1, 2):
            if (dy, dx) != (1, 1):
                around |= pad[dy:dy + h, dx:dx + w]
    return drawn & around


def spread(img, threshold: float = 0.6, max_px: int = 2):
    """Sparse points grown so that they are seen, as Datashader's ``dynspread``: while fewer
    than ``threshold`` of the drawn pixels have a drawn neighbour, the points grow by one
    pixel more, up to ``max_px``; an empty pixel within the reach of points takes the
    highest of their values (the highest layer wins, as in ``raster``), a drawn pixel keeps
    its own."""
    drawn = np.isfinite(img)
    if not drawn.any():
        return img
    grown = img
    for px in range(1, max_px + 1):
        ok = np.isfinite(grown)
        if np.count_nonzero(_has_neighbour(ok)) >= threshold * np.count_nonzero(ok):
            break
        grown = _neighbourhood_max(img, px)
    return np.where(drawn, img, grown)


def nearest(px, py, xr, yr, sources):
    """The point of ``sources`` (``Diagram``s or ``Cloud``s, None skipped) in the view's
    window ``xr`` x ``yr`` nearest (``px``, ``py``), distances measured in screen units,
    read a slab at a time: (source index, x, y, run), or None when the window holds none."""
    best = None
    sx, sy = max(xr[1] - xr[0], 1e-300), max(yr[1] - yr[0], 1e-300)
    for src, pts in enumerate(sources):
        if pts is None:
            continue
        for x, y, run in pts.chunks(xr):
            inside = (y >= yr[0]) & (y <= yr[1])
            if not inside.any():
                continue
            x, y, run = x[inside], y[inside], run[inside]
            d2 = ((x - px) / sx) ** 2 + ((y - py) / sy) ** 2
            i = int(np.argmin(d2))
            if best is None or d2[i] < best[0]:
                best = (float(d2[i]), src, float(x[i]), float(y[i]), int(run[i]))
    return None if best is None else best[1:]


class Chart(Runs):
    """A file of two swept axes (two parameters: a chart; two start coordinates: a basin) as
    an image of its grid: ``xv``, ``yv`` the axes' values (evenly spaced, increasing), each
    cell coloured by its starts' highest layer (a chart, as ``cornerbif plot``'s raster) or
    by its first start (a basin, as ``plot_attractors.draw_basin``).  ``ValueError`` for a
    file this view cannot draw."""

    def __init__(self, path, data=None):
        super().__init__(path, data)
        d = self.data
        if len(d.axes) != 2:
            raise ValueError(f"{path}: a chart has two swept axes; this file sweeps "
                             f"{len(d.axes)} ({', '.join(d.axes)})")
        self.axes = tuple(d.axes)
        self.xv, self.yv = (np.asarray(d.values[a], float) for a in self.axes)
        for a, v in zip(self.axes, (self.xv, self.yv)):
            step = np.diff(v)
            if v.size < 2 or step[0] <= 0 or not np.allclose(step, step[0], rtol=1e-6, atol=0):
                raise ValueError(f"{path}: the explorer draws a chart of evenly spaced, "
                                 f"increasing axes; {a} is not: draw it with cornerbif plot")
        self.n_ic = d.period.shape[-1]
        self.basin = all(a.startswith("initial.") for a in self.axes)

    @property
    def size(self) -> int:
        return int(self.xv.size * self.yv.size)

    def image(self, colouring: Colouring) -> np.ndarray:
        """The cells' values (``cell_image``)."""
        return cell_image(colouring, (self.xv.size, self.yv.size, self.n_ic), self.basin)

    def cell(self, px, py) -> tuple:
        """The grid index (i, j) of the cell nearest (``px``, ``py``)."""
        return int(np.argmin(np.abs(self.xv - px))), int(np.argmin(np.abs(self.yv - py)))


# every colour a labelled colouring uses (``plot_attractors.attractor_colors`` takes its
# palette's); a run's value is its layer * SLOTS + its colour's index here, so that the
# highest layer wins a pixel (the rarer orbit over the more common, as ``cornerbif plot``'s
# raster) and one fixed colour map serves every labelled colouring: a new colouring is new
# data, not a new plot
COLOURS = tuple(dict.fromkeys(c.lower() for c in (NO_CYCLE_COLOR, OTHER_COLOR,
                                                   *plot_attractors.PALETTE)))
SLOTS = 32
LAYERS = SHOWN + 2
LABEL_CMAP = [COLOURS[k % SLOTS] if k % SLOTS < len(COLOURS) else "#ffffff"
              for k in range(LAYERS * SLOTS)]


def codes(colouring: Colouring, runs) -> np.ndarray:
    """The runs ``runs``' values as the datashader reads them (float32): their layer and
    colour (``COLOURS``) as one number, or their value on a colour scale."""
    if colouring.layer is not None:
        slot = np.array([COLOURS.index(c.lower()) for c in colouring.colors], np.float32)
        layer = colouring.layer[runs]
        return layer.astype(np.float32) * SLOTS + slot[layer]
    return colouring.value[runs].astype(np.float32)


def cell_image(colouring: Colouring, shape, basin: bool, done=None) -> np.ndarray:
    """The cells of a grid of ``shape`` (x values, y values, starts) as an image's values,
    y along the first axis: their runs' ``codes``, the first start's (a basin) or the
    highest over the starts (a chart); NaN where ``done`` (per cell) is false."""
    c = codes(colouring, np.arange(int(np.prod(shape)))).reshape(shape)
    if basin:
        cell = c[..., 0]
    else:
        cell = np.where(np.isnan(c), -np.inf, c).max(axis=-1)
    if done is not None:
        cell = np.where(done, cell, np.nan)
    return np.where(np.isfinite(cell), cell, np.nan).T.astype(np.float32)


def open_file(path) -> Runs:
    """A file as the explorer draws it: a ``Diagram`` (one swept parameter) or a ``Chart``
    (two swept axes); ``ValueError`` for another."""
    data = PlotData(path)
    if len(data.axes) == 1:
        return Diagram(path, data=data)
    if len(data.axes) == 2:
        return Chart(path, data=data)
    raise ValueError(f"{path}: the explorer draws files of one or two swept axes; this one "
                     f"sweeps {len(data.axes)}: draw it with cornerbif plot")


def _stamp(path):
    """What tells a changed file: its modification time, size and inode."""
    st = os.stat(path)
    return (st.st_mtime_ns, st.st_size, st.st_ino)


def _layers(what, names, counts, idx) -> Colouring:
    """Layers as ``plot_attractors.draw_diagram_by_label`` draws them: 0 the runs without a
    cycle (light grey), 1 the cycles not named (black), 2 + k the k-th label of the ``SHOWN``
    with the most runs, in its colour (``plot_attractors.attractor_colors``)."""
    top = [int(i) for i in np.argsort(-counts, kind="stable")[:SHOWN] if counts[i] > 0]
    colors = plot_attractors.attractor_colors([names[i] for i in top])
    label_layer = np.ones(len(names) + 1, np.int16)
    label_layer[top] = 2 + np.arange(len(top))
    label_layer[-1] = 0                                  # idx -1: no attractor
    layer = label_layer[idx].ravel()
    tex = plot_attractors.family_tex if what == "family" else word_label
    shown = [_plain(tex(names[i])) for i in top]
    return Colouring(what, layer=layer, names=[NO_CYCLE, OTHER] + shown,
                     colors=[NO_CYCLE_COLOR, OTHER_COLOR] + [colors[names[i]] for i in top])


def word_colouring(symbols, period) -> Colouring:
    """Layers by each run's cycle word alone (a file without an attractor table: partial, or
    a refine being swept): the words with the most runs named, in their labels' colours."""
    words = np.asarray(symbols).ravel()
    has = (np.asarray(period).ravel() > 0) & (words != "")
    names, inv = np.unique(np.where(has, words, ""), return_inverse=True)
    counts = np.bincount(inv, minlength=len(names))
    idx = np.where(has, inv, -1)
    if len(names) and names[0] == "":
        counts[0] = 0
    return _layers("word", list(names), counts, idx)


GREEK = {"alpha": "α", "beta": "β", "gamma": "γ", "delta": "δ", "kappa": "κ", "omega": "ω",
         "Omega": "Ω", "lambda": "λ", "mu": "μ", "sigma": "σ", "phi": "φ", "theta": "θ",
         "tau": "τ", "infty": "∞", "geq": "≥", "leq": "≤"}


def _plain(label: str) -> str:
    """A label in plain text for the page: the paper's letters without TeX."""
    text = re.sub(r"\\([A-Za-z]+)", lambda m: GREEK.get(m.group(1), m.group(1)), str(label))
    return re.sub(r"\\[,;!]|[${}]", lambda m: " " if m.group(0).startswith("\\") else "",
                  text).replace("_", "")
