"""``[plot] kind = "branches"``: the skeleton of an explained diagram (``cornerbif explain``,
docs/basins.md "Branches across the sweep").  Above: the diagram in grey, each branch's
located ends marked by kind at the orbit's point there.  Below: one bar per branch over
the parameter, from its located beginning to its located end (the grid values it spans
where an end is not located), coloured by its word, its ends marked by kind.  A sweep of two
parameters: the located edges of every branch in the parameter plane, marked by kind and
coloured by the branch's word, with the words (short ones) of the largest branches written at
their middle."""

from __future__ import annotations

import math

import numpy as np

from ..attractors import read_branches
from ..model import IC_PREFIX, FigureKind
from ..plot_style import save, title_lines

# marker and legend words of each kind of end (attractors.BRANCH_END_KINDS)
MARKS = {
    "corner": ("v", "corner collision"),
    "grazing": ("^", "grazing"),
    "fold": ("s", "fold"),
    "period_doubling": ("D", "period doubling"),
    "torus": ("o", "torus"),
    "admissibility": ("X", "loss of admissibility"),
    "no_orbit": ("*", "no periodic orbit beyond"),
    "unsampled": (">", "goes on, unreached by the starts"),
    "unlocated": ("d", "not located"),
}
LABELLED = 12        # the words of this many branches (the most attractors) are written
SHORT_WORD = 8       # (in the plane: of those whose word is at most this long)


class Skeleton(FigureKind):
    def check(self, w):
        if len(w.axes) in (1, 2) and not any(a.name.startswith(IC_PREFIX) for a in w.axes):
            return []
        return ["plot.kind: 'branches' draws the branches of one or two swept parameters "
                "(cornerbif explain); this scene sweeps "
                + (", ".join(a.name for a in w.axes) or "nothing")]

    def draw(self, plt, datas, out, y, title, plot_cfg, color_by, branches):
        # start-up: drawing loads h5py, matplotlib and numba; checking a scene loads none
        from ..plot_attractors import attractor_colors, label_tex
        from ..plot_base import Undrawable
        from ..plot_diagram import draw_bifurcation
        d0 = datas[0]
        bt = read_branches(d0.path)
        if bt is None:
            raise Undrawable(f"{d0.path}: the file holds no branch table; run `cornerbif "
                             f"explain {d0.path}` first")
        if len(bt["axes"]) == 2:
            return _plane(plt, d0, bt, out, title, plot_cfg)
        axis = bt["axes"][0]
        kind = y or plot_cfg.get("y") or d0.default_y()
        fig, (ax, axb) = plt.subplots(2, 1, sharex=True, figsize=(7.5, 7.0),
                                      gridspec_kw={"height_ratios": [3, 2]})
        if kind and d0.y(kind) is not None:
            draw_bifurcation(ax, d0, kind, ms=1.0, color="0.72")
        m = len(bt["id"])
        colors = attractor_colors(sorted(set(bt["word"])))
        seen = set()
        big = set(np.argsort(-bt["attractors"], kind="stable")[:LABELLED].tolist())
        for b in range(m):
            lo = bt["low_at"][b] if np.isfinite(bt["low_at"][b]) else bt[f"min_{axis}"][b]
            hi = bt["high_at"][b] if np.isfinite(bt["high_at"][b]) else bt[f"max_{axis}"][b]
            c = colors[bt["word"][b]]
            axb.plot([lo, hi], [b, b], "-", lw=2.0, color=c, solid_capstyle="butt")
            if b in big:
                axb.text(hi, b, " " + label_tex(bt["word"][b]), fontsize=6, va="center",
                         color=c)
            for side, x in (("low", lo), ("high", hi)):
                k = bt[f"{side}_kind"][b]
                if k not in MARKS:
                    continue
                mk, words = MARKS[k]
                lab = None if k in seen else words
                seen.add(k)
                axb.plot([x], [b], mk, ms=4, color="k", mfc="none" if k != "no_orbit" else "k",
                         label=lab)
                pa = bt[f"{side}_point"][b][0]
                if kind == "impact_u" and math.isfinite(pa) and np.isfinite(bt[f"{side}_at"][b]):
                    ax.plot([x], [pa], mk, ms=4, color=c, mfc="none")
        from matplotlib.ticker import MaxNLocator  # start-up: loads matplotlib
        axb.yaxis.set_major_locator(MaxNLocator(integer=True))
        axb.set_ylabel("branch")
        axb.set_xlabel(axis)
        axb.set_ylim(-0.7, m - 0.3)
        axb.invert_yaxis()
        if seen:
            axb.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=6,
                       frameon=False, title="ends", title_fontsize=7)
        ax.set_ylabel(kind or "")
        for a in (ax, axb):
            a.ticklabel_format(axis="x", useOffset=False)
        if "xlim" in plot_cfg:
            ax.set_xlim(*plot_cfg["xlim"])
        if "ylim" in plot_cfg:
            ax.set_ylim(*plot_cfg["ylim"])
        sc = d0.scene.get("scene", {})
        ax.set_title(title_lines(title or plot_cfg.get("title") or
                                 f"{sc.get('title', sc.get('name', ''))}: {m} branches", 80),
                     fontsize=9)
        fig.tight_layout()
        return save(fig, out)


