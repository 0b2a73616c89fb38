"""A file as a figure reads it, opened once: a sweep's datasets (``PlotData``: its scene
parsed once, its grid, its per-run values, its per-event datasets read a slab at a time by
``RecordedData``) and a continuation file's branches, events and curves
(``read_continuation``).  The figures (``cornerbif/figures``) draw from these objects; this
module is the one that reads files."""

from __future__ import annotations

import contextlib
import functools
import tomllib

import numpy as np

from . import registry
from .config import loads, sweep_items
from .continuation_run import FORMAT, FORMAT_VERSION, read
from .io import check_readable
from .model import cut
from .outputs import CONTINUATION_FORMAT, hdf5_format
from .plot_base import DRAW_LIMIT, SYMBOL_LETTERS, WORD_LETTERS, beyond_drawing, symbol_words
from .plot_style import Rows, slab_rows

# the per-event datasets a figure may draw (read when first drawn: ``RecordedData``)
RECORDED = ("impacts/u", "impacts/v_in", "section/u", "section/v", "impacts/t",
            "impacts/corner_offset", "impacts/contact")
# the dataset each y of a diagram is made from (winding and period: the per-run words
# and periods)
Y_DATASETS = {"impact_u": "impacts/u", "impact_v": "impacts/v_in",
              "impact_height": "impacts/u", "section_u": "section/u",
              "section_v": "section/v"}


class RecordedData(dict):
    """The file's per-event datasets, each read from the file the first time it is asked
    for: a figure of impact heights reads that dataset alone (a 5 M-point diagram holds
    one 40 MB array, not six; benchmarks/plot_speed.py).  ``rows`` reads a slab of rows
    alone (a diagram of millions of points holds none whole); ``shapes`` their shapes."""

    def __init__(self, path, shapes, swmr=False):
        super().__init__()
        self.path = path
        self.shapes = dict(shapes)
        self.names = tuple(self.shapes)
        self.swmr = swmr            # how check_readable opened the file
        self._file = None           # held open by ``opened``

    def __contains__(self, name):
        return name in self.names

    def __getitem__(self, name):
        if name not in self.names:
            raise KeyError(name)
        if not dict.__contains__(self, name):
            with check_readable(self.path) as f:
                dict.__setitem__(self, name, f[name][...])
        return dict.__getitem__(self, name)

    def get(self, name, default=None):
        return self[name] if name in self.names else default

    def rows(self, name, rows: slice):
        """Rows ``rows`` of the first axis of ``name``: a view of the whole when it has been
        read, else read alone from the file."""
        if name not in self.names:
            raise KeyError(name)
        if dict.__contains__(self, name):
            return dict.__getitem__(self, name)[rows]
        with self.opened():
            return self._file[name][rows]

    @contextlib.contextmanager
    def opened(self):
        """The file held open for the ``rows`` read inside (a pass over the slabs opens it
        once; PlotData checked it with ``check_readable``, which reads the whole file's
        structure)."""
        if self._file is not None:
            yield
            return
        import h5py  # start-up: loads h5py
        with h5py.File(self.path, "r", swmr=self.swmr, locking=False) as f:
            self._file = f
            try:
                yield
            finally:
                self._file = None


