"""Figures from HDF5 files only (plotting never runs kernels).

matplotlib's recipe: ``draw_*(ax, data, **kw) -> artists`` plus ``figure``,
which makes the whole figure.  matplotlib is imported here only, so
``cornerbif sweep`` starts fast and needs no display.

What one figure may draw together is checked before anything is drawn
(``check_together``: files of one parameter, a flow against its map, branches over their
sweep); a figure is written whole or not at all (``outputs.save_figure``); the warnings
numpy and matplotlib give on what a file holds by design are silenced while drawing
(``quiet``).
"""

from __future__ import annotations

import contextlib
import math
import os
import tomllib
import warnings
from dataclasses import dataclass

import numpy as np

from . import plot_attractors, plot_normal_form, registry, theory
from . import status as S
from .errors import SweepError
from .io import check_readable
from .model import cut
from .plot_style import bounded, legend, plain, quiet, save, title_lines


class Undrawable(SweepError, ValueError):
    """Files or options one figure cannot show truthfully, refused before anything is drawn
    (exit 2); the message names each file and what it holds."""


def obstacle_kind(system: dict):
    """The obstacle kind (``model.Obstacle``) a file's ``[system]`` names, the default where it
    names none (the figures ask it what it draws: corner curves, marks, its wedge)."""
    from .model import Obstacle
    name = system.get("obstacle", registry.DEFAULT_OBSTACLE)
    known = registry.obstacles().get(name) if isinstance(name, str) else None
    return known or Obstacle(str(name), -1, "not a registered obstacle", 1, 1, corners=False)


LABELS = {
    "initial.u": r"start $u(t_0)$", "initial.v": r"start $v(t_0)$",
    "initial.z": r"start $z(t_0)$", "initial.y": r"start $y(t_0)$",
    "initial.t": r"start time $t_0$",
    "omega": r"$\omega$", "kappa": r"$\kappa$", "beta": r"$\beta$", "r": r"$r$",
    "sigma": r"$\sigma$", "k": r"$k$", "theta1": r"$\theta_1$", "theta2": r"$\theta_2$",
    "F": r"$F$", "Omega": r"$\Omega$", "phi": r"$\varphi$",
    "omega0": r"$\omega_0$", "omega1": r"$\omega_1$", "omega2": r"$\omega_2$",
    "mu": r"$\mu = M/m$", "r1": r"$r_1$", "r2": r"$r_2$",
}
YLABELS = {
    "impact_u": "impact height $u$", "impact_v": "impact velocity $v^-$",
    "impact_height": r"height above the corner $u - \kappa$",
    "section_u": r"$u(nT)$ (map2d: $a_n$)", "section_v": r"$v(nT)$ (map2d: $b_n$)",
    "winding": r"winding number $W$ (share of $\gamma$, §5.4)",
    "period": "period (clusters per cycle)",
}
def _model_labels(model: str | None) -> dict:
    """The labels a model declares for its own axes (``Model.axis_labels``)."""
    spec = registry.models().get(model) if isinstance(model, str) else None
    return spec.axis_labels if spec is not None else {}


def axis_label(name: str, model: str | None = None) -> str:
    """The label of a swept axis ``name`` for a file of ``model``."""
    return _model_labels(model).get(name) or LABELS.get(name, name)


# the diagram's y values that a model may name in its own terms (the maps' section is
# (a_n, b_n), a flow's (u(nT), v(nT)))
SECTION_KINDS = ("section_u", "section_v")


def y_label(kind: str, model: str | None = None) -> str:
    """The axis label of a drawn ``kind`` for a file of ``model`` (its own label where it
    declares one; a file of several models compared on one axis names both)."""
    own = _model_labels(model).get(kind)
    if own:
        return own
    if kind in SECTION_KINDS and model is not None:
        return YLABELS[kind].split(" (")[0]
    return YLABELS.get(kind, kind)


# the per-event datasets a figure may draw (read when first drawn: ``RecordedData``)
RECORDED = ("impacts/u", "impacts/v_in", "section/u", "section/v", "impacts/t",
            "impacts/corner_offset")
# the dataset each y of a diagram is made from (winding and period: the per-run words
# and periods)
Y_DATASETS = {"impact_u": "impacts/u", "impact_v": "impacts/v_in",
              "impact_height": "impacts/u", "section_u": "section/u",
              "section_v": "section/v"}


class RecordedData(dict):
    """The file's per-event datasets, each read from the file the first time it is asked
    for: a figure of impact heights reads that dataset alone (a 5 M-point diagram holds
    one 40 MB array, not six; benchmarks/plot_speed.py).  ``rows`` reads a slab of rows
    alone (a diagram of millions of points holds none whole); ``shapes`` their shapes."""

    def __init__(self, path, shapes, swmr=False):
        super().__init__()
        self.path = path
        self.shapes = dict(shapes)
        self.names = tuple(self.shapes)
        self.swmr = swmr            # how check_readable opened the file
        self._file = None           # held open by ``opened``

    def __contains__(self, name):
        return name in self.names

    def __getitem__(self, name):
        if name not in self.names:
            raise KeyError(name)
        if not dict.__contains__(self, name):
            with check_readable(self.path) as f:
                dict.__setitem__(self, name, f[name][...])
        return dict.__getitem__(self, name)

    def get(self, name, default=None):
        return self[name] if name in self.names else default

    def rows(self, name, rows: slice):
        """Rows ``rows`` of the first axis of ``name``: a view of the whole when it has been
        read, else read alone from the file."""
        if name not in self.names:
            raise KeyError(name)
        if dict.__contains__(self, name):
            return dict.__getitem__(self, name)[rows]
        with self.opened():
            return self._file[name][rows]

    @contextlib.contextmanager
    def opened(self):
        """The file held open for the ``rows`` read inside (a pass over the slabs opens it
        once; PlotData checked it with ``check_readable``, which reads the whole file's
        structure)."""
        if self._file is not None:
            yield
            return
        import h5py
        with h5py.File(self.path, "r", swmr=self.swmr, locking=False) as f:
            self._file = f
            try:
                yield
            finally:
                self._file = None


# values larger than this in size are escapes (a figure's transforms overflow near 1e308):
# drawn as infinities are, not at all, and counted on the figure
DRAW_LIMIT = 1e100


def beyond_drawing(v):
    """``v`` with its values beyond DRAW_LIMIT in size as infinities of their sign."""
    v = np.asarray(v)
    if v.dtype.kind != "f":
        return v
    with np.errstate(invalid="ignore"):
        big = np.abs(v) > DRAW_LIMIT
    return np.where(big, np.copysign(np.inf, v), v) if big.any() else v


# the letters of a cycle word (analysis.detect_cycle: the corner clusters alpha, beta, gamma
# and x, any other cluster)
WORD_LETTERS = b"abgx"


def _words(sym):
    """The file's cycle words (``symbols``) as str no wider than the longest (the file's
    field may be many times wider: memory per run).  A word holding a character no kernel
    writes (a crafted file's) reads as no word: a figure never draws it."""
    width = sym.dtype.itemsize
    allowed = np.zeros(256, bool)
    allowed[list(b"\0" + WORD_LETTERS)] = True
    ok = allowed[np.ascontiguousarray(sym).view(np.uint8)]
    if width and not ok.all():
        sym = np.where(ok.reshape(sym.shape + (width,)).all(axis=-1), sym, b"")
    return sym.astype(f"U{max(1, int(np.char.str_len(sym).max(initial=0)))}")


class PlotData:
    """What the plot needs, read from one file.

    Only the grid points the sweep finished (``done``) are shown: a partial file's other
    points read as not run (status -1, no cycle, no values), and ``partial_note`` says how
    many are finished; a file with none finished is refused (``FileFormatError``)."""

    def __init__(self, path):
        from .io import FileFormatError
        with check_readable(path) as f:
            self.path = str(path)
            self.scene_text = f.attrs["scene"]
            self.scene = tomllib.loads(self.scene_text)
            from .config import sweep_items
            self.axes = [k for k, _ in sweep_items(self.scene.get("sweep", {}))]
            self.done = f["done"][...].astype(bool)
            G = self.done.shape
            self.unplaceable = None      # why no figure can place its values (``_check_axes``)
            self._check_axes(f, G)
            self.values = {a: f[a][...] for a in self.axes}
            self.n_done, self.n_points = int(np.count_nonzero(self.done)), int(self.done.size)
            if self.n_done == 0:
                raise FileFormatError(
                    f"{path}: no grid point of its sweep is finished (0 of {self.n_points}): "
                    "nothing to show; a sweep stopped before its first block is completed by "
                    "cornerbif sweep SCENE -o OUT --resume")
            self.status = f["status"][...]
            self.period = f["period"][...]
            self.ipc = f["impacts_per_cycle"][...]
            self.symbols = _words(f["symbols"][...])
            self.model = self.scene.get("scene", {}).get("model", registry.DEFAULT_MODEL)
            self.spec = registry.models().get(self.model)
            # its part in the flow-against-map figures of sections 4-5 ("flow", "map", None)
            self.normal_form = self.spec.normal_form if self.spec else None
            self.initial = {k: f[f"initial/{k}"][...] for k in ("u", "v") if f"initial/{k}" in f}
            runs = self.status.shape
            shapes = {n: f[n].shape for n in RECORDED if n in f}
            for n, shp in shapes.items():
                if shp[:len(runs)] != runs:
                    raise FileFormatError(f"{path}: dataset {n!r} has shape {shp}, which does "
                                          f"not match the runs {runs}")
            self.data = RecordedData(path, shapes, swmr=f.swmr_mode)
            self.follow = self.scene.get("sweep", {}).get("follow", "none")
            self.complete = bool(f.attrs.get("completed", "")) and self.n_done == self.n_points
            # the attractor table (cornerbif.attractors) is written when the sweep finishes
            self.has_table = "attractors" in f and self.complete
            # the stability observable (docs/stability.md), per run
            self.stability = {}
            for what, names in (("lyapunov", ("stability/lyapunov",)),
                                ("multiplier", ("stability/multiplier_re",
                                                "stability/multiplier_im"))):
                if not all(n in f for n in names):
                    continue
                if any(f[n].shape[:len(runs)] != runs or f[n].ndim != len(runs) + 1
                       or f[n].dtype.kind != "f" for n in names):
                    raise FileFormatError(f"{path}: its stability datasets ({', '.join(names)}) "
                                          f"do not match the runs {runs}")
                vals = [f[n][..., 0] for n in names]
                with np.errstate(all="ignore"):
                    self.stability[what] = beyond_drawing(vals[0] if len(vals) == 1
                                                          else np.hypot(*vals))
            try:
                self.period_tol = float(self.scene.get("run", {}).get("period_tol", 1e-6))
            except (TypeError, ValueError):
                self.period_tol = 1e-6
        self.unfinished = ~self.done if self.n_done < self.n_points else None
        if self.unfinished is not None:
            # what a partial file holds at its unfinished points is not a result (fill
            # values, or anything a crafted file put there): read as not run
            per_run = self.unfinished.reshape(G + (1,) * (self.status.ndim - len(G)))
            per_run = np.broadcast_to(per_run, self.status.shape)
            self.status = np.where(per_run, -1, self.status)
            self.period = np.where(per_run, 0, self.period)
            self.ipc = np.where(per_run, 0, self.ipc)
            self.symbols = np.where(per_run, "", self.symbols)
            self.stability = {k: np.where(per_run, np.nan, v) for k, v in self.stability.items()}
        self._attractors = None
        self._y = {}                 # y(kind), computed once

    def _check_axes(self, f, G):
        """The swept parameters of the file's scene are its grid's axes: one dataset of
        finite values each, of the grid's length along its axis."""
        import h5py

        from .io import FileFormatError
        if len(self.axes) != len(G):
            raise FileFormatError(f"{self.path}: its scene sweeps {len(self.axes)} parameter(s), "
                                  f"its grid has {len(G)} axes")
        for i, a in enumerate(self.axes):
            ok = (a in f and isinstance(f[a], h5py.Dataset) and f[a].shape == (G[i],)
                  and f[a].dtype.kind in "fiu")
            if not ok:
                raise FileFormatError(f"{self.path}: the values of its swept parameter "
                                      f"{cut(a)!r} are missing or do not match the grid")
            v = f[a][...]
            if not np.isfinite(v).all():
                raise FileFormatError(f"{self.path}: its swept parameter {cut(a)!r} has "
                                      "values that are not finite")
            if np.abs(v).max(initial=0.0) > DRAW_LIMIT and self.unplaceable is None:
                # summarised by info; refused by a figure (``check_together``)
                self.unplaceable = (f"{self.path}: its swept parameter {cut(a)!r} has values "
                                    f"beyond {DRAW_LIMIT:g} in size, which no figure can place")

    def partial_note(self) -> str:
        """What a figure or ``info`` says of a file that is not complete ("" when it is)."""
        if self.n_done < self.n_points:
            return (f"partial sweep: {self.n_done} of {self.n_points} grid points finished; "
                    "only these are shown")
        if not self.complete:
            return ("every grid point finished, but the sweep was not stamped complete "
                    "(cornerbif sweep --resume finishes it)")
        return ""

    def attractors(self):
        """Distinct attractors among the starts of each grid point (``analysis.distinct_attractors``).

        Compared on one cycle of impact heights and velocities when impacts are
        stored, else on the section values, else on the cycle's word alone; to
        100 ``run.period_tol`` (two starts on one cycle agree to the detection
        tolerance of each).  Each grid point on its own: the series are read a slab of
        grid points at a time (``plot_style.slab_rows``), never whole.  Returns (labels
        G + (n_ic,), count G).
        """
        if self._attractors is None:
            from .analysis import distinct_attractors
            from .plot_style import slab_rows
            if "impacts/u" in self.data:
                names = [("impacts/u", "impacts"), ("impacts/v_in", "impacts")]
            elif "section/u" in self.data:
                names = [("section/u", "section"), ("section/v", "section")]
            else:
                names = []
            width = max([int(np.prod(self.data.shapes[n][1:])) for n, _ in names] + [1])
            slabs = ((slab_rows((self.period.shape[0], width)) if self.period.ndim >= 2
                      else []) or [slice(None)])
            with self.data.opened():
                parts = [distinct_attractors(
                    self.period[rows], self.ipc[rows], self.symbols[rows],
                    [(self.data.rows(n, rows), kind) for n, kind in names],
                    100.0 * self.period_tol) for rows in slabs]
            self._attractors = (parts[0] if len(parts) == 1 else
                                tuple(np.concatenate(p) for p in zip(*parts)))
        return self._attractors

    def y(self, kind):
        """The values drawn for ``kind`` (``YLABELS``), computed once per kind; None when
        the file holds none."""
        if kind not in self._y:
            self._y[kind] = self._compute_y(kind)
        return self._y[kind]

    def y_rows(self, kind):
        """The values drawn for ``kind`` as ``plot_style.Rows``, read and computed a slab of
        rows at a time (sliced from the whole when ``y`` has computed it, or when it has one
        value per run): a diagram of millions of points is never whole in memory.  None
        when the file holds none."""
        from .plot_style import Rows
        if kind in ("winding", "period") or kind in self._y:     # one value per run
            whole = self.y(kind)
            return None if whole is None else Rows(whole.shape, lambda a, b: whole[a:b])
        if Y_DATASETS[kind] not in self.data:
            return None
        return Rows(self.data.shapes[Y_DATASETS[kind]],
                    lambda a, b: self._compute_y(kind, slice(a, b)), self.data.opened)

    def _compute_y(self, kind, rows=slice(None)):
        """``kind``'s values in ``rows`` of the first axis (all by default; a slab is read
        alone, ``RecordedData.rows``), or None when the file holds none."""
        if kind == "winding":
            from .analysis import winding_number
            return np.vectorize(winding_number, otypes=[float])(self.symbols[rows])
        if kind == "period":
            per = self.period[rows]
            return np.where(per > 0, per, np.nan).astype(float)
        name = Y_DATASETS[kind]
        if name not in self.data:
            return None
        v = self.data[name] if rows == slice(None) else self.data.rows(name, rows)
        if self.unfinished is not None:          # a partial file: its finished points only
            un = self.unfinished[rows]
            v = np.where(un.reshape(un.shape + (1,) * (v.ndim - un.ndim)), np.nan, v)
        v = beyond_drawing(v)
        if kind == "impact_height":
            # u - kappa: the impact's height above the corners of z = kappa + beta |sin|
            # (and the triangle's valleys), where a kappa sweep's cascade lies
            kap = (self.values["kappa"] if "kappa" in self.axes
                   else np.float64(self.scene.get("system", {}).get("kappa", 0.0)))
            if np.ndim(kap):
                pos = self.axes.index("kappa")
                kap = kap.reshape((-1,) + (1,) * (v.ndim - 1 - pos))
                kap = kap[rows] if pos == 0 else kap
            return v - kap
        return v

    def default_y(self):
        if self.spec is not None and self.spec.default_y:
            return self.spec.default_y
        for kind in ("impact_u", "section_u"):
            if Y_DATASETS[kind] in self.data:
                return kind
        return None


