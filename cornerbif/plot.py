"""Figures from HDF5 files only (plotting never runs kernels).

matplotlib's recipe: ``draw_*(ax, data, **kw) -> artists`` plus ``figure``,
which makes the whole figure.  matplotlib is imported here only, so
``cornerbif sweep`` starts fast and needs no display.
"""

from __future__ import annotations

import contextlib
import math
import tomllib

import numpy as np

from . import plot_attractors, plot_normal_form, registry, theory
from .io import check_readable
from .plot_style import title_lines

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
# the maps' start is the point x = (a_0, b_1) of their plane (section 4, Fig. 9)
MAP_STARTS = {"initial.u": r"start $a_0$", "initial.v": r"start $b_1$"}


def axis_label(name: str, model: str | None = None) -> str:
    """The label of a swept axis ``name`` for a file of ``model``."""
    if model == "map2d" and name in MAP_STARTS:
        return MAP_STARTS[name]
    return LABELS.get(name, name)


# the section of the local 2D maps (sections 4-5) is (a_n, b_n); a flow's is (u(nT), v(nT))
MAP_SECTION = {"section_u": r"$a_n$", "section_v": r"$b_n$"}


def y_label(kind: str, model: str | None = None) -> str:
    """The axis label of a drawn ``kind`` for a file of ``model`` (the maps' section is
    a_n, b_n; a flow's u(nT), v(nT); a file of either compared on one axis names both)."""
    if kind in MAP_SECTION:
        if model == "map2d":
            return MAP_SECTION[kind]
        if model is None:
            return YLABELS[kind]
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


class PlotData:
    """What the plot needs, read from one file."""

    def __init__(self, path):
        with check_readable(path) as f:
            self.path = str(path)
            self.scene_text = f.attrs["scene"]
            self.scene = tomllib.loads(self.scene_text)
            from .config import sweep_items
            self.axes = [k for k, _ in sweep_items(self.scene.get("sweep", {}))]
            self.values = {a: f[a][...] for a in self.axes}
            self.status = f["status"][...]
            self.period = f["period"][...]
            self.ipc = f["impacts_per_cycle"][...]
            # as str no wider than the longest word (the file's field may be many times
            # wider: memory per run)
            sym = f["symbols"][...]
            self.symbols = sym.astype(f"U{max(1, int(np.char.str_len(sym).max(initial=0)))}")
            self.model = self.scene.get("scene", {}).get("model", registry.DEFAULT_MODEL)
            self.spec = registry.models().get(self.model)
            # its part in the flow-against-map figures of sections 4-5 ("flow", "map", None)
            self.role = self.spec.normal_form_role if self.spec else None
            self.done = f["done"][...]
            self.initial = {k: f[f"initial/{k}"][...] for k in ("u", "v") if f"initial/{k}" in f}
            self.data = RecordedData(path, {n: f[n].shape for n in RECORDED if n in f},
                                     swmr=f.swmr_mode)
            self.follow = self.scene.get("sweep", {}).get("follow", "none")
            self.has_table = "attractors" in f            # cornerbif.attractors
            self.complete = bool(f.attrs.get("completed", ""))
            # the stability observable (docs/stability.md), per run
            self.stability = {}
            if "stability/lyapunov" in f:
                self.stability["lyapunov"] = f["stability/lyapunov"][..., 0]
            if "stability/multiplier_re" in f:
                self.stability["multiplier"] = np.hypot(f["stability/multiplier_re"][..., 0],
                                                        f["stability/multiplier_im"][..., 0])
            self.period_tol = float(self.scene.get("run", {}).get("period_tol", 1e-6))
        self._attractors = None
        self._y = {}                 # y(kind), computed once

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
    import warnings
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
    """Whether ``path`` is a ``cornerbif continue`` file (root attribute ``format``)."""
    import h5py

    from .continuation import FORMAT
    try:
        with h5py.File(path, "r") as f:
            return f.attrs.get("format") == FORMAT
    except OSError:
        return False


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
    """A cycle word in the paper's notation (b^3 g -> beta^3 gamma; '?' when unknown)."""
    return plot_attractors.label_tex(str(word)) if word else "?"


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
        vals = br[key]
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
            i = int(np.argmin(np.abs(br["param"] - e["param"])))
            vals = br[key][i] if br[key].ndim == 1 else br[key][i].min()
        arts += ax.plot([e["param"]], [vals], mk, color=c, ms=6, mec="k", mew=0.5,
                        label=None if lab in seen else lab, zorder=5)
        seen.add(lab)
    return arts


