"""What every figure shares: a file's data as a figure reads it (``PlotData``, ``RecordedData``,
continuation files: ``read_continuation``), the labels of axes and values in the paper's
notation, the names of run outcomes, colours of attractors and branches, and the refusal of a
figure that cannot be drawn truthfully (``Undrawable``).  Loads neither matplotlib nor a
kernel."""

from __future__ import annotations

import os
from typing import TYPE_CHECKING

import numpy as np

from . import obstacles, plot_attractors, registry
from . import status as S
from .chaos import CHAOTIC
from .errors import SweepError
from .model import Obstacle
from .plot_style import bounded, plain

if TYPE_CHECKING:
    from .plot_data import PlotData


class Undrawable(SweepError, ValueError):
    """Files or options one figure cannot show truthfully, refused before anything is drawn
    (exit 2); the message names each file and what it holds."""


def obstacle_kind(system: dict, spec=None):
    """The obstacle kind (``model.Obstacle``) a file's ``[system]`` names; where it names none,
    its model's ``drawn_obstacle`` (``spec``: the file's model; None: the paper's obstacle,
    ``obstacles.DEFAULT``).  The figures ask it what they draw: corner curves, marks, its
    wedge; a model with no one obstacle gets a kind that draws none."""
    default = obstacles.DEFAULT if spec is None else spec.drawn_obstacle
    name = system.get("obstacle", default)
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


# the letters of a cycle word (analysis.detect_cycle: the corner clusters alpha, beta, gamma
# and x, any other cluster)
WORD_LETTERS = b"abgx"


# every letter a kernel may write: the corner clusters' and a linear model's contact names
# (one ASCII letter each: models/linear/declare.py)
SYMBOL_LETTERS = b"abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ"


def symbol_words(sym, letters=WORD_LETTERS):
    """The file's cycle words (``symbols``) as str no wider than the longest (the file's
    field may be many times wider: memory per run).  A word holding a character no kernel
    of its model writes (``letters``: the corner clusters' WORD_LETTERS, or any letter for a
    linear model's contacts; a crafted file's other bytes) reads as no word: a figure never
    draws it."""
    width = sym.dtype.itemsize
    allowed = np.zeros(256, bool)
    allowed[list(b"\0" + letters)] = True
    ok = allowed[np.ascontiguousarray(sym).view(np.uint8)]
    if width and not ok.all():
        sym = np.where(ok.reshape(sym.shape + (width,)).all(axis=-1), sym, b"")
    return sym.astype(f"U{max(1, int(np.char.str_len(sym).max(initial=0)))}")


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


# a run that ended well without a cycle, once the chaos pass has looked at it (a file
# whose attractor table says which runs are on chaotic attractors)
TESTED_OK = "ended without one within the record, on no chaotic attractor"


def endings(status, no_cycle, tested=False) -> str:
    """How the runs ``no_cycle`` (a mask) that reached no cycle ended, by status, most
    first: '3 ended without one (chaos, ...), 2 escaped (...)'; '' when there are none.
    ``tested``: the file's table names its chaotic attractors (the runs left are not on
    one: TESTED_OK)."""
    codes, counts = np.unique(np.asarray(status)[no_cycle], return_counts=True)
    order = sorted(zip(counts.tolist(), codes.tolist()), key=lambda t: (-t[0], t[1]))
    words = dict(ENDINGS) | ({S.OK: TESTED_OK} if tested else {})
    return ", ".join(f"{n} {words.get(c, f'of unknown status {c}')}" for n, c in order)


def chaotic_runs(data: PlotData):
    """The runs on chaotic attractors (the table's rows of word ``chaos.CHAOTIC``), a mask
    shaped as the file's runs, or None where the file has no table or one written before
    the table named them."""
    if not data.has_table:
        return None
    tab = plot_attractors.read_table(data.path)
    if tab is None or "lyapunov" not in tab:
        return None
    ids = tab["id"][tab["word"] == CHAOTIC]
    return np.isin(tab["ids"], ids)


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
    chaotic = chaotic_runs(data)
    if chaotic is not None and chaotic.shape == no_cycle.shape:
        no_cycle &= ~chaotic
    how = endings(data.status, no_cycle, tested=chaotic is not None)
    has_chaos = chaotic is not None and bool(chaotic.any())
    if k == 0 and not has_chaos:
        if not no_cycle.any():
            return "no run finished"
        if (data.status[no_cycle] == S.OK).all():
            return "no start reached a cycle (chaos, or a period too long for the record)"
        return f"no start reached a cycle: of {int(no_cycle.sum())} runs, {how}"
    parts = [f"coexisting attractors: up to {k}"] if k else ["no periodic attractor"]
    if k >= 2 and data.axes:
        a = data.axes[0]
        where = np.nonzero(count.reshape(len(data.values[a]), -1).max(axis=1) >= 2)[0]
        vals = data.values[a][where]
        parts.append(f"{int((count >= 2).sum())} of {n} points have 2 or more "
                     f"({LABELS.get(a, a) if tex else a} in [{vals.min():.6g}, {vals.max():.6g}])")
    if has_chaos:
        on = chaotic.reshape(n, -1).any(axis=1)
        parts.append(f"{int(chaotic.sum())} runs at {int(on.sum())} points on chaotic "
                     "attractors (Lyapunov exponent's 95 % interval above 0)")
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