def points(x, y):
    """Bifurcation-diagram points: x repeated over every recorded value, NaN dropped."""
    xs = np.broadcast_to(x.reshape((-1,) + (1,) * (y.ndim - 1)), y.shape).ravel()
    ys = y.ravel()
    ok = np.isfinite(ys)
    return xs[ok], ys[ok]


ATTRACTOR_COLORS = ("tab:red", "tab:blue", "tab:green", "tab:orange", "tab:purple", "tab:brown")


def draw_bifurcation(ax, data: PlotData, y="impact_u", ms=0.6, color="k", label=None,
                     by_attractor=False):
    """Parameter against impact height (or section values), small markers (paper Figs 1, 4, 6, 7).

    ``by_attractor``: where two or more distinct attractors coexist at a
    parameter value (``PlotData.attractors``), each is drawn in its own colour,
    ranked by (period, word); points with a single attractor stay black.
    """
    a = data.axes[0]
    yv = data.y(y)
    if not by_attractor or yv is None or yv.ndim != 3:
        xs, ys = points(data.values[a], yv)
        return ax.plot(xs, ys, ls="none", marker=".", mew=0, ms=ms, color=color, label=label,
                       rasterized=True)
    labels, count = data.attractors()
    x = data.values[a]
    many = count >= 2
    arts = []
    single = np.where(many[:, None, None] & (labels[..., None] >= 0), np.nan, yv)
    xs, ys = points(x, single)
    lab1 = label or ("one attractor (or no cycle)" if many.any() else None)
    arts += ax.plot(xs, ys, ls="none", marker=".", mew=0, ms=ms, color=color, label=lab1,
                    rasterized=True)
    for rank in range(int(count.max()) if count.size else 0):
        sel = many[:, None, None] & (labels[..., None] == rank)
        if not sel.any():
            continue
        xs, ys = points(x, np.where(sel, yv, np.nan))
        c = ATTRACTOR_COLORS[rank] if rank < len(ATTRACTOR_COLORS) else "0.5"
        arts += ax.plot(xs, ys, ls="none", marker=".", mew=0, ms=ms * 1.3, color=c,
                        label=f"attractor {rank + 1} where $\\geq$2 coexist", rasterized=True)
    return arts


# [plot] color_by (config.PLOT_COLOR_BY): what colours a diagram or a chart, per run, its
# label and the neutral value (docs/stability.md)
COLOR_BY = {
    "lyapunov": (r"largest Lyapunov exponent $\lambda_1$", 0.0),
    "multiplier": (r"largest Floquet multiplier $|\mu_1|$", 1.0),
}


def stability_values(data: PlotData, what: str):
    """The per-run values ``what`` ("lyapunov" or "multiplier") of a file kept with
    ``"stability"``, or a ValueError that says how to get them."""
    if what not in data.stability:
        raise ValueError(f"{data.path}: no stability/ datasets to colour by {what!r}; re-run "
                         "the scene with output.keep containing \"stability\"")
    return data.stability[what]


def stability_norm(values, centre):
    """A diverging colour scale with its neutral colour at ``centre`` (lambda = 0,
    |mu| = 1: the stability boundary); each side spans its own values (2nd and 98th
    percentiles), so stable cycles and chaos both reach a saturated colour."""
    import matplotlib.colors as mcolors
    fin = values[np.isfinite(values)]
    lo = np.percentile(fin, 2) if fin.size else centre - 1.0
    hi = np.percentile(fin, 98) if fin.size else centre + 1.0
    # a side with no values keeps a quarter of the other's span, so the bar still reads
    span = max(hi - lo, 1e-12)
    return mcolors.TwoSlopeNorm(vcenter=centre, vmin=min(lo, centre - 0.25 * span),
                                vmax=max(hi, centre + 0.25 * span))


def draw_bifurcation_colored(ax, data: PlotData, y, what, ms=0.6):
    """A diagram (one sweep axis) whose points carry their run's largest Lyapunov exponent
    or largest |multiplier| as colour (diverging, centred on the stability boundary);
    runs without a value (no cycle, grazing) grey, runs that stick (lambda = -inf,
    mu = 0) black.  Returns the scatter (for the colour bar)."""
    a = data.axes[0]
    yv = data.y(y)
    val = stability_values(data, what)
    cval = np.broadcast_to(val.reshape(val.shape + (1,) * (yv.ndim - val.ndim)), yv.shape)
    x = np.broadcast_to(data.values[a].reshape((-1,) + (1,) * (yv.ndim - 1)), yv.shape)
    ok = np.isfinite(yv)
    label, centre = COLOR_BY[what]
    stuck = ok & ((cval == -np.inf) | ((what == "multiplier") & (cval == 0.0)))
    none = ok & ~np.isfinite(cval) & ~stuck
    s = (ms * 1.2) ** 2
    if none.any():
        ax.scatter(x[none], yv[none], s=s, c="0.75", lw=0, rasterized=True,
                   label="no value (no cycle, grazing)")
    if stuck.any():
        ax.scatter(x[stuck], yv[stuck], s=s, c="k", lw=0, rasterized=True,
                   label="sticks: " + (r"$\lambda = -\infty$" if what == "lyapunov"
                                       else r"$\mu = 0$"))
    fin = ok & np.isfinite(cval) & ~stuck
    sc = ax.scatter(x[fin], yv[fin], s=s, c=cval[fin], cmap="coolwarm",
                    norm=stability_norm(cval[fin], centre), lw=0, rasterized=True)
    return sc


def draw_plane_stability(ax, data: PlotData, what):
    """Two-axis sweep: the largest Lyapunov exponent (or |multiplier|), the largest over
    the starts at each point (the least stable attractor found there)."""
    a, b = data.axes[:2]
    val = stability_values(data, what).astype(float)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)      # points with no value at all
        show = np.nanmax(val, axis=-1)
    x, y = data.values[a], data.values[b]
    label, centre = COLOR_BY[what]
    import matplotlib
    import matplotlib.colors as mcolors
    # every start at the point sticks: lambda = -inf, |mu_1| = 0
    stuck = (show == -np.inf) | ((what == "multiplier") & (show == 0.0))
    # the scale spans the 2nd to 98th percentiles (stability_norm): values past it take its
    # end colours (the most stable cycles are not black: black is for sticking alone)
    base = matplotlib.colormaps["coolwarm"]
    cmap = base.with_extremes(under=base(0.0), over=base(1.0))
    rest = np.where(np.isfinite(show) & ~stuck, show, np.nan)
    im = ax.pcolormesh(x, y, rest.T, shading="nearest", cmap=cmap,
                       norm=stability_norm(rest, centre))
    if stuck.any():
        ax.pcolormesh(x, y, np.where(stuck, 1.0, np.nan).T, shading="nearest",
                      cmap=mcolors.ListedColormap(["k"]), vmin=0.0, vmax=2.0)
        ax.fill_between([], [], color="k", label="sticks: " + (
            r"$\lambda_1 = -\infty$" if what == "lyapunov" else r"$|\mu_1| = 0$"))
    fin = show[np.isfinite(show)]
    if fin.size and fin.max() < centre:
        sym = r"\lambda_1" if what == "lyapunov" else r"|\mu_1|"
        ax.text(0.99, 0.01, f"every attractor found is stable: ${sym}$ < {centre:g} "
                f"(max {fin.max():.3g})", transform=ax.transAxes, ha="right", va="bottom",
                fontsize=7, color="0.15", bbox=dict(fc="w", ec="none", alpha=0.7))
    ax.set_xlabel(LABELS.get(a, a))
    ax.set_ylabel(LABELS.get(b, b))
    draw_plane_curves(ax, data)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", fontsize=7)
    return im


# ------------------------------------------------------------------ continuation branches
EVENT_MARKERS = {"corner": ("D", "tab:red", "corner collision"),
                 "fold": ("^", "tab:purple", "fold"),
                 "period_doubling": ("s", "tab:orange", "period doubling"),
                 "torus": ("o", "tab:green", "torus"),
                 "grazing": ("X", "tab:blue", "grazing"),
                 "zero_velocity": ("v", "tab:brown", "zero-velocity impact")}