def figure_branches(paths, out, y=None, title=None, plot_cfg=None, style=None):
    """Continuation files drawn alone: branches against the parameter, and the corner
    curves in the plane of the two parameters when the files have them; in the project's
    style with the user's sheet over it (``style``, or ``[plot] style``), ``[plot] ylim``
    the window of the branches' panel."""
    from . import plot_style
    from .continuation import read
    conts = [read(p) for p in paths]
    scene = tomllib.loads(conts[0]["scene"])
    if plot_cfg is None:                 # the first file's scene, as a sweep's figure
        plot_cfg = scene.get("plot", {})
    with plot_style.style(style or plot_cfg.get("style")):
        return _figure_branches(conts, scene, out, y, title, plot_cfg)


def _figure_branches(conts, scene, out, y, title, plot_cfg):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    curves = any(c["curves"] for c in conts)
    fig, axs = plt.subplots(1, 2 if curves else 1, figsize=(12 if curves else 7, 4.5),
                            dpi=150, squeeze=False)
    ax = axs[0, 0]
    have = {k for c in conts for b in c["branches"] for k in b}
    own = "impact_u" if "impact_u" in have or not have else "section_v"
    kind = y or plot_cfg.get("y") or own
    plot_cfg = cfg_for_y(plot_cfg, y, own)      # the scene's ylim is for its own y
    if have and BRANCH_Y.get(kind) not in have:
        plt.close(fig)
        raise ValueError(f"y = {kind!r}: the branches store "
                         + ", ".join(k for k, v in BRANCH_Y.items() if v in have))
    title = title or plot_cfg.get("title")
    colors = branch_colors(conts)
    for c in conts:
        draw_branches(ax, c, kind, colors)
    if "ylim" in plot_cfg:
        ax.set_ylim(*plot_cfg["ylim"])
    name = conts[0]["parameter"]
    ax.set_xlabel(LABELS.get(name, name))
    sc = scene.get("scene", {})
    ax.set_ylabel(y_label(kind, sc.get("model")))
    ax.legend(loc="best", fontsize=7)
    if curves:
        draw_corner_curves_continued(axs[0, 1], conts, colors)
    fig.suptitle(title_lines(title or sc.get("title", ""), 100), fontsize=9)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)
    return out


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
    if names == ("omega", "kappa") and sys_.get("obstacle", "rectified_sine") == "rectified_sine":
        r, beta = sys_.get("r", 0.8), sys_.get("beta", 1.0)
        w = np.linspace(cv0["param"].min(), cv0["param"].max(), 300)
        arts += ax.plot(w, [theory.kappa_C(t, r, beta) for t in w], ":", color="tab:red",
                        lw=2, label=r"$\kappa_C$, eq (11)")
        arts += ax.plot(w, [theory.kappa_CC(t, r, beta) for t in w], ":", color="tab:blue",
                        lw=2, label=r"$\kappa_{CC}$, eq (17)")
    ax.set_xlabel(LABELS.get(names[0], names[0]))
    ax.set_ylabel(LABELS.get(names[1], names[1]))
    ax.legend(loc="best", fontsize=7)
    return arts


def attractor_summary(data: PlotData, tex: bool = True) -> str:
    """One line: how many attractors coexist, and where (for the figure and ``cornerbif info``)."""
    labels, count = data.attractors()
    if count.size == 0:
        return ""
    n = count.size
    k = int(count.max())
    if k == 0:
        return "no start reached a cycle (chaos, or a period too long for the record)"
    parts = [f"coexisting attractors: up to {k}"]
    if k >= 2 and data.axes:
        a = data.axes[0]
        where = np.nonzero(count.reshape(len(data.values[a]), -1).max(axis=1) >= 2)[0]
        vals = data.values[a][where]
        parts.append(f"{int((count >= 2).sum())} of {n} points have 2 or more "
                     f"({LABELS.get(a, a) if tex else a} in [{vals.min():.6g}, {vals.max():.6g}])")
    none = int((labels < 0).all(axis=-1).sum())
    if none:
        parts.append(f"{none} points without a cycle")
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
    if sys_.get("obstacle") == "profile":
        return draw_jump_speed(ax, data)
    if sys_.get("obstacle", "rectified_sine") != "rectified_sine":
        return []
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


