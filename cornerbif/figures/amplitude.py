"""``[plot] kind = "amplitude"``: the amplitude of one coordinate of a ``linear`` scene against
its one swept parameter, run by run, and (``[plot] without``) over it the same structure with
some coordinates removed, in closed form: the impact damper against the structure without
its ball (issue 33).

```toml
[plot]
kind = "amplitude"
coordinate = "x"        # a dof of [system] dofs: whose amplitude is drawn
without = ["y"]         # optional: the reference, the structure without these dofs
```

**The amplitude** of coordinate x of a run is A = (max x − min x) / 2 over its last recorded
cycle (the run's last ``impacts_per_cycle`` flights): a forced structure oscillating between
−A and A has amplitude A, whatever its mean.  A run without a cycle that ended OK (chaotic,
or of a period longer than the record) is drawn apart, in grey: (max − min) / 2 over its
whole recorded window; one that ended otherwise (STUCK: the ball chattered to rest, which the
model does not follow yet) is not drawn, and counted by its status.

It is computed exactly between impacts (``cycle_extremes``): from each recorded impact's
state (every x_<dof> and v_<dof> just after it, at its time t) the flight to the next impact
is the model's own exact flight (``models.linear.flight.augmented``: y(t + s) = expm(A s)
y(t), y = (x, v, (cos, sin)(Ω t + φ) of each force)), sampled at ``SAMPLES`` (at least, and
at least ‖A‖₁ h + 1) equal steps δ, each step expm(A δ) by its series to (‖A‖₁ δ)^J / J! <
1e-18 (‖A‖₁ δ ≤ 1: exact to rounding), for every flight of a grid point at once.  Where x's
velocity changes sign between two samples, the extremum between them is located where it
vanishes: Newton steps on the same series about the sample, kept in the bracket (else
halving it).  So every extremum is exact but one whose velocity changes sign twice within
one step δ (a maximum and a minimum closer than δ), which lies within max|x''| δ² / 8 of the
samples.  The flights' ends (the impacts, where x is continuous and its velocity may jump)
are samples.

**The reference** (``without``): the structure with those dofs' rows and columns of M, K, C
and the forces on them removed, whose steady response to the swept force F cos(Ω t + φ) is
harmonic of amplitude |(H(Ω) F)_x|, H(Ω) = (K − Ω² M + iΩ C)⁻¹ (one dof: F / √((k − mΩ²)² +
(cΩ)²)), a line over the swept range.  ``without = []`` is the whole system with no contacts.
It needs the swept parameter to be a force's frequency ``forcing.<k>.Omega``, acting on a
kept dof, and no other force on the kept dofs (the response to it alone); otherwise the scene
is refused, naming the key and its value.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING

import numpy as np

from .. import registry
from ..model import FigureKind
from ..models.linear.flight import augmented, has_constant_state
from ..plot_style import save, title_lines

if TYPE_CHECKING:
    from ..plot_data import PlotData

SAMPLES = 200          # samples of each flight, at least (more where ‖A‖ h is large)
TAYLOR = 30            # terms of the flight's series about a sample, at most (‖A‖₁ δ <= 1)
# the root's steps: Newton kept in its bracket, else bisection; 24 halvings alone leave the
# root within δ 2^-24, x there within max|x''| (δ 2^-24)² / 2 of the extremum
ROOT_STEPS = 24
LEGEND_WORDS = 6       # the cycles' words named in the legend (the most frequent); the rest in black
WORD_COLORS = ("tab:orange", "tab:blue", "tab:green", "tab:red", "tab:purple", "tab:brown")
OMEGA_AXIS = re.compile(r"forcing\.(\d+)\.Omega")


# ------------------------------------------------------------------ the exact amplitude
def _forcing_states(system, t):
    """``flight.forcing_state`` at each time of ``t`` (F,): (F, m)."""
    cols = []
    for f in system.forcing:
        if f.Omega > 0.0:
            cols += [np.cos(f.Omega * t + f.phi), np.sin(f.Omega * t + f.phi)]
    if has_constant_state(system):
        cols.append(np.ones_like(t))
    return np.stack(cols, axis=1) if cols else np.zeros((t.size, 0))


def _series_root(c_x, c_v, c_a, width):
    """Per row, the root tau in [0, width] of v(tau) = sum c_v[m] tau^m, which changes sign
    there (bracketed), by Newton steps kept inside the bracket (else bisection); x there."""
    lo, hi = np.zeros(width.size), width.copy()
    v_lo = c_v[:, 0]
    tau = 0.5 * width

    def poly(c, s):
        out = np.zeros(s.size)
        for m in range(c.shape[1] - 1, -1, -1):
            out = out * s + c[:, m]
        return out
    for _ in range(ROOT_STEPS):
        v = poly(c_v, tau)
        same = np.sign(v) == np.sign(v_lo)
        lo, hi = np.where(same, tau, lo), np.where(same, hi, tau)
        v_lo = np.where(same, v, v_lo)
        a = poly(c_a, tau)
        with np.errstate(divide="ignore", invalid="ignore"):
            nt = tau - v / a
        inside = np.isfinite(nt) & (nt > lo) & (nt < hi)
        tau = np.where(inside, nt, 0.5 * (lo + hi))
    return poly(c_x, tau)


def cycle_extremes(system, t0, x0, v0, h, coordinate: int, samples: int = SAMPLES):
    """(max, min) of coordinate ``coordinate`` over each flight of ``system`` from (x0, v0)
    (F, N) just after an impact at t0 (F,), lasting h (F,): exact (the module docstring)."""
    A = augmented(system)
    n, d = system.n, A.shape[0]
    t0, h = np.asarray(t0, float), np.asarray(h, float)
    y = np.concatenate([np.asarray(x0, float), np.asarray(v0, float),
                        _forcing_states(system, t0)], axis=1)
    norm = np.linalg.norm(A, 1)
    m = max(samples, int(np.ceil(norm * h.max(initial=0.0))) + 1)
    delta = h / (m - 1)
    # the series' terms: (||A|| delta)^J / J! below 1e-18 (at most TAYLOR)
    r, J, term = norm * delta.max(initial=0.0), 1, 1.0
    while J < TAYLOR and term > 1e-18:
        term *= r / J
        J += 1
    # expm(A delta) of every flight at once: its series, exact to rounding at ||A delta|| <= 1
    powers = np.empty((J, d, d))
    powers[0] = np.eye(d)
    for j in range(1, J):
        powers[j] = powers[j - 1] @ A / j
    E = np.einsum("fj,jab->fab", delta[:, None] ** np.arange(J), powers)
    S = np.empty((h.size, m, d))
    S[:, 0] = y
    for k in range(1, m):
        S[:, k] = np.einsum("fij,fj->fi", E, S[:, k - 1])
    x, v = S[:, :, coordinate], S[:, :, n + coordinate]
    hi, lo = x.max(axis=1, initial=-np.inf), x.min(axis=1, initial=np.inf)
    f, k = np.nonzero(np.sign(v[:, :-1]) * np.sign(v[:, 1:]) < 0)
    if f.size:
        # the flight's series about each bracketing sample: c_j = A^j y / j!
        c = np.empty((f.size, J, d))
        c[:, 0] = S[f, k]
        for j in range(1, J):
            c[:, j] = c[:, j - 1] @ A.T / j
        c_x, c_v = c[:, :, coordinate], c[:, :, n + coordinate]
        c_a = np.zeros_like(c_v)
        c_a[:, :-1] = c_v[:, 1:] * np.arange(1, J)
        xr = _series_root(c_x, c_v, c_a, delta[f])
        np.maximum.at(hi, f, xr)
        np.minimum.at(lo, f, xr)
    return hi, lo


def run_amplitudes(system, t, x, v, ipc, coordinate: int, samples: int = SAMPLES):
    """The amplitude (max − min) / 2 of coordinate ``coordinate`` over each run's last
    recorded cycle: its last ``ipc`` flights between the recorded impacts at times t (R,
    rec) with states x, v (R, rec, N) just after them.  A run without a cycle (ipc 0): over
    all its recorded flights (the figure draws it apart); NaN with fewer than two impacts
    recorded (or fewer than ipc + 1)."""
    R = t.shape[0]
    count = np.isfinite(t).sum(axis=1)
    span = np.where(ipc > 0, ipc, count - 1)
    ok = (span > 0) & (count >= span + 1)
    rows, flights = [], []
    for r in np.flatnonzero(ok):
        for j in range(count[r] - 1 - span[r], count[r] - 1):
            rows.append(r)
            flights.append(j)
    out = np.full(R, np.nan)
    if not rows:
        return out
    rows, flights = np.array(rows), np.array(flights)
    hi, lo = cycle_extremes(system, t[rows, flights], x[rows, flights], v[rows, flights],
                            t[rows, flights + 1] - t[rows, flights], coordinate, samples)
    top, bottom = np.full(R, -np.inf), np.full(R, np.inf)
    np.maximum.at(top, rows, hi)
    np.minimum.at(bottom, rows, lo)
    out[ok] = 0.5 * (top[ok] - bottom[ok])
    return out


def _read_states(data: PlotData, dofs):
    """The recorded impacts' times (runs + (rec,)) and states x, v (runs + (rec, N)) of the
    file ``data`` (``PlotData`` reads the datasets every model writes; the per-dof ones of a
    linear file are read here), each of the runs' shape."""
    import h5py  # start-up: loads h5py
    names = ["impacts/t"] + [f"impacts/{d}" for d in dofs] + [f"impacts/v_{d}" for d in dofs]
    with h5py.File(data.path, "r", locking=False) as f:
        missing = [n for n in names if n not in f or not isinstance(f[n], h5py.Dataset)]
        if missing:
            raise ValueError(f"{data.path}: holds no {missing[0]}: the amplitude is computed "
                             "from every dof's state at the impacts (output.keep = [\"impacts\"])")
        arrays = [f[n][...] for n in names]
    runs = np.shape(data.status)
    shape = arrays[0].shape
    if len(shape) != len(runs) + 1 or shape[:-1] != runs or any(a.shape != shape for a in arrays):
        raise ValueError(f"{data.path}: its impacts' datasets do not match the runs {runs}")
    arrays = [np.asarray(a, float) for a in arrays]
    k = len(dofs)
    return arrays[0], np.stack(arrays[1:1 + k], axis=-1), np.stack(arrays[1 + k:], axis=-1)