BRANCH_Y = {"impact_u": "impact_u", "impact_v": "impact_v_in", "section_u": "section_u",
            "section_v": "section_v"}


def is_continuation(path) -> bool:
    """Whether ``path`` is a ``cornerbif continue`` file (root attribute ``format``; a
    FIFO or a device is never opened: ``outputs.hdf5_format``)."""
    from .outputs import CONTINUATION_FORMAT, hdf5_format
    return hdf5_format(path) == CONTINUATION_FORMAT


# what a continuation file's branch holds per point, beside its parameter values
BRANCH_ARRAYS = ("impact_u", "impact_v_in", "section_u", "section_v", "stable",
                 "multiplier_re", "multiplier_im")


def read_continuation(path) -> dict:
    """A continuation file for a figure or ``info``: ``continuation_run.read``, with "path", once
    ``io.open_checked`` has found it a regular HDF5 file of format
    ``cornerbif-continuation`` this version reads, referring to no other file (links,
    external storage, virtual datasets), within memory; then each branch's datasets one row
    per point of its parameter values (finite), the events' and curves' likewise
    (``_check_continuation``).  Else ``FileFormatError`` naming the file."""
    from .continuation_run import FORMAT, FORMAT_VERSION, read
    from .io import FileFormatError, error_line, open_checked
    path = str(path)
    with open_checked(path, FORMAT, FORMAT_VERSION):
        pass
    try:
        cont = read(path)
        _check_continuation(cont)
    except Exception as e:  # noqa: BLE001 - h5py's and a crafted file's zoo of errors
        raise FileFormatError(f"{path}: a damaged continuation file ({error_line(e, path)})") \
            from None
    cont["path"] = path
    return cont


def _check_continuation(cont):
    """What the figures and ``info`` need of a continuation file (``read_continuation``);
    a ValueError says what is not so."""
    if not cont["parameter"] or not isinstance(cont["parameter"], str):
        raise ValueError("no parameter")
    tomllib.loads(cont["scene"])
    for b, br in enumerate(cont["branches"]):
        lam = np.asarray(br.get("param"))
        if lam.ndim != 1 or lam.size == 0 or lam.dtype.kind != "f" or not np.isfinite(lam).all():
            raise ValueError(f"branch {b}: its parameter values are not a list of numbers")
        if "stable" not in br:
            raise ValueError(f"branch {b}: no 'stable'")
        for key in BRANCH_ARRAYS:
            v = br.get(key)
            if v is None:
                continue
            if not (isinstance(v, np.ndarray) and v.ndim in (1, 2) and v.shape[0] == lam.size
                    and v.dtype.kind in "fiub"):
                raise ValueError(f"branch {b}: {key} does not hold one row per point")
    for e in cont["events"]:
        if not (0 <= e["branch"] < len(cont["branches"])):
            raise ValueError(f"an event of branch {e['branch']}, which the file does not hold")
    for k, cv in enumerate(cont["curves"]):
        x, y = np.asarray(cv.get("param")), np.asarray(cv.get("event_param"))
        if x.ndim != 1 or x.shape != y.shape or x.dtype.kind != "f" or y.dtype.kind != "f":
            raise ValueError(f"curve {k}: its two parameters' values do not match")
        if not (0 <= int(cv.get("branch", -1)) < len(cont["branches"])):
            raise ValueError(f"curve {k}: of a branch the file does not hold")


def continuation_note(cont) -> str:
    """What a figure or ``info`` says of a continuation file that is not finished ("" when
    it is)."""
    if cont["attrs"].get("completed"):
        return ""
    n = len(cont["branches"])
    return (f"partial continuation: {n} branch{'' if n == 1 else 'es'} finished "
            "(cornerbif continue SCENE -o OUT --resume completes it)")


def _runs(mask):
    """(start, stop) of the runs of True in a boolean array."""
    out, i = [], 0
    while i < len(mask):
        if mask[i]:
            j = i
            while j < len(mask) and mask[j]:
                j += 1
            out.append((i, j))
            i = j
        else:
            i += 1
    return out


def _word_label(word) -> str:
    """A cycle word in the paper's notation (b^3 g -> beta^3 gamma; '?' when unknown); a
    file's word of other characters is shown as it is (``plain``)."""
    w = str(word) if word else ""
    if not w:
        return "?"
    if set(w.partition("#")[0]) - set(WORD_LETTERS.decode()):
        return plain(w)
    return plot_attractors.label_tex(w)


def branch_colors(conts) -> dict:
    """A colour per branch word, the one its orbit has in every diagram
    (``plot_attractors.attractor_colors``: beta blue, alpha orange, gamma green)."""
    return plot_attractors.attractor_colors([str(br["word"]) for c in conts
                                             for br in c["branches"]])


def draw_branches(ax, cont: dict, y="impact_u", colors=None):
    """Continued branches over a diagram: each impact's height (or the section state, or
    the impact velocity) against the parameter, one colour per branch (its word in the
    legend), stable solid, unstable dashed, events marked."""
    key = BRANCH_Y.get(y)
    if key is None:
        raise ValueError(f"branches draw y = {', '.join(BRANCH_Y)}, not {y!r}")
    colors = colors or branch_colors([cont])
    arts = []
    seen = set()
    any_unstable = False
    for b, br in enumerate(cont["branches"]):
        color = colors[str(br["word"])]
        x = br["param"]
        vals = br.get(key)
        if vals is None:                 # a branch that stores other values
            continue
        vals = vals[:, None] if vals.ndim == 1 else vals
        st = br["stable"].astype(bool)
        any_unstable |= not st.all()
        label = f"branch {b}: {_word_label(br['word'])}"
        for q in range(vals.shape[1]):
            for stable in (True, False):
                m = st if stable else ~st
                # segments include the neighbour point so that solid and dashed join; a
                # branch of one point (it ended where it started) is a marker
                for a, e in _runs(m):
                    lo, hi = max(a - 1, 0), min(e + 1, len(x))
                    arts += ax.plot(x[lo:hi], vals[lo:hi, q], "-" if stable else "--",
                                    color=color, lw=1.1, marker="." if len(x) == 1 else None,
                                    label=None if label in seen else label)
                    seen.add(label)
    if any_unstable:
        arts += ax.plot([], [], "--", color="0.3", lw=1.1, label="unstable (dashed)")
    for e in cont["events"]:
        if e["kind"] not in EVENT_MARKERS:
            continue
        mk, c, lab = EVENT_MARKERS[e["kind"]]
        if key in e and np.isfinite(e[key]):
            vals = e[key]
        else:
            br = cont["branches"][e["branch"]]
            if key not in br:
                continue
            i = int(np.argmin(np.abs(br["param"] - e["param"])))
            vals = br[key][i] if br[key].ndim == 1 else br[key][i].min()
        arts += ax.plot([e["param"]], [vals], mk, color=c, ms=6, mec="k", mew=0.5,
                        label=None if lab in seen else lab, zorder=5)
        seen.add(lab)
    return arts


def figure_branches(paths, out, y=None, title=None, plot_cfg=None, style=None, color_by=None):
    """Continuation files drawn alone: branches against the parameter, and the corner
    curves in the plane of the two parameters when the files have them; in the project's
    style with the user's sheet over it (``style``, or ``[plot] style``), ``[plot] ylim``
    the window of the branches' panel.  ``check_together`` first: files continued in one
    parameter of one model, a ``y`` they store; ``color_by`` is refused (a branch is
    drawn stable solid, unstable dashed)."""
    from . import plot_style
    conts = [read_continuation(p) for p in paths]
    scene = tomllib.loads(conts[0]["scene"])
    if plot_cfg is None:                 # the first file's scene, as a sweep's figure
        plot_cfg = scene.get("plot", {})
    check_together([], conts, y=y, color_by=color_by, plot_cfg=plot_cfg)
    with plot_style.style(style or plot_cfg.get("style")), quiet():
        return _figure_branches(conts, scene, out, y, title, plot_cfg)


def branch_keys(conts) -> set:
    """The values the branches of ``conts`` store per point (``BRANCH_Y``'s values)."""
    return {k for c in conts for b in c["branches"] for k in b if k in BRANCH_Y.values()}


def own_branch_y(conts) -> str:
    """What branches draw by default: impact heights, else the section's velocity."""
    have = branch_keys(conts)
    return "impact_u" if "impact_u" in have or not have else "section_v"


def _figure_branches(conts, scene, out, y, title, plot_cfg):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    curves = any(c["curves"] for c in conts)
    fig, axs = plt.subplots(1, 2 if curves else 1, figsize=(12 if curves else 7, 4.5),
                            dpi=150, squeeze=False)
    ax = axs[0, 0]
    own = own_branch_y(conts)
    kind = y or plot_cfg.get("y") or own
    if BRANCH_Y.get(kind) not in branch_keys(conts):
        kind = own                      # the scene's [plot] y is a diagram's (check_together)
    plot_cfg = cfg_for_y(plot_cfg, kind, own)      # the scene's ylim is for its own y
    title = title or plot_cfg.get("title")
    colors = branch_colors(conts)
    for c in conts:
        draw_branches(ax, c, kind, colors)
    if "ylim" in plot_cfg:
        ax.set_ylim(*plot_cfg["ylim"])
    name = conts[0]["parameter"]
    ax.set_xlabel(LABELS.get(name, plain(name)))
    sc = scene.get("scene", {})
    ax.set_ylabel(y_label(kind, sc.get("model")))
    legend(ax, loc="best", fontsize=7)
    notes = [n for n in (continuation_note(c) for c in conts) if n]
    if not any(c["branches"] for c in conts):
        notes.append("no branch: the continuation found no orbit to follow from its start")
    if notes:
        ax.text(0.5, 0.5, "\n".join(title_lines(n, 60) for n in notes), transform=ax.transAxes,
                ha="center", va="center", fontsize=7, color="tab:red")
    if curves:
        draw_corner_curves_continued(axs[0, 1], conts, colors)
    fig.suptitle(title_lines(title or sc.get("title", ""), 100), fontsize=9)
    fig.tight_layout()
    return save(fig, out)


def draw_corner_curves_continued(ax, conts, colors=None):
    """The corner-collision and fold curves continued in two parameters, with eqs (11)
    and (17) where the plane is (omega, kappa) on the rectified sine; each curve in its
    branch's colour (``colors``: word -> colour, default ``branch_colors``)."""
    colors = colors or branch_colors(conts)
    arts = []
    names = None
    for c in conts:
        for cv in c["curves"]:
            x, yv = cv["param"], cv["event_param"]
            b = int(cv["branch"])
            word = c["branches"][b]["word"]
            names = (str(cv.get("param_name", "omega")), str(cv.get("event_param_name",
                                                                    c["parameter"])))
            what = ("fold" if str(cv.get("kind", "corner")) == "fold"
                    else f"{cv['what']} at its corner")
            arts += ax.plot(x, yv, "-", color=colors[str(word)], lw=1.2,
                            label=f"branch {b} ({_word_label(word)}): {what}, continued")
    sys_ = tomllib.loads(conts[0]["scene"]).get("system", {})
    cv0 = next(cv for c in conts for cv in c["curves"])
    if names == ("omega", "kappa") and obstacle_kind(sys_).normal_form:
        r, beta = sys_.get("r", 0.8), sys_.get("beta", 1.0)
        w = np.linspace(cv0["param"].min(), cv0["param"].max(), 300)
        arts += ax.plot(w, [theory.kappa_C(t, r, beta) for t in w], ":", color="tab:red",
                        lw=2, label=r"$\kappa_C$, eq (11)")
        arts += ax.plot(w, [theory.kappa_CC(t, r, beta) for t in w], ":", color="tab:blue",
                        lw=2, label=r"$\kappa_{CC}$, eq (17)")
    ax.set_xlabel(LABELS.get(names[0], plain(names[0])))
    ax.set_ylabel(LABELS.get(names[1], plain(names[1])))
    legend(ax, loc="best", fontsize=7)
    return arts


# how a run that reached no cycle ended, by its status (cornerbif.status; -1: not run)
ENDINGS = {S.OK: "ended without one (chaos, or a period too long for the record)",
           S.NO_IMPACT: "never impacted (within the time budget)",
           S.STUCK: "stuck to the obstacle",
           S.MAX_EVENTS: "spent the event budget (chattering)",
           S.ESCAPED: "escaped (amplitude past the escape bound)",
           S.BELOW_OBSTACLE: "started below the obstacle",
           S.STEP_LIMIT: "ran out of root-search steps",
           S.NONFINITE: "reached a non-finite state",
           -1: "not run"}


