"""Chaotic attractors among the runs that reached no cycle (issue 32, docs/basins.md
"Chaotic attractors").

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

from . import registry
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
# why a run with no cycle is not on a chaotic attractor (``find``; the table's
# /attractors/no_cycle counts them per parameter point)
REASONS = ("its long rerun did not end well (escapes, sticks for good, budget)",
           "it sticks within the long window (exponent -inf: a long orbit through sticking)",
           "it grazes within the long window (exponent undefined)",
           "not recurrent within the long window (a transient)",
           "its exponent's interval is not above 0 (a longer cycle, a torus)",
           f"not examined (past the first {RERUN_MAX} runs without a cycle at its point, and "
           "its record in the file is on no chaotic attractor found there)")


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


def _long_scene(scene, extra_transient=0):
    """The scene of the reruns: the same system and starts, a window of WINDOW, the cycle
    series and the stability kept, the budgets scaled with the run's length."""
    spec = registry.get(scene.model)
    keep = tuple(sorted({spec.cycle.per == "impacts" and "impacts" or "section", "stability"}))
    old = scene.transient + scene.record
    new = scene.transient + extra_transient + WINDOW
    return dataclasses.replace(
        scene, transient=scene.transient + extra_transient, record=WINDOW, keep=keep,
        stop="none", max_events=int(scene.max_events * max(1.0, new / old)),
        max_periods=int(scene.max_periods * max(1.0, new / old)))


def rerun(scene, grid_index, starts, extra_transient=0):
    """The runs of ``scene`` at grid indices ``grid_index`` (n tuples) from ``starts`` (n,
    start size), over the long window: (a, b, lambda_1, ok, ended) per run (``ended``: the
    run ended well; ``ok``: and its exponent is finite)."""
    spec = registry.get(scene.model)
    long = _long_scene(scene, extra_transient)
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
    spec = registry.get(scene.model)
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
            for chaotic in _batch(scene, f, start_all, runs, points, batch, why):
                found += chaotic
            batch = []
    return found, why


def _batch(scene, f, start_all, runs, points, batch, why):
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
                     starts[k:k + m], why, f)
        k += m


def _point(scene, runs, point, mine, pick, res, grid, starts, why, f):
    """One parameter point's chaotic attractors from its rerun runs ``pick`` (indices into
    ``runs``; ``res`` their windows, exponents and ends), the reasons of the others in
    ``why``; its runs past RERUN_MAX join an attractor whose cloud holds their record."""
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
        if lo > 0.0:
            fa = np.concatenate([a[i][np.isfinite(a[i])] for i in group])
            fb = np.concatenate([b[i][np.isfinite(b[i])] for i in group])
            members = list(pick[group])
            rest = mine[RERUN_MAX:]
            if rest.size:
                members += list(_on_cloud(f, scene, runs, rest, fa, fb))
            why[members] = -1
            out.append(Chaotic(point, runs[np.sort(members)], fa, fb, m, lo, hi))
    rest = mine[RERUN_MAX:]
    why[rest[why[rest] == -1]] = 5
    if out:
        joined = np.concatenate([c.runs for c in out])
        why[rest[np.isin(runs[rest], joined)]] = -1
    return out


def _on_cloud(f, scene, runs, rest, fa, fb):
    """The runs among ``rest`` (indices into ``runs``) whose record in the file holds at
    least OVERLAP_MIN of its points in the cells of the cloud (fa, fb): those on it (none
    where the file does not keep the model's cycle series)."""
    spec = registry.get(scene.model)
    names = {fld.source: fld.name for fld in spec.fields(tuple(spec.observables))}
    if names.get(spec.cycle.a) not in f or names.get(spec.cycle.b) not in f:
        return np.empty(0, np.int64)
    da, db = f[names[spec.cycle.a]], f[names[spec.cycle.b]]
    out = []
    for i in rest:
        ix = np.unravel_index(runs[i], da.shape[:-1])
        ra, rb = da[ix], db[ix]
        keep = np.isfinite(ra) & np.isfinite(rb)
        if keep.sum() >= 8 and overlap(ra[keep], rb[keep], fa, fb) >= OVERLAP_MIN:
            out.append(i)
    return np.array(out, np.int64)


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
