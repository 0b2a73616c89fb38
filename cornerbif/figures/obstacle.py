"""``[plot] kind = "obstacle"``: the obstacle z(t) with its corners and the wedge of eq (7)
at a corner (Fig. 2)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from .. import registry
from ..model import FigureKind
from ..plot_style import save, title_lines

if TYPE_CHECKING:
    from ..plot_data import PlotData


def obstacle_curve(data: PlotData):
    """z(t) of a scene's obstacle at its system values (the model's ``wall_at``: the kernels'
    own obstacle) as a function of t, its period and the scene."""
    scene = data.parsed
    model = scene.spec
    row = np.ascontiguousarray(model.pack_values(scene.system, scene)[None, :])

    def z(t):
        return model.wall_at(row, np.asarray(t, float)[None, :])[0]
    kind = model.obstacles[scene.extra["obstacle"]]
    return z, kind.period(scene.system["omega"], scene.obstacle_table), scene


def figure_obstacle(plt, data: PlotData, plot_cfg: dict, title=None):
    """The obstacle z(t) (Fig. 2): (a) ``[plot] cycles`` periods (default 2) with the corners
    t_k = k P marked, (b) a magnification around the corner t_0 = P with the two slopes of
    the wedge of eq (7), z ~ kappa + theta2 (t - t_0) after it and kappa + theta1 (t_0 - t)
    before it (theta1 = theta2 = beta omega for z = kappa + beta |sin omega t|)."""
    # start-up: drawing loads h5py, matplotlib and numba; checking a scene loads none
    from ..plot_base import obstacle_kind
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
    if obstacle_kind(sys_, getattr(data, "spec", None)).corner_wedge:
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


class ObstacleFigure(FigureKind):
    def check(self, w):
        ob = w.spec.obstacles.get(w.obstacle) if w.spec.obstacles else None
        if ob is not None and ob.corner_wedge:
            return []
        wedges = [(m.name, o.name) for m in registry.models().values()
                  for o in m.obstacles.values() if o.corner_wedge]
        models = " or ".join(dict.fromkeys(repr(m) for m, _ in wedges))
        return ["plot.kind: 'obstacle' draws z(t) with its corners at the period's start and "
                f"the wedge of eq (7) (Fig. 2): it needs model {models} with obstacle "
                + " or ".join(repr(o) for _, o in wedges) + f" (this scene: model {w.model!r}"
                + (f", obstacle {w.obstacle!r}" if w.spec.obstacles else "") + ")"]

    def draw(self, plt, datas, out, y, title, plot_cfg, color_by, branches):
        # start-up: drawing loads h5py and matplotlib; checking a scene loads neither
        from ..plot_base import partial_notes
        fig = figure_obstacle(plt, datas[0], plot_cfg, title)
        partial_notes(fig, datas)
        return save(fig, out)


FIGURE = ObstacleFigure("obstacle", "the obstacle's shape", files="one")