def status_name(code: int, names=None) -> str:
    """A run's status in the file's words (``names``: its ``status_codes``, else
    ``status.NAMES``): -1 is NOT_RUN, a code neither knows 'unknown (N)'."""
    code = int(code)
    if code == -1:
        return "NOT_RUN"
    name = (names or S.NAMES).get(str(code) if names else code)
    return bounded(name, 40) if name else f"unknown ({code})"


def endings(status, no_cycle) -> str:
    """How the runs ``no_cycle`` (a mask) that reached no cycle ended, by status, most
    first: '3 ended without one (chaos, ...), 2 escaped (...)'; '' when there are none."""
    codes, counts = np.unique(np.asarray(status)[no_cycle], return_counts=True)
    order = sorted(zip(counts.tolist(), codes.tolist()), key=lambda t: (-t[0], t[1]))
    return ", ".join(f"{n} {ENDINGS.get(c, f'of unknown status {c}')}" for n, c in order)


def attractor_summary(data: PlotData, tex: bool = True) -> str:
    """One line: how many attractors coexist, and where; how the runs without a cycle
    ended, by status (for the figure and ``cornerbif info``).  "No cycle (chaos, or a
    period too long)" is said only of runs that ended well without one."""
    labels, count = data.attractors()
    if count.size == 0:
        return ""
    n = count.size
    k = int(count.max())
    run = data.status != -1                     # a partial file's unfinished points aside
    no_cycle = (labels < 0) & run
    how = endings(data.status, no_cycle)
    if k == 0:
        if not no_cycle.any():
            return "no run finished"
        if (data.status[no_cycle] == S.OK).all():
            return "no start reached a cycle (chaos, or a period too long for the record)"
        return f"no start reached a cycle: of {int(no_cycle.sum())} runs, {how}"
    parts = [f"coexisting attractors: up to {k}"]
    if k >= 2 and data.axes:
        a = data.axes[0]
        where = np.nonzero(count.reshape(len(data.values[a]), -1).max(axis=1) >= 2)[0]
        vals = data.values[a][where]
        parts.append(f"{int((count >= 2).sum())} of {n} points have 2 or more "
                     f"({LABELS.get(a, a) if tex else a} in [{vals.min():.6g}, {vals.max():.6g}])")
    none = int(no_cycle.all(axis=-1).sum())
    if none:
        parts.append(f"{none} points without a cycle")
    if no_cycle.any():
        parts.append(f"runs without a cycle: {how}")
    return "; ".join(parts)


def draw_winding_by_alpha(ax, d: PlotData, ms):
    """The winding number W (the share of gamma among the iterates, section 5.4) with the
    words that hold alpha apart: W orders the words of beta and gamma alone (the
    staircase of Fig. 14); where alpha enters, W no longer says which orbit it is (and
    is 0 on 'a b').  The first parameter value where a word holds alpha is marked."""
    x = d.values[d.axes[0]]
    w = d.y("winding")
    has_a = np.char.find(d.symbols.astype(str), "a") >= 0
    for sel, color, lab in ((~has_a, "k", r"words of $\beta$, $\gamma$ alone"),
                            (has_a, "tab:orange", r"words with $\alpha$: $W$ does not order "
                                                  "them")):
        xs, ys = points(x, np.where(sel, w, np.nan))
        if xs.size:
            ax.plot(xs, ys, ls="none", marker=".", mew=0, ms=ms * 1.5, color=color, label=lab,
                    rasterized=True)
    rows = np.flatnonzero(has_a.reshape(has_a.shape[0], -1).any(axis=1))
    if rows.size:
        first = float(x[rows[0]])
        ax.axvline(first, color="tab:orange", lw=0.8, ls=":",
                   label=rf"$\alpha$ first at {LABELS.get(d.axes[0], d.axes[0])} = {first:.6g}")


def follow_label(d: PlotData) -> str:
    """A followed sweep's legend entry: the way it went along its parameter."""
    a = d.axes[0]
    name = LABELS.get(a, a)
    return (rf"followed up: {name} increasing $\rightarrow$" if d.follow == "up"
            else rf"followed down: {name} decreasing $\leftarrow$")


def draw_marks(ax, plot_cfg: dict):
    """``[plot] marks``: values known from elsewhere (a continuation's corner collision, a
    measured threshold) as dotted vertical lines named in the legend."""
    arts = []
    for x, label in plot_cfg.get("marks", []):
        arts.append(ax.axvline(x, color="0.25", lw=0.8, ls=":", label=f"{label} = {x:.10g}"))
    return arts


def draw_corner_points(ax, data: PlotData, corner_line=True, mono=False):
    """Mark kappa_C and kappa_CC (eqs 11, 17) or omega_C, omega_CC on the swept axis
    (``mono``: in greys, beside curves coloured by attractor)."""
    sys_ = data.scene.get("system", {})
    kind = obstacle_kind(sys_)
    if not kind.normal_form:      # the kind's own marks (a cam's jump speed), if any
        return kind.marks(ax, data.axes, data.values, sys_)
    if not data.axes:
        return []
    a = data.axes[0]
    r = sys_.get("r", 0.8)
    beta = sys_.get("beta", 1.0)
    if r >= 1.0:
        return []
    lo, hi = float(np.min(data.values[a])), float(np.max(data.values[a]))
    marks = []
    if a == "kappa":
        w = sys_.get("omega", 2.0)
        marks = [(theory.kappa_C(w, r, beta), r"$\kappa_C$", "tab:red"),
                 (theory.kappa_CC(w, r, beta), r"$\kappa_{CC}$", "tab:blue")]
    elif a == "omega":
        kap = sys_.get("kappa", 0.0)
        marks = [(theory.omega_C(kap, r, beta), r"$\omega_C$", "tab:red"),
                 (theory.omega_CC(kap, r, beta), r"$\omega_{CC}$", "tab:blue")]
    arts = []
    if a == "kappa" and corner_line:
        # the height of the corner itself, z(t_k) = kappa (the solid line of Fig. 7b)
        arts += ax.plot([lo, hi], [lo, hi], color="0.6", lw=0.6, label=r"corner $z(t_k)=\kappa$")
    for i, (x, lab, c) in enumerate(marks):
        if math.isfinite(x) and lo <= x <= hi:
            arts.append(ax.axvline(x, color="0.3" if mono else c, lw=0.8,
                                   ls=("--", "-.")[i] if mono else "--", label=f"{lab} = {x:.6g}"))
    return arts


def draw_plane(ax, data: PlotData):
    """Two-axis sweep: colour each point by the period of its attractors (the largest over
    the starts), on a log scale: a few long periods (73-75 in the charts near (2, 0)) do
    not press periods 1-20 into one colour.  A mass ratio spanning decades is drawn on a
    log axis, each value's cell between the geometric means with its neighbours."""
    import matplotlib.colors as mcolors
    a, b = data.axes[:2]
    per = data.period.astype(float)
    per[per <= 0] = np.nan
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)   # points where no start found a cycle
        show = np.nanmax(per, axis=-1)
    x, y = data.values[a], data.values[b]
    top = np.nanmax(show) if np.isfinite(show).any() else 2.0
    norm = mcolors.LogNorm(vmin=1.0, vmax=max(2.0, top))
    if b == "mu" and np.all(y > 0) and y.max() / y.min() > 20:
        im = ax.pcolormesh(cell_edges(x), cell_edges(y, log=True), show.T, cmap="viridis",
                           norm=norm)
        ax.set_yscale("log")
    else:
        im = ax.pcolormesh(x, y, show.T, shading="nearest", cmap="viridis", norm=norm)
    ax.set_xlabel(LABELS.get(a, a))
    ax.set_ylabel(LABELS.get(b, b))
    draw_plane_curves(ax, data)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", fontsize=7)
    return im


def cell_edges(v, log=False):
    """The edges of cells centred on the increasing values ``v``: midway between
    neighbours (geometric means with ``log``), the ends as far out as the next edge in."""
    v = np.asarray(v, float)
    if v.size < 2:
        return np.array([v[0] * 0.5, v[0] * 1.5]) if log else np.array([v[0] - 0.5, v[0] + 0.5])
    w = np.log(v) if log else v
    mid = 0.5 * (w[1:] + w[:-1])
    e = np.concatenate([[2 * w[0] - mid[0]], mid, [2 * w[-1] - mid[-1]]])
    return np.exp(e) if log else e


def draw_plane_curves(ax, data: PlotData):
    """The corner curves kappa_C (11) and kappa_CC (17) over an (omega, kappa) plane."""
    a, b = data.axes[:2]
    x, y = data.values[a], data.values[b]
    sys_ = data.scene.get("system", {})
    if {a, b} == {"omega", "kappa"} and obstacle_kind(sys_).normal_form:
        r = sys_.get("r", 0.8)
        beta = sys_.get("beta", 1.0)
        w = np.linspace(x.min(), x.max(), 400) if a == "omega" else np.linspace(y.min(), y.max(), 400)
        kc = [theory.kappa_C(t, r, beta) for t in w]
        kcc = [theory.kappa_CC(t, r, beta) for t in w]
        if a == "omega":
            ax.plot(w, kc, "r-", lw=0.8, label=r"$\kappa_C$ (11)")
            ax.plot(w, kcc, "b-", lw=0.8, label=r"$\kappa_{CC}$ (17)")
            if y.max() > y.min():
                ax.set_ylim(y.min(), y.max())
        else:
            ax.plot(kc, w, "r-", lw=0.8, label=r"$\kappa_C$ (11)")
            ax.plot(kcc, w, "b-", lw=0.8, label=r"$\kappa_{CC}$ (17)")
            if x.max() > x.min():
                ax.set_xlim(x.min(), x.max())
        ax.legend(loc="upper left", fontsize=7)


def _need_table(data: PlotData):
    """Basin images and fractions read the file's attractor table (cornerbif.attractors),
    which a sweep writes when it finishes."""
    if not data.has_table:
        raise Undrawable(f"{data.path}: has no attractor table (written by an older "
                         "cornerbif, or not finished), which this figure draws; "
                         + ("complete the sweep (cornerbif sweep SCENE -o OUT --resume)"
                            if not data.complete else "run its sweep again"))


def coexisting_words(symbols):
    """Number of distinct non-empty cycle words among the starts of each grid point.

    A lower bound on the number of coexisting attractors (the starts are random;
    two attractors with one word count once); 0 where no start found a cycle.
    """
    flat = symbols.reshape(-1, symbols.shape[-1])
    n = np.array([len({w for w in row if w}) for row in flat])
    return n.reshape(symbols.shape[:-1])


def draw_plane_count(ax, data: PlotData):
    """Two-axis sweep: how many distinct attractors (cycle words) the starts found."""
    a, b = data.axes[:2]
    n = coexisting_words(data.symbols).astype(float)
    x, y = data.values[a], data.values[b]
    top = max(int(n.max()), 1)
    import matplotlib.colors as mcolors
    cmap = mcolors.ListedColormap(["0.85", "k", "tab:orange", "tab:red", "tab:purple",
                                   "tab:blue"][: top + 1])
    if b == "mu" and np.all(y > 0) and y.max() / y.min() > 20:
        im = ax.pcolormesh(cell_edges(x), cell_edges(y, log=True), n.T, cmap=cmap,
                           vmin=-0.5, vmax=top + 0.5)
        ax.set_yscale("log")
    else:
        im = ax.pcolormesh(x, y, n.T, shading="nearest", cmap=cmap, vmin=-0.5,
                           vmax=top + 0.5)
    ax.set_xlabel(LABELS.get(a, a))
    ax.set_ylabel(LABELS.get(b, b))
    ax.set_title(f"coexisting attractors found (max {top}; grey: none)", fontsize=8, loc="left")
    draw_plane_curves(ax, data)
    return im


def hausdorff_per_point(y1, y2, decimals=9):
    """Distance between the sets of recorded values at each grid point (1-axis sweeps).

    For each parameter value: the Hausdorff distance between the finite values of
    y1 (all starts and records) and those of y2; NaN where either set is empty.
    """
    n = y1.shape[0]
    out = np.full(n, np.nan)
    for i in range(n):
        a = np.unique(np.round(y1[i][np.isfinite(y1[i])], decimals))
        b = np.unique(np.round(y2[i][np.isfinite(y2[i])], decimals))
        if a.size and b.size:
            d = np.abs(a[:, None] - b[None, :])
            out[i] = max(d.min(axis=1).max(), d.min(axis=0).max())
    return out


