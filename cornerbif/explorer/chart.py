"""The page of a file of two swept axes: an (ω, κ) chart or a basin of two start coordinates,
one cell per grid point (``points.Chart``), rasterized by Datashader at the frame's pixels
so that pan and zoom re-render it; a refine of the visible window (cells of ``CELL_PX``
screen pixels) swept in the background into a side file, drawn as its blocks finish; a
click shows the cell's orbit, which "Continue from here" continues (on a chart in one of
its axes, the corner collisions and folds met continued as curves in the other and drawn
over it; on a basin in a parameter and range chosen on the page); the view is saved as a
scene or a figure."""

from __future__ import annotations

import os

import holoviews as hv
import numpy as np
import pandas as pd
import panel as pn
from holoviews.operation.datashader import rasterize

from ..outputs import write_text
from ..plot_base import axis_label
from . import jobs
from .app import (
    BRANCH_COLOR,
    EVENT_COLORS,
    HEIGHT,
    POLL_MS,
    WIDTH,
    Files,
    Page,
    _branch_paths,
    _event_points,
    _mark,
    _plain,
    _stem,
    legend_html,
    like,
)
from .points import LABEL_CMAP, LAYERS, SLOTS, Chart, Colouring, cell_image

CELL_PX = 4          # a refine's cell, in screen pixels: 215 x 120 cells in the frame