def draw_jump_speed(ax, data: PlotData):
    """A cam profile swept in omega with a constant force (Omega = 0: a follower's spring
    preload): the jump speed above which a follower riding the cam leaves it
    (``models.profile.jump_speed``), a vertical line."""
    sys_ = data.scene.get("system", {})
    if not data.axes or data.axes[0] != "omega" or sys_.get("Omega", 1.0) != 0.0:
        return []
    from .models.profile import jump_speed, read
    prof = read(sys_["profile"])
    force = sys_.get("F", 0.0) * math.cos(sys_.get("phi", 0.0))
    w = jump_speed(prof, sys_.get("kappa", 0.0), sys_.get("beta", 1.0), sys_.get("k", 1.0),
                   force, sys_.get("sigma", 0.0), sys_.get("r", 0.8))
    x = data.values["omega"]
    if w == 0.0:
        return [ax.text(0.99, 0.99, "no jump speed: the follower leaves the cam at every "
                        "speed (a corner launches or strikes it)",
                        transform=ax.transAxes, ha="right", va="top", fontsize=7, color="0.3")]
    if w is None or not (x.min() <= w <= x.max()):
        return []
    return [ax.axvline(w, color="tab:red", lw=0.8, ls="--",
                       label=rf"jump speed $\omega_j$ = {w:.6g}")]


def draw_plane(ax, data: PlotData):
    """Two-axis sweep: colour each point by the period of its attractors (the largest over
    the starts), on a log scale: a few long periods (73-75 in the charts near (2, 0)) do
    not press periods 1-20 into one colour.  A mass ratio spanning decades is drawn on a
    log axis, each value's cell between the geometric means with its neighbours."""
    import matplotlib.colors as mcolors
    a, b = data.axes[:2]
    per = data.period.astype(float)
    per[per <= 0] = np.nan
    import warnings
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
    if {a, b} == {"omega", "kappa"} and sys_.get("obstacle", "rectified_sine") == "rectified_sine":
        r = sys_.get("r", 0.8)
        beta = sys_.get("beta", 1.0)
        w = np.linspace(x.min(), x.max(), 400) if a == "omega" else np.linspace(y.min(), y.max(), 400)
        kc = [theory.kappa_C(t, r, beta) for t in w]
        kcc = [theory.kappa_CC(t, r, beta) for t in w]
        if a == "omega":
            ax.plot(w, kc, "r-", lw=0.8, label=r"$\kappa_C$ (11)")
            ax.plot(w, kcc, "b-", lw=0.8, label=r"$\kappa_{CC}$ (17)")
            ax.set_ylim(y.min(), y.max())
        else:
            ax.plot(kc, w, "r-", lw=0.8, label=r"$\kappa_C$ (11)")
            ax.plot(kcc, w, "b-", lw=0.8, label=r"$\kappa_{CC}$ (17)")
            ax.set_xlim(x.min(), x.max())
        ax.legend(loc="upper left", fontsize=7)


def _need_table(data: PlotData):
    """Basin images and fractions read the file's attractor table (cornerbif.attractors)."""
    with check_readable(data.path) as f:
        if "attractors" not in f:
            raise ValueError(f"{data.path}: has no attractor table (written by an older "
                             "cornerbif, or not finished); run its sweep again")


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
    panel = {"flow": "the impacting system (direct simulation of the flow)",
             "map": "the local 2D maps (56)"}
    for ax, d, tag in zip(axs[:2], datas, "ab"):
        draw_bifurcation(ax, d, kind, ms=plot_cfg.get("marker_size", 0.6))
        ax.set_ylabel(y_label(kind, d.model), fontsize=8)
        ax.set_title(f"({tag}) {panel.get(d.role, d.model)}", fontsize=8, loc="left")
        if "ylim" in plot_cfg:
            ax.set_ylim(*plot_cfg["ylim"])
    dist = hausdorff_per_point(datas[0].y(kind), datas[1].y(kind))
    axs[2].semilogy(datas[0].values[a], dist, "k.", ms=1.5)
    axs[2].set_ylabel("distance\nflow to map", fontsize=8)
    axs[2].set_title("(c) their distance at each parameter value (Hausdorff, per point)",
                     fontsize=8, loc="left")
    axs[2].set_xlabel(LABELS.get(a, a))
    return axs


