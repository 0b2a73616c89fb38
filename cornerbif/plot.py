"""Figures from HDF5 files only (plotting never runs kernels).

matplotlib's recipe: ``draw_*(ax, data, **kw) -> artists`` plus ``figure``,
which makes the whole figure.  matplotlib is imported here only, so
``cornerbif sweep`` starts fast and needs no display.
"""

from __future__ import annotations

import math
import tomllib

import numpy as np

from . import plot_normal_form, theory
from .io import check_readable

LABELS = {
    "omega": r"$\omega$", "kappa": r"$\kappa$", "beta": r"$\beta$", "r": r"$r$",
    "sigma": r"$\sigma$", "k": r"$k$", "theta1": r"$\theta_1$", "theta2": r"$\theta_2$",
    "F": r"$F$", "Omega": r"$\Omega$", "phi": r"$\varphi$",
    "omega0": r"$\omega_0$", "omega1": r"$\omega_1$", "omega2": r"$\omega_2$",
    "mu": r"$\mu = M/m$", "r1": r"$r_1$", "r2": r"$r_2$",
}
YLABELS = {
    "impact_u": "impact height $u$", "impact_v": "impact velocity $v^-$",
    "section_u": r"$u(nT)$ (map2d: $a_n$)", "section_v": r"$v(nT)$ (map2d: $b_n$)",
    "winding": r"winding number $W$ (share of $\gamma$, §5.4)",
    "period": "period (clusters per cycle)",
}


class PlotData:
    """What the plot needs, read from one file."""

    def __init__(self, path):
        with check_readable(path) as f:
            self.path = str(path)
            self.scene = tomllib.loads(f.attrs["scene"])
            self.axes = [k for k in self.scene.get("sweep", {}) if k != "follow"]
            self.values = {a: f[a][...] for a in self.axes}
            self.status = f["status"][...]
            self.period = f["period"][...]
            self.symbols = f["symbols"][...].astype(str)
            self.model = self.scene.get("scene", {}).get("model", "flow")
            self.done = f["done"][...]
            self.initial = {k: f[f"initial/{k}"][...] for k in ("u", "v") if f"initial/{k}" in f}
            self.data = {}
            for name in ("impacts/u", "impacts/v_in", "section/u", "section/v", "impacts/t",
                         "impacts/corner_offset"):
                if name in f:
                    self.data[name] = f[name][...]
            self.follow = self.scene.get("sweep", {}).get("follow", "none")
            self.complete = bool(f.attrs.get("completed", ""))

    def y(self, kind):
        if kind == "winding":
            w = np.vectorize(lambda s: s.count("g") / len(s) if s else np.nan, otypes=[float])
            return w(self.symbols)
        if kind == "period":
            return np.where(self.period > 0, self.period, np.nan).astype(float)
        name = {"impact_u": "impacts/u", "impact_v": "impacts/v_in",
                "section_u": "section/u", "section_v": "section/v"}[kind]
        return self.data.get(name)

    def default_y(self):
        if self.model == "map2d":
            return "section_v"
        for kind in ("impact_u", "section_u"):
            if self.y(kind) is not None:
                return kind
        return None


def points(x, y):
    """Bifurcation-diagram points: x repeated over every recorded value, NaN dropped."""
    xs = np.broadcast_to(x.reshape((-1,) + (1,) * (y.ndim - 1)), y.shape).ravel()
    ys = y.ravel()
    ok = np.isfinite(ys)
    return xs[ok], ys[ok]


def draw_bifurcation(ax, data: PlotData, y="impact_u", ms=0.6, color="k", label=None):
    """Parameter against impact height (or section values), small markers (paper Figs 1, 4, 6, 7)."""
    a = data.axes[0]
    xs, ys = points(data.values[a], data.y(y))
    return ax.plot(xs, ys, ls="none", marker=".", mew=0, ms=ms, color=color, label=label,
                   rasterized=True)


def draw_corner_points(ax, data: PlotData, corner_line=True):
    """Mark kappa_C and kappa_CC (eqs 11, 17) or omega_C, omega_CC on the swept axis."""
    sys_ = data.scene.get("system", {})
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
    for x, lab, c in marks:
        if math.isfinite(x) and lo <= x <= hi:
            arts.append(ax.axvline(x, color=c, lw=0.8, ls="--", label=f"{lab} = {x:.6g}"))
    return arts