class PlotData:
    """What the plot needs, read from one file.

    Only the grid points the sweep finished (``done``) are shown: a partial file's other
    points read as not run (status -1, no cycle, no values), and ``partial_note`` says how
    many are finished; a file with none finished is refused (``FileFormatError``)."""

    def __init__(self, path):
        from .io import FileFormatError  # start-up: loads h5py
        with check_readable(path) as f:
            self.path = str(path)
            self.scene_text = f.attrs["scene"]
            self.scene = tomllib.loads(self.scene_text)
            self.axes = [k for k, _ in sweep_items(self.scene.get("sweep", {}))]
            self.done = f["done"][...].astype(bool)
            G = self.done.shape
            self.unplaceable = None      # why no figure can place its values (``_check_axes``)
            self._check_axes(f, G)
            self.values = {a: f[a][...] for a in self.axes}
            self.n_done, self.n_points = int(np.count_nonzero(self.done)), int(self.done.size)
            if self.n_done == 0:
                raise FileFormatError(
                    f"{path}: no grid point of its sweep is finished (0 of {self.n_points}): "
                    "nothing to show; a sweep stopped before its first block is completed by "
                    "cornerbif sweep SCENE -o OUT --resume")
            self.status = f["status"][...]
            self.period = f["period"][...]
            self.ipc = f["impacts_per_cycle"][...]
            self.model = self.scene.get("scene", {}).get("model", registry.DEFAULT_MODEL)
            self.spec = registry.models().get(self.model)
            declared = self.spec is not None and self.spec.for_system is not None
            if declared:
                # a model its scene declares (linear): the model of the stored [system]
                self.spec = self.spec.for_system(self.scene.get("system", {}))[0] or self.spec
            # its words: the corner clusters' letters, or (linear) its contacts' names
            self.contact_words = self.spec is not None and self.spec.contact_words
            self.symbols = symbol_words(f["symbols"][...],
                                        SYMBOL_LETTERS if self.contact_words else WORD_LETTERS)
            # its part in the flow-against-map figures of sections 4-5 ("flow", "map", None)
            self.normal_form = self.spec.normal_form if self.spec else None
            self.initial = {k: f[f"initial/{k}"][...] for k in ("u", "v") if f"initial/{k}" in f}
            runs = self.status.shape
            shapes = {n: f[n].shape for n in RECORDED if n in f}
            for n, shp in shapes.items():
                if shp[:len(runs)] != runs:
                    raise FileFormatError(f"{path}: dataset {n!r} has shape {shp}, which does "
                                          f"not match the runs {runs}")
            self.data = RecordedData(path, shapes, swmr=f.swmr_mode)
            self.follow = self.scene.get("sweep", {}).get("follow", "none")
            self.complete = bool(f.attrs.get("completed", "")) and self.n_done == self.n_points
            # the attractor table (cornerbif.attractors) is written when the sweep finishes
            self.has_table = "attractors" in f and self.complete
            # the stability observable (docs/stability.md), per run
            self.stability = {}
            for what, names in (("lyapunov", ("stability/lyapunov",)),
                                ("multiplier", ("stability/multiplier_re",
                                                "stability/multiplier_im"))):
                if not all(n in f for n in names):
                    continue
                if any(f[n].shape[:len(runs)] != runs or f[n].ndim != len(runs) + 1
                       or f[n].dtype.kind != "f" for n in names):
                    raise FileFormatError(f"{path}: its stability datasets ({', '.join(names)}) "
                                          f"do not match the runs {runs}")
                vals = [f[n][..., 0] for n in names]
                with np.errstate(all="ignore"):
                    self.stability[what] = beyond_drawing(vals[0] if len(vals) == 1
                                                          else np.hypot(*vals))
            try:
                self.period_tol = float(self.scene.get("run", {}).get("period_tol", 1e-6))
            except (TypeError, ValueError):
                self.period_tol = 1e-6
        self.unfinished = ~self.done if self.n_done < self.n_points else None
        if self.unfinished is not None:
            # what a partial file holds at its unfinished points is not a result (fill
            # values, or anything a crafted file put there): read as not run
            per_run = self.unfinished.reshape(G + (1,) * (self.status.ndim - len(G)))
            per_run = np.broadcast_to(per_run, self.status.shape)
            self.status = np.where(per_run, -1, self.status)
            self.period = np.where(per_run, 0, self.period)
            self.ipc = np.where(per_run, 0, self.ipc)
            self.symbols = np.where(per_run, "", self.symbols)
            self.stability = {k: np.where(per_run, np.nan, v) for k, v in self.stability.items()}
        self._attractors = None
        self._y = {}                 # y(kind), computed once

    def _check_axes(self, f, G):
        """The swept parameters of the file's scene are its grid's axes: one dataset of
        finite values each, of the grid's length along its axis."""
        import h5py  # start-up: loads h5py

        from .io import FileFormatError  # start-up: loads h5py
        if len(self.axes) != len(G):
            raise FileFormatError(f"{self.path}: its scene sweeps {len(self.axes)} parameter(s), "
                                  f"its grid has {len(G)} axes")
        for i, a in enumerate(self.axes):
            ok = (a in f and isinstance(f[a], h5py.Dataset) and f[a].shape == (G[i],)
                  and f[a].dtype.kind in "fiu")
            if not ok:
                raise FileFormatError(f"{self.path}: the values of its swept parameter "
                                      f"{cut(a)!r} are missing or do not match the grid")
            v = f[a][...]
            if not np.isfinite(v).all():
                raise FileFormatError(f"{self.path}: its swept parameter {cut(a)!r} has "
                                      "values that are not finite")
            if np.abs(v).max(initial=0.0) > DRAW_LIMIT and self.unplaceable is None:
                # summarised by info; refused by a figure (``check_together``)
                self.unplaceable = (f"{self.path}: its swept parameter {cut(a)!r} has values "
                                    f"beyond {DRAW_LIMIT:g} in size, which no figure can place")

    @functools.cached_property
    def parsed(self):
        """The file's scene as a ``config.Scene``, parsed once (a figure asks its model and
        obstacle through it)."""
        return loads(self.scene_text)

    def run_record(self, point, ic) -> dict:
        """One run's record: its impacts (``t``, ``u``, ``v_out``, ``corner_offset``), its
        ``period``, ``ipc`` (impacts per cycle), ``word`` and ``status``.  ``ValueError`` where
        the file keeps no impacts."""
        with check_readable(self.path) as f:
            if "impacts/t" not in f:
                raise ValueError(f"{self.path}: a time series needs the impacts: set "
                                 "output.keep = [\"impacts\"]")
            idx = tuple(point) + (ic,)
            out = {k: f[f"impacts/{k}"][idx] for k in ("t", "u", "v_out", "corner_offset")}
            word = f["symbols"][idx]
            out.update(period=int(f["period"][idx]), ipc=int(f["impacts_per_cycle"][idx]),
                       word=word.decode() if isinstance(word, bytes) else str(word),
                       status=int(f["status"][idx]))
        return out

    def partial_note(self) -> str:
        """What a figure or ``info`` says of a file that is not complete ("" when it is)."""
        if self.n_done < self.n_points:
            return (f"partial sweep: {self.n_done} of {self.n_points} grid points finished; "
                    "only these are shown")
        if not self.complete:
            return ("every grid point finished, but the sweep was not stamped complete "
                    "(cornerbif sweep --resume finishes it)")
        return ""

    def attractors(self):
        """Distinct attractors among the starts of each grid point (``analysis.distinct_attractors``).

        Compared on one cycle of impact heights and velocities when impacts are
        stored, else on the section values, else on the cycle's word alone; to
        100 ``run.period_tol`` (two starts on one cycle agree to the detection
        tolerance of each).  Each grid point on its own: the series are read a slab of
        grid points at a time (``plot_style.slab_rows``), never whole.  Returns (labels
        G + (n_ic,), count G).
        """
        if self._attractors is None:
            from .analysis import distinct_attractors  # start-up: loads numba
            if "impacts/u" in self.data:
                names = [("impacts/u", "impacts"), ("impacts/v_in", "impacts")]
            elif "section/u" in self.data:
                names = [("section/u", "section"), ("section/v", "section")]
            else:
                names = []
            width = max([int(np.prod(self.data.shapes[n][1:])) for n, _ in names] + [1])
            slabs = ((slab_rows((self.period.shape[0], width)) if self.period.ndim >= 2
                      else []) or [slice(None)])
            with self.data.opened():
                parts = [distinct_attractors(
                    self.period[rows], self.ipc[rows], self.symbols[rows],
                    [(self.data.rows(n, rows), kind) for n, kind in names],
                    100.0 * self.period_tol) for rows in slabs]
            self._attractors = (parts[0] if len(parts) == 1 else
                                tuple(np.concatenate(p) for p in zip(*parts)))
        return self._attractors

    def y(self, kind):
        """The values drawn for ``kind`` (``YLABELS``), computed once per kind; None when
        the file holds none."""
        if kind not in self._y:
            self._y[kind] = self._compute_y(kind)
        return self._y[kind]

    def y_rows(self, kind):
        """The values drawn for ``kind`` as ``plot_style.Rows``, read and computed a slab of
        rows at a time (sliced from the whole when ``y`` has computed it, or when it has one
        value per run): a diagram of millions of points is never whole in memory.  None
        when the file holds none."""
        if kind in ("winding", "period") or kind in self._y:     # one value per run
            whole = self.y(kind)
            return None if whole is None else Rows(whole.shape, lambda a, b: whole[a:b])
        if Y_DATASETS[kind] not in self.data:
            return None
        return Rows(self.data.shapes[Y_DATASETS[kind]],
                    lambda a, b: self._compute_y(kind, slice(a, b)), self.data.opened)

    def _compute_y(self, kind, rows=slice(None)):
        """``kind``'s values in ``rows`` of the first axis (all by default; a slab is read
        alone, ``RecordedData.rows``), or None when the file holds none."""
        if kind == "winding":
            from .analysis import winding_number  # start-up: loads numba
            # the share of gamma clusters of a corner word; a contact word (linear) has none
            if self.contact_words:
                return np.full(self.symbols[rows].shape, np.nan)
            return np.vectorize(winding_number, otypes=[float])(self.symbols[rows])
        if kind == "period":
            per = self.period[rows]
            return np.where(per > 0, per, np.nan).astype(float)
        name = Y_DATASETS[kind]
        if name not in self.data:
            return None
        v = self.data[name] if rows == slice(None) else self.data.rows(name, rows)
        if self.unfinished is not None:          # a partial file: its finished points only
            un = self.unfinished[rows]
            v = np.where(un.reshape(un.shape + (1,) * (v.ndim - un.ndim)), np.nan, v)
        v = beyond_drawing(v)
        if kind == "impact_height" and self.spec is not None:
            contact = None
            if "impacts/contact" in self.data:      # each impact's contact (linear)
                contact = (self.data["impacts/contact"] if rows == slice(None)
                           else self.data.rows("impacts/contact", rows))
            ref = self.spec.impact_reference(self.scene.get("system", {}), self.values, rows,
                                             self.done[rows].shape, contact)
            if ref is not None:
                return v - ref
        if kind == "impact_height":
            # u - kappa: the impact's height above the corners of z = kappa + beta |sin|
            # (and the triangle's valleys), where a kappa sweep's cascade lies
            kap = (self.values["kappa"] if "kappa" in self.axes
                   else np.float64(self.scene.get("system", {}).get("kappa", 0.0)))
            if np.ndim(kap):
                pos = self.axes.index("kappa")
                kap = kap.reshape((-1,) + (1,) * (v.ndim - 1 - pos))
                kap = kap[rows] if pos == 0 else kap
            return v - kap
        return v

    def default_y(self):
        if self.spec is not None and self.spec.default_y:
            return self.spec.default_y
        for kind in ("impact_u", "section_u"):
            if Y_DATASETS[kind] in self.data:
                return kind
        return None


