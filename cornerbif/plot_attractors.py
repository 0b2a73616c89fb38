"""Figures of a file's attractor table (``cornerbif.attractors``): basin images and basin
fractions against a parameter.

Colours mean the same orbit everywhere: an attractor's colour is a function of its label
(its word, and ``#2``, ``#3`` for the second and third attractor with that word at one
parameter point, by the mean of the first cycle series), not of its rank in one figure
(``attractor_colors``).  The runs that reached no attractor are drawn in greys, one per
outcome code (``OUTCOME_COLORS``).
"""

from __future__ import annotations

import re
import zlib

import numpy as np

from . import plot_style
from .analysis import run_length
from .attractors import CODES, ESCAPES, FAILED, NO_CYCLE, NOT_RUN, STICKS, read_table
from .chaos import CHAOTIC
from .plot_style import Rows, row_slabs

# tab20 without its two greys: dark and light of nine hues
PALETTE = ("#1f77b4", "#aec7e8", "#ff7f0e", "#ffbb78", "#2ca02c", "#98df8a", "#d62728",
           "#ff9896", "#9467bd", "#c5b0d5", "#8c564b", "#c49c94", "#e377c2", "#f7b6d2",
           "#bcbd22", "#dbdb8d", "#17becf", "#9edae5")
# the three one-cluster orbits of sections 4.2-4.4 keep fixed colours
FIXED = {"b": 0, "a": 2, "g": 4}
OUTCOME_COLORS = {NO_CYCLE: "0.8", STICKS: "0.45", ESCAPES: "0.1", FAILED: "#efe6c8",
                  NOT_RUN: "w"}


def attractor_labels(table) -> list:
    """Each row's label: its word, with ``#k`` for the k-th attractor of that word at its
    parameter point (k >= 2, in the table's order, i.e. by the mean of series a)."""
    seen = {}
    out = []
    for p, w in zip(table["parameter_point"], table["word"]):
        k = seen.get((int(p), w), 0) + 1
        seen[(int(p), w)] = k
        out.append(w if k == 1 else f"{w}#{k}")
    return out


def preferred_slot(label: str) -> int:
    """The palette slot a label asks for: fixed for b, a, g, else a hash of the label
    (crc32, the same in every process and on every machine)."""
    if label in FIXED:
        return FIXED[label]
    return zlib.crc32(label.encode()) % len(PALETTE)


def attractor_colors(labels) -> dict:
    """A colour per distinct label: its preferred slot, or the next free one when another
    label of the same figure holds it (labels taken in order of (length, label), so the
    choice depends only on the set).  Past the free slots colours repeat, but never
    beta's, alpha's or gamma's."""
    labels = list(labels)
    # beta's, alpha's and gamma's colours are theirs in every figure (no other orbit takes
    # them, even where they are absent), and the light partner of one in the palette's
    # pairs is kept free while that orbit is in the figure: alpha's orange and a light
    # orange were hard to tell apart (Fig. 18(a))
    reserved = set(FIXED.values()) | {FIXED[lab] + 1 for lab in set(labels) & set(FIXED)}
    taken = dict.fromkeys(reserved)
    out = {}
    for lab in sorted(set(labels), key=lambda s: (s not in FIXED, len(s), s)):
        slot = FIXED.get(lab, preferred_slot(lab))
        if lab not in FIXED:
            # the next free slot; once every slot is used, the next one not reserved
            # (colours then repeat, but never a fixed orbit's)
            full = len(taken) >= len(PALETTE)
            while slot in (reserved if full else taken):
                slot = (slot + 1) % len(PALETTE)
        taken[slot] = lab
        out[lab] = PALETTE[slot]
    return out


def _greek(w: str) -> str:
    """A run-length word ('b$^{3}$ g', 'b^N g') in the paper's letters, as one math text."""
    for a, b in (("a", r"\alpha"), ("b", r"\beta"), ("g", r"\gamma")):
        w = w.replace(a, b)
    return "$" + w.replace("$", "").replace(" ", r"\,") + "$"


# the most letters of a word (after run-length: b^11 is one) a label shows; the rest "..."
LABEL_LETTERS = 16