def _plane(plt, d0, bt, out, title, plot_cfg):
    """The skeleton of a sweep of two parameters: every located edge (``/branch_edges``) at
    its place in the plane (the located value on its grid line), marked by kind, coloured by
    its branch's word; the words of the LABELLED largest branches at their middle."""
    from ..plot_attractors import attractor_colors, label_tex  # start-up: loads matplotlib
    from ..plot_base import Undrawable  # start-up: loads matplotlib
    E = bt.get("edges")
    if E is None:
        raise Undrawable(f"{d0.path}: its branch table has no edges (stored by an older "
                         f"cornerbif); run `cornerbif explain {d0.path} --recompute` first")
    xa, ya = bt["axes"]
    fig, ax = plt.subplots(figsize=(7.5, 6.0))
    colors = attractor_colors(sorted(set(bt["word"])))
    tab_at = {a: _at(d0.path, a) for a in (xa, ya)}
    unplaced = 0
    if len(E["branch"]):
        row = E["attractor"]
        x = np.where(E["axis"] == 0, E["at"], tab_at[xa][row])
        yv = np.where(E["axis"] == 1, E["at"], tab_at[ya][row])
        for k, (mk, words) in MARKS.items():
            sel = (E["kind"] == k) & np.isfinite(x) & np.isfinite(yv)
            if sel.any():
                c = [colors[bt["word"][b]] for b in E["branch"][sel]]
                ax.scatter(x[sel], yv[sel], s=10, marker=mk, c=c, linewidths=0.5)
                ax.scatter([], [], s=10, marker=mk, c="k", label=f"{words} ({int(sel.sum())})")
        unplaced = int(np.sum(~(np.isfinite(x) & np.isfinite(yv))))
    if unplaced:          # an orbit that goes on unreached, a chaotic attractor's, ...
        ax.scatter([], [], s=0, label=f"{unplaced} more with no located value: not drawn")
    short = [b for b in np.argsort(-bt["attractors"], kind="stable")
             if len(bt["word"][b]) <= SHORT_WORD]
    for b in short[:LABELLED]:
        mine = bt["branch"] == b
        cx, cy = np.median(tab_at[xa][mine]), np.median(tab_at[ya][mine])
        ax.text(cx, cy, label_tex(bt["word"][b]), fontsize=7, ha="center", va="center",
                color=colors[bt["word"][b]], bbox={"fc": "white", "ec": "none", "alpha": 0.7,
                                                    "pad": 0.5})
    ax.set_xlabel(xa)
    ax.set_ylabel(ya)
    ax.ticklabel_format(useOffset=False)
    for lim, setter in (("xlim", ax.set_xlim), ("ylim", ax.set_ylim)):
        if lim in plot_cfg:
            setter(*plot_cfg[lim])
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=6, frameon=False,
              title="edges", title_fontsize=7)
    sc = d0.scene.get("scene", {})
    ax.set_title(title_lines(title or plot_cfg.get("title") or
                             f"{sc.get('title', sc.get('name', ''))}: {len(bt['id'])} branches, "
                             "their located edges", 80), fontsize=9)
    fig.tight_layout()
    return save(fig, out)


def _at(path, axis):
    """Each attractor's value of parameter ``axis`` (the table's ``at_<axis>``)."""
    import h5py  # start-up: loads h5py
    with h5py.File(path, "r") as f:
        return f[f"attractors/at_{axis}"][...]


FIGURE = Skeleton("branches", "the branches of an explained sweep and their ends",
                  files="one", explained=True)