def draw_comparison(fig, datas, kind, plot_cfg):
    """Flow against map2d on one parameter axis (paper Fig. 16): both, and their distance."""
    axs = fig.subplots(3, 1, sharex=True, gridspec_kw={"height_ratios": [2, 2, 1]})
    a = datas[0].axes[0]
    for ax, d, tag in zip(axs[:2], datas, "ab"):
        draw_bifurcation(ax, d, kind, ms=plot_cfg.get("marker_size", 0.6))
        ax.set_ylabel(y_label(kind, d.model), fontsize=8)
        ax.set_title(f"({tag}) {d.normal_form.panel if d.normal_form else d.model}", fontsize=8,
                     loc="left")
        if "ylim" in plot_cfg:
            ax.set_ylim(*plot_cfg["ylim"])
    dist = hausdorff_per_point(datas[0].y(kind), datas[1].y(kind))
    shown = np.isfinite(dist) & (dist > 0)
    axs[2].plot(datas[0].values[a][shown], dist[shown], "k.", ms=1.5)
    if shown.any():
        axs[2].set_yscale("log")
    else:
        # a log scale needs a positive distance somewhere
        axs[2].text(0.5, 0.5, "no distance to show: " + (
            "the two agree at every value" if np.isfinite(dist).any()
            else "no parameter value where both hold values"), transform=axs[2].transAxes,
            ha="center", va="center", fontsize=7, color="0.3")
    if (np.isfinite(dist) & (dist == 0)).any() and shown.any():
        axs[2].text(0.99, 0.02, f"equal (distance 0) at {int((dist == 0).sum())} values",
                    transform=axs[2].transAxes, ha="right", va="bottom", fontsize=6,
                    color="0.3")
    axs[2].set_ylabel("distance\nflow to map", fontsize=8)
    axs[2].set_title("(c) their distance at each parameter value (Hausdorff, per point)",
                     fontsize=8, loc="left")
    axs[2].set_xlabel(LABELS.get(a, a))
    return axs


def figure(paths, out, y=None, title=None, plot_cfg=None, color_by=None, branches=(),
           style=None):
    """Draw one or more files of the same kind into ``out`` (png, pdf or svg), in the
    project's style (``plot_style``) with the user's style sheet over it (``style``, or
    ``[plot] style``), continuation files ``branches`` over them.  What the files and
    options ask is checked before anything is drawn (``check_together``); the figure is
    written whole or not at all (``save``).  See ``_figure``."""
    from . import plot_style
    datas = [PlotData(p) for p in paths]
    conts = [read_continuation(b) for b in branches]
    cfg = datas[0].scene.get("plot", {}) if plot_cfg is None else plot_cfg
    check_together(datas, conts, y=y, color_by=color_by, plot_cfg=cfg)
    color_by = color_by or scene_color_by(datas, cfg)
    cfg = cfg_for_y(cfg, y, datas[0].default_y())
    with plot_style.style(style or cfg.get("style")), quiet():
        return _figure(datas, out, y, title, cfg, color_by, conts)


def draw_files(files, out, y=None, title=None, color_by=None, style=None):
    """``cornerbif plot``: the sweeps among ``files`` drawn with the continuation files
    over them (``figure``), or the continuation files alone (``figure_branches``)."""
    conts = [f for f in files if is_continuation(f)]
    sweeps = [f for f in files if f not in conts]
    if sweeps:
        return figure(sweeps, out, y=y, title=title, color_by=color_by, branches=conts,
                      style=style)
    return figure_branches(conts, out, y=y, title=title, style=style, color_by=color_by)


# ------------------------------------------------------------------ what one figure draws
# the [plot] kinds that draw one file, in words
ONE_FILE_KINDS = {"timeseries": "time series of one grid point",
                  "corner_curves": "the corner curves of eqs (11), (17)",
                  "obstacle": "the obstacle's shape",
                  "fractions": "basin fractions against one swept parameter"}


def _described(d: PlotData) -> str:
    """A file as a refusal names it: its path, what it sweeps, its model."""
    what = ("sweeps " + " and ".join(cut(a) for a in d.axes) if d.axes
            else "sweeps no parameter")
    return f"{d.path} {what} (model {cut(d.model)})"


def _held_y(d: PlotData) -> list:
    """The values a diagram of ``d`` can draw against its parameter (``--y``)."""
    return [k for k, n in Y_DATASETS.items() if n in d.data] + ["winding", "period"]


def _cont_model(cont) -> tuple:
    """(model, obstacle) of a continuation file."""
    a = cont["attrs"]
    return str(a.get("model", "")), str(a.get("obstacle", "") or "")


def check_together(datas, conts, y=None, color_by=None, plot_cfg=None):
    """Refuse (``Undrawable``, exit 2), before anything is drawn, files and options that one
    figure cannot show truthfully.  One figure draws:

    * one file, as its scene's ``[plot] kind`` says;
    * diagrams of one swept parameter overlaid: files of one model sweeping the same
      parameter (followed up and down, Fig. 7(b); scenes compared), each named in the
      legend;
    * a flow against its map (sections 4-5; ``gallery.GROUPS`` fig09, fig10, fig11, fig16):
      two files, of models flow and map2d, at the same system values and of one ``[plot]
      kind``: a diagram of the same swept values (Fig. 16; their distance per value), or
      single runs (regions of the same starts, Fig. 9; return maps, Fig. 10; orbits, Fig. 11);
    * continuation files over a diagram of the parameter they are continued in (same model
      and obstacle), or alone: files continued in one parameter of one model.

    ``y`` (``--y``) is what a diagram or branches draw against the parameter: every file
    must hold it.  ``color_by`` (``--color-by``) colours one file's diagram or chart by its
    stability datasets.  A chart (two swept parameters), a basin and the one-file kinds
    draw one file.
    """
    from .io import check_stored_plot
    for c in conts:
        check_stored_plot(c["path"], c["scene"])
    if not datas:
        return _check_branches_alone(conts, y, color_by)
    for d in datas:
        if getattr(d, "scene_text", None):
            check_stored_plot(d.path, d.scene_text)
        if d.unplaceable:
            raise Undrawable(d.unplaceable)
    cfg = datas[0].scene.get("plot", {}) if plot_cfg is None else plot_cfg
    kind = cfg.get("kind", "diagram")
    if kind in plot_normal_form.KINDS:
        _check_single_runs(datas, conts, kind, y, color_by, plot_cfg)
    elif kind in ONE_FILE_KINDS:
        if len(datas) > 1:
            raise Undrawable(f"[plot] kind {kind!r} ({ONE_FILE_KINDS[kind]}) draws one file; "
                             f"got {_all_described(datas)}")
        if kind == "fractions" and len(datas[0].axes) != 1:
            raise Undrawable(f"{_described(datas[0])}: [plot] kind 'fractions' draws a file "
                             "swept over one parameter")
        _no_options(kind, y, color_by, conts, datas)
    elif kind != "diagram":
        raise Undrawable(f"{datas[0].path}: [plot] kind {cut(kind)!r} is not a figure this "
                         "cornerbif draws")
    else:
        for d in datas:
            if not d.axes:
                raise Undrawable(f"{_described(d)}: nothing to draw as a diagram (a scene of "
                                 "single runs is drawn by [plot] kind timeseries, regions, "
                                 "return_map or orbit)")
            if len(d.axes) > 2:
                raise Undrawable(f"{_described(d)}: a figure draws one or two swept "
                                 "parameters")
        if any(len(d.axes) == 2 for d in datas):
            _check_chart(datas, conts, y, color_by)
        else:
            _check_diagrams(datas, conts, cfg, y, color_by)


def _all_described(datas) -> str:
    """The files of a refusal, each ``_described``."""
    return "; ".join(_described(d) for d in datas)


def check_scenes_drawable(sweeps, conts=(), plot_cfg=None):
    """``check_together`` for a figure not yet swept (``cornerbif gallery``'s plan): the
    same rules, on what each file will hold, known from its scene alone.  ``sweeps`` and
    ``conts``: (name for messages, ``config.Scene``) of the sweep and continuation files
    the figure draws.  A sweep's stand-in holds its scene, swept values, model, the
    datasets its ``output.keep`` writes (``spec.fields``) and its starts as their
    ``[initial]`` count, seed and box (one draw each: the same three, the same starts); a
    continuation's holds its parameter, model, obstacle and scene, its branches unknown
    (what they store is checked when drawn).  What only a file can say (a flag a newer
    ``PlotData`` sets) reads as None here.  ``Undrawable`` as ``check_together``."""
    class _Will:
        def __init__(self, name, sc):
            self.path, self.scene = str(name), tomllib.loads(sc.text)
            self.axes = [a.name for a in sc.axes]
            self.values = {a.name: a.array for a in sc.axes}
            far = [a for a in self.axes if np.abs(self.values[a]).max(initial=0.0) > DRAW_LIMIT]
            self.unplaceable = (f"{self.path}: its swept parameter {cut(far[0])!r} has values "
                                f"beyond {DRAW_LIMIT:g} in size, which no figure can place"
                                if far else None)
            self.model, self.spec = sc.model, registry.models().get(sc.model)
            self.normal_form = self.spec.normal_form if self.spec else None
            self.data = {f.name: None for f in sc.spec.fields(sc.keep)} if self.spec else {}
            self.stability = {}
            self.initial = {k: np.array([sc.n_ic, sc.seed, *sc.initial.get(k, (np.nan,) * 2)],
                                        dtype=float) for k in ("u", "v")}
        default_y = PlotData.default_y

        def __getattr__(self, name):
            return None
    wills = [_Will(n, sc) for n, sc in sweeps]
    cs = [{"path": str(n), "parameter": sc.cont["parameter"], "scene": sc.text, "branches": [],
           "attrs": {"model": sc.model, "obstacle": sc.obstacle}} for n, sc in conts]
    check_together(wills, cs, plot_cfg=plot_cfg)


def _sides(datas) -> set:
    """Which sides of the normal-form figures the files are: maps or not (None: neither)."""
    return {d.normal_form.maps if d.normal_form else None for d in datas}


def _flow_and_map(datas) -> bool:
    """Whether ``datas`` are a flow and its map (two files, of the roles flow and map)."""
    return len(datas) == 2 and _sides(datas) == {False, True}


def _check_single_runs(datas, conts, kind, y, color_by, plot_cfg):
    """The normal-form kinds (regions, return maps, orbits: sections 4-5) draw single runs
    of a flow or map2d file, or a flow against its map: at the same system values, in one
    kind, the regions of the same starts."""
    pair = _flow_and_map(datas)
    for d in datas:
        if d.axes:
            raise Undrawable(f"{_described(d)}: [plot] kind {kind!r} draws single runs (a "
                             "scene without sweep axes: sections 4-5)")
        if d.normal_form is None:
            raise Undrawable(f"{_described(d)}: [plot] kind {kind!r} draws a flow or "
                             "map2d file")
    if len(datas) > 1 and not pair:
        raise Undrawable(f"[plot] kind {kind!r} draws one file, or a flow against its map "
                         f"(one file of model flow, one of map2d); got {_all_described(datas)}")
    if pair:
        other = datas[1].scene.get("plot", {}).get("kind", "diagram")
        if plot_cfg is None and other != kind:
            raise Undrawable(f"{datas[0].path} is drawn as [plot] kind {kind!r}, "
                             f"{datas[1].path} as {cut(other)!r}: a flow is drawn "
                             "against its map in one kind")
        _check_one_system(*datas)
        if kind == "regions":
            _check_same_starts(*datas)
    _no_options(kind, y, color_by, conts, datas)


def _check_chart(datas, conts, y, color_by):
    """A chart (two swept parameters) or a basin image (two swept starts) draws one file,
    coloured by its periods or attractors (``color_by``: by its stability datasets, a chart
    only); no branches, no --y."""
    d0 = datas[0]
    basin = all(a.startswith("initial.") for a in d0.axes)
    what = "a basin image (two swept starts)" if basin else "a chart (two swept parameters)"
    if len(datas) > 1:
        raise Undrawable(f"{what} draws one file; got {_all_described(datas)}")
    if conts:
        raise Undrawable(f"{conts[0]['path']}: continuation branches are drawn over a "
                         f"diagram of one swept parameter; {_described(d0)}")
    if y:
        raise Undrawable(f"--y {y}: {d0.path} is drawn as {what}, which colours each point "
                         "(by its period or attractor); --y chooses what a diagram of one "
                         "swept parameter draws")
    if color_by and basin:
        raise Undrawable(f"--color-by {color_by}: {d0.path} is drawn as {what}, coloured "
                         "by each start's attractor")
    if color_by:
        _check_stability(d0, color_by)