def label_tex(label: str) -> str:
    """A label in the paper's notation: 'bbbg#2' -> '$\\beta^{3}\\gamma$ #2'; a word of more
    than LABEL_LETTERS runs shows its first ones, then '...'."""
    word, _, k = label.partition("#")
    if word == CHAOTIC:
        return "chaotic" + (f" #{k[:12]}" if k else "")
    runs = run_length(word, tex=True, empty="?").split(" ")
    w = _greek(" ".join(runs[:LABEL_LETTERS])) + (" ..." if len(runs) > LABEL_LETTERS else "")
    return f"{w} #{k[:12]}" if k else w


def draw_basin(ax, path, axes, values, labels_of=None):
    """Two swept start coordinates: each cell coloured by its attractor (the table's id,
    colours by label; with several starts per cell, its first start's), the outcomes
    without one in greys; the legend gives each
    attractor's share of the cells (a grid's share has no sampling error: its convergence
    is shown by refining, docs/basins.md)."""
    import matplotlib.colors as mcolors  # start-up: loads matplotlib
    import matplotlib.patches as mpatches  # start-up: loads matplotlib
    table = read_table(path)
    n_ic = table["ids"].shape[-1]
    ids = table["ids"][..., 0]        # the first start of each cell (module doc)
    labels = attractor_labels(table)
    colors = attractor_colors(labels if labels_of is None else labels_of)
    R = len(labels)
    codes = sorted(CODES)                          # -5 .. -1
    palette = [OUTCOME_COLORS[c] for c in codes] + [colors[lab] for lab in labels]
    index = np.where(ids >= 0, ids + len(codes), ids - codes[0])
    cmap = mcolors.ListedColormap(palette)
    a, b = axes
    im = ax.pcolormesh(values[a], values[b], index.T, shading="nearest", cmap=cmap,
                       vmin=-0.5, vmax=len(palette) - 0.5, rasterized=True)
    handles = []
    for i in np.argsort(-table["runs"], kind="stable"):
        handles.append(mpatches.Patch(
            color=colors[labels[i]],
            label=f"{label_tex(labels[i])}: {table['fraction'][i]:.2%} of the "
                  + ("cells" if n_ic == 1 else "runs")))
    every = table["ids"]
    n = every.size
    for c in reversed(codes):
        k = int((every == c).sum())
        if k:
            handles.append(mpatches.Patch(facecolor=OUTCOME_COLORS[c], edgecolor="0.6",
                                          label=f"{CODES[c]}: {k / n:.1%}"))
    title = f"attractor reached ({R} found)"
    if n_ic > 1:
        title += f"\ncells: the first of {n_ic} starts;\nshares: every start"
    ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=7,
              title=title, title_fontsize=7, frameon=False)
    return im


def fraction_series(table, n_points):
    """Per label, its fraction and the 95 % interval of it at each parameter point (NaN
    where the label has no attractor): {label: (fraction, low, high), each (n_points,)}.
    The interval is the table's Wilson interval (``share_low``, ``share_high``), or +-1
    standard error in a file written before the table had one."""
    labels = attractor_labels(table)
    lo = table.get("share_low", table["fraction"] - table["standard_error"])
    hi = table.get("share_high", table["fraction"] + table["standard_error"])
    out = {}
    for lab, p, f, a, b in zip(labels, table["parameter_point"], table["fraction"], lo, hi):
        if lab not in out:
            out[lab] = tuple(np.full(n_points, np.nan) for _ in range(3))
        out[lab][0][p], out[lab][1][p], out[lab][2][p] = f, a, b
    return out


LOG_SPAN = 100.0     # shares spanning more than this factor are drawn on a log scale