class ChartPage(Page):
    """One session's page over file ``k`` of ``files``, a ``points.Chart``."""

    what = "chart"

    def __init__(self, files: Files, k: int = 0):
        super().__init__(files, files.get(k))
        c = self.dia
        self.what = "basin" if c.basin else "chart"
        self.window = (_edges(c.xv), _edges(c.yv))
        self.refine = self.refined = self.refine_grid = None
        self._common_widgets()
        self._continuation_widgets()
        self._say_window()
        self.col = self.fine_col = c.colouring(self.colour.value)
        self.range = hv.streams.RangeXY(x_range=self.window[0], y_range=self.window[1])
        self.range.add_subscriber(self._on_range)
        self.pipe = hv.streams.Pipe(data=(c.image(self.col), self._bounds(c)))
        self.fine_pipe = hv.streams.Pipe(data=_nothing(self.window))
        self.mark_pipe = hv.streams.Pipe(data=None)
        self.branch_pipe = hv.streams.Pipe(data=None)
        self.plot_pane = pn.pane.HoloViews(self._overlay(), sizing_mode="fixed")
        self.legend.object = legend_html(self.col)

    def view(self):
        c = self.dia
        controls = pn.Row(self.colour, self.refine_btn, self.cancel_btn, self.save_btn,
                          self.png_btn, self.pdf_btn)
        cont = pn.Row(self.cont_btn, self.cont_param, *([self.cont_range] if c.basin else []))
        shows = "its first start" if c.basin else "the highest layer of its starts"
        note = pn.pane.HTML(f"<i>{self.what}: {c.xv.size} x {c.yv.size} cells of {c.n_ic} "
                            f"start(s); a cell shows {shows}</i>")
        page = pn.Column(self._head(f"{c.size:,} cells"), self.warning, controls, cont,
                         pn.Row(self.progress, self.window_text, note), self.status,
                         self.plot_pane, self.legend, pn.Row(self.facts, self.orbit_pane),
                         self.branch_pane, self.download, sizing_mode="stretch_width")
        pn.state.add_periodic_callback(self.poll, period=POLL_MS)
        return page

    @staticmethod
    def _bounds(chart: Chart) -> tuple:
        (x0, x1), (y0, y1) = _edges(chart.xv), _edges(chart.yv)
        return x0, y0, x1, y1

    def _overlay(self):
        c = self.dia
        (x0, x1), (y0, y1) = self.window
        base = self._shaded(hv.DynamicMap(_image, streams=[self.pipe]), self.col)
        fine = self._shaded(hv.DynamicMap(_image, streams=[self.fine_pipe]), self.fine_col)
        self.tap = hv.streams.Tap(source=base, x=None, y=None)
        self.tap.add_subscriber(self._on_tap)
        mark = hv.DynamicMap(_mark, streams=[self.mark_pipe])
        over = base * fine * mark
        if not c.basin:      # a chart's continued branch, its events and their curves
            over = over * hv.DynamicMap(_chart_paths, streams=[self.branch_pipe]) \
                * hv.DynamicMap(_chart_events, streams=[self.branch_pipe])
        return over.opts(hv.opts.Path(color=BRANCH_COLOR, line_width=2),
                         hv.opts.Points("Events", color=hv.dim("event").categorize(
                             EVENT_COLORS, default="black"), size=10, marker="diamond",
                             line_color="black", tools=["hover"]),
                         hv.opts.Image(
            frame_width=WIDTH, frame_height=HEIGHT, xlim=(x0, x1), ylim=(y0, y1),
            tools=["tap", "wheel_zoom", "box_zoom", "pan", "reset"],
            active_tools=["wheel_zoom", "box_zoom", "tap"], xformatter="%.6g",
            yformatter="%.6g", xlabel=_plain(axis_label(c.axes[0], c.data.model)),
            ylabel=_plain(axis_label(c.axes[1], c.data.model))))

    def _shaded(self, cells, colouring: Colouring):
        """``cells`` rasterized over the view's range: a cell's highest code (one fixed colour
        map, ``points.codes``), or the mean of its value on a colour scale."""
        labelled = colouring.layer is not None
        img = rasterize(cells, aggregator="max" if labelled else "mean", width=WIDTH,
                        height=HEIGHT, streams=[self.range])
        style = (dict(cmap=LABEL_CMAP, clim=(0, LAYERS * SLOTS)) if labelled else
                 dict(cmap="viridis" if colouring.centre is None else "coolwarm",
                      cnorm="eq_hist", colorbar=True))
        return img.opts(clipping_colors={"NaN": "transparent"}, **style)

    def _recolour(self):
        """A new colouring: new data for a labelled one after a labelled one, else a new
        plot (another aggregation) over the same window."""
        before, self.col = self.col, self.dia.colouring(self.colour.value)
        self.legend.object = legend_html(self.col)
        self.pipe.event(data=(self.dia.image(self.col), self._bounds(self.dia)))
        if self.refined is not None:
            self._show_refined()
        elif (before.layer is None) != (self.col.layer is None):
            self.fine_col = self.col
            self.fine_pipe.event(data=_nothing(self.window))
        if (before.layer is None) != (self.col.layer is None):
            self.plot_pane.object = self._overlay()

    def _say_window(self):
        (x0, x1), (y0, y1) = self.window
        a, b = self.dia.axes
        self.window_text.object = (f"window: {a} in [{x0:.12g}, {x1:.12g}], "
                                   f"{b} in [{y0:.12g}, {y1:.12g}]")

    # ------------------------------------------------------------------ continuation
    def _continuation_widgets(self):
        """What a click's orbit is continued in: on a chart, either of its parameter axes
        over the chart's range (the corner collisions and folds it meets continued as
        curves in the other: the edges of the regions drawn); on a basin, a parameter of the
        model over a range typed in (the branch drawn in a figure of its own)."""
        c = self.dia
        spec = c.data.parsed.spec
        if c.basin:
            options = list(spec.params)
        else:
            options = [a for a in reversed(c.axes) if not a.startswith("initial.")]
        self.cont_param = pn.widgets.Select(label="continue in", options=options, width=150,
                                            value=options[0] if options else None,
                                            disabled=not options)
        self.cont_range = pn.widgets.TextInput(label="over the range (low, high)", width=200,
                                               placeholder="e.g. 0.9, 1.1")
        self.cont_param.param.watch(lambda e: self._default_range(), "value")
        self._default_range()
        self.branch_pane = pn.pane.HoloViews(None, sizing_mode="stretch_width")

    def _default_range(self):
        """A basin's range: the parameter's value +- 5 % (+- 0.05 at 0)."""
        c = self.dia
        name = self.cont_param.value
        if not c.basin or name is None:
            return
        v = c.data.parsed.point((0, 0)).get(name)
        if v is None:
            self.cont_range.value = ""
            return
        h = 0.05 * abs(v) if v else 0.05
        self.cont_range.value = f"{v - h:.6g}, {v + h:.6g}"

    def _continuation_raw(self, orbit, chart) -> dict:
        name = self.cont_param.value
        if name is None:
            raise jobs.Refused("this chart has no parameter axis to continue in")
        c = self.dia
        values = chart.data.parsed.point(orbit.point)
        if c.basin:
            try:
                lo, hi = (float(t) for t in self.cont_range.value.split(","))
            except ValueError:
                raise jobs.Refused(f"the range {self.cont_range.value!r} is not two numbers "
                                   "'low, high'") from None
            return jobs.continue_raw(chart.data.scene_text, name, float(values[name]),
                                     orbit.initial, lo, hi)
        other = next(a for a in c.axes if a != name)
        lo, hi = _edges(c.xv if name == c.axes[0] else c.yv)
        v = float(values[name])
        fixed = {} if other.startswith("initial.") else {other: float(values[other])}
        curve = None if other.startswith("initial.") else \
            (other, *_edges(c.xv if other == c.axes[0] else c.yv))
        return jobs.continue_raw(chart.data.scene_text, name, v, orbit.initial,
                                 min(lo, v), max(hi, v), fixed=fixed, curve=curve)

    def _show_branch(self, cont):
        c = self.dia
        if c.basin:
            kind = "impact_u"
            self.branch_pane.object = (
                hv.DynamicMap(_branch_paths, streams=[hv.streams.Pipe(data=(cont, kind))])
                * hv.DynamicMap(_event_points, streams=[hv.streams.Pipe(data=(cont, kind))])
            ).opts(hv.opts.Path(color=BRANCH_COLOR, line_width=2, frame_width=500,
                                frame_height=260, xlabel=_plain(cont["parameter"]),
                                ylabel="impact height u", title="the continued branch"),
                   hv.opts.Points("Events", color=hv.dim("event").categorize(
                       EVENT_COLORS, default="black"), size=10, marker="diamond",
                       line_color="black", tools=["hover"]))
            return
        name = cont["parameter"]
        point = self.orbit.point
        chart = self.orbit_dia
        values = chart.data.parsed.point(point)
        other = next(a for a in c.axes if a != name)
        self.branch_pipe.send((cont, name == c.axes[0], float(values.get(other, np.nan))))

    # ------------------------------------------------------------------ refine
    def _refine_grid(self) -> tuple:
        """The visible window as a refine's grid: cell centres, ``CELL_PX`` pixels a cell:
        ((x first, x last, nx), (y first, y last, ny))."""
        (x0, x1), (y0, y1) = self.window
        nx, ny = WIDTH // CELL_PX, HEIGHT // CELL_PX
        hx, hy = 0.5 * (x1 - x0) / nx, 0.5 * (y1 - y0) / ny
        return (x0 + hx, x1 - hx, nx), (y0 + hy, y1 - hy, ny)

    def start_refine(self):
        """Sweep the visible window at ``CELL_PX`` pixels a cell into a side file, in the
        background; refused (said on the page) when degenerate or too large, or while
        another refine runs."""
        if self.refine is not None and self.refine.running:
            return self.say("a refine is running: wait for it to finish", error=True)
        gx, gy = self._refine_grid()
        c = self.dia
        try:
            scene, text = jobs.window_scene(c.data.scene_text, c.axes[0], *gx,
                                            threads=os.cpu_count() or 1,
                                            second=(c.axes[1], *gy))
        except jobs.Refused as e:
            return self.say(f"refine refused: {e}", error=True)
        out = jobs.side_name(self.files.side_dir, _stem(c.path), "refine") + ".h5"
        write_text(out[:-3] + ".toml", text)
        self.refine = jobs.start_refine(scene, out)
        self.refine_grid = (gx, gy, self.window, scene.n_ic)
        self.progress.visible = self.cancel_btn.visible = True
        self.progress.value = 0
        self.say(f"refine: sweeping {gx[2]} x {gy[2]} cells x {scene.n_ic} starts into {out}")

    def _poll_refine(self):
        job = self.refine
        if job is None or job.state == "shown":
            return
        if job.running:
            gx, gy, window, n_ic = self.refine_grid
            got = _partial_cells(job.partial, (gx[2], gy[2], n_ic))
            if got is not None:
                self.fine_col = self._live_colouring(got)
                bounds = (window[0][0], window[1][0], window[0][1], window[1][1])
                self.fine_pipe.send((cell_image(self.fine_col, (gx[2], gy[2], n_ic),
                                                self.dia.basin, got["done"]), bounds))
                self.progress.value = int(100 * got["done"].sum() / max(job.total, 1))
                self.say(f"refine: {int(got['done'].sum())} of {job.total} cells swept "
                         f"({job.seconds():.1f} s)")
            return
        self._refine_finished(job, Chart, "cells")

    def _show_refined(self):
        what = self.colour.value
        if what not in self.refined.choices():
            what = "word" if self.col.layer is not None else "period"
        self.fine_col = like(self.refined.colouring(what), self.col)
        self.legend.object = legend_html(self.col, self.fine_col)
        self.fine_pipe.send((self.refined.image(self.fine_col), self._bounds(self.refined)))

    def _poll_jobs(self):
        self._poll_refine()

    # ------------------------------------------------------------------ orbit, saving
    def _on_tap(self, x=None, y=None):
        if x is None or y is None:
            return
        chart = self.dia
        r = self.refined
        if r is not None and _edges(r.xv)[0] <= x <= _edges(r.xv)[1] \
                and _edges(r.yv)[0] <= y <= _edges(r.yv)[1]:
            chart = r
        i, j = chart.cell(x, y)
        self.mark_pipe.send((float(chart.xv[i]), float(chart.yv[j])))
        self._start_orbit(chart, (i, j), 0)

    def _refine_is_the_view(self) -> bool:
        return self.refined is not None and self.refine_grid[2] == self.window

    def _figure_source(self) -> tuple:
        path, cfg, kind = super()._figure_source()
        return (self.refined.path if self._refine_is_the_view() else path), cfg, kind

    def save_scene(self):
        """The view as a scene TOML in the side folder: the refine's grid when the window is
        the refine's (sweeping it gives the refine's cells), else the file's grid values
        inside the window (the file's cells there), or the window's edges when it holds
        fewer than two."""
        (x0, x1), (y0, y1) = self.window
        c = self.dia
        if self._refine_is_the_view():
            gx, gy = self.refine_grid[:2]
        else:
            gx, gy = _inside(c.xv, x0, x1), _inside(c.yv, y0, y1)
        try:
            raw = jobs.window_raw(c.data.scene_text, c.axes[0], *gx, second=(c.axes[1], *gy))
        except jobs.Refused as e:
            return self.say(f"save refused: {e}", error=True)
        self._saved_scene(raw)