def file_amplitudes(data: PlotData, coordinate: str):
    """(the swept values, the amplitudes (points, starts) of ``coordinate`` of each run of
    the file ``data`` (``run_amplitudes``; NaN at unfinished points), the scene's system at
    its first point)."""
    scene, spec = data.parsed, data.spec
    axis = data.axes[0]
    dofs = list(data.scene["system"]["dofs"])
    i = dofs.index(coordinate)
    t, x, v = _read_states(data, dofs)
    ipc = np.asarray(data.ipc)
    amp = np.full(ipc.shape, np.nan)
    first = None
    for p in range(ipc.shape[0]):
        system, bad = spec.system_of(scene.point((p,)))
        if bad:
            raise ValueError("; ".join(bad))
        first = first or system
        if data.done[p]:
            amp[p] = run_amplitudes(system, t[p], x[p], v[p], ipc[p], i)
    return data.values[axis], amp, first


# ------------------------------------------------------------------ the reference
def without_ball(system, without, force: int, coordinate: str, Omega):
    """|(H(Omega) F)_coordinate| of ``system`` with the dofs ``without`` removed (their rows
    and columns of M, K, C), forced by its force number ``force`` alone, at each Omega."""
    keep = [k for k, d in enumerate(system.dofs) if d not in without]
    M, K, C = (a[np.ix_(keep, keep)] for a in (system.mass, system.stiffness, system.damping))
    f = system.forcing[force]
    F = np.zeros(len(keep))
    F[keep.index(f.on)] = f.F
    i = keep.index(list(system.dofs).index(coordinate))
    out = []
    for w in np.atleast_1d(np.asarray(Omega, float)):
        Z = K - w * w * M + 1j * w * C
        try:
            out.append(abs(np.linalg.solve(Z, F)[i]))
        except np.linalg.LinAlgError:
            out.append(np.inf)
    return np.array(out)


