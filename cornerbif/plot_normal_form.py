"""Figures of the corner normal form in the (a0, b1) plane (paper section 4.5-5.4).

Three plot kinds, chosen by ``[plot] kind`` in the scene of the first file:

``regions`` (Fig. 9)
    The starts x0 = (a0, b1) of a scene without sweep axes, coloured by the map
    that acts on them.  A ``map2d`` file is coloured by the rule (56) itself
    (:func:`cornerbif.models.map2d.maps.region`); a ``flow`` file by what the flow did in
    its first period: the impacts of the cluster at the corner t0 = pi/omega
    read as in section 4 (one just after t0: beta; one just before: gamma;
    one on each side: alpha; anything else: x).  The lines Sigma_1 (C x =
    kappa1, eqs 36/39) and Sigma_2 (a0 = 2 + 4/r, eq 41) are drawn from the
    closed forms.
``return_map`` (Fig. 10)
    A0 (the section value u one period T = 2 pi/omega after the start) against
    a0 = u(0), for starts on a line b1 = const.  It needs ``run.transient =
    0``: a flow file's first section slot is then u(T); a map2d file's slot 0
    is x0 itself and slot 1 is x1 = P(x0).
``orbit`` (Fig. 11)
    The recorded section points (a_n, b_n) of each start, coloured by region,
    with Sigma_1, the beta fixed point x_beta* (64) and its image x** (section
    5.4) marked: near kappa1 = kappa_beta the (beta^N gamma) / (beta^N alpha)
    orbits approximate the homoclinic orbits (beta^inf gamma) / (beta^inf alpha).

With epsilon = 1 the flow's section values at the paper's section are the
map's x = (a0, b1) (see :mod:`cornerbif.models.map2d.maps`), so a flow file and a map2d
file of the same scene draw on the same axes.
"""

from __future__ import annotations

import math

import numpy as np

from . import registry, theory
from .analysis import run_length
from .plot_style import emptiest_corner, legend, save, title_lines

REGION_COLORS = {"a": "tab:blue", "b": "tab:orange", "g": "tab:green", "x": "0.6"}
REGION_NAMES = {"a": r"$S_\alpha$", "b": r"$S_\beta$", "g": r"$S_\gamma$", "x": "other"}


def _system(data):
    s = data.scene.get("system", {})
    omega = s.get("omega", 2.0)
    return omega, omega - 2.0, s.get("kappa", 0.0), s.get("r", 0.8)


def draw_sigma(ax, omega1, kappa1, r, alim, blim):
    """Sigma_1: b = kappa1 - (pi omega1/4) a (eqs 36, 39); Sigma_2: a = 2 + 4/r below it (41)."""
    a = np.linspace(alim[0], alim[1], 200)
    arts = ax.plot(a, kappa1 - 0.25 * math.pi * omega1 * a, "k-", lw=0.9,
                   label=r"$\Sigma_1$: $\pi\omega_1 a_0/4 + b_1 = \kappa_1$")
    e = 2.0 + 4.0 / r
    if alim[0] <= e <= alim[1]:
        top = kappa1 - 0.25 * math.pi * omega1 * e
        arts += ax.plot([e, e], [min(blim[0], top), top], "k--", lw=0.9,
                        label=r"$\Sigma_2$: $a_0 = 2 + 4/r$")
    return arts


def draw_regions(ax, data, ms=1.5):
    """Fig. 9: starts coloured by the map that acts on them, with Sigma_1, Sigma_2."""
    omega, omega1, kappa1, r = _system(data)
    a0 = data.initial["u"].ravel()
    b0 = data.initial["v"].ravel()
    lab, source = data.normal_form.start_regions(data, omega, omega1, kappa1, r)
    for ch in "abgx":
        m = lab == ch
        if m.any():
            ax.plot(a0[m], b0[m], ls="none", marker=".", mew=0, ms=ms, color=REGION_COLORS[ch],
                    label=f"{REGION_NAMES[ch]} ({int(m.sum())})", rasterized=True)
    alim = (float(a0.min()), float(a0.max()))
    blim = (float(b0.min()), float(b0.max()))
    draw_sigma(ax, omega1, kappa1, r, alim, blim)
    ax.set_xlim(*alim)
    ax.set_ylim(*blim)
    ax.set_xlabel(r"$a_0 = u(0)$")
    ax.set_ylabel(r"$b_1 = u'(0)$")
    ax.set_title(f"{data.model}: coloured by {source}", fontsize=8, loc="left")
    return lab