def _image(data):
    """A grid's cells as an ``hv.Image``: ``data`` (values, y along the first axis; bounds
    (x0, y0, x1, y1))."""
    values, bounds = data
    return hv.Image(values, bounds=bounds, kdims=["x", "y"], vdims=["c"])


def _nothing(window) -> tuple:
    """A layer of no cell over ``window`` (an image of NaN)."""
    (x0, x1), (y0, y1) = window
    return np.full((2, 2), np.nan, np.float32), (x0, y0, x1, y1)


def _partial_cells(partial, shape):
    """The finished cells of a chart's refine being written (its partial file, read through
    ``jobs.partial_copy``): done (per cell), periods and words; None when it cannot be read
    yet."""
    try:
        with jobs.partial_copy(partial) as f:
            done = f["done"][...].astype(bool)
            if done.shape != tuple(shape[:2]) or not done.any():
                return None
            per = np.where(done[..., None], f["period"][...], 0)
            sym = np.where(done[..., None], f["symbols"][...].astype(str), "")
    except (OSError, KeyError, ValueError):
        return None
    return {"done": done, "period": per, "symbols": sym}


def _edges(v) -> tuple:
    """The outer edges of cells centred on the evenly spaced values ``v``."""
    half = 0.5 * float(v[1] - v[0]) if len(v) > 1 else 0.5
    return float(v[0]) - half, float(v[-1]) + half


