"""What every figure shares: a file's data as a figure reads it (``PlotData``, ``RecordedData``,
continuation files: ``read_continuation``), the labels of axes and values in the paper's
notation, the names of run outcomes, colours of attractors and branches, and the refusal of a
figure that cannot be drawn truthfully (``Undrawable``).  Loads neither matplotlib nor a
kernel."""

from __future__ import annotations

import contextlib
import os
import tomllib

import numpy as np

from . import obstacles, plot_attractors, registry
from . import status as S
from .errors import SweepError
from .io import check_readable
from .model import cut
from .plot_style import bounded, plain


class Undrawable(SweepError, ValueError):
    """Files or options one figure cannot show truthfully, refused before anything is drawn
    (exit 2); the message names each file and what it holds."""


def obstacle_kind(system: dict):
    """The obstacle kind (``model.Obstacle``) a file's ``[system]`` names, the default where it
    names none (the figures ask it what it draws: corner curves, marks, its wedge)."""
    from .model import Obstacle
    name = system.get("obstacle", obstacles.DEFAULT)
    known = obstacles.registered().get(name) if isinstance(name, str) else None
    return known or Obstacle(str(name), -1, "not a registered obstacle", 1, 1, corners=False)


LABELS = {
    "initial.u": r"start $u(t_0)$", "initial.v": r"start $v(t_0)$",
    "initial.z": r"start $z(t_0)$", "initial.y": r"start $y(t_0)$",
    "initial.t": r"start time $t_0$",
    "omega": r"$\omega$", "kappa": r"$\kappa$", "beta": r"$\beta$", "r": r"$r$",
    "sigma": r"$\sigma$", "k": r"$k$", "theta1": r"$\theta_1$", "theta2": r"$\theta_2$",
    "F": r"$F$", "Omega": r"$\Omega$", "phi": r"$\varphi$",
    "omega0": r"$\omega_0$", "omega1": r"$\omega_1$", "omega2": r"$\omega_2$",
    "mu": r"$\mu = M/m$", "r1": r"$r_1$", "r2": r"$r_2$",
}
YLABELS = {
    "impact_u": "impact height $u$", "impact_v": "impact velocity $v^-$",
    "impact_height": r"height above the corner $u - \kappa$",
    "section_u": r"$u(nT)$ (map2d: $a_n$)", "section_v": r"$v(nT)$ (map2d: $b_n$)",
    "winding": r"winding number $W$ (share of $\gamma$, §5.4)",
    "period": "period (clusters per cycle)",
}
def _model_labels(model: str | None) -> dict:
    """The labels a model declares for its own axes (``Model.axis_labels``)."""
    spec = registry.models().get(model) if isinstance(model, str) else None
    return spec.axis_labels if spec is not None else {}


def axis_label(name: str, model: str | None = None) -> str:
    """The label of a swept axis ``name`` for a file of ``model``."""
    return _model_labels(model).get(name) or LABELS.get(name, name)


# the diagram's y values that a model may name in its own terms (the maps' section is
# (a_n, b_n), a flow's (u(nT), v(nT)))
SECTION_KINDS = ("section_u", "section_v")


def y_label(kind: str, model: str | None = None) -> str:
    """The axis label of a drawn ``kind`` for a file of ``model`` (its own label where it
    declares one; a file of several models compared on one axis names both)."""
    own = _model_labels(model).get(kind)
    if own:
        return own
    if kind in SECTION_KINDS and model is not None:
        return YLABELS[kind].split(" (")[0]
    return YLABELS.get(kind, kind)


# the per-event datasets a figure may draw (read when first drawn: ``RecordedData``)
RECORDED = ("impacts/u", "impacts/v_in", "section/u", "section/v", "impacts/t",
            "impacts/corner_offset")
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
        import h5py
        with h5py.File(self.path, "r", swmr=self.swmr, locking=False) as f:
            self._file = f
            try:
                yield
            finally:
                self._file = None


# values larger than this in size are escapes (a figure's transforms overflow near 1e308):
# drawn as infinities are, not at all, and counted on the figure
DRAW_LIMIT = 1e100


def beyond_drawing(v):
    """``v`` with its values beyond DRAW_LIMIT in size as infinities of their sign."""
    v = np.asarray(v)
    if v.dtype.kind != "f":
        return v
    with np.errstate(invalid="ignore"):
        big = np.abs(v) > DRAW_LIMIT
    return np.where(big, np.copysign(np.inf, v), v) if big.any() else v


# the letters of a cycle word (analysis.detect_cycle: the corner clusters alpha, beta, gamma
# and x, any other cluster)
WORD_LETTERS = b"abgx"


def _words(sym):
    """The file's cycle words (``symbols``) as str no wider than the longest (the file's
    field may be many times wider: memory per run).  A word holding a character no kernel
    writes (a crafted file's) reads as no word: a figure never draws it."""
    width = sym.dtype.itemsize
    allowed = np.zeros(256, bool)
    allowed[list(b"\0" + WORD_LETTERS)] = True
    ok = allowed[np.ascontiguousarray(sym).view(np.uint8)]
    if width and not ok.all():
        sym = np.where(ok.reshape(sym.shape + (width,)).all(axis=-1), sym, b"")
    return sym.astype(f"U{max(1, int(np.char.str_len(sym).max(initial=0)))}")