def is_continuation(path) -> bool:
    """Whether ``path`` is a ``cornerbif continue`` file (root attribute ``format``; a
    FIFO or a device is never opened: ``outputs.hdf5_format``)."""
    return hdf5_format(path) == CONTINUATION_FORMAT


# what a continuation file's branch holds per point, beside its parameter values
BRANCH_ARRAYS = ("impact_u", "impact_v_in", "section_u", "section_v", "stable",
                 "multiplier_re", "multiplier_im")


def read_continuation(path) -> dict:
    """A continuation file for a figure or ``info``: ``continuation_run.read``, with "path", once
    ``io.open_checked`` has found it a regular HDF5 file of format
    ``cornerbif-continuation`` this version reads, referring to no other file (links,
    external storage, virtual datasets), within memory; then each branch's datasets one row
    per point of its parameter values (finite), the events' and curves' likewise
    (``_check_continuation``).  Else ``FileFormatError`` naming the file."""
    from .io import FileFormatError, error_line, open_checked  # start-up: loads h5py
    path = str(path)
    with open_checked(path, FORMAT, FORMAT_VERSION):
        pass
    try:
        cont = read(path)
        _check_continuation(cont)
    except Exception as e:  # noqa: BLE001 - h5py's and a crafted file's zoo of errors
        raise FileFormatError(f"{path}: a damaged continuation file ({error_line(e, path)})") \
            from None
    cont["path"] = path
    return cont