def _check_diagrams(datas, conts, cfg, y, color_by):
    """Diagrams of one swept parameter overlaid: the same parameter, one model (or a flow
    against its map over the same values), ``color_by`` of one file, the y drawn held by
    every file, and the branches over them of that parameter and system."""
    d0 = datas[0]
    names = _all_described(datas)
    pair = _flow_and_map(datas)
    if len({d.axes[0] for d in datas}) > 1:
        raise Undrawable(f"files drawn on one axis sweep the same parameter; got {names}")
    if len({d.model for d in datas}) > 1 and not pair:
        raise Undrawable("files of different models are drawn together only as a flow against "
                         f"its map (two files: model flow and model map2d); got {names}")
    if pair:
        _check_one_system(*datas)
        a = d0.axes[0]
        va, vb = datas[0].values[a], datas[1].values[a]
        if va.shape != vb.shape or not np.allclose(va, vb, rtol=1e-12, atol=0.0):
            raise Undrawable(f"{datas[0].path} and {datas[1].path} sweep {cut(a)} over "
                             "different values: a flow is compared with its map value by value "
                             "(sweep both over the same values)")
        if conts:
            raise Undrawable(f"{conts[0]['path']}: continuation branches are not drawn on a "
                             "flow against its map; draw them over one of the two")
    if color_by and len(datas) > 1:
        raise Undrawable(f"--color-by {color_by}: colours the runs of one file; "
                         f"{len(datas)} files are drawn together ({names})")
    if color_by:
        _check_stability(d0, color_by)
    ykind = y or ("section_v" if pair else cfg.get("y") or d0.default_y())
    for d in datas:
        if ykind is None or ykind not in _held_y(d):
            raise Undrawable(f"{d.path}: holds no {ykind or 'recorded'} values to draw (it holds "
                             f"{', '.join(_held_y(d))}; impact values need output.keep "
                             "\"impacts\", section values \"section\")")
    for c in conts:
        _check_branches_over(c, d0, ykind)


def _check_branches_over(cont, d0: PlotData, ykind):
    """A continuation file drawn over the diagram of ``d0``: continued in its parameter, of
    its model and obstacle, storing ``ykind``."""
    p = d0.axes[0]
    if cont["parameter"] != p:
        raise Undrawable(f"{cont['path']}: its branches are continued in "
                         f"{cut(cont['parameter'])!r}; {_described(d0)}: branches are drawn "
                         "over a diagram of the parameter they are continued in")
    model, obstacle = _cont_model(cont)
    own = str(d0.scene.get("system", {}).get("obstacle", "") or "")
    if model != d0.model or (obstacle and own and obstacle != own):
        raise Undrawable(f"{cont['path']} continues orbits of model {cut(model)}"
                         + (f", obstacle {cut(obstacle)}" if obstacle else "")
                         + f"; {_described(d0)}" + (f", obstacle {cut(own)}" if own else "")
                         + ": branches are drawn over a diagram of their own system")
    _same_system(cont["path"], tomllib.loads(cont["scene"]), d0.path, d0.scene, {p},
                 "branches are drawn over the diagram of their own system")
    if cont["branches"] and BRANCH_Y.get(ykind) not in branch_keys([cont]):
        stored = [k for k, v in BRANCH_Y.items() if v in branch_keys([cont])]
        raise Undrawable(f"{cont['path']}: its branches store {', '.join(stored) or 'no values'}"
                         f", not {ykind} (the diagram's y); choose one of these with --y, or "
                         "draw the diagram alone")


def _check_branches_alone(conts, y, color_by):
    """Continuation files drawn alone: one parameter, one model, ``y`` stored."""
    if color_by:
        raise Undrawable(f"--color-by {color_by}: continuation files are drawn stable solid, "
                         "unstable dashed (from each point's multipliers); --color-by colours "
                         "the runs of a sweep kept with \"stability\"")
    described = "; ".join(f"{c['path']} continues in {cut(c['parameter'])} (model "
                          f"{cut(_cont_model(c)[0])})" for c in conts)
    if len({c["parameter"] for c in conts}) > 1 or len({_cont_model(c)[0] for c in conts}) > 1:
        raise Undrawable("continuation files drawn together are continued in one parameter of "
                         f"one model; got {described}")
    have = branch_keys(conts)
    if y and have and BRANCH_Y.get(y) not in have:
        raise Undrawable(f"--y {y}: the branches of {', '.join(c['path'] for c in conts)} store "
                         + ", ".join(k for k, v in BRANCH_Y.items() if v in have))


def _no_options(kind, y, color_by, conts, datas):
    """The one-file and normal-form kinds draw what their kind says: no --y, no
    --color-by, no branches over them."""
    files = " and ".join(d.path for d in datas)
    drawn = f"{files} {'are' if len(datas) > 1 else 'is'} drawn as [plot] kind {kind!r}"
    if y:
        raise Undrawable(f"--y {y}: {drawn}, which chooses what it draws; --y is for "
                         "diagrams of one swept parameter")
    if color_by:
        raise Undrawable(f"--color-by {color_by}: {drawn}; --color-by colours a diagram or a "
                         "chart")
    if conts:
        raise Undrawable(f"{conts[0]['path']}: continuation branches are drawn over a diagram "
                         f"of one swept parameter; {drawn}")


def _check_stability(d: PlotData, what):
    """``--color-by what`` needs the file's stability datasets."""
    if what not in COLOR_BY:
        raise Undrawable(f"color_by: {cut(what)!r} is not allowed; allowed: "
                         + ", ".join(COLOR_BY))
    if what not in d.stability:
        raise Undrawable(f"--color-by {what}: {d.path} has no stability/ datasets to colour by; "
                         "re-run its scene with output.keep containing \"stability\"")


def scene_color_by(datas, cfg):
    """The scene's ``[plot] color_by`` where it applies (one file's diagram or chart, kept with
    its stability datasets), else None: a scene's default never refuses a figure."""
    what = cfg.get("color_by")
    d0 = datas[0]
    if (what in COLOR_BY and len(datas) == 1 and cfg.get("kind", "diagram") == "diagram"
            and len(d0.axes) in (1, 2) and what in d0.stability
            and not all(a.startswith("initial.") for a in d0.axes)):
        return what
    return None


def _check_one_system(a: PlotData, b: PlotData):
    """A flow and its map compared: the same values of the system's keys they share (the
    swept ones aside)."""
    _same_system(a.path, a.scene, b.path, b.scene, set(a.axes) | set(b.axes),
                 "a flow is compared with its map at the same system values")


def _same_system(pa, scene_a, pb, scene_b, swept, why):
    """Refuse two files whose scenes give a system key they share (``swept`` aside)
    different values; ``why`` says why they must agree."""
    sa, sb = scene_a.get("system", {}), scene_b.get("system", {})
    if not (isinstance(sa, dict) and isinstance(sb, dict)):
        return
    for key in sorted(set(sa) & set(sb) - set(swept)):
        va, vb = sa[key], sb[key]
        same = (math.isclose(va, vb, rel_tol=1e-12, abs_tol=0.0)
                if all(isinstance(v, (int, float)) for v in (va, vb)) else va == vb)
        if not same:
            raise Undrawable(f"{pa} and {pb} are not one system: {cut(key)} = "
                             f"{cut(va)} and {cut(vb)}; {why}")


def _check_same_starts(a: PlotData, b: PlotData):
    """The regions of a flow and its map are compared start by start."""
    same = all(k in a.initial and k in b.initial and a.initial[k].shape == b.initial[k].shape
               and np.allclose(a.initial[k], b.initial[k], rtol=1e-12, atol=0.0,
                               equal_nan=True) for k in ("u", "v"))
    if not same:
        raise Undrawable(f"{a.path} and {b.path} do not hold the same starts: the regions of a "
                         "flow and its map are compared start by start (the same [initial] "
                         "count, seed and box)")


def cfg_for_y(cfg: dict, y, default_y) -> dict:
    """The ``[plot]`` table for a figure of ``y`` (``--y``): the scene's ``ylim`` is a
    window in the scene's own y (``[plot] y``, else the file's default), so it is dropped
    when another y is drawn."""
    own = cfg.get("y") or default_y
    if y and "ylim" in cfg and y != own:
        return {k: v for k, v in cfg.items() if k != "ylim"}
    return cfg