class PlotData:
    """What the plot needs, read from one file.

    Only the grid points the sweep finished (``done``) are shown: a partial file's other
    points read as not run (status -1, no cycle, no values), and ``partial_note`` says how
    many are finished; a file with none finished is refused (``FileFormatError``)."""

    def __init__(self, path):
        from .io import FileFormatError
        with check_readable(path) as f:
            self.path = str(path)
            self.scene_text = f.attrs["scene"]
            self.scene = tomllib.loads(self.scene_text)
            from .config import sweep_items
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
            self.symbols = _words(f["symbols"][...])
            self.model = self.scene.get("scene", {}).get("model", registry.DEFAULT_MODEL)
            self.spec = registry.models().get(self.model)
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
        import h5py

        from .io import FileFormatError
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
            from .analysis import distinct_attractors
            from .plot_style import slab_rows
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
        from .plot_style import Rows
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
            from .analysis import winding_number
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


def points(x, y):
    """Bifurcation-diagram points: x repeated over every recorded value, NaN dropped."""
    xs = np.broadcast_to(x.reshape((-1,) + (1,) * (y.ndim - 1)), y.shape).ravel()
    ys = y.ravel()
    ok = np.isfinite(ys)
    return xs[ok], ys[ok]


ATTRACTOR_COLORS = ("tab:red", "tab:blue", "tab:green", "tab:orange", "tab:purple", "tab:brown")


# [plot] color_by (config.PLOT_COLOR_BY): what colours a diagram or a chart, per run, its
# label and the neutral value (docs/stability.md)
COLOR_BY = {
    "lyapunov": (r"largest Lyapunov exponent $\lambda_1$", 0.0),
    "multiplier": (r"largest Floquet multiplier $|\mu_1|$", 1.0),
}


EVENT_MARKERS = {"corner": ("D", "tab:red", "corner collision"),
                 "fold": ("^", "tab:purple", "fold"),
                 "period_doubling": ("s", "tab:orange", "period doubling"),
                 "torus": ("o", "tab:green", "torus"),
                 "grazing": ("X", "tab:blue", "grazing"),
                 "zero_velocity": ("v", "tab:brown", "zero-velocity impact")}
BRANCH_Y = {"impact_u": "impact_u", "impact_v": "impact_v_in", "section_u": "section_u",
            "section_v": "section_v"}


def is_continuation(path) -> bool:
    """Whether ``path`` is a ``cornerbif continue`` file (root attribute ``format``; a
    FIFO or a device is never opened: ``outputs.hdf5_format``)."""
    from .outputs import CONTINUATION_FORMAT, hdf5_format
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
    from .continuation_run import FORMAT, FORMAT_VERSION, read
    from .io import FileFormatError, error_line, open_checked
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


def continuation_note(cont) -> str:
    """What a figure or ``info`` says of a continuation file that is not finished ("" when
    it is)."""
    if cont["attrs"].get("completed"):
        return ""
    n = len(cont["branches"])
    return (f"partial continuation: {n} branch{'' if n == 1 else 'es'} finished "
            "(cornerbif continue SCENE -o OUT --resume completes it)")


def mask_runs(mask):
    """(start, stop) of the runs of True in a boolean array."""
    out, i = [], 0
    while i < len(mask):
        if mask[i]:
            j = i
            while j < len(mask) and mask[j]:
                j += 1
            out.append((i, j))
            i = j
        else:
            i += 1
    return out


def word_label(word) -> str:
    """A cycle word in the paper's notation (b^3 g -> beta^3 gamma; '?' when unknown); a
    file's word of other characters is shown as it is (``plain``)."""
    w = str(word) if word else ""
    if not w:
        return "?"
    if set(w.partition("#")[0]) - set(WORD_LETTERS.decode()):
        return plain(w)
    return plot_attractors.label_tex(w)


def branch_colors(conts) -> dict:
    """A colour per branch word, the one its orbit has in every diagram
    (``plot_attractors.attractor_colors``: beta blue, alpha orange, gamma green)."""
    return plot_attractors.attractor_colors([str(br["word"]) for c in conts
                                             for br in c["branches"]])


def branch_keys(conts) -> set:
    """The values the branches of ``conts`` store per point (``BRANCH_Y``'s values)."""
    return {k for c in conts for b in c["branches"] for k in b if k in BRANCH_Y.values()}


def own_branch_y(conts) -> str:
    """What branches draw by default: impact heights, else the section's velocity."""
    have = branch_keys(conts)
    return "impact_u" if "impact_u" in have or not have else "section_v"


