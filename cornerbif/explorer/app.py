"""The explorer's pages: what every page has (``Page``: the colouring, the orbit of a clicked
point, the view saved as a scene or a figure, the session's clock) and a diagram's page
(``Explorer``): its points rasterized at screen resolution from the file, a slab at a time,
on every pan and zoom (``points.raster``; the points are never held, the server's memory
does not grow with the file), the refine of the visible window, the continuation from a
clicked orbit.  One page per browser session; the files (``Diagram``,
``Chart``) are read once per server (``Files``) and shared by the sessions."""

from __future__ import annotations

import os
import threading

import holoviews as hv
import numpy as np
import pandas as pd
import panel as pn
from matplotlib.colors import to_hex

from ..config import dumps
from ..model import cut
from ..outputs import write_text
from ..plot_base import BRANCH_Y, EVENT_MARKERS, axis_label, word_label, y_label
from . import jobs
from .orbit import recompute
from .points import (
    LABEL_CMAP,
    LAYERS,
    SCALED,
    SLOTS,
    Cloud,
    Colouring,
    Diagram,
    _plain,
    nearest,
    open_file,
    spread,
    word_colouring,
)

hv.extension("bokeh", logo=False)

WIDTH, HEIGHT = 860, 480          # the diagram's frame, in screen pixels
POLL_MS = 250                     # how often a session looks at its jobs
SELECTED = "#e4007c"              # the clicked point's ring
BRANCH_COLOR = "#ff00ff"          # continued branches over the diagram (in no palette)
EVENT_COLORS = {k: to_hex(v[1]) for k, v in EVENT_MARKERS.items()}   # as cornerbif plot's


class Files:
    """The files a server was given and the side folder it writes to: each file's
    ``Diagram`` read once, on first use, shared by the sessions.  Only these files are ever
    opened by name from a page (``get``)."""

    def __init__(self, paths, side_dir):
        self.paths = [os.path.abspath(p) for p in paths]
        self.side_dir = side_dir
        self._diagrams = {}
        self._lock = threading.Lock()

    def names(self) -> list:
        return [os.path.basename(p) for p in self.paths]

    def index(self, name: str | None) -> int | None:
        """The index of the file a page asks for (its index or its base name), None when
        it names none of them."""
        if name is None or name == "":
            return 0
        names = self.names()
        if name in names:
            return names.index(name)
        if name.isdigit() and int(name) < len(self.paths):
            return int(name)
        return None

    def get(self, k: int):
        """File ``k`` as a ``points.Diagram`` or ``points.Chart``, read once."""
        with self._lock:
            if k not in self._diagrams:
                self._diagrams[k] = open_file(self.paths[k])
            return self._diagrams[k]


def image(points, colouring: Colouring, x_range, y_range) -> hv.Image:
    """``points`` (a ``points.Diagram`` or ``Cloud``, or None: nothing) in the window at the
    frame's pixels (``points.raster``: the file read a slab at a time; a diagram keeps its last
few), as an ``hv.Image`` over
    the window (NaN pixels: transparent)."""
    (x0, x1), (y0, y1) = x_range, y_range
    if points is None or not (x1 > x0 and y1 > y0):      # nothing: 2 x 2 pixels, not sent whole
        xs, ys = np.array([x0, x1]), np.array([y0, y1])
        empty = np.full((2, 2), np.nan, np.float32)
        # its value range given: HoloViews need not look for one in NaN alone
        return hv.Image((xs, ys, empty), ["x", "y"], hv.Dimension("c", range=(0.0, 1.0)))
    img = spread(points.image(colouring, x_range, y_range, WIDTH, HEIGHT))
    xs = x0 + (np.arange(WIDTH) + 0.5) * ((x1 - x0) / WIDTH)
    ys = y0 + (np.arange(HEIGHT) + 0.5) * ((y1 - y0) / HEIGHT)
    return hv.Image((xs, ys, img), ["x", "y"], "c")


def like(colouring: Colouring, base: Colouring) -> Colouring:
    """``colouring`` with each layer that ``base`` names too in ``base``'s colour: a refine's
    orbits drawn in the colours they have in the file's diagram."""
    if colouring.layer is None or base.layer is None:
        return colouring
    of = dict(zip(base.names, base.colors))
    colouring.colors = [of.get(n, c) for n, c in zip(colouring.names, colouring.colors)]
    return colouring