def return_values(data):
    """(a0, A0) of every start: A0 is the section value u one period after the start."""
    if int(data.scene.get("run", {}).get("transient", 500)) != 0:
        raise ValueError(f"{data.path}: plot kind 'return_map' needs run.transient = 0 "
                         "(A0 is the first section after the start)")
    su = data.data.get("section/u")
    if su is None:
        raise ValueError(f"{data.path}: plot kind 'return_map' needs output.keep = [\"section\"]")
    a0 = data.initial["u"].ravel()
    col = data.normal_form.first_return
    A0 = su.reshape(a0.size, -1)[:, col]
    order = np.argsort(a0)
    return a0[order], A0[order]


def maps():
    """The maps' side of the normal form (the registered model whose ``normal_form`` is the
    maps): a figure asks it for the maps' steps and regions."""
    return next(m.normal_form for m in registry.models().values()
                if m.normal_form is not None and m.normal_form.maps)


def map_return_line(omega1, kappa1, r, b1, a0):
    """A0 of the linear maps (34), (37), (52) at x0 = (a0, b1), region by (56)."""
    A0 = np.empty_like(a0)
    for i, a in enumerate(a0):
        A0[i] = maps().step(a, b1, omega1, kappa1, r)[0]
    return A0


def draw_return_map(ax, data, ms=1.5, color="k", label=None):
    """Fig. 10: A0 against a0 on a line of starts b1 = const."""
    a0, A0 = return_values(data)
    arts = ax.plot(a0, A0, ls="none", marker=".", mew=0, ms=ms, color=color, label=label,
                   rasterized=True)
    ax.set_xlabel(r"$a_0$")
    ax.set_ylabel(r"$A_0$ (section value after one period $T$)")
    return arts


def _word(data):
    w = [str(x) for x in np.ravel(data.symbols) if str(x)]
    return run_length(w[0], tex=True) if w else "none found"


def draw_orbit(ax, data, ms=4.0):
    """Fig. 11: recorded section points (a_n, b_n).

    A map2d file's points are coloured by the region that maps them (56); a flow
    file's points are drawn as black crosses: the flow has no regions, only its
    word (read from its impacts), which the label states.
    """
    omega, omega1, kappa1, r = _system(data)
    su, sv = data.data.get("section/u"), data.data.get("section/v")
    if su is None:
        raise ValueError(f"{data.path}: plot kind 'orbit' needs output.keep = [\"section\"]")
    a, b = su.ravel(), sv.ravel()
    ok = np.isfinite(a) & np.isfinite(b)
    a, b = a[ok], b[ok]
    lab = data.normal_form.point_regions(a, b, omega1, kappa1, r)
    if lab is None:               # no regions of its own: the system's points, its word
        ax.plot(a, b, ls="none", marker="x", ms=1.6 * ms, mew=0.9, color="k",
                label=f"flow: $(u, u')(nT)$, word {_word(data)}")
        return a, b
    for ch in "abg":
        m = lab == ch
        if m.any():
            ax.plot(a[m], b[m], ls="none", marker="o", ms=ms, mew=0, color=REGION_COLORS[ch],
                    label=f"map2d: {int(m.sum())} iterates in {REGION_NAMES[ch]}")
    ax.plot([], [], ls="none", label=f"map2d word {_word(data)}")
    return a, b