def draw_fractions(ax, path, x, min_share=0.0):
    """Basin fractions against a swept parameter (random starts at each point): one line
    per attractor label with a band of its 95 % interval (Wilson: right for rare basins,
    a share of 0 keeps an upper bound), and the share of the starts that found no
    attractor (dotted), on a log scale where the shares drawn span more than LOG_SPAN.
    Labels whose largest fraction stays below ``min_share`` are summed into one grey line."""
    table = read_table(path)
    series = fraction_series(table, x.size)
    colors = attractor_colors(series)
    rare = np.zeros(x.size)
    order = sorted(series, key=lambda lab: -np.nanmax(series[lab][0]))
    drawn = []
    for lab in order:
        f, lo, hi = series[lab]
        if np.nanmax(f) < min_share:
            rare += np.nan_to_num(f)
            continue
        ax.plot(x, f, "-", lw=1.0, color=colors[lab], label=label_tex(lab))
        ax.fill_between(x, lo, hi, color=colors[lab], alpha=0.25, lw=0)
        drawn.append(f)
    if rare.any():
        ax.plot(x, rare, "-", lw=0.8, color="0.5", label=f"others (each < {min_share:.0%})")
    out = table["outcomes"]
    none = 1.0 - out[:, 0] / out.sum(axis=1)
    if np.any(none > 0):
        ax.plot(x, none, ":", lw=1.0, color="k", label="no attractor")
    pos = np.concatenate([d[np.isfinite(d) & (d > 0)] for d in drawn]) if drawn else []
    if len(pos) and pos.max() / pos.min() > LOG_SPAN:
        ax.set_yscale("log")
        ax.set_ylim(0.5 * pos.min(), 1.5)
    else:
        ax.set_ylim(-0.02, 1.02)
    ax.set_ylabel(f"fraction of starts ({table['runs_per_point']} per point; band: 95 % "
                  "Wilson interval)")
    return series


def family(label: str) -> str:
    """The family of an orbit's label: its word run-length encoded with every power of two
    or more written N ('bbbba#2' -> 'b^N a', 'abbgbbbg' -> 'a b^N g b^N g'): the period-adding
    cascades beta^N alpha and beta^N gamma (section 5) each become one label."""
    return re.sub(r"\^\d+", "^N", run_length(label.partition("#")[0]))


def family_tex(fam: str) -> str:
    """A family in the paper's notation: 'b^N a' -> '$\\beta^N\\,\\alpha$'."""
    return _greek(fam)


def run_labels(table, families=False):
    """Every run's attractor as an index into the returned label list, -1 where the run
    reached none: (index array shaped like the file's ``/attractor``, labels); with
    ``families``, the labels are the orbits' families (``family``)."""
    names, row = label_rows(table, families)
    return run_index(table["ids"], row), names


def label_rows(table, families=False, branches=False):
    """The distinct labels of the table's rows, sorted (their families with
    ``families``; with ``branches``, each row's branch of ``cornerbif explain``, its word
    and "#branch N", the table having them), and each row's index into them."""
    labels = attractor_labels(table)
    if branches:
        labels = [f"{w}#branch {int(b)}" for w, b in zip(table["word"], table["branch"])]
    elif families:
        labels = [family(lab) for lab in labels]
    names = sorted(set(labels))
    at = {lab: i for i, lab in enumerate(names)}
    return names, np.array([at[lab] for lab in labels], np.int64)


def run_index(ids, row):
    """The runs' attractor ids (``/attractor``: a table row, < 0 for none) as label
    indices (``row``: each table row's), -1 where a run reached none."""
    return np.where(ids >= 0, row[np.maximum(ids, 0)] if row.size else -1, -1)


def label_counts(ids, row, n_labels):
    """(runs per label, runs without an attractor) of the attractor ids ``ids`` (an array
    or ``plot_style.Rows``), counted a slab of rows at a time."""
    counts = np.zeros(n_labels, np.int64)
    none = 0
    for _, block in row_slabs(ids):
        found = block[block >= 0]
        counts += np.bincount(row[found], minlength=n_labels)
        none += block.size - found.size
    return counts, none


