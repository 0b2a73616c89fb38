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

import math
import tomllib

import numpy as np

from . import figures, plot_style, registry
from .config import kind_problems, recorded_obstacle
from .model import FigureKind, cut
from .plot_base import BRANCH_Y, COLOR_BY, Undrawable, branch_keys, cfg_for_y, flow_and_map
from .plot_data import DRAW_LIMIT, Y_DATASETS, PlotData, is_continuation, read_continuation
from .plot_diagram import branches_figure
from .plot_style import quiet


def figure_branches(paths, out, y=None, title=None, plot_cfg=None, style=None, color_by=None):
    """Continuation files drawn alone: branches against the parameter, and the corner
    curves in the plane of the two parameters when the files have them; in the project's
    style with the user's sheet over it (``style``, or ``[plot] style``), ``[plot] ylim``
    the window of the branches' panel.  ``check_together`` first: files continued in one
    parameter of one model, a ``y`` they store; ``color_by`` is refused (a branch is
    drawn stable solid, unstable dashed)."""
    conts = [read_continuation(p) for p in paths]
    scene = tomllib.loads(conts[0]["scene"])
    if plot_cfg is None:                 # the first file's scene, as a sweep's figure
        plot_cfg = scene.get("plot", {})
    check_together([], conts, y=y, color_by=color_by, plot_cfg=plot_cfg)
    with plot_style.style(style or plot_cfg.get("style")), quiet():
        return branches_figure(conts, scene, out, y, title, plot_cfg)


def figure(paths, out, y=None, title=None, plot_cfg=None, color_by=None, branches=(),
           style=None, kind=None, orbits=None):
    """Draw one or more files of the same kind into ``out`` (png, pdf or svg), in the
    project's style (``plot_style``) with the user's style sheet over it (``style``, or
    ``[plot] style``), continuation files ``branches`` over them.  What the files and
    options ask is checked before anything is drawn (``check_together``); the figure is
    written whole or not at all (``save``).  ``kind`` (``--kind``) draws another figure
    kind than the scene's ``[plot] kind``, ``orbits`` (``--orbits``) colours by another
    than its ``[plot] orbits``.  See ``_figure``."""
    datas = [PlotData(p) for p in paths]
    conts = [read_continuation(b) for b in branches]
    cfg = datas[0].scene.get("plot", {}) if plot_cfg is None else plot_cfg
    if kind is not None:
        cfg = dict(cfg) | {"kind": kind}
    if orbits is not None:
        cfg = dict(cfg) | {"orbits": orbits}
    check_together(datas, conts, y=y, color_by=color_by, plot_cfg=cfg)
    color_by = color_by or scene_color_by(datas, cfg)
    cfg = cfg_for_y(cfg, y, datas[0].default_y())
    with plot_style.style(style or cfg.get("style")), quiet():
        return _figure(datas, out, y, title, cfg, color_by, conts)


def draw_files(files, out, y=None, title=None, color_by=None, style=None, kind=None,
               orbits=None):
    """``cornerbif plot``: the sweeps among ``files`` drawn with the continuation files
    over them (``figure``), or the continuation files alone (``figure_branches``)."""
    conts = [f for f in files if is_continuation(f)]
    sweeps = [f for f in files if f not in conts]
    if sweeps:
        return figure(sweeps, out, y=y, title=title, color_by=color_by, branches=conts,
                      style=style, kind=kind, orbits=orbits)
    if kind is not None:
        # a figure kind draws sweep files; continuation files alone are one figure, their
        # branches (a --kind said nothing of what was drawn: it was not drawn)
        raise Undrawable(f"--kind {kind}: {', '.join(conts)} "
                         + ("are continuation files" if len(conts) > 1 else
                            "is a continuation file")
                         + ", drawn as branches against the continued parameter; --kind "
                         "chooses the figure of a sweep file")
    return figure_branches(conts, out, y=y, title=title, style=style, color_by=color_by)