def draw_orbit_frame(ax, datas):
    """Sigma_1, Sigma_2, x_beta* (64) and its image x** under gamma or alpha (section 5.4)."""
    omega, omega1, kappa1, r = _system(datas[0])
    xs = theory.fixed_point("beta", omega1, kappa1, r)
    xss = np.array(maps().step(xs[0], xs[1] - 1e-12, omega1, kappa1, r)[:2])
    pts = [d.data["section/u"].ravel() for d in datas] + [[xs[0], xss[0]]]
    allpts = np.concatenate([np.asarray(p, float) for p in pts])
    allpts = allpts[np.isfinite(allpts)]
    pad = 0.08 * (allpts.max() - allpts.min() + 1e-9)
    alim = (allpts.min() - pad, allpts.max() + pad)
    bs = np.concatenate([d.data["section/v"].ravel() for d in datas] + [[xs[1], xss[1]]])
    bs = bs[np.isfinite(bs)]
    bpad = 0.1 * (bs.max() - bs.min() + 1e-12)
    blim = (bs.min() - bpad, bs.max() + bpad)
    draw_sigma(ax, omega1, kappa1, r, alim, blim)
    ax.plot([xs[0]], [xs[1]], "k*", ms=9, label=r"$x_\beta^*$ (64)")
    which = r"\gamma" if maps().region(xs[0], xs[1] - 1e-12, omega1, kappa1, r) == 2 else r"\alpha"
    ax.plot([xss[0]], [xss[1]], "kP", ms=8, mfc="none",
            label=rf"$x^{{**}} = {which}(x_\beta^*)$")
    ax.set_xlim(*alim)
    ax.set_ylim(*blim)
    ax.set_xlabel(r"$a_n$ (flow: $u(nT)$)")
    ax.set_ylabel(r"$b_n$ (flow: $u'(nT)$)")


def figure(datas, out, plot_cfg, title, draw):
    """Draw one or two files (flow and/or map2d) by ``draw``, the function its figure kind
    names (``figures.normal_form.NormalFormKind.drawer``): the regions of the starts (Fig. 9,
    ``figure_regions``), the return maps (Fig. 10, ``figure_return_maps``) or the orbits
    (Fig. 11, ``figure_orbits``)."""
    import matplotlib.pyplot as plt  # start-up: loads matplotlib

    kind = plot_cfg["kind"]
    for d in datas:
        if d.axes:
            raise ValueError(f"{d.path}: plot kind {kind!r} draws a scene without sweep axes "
                             f"(this one sweeps {', '.join(d.axes)})")
    datas = sorted(datas, key=lambda d: d.normal_form.order)
    ms = plot_cfg.get("marker_size")
    fig = draw(plt, datas, ms)
    sc = datas[-1].scene.get("scene", {})
    fig.suptitle(title_lines(title or plot_cfg.get("title") or sc.get("title", sc.get("name", "")),
                             90), fontsize=9)
    fig.tight_layout()
    return save(fig, out)


def figure_regions(plt, datas, ms):
    """The regions of the starts, flow and map side by side, with the share of starts whose
    letter the map gives as the flow does (Fig. 9)."""
    fig, axs = plt.subplots(1, len(datas), figsize=(5.2 * len(datas), 4.6), dpi=150,
                            squeeze=False, sharex=True, sharey=True)
    labs = [draw_regions(ax, d, ms=ms or 1.5) for ax, d in zip(axs[0], datas)]
    if len(datas) == 2:
        agree = float(np.mean(labs[0] == labs[1]))
        axs[0][1].text(0.01, 0.01, f"same letter as the flow: {100 * agree:.2f} % of starts",
                       transform=axs[0][1].transAxes, fontsize=7)
    for ax in axs[0]:
        legend(ax, loc="upper right", fontsize=6, markerscale=5)
    return fig