# how long after the last wheel or pan event the view's range is sent to the server (Bokeh's
# ``lod_timeout``, 500 ms by default): the re-render starts this soon after a zoom ends
SETTLE_MS = 100


def quick_settle(plot, element):
    """A HoloViews hook: the Bokeh figure sends its new range ``SETTLE_MS`` after a zoom or
    pan ends."""
    plot.state.lod_timeout = SETTLE_MS


def shaded(image_dmap, colouring: Colouring):
    """``image_dmap`` (a DynamicMap of ``image``s, re-rendered on every pan and zoom, sparse
    points grown by ``points.spread``) shaded: a labelled colouring by one fixed colour map
    (a pixel's value is its highest layer's colour, ``points.codes``), a value on a colour
    scale."""
    if colouring.layer is not None:
        style = dict(cmap=LABEL_CMAP, clim=(0, LAYERS * SLOTS))
    else:
        style = dict(cmap="viridis" if colouring.centre is None else "coolwarm",
                     cnorm="eq_hist")
    return image_dmap.opts(
        clipping_colors={"NaN": "transparent"}, colorbar=colouring.layer is None, **style)


def legend_html(colouring: Colouring, refine: Colouring | None = None) -> str:
    """The colouring's legend as HTML: a swatch and a name per layer, then the layers a
    refine's points add (``refine``)."""
    if colouring.layer is None:
        name = SCALED[colouring.what][0]
        return f"<b>colour</b>: {_plain(name)} (mean per pixel; histogram-equalised)"
    shown = colouring.legend()
    if refine is not None and refine.layer is not None:
        have = {n for n, _ in shown}
        shown += [(f"{n} (refine)", c) for n, c in refine.legend() if n not in have]
    items = [f"<span style='color:{c}'>&#9632;</span>&nbsp;{_escape(n)}" for n, c in shown]
    return "<b>colour</b>: " + " &nbsp; ".join(items)


def _escape(s: str) -> str:
    return str(s).replace("&", "&amp;").replace("<", "&lt;").replace(">", "&gt;")