# ------------------------------------------------------------------ what one figure draws
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
    from .io import check_stored_plot  # start-up: loads h5py
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
    kind = cfg.get("kind", figures.DEFAULT)
    fk = figures.registered().get(kind) if isinstance(kind, str) else None
    if fk is None:
        raise Undrawable(f"{datas[0].path}: [plot] kind {cut(kind)!r} is not a figure this "
                         "cornerbif draws")
    for d in datas:
        _check_kind_of_file(d, kind, fk)
    if fk.files == "single_runs":
        _check_single_runs(datas, conts, kind, y, color_by, plot_cfg)
    elif fk.files == "one":
        if len(datas) > 1:
            raise Undrawable(f"[plot] kind {kind!r} ({fk.doc}) draws one file; "
                             f"got {_all_described(datas)}")
        if fk.one_axis and len(datas[0].axes) != 1:
            raise Undrawable(f"{_described(datas[0])}: [plot] kind {kind!r} draws a file "
                             "swept over one parameter")
        _no_options(kind, y, color_by, conts, datas)
    else:
        for d in datas:
            if not d.axes:
                kinds = _single_run_kinds(d)
                raise Undrawable(f"{_described(d)}: nothing to draw as a diagram ("
                                 + ("its single runs are drawn by [plot] kind "
                                    + " or ".join(kinds) if kinds else
                                    "no figure kind draws its single runs; cornerbif info "
                                    "summarises them") + ")")
            if len(d.axes) > 2:
                raise Undrawable(f"{_described(d)}: a figure draws one or two swept "
                                 "parameters")
        if any(len(d.axes) == 2 for d in datas):
            _check_chart(datas, conts, y, color_by)
        else:
            _check_diagrams(datas, conts, cfg, y, color_by)


def _check_kind_of_file(d, kind, fk):
    """A figure kind other than the one a file was swept with (``--kind``, or the ``[plot]``
    a gallery passes) is asked of the file's scene as ``validate`` asks it of ``[plot] kind``
    (``config.kind_problems``): a file the kind cannot draw (a time series of a linear
    scene, the obstacle of a map) is refused before drawing, with the kind's own reason.
    The kind a file was swept with was asked when it was swept (and a stored [plot] is
    checked again by ``io.check_stored_plot``)."""
    text = getattr(d, "scene_text", None)
    plot = d.scene.get("plot", {}) if isinstance(d.scene, dict) else {}
    stored = plot.get("kind", figures.DEFAULT) if isinstance(plot, dict) else None
    if not text or stored == kind:
        return
    why = kind_problems(text, kind)
    if why:
        raise Undrawable(f"{d.path}: cannot be drawn as [plot] kind {kind!r} ({fk.doc}): "
                         + cut("; ".join(why), MAX_REASON))


# the characters of a figure kind's reasons quoted in a refusal (they may name a file's
# swept parameters, whose names a scene declares)
MAX_REASON = 1000


def _single_run_kinds(d) -> list:
    """The figure kinds that draw the single runs of a file without sweep axes: kinds of
    one file or of single runs that say what they need of a scene (their own ``check``),
    and whose check passes on ``d``'s scene where the file holds one (a figure's stand-in,
    ``check_scenes_drawable``, holds none: every such kind)."""
    text = getattr(d, "scene_text", None)
    out = []
    for name, fk in figures.registered().items():
        if (fk.files == "diagram" or fk.one_axis or fk.explained
                or type(fk).check is FigureKind.check):
            continue
        if text and kind_problems(text, name) != []:
            continue
        out.append(name)
    return out


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
           "attrs": {"model": sc.model, "obstacle": recorded_obstacle(sc)}} for n, sc in conts]
    check_together(wills, cs, plot_cfg=plot_cfg)


def _check_single_runs(datas, conts, kind, y, color_by, plot_cfg):
    """The normal-form kinds (regions, return maps, orbits: sections 4-5) draw single runs
    of a flow or map2d file, or a flow against its map: at the same system values, in one
    kind, the regions of the same starts."""
    pair = flow_and_map(datas)
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
        other = datas[1].scene.get("plot", {}).get("kind", figures.DEFAULT)
        if plot_cfg is None and other != kind:
            raise Undrawable(f"{datas[0].path} is drawn as [plot] kind {kind!r}, "
                             f"{datas[1].path} as {cut(other)!r}: a flow is drawn "
                             "against its map in one kind")
        _check_one_system(*datas)
        if figures.registered()[kind].same_starts:
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
    pair = flow_and_map(datas)
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
    kind = cfg.get("kind", figures.DEFAULT)
    fk = figures.registered().get(kind) if isinstance(kind, str) else None
    if (what in COLOR_BY and len(datas) == 1 and fk is not None and fk.colors_by
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
    import matplotlib  # start-up: loads matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # start-up: loads matplotlib

    d0 = datas[0]
    plot_cfg = d0.scene.get("plot", {}) if plot_cfg is None else plot_cfg
    kind_ = plot_cfg.get("kind", figures.DEFAULT)
    if color_by is not None and color_by not in COLOR_BY:
        raise Undrawable(f"color_by: {cut(color_by)!r} is not allowed; allowed: "
                         + ", ".join(COLOR_BY))
    return figures.registered()[kind_].draw(plt, datas, out, y, title, plot_cfg, color_by,
                                          branches)