# ------------------------------------------------------------------ the scene's check
def _reference_problems(table, without, coordinate, axes) -> list:
    """What the reference ``[plot] without`` needs of the scene (module docstring)."""
    dofs = list(table.get("dofs", []))
    if not (isinstance(without, list) and all(isinstance(d, str) for d in without)):
        return [f"plot.without: {without!r} must be a list of dof names (the structure "
                f"without them is drawn; its dofs: {', '.join(dofs)})"]
    unknown = [d for d in without if d not in dofs]
    if unknown:
        return [f"plot.without: {unknown[0]!r} is not a dof of the system; its dofs: "
                f"{', '.join(dofs)}"]
    if coordinate in without:
        return [f"plot.without: {without!r} removes {coordinate!r}, the plot.coordinate drawn"]
    names = [a.name for a in axes]
    match = OMEGA_AXIS.fullmatch(names[0]) if len(names) == 1 else None
    if match is None:
        return [f"plot.without: {without!r}: the structure without them is drawn in closed form "
                "against the forcing frequency; the scene must sweep a force's "
                f"\"forcing.<k>.Omega\" alone, and it sweeps {', '.join(repr(n) for n in names)}"
                f" (sweep.{names[0] if names else ''})"]
    forcing = table.get("forcing", [])
    k = int(match.group(1))
    if k >= len(forcing):
        return []       # the sweep's own check names it
    on = forcing[k].get("on")
    if on in without:
        return [f"plot.without: {without!r} removes {on!r}, on which the swept force "
                f"forcing.{k} (sweep.{names[0]}) acts"]
    others = [j for j, f in enumerate(forcing) if j != k and f.get("on") not in without]
    if others:
        j = others[0]
        return [f"plot.without: the structure without {without!r} is drawn in closed form as "
                f"its response to the swept force forcing.{k} alone; system.forcing.{j} "
                f"({forcing[j]!r}) acts on a kept dof too"]
    return []