def _inside(v, lo, hi) -> tuple:
    """(first, last, count) of the values ``v`` in [lo, hi]; (lo, hi, 2) when fewer than
    two are."""
    inside = v[(v >= lo) & (v <= hi)]
    if inside.size < 2:
        return float(lo), float(hi), 2
    return float(inside[0]), float(inside[-1]), int(inside.size)



def _chart_paths(data):
    """A chart's continuation as paths in its plane: each branch at the run's value of the
    other axis (a line along the continued one), each curve of a corner collision or fold
    (its points in the two parameters); ``data`` = (continuation, continued along x, the
    other axis's value) or None."""
    paths = []
    if data is not None:
        cont, along_x, other = data
        for br in cont["branches"]:
            lam = np.asarray(br["param"], float)
            fix = np.full(lam.shape, other)
            paths.append({"x": lam, "y": fix} if along_x else {"x": fix, "y": lam})
        for cv in cont["curves"]:
            p2, p1 = np.asarray(cv["param"], float), np.asarray(cv["event_param"], float)
            paths.append({"x": p1, "y": p2} if along_x else {"x": p2, "y": p1})
    paths = paths or [{"x": np.array([np.nan]), "y": np.array([np.nan])}]
    return hv.Path(paths, ["x", "y"])


def _chart_events(data):
    """A chart's continuation's events (``_chart_paths``' data) as points in their ``cornerbif
    plot`` colours, named on hover."""
    rows = []
    if data is not None:
        cont, along_x, other = data
        for e in cont["events"]:
            lam = float(e["param"])
            rows.append((lam, other, str(e["kind"])) if along_x else (other, lam, str(e["kind"])))
    df = pd.DataFrame(rows or [(np.nan, np.nan, "none")], columns=["x", "y", "event"])
    return hv.Points(df, ["x", "y"], vdims=["event"], group="Events")