class Page:
    """What every page of the explorer has, over a file of ``files`` (``dia``, a
    ``points.Runs``): the colouring, the status and the file-changed warning, the window
    said, the orbit of a click (recomputed in a thread), the view saved as a figure by
    ``cornerbif plot``'s code, and the session's clock (``poll``).  A page's kind adds its
    plot (``plot_pane``), its window (``window``) and its own jobs (``_poll_jobs``)."""

    what = "diagram"

    def __init__(self, files: Files, dia):
        self.files = files
        self.dia = dia
        self.orbit_job = self.save_job = self.cont_job = None
        self.orbit = self.orbit_dia = None
        self.cont_path = None

    def _common_widgets(self):
        d = self.dia
        self.colour = pn.widgets.Select(label="colour by", options=d.choices(), width=200,
                                        value=d.choices()[0])
        self.colour.param.watch(lambda e: self._recolour(), "value")
        self.cont_btn = pn.widgets.Button(label="Continue from here", width=170, disabled=True)
        self.cont_btn.on_click(lambda e: self.start_continuation())
        self.save_btn = pn.widgets.Button(label="Save view as scene", width=170)
        self.save_btn.on_click(lambda e: self.save_scene())
        self.png_btn = pn.widgets.Button(label="Save PNG", width=110)
        self.png_btn.on_click(lambda e: self.save_figure("png"))
        self.pdf_btn = pn.widgets.Button(label="Save PDF", width=110)
        self.pdf_btn.on_click(lambda e: self.save_figure("pdf"))
        self.status = pn.pane.HTML("", sizing_mode="stretch_width", name="status")
        self.warning = pn.pane.HTML("", sizing_mode="stretch_width", name="warning")
        self.window_text = pn.pane.HTML("", name="window")
        self.legend = pn.pane.HTML("", sizing_mode="stretch_width")
        self.facts = pn.pane.HTML(f"<i>click a point of the {self.what} to see its orbit</i>",
                                  width=300)
        self.orbit_pane = pn.pane.HoloViews(None, sizing_mode="stretch_width")
        self.download = pn.Column()
        self.refine_btn = pn.widgets.Button(label="Refine the window", color="primary",
                                            width=170)
        self.refine_btn.on_click(lambda e: self.start_refine())
        self.cancel_btn = pn.widgets.Button(label="Cancel the refine", width=150,
                                            visible=False)
        self.cancel_btn.on_click(lambda e: self.cancel_refine())
        self.progress = pn.indicators.Progress(value=0, max=100, width=300, visible=False)

    def _head(self, size_text: str):
        d = self.dia
        names = self.files.names()
        others = "" if len(names) < 2 else "; the server's files: " + ", ".join(
            f"<a href='?file={k}'>{_escape(n)}</a>" for k, n in enumerate(names))
        return pn.pane.HTML(f"<b>{_escape(os.path.basename(d.path))}</b>: "
                            f"{_escape(d.data.scene.get('scene', {}).get('title', ''))} "
                            f"&mdash; {size_text}; side files in "
                            f"<code>{_escape(self.files.side_dir)}</code>{others}",
                            sizing_mode="stretch_width")

    def say(self, text: str, error=False):
        colour = "#b00020" if error else "#222"
        self.status.object = f"<span style='color:{colour}'>{_escape(text)}</span>"

    def _on_range(self, x_range=None, y_range=None):
        if x_range is None or y_range is None:
            return
        self.window = (tuple(map(float, x_range)), tuple(map(float, y_range)))
        self._say_window()

    # ------------------------------------------------------------------ orbit
    def _start_orbit(self, dia, point, start):
        """Recompute run (``point``, ``start``) of ``dia``'s file in a thread."""
        self.orbit_job = jobs.Job("orbit").start(lambda: (dia, recompute(dia, point, start)))
        self.say(f"orbit: recomputing grid point {', '.join(map(str, point))}, start {start} "
                 f"of {os.path.basename(dia.path)}")

    def _poll_orbit(self):
        job = self.orbit_job
        if job is None or job.running:
            return
        self.orbit_job = None
        if job.state == "failed":
            return self.say(job.message, error=True)
        dia, self.orbit = job.result
        self.orbit_dia = dia
        self.facts.object = _facts_html(self.orbit)
        self.orbit_pane.object = orbit_plots(self.orbit)
        self._orbit_shown()
        word = _plain(word_label(self.orbit.word)) if self.orbit.word else "no cycle"
        self.say(f"orbit: {word} at {dia.data.axes[0]} = {self.orbit.x:.10g}")

    def _orbit_shown(self):
        """Once an orbit is shown, it can be continued."""
        self.cont_btn.disabled = False

    # ------------------------------------------------------------------ refine
    def cancel_refine(self):
        """Stop the running refine (``jobs.start_refine``'s ``cancel``): the block being
        computed is dropped; the finished ones stay drawn and kept in its partial file."""
        job = getattr(self, "refine", None)
        if job is None or not job.running:
            return self.say("no refine is running", error=True)
        job.cancel.set()
        self.say("refine: cancelling (the block being computed is dropped)")

    def _refine_finished(self, job, read, unit: str):
        """A refine that ended: its side file read by ``read`` into ``refined`` and drawn
        (``_show_refined``), or its failure or cancellation said."""
        if job.state == "failed":
            self.say(job.message, error=True)
        elif job.state == "cancelled":
            self.say(job.message)
        else:
            try:
                self.refined = read(job.result)
                self._show_refined()
                self.progress.value = 100
                self.say(job.message + f"; {self.refined.size:,} {unit}")
            except Exception as e:  # noqa: BLE001 - said on the page
                self.say(f"refine: the side file cannot be read: {cut(str(e), 300)}", error=True)
        job.state = "shown" if job.state == "done" else job.state
        self.progress.visible = self.cancel_btn.visible = False

    # ------------------------------------------------------------------ continuation
    def start_continuation(self):
        """Continue the clicked orbit (``_continuation_raw``: the page's parameter and range)
        in the background; its branches and events are drawn (``_show_branch``) when done."""
        if self.orbit is None:
            return self.say("click a point first: its orbit is continued", error=True)
        if self.cont_job is not None and self.cont_job.running:
            return self.say("a continuation is running", error=True)
        spec = self.dia.data.parsed.spec
        if not spec.continuation:
            return self.say(f"continuation refused: the model {spec.name!r} has no "
                            "continuation yet (cornerbif continue)", error=True)
        try:
            raw = self._continuation_raw(self.orbit, self.orbit_dia)
            out = jobs.side_name(self.files.side_dir, _stem(self.dia.path), "continue") + ".h5"
            write_text(out[:-3] + ".toml", dumps(raw))
            self.cont_job = jobs.start_continuation(raw, out)
        except jobs.Refused as e:
            return self.say(f"continuation refused: {e}", error=True)
        word = _plain(word_label(self.orbit.word)) if self.orbit.word else "no cycle"
        c = raw["continue"]
        self.say(f"continuation: from {word} in {c['parameter']} = {c['start']:.10g} over "
                 f"[{c['range'][0]:.6g}, {c['range'][1]:.6g}] into {out}")

    def _continuation_raw(self, orbit, dia) -> dict:
        """The scene that continues ``orbit`` (a run of ``dia``'s file): ``jobs.continue_raw``'s."""
        raise NotImplementedError

    def _show_branch(self, cont):
        """Draw the finished continuation ``cont`` (``plot_data.read_continuation``'s)."""
        raise NotImplementedError

    def _poll_continuation(self):
        job = self.cont_job
        if job is None:
            return
        if job.running:
            self.say(job.message)
            return
        self.cont_job = None
        if job.state == "failed":
            return self.say(job.message, error=True)
        self.cont_path = job.result["path"]
        self._show_branch(job.result)
        self.say(job.message)

    # ------------------------------------------------------------------ saving
    def _figure_source(self) -> tuple:
        """(the file a figure of the view draws, its ``[plot]`` table, y kind)."""
        (x0, x1), (y0, y1) = self.window
        cfg = dict(self.dia.data.scene.get("plot", {})) | {"xlim": [x0, x1], "ylim": [y0, y1]}
        return self.dia.path, cfg, None

    def save_figure(self, ext: str):
        """The view drawn by ``cornerbif plot``'s code into a PNG or PDF in the side folder
        (the refine's file when the window is the refine's, else the file explored; the
        continued branches over it), in the background."""
        from ..plot import figure  # start-up: loads matplotlib
        if self.save_job is not None and self.save_job.running:
            return self.say("a figure is being drawn: wait for it", error=True)
        path, cfg, kind = self._figure_source()
        colour = self.colour.value
        kw = {"color_by": colour} if colour in ("lyapunov", "multiplier") else {}
        if colour in ("family", "branch"):
            cfg["orbits"] = {"family": "families", "branch": "branches"}[colour]
        elif colour == "attractor":
            cfg.pop("orbits", None)
        out = jobs.side_name(self.files.side_dir, _stem(self.dia.path), "view") + "." + ext
        branches = [self.cont_path] if self.cont_path else []
        self.save_job = jobs.Job(f"save {ext.upper()}").start(
            lambda: figure([path], out, y=kind, plot_cfg=cfg, branches=branches, **kw))
        self.save_job.out = out
        self.say(f"drawing {out} with cornerbif plot's code")

    def _saved_scene(self, raw):
        """Write ``raw`` (a window's scene) to the side folder, offered for download."""
        out = jobs.side_name(self.files.side_dir, _stem(self.dia.path), "view") + ".toml"
        write_text(out, dumps(raw))
        self.download.objects = [pn.widgets.FileDownload(file=out, filename=os.path.basename(out),
                                                         color="success", width=300)]
        self.say(f"saved the view as a scene: {out} (cornerbif sweep {out} sweeps it)")

    def _poll_save(self):
        job = self.save_job
        if job is None or job.running:
            return
        self.save_job = None
        if job.state == "failed":
            return self.say(job.message, error=True)
        self.download.objects = [pn.widgets.FileDownload(
            file=job.out, filename=os.path.basename(job.out), color="success", width=300)]
        self.say(f"saved the view as a figure: {job.out}")

    # ------------------------------------------------------------------ the session's clock
    def _poll_jobs(self):
        """The page's own jobs since the last look."""

    def poll(self):
        """What the jobs did since the last look, on the page; a file changed on disk is
        said.  Never raises: a failure is a message."""
        try:
            self._poll_jobs()
            self._poll_continuation()
            self._poll_orbit()
            self._poll_save()
            if not self.warning.object and self.dia.changed():
                self.warning.object = (
                    f"<span style='color:#b00020'><b>{_escape(self.dia.path)} changed on disk "
                    "since it was read</b>: its points are no longer read (a new view of it "
                    "draws nothing; a click's orbit reads its start from the file as it is "
                    "now); restart cornerbif explore to read it again</span>")
        except Exception as e:  # noqa: BLE001 - the page says it; the server goes on
            self.say(f"{type(e).__name__}: {cut(str(e), 300)}", error=True)

    def _live_colouring(self, got) -> Colouring:
        """A refine's finished blocks or cells coloured as the page: by word (their
        attractor table comes when the refine is done), or by period on the page's colour
        scale (a stability value is drawn when the refine is done)."""
        if self.col.layer is not None:
            return like(word_colouring(got["symbols"], got["period"]), self.col)
        per = got["period"].astype(float).ravel()
        keep = per > 0 if self.col.what == "period" else np.zeros(per.shape, bool)
        return Colouring("period", value=np.where(keep, per, np.nan))