class Amplitude(FigureKind):
    def check(self, w):
        table = getattr(w.spec, "system_table", None)
        if w.spec.for_system is None or not isinstance(table, dict):
            which = " or ".join(repr(m.name) for m in registry.models().values()
                                if m.for_system is not None)
            return [f"plot.kind: 'amplitude' draws a coordinate of a {which} scene (its "
                    f"recorded states between exact flights); the scene's model is {w.model!r}"]
        problems = []
        if "impacts" not in w.keep:
            problems.append("plot.kind: 'amplitude' is computed from the impacts' states; "
                            "output.keep must contain \"impacts\"")
        if len(w.axes) != 1:
            problems.append(f"plot.kind: 'amplitude' draws each run's amplitude against one swept "
                            f"parameter; the scene sweeps {len(w.axes)}")
        plot = w.table("plot")
        dofs = list(table.get("dofs", []))
        coordinate = plot.get("coordinate")
        if coordinate is None:
            return problems + [f"plot.coordinate: missing; 'amplitude' draws one dof's amplitude "
                               f"(one of {', '.join(dofs)})"]
        if coordinate not in dofs:
            return problems + [f"plot.coordinate: {coordinate!r} is not a dof of the system; "
                               f"its dofs: {', '.join(dofs)}"]
        if "without" in plot:
            problems += _reference_problems(table, plot["without"], coordinate, w.axes)
        return problems

    def draw(self, plt, datas, out, y, title, plot_cfg, color_by, branches):
        # start-up: drawing loads h5py and matplotlib; checking a scene loads neither
        from ..plot_base import partial_notes
        fig = figure_amplitude(plt, datas[0], plot_cfg, title)
        partial_notes(fig, datas)
        return save(fig, out)