def figure_return_maps(plt, datas, ms):
    """The return maps A0 of a flow and of the linear maps (56), the transitions Sigma_1 and
    Sigma_2 marked, the maps' curve over the flow's with an inset at the grazing Sigma_2,
    where the flow has a square-root form (Fig. 10)."""
    fig, axs = plt.subplots(1, len(datas), figsize=(5.2 * len(datas), 4.4), dpi=150,
                            squeeze=False, sharey=True)
    for ax, d in zip(axs[0], datas):
        draw_return_map(ax, d, ms=ms or 1.5)
        omega, omega1, kappa1, r = _system(d)
        b1 = float(np.nanmean(d.initial["v"]))
        lo, hi = ax.get_xlim()
        s1 = (kappa1 - b1) / (0.25 * math.pi * omega1) if omega1 else math.nan
        for x, lab in ((s1, r"$\Sigma_1$"), (2.0 + 4.0 / r, r"$\Sigma_2$")):
            if math.isfinite(x) and lo <= x <= hi:
                ax.axvline(x, color="0.5", lw=0.7, ls=":")
                ax.text(x, 1.0, lab, transform=ax.get_xaxis_transform(), ha="center",
                        va="bottom", fontsize=7)
        name = "(a) the impacting system (flow)" if not d.normal_form.maps else \
            "(b) the linear maps (56)"
        ax.set_title(name, fontsize=8, loc="left", pad=12)
    if not datas[0].normal_form.maps and len(datas) == 2:
        a0, A0 = return_values(datas[0])
        a0m, A0m = return_values(datas[1])
        ax = axs[0][0]
        ax.plot(a0m, A0m, "-", color="tab:red", lw=0.6, alpha=0.7, label="linear maps")
        legend(ax, loc="upper center", fontsize=7)
        # inset: the grazing transition Sigma_2, where the flow has a square-root form
        omega, omega1, kappa1, r = _system(datas[0])
        e = 2.0 + 4.0 / r
        # in the corner with the fewest points of either curve: it hides no data
        ax.autoscale_view()
        ins = ax.inset_axes(emptiest_corner(ax, np.concatenate([a0, a0m]),
                                            np.concatenate([A0, A0m]), avoid=()))
        m = np.abs(a0 - e) < 0.25
        ins.plot(a0[m], A0[m], "k.", ms=1.5, mew=0)
        mm = np.abs(a0m - e) < 0.25
        ins.plot(a0m[mm], A0m[mm], "-", color="tab:red", lw=0.6)
        ins.axvline(e, color="0.5", lw=0.6, ls=":")
        ins.tick_params(labelsize=5)
        ins.set_title(r"near $\Sigma_2$ (grazing)", fontsize=6)
    return fig


def figure_orbits(plt, datas, ms):
    """The orbits of a flow and its map on the section (left), and their approach to the
    fixed point x_beta* along (0, 1) with the switching iterate there (right; section
    5.1, Fig. 11)."""
    fig, (ax, zoom) = plt.subplots(1, 2, figsize=(11, 4.8), dpi=150,
                                   gridspec_kw={"width_ratios": [3, 2]})
    draw_orbit_frame(ax, datas)
    for d in sorted(datas, key=lambda d: -d.normal_form.order):
        draw_orbit(ax, d, ms=ms or 4.0)
    legend(ax, loc="lower center", fontsize=6)
    # right: the approach to x_beta* along (0, 1) and the switching iterate there
    omega, omega1, kappa1, r = _system(datas[0])
    xs = theory.fixed_point("beta", omega1, kappa1, r)
    a_all = np.concatenate([d.data["section/u"].ravel() for d in datas])
    b_all = np.concatenate([d.data["section/v"].ravel() for d in datas])
    near = np.isfinite(a_all) & (np.abs(a_all - xs[0]) < 0.02 * abs(xs[0]))
    for d in sorted(datas, key=lambda d: -d.normal_form.order):
        draw_orbit(zoom, d, ms=ms or 4.0)
    zoom.plot([xs[0]], [xs[1]], "k*", ms=9)
    if near.sum() > 3:
        bl = np.quantile(b_all[near], [0.0, 0.6])
        pad = 0.15 * (bl[1] - bl[0] + 1e-12)
        zoom.set_ylim(bl[0] - pad, bl[1] + pad)
        al = (a_all[near].min(), a_all[near].max())
        apad = 0.1 * (al[1] - al[0] + 1e-9)
        zoom.set_xlim(al[0] - apad, al[1] + apad)
    aa = np.linspace(*zoom.get_xlim(), 50)
    zoom.plot(aa, kappa1 - 0.25 * math.pi * omega1 * aa, "k-", lw=0.8)
    zoom.set_title(r"near $x_\beta^*$: the approach along $(0, 1)^T$ (section 5.1)", fontsize=8,
                   loc="left")
    zoom.set_xlabel(r"$a_n$")
    return fig
