"""A sweep's file as the explorer draws it: a diagram (one swept parameter: every finite
value a point (x, y, run), read a slab of rows at a time, ``plot_style.row_slabs``) or a
chart or basin (two swept axes: a cell per grid point), each run coloured as ``cornerbif
plot`` colours it: the attractor's label, its family or its branch (``plot_attractors``:
the same colour for the same orbit in every figure), or its period or stability value on a
colour scale."""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field

import numpy as np

from .. import plot_attractors
from ..attractors import read_table
from ..plot_base import COLOR_BY, word_label
from ..plot_data import PlotData
from ..plot_style import row_slabs

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

    def changed(self) -> bool:
        """Whether the file changed on disk since it was read."""
        return _stamp(self.path) != self.mtime


class Diagram(Runs):
    """A file of one swept parameter as points: ``x``, ``y`` (finite values of the y kind
    ``kind``), ``run`` (each point's run, grid index * starts + start), read once.
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
        self.n_ic = rows.shape[1]
        self.x, self.y, self.run = _points(d.values[self.axis], rows)

    @property
    def size(self) -> int:
        return int(self.x.size)

    def nearest(self, px, py, xr, yr, extra=None):
        """The point nearest (``px``, ``py``) in the view's ranges ``xr``, ``yr`` (distances
        measured in screen units): (source, index); ``extra`` (a ``Diagram`` of a refine, or
        None) is searched too, source 1."""
        best = (np.inf, 0, -1)
        for src, dia in enumerate([self, extra]):
            if dia is None or dia.size == 0:
                continue
            dx = (dia.x - px) / max(xr[1] - xr[0], 1e-300)
            dy = (dia.y - py) / max(yr[1] - yr[0], 1e-300)
            d2 = dx * dx + dy * dy
            i = int(np.argmin(d2))
            if d2[i] < best[0]:
                best = (float(d2[i]), src, i)
        return best[1], best[2]

    def run_of(self, i: int) -> tuple:
        """(grid index, start) of point ``i``."""
        k, ic = divmod(int(self.run[i]), self.n_ic)
        return (k,), ic


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


def _points(xv, rows):
    """The finite values of ``rows`` (``plot_style.Rows`` of (points, starts, record)) with
    their x and run index, read a slab at a time: three flat arrays."""
    xs, ys, runs = [], [], []
    n_ic = rows.shape[1]
    for a, block in row_slabs(rows):
        ok = np.isfinite(block)
        i, ic, _ = np.nonzero(ok)
        xs.append(xv[a + i].astype(float))
        ys.append(block[ok].astype(float))
        runs.append(((a + i) * n_ic + ic).astype(np.int32))
    if not xs:
        return np.zeros(0), np.zeros(0), np.zeros(0, np.int32)
    return np.concatenate(xs), np.concatenate(ys), np.concatenate(runs)


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