def _figure(datas, out, y=None, title=None, plot_cfg=None, color_by=None, branches=()):
    """Draw one or more files of the same kind (``datas``, their PlotData, passed by
    ``check_together``) into ``out`` (png, pdf or svg).

    ``plot_cfg`` replaces the file's ``[plot]`` table (the gallery passes the
    committed scene's, so a figure setting never forces a new sweep).
    ``[plot] kind``: "diagram" (default: bifurcation diagram or parameter plane),
    "timeseries" (Figs 1b, 5, 6d, 17) or "corner_curves" (Fig. 7a).
    ``color_by`` (or ``[plot] color_by``): "lyapunov" or "multiplier" colours a diagram's
    points, or the left panel of an (omega, kappa) chart, by the run's stability.
    ``branches``: continuation files (``read_continuation``) drawn over a diagram.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d0 = datas[0]
    plot_cfg = d0.scene.get("plot", {}) if plot_cfg is None else plot_cfg
    kind_ = plot_cfg.get("kind", "diagram")
    if color_by is not None and color_by not in COLOR_BY:
        raise Undrawable(f"color_by: {cut(color_by)!r} is not allowed; allowed: "
                         + ", ".join(COLOR_BY))
    if kind_ in plot_normal_form.KINDS:
        return plot_normal_form.figure(datas, out, plot_cfg, title)
    if kind_ in ("timeseries", "corner_curves", "obstacle"):
        if kind_ == "timeseries":
            fig, _ = figure_timeseries(plt, d0, plot_cfg, title)
        elif kind_ == "obstacle":
            fig = figure_obstacle(plt, d0, plot_cfg, title)
        else:
            fig = figure_corner_curves(plt, d0, plot_cfg, title)
        _partial_notes(fig, datas)
        return save(fig, out)
    if _flow_and_map(datas) and len(d0.axes) == 1:
        return _figure_flow_and_map(plt, datas, out, y, title, plot_cfg)
    fig, ax = _panels(plt, d0, kind_, color_by)
    diagram = len(d0.axes) == 1 and kind_ != "fractions"
    if diagram:
        _draw_diagram(fig, ax, datas, y, plot_cfg, color_by, list(branches))
    if "xlim" in plot_cfg:
        ax.set_xlim(*plot_cfg["xlim"])
    if "ylim" in plot_cfg:
        ax.set_ylim(*plot_cfg["ylim"])
    sc = d0.scene.get("scene", {})
    ax.set_title(title_lines(title or plot_cfg.get("title")
                             or sc.get("title", sc.get("name", "")), 80), fontsize=9)
    _partial_notes(fig, datas, list(branches) if diagram else ())
    fig.tight_layout()
    return save(fig, out)


def _figure_flow_and_map(plt, datas, out, y, title, plot_cfg):
    """A flow's diagram against its map's, value by value (Fig. 16: ``draw_comparison``)."""
    datas.sort(key=lambda d: d.normal_form.order)
    fig = plt.figure(figsize=(7, 7), dpi=150)
    draw_comparison(fig, datas, y or "section_v", plot_cfg)
    sc = datas[1].scene.get("scene", {})
    fig.suptitle(title_lines(title or plot_cfg.get("title") or sc.get("title", ""), 80),
                 fontsize=9)
    _partial_notes(fig, datas)
    fig.tight_layout()
    return save(fig, out)


def _panels(plt, d0: PlotData, kind_, color_by):
    """The figure and its main axes: a file's basin fractions against its one swept
    parameter, its basin image (two swept starts) or its chart (two swept parameters: the
    period or ``color_by``, and the count of distinct words), drawn whole; for a diagram,
    its axes, empty."""
    basin = len(d0.axes) == 2 and all(a.startswith("initial.") for a in d0.axes)
    if kind_ == "fractions":
        _need_table(d0)
        fig, ax = plt.subplots(figsize=(8, 4.5), dpi=150)
        plot_attractors.draw_fractions(ax, d0.path, d0.values[d0.axes[0]])
        draw_corner_points(ax, d0, corner_line=False, mono=True)
        legend(ax, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
        ax.set_xlabel(LABELS.get(d0.axes[0], d0.axes[0]))
    elif basin:
        _need_table(d0)
        fig, ax = plt.subplots(figsize=(8, 5.2), dpi=150)
        plot_attractors.draw_basin(ax, d0.path, d0.axes, d0.values)
        ax.set_xlabel(axis_label(d0.axes[0], d0.model))
        ax.set_ylabel(axis_label(d0.axes[1], d0.model))
    elif len(d0.axes) == 2:
        fig, (ax, ax2) = plt.subplots(1, 2, figsize=(12, 4.8), dpi=150)
        if color_by:
            im = draw_plane_stability(ax, d0, color_by)
            fig.colorbar(im, ax=ax, label=COLOR_BY[color_by][0] + ", max over starts")
        else:
            im = draw_plane(ax, d0)
            fig.colorbar(im, ax=ax, label="period (clusters per cycle; max over starts; "
                         "log scale)")
        im2 = draw_plane_count(ax2, d0)
        fig.colorbar(im2, ax=ax2, label="distinct cycle words among the starts",
                     ticks=range(int(im2.norm.vmax + 0.5)))
    else:
        fig, ax = plt.subplots(figsize=(8.2, 4.5), dpi=150)
    return fig, ax


@dataclass
class _DiagramValues:
    """What a diagram draws of its files (``_diagram_values``): the y drawn (``kind``), each
    file's values a slab at a time, how many are finite and how many not (escapes), the
    marker size, whether the points are coloured by their orbit's label and rastered, the
    y-window and how many values fall outside it."""
    kind: str
    ys: list
    n_drawn: int
    n_inf: int
    ms: float
    by_label: bool
    raster: bool
    window: tuple | None
    n_out: int


def _diagram_values(fig, datas, y, plot_cfg, color_by, conts) -> _DiagramValues:
    """The values a diagram of one swept parameter draws (``_DiagramValues``), counted and
    windowed a slab at a time (plot_style.Rows) and, past RASTER_POINTS, rastered without
    holding them whole; refused (``Undrawable``, the figure closed) when the files hold
    none of ``y``."""
    from . import plot_style
    d0 = datas[0]
    kind = y or plot_cfg.get("y") or d0.default_y()
    ys = [d.y_rows(kind) for d in datas] if kind else [None]
    if ys[0] is None:
        import matplotlib.pyplot as plt
        plt.close(fig)
        raise Undrawable(f"{d0.path}: the file holds no {kind or 'recorded'} values to draw "
                         "(output.keep of its scene; impact values need \"impacts\", "
                         "section values \"section\")")
    n_drawn = sum(plot_style.count_finite(v) for v in ys if v is not None)
    n_inf = (sum(plot_style.count_infinite(v) for v in ys if v is not None)
             if kind not in ("winding", "period") else 0)
    ms = plot_cfg.get("marker_size") or plot_style.marker_size(n_drawn)
    by_label = (len(datas) == 1 and not color_by and kind not in ("winding", "period")
                and ys[0].ndim == 3 and d0.has_table)
    raster = by_label and n_drawn > plot_style.RASTER_POINTS and not conts
    # the y-window: the scene's, or one that a few outlying points do not set
    # (plot_style.robust_range); what it leaves out is said on the figure
    yall = (ys[0] if len(datas) == 1 else
            np.concatenate([d.y(kind).ravel() for d in datas if d.y(kind) is not None]))
    if "ylim" in plot_cfg:
        lo, hi = plot_cfg["ylim"]
        n_out = plot_style.count_outside(yall, lo, hi)
        window = (lo, hi)
    elif any(c["branches"] for c in conts):
        # continued branches may reach past the sweep's values: the axes take them all
        n_out, window = 0, None
    else:
        win = plot_style.robust_range(yall)
        lo, hi, n_out = win if win else (None, None, 0)
        window = (lo, hi) if win else None
    return _DiagramValues(kind, ys, n_drawn, n_inf, ms, by_label, raster, window, n_out)


def _draw_diagram(fig, ax, datas, y, plot_cfg, color_by, conts):
    """A diagram of one swept parameter: each file's values (coloured by stability, by
    orbit, or one colour per file, followed sweeps each way), the continuation files'
    branches ``conts`` over them, the corner points and the marks; then its labels, its
    notes and its legends (``_label_diagram``)."""
    v = _diagram_values(fig, datas, y, plot_cfg, color_by, conts)
    d0, kind, ms = datas[0], v.kind, v.ms
    if color_by:
        sc = draw_bifurcation_colored(ax, d0, kind, color_by, ms=ms)
        fig.colorbar(sc, ax=ax, label=COLOR_BY[color_by][0], extend="both")
        legend(ax, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2, fontsize=7,
               frameon=False, markerscale=3)
    # a branch takes the colour its orbit has in the diagram (its family's, with
    # families): one colour map for both
    families = plot_cfg.get("orbits") == "families"
    words = [str(br["word"]) for c in conts for br in c["branches"]]
    label_of = {w: plot_attractors.family(w) if families else w for w in words}
    colors_b = branch_colors(conts)
    orbit_handles = []
    if v.by_label:
        shared = {}
        orbit_handles = plot_attractors.draw_diagram_by_label(
            ax, d0.path, d0.values[d0.axes[0]], v.ys[0] if v.raster else d0.y(kind), ms,
            families=families, window=v.window if v.raster else None,
            xlim=plot_cfg.get("xlim"), also=list(label_of.values()), colors_out=shared)
        colors_b = {w: shared[lab] for w, lab in label_of.items()}
    if kind == "winding" and len(datas) == 1 and not color_by:
        draw_winding_by_alpha(ax, d0, ms)
    elif not (color_by or v.by_label):
        _draw_files(ax, datas, kind, ms)
    branch_arts = []
    for cont in conts:
        branch_arts += draw_branches(ax, cont, kind, colors_b)
    if kind in ("impact_u", "impact_height", "winding", "section_v", "period"):
        draw_corner_points(ax, d0, corner_line=kind == "impact_u")
    draw_marks(ax, plot_cfg)
    _label_diagram(ax, datas, v, plot_cfg, color_by, conts, orbit_handles, branch_arts,
                   families)


def _draw_files(ax, datas, kind, ms):
    """Each file's values in a colour of its own, named in the legend when there are
    several; followed sweeps with the way each went in its label, the downward one
    underneath and larger, so that the upward one's jumps stay in sight over it."""
    colors = ["k", "tab:orange", "tab:green", "tab:purple"]
    for i, d in sorted(enumerate(datas), key=lambda item: item[1].follow != "down"):
        lab = None
        if len(datas) > 1:
            lab = (follow_label(d) if d.follow != "none"
                   else plain(d.scene["scene"].get("name", f"file {i + 1}")))
        down = len(datas) > 1 and d.follow == "down"
        draw_bifurcation(ax, d, kind, ms=ms * (1.8 if down else 1.0),
                         color=colors[i % len(colors)], label=lab,
                         by_attractor=len(datas) == 1 and kind not in ("winding", "period"))


def _label_diagram(ax, datas, v: _DiagramValues, plot_cfg, color_by, conts, orbit_handles,
                   branch_arts, families):
    """A diagram's orbit legend (coloured by label), axis labels, ticks and y-window, the
    notes beside it (its attractors, branchless continuations, values outside the window or
    not finite) and the legends of its files and branches."""
    d0 = datas[0]
    if v.by_label:
        lines, names = ax.get_legend_handles_labels()
        legend_title = "orbit (family of words)" if families else "orbit (word)"
        if any("x" in h.get_label() for h in orbit_handles):
            # a corner's cluster of impacts that is none of alpha, beta, gamma (or any
            # cluster, on an obstacle without corners): analysis.detect_cycle
            legend_title += "\n" + r"x: impacts other than $\alpha$, $\beta$, $\gamma$"
        ax.legend(handles=orbit_handles + lines, labels=[h.get_label() for h in
                                                          orbit_handles] + names,
                  loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False,
                  title=legend_title, title_fontsize=7, fontsize=7)
    a = d0.axes[0]
    ax.set_xlabel(LABELS.get(a, a))
    ax.set_ylabel(y_label(v.kind, d0.model if all(d.model == d0.model for d in datas)
                          else None))
    from matplotlib.ticker import MaxNLocator
    ax.xaxis.set_major_locator(MaxNLocator(6))   # long tick labels (1.9996) stay apart
    ax.ticklabel_format(axis="x", useOffset=False)
    if v.window and "ylim" not in plot_cfg:
        ax.set_ylim(*v.window)
    # what the figure holds beside its points, right of the axes below the legend
    # (inside the axes it lay on the data: Fig. 19(a)'s summary over its lowest points)
    notes = [attractor_summary(d0)] if len(datas) == 1 else []
    notes += [f"{os.path.basename(c['path'])}: no branch (the continuation found no orbit "
              "to follow)" for c in conts if not c["branches"]]
    if v.n_out:
        notes.append(f"{v.n_out} of {v.n_drawn} values outside the y window")
    if v.n_inf:
        notes.append(f"{v.n_inf} values not finite or beyond {DRAW_LIMIT:g} in size "
                     "(escapes) are not drawn")
    notes = [n for n in notes if n]
    if notes:
        ax.text(1.02, 0.0, "\n\n".join(title_lines(n, 44) for n in notes),
                transform=ax.transAxes, ha="left", va="bottom", fontsize=6, color="0.3")
    if ax.get_legend_handles_labels()[0] and not color_by and not v.by_label:
        hs, ls = ax.get_legend_handles_labels()
        keep = [(h, lab) for h, lab in zip(hs, ls) if h not in branch_arts]
        # outside the axes: a legend never covers the data (Fig. 1(a) had one over it)
        leg = ax.legend(*zip(*keep), loc="upper left", bbox_to_anchor=(1.01, 1.0),
                        fontsize=7, markerscale=4, frameon=False) if keep else None
        extra = [(h, lab) for h, lab in zip(hs, ls) if h in branch_arts]
        if extra:
            # the branches' own legend, markers at their size
            if leg is not None:
                ax.add_artist(leg)
            ax.legend(*zip(*extra), loc="lower right", fontsize=7, framealpha=0.9)


def _partial_notes(fig, datas, conts=()):
    """A file that is not complete says so at the figure's foot, in red: how many of its
    grid points (or branches) are finished and shown (``PlotData.partial_note``)."""
    several = len(datas) + len(conts) > 1
    notes = [(d.path, d.partial_note()) for d in datas]
    notes += [(c["path"], continuation_note(c)) for c in conts]
    text = "\n".join(f"{plain(os.path.basename(p), 40)}: {n}" if several else n
                      for p, n in notes if n)
    if text:
        fig.text(0.995, 0.005, text, ha="right", va="bottom", fontsize=7, color="tab:red")


# ------------------------------------------------------------------ time series (Figs 1b, 5, 6d, 17)
ROMAN = ("I", "II", "III", "IV", "V", "VI", "VII", "VIII")


def timeseries_choice(data: PlotData, plot_cfg: dict):
    """Grid point and starts a time-series figure shows.

    ``[plot] point`` is the grid index (default: the first point); ``ic`` a list
    of start indices or "distinct" (default): the first start of each distinct
    attractor at that point (``PlotData.attractors``), in rank order.  At most
    ``max_panels`` (default 4) panels.
    """
    point = tuple(plot_cfg.get("point", [0] * len(data.axes)))
    shape = data.done.shape
    if len(point) != len(shape) or not all(isinstance(i, int) and 0 <= i < n
                                           for i, n in zip(point, shape)):
        raise Undrawable(f"{data.path}: plot.point {cut(list(point))} is not a point of its "
                         f"grid (of shape {shape}: one index per swept parameter, from 0)")
    if not data.done[point]:
        raise Undrawable(f"{data.path}: plot.point {list(point)} is not finished "
                         f"({data.partial_note()}); complete the sweep, or choose a finished "
                         "point")
    labels, _ = data.attractors()
    lab = labels[point]
    ic = plot_cfg.get("ic", "distinct")
    if ic == "distinct":
        chosen = []
        for rank in range(int(lab.max()) + 1 if lab.size else 0):
            chosen.append(int(np.nonzero(lab == rank)[0][0]))
        if not chosen:   # no cycle anywhere: the first start
            chosen = [0]
    else:
        chosen = [int(i) for i in ic]
    n = lab.shape[-1]
    bad = [i for i in chosen if not 0 <= i < n]
    if bad:
        raise ValueError(f"{data.path}: plot.ic: {bad} out of range; the file has starts 0..{n - 1}")
    return point, chosen[: int(plot_cfg.get("max_panels", 4))], lab