class Explorer(Page):
    """One session's page over file ``k`` of ``files``, a diagram of one swept parameter:
    refine and continuation beside ``Page``'s."""

    def __init__(self, files: Files, k: int = 0):
        super().__init__(files, files.get(k))
        self.window = (self.dia.x_extent() or (0.0, 1.0), _y_window(self.dia))
        self.refine = None          # the running or last refine job
        self.refined = None         # the last finished refine's Diagram
        self.refine_window = None   # its (x0, x1, num)
        self.shown_blocks = -1
        self._build_widgets()
        self._build_plot()

    # ------------------------------------------------------------------ layout
    def _build_widgets(self):
        self._common_widgets()
        self._say_window()

    def view(self):
        controls = pn.Row(self.colour, self.refine_btn, self.cancel_btn, self.cont_btn,
                          self.save_btn, self.png_btn, self.pdf_btn)
        page = pn.Column(self._head(f"{self.dia.size:,} points"), self.warning, controls,
                         pn.Row(self.progress, self.window_text), self.status,
                         self.plot_pane, self.legend,
                         pn.Row(self.facts, self.orbit_pane), self.download,
                         sizing_mode="stretch_width")
        pn.state.add_periodic_callback(self.poll, period=POLL_MS)
        return page

    # ------------------------------------------------------------------ the diagram
    def _build_plot(self):
        d = self.dia
        self.col = self.fine_col = d.colouring(self.colour.value)
        (x0, x1), (y0, y1) = self.window
        self.range = hv.streams.RangeXY(x_range=(x0, x1), y_range=(y0, y1))
        self.range.add_subscriber(self._on_range)
        # what a layer draws: (points, colouring); a new one re-renders the layer
        self.base_pipe = hv.streams.Pipe(data=(d, self.col))
        self.base = hv.DynamicMap(self._image, streams=[self.base_pipe, self.range])
        self.fine_pipe = hv.streams.Pipe(data=(None, self.col))
        self.fine = hv.DynamicMap(self._image, streams=[self.fine_pipe, self.range])
        self.branch_pipe = hv.streams.Pipe(data=None)
        self.mark_pipe = hv.streams.Pipe(data=None)
        self.plot_pane = pn.pane.HoloViews(self._overlay(), sizing_mode="fixed")
        self.legend.object = legend_html(self.col)

    def _image(self, data, x_range=None, y_range=None):
        (x0, x1), (y0, y1) = self.window
        return image(data[0], data[1], x_range or (x0, x1), y_range or (y0, y1))

    def _overlay(self):
        d = self.dia
        (x0, x1), (y0, y1) = self.window
        base = shaded(self.base, self.col)
        fine = shaded(self.fine, self.fine_col)
        branches = hv.DynamicMap(_branch_paths, streams=[self.branch_pipe])
        events = hv.DynamicMap(_event_points, streams=[self.branch_pipe])
        mark = hv.DynamicMap(_mark, streams=[self.mark_pipe])
        self.tap = hv.streams.Tap(source=base, x=None, y=None)
        self.tap.add_subscriber(self._on_tap)
        over = (base * fine * branches * events * mark).opts(
            hv.opts.Image(frame_width=WIDTH, frame_height=HEIGHT, xlim=(x0, x1), ylim=(y0, y1),
                        tools=["tap", "wheel_zoom", "box_zoom", "pan", "reset"],
                        active_tools=["wheel_zoom", "box_zoom", "tap"],
                        xlabel=_plain(axis_label(d.axis, d.data.model)),
                        ylabel=_plain(y_label(d.kind, d.data.model)), xformatter="%.6g",
                        hooks=[quick_settle]),
            hv.opts.Path(color=BRANCH_COLOR, line_width=2),
            hv.opts.Points("Events", color=hv.dim("event").categorize(EVENT_COLORS,
                                                                      default="black"),
                           size=10, marker="diamond", line_color="black", tools=["hover"]))
        return over

    def _recolour(self):
        """A new colouring: new data for a labelled one after a labelled one (one colour key
        serves all), else a new plot (another aggregation) over the same window."""
        before = self.col
        self.col = self.dia.colouring(self.colour.value)
        self.legend.object = legend_html(self.col)
        if (before.layer is None) != (self.col.layer is None):
            self.fine_col = self.col
            self.fine_pipe.event(data=(None, self.col))
            self.base_pipe.event(data=(self.dia, self.col))
            self.plot_pane.object = self._overlay()
        else:
            self.base_pipe.send((self.dia, self.col))
        if self.refined is not None:
            self._show_refined()

    def _say_window(self):
        (x0, x1), (y0, y1) = self.window
        self.window_text.object = (f"window: {self.dia.axis} in [{x0:.12g}, {x1:.12g}], "
                                   f"y in [{y0:.6g}, {y1:.6g}]")

    # ------------------------------------------------------------------ refine
    def start_refine(self, num=None):
        """Sweep the visible window at screen resolution (``WIDTH`` values) into a side
        file, in the background; refused (said on the page) when degenerate or too large,
        or while another refine runs."""
        if self.refine is not None and self.refine.running:
            return self.say("a refine is running: wait for it to finish", error=True)
        (x0, x1), _ = self.window
        num = int(num or WIDTH)
        try:
            scene, text = jobs.window_scene(self.dia.data.scene_text, self.dia.axis, x0, x1,
                                            num, threads=os.cpu_count() or 1)
        except jobs.Refused as e:
            return self.say(f"refine refused: {e}", error=True)
        out = jobs.side_name(self.files.side_dir, _stem(self.dia.path), "refine") + ".h5"
        write_text(out[:-3] + ".toml", text)
        self.refine = jobs.start_refine(scene, out)
        self.refine_window = (x0, x1, num)
        self.shown_blocks = -1
        self.progress.visible = self.cancel_btn.visible = True
        self.progress.value = 0
        self.say(f"refine: sweeping {num} values x {scene.n_ic} starts of {self.dia.axis} in "
                 f"[{x0:.10g}, {x1:.10g}] into {out}")

    def _poll_refine(self):
        job = self.refine
        if job is None or job.state == "shown":
            return
        if job.running:
            got = _partial_points(job.partial, self.dia.kind, self.dia.axis)
            if got is not None and got["blocks"] != self.shown_blocks:
                self.shown_blocks = got["blocks"]
                self.fine_col = self._live_colouring(got)
                self.legend.object = legend_html(self.col, self.fine_col)
                self.fine_pipe.send((got["points"], self.fine_col))
                self.progress.value = int(100 * got["done"] / max(job.total, 1))
                self.say(f"refine: {got['done']} of {job.total} values swept "
                         f"({job.seconds():.1f} s); {got['points'].x.size:,} new points drawn")
            return
        self._refine_finished(job, lambda path: Diagram(path, self.dia.kind), "points")

    def _show_refined(self):
        what = self.colour.value
        if what not in self.refined.choices():
            what = "word" if self.col.layer is not None else "period"
        self.fine_col = like(self.refined.colouring(what), self.col)
        self.legend.object = legend_html(self.col, self.fine_col)
        self.fine_pipe.send((self.refined, self.fine_col))

    # ------------------------------------------------------------------ orbit
    def _on_tap(self, x=None, y=None):
        if x is None or y is None:
            return
        (x0, x1), (y0, y1) = self.window
        got = nearest(x, y, (x0, x1), (y0, y1), [self.dia, self.refined])
        if got is None:
            return self.say("no point in the window to select", error=True)
        src, px, py, run = got
        dia = self.dia if src == 0 else self.refined
        point, start = dia.run_of(run)
        self.mark_pipe.send((px, py))
        self._start_orbit(dia, point, start)

    # ------------------------------------------------------------------ continuation
    def _continuation_raw(self, orbit, dia) -> dict:
        """The clicked orbit continued in the swept parameter over the file's range."""
        xv = self.dia.data.values[self.dia.axis]
        return jobs.continue_raw(dia.data.scene_text, dia.axis, orbit.x, orbit.initial,
                                 float(xv.min()), float(xv.max()))

    def _show_branch(self, cont):
        self.branch_pipe.send((cont, self.dia.kind))

    # ------------------------------------------------------------------ saving
    def save_scene(self):
        """The view as a scene TOML in the side folder: the file's scene over the window at
        the refine's resolution (sweeping it gives the refine's points)."""
        (x0, x1), (y0, y1) = self.window
        num = self.refine_window[2] if self.refine_window and \
            self.refine_window[:2] == (x0, x1) else WIDTH
        try:
            raw = jobs.window_raw(self.dia.data.scene_text, self.dia.axis, x0, x1, num)
        except jobs.Refused as e:
            return self.say(f"save refused: {e}", error=True)
        raw["plot"]["ylim"] = [y0, y1]
        self._saved_scene(raw)

    def _figure_source(self) -> tuple:
        path, cfg, _ = super()._figure_source()
        if self.refined is not None and self.refine_window[:2] == self.window[0]:
            path = self.refined.path
        return path, cfg, self.dia.kind

    def _poll_jobs(self):
        self._poll_refine()