def figure(paths, out, y=None, title=None, plot_cfg=None, color_by=None, branches=(),
           style=None):
    """Draw one or more files of the same kind into ``out`` (png, pdf or svg), in the
    project's style (``plot_style``) with the user's style sheet over it (``style``, or
    ``[plot] style``).  See ``_figure``."""
    from . import plot_style
    datas = [PlotData(p) for p in paths]
    cfg = datas[0].scene.get("plot", {}) if plot_cfg is None else plot_cfg
    cfg = cfg_for_y(cfg, y, datas[0].default_y())
    with plot_style.style(style or cfg.get("style")):
        return _figure(datas, out, y, title, cfg, color_by, branches)


def cfg_for_y(cfg: dict, y, default_y) -> dict:
    """The ``[plot]`` table for a figure of ``y`` (``--y``): the scene's ``ylim`` is a
    window in the scene's own y (``[plot] y``, else the file's default), so it is dropped
    when another y is drawn."""
    own = cfg.get("y") or default_y
    if y and "ylim" in cfg and y != own:
        return {k: v for k, v in cfg.items() if k != "ylim"}
    return cfg


def _figure(datas, out, y=None, title=None, plot_cfg=None, color_by=None, branches=()):
    """Draw one or more files of the same kind (``datas``, their PlotData) into ``out``
    (png, pdf or svg).

    ``plot_cfg`` replaces the file's ``[plot]`` table (the gallery passes the
    committed scene's, so a figure setting never forces a new sweep).
    ``[plot] kind``: "diagram" (default: bifurcation diagram or parameter plane),
    "timeseries" (Figs 1b, 5, 6d, 17) or "corner_curves" (Fig. 7a).
    ``color_by`` (or ``[plot] color_by``): "lyapunov" or "multiplier" colours a diagram's
    points, or the left panel of an (omega, kappa) chart, by the run's stability.
    ``branches``: continuation files (``cornerbif continue``) drawn over a diagram.
    """
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    d0 = datas[0]
    plot_cfg = d0.scene.get("plot", {}) if plot_cfg is None else plot_cfg
    kind_ = plot_cfg.get("kind", "diagram")
    color_by = color_by or plot_cfg.get("color_by")
    if color_by is not None and color_by not in COLOR_BY:
        raise ValueError(f"color_by: {color_by!r} is not allowed; allowed: "
                         + ", ".join(COLOR_BY))
    if kind_ in plot_normal_form.KINDS:
        return plot_normal_form.figure(datas, out, plot_cfg, title)
    if kind_ in ("timeseries", "corner_curves", "obstacle"):
        if len(datas) > 1:
            raise ValueError(f"plot kind {kind_!r} draws one file, got {len(datas)}")
        if kind_ == "timeseries":
            fig, _ = figure_timeseries(plt, d0, plot_cfg, title)
        elif kind_ == "obstacle":
            fig = figure_obstacle(plt, d0, plot_cfg, title)
        else:
            fig = figure_corner_curves(plt, d0, plot_cfg, title)
        fig.savefig(out)
        plt.close(fig)
        return out
    roles = {d.role for d in datas}
    if len(datas) == 2 and roles == {"flow", "map"} and len(d0.axes) == 1:
        datas.sort(key=lambda d: d.role != "flow")
        kind = y or "section_v"
        fig = plt.figure(figsize=(7, 7), dpi=150)
        draw_comparison(fig, datas, kind, plot_cfg)
        sc = datas[1].scene.get("scene", {})
        fig.suptitle(title_lines(title or plot_cfg.get("title") or sc.get("title", ""), 80),
                     fontsize=9)
        fig.tight_layout()
        fig.savefig(out)
        plt.close(fig)
        return out
    basin = len(d0.axes) == 2 and all(a.startswith("initial.") for a in d0.axes)
    if kind_ == "fractions":
        if len(datas) > 1 or len(d0.axes) != 1:
            raise ValueError("plot kind 'fractions' draws one file swept over one parameter")
        _need_table(d0)
        fig, ax = plt.subplots(figsize=(8, 4.5), dpi=150)
        plot_attractors.draw_fractions(ax, d0.path, d0.values[d0.axes[0]])
        draw_corner_points(ax, d0, corner_line=False, mono=True)
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
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
    if len(d0.axes) == 1 and kind_ != "fractions":
        kind = y or plot_cfg.get("y") or d0.default_y()
        # the drawn values a slab at a time (plot_style.Rows): counted, windowed and, past
        # RASTER_POINTS, rastered without holding them whole
        ys = [d.y_rows(kind) for d in datas] if kind else [None]
        if ys[0] is None:
            plt.close(fig)
            raise ValueError(f"{d0.path}: the file holds no {kind or 'recorded'} values to draw "
                             "(output.keep of its scene; impact values need \"impacts\", "
                             "section values \"section\")")
        colors = ["k", "tab:orange", "tab:green", "tab:purple"]
        from . import plot_style
        n_drawn = sum(plot_style.count_finite(v) for v in ys if v is not None)
        ms = plot_cfg.get("marker_size") or plot_style.marker_size(n_drawn)
        by_label = (len(datas) == 1 and not color_by and kind not in ("winding", "period")
                    and ys[0].ndim == 3 and d0.has_table)
        raster = by_label and n_drawn > plot_style.RASTER_POINTS and not branches
        # the y-window: the scene's, or one that a few outlying points do not set
        # (plot_style.robust_range); what it leaves out is said on the figure
        yall = (ys[0] if len(datas) == 1 else
                np.concatenate([d.y(kind).ravel() for d in datas if d.y(kind) is not None]))
        n_fin = n_drawn
        if "ylim" in plot_cfg:
            lo, hi = plot_cfg["ylim"]
            n_out = plot_style.count_outside(yall, lo, hi)
            window = (lo, hi)
        elif branches:
            # continued branches may reach past the sweep's values: the axes take them all
            lo, hi, n_out, window = None, None, 0, None
        else:
            win = plot_style.robust_range(yall)
            lo, hi, n_out = win if win else (None, None, 0)
            window = (lo, hi) if win else None
        del yall
        if color_by:
            if len(datas) > 1:
                plt.close(fig)
                raise ValueError(f"color_by: draws one file, got {len(datas)}")
            sc = draw_bifurcation_colored(ax, d0, kind, color_by, ms=ms)
            fig.colorbar(sc, ax=ax, label=COLOR_BY[color_by][0], extend="both")
            if ax.get_legend_handles_labels()[0]:
                ax.legend(loc="upper center", bbox_to_anchor=(0.5, -0.12), ncol=2, fontsize=7,
                          frameon=False, markerscale=3)
        conts = []
        if branches:
            from .continuation import read
            conts = [read(bp) for bp in branches]
            for bp, cont in zip(branches, conts):
                if cont["parameter"] != d0.axes[0]:
                    plt.close(fig)
                    raise ValueError(f"{bp}: its branches are continued in "
                                     f"{cont['parameter']!r}, the diagram sweeps "
                                     f"{d0.axes[0]!r}")
        # a branch takes the colour its orbit has in the diagram (its family's, with
        # families): one colour map for both
        families = plot_cfg.get("orbits") == "families"
        words = [str(br["word"]) for c in conts for br in c["branches"]]
        label_of = {w: plot_attractors.family(w) if families else w for w in words}
        colors_b = branch_colors(conts)
        orbit_handles = []
        if by_label:
            shared = {}
            orbit_handles = plot_attractors.draw_diagram_by_label(
                ax, d0.path, d0.values[d0.axes[0]], ys[0] if raster else d0.y(kind), ms,
                families=families, window=window if raster else None,
                xlim=plot_cfg.get("xlim"), also=list(label_of.values()), colors_out=shared)
            colors_b = {w: shared[lab] for w, lab in label_of.items()}
        if kind == "winding" and len(datas) == 1 and not color_by:
            draw_winding_by_alpha(ax, d0, ms)
            datas_drawn = []
        else:
            datas_drawn = datas
        # followed sweeps: the way each went in its label, the downward one underneath and
        # larger, so that the upward one's jumps stay in sight over it
        drawn = sorted(enumerate(datas), key=lambda item: item[1].follow != "down")
        drawn = [item for item in drawn if item[1] in datas_drawn]
        for i, d in (drawn if not (color_by or by_label) else []):
            lab = None
            if len(datas) > 1:
                lab = (follow_label(d) if d.follow != "none"
                       else d.scene["scene"].get("name", f"file {i + 1}"))
            down = len(datas) > 1 and d.follow == "down"
            draw_bifurcation(ax, d, kind, ms=ms * (1.8 if down else 1.0),
                             color=colors[i % len(colors)], label=lab,
                             by_attractor=len(datas) == 1 and kind not in ("winding", "period"))
        branch_arts = []
        for cont in conts:
            branch_arts += draw_branches(ax, cont, kind, colors_b)
        if kind in ("impact_u", "impact_height", "winding", "section_v", "period"):
            draw_corner_points(ax, d0, corner_line=kind == "impact_u")
        draw_marks(ax, plot_cfg)
        if by_label:
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
        ax.set_ylabel(y_label(kind, d0.model if all(d.model == d0.model for d in datas)
                              else None))
        from matplotlib.ticker import MaxNLocator
        ax.xaxis.set_major_locator(MaxNLocator(6))   # long tick labels (1.9996) stay apart
        ax.ticklabel_format(axis="x", useOffset=False)
        if window and "ylim" not in plot_cfg:
            ax.set_ylim(*window)
        # what the figure holds beside its points, right of the axes below the legend
        # (inside the axes it lay on the data: Fig. 19(a)'s summary over its lowest points)
        notes = [attractor_summary(d0)] if len(datas) == 1 else []
        if n_out:
            notes.append(f"{n_out} of {n_fin} values outside the y window")
        notes = [n for n in notes if n]
        if notes:
            ax.text(1.02, 0.0, "\n\n".join(title_lines(n, 44) for n in notes),
                    transform=ax.transAxes, ha="left", va="bottom", fontsize=6, color="0.3")
        if ax.get_legend_handles_labels()[0] and not color_by and not by_label:
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
    elif len(d0.axes) not in (1, 2):
        plt.close(fig)
        raise ValueError(f"{d0.path}: a scene without a sweep axis has nothing to draw")
    if "xlim" in plot_cfg:
        ax.set_xlim(*plot_cfg["xlim"])
    if "ylim" in plot_cfg:
        ax.set_ylim(*plot_cfg["ylim"])
    sc = d0.scene.get("scene", {})
    ax.set_title(title_lines(title or plot_cfg.get("title")
                             or sc.get("title", sc.get("name", "")), 80), fontsize=9)
    if not all(d.complete for d in datas):
        ax.text(0.99, 0.01, "incomplete sweep", transform=ax.transAxes, ha="right", va="bottom",
                color="r", fontsize=8)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)
    return out


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

    Rebuilt from the stored impacts by exact free flight (``cornerbif.trajectory``);
    impacts are marked.  Time is counted from the section t0 = nT (T = 2 pi/omega)
    before the first recorded impact.  Returns a dict of what was drawn and measured.
    """
    from . import config as C
    from . import trajectory as TR
    with check_readable(path) as f:
        scene = C.loads(f.attrs["scene"])
        if not scene.spec.timeseries:
            raise ValueError(f"{path}: a time series needs a 'flow' scene, not {scene.model!r}")
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
        if (data.scene["system"].get("obstacle") == "sine" and v["omega"] == 2.0 and v["kappa"] == 0.0
                and v.get("sigma", 0.0) == 0.0 and v.get("k", 1.0) == 1.0 and v.get("F", 0.0) == 0.0):
            # the resonant orbit u = 2 beta (1 + r)/(1 - r) |sin t| of eq (6)
            b = theory.resonant_amplitude(v["r"], v["beta"])
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
    """z(t) of a flow scene's obstacle at its system values (``kernels.flow``
    ``obstacle_heights``, the kernels' own obstacle) as a function of t, its period and
    the scene."""
    from .config import loads
    from .kernels.flow import obstacle_heights
    from .models import params as P
    scene = loads(data.scene_text)
    row = np.ascontiguousarray(registry.get("flow").pack_values(scene.system, scene)[None, :])

    def z(t):
        return obstacle_heights(row, np.ascontiguousarray(np.asarray(t, float)[None, :]))[0]
    return z, P.obstacle_period(scene.obstacle, scene.system["omega"], scene.profile), scene


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
    if scene.obstacle in ("rectified_sine", "triangle"):
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