def figure_amplitude(plt, data: PlotData, plot_cfg: dict, title=None):
    """Each run's amplitude against the swept parameter, coloured by its cycle's word, the
    reference without ``[plot] without`` over it, and the peaks of both in a box."""
    # start-up: drawing loads h5py, matplotlib and numba; checking a scene loads none
    from ..plot_base import axis_label, status_name
    coordinate = plot_cfg["coordinate"]
    xs, amp, system = file_amplitudes(data, coordinate)
    axis = data.axes[0]
    label = "$\\Omega$" if OMEGA_AXIS.fullmatch(axis) else axis
    fig, ax = plt.subplots(figsize=(7, 4.5), dpi=150)
    words = np.asarray(data.symbols)
    cyc = np.isfinite(amp) & (np.asarray(data.ipc) > 0)
    # a run without a cycle that ended well (chaotic, or a period past the record): over its
    # window; one that ended otherwise (stuck: the ball chattered to rest) is its transient
    nocyc = np.isfinite(amp) & ~cyc & (np.asarray(data.status) == 0)
    amp = np.where(cyc | nocyc, amp, np.nan)
    grid = np.broadcast_to(xs[:, None], amp.shape)
    without = plot_cfg.get("without")
    who = f"with {', '.join(without)}" if without else "runs"
    if nocyc.any():
        ax.plot(grid[nocyc], amp[nocyc], ".", ms=2.0, color="0.6",
                label=f"{who}, no cycle: over its recorded window")
    counts = {}
    for wd in words[cyc].tolist():
        counts[wd] = counts.get(wd, 0) + 1
    shown = sorted(counts, key=lambda s: (-counts[s], len(s), s))[:LEGEND_WORDS]
    colors = dict(zip(shown, WORD_COLORS))
    rest = cyc & ~np.isin(words, shown)
    if rest.any():
        ax.plot(grid[rest], amp[rest], "o", ms=2.5, color="k",
                label=f"{who}: {len(counts) - len(shown)} other cycles")
    for wd in shown:
        sel = cyc & (words == wd)
        ax.plot(grid[sel], amp[sel], "o", ms=2.5, color=colors[wd],
                label=f"{who}: cycle {wd} ({counts[wd]} runs)")
    lines = []
    for what, sel in ((f"{who}, cycles", cyc), (f"{who}, all runs", cyc | nocyc)):
        if sel.any():
            a = np.where(sel, amp, -np.inf)
            p = int(np.argmax(a.max(axis=1)))
            lines.append(f"{what}: peak {a[p].max():.4g} at {label} = {xs[p]:.4g}")
    if without is not None:
        k = int(OMEGA_AXIS.fullmatch(axis).group(1))
        fine = np.linspace(xs.min(), xs.max(), 2001)
        ref = without_ball(system, without, k, coordinate, fine)
        name = ", ".join(without) if without else "the contacts"
        ax.plot(fine, ref, "-", color="0.25", lw=1.0,
                label=f"without {name}: $|H(\\Omega)F|$ (closed form)")
        j = int(np.argmax(ref))
        lines.append(f"without {name}: peak {ref[j]:.4g} at {label} = {fine[j]:.4g}")
    st = np.asarray(data.status)
    none = ~np.isfinite(amp) & (st != -1)
    if none.any():
        codes, counts = np.unique(st[none], return_counts=True)
        lines.append("not drawn (no cycle, not ended OK): " + ", ".join(
            f"{c} {status_name(k)}" for k, c in zip(codes.tolist(), counts.tolist())))
    if lines:
        ax.text(0.99, 0.98, "\n".join(lines), transform=ax.transAxes, ha="right", va="top",
                fontsize=7, bbox=dict(fc="white", ec="0.7", lw=0.5))
    ax.set_xlabel(f"{axis} ({label})" if label != axis else axis_label(axis, data.model))
    ax.set_ylabel(f"amplitude of {coordinate}: (max − min)/2 over the last cycle")
    if "ylim" in plot_cfg:
        ax.set_ylim(*plot_cfg["ylim"])
    else:
        ax.set_ylim(bottom=0.0)
    if "xlim" in plot_cfg:
        ax.set_xlim(*plot_cfg["xlim"])
    ax.legend(loc="center right", fontsize=6, markerscale=2)
    sc = data.scene.get("scene", {})
    ax.set_title(title_lines(title or plot_cfg.get("title") or sc.get("title", ""), 80),
                 fontsize=9)
    fig.tight_layout()
    return fig


FIGURE = Amplitude("amplitude", "a coordinate's amplitude over its cycle (linear), against the "
                   "structure without some dofs", files="one", one_axis=True)