def _stem(path: str) -> str:
    return os.path.splitext(os.path.basename(path))[0]


def _y_window(dia: Diagram):
    """The y-window a diagram opens on: its scene's ``[plot] ylim``, else
    ``plot_style.robust_range`` of its values (a few outliers do not set it)."""
    ylim = dia.data.scene.get("plot", {}).get("ylim")
    if isinstance(ylim, list) and len(ylim) == 2 and dia.kind == dia.data.default_y():
        return float(ylim[0]), float(ylim[1])
    win = dia.y_window()
    return (float(win[0]), float(win[1])) if win else (0.0, 1.0)


def _partial_points(partial, kind, axis):
    """The finished blocks of a refine being written (its partial file, read through
    ``jobs.partial_copy``): points, words and periods; None when it cannot be read yet or
    ``kind`` is not a dataset of the file."""
    from ..plot_data import Y_DATASETS  # start-up: loads h5py
    name = Y_DATASETS.get(kind)
    try:
        with jobs.partial_copy(partial) as f:
            done = f["done"][...].astype(bool)
            if name not in f or not done.any():
                return None
            rows = np.nonzero(done)[0]
            y = f[name][rows[0]:rows[-1] + 1][done[rows[0]:rows[-1] + 1]]
            xv = f[axis][...] if axis in f else np.arange(done.size, dtype=float)
            per = np.where(done[:, None], f["period"][...], 0)
            sym = np.where(done[:, None], f["symbols"][...].astype(str), "")
    except (OSError, KeyError, ValueError):
        return None
    if kind == "impact_height":
        y = y - (xv[rows][:, None, None] if axis == "kappa" else 0.0)
    ok = np.isfinite(y)
    i, ic, _ = np.nonzero(ok)
    n_ic = y.shape[1]
    pts = Cloud(xv[rows][i].astype(float), y[ok], (rows[i] * n_ic + ic).astype(np.int64), n_ic)
    return {"points": pts, "symbols": sym, "period": per, "done": int(done.sum()),
            "blocks": int(done.sum())}