# how a run that reached no cycle ended, by its status (cornerbif.status; -1: not run)
ENDINGS = {S.OK: "ended without one (chaos, or a period too long for the record)",
           S.NO_IMPACT: "never impacted (within the time budget)",
           S.STUCK: "stuck to the obstacle",
           S.MAX_EVENTS: "spent the event budget (chattering)",
           S.ESCAPED: "escaped (amplitude past the escape bound)",
           S.BELOW_OBSTACLE: "started below the obstacle",
           S.STEP_LIMIT: "ran out of root-search steps",
           S.NONFINITE: "reached a non-finite state",
           -1: "not run"}


def status_name(code: int, names=None) -> str:
    """A run's status in the file's words (``names``: its ``status_codes``, else
    ``status.NAMES``): -1 is NOT_RUN, a code neither knows 'unknown (N)'."""
    code = int(code)
    if code == -1:
        return "NOT_RUN"
    name = (names or S.NAMES).get(str(code) if names else code)
    return bounded(name, 40) if name else f"unknown ({code})"


def endings(status, no_cycle) -> str:
    """How the runs ``no_cycle`` (a mask) that reached no cycle ended, by status, most
    first: '3 ended without one (chaos, ...), 2 escaped (...)'; '' when there are none."""
    codes, counts = np.unique(np.asarray(status)[no_cycle], return_counts=True)
    order = sorted(zip(counts.tolist(), codes.tolist()), key=lambda t: (-t[0], t[1]))
    return ", ".join(f"{n} {ENDINGS.get(c, f'of unknown status {c}')}" for n, c in order)


def attractor_summary(data: PlotData, tex: bool = True) -> str:
    """One line: how many attractors coexist, and where; how the runs without a cycle
    ended, by status (for the figure and ``cornerbif info``).  "No cycle (chaos, or a
    period too long)" is said only of runs that ended well without one."""
    labels, count = data.attractors()
    if count.size == 0:
        return ""
    n = count.size
    k = int(count.max())
    run = data.status != -1                     # a partial file's unfinished points aside
    no_cycle = (labels < 0) & run
    how = endings(data.status, no_cycle)
    if k == 0:
        if not no_cycle.any():
            return "no run finished"
        if (data.status[no_cycle] == S.OK).all():
            return "no start reached a cycle (chaos, or a period too long for the record)"
        return f"no start reached a cycle: of {int(no_cycle.sum())} runs, {how}"
    parts = [f"coexisting attractors: up to {k}"]
    if k >= 2 and data.axes:
        a = data.axes[0]
        where = np.nonzero(count.reshape(len(data.values[a]), -1).max(axis=1) >= 2)[0]
        vals = data.values[a][where]
        parts.append(f"{int((count >= 2).sum())} of {n} points have 2 or more "
                     f"({LABELS.get(a, a) if tex else a} in [{vals.min():.6g}, {vals.max():.6g}])")
    none = int(no_cycle.all(axis=-1).sum())
    if none:
        parts.append(f"{none} points without a cycle")
    if no_cycle.any():
        parts.append(f"runs without a cycle: {how}")
    return "; ".join(parts)


def follow_label(d: PlotData) -> str:
    """A followed sweep's legend entry: the way it went along its parameter."""
    a = d.axes[0]
    name = LABELS.get(a, a)
    return (rf"followed up: {name} increasing $\rightarrow$" if d.follow == "up"
            else rf"followed down: {name} decreasing $\leftarrow$")


def need_table(data: PlotData):
    """Basin images and fractions read the file's attractor table (cornerbif.attractors),
    which a sweep writes when it finishes."""
    if not data.has_table:
        raise Undrawable(f"{data.path}: has no attractor table (written by an older "
                         "cornerbif, or not finished), which this figure draws; "
                         + ("complete the sweep (cornerbif sweep SCENE -o OUT --resume)"
                            if not data.complete else "run its sweep again"))


def _sides(datas) -> set:
    """Which sides of the normal-form figures the files are: maps or not (None: neither)."""
    return {d.normal_form.maps if d.normal_form else None for d in datas}


def flow_and_map(datas) -> bool:
    """Whether ``datas`` are a flow and its map (two files, of the roles flow and map)."""
    return len(datas) == 2 and _sides(datas) == {False, True}


def cfg_for_y(cfg: dict, y, default_y) -> dict:
    """The ``[plot]`` table for a figure of ``y`` (``--y``): the scene's ``ylim`` is a
    window in the scene's own y (``[plot] y``, else the file's default), so it is dropped
    when another y is drawn."""
    own = cfg.get("y") or default_y
    if y and "ylim" in cfg and y != own:
        return {k: v for k, v in cfg.items() if k != "ylim"}
    return cfg


def partial_notes(fig, datas, conts=()):
    """A file that is not complete says so at the figure's foot, in red: how many of its
    grid points (or branches) are finished and shown (``PlotData.partial_note``)."""
    several = len(datas) + len(conts) > 1
    notes = [(d.path, d.partial_note()) for d in datas]
    notes += [(c["path"], continuation_note(c)) for c in conts]
    text = "\n".join(f"{plain(os.path.basename(p), 40)}: {n}" if several else n
                      for p, n in notes if n)
    if text:
        fig.text(0.995, 0.005, text, ha="right", va="bottom", fontsize=7, color="tab:red")