def draw_plane(ax, data: PlotData):
    """Two-axis sweep: colour each point by the period of its attractor (first start)."""
    a, b = data.axes[:2]
    per = data.period.astype(float)
    per[per <= 0] = np.nan
    # the most common period over the starts
    with np.errstate(all="ignore"):
        show = np.nanmax(per, axis=-1)
    x, y = data.values[a], data.values[b]
    im = ax.pcolormesh(x, y, show.T, shading="nearest", cmap="viridis")
    if b == "mu" and np.all(y > 0) and y.max() / y.min() > 20:
        ax.set_yscale("log")
    ax.set_xlabel(LABELS.get(a, a))
    ax.set_ylabel(LABELS.get(b, b))
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
    for ax, d in zip(axs[:2], datas):
        draw_bifurcation(ax, d, kind, ms=plot_cfg.get("marker_size", 0.6))
        ax.set_ylabel(YLABELS[kind], fontsize=8)
        ax.set_title(f"{d.model}: {d.scene['scene']['name']}", fontsize=8, loc="left")
        if "ylim" in plot_cfg:
            ax.set_ylim(*plot_cfg["ylim"])
    dist = hausdorff_per_point(datas[0].y(kind), datas[1].y(kind))
    axs[2].semilogy(datas[0].values[a], dist, "k.", ms=1.5)
    axs[2].set_ylabel("distance\nflow to map", fontsize=8)
    axs[2].set_xlabel(LABELS.get(a, a))
    return axs


def figure(paths, out, y=None, title=None):
    """Draw one or more files of the same kind into ``out`` (png, pdf or svg)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    datas = [PlotData(p) for p in paths]
    d0 = datas[0]
    plot_cfg = d0.scene.get("plot", {})
    if plot_cfg.get("kind", "bifurcation") in plot_normal_form.KINDS:
        return plot_normal_form.figure(datas, out, plot_cfg, title)
    models = {d.model for d in datas}
    if len(datas) == 2 and models == {"flow", "map2d"} and len(d0.axes) == 1:
        datas.sort(key=lambda d: d.model != "flow")
        kind = y or "section_v"
        fig = plt.figure(figsize=(7, 7), dpi=150)
        axs = draw_comparison(fig, datas, kind, plot_cfg)
        import textwrap
        sc = datas[1].scene.get("scene", {})
        fig.suptitle("\n".join(textwrap.wrap(title or sc.get("title", ""), 80)), fontsize=9)
        fig.tight_layout()
        fig.savefig(out)
        plt.close(fig)
        return out
    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=150)
    if len(d0.axes) == 2:
        im = draw_plane(ax, d0)
        fig.colorbar(im, ax=ax, label="period (clusters per cycle; max over starts)")
    elif len(d0.axes) == 1:
        kind = y or plot_cfg.get("y") or d0.default_y()
        if kind is None or d0.y(kind) is None:
            plt.close(fig)
            raise ValueError(f"{d0.path}: no recorded observable to draw (output.keep was empty); "
                             "re-run with output.keep = [\"impacts\"]")
        colors = ["k", "tab:orange", "tab:green", "tab:purple"]
        for i, d in enumerate(datas):
            lab = None
            if len(datas) > 1:
                lab = f"follow {d.follow}" if d.follow != "none" else d.scene["scene"]["name"]
            draw_bifurcation(ax, d, kind, ms=plot_cfg.get("marker_size", 0.6),
                             color=colors[i % len(colors)], label=lab)
        if kind in ("impact_u", "winding", "section_v", "period"):
            draw_corner_points(ax, d0, corner_line=kind == "impact_u")
        a = d0.axes[0]
        ax.set_xlabel(LABELS.get(a, a))
        ax.set_ylabel(YLABELS[kind])
        if ax.get_legend_handles_labels()[0]:
            ax.legend(loc="best", fontsize=7, markerscale=8)
    else:
        plt.close(fig)
        raise ValueError(f"{d0.path}: a scene without a sweep axis has nothing to draw")
    if "xlim" in plot_cfg:
        ax.set_xlim(*plot_cfg["xlim"])
    if "ylim" in plot_cfg:
        ax.set_ylim(*plot_cfg["ylim"])
    sc = d0.scene.get("scene", {})
    import textwrap
    ax.set_title("\n".join(textwrap.wrap(title or plot_cfg.get("title")
                                          or sc.get("title", sc.get("name", "")), 80)), fontsize=9)
    if not all(d.complete for d in datas):
        ax.text(0.99, 0.01, "incomplete sweep", transform=ax.transAxes, ha="right", va="bottom",
                color="r", fontsize=8)
    fig.tight_layout()
    fig.savefig(out)
    plt.close(fig)
    return out