def _branch_paths(data):
    """The continued branches as one ``hv.Path`` (one path per branch and impact, in its
    colour)."""
    paths = []
    if data is not None:
        cont, kind = data
        key = BRANCH_Y.get(kind, "impact_u")
        for b, br in enumerate(cont["branches"]):
            vals = br.get(key)
            if vals is None:
                continue
            vals = vals[:, None] if vals.ndim == 1 else vals
            for q in range(vals.shape[1]):
                paths.append({"x": br["param"], "y": vals[:, q], "branch": b})
    # none yet: one path of no point (a colour mapped over no path is refused)
    paths = paths or [{"x": np.array([np.nan]), "y": np.array([np.nan]), "branch": -1}]
    return hv.Path(paths, ["x", "y"], vdims=["branch"])


def _event_points(data):
    """The continuation's events (corner collisions, folds, ...) as points in their
    ``cornerbif plot`` colours, named on hover."""
    rows = []
    if data is not None:
        cont, kind = data
        key = BRANCH_Y.get(kind, "impact_u")
        for e in cont["events"]:
            br = cont["branches"][e["branch"]]
            if key not in br:
                continue
            if key in e and np.isfinite(e[key]):
                yv = float(np.min(e[key]))
            else:
                j = int(np.argmin(np.abs(br["param"] - e["param"])))
                yv = float(np.min(br[key][j]))
            rows.append((float(e["param"]), yv, str(e["kind"])))
    df = pd.DataFrame(rows or [(np.nan, np.nan, "none")], columns=["x", "y", "event"])
    return hv.Points(df, ["x", "y"], vdims=["event"], group="Events")