def draw_diagram_by_label(ax, path, x, yv, ms, shown=8, families=False, window=None,
                          xlim=None, also=(), colors_out=None, branches=False):
    """A one-parameter diagram coloured by what each run's orbit is: its attractor's label
    (the word; the same colour in every figure, ``attractor_colors``).  The ``shown``
    labels with the most runs are named in the paper's notation; the other cycles are
    black, the runs without a cycle light grey.  ``yv``: (points, starts, record).
    ``families``: one colour per family of orbits (``family``: beta^N gamma for every N);
    ``branches``: one per branch (``cornerbif explain``'s, the file having them).
    ``window`` (the y-window): draw the points as one image (``plot_style.raster_runs``,
    for millions of points: memory that does not grow with them; ``yv`` may then be
    ``plot_style.Rows``, read a slab at a time), ``xlim`` its x-window.  ``also``: labels
    the figure draws besides (continued branches' words or families), coloured in the same
    map; ``colors_out`` (a dict) receives that map.
    Returns the legend's handles (the caller places the legend with its other lines)."""
    table = read_table(path)
    names, row = label_rows(table, families, branches)
    tex = family_tex if families else label_tex
    counts, none = label_counts(table["ids"], row, len(names))
    top = [int(i) for i in np.argsort(-counts, kind="stable")[:shown] if counts[i] > 0]
    colors = attractor_colors([names[i] for i in top] + list(also))
    if colors_out is not None:
        colors_out.update(colors)
    handles = _legend_handles(counts, none, names, top, colors, tex)
    if window is not None:
        # layer 1 the other cycles, 2 + k the k-th label shown
        label_layer = np.ones(len(names), np.int16)
        label_layer[top] = 2 + np.arange(len(top))
        _raster_by_label(ax, x, yv, table["ids"], label_layer[row],
                         ["0.78", "k"] + [colors[names[i]] for i in top], ms, window, xlim)
        return handles
    idx = run_index(table["ids"], row)
    xs_all = np.broadcast_to(x[:, None, None], yv.shape)

    def scatter(sel, color, z):
        m = sel[..., None] & np.isfinite(yv)
        if m.any():
            ax.plot(xs_all[m], yv[m], ls="none", marker=".", mew=0, ms=ms, color=color,
                    rasterized=True, zorder=z)
    scatter(idx < 0, "0.78", 1)
    scatter((idx >= 0) & ~np.isin(idx, top), "k", 2)
    for rank, i in enumerate(top):
        scatter(idx == i, colors[names[i]], 3 + rank)
    return handles


def _raster_by_label(ax, x, yv, ids, row_layer, cols, ms, window, xlim=None):
    """``draw_diagram_by_label`` as one image: layer 0 the runs without a cycle, 1 the other
    cycles, 2 + k the k-th label shown (the rarer over the more common, as the markers;
    ``row_layer``: each table row's layer, ``cols``: each layer's colour).  The runs'
    layers are made from their ids a slab at a time, beside their values."""
    import matplotlib as mpl  # start-up: loads matplotlib

    row_layer = np.append(row_layer, np.int16(0))        # the last: no attractor (id < 0)
    layer = Rows(ids.shape, lambda a, b: row_layer[np.where(ids[a:b] >= 0, ids[a:b], -1)])
    if xlim is None:
        span = float(x.max() - x.min()) or 1.0
        xlim = (float(x.min()) - 0.05 * span, float(x.max()) + 0.05 * span)
    dpi = mpl.rcParams["savefig.dpi"]
    plot_style.raster_runs(ax, x, yv, layer, cols, xlim, window, ms,
                           dpi if isinstance(dpi, (int, float)) else 300)


def _legend_handles(counts, none, names, top, colors, tex):
    """The diagram's legend: the labels shown, then "no cycle" and the other cycles where
    there are runs of them (``counts``: runs per label; ``none``: runs without one)."""
    from matplotlib.lines import Line2D  # start-up: loads matplotlib

    def dot(color, label):
        return Line2D([], [], ls="none", marker="o", ms=4, mew=0, color=color, label=label)
    handles = [dot(colors[names[i]], tex(names[i])) for i in top]
    if none:
        handles.append(dot("0.78", "no cycle"))
    n_other = int(np.count_nonzero(counts)) - len(top)
    if n_other:
        handles.append(dot("k", f"{n_other} other cycle{'s' if n_other > 1 else ''}"))
    return handles
