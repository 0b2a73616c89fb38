"""``[plot] kind = "corner_curves"``: the curves kappa_C(omega) (eq 11) and kappa_CC(omega)
(eq 17) near omega = 2 (Fig. 7a), from the closed forms alone."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..model import FigureKind
from ..plot_style import save, title_lines
from .normal_form import normal_form_needs

if TYPE_CHECKING:
    from ..plot_data import PlotData


def figure_corner_curves(plt, data: PlotData, plot_cfg: dict, title=None):
    """The curves kappa_C(omega) (eq 11) and kappa_CC(omega) (eq 17) near omega = 2 (Fig. 7a).

    Theory only: the scene gives r, beta and the omega range ``[plot] xlim``.
    The regions are labelled with what section 3.3 says exists there: the
    single-impact orbit below kappa_C (eq 13), the double-impact orbit above
    kappa_CC (eq 19).
    """
    # start-up: drawing loads h5py, matplotlib and numba; checking a scene loads none
    from .. import theory
    from ..plot_base import LABELS  # start-up: loads numba
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


class CornerCurves(FigureKind):
    def check(self, w):
        """The curves are eqs (11) and (17) of z = kappa + beta |sin omega t|, drawn with the
        scene's r and beta: a scene of a model and obstacle with that corner normal form."""
        if w.spec.has_normal_form(w.obstacle):
            return []
        return [f"plot.kind: 'corner_curves' draws kappa_C and kappa_CC of z = kappa + beta "
                f"|sin omega t| (eqs 11, 17): it needs {normal_form_needs()} (this scene: model "
                f"{w.model!r}" + (f", obstacle {w.obstacle!r}" if w.spec.obstacles else "") + ")"]

    def draw(self, plt, datas, out, y, title, plot_cfg, color_by, branches):
        # start-up: drawing loads h5py and matplotlib; checking a scene loads neither
        from ..plot_base import partial_notes
        fig = figure_corner_curves(plt, datas[0], plot_cfg, title)
        partial_notes(fig, datas)
        return save(fig, out)


FIGURE = CornerCurves("corner_curves", "the corner curves of eqs (11), (17)", files="one")