def _check_continuation(cont):
    """What the figures and ``info`` need of a continuation file (``read_continuation``);
    a ValueError says what is not so."""
    if not cont["parameter"] or not isinstance(cont["parameter"], str):
        raise ValueError("no parameter")
    tomllib.loads(cont["scene"])
    for b, br in enumerate(cont["branches"]):
        lam = np.asarray(br.get("param"))
        if lam.ndim != 1 or lam.size == 0 or lam.dtype.kind != "f" or not np.isfinite(lam).all():
            raise ValueError(f"branch {b}: its parameter values are not a list of numbers")
        if "stable" not in br:
            raise ValueError(f"branch {b}: no 'stable'")
        for key in BRANCH_ARRAYS:
            v = br.get(key)
            if v is None:
                continue
            if not (isinstance(v, np.ndarray) and v.ndim in (1, 2) and v.shape[0] == lam.size
                    and v.dtype.kind in "fiub"):
                raise ValueError(f"branch {b}: {key} does not hold one row per point")
    for e in cont["events"]:
        if not (0 <= e["branch"] < len(cont["branches"])):
            raise ValueError(f"an event of branch {e['branch']}, which the file does not hold")
    for k, cv in enumerate(cont["curves"]):
        x, y = np.asarray(cv.get("param")), np.asarray(cv.get("event_param"))
        if x.ndim != 1 or x.shape != y.shape or x.dtype.kind != "f" or y.dtype.kind != "f":
            raise ValueError(f"curve {k}: its two parameters' values do not match")
        if not (0 <= int(cv.get("branch", -1)) < len(cont["branches"])):
            raise ValueError(f"curve {k}: of a branch the file does not hold")