def _mark(data):
    pts = [] if data is None else [data]
    return hv.Points(pts, ["x", "y"], group="Selected").opts(
        color="none", line_color=SELECTED, size=16, line_width=2, marker="circle")


def _facts_html(o) -> str:
    rows = "".join(f"<tr><td>{_escape(k)}</td><td><b>{_escape(v)}</b></td></tr>"
                   for k, v in o.facts)
    return f"<b>orbit</b><table>{rows}</table>"


def orbit_plots(o):
    """The orbit's panels: u(t) over the obstacle z(t) with its impacts, the phase portrait
    (u, du/dt) and the impacts' corner offset against their velocity."""
    imp = o.impacts
    ok = np.isfinite(imp["t"])
    panels = []
    opts = dict(frame_width=250, frame_height=200, tools=["hover"], toolbar="above")
    if o.flight is not None:
        fl = o.flight
        shown = ok & (imp["t"] >= fl["t0"]) & (imp["t"] <= fl["t0"] + fl["s"][-1])
        ts = (hv.Curve((fl["s"], fl["z"]), "t - t0", "u, z", label="obstacle z(t)")
              .opts(color="#777777")
              * hv.Curve((fl["s"], fl["u"]), "t - t0", "u, z", label="particle u(t)")
              .opts(color="black")
              * hv.Scatter((imp["t"][shown] - fl["t0"], imp["u"][shown]), "t - t0", "u, z",
                           label="impacts").opts(color=SELECTED, size=5))
        panels.append(ts.opts(hv.opts.Overlay(legend_position="top_left", title="u(t), z(t)",
                                              **opts)))
        panels.append(hv.Curve((fl["u"], fl["v"]), "u", "v = du/dt").opts(
            color="black", title="phase portrait", **opts))
    if "corner_offset" in imp and np.isfinite(imp["corner_offset"][ok]).any():
        panels.append(hv.Scatter((imp["corner_offset"][ok], imp["v_out"][ok]),
                                 "corner offset", "impact velocity v_out").opts(
            color=SELECTED, size=5, title="impacts", xformatter="%.2g", **opts))
    else:
        panels.append(hv.Scatter((imp["t"][ok], imp["u"][ok]), "t", "u").opts(
            color=SELECTED, size=5, title="impacts", **opts))
    return hv.Layout(panels).cols(3).opts(shared_axes=False)
