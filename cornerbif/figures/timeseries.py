"""``[plot] kind = "timeseries"``: the recorded attractors of one grid point rebuilt as u(t)
over the obstacle z(t) (Figs 1b, 5, 6d, 17)."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .. import registry
from ..model import FigureKind, cut
from ..plot_style import save, title_lines

if TYPE_CHECKING:
    from ..plot_data import PlotData

ROMAN = ("I", "II", "III", "IV", "V", "VI", "VII", "VIII")


def timeseries_choice(data: PlotData, plot_cfg: dict):
    """Grid point and starts a time-series figure shows.

    ``[plot] point`` is the grid index (default: the first point); ``ic`` a list
    of start indices or "distinct" (default): the first start of each distinct
    attractor at that point (``PlotData.attractors``), in rank order.  At most
    ``max_panels`` (default 4) panels.
    """
    # start-up: drawing loads h5py, matplotlib and numba; checking a scene loads none
    from ..plot_base import Undrawable
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


def draw_timeseries(ax, data, point, ic, cycles=2.0, color="k", label=None):
    """u(t) and z(t) over ``cycles`` cycles of the attractor reached by start ``ic`` of the
    file ``data`` (``plot_data.PlotData``).

    Rebuilt from the stored impacts by exact free flight (the model's ``time_series``);
    impacts are marked.  Time is counted from the section t0 = nT (T = 2 pi/omega)
    before the first recorded impact.  Returns a dict of what was drawn and measured.
    """
    scene, path = data.parsed, data.path
    if not scene.spec.timeseries:
        which = " or ".join(repr(m.name) for m in registry.models().values() if m.timeseries)
        raise ValueError(f"{path}: a time series needs a scene of model {which}, not "
                         f"{scene.model!r}")
    run = data.run_record(point, ic)
    t, u, vo, off = (run[k] for k in ("t", "u", "v_out", "corner_offset"))
    per, ipc, word, st = run["period"], run["ipc"], run["word"], run["status"]
    vals = scene.point(tuple(point))
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
    flights = scene.spec.time_series(scene, vals, t, u, vo, t0, t1)
    s, us, zs, err, p, d = (flights[k] for k in ("t", "u", "z", "meet", "p", "d"))
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
    # start-up: drawing loads h5py, matplotlib and numba; checking a scene loads none
    from ..plot_base import word_label
    return word_label(word) if word else "no cycle"


def figure_timeseries(plt, data: PlotData, plot_cfg: dict, title=None):
    """One panel per chosen attractor, stacked (paper Figs 1b, 5, 6d, 17)."""
    # start-up: drawing loads h5py, matplotlib and numba; checking a scene loads none
    from ..plot_base import ATTRACTOR_COLORS, obstacle_kind
    point, chosen, lab = timeseries_choice(data, plot_cfg)
    n = len(chosen)
    fig, axs = plt.subplots(n, 1, figsize=(7, 1.2 + 2.0 * n), dpi=150, squeeze=False)
    info = []
    for k, (ax, ic) in enumerate(zip(axs[:, 0], chosen)):
        rank = int(lab[ic])
        color = "k" if n == 1 else ATTRACTOR_COLORS[k % len(ATTRACTOR_COLORS)]
        r = draw_timeseries(ax, data, point, ic, cycles=float(plot_cfg.get("cycles", 2)),
                            color=color)
        name = (ROMAN[rank] + ": ") if (n > 1 and 0 <= rank < len(ROMAN)) else ""
        ax.set_title(f"{name}start {ic}: period {r['period']} (map iterates), impacts per cycle "
                     f"{r['ipc']}, word {_word_text(r['word'])}; the rebuilt flight meets $z$ at "
                     f"the next impact to {r['meet']:.1e}", fontsize=7, loc="left")
        v = r["vals"]
        b = obstacle_kind(data.scene["system"], getattr(data, "spec", None)).resonant_amplitude(v)
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


class TimeSeries(FigureKind):
    def check(self, w):
        problems = []
        if not w.spec.timeseries:
            which = " or ".join(repr(m.name) for m in registry.models().values() if m.timeseries)
            problems.append(f"plot.kind: 'timeseries' needs model {which} (the scene's model is "
                            f"{w.model!r})")
        if "impacts" not in w.keep:
            problems.append("plot.kind: 'timeseries' is rebuilt from the impacts; "
                            "output.keep must contain \"impacts\"")
        return problems

    def draw(self, plt, datas, out, y, title, plot_cfg, color_by, branches):
        # start-up: drawing loads h5py and matplotlib; checking a scene loads neither
        from ..plot_base import partial_notes
        fig, _ = figure_timeseries(plt, datas[0], plot_cfg, title)
        partial_notes(fig, datas)
        return save(fig, out)


FIGURE = TimeSeries("timeseries", "time series of one grid point", files="one")
