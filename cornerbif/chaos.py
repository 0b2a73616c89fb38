"""Chaotic attractors among the runs that reached no cycle (docs/basins.md "Chaotic
attractors").

A run that ends well without a cycle in its record (``attractors.NO_CYCLE``) is on a chaotic
attractor, on a cycle longer than its record, on a torus, or still in its transient.  The
file's record cannot tell these apart, so each such run is run again from its stored start
(the same kernel, the same transient) over a longer window of ``WINDOW`` impacts (section
periods for the models that record sections), keeping the model's cycle series and its
stability (``[output] keep`` "stability": the largest Lyapunov exponent over the window,
docs/stability.md).  Then:

* **recurrence** (the idea of Attractors.jl's recurrences method, Datseris & Wagemakers
  2022): the window's cycle series (a, b) on a grid of RECURRENCE_CELLS x RECURRENCE_CELLS
  cells over its own range; the run has settled on a bounded recurrent set when at least
  RECURRENCE_MIN of the second half's points fall in cells the first half visited;
* **one attractor per overlapping set**: at one parameter point, recurrent runs whose clouds
  share cells (each holds at least OVERLAP_MIN of its points in cells of the other, on a
  grid over both) are one attractor (union of such pairs);
* **the Lyapunov exponent with its interval**: each run of the attractor gives one estimate
  over its own window (independent starts); with fewer than MIN_ESTIMATES runs, the first
  run is continued over further windows (transient + k WINDOW) until there are.  Their mean
  and its Student-t 95 % interval (``basin_stats.mean_interval``).

An attractor whose interval lies above 0 is a **chaotic attractor**: a row of the table with
word CHAOTIC, period 0, its runs, share and exponent.  Every other run keeps NO_CYCLE, "no
cycle within the record": an honest unknown (a longer cycle, a torus, a slow transient, or
an exponent whose interval holds 0).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from . import status as S
from .basin_stats import mean_interval

CHAOTIC = "~"               # the word of a chaotic attractor in the table (no cycle word)
WINDOW = 2000               # impacts (or section periods) of each rerun's window
RECURRENCE_CELLS = 8
RECURRENCE_MIN = 0.9
OVERLAP_CELLS = 16
OVERLAP_MIN = 0.5
MIN_ESTIMATES = 3
GROUP = 256                 # runs rerun at a time (memory: GROUP x WINDOW x the outputs)
RERUN_MAX = 64              # runs rerun at one parameter point (the first in the file's order)
BUDGET_MAX = 2**62 - 1      # a rerun's scaled budgets stay within a scene's limits (config's
PERIODS_MAX = 2**58         # MAX_INT - 1 and MAX_PERIODS)
# why a run with no cycle is not on a chaotic attractor (``find``; the table's
# /attractors/no_cycle counts them per parameter point)
REASONS = ("its long rerun did not end well (escapes, sticks for good, budget)",
           "it sticks within the long window (exponent -inf: a long orbit through sticking)",
           "its exponent is undefined over the long window (a grazing, or too few impacts)",
           "not recurrent within the long window (a transient)",
           "its exponent's interval is not above 0 (a longer cycle, a torus)",
           f"past the first {RERUN_MAX} runs without a cycle at its point: on no chaotic "
           "attractor found among those (rerun, its window's points are not in one's cells)")


@dataclasses.dataclass
class Chaotic:
    """A chaotic attractor found at one parameter point."""
    point: int                  # the parameter point
    runs: np.ndarray            # the file's flat run indices it attracts
    a: np.ndarray               # its cloud: the cycle series of its runs' windows
    b: np.ndarray
    lyapunov: float
    low: float
    high: float


def recurrence(a, b, cells=RECURRENCE_CELLS) -> float:
    """The share of the second half's finite points (a, b) that fall in cells of a
    ``cells`` x ``cells`` grid over the whole window's range that the first half visited."""
    ok = np.isfinite(a) & np.isfinite(b)
    a, b = a[ok], b[ok]
    n = a.size
    if n < 8:
        return 0.0
    ia = _cell(a, a.min(), a.max(), cells)
    ib = _cell(b, b.min(), b.max(), cells)
    code = ia * cells + ib
    seen = np.zeros(cells * cells, bool)
    seen[code[: n // 2]] = True
    return float(seen[code[n // 2:]].mean())


def _cell(x, lo, hi, cells):
    if hi <= lo:
        return np.zeros(x.size, np.int64)
    return np.clip(((x - lo) / (hi - lo) * cells).astype(np.int64), 0, cells - 1)


def overlap(a1, b1, a2, b2, cells=OVERLAP_CELLS) -> float:
    """The lesser of the two shares of each cloud's points in cells the other visits (a
    grid of ``cells`` x ``cells`` over both clouds' range)."""
    lo_a, hi_a = min(a1.min(), a2.min()), max(a1.max(), a2.max())
    lo_b, hi_b = min(b1.min(), b2.min()), max(b1.max(), b2.max())
    c1 = _cell(a1, lo_a, hi_a, cells) * cells + _cell(b1, lo_b, hi_b, cells)
    c2 = _cell(a2, lo_a, hi_a, cells) * cells + _cell(b2, lo_b, hi_b, cells)
    in1 = np.isin(c1, c2).mean()
    in2 = np.isin(c2, c1).mean()
    return float(min(in1, in2))


def _series_observable(spec) -> str:
    """The observable that keeps the model's cycle series (``Model.cycle``)."""
    return "impacts" if spec.cycle.per == "impacts" else "section"


def _long_scene(scene, extra_transient=0, window=WINDOW):
    """The scene of the reruns: the same system and starts, a window of ``window``, the
    cycle series and the stability kept over it (not streamed: ``run.lyapunov_impacts``
    off), the budgets scaled with the run's length (within
    the limits a scene may give)."""
    spec = scene.spec
    keep = tuple(sorted({_series_observable(spec), "stability"}))
    old = scene.transient + scene.record
    grow = max(1.0, (scene.transient + extra_transient + window) / old)
    return dataclasses.replace(
        scene, transient=scene.transient + extra_transient, record=window, keep=keep,
        stop="none", max_events=min(int(scene.max_events * grow), BUDGET_MAX),
        max_periods=min(int(scene.max_periods * grow), PERIODS_MAX), lyapunov_impacts=0)


def rerun(scene, grid_index, starts, extra_transient=0, window=WINDOW):
    """The runs of ``scene`` at grid indices ``grid_index`` (n tuples) from ``starts`` (n,
    start size), over the long window: (a, b, lambda_1, ok, ended) per run (``ended``: the
    run ended well; ``ok``: and its exponent is finite)."""
    spec = scene.spec
    long = _long_scene(scene, extra_transient, window)
    ints = spec.int_settings(long)
    a_all, b_all, lam, ended = [], [], [], []
    for s in range(0, len(grid_index), GROUP):
        params = spec.pack_points(long, grid_index[s:s + GROUP])
        run = spec.run_items(params, np.ascontiguousarray(starts[s:s + GROUP]), ints, long)
        a_all.append(np.asarray(run.fields[spec.cycle.a], float))
        b_all.append(np.asarray(run.fields[spec.cycle.b], float))
        ly = np.asarray(run.fields["lyapunov"], float)[:, 0]
        lam.append(ly)
        ended.append(run.status == S.OK)
    lam, ended = np.concatenate(lam), np.concatenate(ended)
    return (np.concatenate(a_all), np.concatenate(b_all), lam, ended & np.isfinite(lam),
            ended)


def find(f, scene, runs, points):
    """The chaotic attractors among the runs ``runs`` (flat indices into the file's runs,
    each with NO_CYCLE, in the file's order) at parameter points ``points`` (the same
    length): (a list of Chaotic, ordered by point then smallest run; per run, the index in
    REASONS of why it is on none, or -1).

    At most RERUN_MAX runs of a point are rerun, points batched up to GROUP runs a kernel
    call, each point finished before the next batch (memory: one batch's windows).  The
    point's other runs join a chaotic attractor found there where their record in the file
    lies on its cloud (``overlap``); else they are said not examined."""
    spec = scene.spec
    why = np.full(runs.size, -1, np.int64)
    if spec.cycle is None or runs.size == 0 or "lyapunov" not in {
            fld.source for fld in spec.fields(("stability",))}:
        return [], why
    start_all = np.stack([f[f"initial/{c}"][...].reshape(-1) for c in spec.start_names], -1)
    order = np.argsort(points, kind="stable")
    bounds = np.flatnonzero(np.r_[True, points[order][1:] != points[order][:-1], True])
    found = []
    batch = []
    for lo, hi in zip(bounds[:-1], bounds[1:]):
        batch.append(order[lo:hi])
        if sum(min(b.size, RERUN_MAX) for b in batch) >= GROUP or hi == runs.size:
            for chaotic in _batch(scene, start_all, runs, points, batch, why):
                found += chaotic
            batch = []
    return found, why


def _batch(scene, start_all, runs, points, batch, why):
    """Rerun the first RERUN_MAX runs of each point of ``batch`` (arrays of indices into
    ``runs``, one point each) in one kernel call and find each point's chaotic attractors
    (``_point``): yields each point's Chaotic list."""
    G, n_ic = scene.shape, scene.n_ic
    picked = [b[:RERUN_MAX] for b in batch]
    flat = runs[np.concatenate(picked)]
    starts = start_all[flat]
    grid = [tuple(int(i) for i in ix) for ix in
            zip(*np.unravel_index(flat // n_ic, G))] if G else [()] * flat.size
    a, b, lam, ok, ended = rerun(scene, grid, starts)
    k = 0
    for mine, pick in zip(batch, picked):
        m = pick.size
        res = (a[k:k + m], b[k:k + m], lam[k:k + m], ok[k:k + m], ended[k:k + m])
        yield _point(scene, runs, int(points[mine[0]]), mine, pick, res, grid[k:k + m],
                     starts[k:k + m], why, start_all)
        k += m


def _point(scene, runs, point, mine, pick, res, grid, starts, why, start_all):
    """One parameter point's chaotic attractors from its rerun runs ``pick`` (indices into
    ``runs``; ``res`` their windows, exponents and ends), the reasons of the others in
    ``why``; its runs past RERUN_MAX are rerun too (``_join``) where an attractor is found."""
    a, b, lam, ok, ended = res
    why[pick] = 4
    why[pick[~ended]] = 0
    why[pick[ended & (lam == -np.inf)]] = 1
    why[pick[ended & np.isnan(lam)]] = 2
    good = np.flatnonzero(ok)
    rec = {i: recurrence(a[i], b[i]) for i in good}
    why[pick[[i for i in good if rec[i] < RECURRENCE_MIN]]] = 3
    good = [i for i in good if rec[i] >= RECURRENCE_MIN]
    out = []
    for group in _groups(good, a, b):
        est = lam[group]
        if len(group) < MIN_ESTIMATES:
            est = np.concatenate([est, _more_windows(scene, grid[group[0]], starts[group[0]],
                                                     MIN_ESTIMATES - len(group))])
        if est.size < 2 or not np.all(np.isfinite(est)):
            continue
        m, lo, hi = mean_interval(est)
        if lo > 0.0 and _persists(scene, grid[group[0]], starts[group[0]], m):
            fa = np.concatenate([a[i][np.isfinite(a[i])] for i in group])
            fb = np.concatenate([b[i][np.isfinite(b[i])] for i in group])
            why[pick[group]] = -1
            out.append(Chaotic(point, runs[pick[group]], fa, fb, m, lo, hi))
    rest = mine[RERUN_MAX:]
    why[rest] = 5
    if out and rest.size:
        out = _join(scene, runs, rest, out, why, start_all)
    return out


PERSIST = 0.6      # lambda over PERSIST_FACTOR windows at least this share of lambda over one
PERSIST_FACTOR = 4


def _persists(scene, grid_index, start, lam):
    """Whether a positive exponent ``lam`` (over windows of WINDOW) persists over a window
    PERSIST_FACTOR times longer: on a chaotic attractor it stays (to its scatter), while on a
    torus or along a neutral direction a finite-time exponent is a bias of order
    log(N) / N, which falls about PERSIST_FACTOR / log(PERSIST_FACTOR) times over the longer
    window (docs/stability.md: the maps' generic basis); kept where it keeps at least
    PERSIST of its value."""
    _, _, lam_long, ok, _ = rerun(scene, [grid_index], start[None],
                                  window=WINDOW * PERSIST_FACTOR)
    return bool(ok[0] and lam_long[0] >= PERSIST * lam)


JOIN_RECORD = 200    # impacts (or periods) of a rerun that joins a run to an attractor


def _join(scene, runs, rest, out, why, start_all):
    """The point's runs past RERUN_MAX (``rest``, indices into ``runs``), rerun without the
    stability pass over JOIN_RECORD after their transient, each joined to the one chaotic
    attractor of ``out`` whose cloud's cells (a grid of OVERLAP_CELLS over the cloud) hold
    the most of its points, at least OVERLAP_MIN of them (one-sided: a short window covers
    little of a cloud; ``start_all``: every run's start, as ``find`` read them).  Returns
    ``out`` with their runs added; ``why`` -1 for them."""
    spec = scene.spec
    G, n_ic = scene.shape, scene.n_ic
    long = dataclasses.replace(_long_scene(scene, window=JOIN_RECORD),
                               keep=(_series_observable(spec),))
    ints = spec.int_settings(long)
    cells = []
    for c in out:
        box = (c.a.min(), c.a.max(), c.b.min(), c.b.max())
        occ = np.zeros(OVERLAP_CELLS * OVERLAP_CELLS, bool)
        occ[_cell(c.a, box[0], box[1], OVERLAP_CELLS) * OVERLAP_CELLS
            + _cell(c.b, box[2], box[3], OVERLAP_CELLS)] = True
        cells.append((box, occ))
    joined = [[] for _ in out]
    for s in range(0, rest.size, GROUP):
        part = rest[s:s + GROUP]
        flat = runs[part]
        grid = [tuple(int(i) for i in ix) for ix in
                zip(*np.unravel_index(flat // n_ic, G))] if G else [()] * flat.size
        run = spec.run_items(spec.pack_points(long, grid),
                             np.ascontiguousarray(start_all[flat]), ints, long)
        ra = np.asarray(run.fields[spec.cycle.a], float)
        rb = np.asarray(run.fields[spec.cycle.b], float)
        fin = np.isfinite(ra) & np.isfinite(rb)
        n_fin = fin.sum(axis=1)
        share = np.zeros((len(out), part.size))
        for k, ((lo_a, hi_a, lo_b, hi_b), occ) in enumerate(cells):
            inside = fin & (ra >= lo_a) & (ra <= hi_a) & (rb >= lo_b) & (rb <= hi_b)
            code = (_cell(np.where(fin, ra, lo_a), lo_a, hi_a, OVERLAP_CELLS) * OVERLAP_CELLS
                    + _cell(np.where(fin, rb, lo_b), lo_b, hi_b, OVERLAP_CELLS))
            hits = (inside & occ[code]).sum(axis=1)
            share[k] = np.where(n_fin >= 8, hits / np.maximum(n_fin, 1), 0.0)
        best = np.argmax(share, axis=0)
        good = (share[best, np.arange(part.size)] >= OVERLAP_MIN) & (run.status == S.OK)
        for i in np.flatnonzero(good):
            joined[best[i]].append(part[i])
    for c, extra in zip(out, joined):
        if extra:
            why[extra] = -1
            c.runs = np.sort(np.concatenate([c.runs, runs[np.array(extra)]]))
    return out


def _groups(mine, a, b):
    """The runs ``mine`` grouped into attractors: unions of pairs whose clouds overlap."""
    parent = {i: i for i in mine}

    def root(i):
        while parent[i] != i:
            i = parent[i]
        return i
    clouds = {i: (a[i][np.isfinite(a[i])], b[i][np.isfinite(b[i])]) for i in mine}
    for x, i in enumerate(mine):
        for j in mine[x + 1:]:
            if root(i) != root(j) and overlap(*clouds[i], *clouds[j]) >= OVERLAP_MIN:
                parent[max(root(i), root(j))] = min(root(i), root(j))
    out = {}
    for i in mine:
        out.setdefault(root(i), []).append(i)
    return [np.array(v) for _, v in sorted(out.items())]


def _more_windows(scene, grid_index, start, k):
    """``k`` more estimates of one run's exponent, over the windows that follow its first
    (transient + j WINDOW, j = 1 .. k)."""
    out = []
    for j in range(1, k + 1):
        _, _, lam, ok, _ = rerun(scene, [grid_index], start[None], extra_transient=j * WINDOW)
        out.append(lam[0] if ok[0] else np.nan)
    return np.array(out)
