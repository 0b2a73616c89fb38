"""Diagrams, charts and basins: a file's swept values drawn against one parameter (the
bifurcation diagram, coloured by attractor, family or stability, continuation branches and
their events over it), over two (a chart of periods and coexisting words, or of stability)
or over two start coordinates (a basin image); a flow's diagram against its map's (Fig. 16);
continuation files alone.  The ``diagram`` and ``fractions`` figure kinds draw here
(``figure_diagram``)."""

from __future__ import annotations

import math
import os
import tomllib
import warnings
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from . import plot_attractors, plot_style, theory
from .attractors import read_branches
from .plot_base import (
    ATTRACTOR_COLORS,
    BRANCH_Y,
    COLOR_BY,
    DRAW_LIMIT,
    EVENT_MARKERS,
    LABELS,
    Undrawable,
    attractor_summary,
    axis_label,
    branch_colors,
    branch_keys,
    cfg_for_y,
    continuation_note,
    flow_and_map,
    follow_label,
    mask_runs,
    need_table,
    obstacle_kind,
    own_branch_y,
    partial_notes,
    points,
    word_label,
    y_label,
)
from .plot_style import legend, plain, save, title_lines

if TYPE_CHECKING:
    from .plot_data import PlotData


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
    import matplotlib.colors as mcolors  # start-up: loads matplotlib
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
    import matplotlib  # start-up: loads matplotlib
    import matplotlib.colors as mcolors  # start-up: loads matplotlib
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
        label = f"branch {b}: {word_label(br['word'])}"
        for q in range(vals.shape[1]):
            for stable in (True, False):
                m = st if stable else ~st
                # segments include the neighbour point so that solid and dashed join; a
                # branch of one point (it ended where it started) is a marker
                for a, e in mask_runs(m):
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


def branches_figure(conts, scene, out, y, title, plot_cfg):
    import matplotlib  # start-up: loads matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # start-up: loads matplotlib

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
                            label=f"branch {b} ({word_label(word)}): {what}, continued")
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
    kind = obstacle_kind(sys_, getattr(data, "spec", None))
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
    import matplotlib.colors as mcolors  # start-up: loads matplotlib
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
    if {a, b} == {"omega", "kappa"} and obstacle_kind(sys_, getattr(data, "spec", None)).normal_form:
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
    import matplotlib.colors as mcolors  # start-up: loads matplotlib
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


def figure_flow_and_map(plt, datas, out, y, title, plot_cfg):
    """A flow's diagram against its map's, value by value (Fig. 16: ``draw_comparison``)."""
    datas.sort(key=lambda d: d.normal_form.order)
    fig = plt.figure(figsize=(7, 7), dpi=150)
    draw_comparison(fig, datas, y or "section_v", plot_cfg)
    sc = datas[1].scene.get("scene", {})
    fig.suptitle(title_lines(title or plot_cfg.get("title") or sc.get("title", ""), 80),
                 fontsize=9)
    partial_notes(fig, datas)
    fig.tight_layout()
    return save(fig, out)


def panels(plt, d0: PlotData, shares, color_by):
    """The figure and its main axes: a file's basin fractions against its one swept
    parameter, its basin image (two swept starts) or its chart (two swept parameters: the
    period or ``color_by``, and the count of distinct words), drawn whole; for a diagram,
    its axes, empty."""
    basin = len(d0.axes) == 2 and all(a.startswith("initial.") for a in d0.axes)
    if shares:
        need_table(d0)
        fig, ax = plt.subplots(figsize=(8, 4.5), dpi=150)
        plot_attractors.draw_fractions(ax, d0.path, d0.values[d0.axes[0]])
        draw_corner_points(ax, d0, corner_line=False, mono=True)
        legend(ax, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7, frameon=False)
        ax.set_xlabel(LABELS.get(d0.axes[0], d0.axes[0]))
    elif basin:
        need_table(d0)
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
    d0 = datas[0]
    kind = y or plot_cfg.get("y") or d0.default_y()
    ys = [d.y_rows(kind) for d in datas] if kind else [None]
    if ys[0] is None:
        import matplotlib.pyplot as plt  # start-up: loads matplotlib
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


def draw_diagram(fig, ax, datas, y, plot_cfg, color_by, conts):
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
    by_branch = plot_cfg.get("orbits") == "branches"
    if by_branch and v.by_label and read_branches(d0.path) is None:
        import matplotlib.pyplot as plt  # start-up: loads matplotlib
        plt.close(fig)
        raise Undrawable(f"{d0.path}: plot.orbits = \"branches\" colours by the branches of "
                         f"cornerbif explain, which the file does not hold yet: run `cornerbif "
                         f"explain {d0.path}` first")
    words = [str(br["word"]) for c in conts for br in c["branches"]]
    label_of = {w: plot_attractors.family(w) if families else w for w in words}
    colors_b = branch_colors(conts)
    orbit_handles = []
    if v.by_label:
        shared = {}
        orbit_handles = plot_attractors.draw_diagram_by_label(
            ax, d0.path, d0.values[d0.axes[0]], v.ys[0] if v.raster else d0.y(kind), ms,
            families=families, window=v.window if v.raster else None,
            xlim=plot_cfg.get("xlim"), also=list(label_of.values()), colors_out=shared,
            branches=by_branch)
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
        legend_title = ("orbit (family of words)" if families else "orbit (word and branch)"
                        if plot_cfg.get("orbits") == "branches" else "orbit (word)")
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
    from matplotlib.ticker import MaxNLocator  # start-up: loads matplotlib
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


def figure_diagram(plt, datas, out, y, title, plot_cfg, color_by, branches, shares=False):
    """The figure of the ``diagram`` kind (``shares``: of the ``fractions`` kind, the shares of
    the starts against the one swept parameter): a flow's diagram against its map's, a
    diagram of one or more files with ``branches`` over it, a chart or a basin; titled, with
    what is partial noted, saved whole."""
    if flow_and_map(datas) and len(datas[0].axes) == 1:
        return figure_flow_and_map(plt, datas, out, y, title, plot_cfg)
    fig, ax = panels(plt, datas[0], shares, color_by)
    diagram = len(datas[0].axes) == 1 and not shares
    if diagram:
        draw_diagram(fig, ax, datas, y, plot_cfg, color_by, list(branches))
    if "xlim" in plot_cfg:
        ax.set_xlim(*plot_cfg["xlim"])
    if "ylim" in plot_cfg:
        ax.set_ylim(*plot_cfg["ylim"])
    sc = datas[0].scene.get("scene", {})
    ax.set_title(title_lines(title or plot_cfg.get("title")
                             or sc.get("title", sc.get("name", "")), 80), fontsize=9)
    partial_notes(fig, datas, list(branches) if diagram else ())
    fig.tight_layout()
    return save(fig, out)