def draw_timeseries(ax, path, point, ic, cycles=2.0, color="k", label=None):
    """u(t) and z(t) over ``cycles`` cycles of the attractor reached by start ``ic``.

    Rebuilt from the stored impacts by exact free flight (``cornerbif.models.flow.timeseries``);
    impacts are marked.  Time is counted from the section t0 = nT (T = 2 pi/omega)
    before the first recorded impact.  Returns a dict of what was drawn and measured.
    """
    from . import config as C
    from .models.flow import timeseries as TR
    with check_readable(path) as f:
        scene = C.loads(f.attrs["scene"])
        if not scene.spec.timeseries:
            which = " or ".join(repr(m.name) for m in registry.models().values() if m.timeseries)
            raise ValueError(f"{path}: a time series needs a scene of model {which}, not "
                             f"{scene.model!r}")
        if "impacts/t" not in f:
            raise ValueError(f"{path}: a time series needs the impacts: set output.keep = [\"impacts\"]")
        idx = tuple(point) + (ic,)
        t, u, vo, off = (f[f"impacts/{k}"][idx] for k in ("t", "u", "v_out", "corner_offset"))
        per = int(f["period"][idx])
        ipc = int(f["impacts_per_cycle"][idx])
        word = f["symbols"][idx]
        word = word.decode() if isinstance(word, bytes) else str(word)
        st = int(f["status"][idx])
    vals = scene.point(tuple(point))
    p, d = TR.pack(vals, scene.obstacle, scene.section_period, scene.profile)
    ok = np.isfinite(t)
    t, u, vo, off = t[ok], u[ok], vo[ok], off[ok]
    if t.size < 2:
        raise ValueError(f"{path}: start {ic} at point {tuple(point)} recorded fewer than two "
                         f"impacts (status {st})")
    T = 2.0 * math.pi / vals["omega"]
    t0 = math.floor(t[0] / T + 1e-9) * T   # an impact on a section belongs to it
    if ipc > 0 and ipc < t.size:
        span = cycles * (t[ipc] - t[0]) + (t[0] - t0)
    else:
        span = t[min(10, t.size - 1)] - t0
    t1 = min(t0 + span, t[-1])
    s, us, zs = TR.rebuild(p, d, t, u, vo, t0, t1)
    err = TR.meet_error(p, d, t, u, vo)
    arts = {}
    arts["z"] = ax.plot(s - t0, zs, color="0.45", lw=0.9, label="obstacle $z(t)$")
    arts["u"] = ax.plot(s - t0, us, color=color, lw=1.0, label=label or "particle $u(t)$")
    shown = (t >= t0) & (t <= t1)
    before = shown & (off < 0)          # NaN offsets (no corners) count as "after"
    after = shown & ~(off < 0)
    arts["impacts"] = ax.plot(t[after] - t0, u[after], ls="none", marker="o", ms=3.5, mfc="none",
                              mec=color, mew=0.9,
                              label="impact after a corner" if np.isfinite(off).any() else "impact")
    if before.any():
        arts["impacts"] += ax.plot(t[before] - t0, u[before], ls="none", marker="v", ms=4.0,
                                   color=color, label="impact before a corner")
    ax.set_ylabel("$u$, $z$")
    lo, hi = np.nanmin(zs), max(np.nanmax(us), np.nanmax(zs))
    ax.set_ylim(lo - 0.05 * (hi - lo), hi + 0.3 * (hi - lo))   # room for the legend
    return dict(period=per, ipc=ipc, word=word, status=st, meet=float(np.nanmax(err)),
                t0=t0, t1=t1, u=u, t=t, p=p, d=d, vals=vals, artists=arts)


def _word_text(word):
    """'bbbbbbbbbbbg' -> beta^11 gamma in the paper's letters (for titles)."""
    return _word_label(word) if word else "no cycle"


def figure_timeseries(plt, data: PlotData, plot_cfg: dict, title=None):
    """One panel per chosen attractor, stacked (paper Figs 1b, 5, 6d, 17)."""
    point, chosen, lab = timeseries_choice(data, plot_cfg)
    n = len(chosen)
    fig, axs = plt.subplots(n, 1, figsize=(7, 1.2 + 2.0 * n), dpi=150, squeeze=False)
    info = []
    for k, (ax, ic) in enumerate(zip(axs[:, 0], chosen)):
        rank = int(lab[ic])
        color = "k" if n == 1 else ATTRACTOR_COLORS[k % len(ATTRACTOR_COLORS)]
        r = draw_timeseries(ax, data.path, point, ic, cycles=float(plot_cfg.get("cycles", 2)),
                            color=color)
        name = (ROMAN[rank] + ": ") if (n > 1 and 0 <= rank < len(ROMAN)) else ""
        ax.set_title(f"{name}start {ic}: period {r['period']} (map iterates), impacts per cycle "
                     f"{r['ipc']}, word {_word_text(r['word'])}; the rebuilt flight meets $z$ at "
                     f"the next impact to {r['meet']:.1e}", fontsize=7, loc="left")
        v = r["vals"]
        b = obstacle_kind(data.scene["system"]).resonant_amplitude(v)
        if b is not None:
            # the resonant orbit u = b |sin t| of eq (6)
            ss = np.linspace(r["t"][r["t"] >= r["t0"]][0], r["t1"], 2000)
            ax.plot(ss - r["t0"], b * np.abs(np.sin(ss)), "--", color="tab:red", lw=0.9,
                    label=f"eq (6): ${b:.6g}\\,|\\sin t|$")
        info.append(r)
        if k == 0:
            ax.legend(loc="upper right", fontsize=7, ncol=4)
    axs[-1, 0].set_xlabel(r"$t - t_0$  ($t_0 = nT$, $T = 2\pi/\omega$, "
                          r"the section before the first recorded impact)")
    sc = data.scene.get("scene", {})
    fig.suptitle(title_lines(title or plot_cfg.get("title") or sc.get("title", ""), 90),
                 fontsize=9)
    fig.tight_layout()
    return fig, info


# ------------------------------------------------------------------ corner curves (Fig. 7a)
def figure_corner_curves(plt, data: PlotData, plot_cfg: dict, title=None):
    """The curves kappa_C(omega) (eq 11) and kappa_CC(omega) (eq 17) near omega = 2 (Fig. 7a).

    Theory only: the scene gives r, beta and the omega range ``[plot] xlim``.
    The regions are labelled with what section 3.3 says exists there: the
    single-impact orbit below kappa_C (eq 13), the double-impact orbit above
    kappa_CC (eq 19).
    """
    sys_ = data.scene.get("system", {})
    r, beta = sys_.get("r", 0.8), sys_.get("beta", 1.0)
    lo, hi = plot_cfg.get("xlim", [1.99, 2.01])
    w = np.linspace(lo, hi, 801)
    kc = np.array([theory.kappa_C(x, r, beta) for x in w])
    kcc = np.array([theory.kappa_CC(x, r, beta) for x in w])
    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=150)
    ax.plot(w, kc, "-", color="tab:red", lw=1.2, label=r"$\kappa_C(\omega)$, eq (11)")
    ax.plot(w, kcc, "-", color="tab:blue", lw=1.2, label=r"$\kappa_{CC}(\omega)$, eq (17)")
    ax.axvline(2.0, color="0.6", lw=0.6)
    ax.axhline(0.0, color="0.6", lw=0.6)
    ax.plot([2.0], [0.0], "ko", ms=4)
    ax.annotate(r"$(\omega, \kappa) = (2, 0)$: both curves cross", (2.0, 0.0), xytext=(10, -25),
                textcoords="offset points", fontsize=7, arrowprops=dict(arrowstyle="-", lw=0.5))
    if "ylim" in plot_cfg:
        ax.set_ylim(*plot_cfg["ylim"])
    y0, y1 = ax.get_ylim()
    ax.text(lo + 0.05 * (hi - lo), y0 + 0.08 * (y1 - y0),
            r"below $\kappa_C$: single-impact period-$T$ orbit (13)", fontsize=7, color="tab:red")
    ax.text(lo + 0.05 * (hi - lo), y1 - 0.12 * (y1 - y0),
            r"above $\kappa_{CC}$: double-impact period-$T$ orbit (19)", fontsize=7, color="tab:blue")
    # the paper's scene lines: omega = 1.999 (Fig. 6) and 2.001 (Fig. 7b)
    for wx in (1.999, 2.001):
        if lo < wx < hi:
            ax.axvline(wx, color="0.3", lw=0.6, ls=":")
            ax.text(wx, y1, f" {wx}", fontsize=6, va="top", rotation=90)
            for fn, c in ((theory.kappa_C, "tab:red"), (theory.kappa_CC, "tab:blue")):
                ax.plot([wx], [fn(wx, r, beta)], "o", color=c, ms=3.5)
    vals = [f"$\\omega$ = {wx}: $\\kappa_C$ = {theory.kappa_C(wx, r, beta):.6f}, "
            f"$\\kappa_{{CC}}$ = {theory.kappa_CC(wx, r, beta):.6f}"
            for wx in (1.999, 2.001) if lo < wx < hi]
    if vals:
        ax.text(0.98, 0.30, "\n".join(vals), transform=ax.transAxes, ha="right", va="bottom",
                fontsize=7, bbox=dict(fc="white", ec="0.7", lw=0.5))
    ax.set_xlabel(LABELS["omega"])
    ax.set_ylabel(LABELS["kappa"])
    ax.set_xlim(lo, hi)
    ax.legend(loc="lower right", fontsize=7)
    sc = data.scene.get("scene", {})
    ax.set_title(title_lines(title or plot_cfg.get("title") or sc.get("title", ""), 80),
                 fontsize=9)
    fig.tight_layout()
    return fig


def obstacle_curve(data: PlotData):
    """z(t) of a scene's obstacle at its system values (the model's ``wall_at``: the kernels'
    own obstacle) as a function of t, its period and the scene."""
    from .config import loads
    scene = loads(data.scene_text)
    model = registry.get(scene.model)
    row = np.ascontiguousarray(model.pack_values(scene.system, scene)[None, :])

    def z(t):
        return model.wall_at(row, np.asarray(t, float)[None, :])[0]
    kind = model.obstacles[scene.obstacle]
    return z, kind.period(scene.system["omega"], scene.profile), scene


def figure_obstacle(plt, data: PlotData, plot_cfg: dict, title=None):
    """The obstacle z(t) (Fig. 2): (a) ``[plot] cycles`` periods (default 2) with the corners
    t_k = k P marked, (b) a magnification around the corner t_0 = P with the two slopes of
    the wedge of eq (7), z ~ kappa + theta2 (t - t_0) after it and kappa + theta1 (t_0 - t)
    before it (theta1 = theta2 = beta omega for z = kappa + beta |sin omega t|)."""
    cycles = float(plot_cfg.get("cycles", 2))
    sys_ = data.scene.get("system", {})
    w = float(sys_.get("omega", 2.0))
    z_of, per, scene = obstacle_curve(data)
    t = np.linspace(0.0, cycles * per, 2001)
    z = z_of(t)
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(8.2, 3.4), dpi=150,
                                 gridspec_kw={"width_ratios": [1.6, 1.0]})
    ax.plot(t, z, color="k", lw=1.0, label="$z(t)$")
    corners = per * np.arange(0, int(cycles) + 1)
    kap = float(sys_.get("kappa", 0.0))
    if obstacle_kind(sys_).corner_wedge:
        ax.plot(corners, np.full(corners.size, kap), "o", ms=4, mfc="w", mec="tab:red",
                label=r"corners $t_k = k\pi/\omega$")
    ax.set_xlabel("$t$")
    ax.set_ylabel("$z$")
    ax.set_title("(a)", loc="left", fontsize=9)
    ax.legend(loc="upper left", bbox_to_anchor=(0.0, -0.18), ncol=2, frameon=False)
    h = 0.06 * per
    tz = np.linspace(per - h, per + h, 401)
    zz = z_of(tz)
    beta = float(sys_.get("beta", 1.0))
    th1 = float(sys_.get("theta1") or beta * w)
    th2 = float(sys_.get("theta2") or beta * w)
    bx.plot(tz - per, zz, color="k", lw=1.0, label="$z(t)$")
    s = tz - per
    bx.plot(s[s <= 0], kap - th1 * s[s <= 0], "--", color="tab:blue", lw=0.8,
            label=r"$\kappa + \theta_1 (t_0 - t)$")
    bx.plot(s[s >= 0], kap + th2 * s[s >= 0], "--", color="tab:orange", lw=0.8,
            label=r"$\kappa + \theta_2 (t - t_0)$")
    bx.set_xlabel("$t - t_0$")
    bx.set_title("(b) near the corner $t_0$, eq (7)", loc="left", fontsize=9)
    bx.legend(loc="upper left", bbox_to_anchor=(0.0, -0.18), frameon=False)
    sc = data.scene.get("scene", {})
    fig.suptitle(title_lines(title or plot_cfg.get("title") or sc.get("title", ""), 90),
                 fontsize=9)
    fig.tight_layout()
    return fig

