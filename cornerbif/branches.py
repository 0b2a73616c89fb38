"""Branches of attractors across a sweep, and the events where they begin and end
(docs/basins.md "Branches across the sweep").

The attractor table (``cornerbif.attractors``) names the attractors of each parameter point
on its own.  Here they are linked across the grid: each attractor's orbit is solved from its
first run's record (the model's ``orbit_seed``: the periodic-orbit problem of its itinerary,
``cornerbif.continuation``), checked against the table's signature of it, and solved again
by Newton's method at each neighbouring grid value along every parameter axis.  Where that
orbit is an attractor of the neighbour's table (the same word, and its signature within the
table's match tolerance) the two are one branch.  A branch is a connected set of linked
attractors; ids are ordered by the table's smallest id in each, so they depend only on the
table (itself the same on any thread count, block size, backend or resume).

For a one-parameter sweep, every end of a branch inside the range is located by continuation
from its last attractor towards the neighbouring grid value (for a sweep of several parameters,
every edge: each attractor not linked to the next grid value along an axis, its end located
along that grid line with the other axes held, ``_edges``) (``continuation.follow_step``,
events to the secant method's 1e-14 in arclength) and named (``KINDS``):

* the first stability event on the way (fold, period doubling, torus): the attractor loses
  stability there (for a period doubling, the doubled branch at the neighbour is named);
* else the event that ends the itinerary: a corner collision (the orbit of the other side's
  itinerary is named, with its branch where the neighbour has it, or it is said that there
  is none), a grazing, an impact at zero relative velocity (a loss of admissibility);
* else: the orbit reaches the neighbour still stable (it is there, but no start reached it:
  "unsampled"), or the continuation fails (said, with "no periodic orbit on the far side"
  where no start at the neighbour reached any cycle).

Written to the file (``write``, on a copy renamed over it)::

    /attractors/branch           (n,) int32: each attractor's branch
    /branches/id, word, period, impacts_per_cycle, attractors   (m,)
    /branches/min_<axis>, max_<axis>   (m,) the grid values it spans on each parameter axis
    /branches/max_abs_multiplier (m,) the largest |Floquet multiplier| of its orbits at the
                                 grid values (NaN where none was solved)
    /branches/{low,high}_kind, _at, _detail, _point   its ends (one-parameter sweeps):
                                 the event's kind (KINDS), the located parameter value, a
                                 sentence, and (a, b) of the orbit there (b largest)
    /branch_edges/branch, attractor, parameter_point, axis, step, kind, at, detail, point
                                 a sweep of several parameters: per edge (an attractor not
                                 linked to the next grid value along axis ``axis`` (index
                                 into /branches' axes) going ``step`` (+1: up)) its end on
                                 that grid line, as the columns of the ends above
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field

import numpy as np

from . import config
from .attractors import BRANCH_END_KINDS as KINDS
from .attractors import read_branches, read_table
from .basin_stats import basin_entropy, share_interval, uncertainty_exponent
from .chaos import CHAOTIC
from .continuation import OrbitError, follow_step, newton, rebase
from .cycles import series_point, series_signature
from .errors import SweepError, WriteFailed
from .outputs import output_lock

STABILITY_EVENTS = ("fold", "period_doubling", "torus")
# /branches' version: a table stored by an older cornerbif (1: without /branch_edges for
# several parameters, map2d's cycles linked by impacts per cycle) is located again
TABLE_VERSION = 2
ENDING_EVENTS = {"corner": "corner", "grazing": "grazing", "zero_velocity": "admissibility"}


@dataclass
class Node:
    """One attractor of the table: its grid position over the parameter axes, and its orbit
    (problem, unknowns at the point's value of ``problem.param``) where one was solved."""
    row: int
    at: tuple
    values: dict
    word: str
    entries: int = 0        # entries per cycle of its series (the model's CycleSeries.per:
    #                         impacts per cycle, or the period)
    problem: object = None
    X: np.ndarray = None
    why: str = ""


@dataclass
class End:
    kind: str
    at: float
    detail: str
    point: tuple = (math.nan, math.nan)


@dataclass
class Branches:
    """The branch table: per attractor its branch, per branch its rows and ends."""
    axes: list                       # the parameter axes' names
    branch_of: np.ndarray            # (n attractors,) int32
    rows: list                       # per branch: its attractor rows, in table order
    low: list = field(default_factory=list)     # per branch: End (one-parameter sweeps)
    high: list = field(default_factory=list)
    max_mu: np.ndarray = None
    edges: list = field(default_factory=list)   # sweeps of several parameters: Edge per
    #                                             boundary crossing of a grid line


@dataclass
class Edge:
    """Where a branch of a sweep of several parameters leaves a grid line: the attractor
    ``row`` at its grid value, the axis and direction (+1 towards larger values) along
    which its orbit was not found at the next grid value, and the End located on that line
    (the other axes fixed at the attractor's values)."""
    branch: int
    row: int
    axis: int
    step: int
    end: End


def _matches(sig, ref, tol) -> bool:
    return bool(np.all(np.abs(sig - ref) <= tol * (1.0 + np.abs(ref))))


class _Links:
    """Union-find over the table's rows."""

    def __init__(self, n):
        self.parent = np.arange(n)

    def find(self, i):
        while self.parent[i] != i:
            self.parent[i] = self.parent[self.parent[i]]
            i = self.parent[i]
        return i

    def join(self, i, j):
        a, b = self.find(i), self.find(j)
        if a != b:
            self.parent[max(a, b)] = min(a, b)


def _parameter_axes(scene):
    starts = {pos for pos, _ in scene.start_axes.values()}
    return [a for i, a in enumerate(scene.axes) if i not in starts]


def _run_record(f, scene, index):
    """The record of one run (``index``: its full grid index and start) as the model's
    ``orbit_seed`` reads it, or None where the file does not keep it."""
    spec = scene.spec
    run = {"ipc": int(f["impacts_per_cycle"][index])}
    for fld in spec.fields(tuple(spec.observables)):
        if fld.name in f and fld.axis is None:
            run[fld.source] = f[fld.name][index]
    need = spec.seed_observable
    if need and not all(fld.source in run for fld in spec.observables[need]):
        return None
    return run


def nodes(f, scene, tab):
    """A Node per attractor of the table, its orbit solved from its first run where it can
    be and checked against the table's signature."""
    par = _parameter_axes(scene)
    shape = tuple(a.array.size for a in par)
    sub = np.unravel_index(tab["parameter_point"], shape) if par else ()
    ids = tab["ids"]
    uniq, first = np.unique(ids.ravel(), return_index=True)
    rep = {int(a): np.unravel_index(i, ids.shape) for a, i in zip(uniq, first) if a >= 0}
    base = {k: v for k, v in scene.system.items() if v is not None}
    param = par[0].name if par else ""
    tol = tab["match_tolerance"]
    per_column = ("impacts_per_cycle" if scene.spec.cycle.per == "impacts" else "period")
    out = []
    for row in range(len(tab["id"])):
        at = tuple(int(s[row]) for s in sub)
        values = base | {a.name: float(a.array[i]) for a, i in zip(par, at)}
        node = Node(row, at, values, str(tab["word"][row]),
                    int(tab[per_column][row]))
        out.append(node)
        if node.word == CHAOTIC:
            node.why = "a chaotic attractor (no periodic orbit to solve)"
            continue
        run = _run_record(f, scene, rep[row])
        if run is None:
            node.why = f"the file does not keep {scene.spec.seed_observable!r}"
            continue
        lam = values[param]
        try:
            prob, X = scene.spec.orbit_seed(values, scene, param, node.word, run)
            X = newton(prob, X, lam)
            sig = series_signature(*prob.cycle_series(X, lam))
        except (OrbitError, NotImplementedError, np.linalg.LinAlgError, ArithmeticError,
                ValueError) as e:
            node.why = f"its orbit could not be solved from its run ({e})"
            continue
        if not _matches(sig, tab["signature"][row], tol):
            node.why = "the orbit solved from its run is not the table's cycle"
            continue
        node.problem, node.X = prob, X
    return out


def _along(node, axis):
    """The node's problem continued in ``axis`` (rebased at its point's values)."""
    if node.problem.param == axis:
        return node.problem
    return rebase(node.problem, dict(node.values), axis)


def solve_at(prob, X, value):
    """The orbit (``prob``, from the unknowns ``X``) solved by Newton at ``value`` of its
    parameter: X there, or None where Newton fails or the orbit is not admissible."""
    try:
        Xn = newton(prob, X, value)
        ok, _ = prob.admissible(Xn, value)
    except (OrbitError, np.linalg.LinAlgError, ArithmeticError, ValueError):
        return None
    return Xn if ok else None


def _stable(prob, X, value) -> bool:
    try:
        mu, _ = prob.floquet(X, value)
    except (ArithmeticError, ValueError, np.linalg.LinAlgError):
        return False
    return bool(np.all(np.abs(mu) < 1.0))


def _match(prob, X, value, candidates, tab):
    """The row among ``candidates`` (nodes at the neighbour) whose cycle is this orbit: the
    same number of entries per cycle in its series (``Node.entries``) and the same
    signature within the table's match tolerance (the table's words and an orbit problem's
    itinerary are in different alphabets for some models: two_particle's problem spells
    its events, U and W)."""
    try:
        a, b = prob.cycle_series(X, value)
        sig = series_signature(a, b)
    except (ArithmeticError, ValueError, np.linalg.LinAlgError):
        return None
    hits = [c.row for c in candidates if c.word != CHAOTIC and len(a) == c.entries
            and _matches(sig, tab["signature"][c.row], tab["match_tolerance"])]
    return hits[0] if len(hits) == 1 else None


class _Order:
    """An axis's grid indices in the order of its values (``link`` and ``_ends`` walk it)."""

    def __init__(self, axis):
        self.order = np.argsort(axis.array, kind="stable")
        self.pos = np.empty_like(self.order)
        self.pos[self.order] = np.arange(self.order.size)

    def next(self, i, step):
        """The grid index next to ``i`` (``step``: +1 the next larger value, -1 the next
        smaller), or None at the end."""
        p = int(self.pos[i]) + step
        return int(self.order[p]) if 0 <= p < self.order.size else None


def link(ns, par, tab):
    """Union the rows whose orbits continue into each other along every parameter axis,
    both ways: from each attractor, its orbit solved by Newton at the next grid value, and
    on while it is stable there but no start reached it (an unsampled grid point), until it
    is an attractor of the table (linked), unstable, or lost.  Returns the _Links."""
    at = {}
    for n in ns:
        at.setdefault(n.at, []).append(n)
    links = _Links(len(ns))
    linked = set()          # (row, axis, step): linked to an attractor that way
    orders = [_Order(a) for a in par]
    _link_chaotic(ns, at, orders, tab, links, linked)
    for k, axis in enumerate(par):
        for step in (1, -1):
            for n in ns:
                if n.problem is None or (n.row, k, step) in linked:
                    continue
                prob, X, i = _along(n, axis.name), n.X, n.at[k]
                while orders[k].next(i, step) is not None:
                    i = orders[k].next(i, step)
                    nb = n.at[:k] + (i,) + n.at[k + 1:]
                    value = float(axis.array[i])
                    X = solve_at(prob, X, value)
                    if X is None:
                        break
                    m = _match(prob, X, value, at.get(nb, []), tab)
                    if m is not None:
                        links.join(n.row, m)
                        linked.add((n.row, k, step))
                        linked.add((m, k, -step))
                        break
                    if not _stable(prob, X, value):
                        break
    return links, linked


def _box(tab, row):
    sig = tab["signature"][row]
    return sig[2], sig[3], sig[4], sig[5]          # min a, max a, min b, max b


def _box_overlap(p, q) -> float:
    """Intersection over union of two boxes (min a, max a, min b, max b)."""
    w = min(p[1], q[1]) - max(p[0], q[0])
    h = min(p[3], q[3]) - max(p[2], q[2])
    if w <= 0 or h <= 0:
        return 0.0
    inter = w * h
    union = (p[1] - p[0]) * (p[3] - p[2]) + (q[1] - q[0]) * (q[3] - q[2]) - inter
    return inter / union if union > 0 else 0.0


CHAOS_LINK = 0.5     # chaotic attractors at neighbouring grid values whose boxes overlap more


def _link_chaotic(ns, at, orders, tab, links, linked):
    """Chaotic attractors have no orbit to follow: those at neighbouring grid values whose
    boxes (the ranges of their cycle series, the table's signature) overlap by more than
    CHAOS_LINK (intersection over union) are one branch."""
    for k, order in enumerate(orders):
        for n in ns:
            j = order.next(n.at[k], 1)
            if n.word != CHAOTIC or j is None:
                continue
            nb = n.at[:k] + (j,) + n.at[k + 1:]
            best = [(m.row, _box_overlap(_box(tab, n.row), _box(tab, m.row)))
                    for m in at.get(nb, []) if m.word == CHAOTIC]
            best = [(r, v) for r, v in best if v > CHAOS_LINK]
            if best:
                m = max(best, key=lambda rv: rv[1])[0]
                links.join(n.row, m)
                linked.add((n.row, k, 1))
                linked.add((m, k, -1))


def build(f, scene, log=None, tab=None) -> Branches | None:
    """The branches of the finished sweep file ``f`` (open; ``tab`` its attractor table,
    read here when not given): None where it has no attractor table or no parameter axis."""
    tab = read_table(f) if tab is None else tab
    par = _parameter_axes(scene)
    if tab is None or not par:
        return None
    ns = nodes(f, scene, tab)
    if log:
        solved = sum(n.problem is not None for n in ns)
        log(f"{solved} of {len(ns)} attractors' orbits solved; linking them across the grid")
    links, linked = link(ns, par, tab)
    roots = np.array([links.find(i) for i in range(len(ns))], np.int64)
    order = {r: b for b, r in enumerate(sorted(set(roots.tolist())))}
    branch_of = np.array([order[r] for r in roots], np.int32)
    rows = [[] for _ in order]
    for i, b in enumerate(branch_of):
        rows[b].append(i)
    br = Branches([a.name for a in par], branch_of, rows)
    br.max_mu = np.array([_max_mu(ns, r) for r in rows])
    if len(par) == 1:
        _ends(br, ns, par[0], tab, log)
    else:
        br.low = br.high = [End("", math.nan, KINDS[""]) for _ in rows]
        br.edges = _edges(br, ns, par, tab, linked, log)
    return br


def _max_mu(ns, rows):
    vals = []
    for r in rows:
        n = ns[r]
        if n.problem is None:
            continue
        try:
            mu, _ = n.problem.floquet(n.X, n.values[n.problem.param])
        except (ArithmeticError, ValueError, np.linalg.LinAlgError):
            continue
        vals.append(np.abs(mu).max())
    return float(max(vals)) if vals else math.nan


def _ends(br, ns, axis, tab, log):
    """Locate and name both ends of every branch of a one-parameter sweep."""
    x = axis.array
    grid = _lines(ns, tab, 0, [axis]).get((), _Grid(x, {}, tab["outcomes"][:, 0] == 0))
    order = _Order(axis)
    for b, rows in enumerate(br.rows):
        idx = [ns[r].at[0] for r in rows]
        for side, pick in (("low", int(np.argmin([x[i] for i in idx]))),
                           ("high", int(np.argmax([x[i] for i in idx])))):
            n = ns[rows[pick]]
            step = 1 if side == "high" else -1
            getattr(br, side).append(_end_of(n, 0, axis, step, order, grid, tab, br))
        if log and b % 50 == 49:
            log(f"ends of {b + 1} of {len(br.rows)} branches located")


def _lines(ns, tab, k, par):
    """The _Grid of every grid line along axis ``k`` of the parameter axes ``par``, keyed by
    the grid indices of the other axes (one pass over the attractors)."""
    shape = tuple(a.array.size for a in par)
    no_cycle = np.moveaxis((tab["outcomes"][:, 0] == 0).reshape(shape), k, -1)
    lines = {}
    for n in ns:
        key = n.at[:k] + n.at[k + 1:]
        if key not in lines:
            lines[key] = _Grid(par[k].array, {}, no_cycle[key])
        lines[key].by_point.setdefault(n.at[k], []).append(n)
    return lines


def _end_of(n, k, axis, step, order, grid, tab, br):
    """Where the branch of node ``n`` ends going ``step`` along axis ``k`` (``grid`` the
    grid line through it): the range's end, a chaotic attractor's (not located), or the
    event ``locate`` finds."""
    x = axis.array
    i = n.at[k]
    j = order.next(i, step)
    if j is None:
        return End("range", float(x[i]), f"the range's end at {axis.name} = {float(x[i])!r}",
                   _point_of(n))
    if n.word == CHAOTIC:
        nxt = grid.by_point.get(j, [])
        beyond = ("its box overlaps none of the next grid value's chaotic "
                  "attractors by more than half" if any(m.word == CHAOTIC for m in nxt)
                  else "the next grid value's attractors are cycles: a periodic "
                  "window or a crisis" if nxt else "the next grid value has no "
                  "attractor: no cycle within the record, and no chaos")
        return End("unlocated", math.nan,
                   f"a chaotic attractor, gone at {axis.name} = {float(x[j])!r} "
                   f"({beyond}); not located between grid values")
    if n.problem is None:
        return End("unlocated", math.nan, f"not located: {n.why}")
    return locate(n, axis.name, float(x.max() if step > 0 else x.min()), float(x[j]), grid,
                  tab, br)


def _edges(br, ns, par, tab, linked, log):
    """Every boundary crossing of the branches of a sweep of several parameters: for each
    attractor and each axis and direction in which it was not linked to the next grid
    value's attractors (``link``), the End located along that grid line, the other axes
    held at the attractor's values (``_end_of``, as a one-parameter sweep's ends).  The
    range's ends are not edges."""
    orders = [_Order(a) for a in par]
    lines = [_lines(ns, tab, k, par) for k in range(len(par))]
    todo = [(n, k, step) for n in ns for k in range(len(par)) for step in (-1, 1)
            if (n.row, k, step) not in linked and orders[k].next(n.at[k], step) is not None]
    out = []
    for c, (n, k, step) in enumerate(todo):
        end = _end_of(n, k, par[k], step, orders[k], lines[k][n.at[:k] + n.at[k + 1:]], tab, br)
        out.append(Edge(int(br.branch_of[n.row]), n.row, k, step, end))
        if log and c % 200 == 199:
            log(f"{c + 1} of {len(todo)} branch edges located")
    return out


@dataclass
class _Grid:
    """A grid line's values (a one-parameter sweep's axis, or one axis of several with the
    others held), its attractors by grid index along it, and where no start reached any
    cycle."""
    x: np.ndarray
    by_point: dict
    no_cycle: np.ndarray

    def beyond(self, lam, direction):
        """The index of the first grid value past ``lam`` going ``direction``."""
        past = np.flatnonzero((self.x - lam) * direction > 0)
        if past.size == 0:
            return None
        return int(past[np.argmin(np.abs(self.x[past] - lam))])


def _point_of(n):
    if n.problem is None:
        return (math.nan, math.nan)
    lam = n.values[n.problem.param]
    return series_point(*n.problem.cycle_series(n.X, lam))


def _event_point(e):
    try:
        prob, X = e.problem, e.X
        if hasattr(prob, "orbit"):
            prob, X = prob.orbit(X, e.lam)
        return series_point(*prob.cycle_series(X, e.lam))
    except (ArithmeticError, ValueError, AttributeError, np.linalg.LinAlgError):
        return (math.nan, math.nan)


def locate(n, axis, value, next_value, grid, tab, br):
    """Where and why the branch of node ``n`` ends on the way from its value to ``value``
    (the range's end that way; ``next_value`` the next grid value): continuation from its
    orbit; the first stability event, else the event that ends its itinerary (module doc).
    The attractors of the first grid value past the event name its other side."""
    prob = _along(n, axis)
    lam = n.values[axis]
    rng = (min(lam, value), max(lam, value))
    direction = 1.0 if value > lam else -1.0
    spacing = abs(next_value - lam)
    b, more = follow_step(prob, n.X, lam, None, "start", rng, direction, switch=True,
                          ds=spacing / 8, ds_min=spacing * 1e-9, ds_max=spacing * 4)
    evs = b.events
    stab = [e for e in evs if e.kind in STABILITY_EVENTS]
    last = evs[-1] if evs else None
    e = stab[0] if stab else last
    j = grid.beyond(e.lam, direction) if e is not None else None
    far = grid.by_point.get(j, []) if j is not None else []
    far_note = ("; no start at the next grid value reached a cycle (chaos, or a cascade "
                "finer than the grid)" if j is not None and grid.no_cycle[j] else "")
    if e is not None and (e.lam - next_value) * direction > 0:
        far_note += (f"; from {axis} = {next_value!r} to the event its orbit is still there "
                     "though no start reached it")
    if stab:
        detail = f"{KINDS[e.kind]} at {axis} = {float(e.lam)!r}"
        if e.kind == "period_doubling":
            doubled = [c for c in far if tab["period"][c.row] == 2 * tab["period"][n.row]]
            detail += (f": the doubled orbit is the next grid value's {doubled[0].word!r}, "
                       f"branch {br.branch_of[doubled[0].row]}" if doubled else
                       ": no doubled orbit among the next grid value's attractors")
        return End(e.kind, float(e.lam), detail + far_note, _event_point(e))
    if last is not None and last.kind in ENDING_EVENTS:
        kind = ENDING_EVENTS[last.kind]
        detail = f"{KINDS[kind]} at {axis} = {float(last.lam)!r}"
        if kind == "corner":
            nxt = grid.x[j] if j is not None else None
            detail += _other_side(more, last, far, br, tab, nxt)
        elif last.detail:
            detail += f" ({last.detail})"
        return End(kind, float(last.lam), detail + far_note, _event_point(last))
    if last is not None and last.kind == "end" and "end of the range" in last.detail:
        pt = b.points[-1]
        return End("unsampled", math.nan,
                   f"its orbit goes on to the range's end ({axis} = {value!r}, |multipliers| "
                   f"<= {np.abs(pt.mu).max():.3g} there) with no event, but no start beyond "
                   "the branch's last grid value reached it")
    why = last.detail if last is not None else "no event"
    if "stops being one of the flow" in why:
        return End("admissibility", float(last.lam), f"{KINDS['admissibility']} ({why})"
                   + far_note, _event_point(last))
    kind = "no_orbit" if far_note else "unlocated"
    return End(kind, math.nan, f"the continuation stopped ({why}){far_note}")


def _other_side(more, last, far, br, tab, next_value):
    """What a corner collision's other side is: the orbit of the other side's itinerary
    (``follow_step``'s switch) and, where it is an attractor of the next grid value (solved
    there by Newton and matched as ``link`` matches), that attractor's branch; or that
    there is none, and why."""
    if not more:
        why = last.detail.split("; ", 1)[1] if "; " in last.detail else "none was found"
        return f": the orbit is lost, with no orbit on the other side ({why})"
    prob, X, lam, _, origin = more[0]
    try:
        word = prob.word(X, lam)
    except (ArithmeticError, ValueError):
        return f": {origin}"
    kind = "turns back (a nonsmooth fold)" if "turns back" in origin else (
        "jumps to another orbit" if "jump" in origin else "persists")
    text = f": the orbit {kind} as {word!r}"
    Xn = solve_at(prob, X, float(next_value)) if next_value is not None else None
    m = _match(prob, Xn, float(next_value), far, tab) if Xn is not None else None
    if m is not None:
        text += f", an attractor of the next grid value on branch {br.branch_of[m]}"
    else:
        text += ", which is no attractor at the next grid value"
    return text


# ------------------------------------------------------------------ the file
def _columns(br, tab) -> dict:
    """The datasets of /branches (module doc), by name."""
    m = len(br.rows)
    first = [rows[0] for rows in br.rows]
    out = {"id": np.arange(m, dtype=np.int32),
           "word": np.array([str(tab["word"][r]).encode() for r in first], dtype=object)}
    for col in ("period", "impacts_per_cycle"):
        out[col] = np.array([tab[col][r] for r in first], np.int32)
    out["attractors"] = np.array([len(r) for r in br.rows], np.int32)
    for name in br.axes:
        v = tab[f"at_{name}"]
        out[f"min_{name}"] = np.array([v[r].min() for r in br.rows])
        out[f"max_{name}"] = np.array([v[r].max() for r in br.rows])
    out["max_abs_multiplier"] = br.max_mu
    for side in ("low", "high"):
        ends = getattr(br, side)
        out[f"{side}_kind"] = np.array([e.kind.encode() for e in ends], dtype=object)
        out[f"{side}_at"] = np.array([e.at for e in ends], float)
        out[f"{side}_detail"] = np.array([e.detail.encode() for e in ends], dtype=object)
        out[f"{side}_point"] = np.array([e.point for e in ends], float).reshape(m, 2)
    return out


def _edge_columns(br, tab) -> dict:
    """The datasets of /branch_edges (module doc), by name (empty for one-parameter
    sweeps)."""
    es = br.edges
    return {"branch": np.array([e.branch for e in es], np.int32),
            "attractor": np.array([e.row for e in es], np.int32),
            "parameter_point": np.array([tab["parameter_point"][e.row] for e in es], np.int64),
            "axis": np.array([e.axis for e in es], np.int8),
            "step": np.array([e.step for e in es], np.int8),
            "kind": np.array([e.end.kind.encode() for e in es], dtype=object),
            "at": np.array([e.end.at for e in es], float),
            "detail": np.array([e.end.detail.encode() for e in es], dtype=object),
            "point": np.array([e.end.point for e in es], float).reshape(len(es), 2)}


def store(path, scene, br, tab) -> str:
    """Store the branch table in the finished sweep file ``path``: on a copy (with the
    file's permissions) renamed over it (``io._amend``: an interrupt, a full disk or a
    file-size limit leaves the file as it was), under its lock.  A link is followed to its
    file.  Returns "" when stored, else why not (a file or folder that cannot be written,
    a file with other hard links, which a rename would part from it)."""
    import h5py  # start-up: loads h5py

    from . import io  # start-up: loads h5py
    real = os.path.realpath(path)
    st = os.stat(real)
    if not st.st_mode & 0o200 or not os.access(real, os.W_OK):
        return "the file is read-only"     # its mode says so even to a superuser
    if not os.access(os.path.dirname(real) or ".", os.W_OK):
        return "its folder cannot be written"
    if st.st_nlink > 1:
        return "the file has other hard links, which replacing it would part from it"
    cols = _columns(br, tab)
    edges = _edge_columns(br, tab) if len(br.axes) > 1 else None     # (none: still stored)

    def change(g):
        a = g["attractors"]
        if "branch" in a:
            del a["branch"]
        a.create_dataset("branch", data=br.branch_of)
        if "branches" in g:
            del g["branches"]
        out = g.create_group("branches")
        for name, v in cols.items():
            if v.dtype.kind == "O":
                out.create_dataset(name, data=v, dtype=h5py.string_dtype())
            else:
                out.create_dataset(name, data=v)
        out.attrs["axes"] = ",".join(br.axes)
        out.attrs["version"] = TABLE_VERSION
        if "branch_edges" in g:
            del g["branch_edges"]
        if edges is not None:
            e = g.create_group("branch_edges")
            for name, v in edges.items():
                e.create_dataset(name, data=v, dtype=h5py.string_dtype() if v.dtype.kind == "O"
                                 else None)
    with output_lock(real, "cornerbif explain"):
        try:
            io.ensure_room(real + ".amend", st.st_size, what="the file's copy",
                           then="the file is unchanged")
            io._amend(real, real, change, after=lambda: os.chmod(real, st.st_mode & 0o7777))
        except WriteFailed as e:
            if e.broken:          # HDF5's state is unusable: the command ends at once
                raise WriteFailed(f"{path}: storing the branch table failed inside HDF5; the "
                                  "file is unchanged", broken=True) from None
            return ("writing its copy failed (a full disk or a file-size limit); the file is "
                    "unchanged")
    return ""


# ------------------------------------------------------------------ explain
def explain_file(path, recompute=False, log=None) -> list:
    """``cornerbif explain``: the branches of the finished sweep ``path`` as lines of text
    (``genealogy``), located the first time (or with ``recompute``) and stored in the file
    where it can be written (``store``; otherwise the lines end with why not).  Refused
    (``SweepError``, exit 2) before any work: a file that is not a finished sweep, one
    without attractors or parameter axes, one that does not keep what the model's orbit
    seed reads, an axis with repeated values."""
    from .io import check_readable  # start-up: loads h5py
    with check_readable(path) as f:
        scene = _explainable(f, path)
        if not _parameter_axes(scene):
            return basin_lines(f, scene, read_table(f))
        if has_current_table(f) and not recompute:
            return genealogy(read_branches(f), read_table(f), scene)
        tab = read_table(f)
        br = build(f, scene, log, tab)
    lines = genealogy(_as_read(br, tab), tab, scene)
    why = store(path, scene, br, tab)
    return lines + ([f"(the branch table is not stored in {path}: {why})"] if why else [])


def has_current_table(f) -> bool:
    """Whether the open file ``f`` holds a branch table this cornerbif stored (its version
    TABLE_VERSION): ``explain`` reads it back instead of locating again."""
    return ("branches" in f and "attractors/branch" in f
            and f["branches"].attrs.get("version", 1) == TABLE_VERSION)


def _explainable(f, path):
    """The scene of the open file ``f`` if ``explain`` can follow its attractors; else
    ``SweepError`` saying why."""
    if not f.attrs.get("completed"):
        raise SweepError(f"{path}: the sweep is not finished; complete it first "
                         "(cornerbif sweep --resume)")
    scene = config.loads(str(f.attrs["scene"]))
    if "attractors" not in f or not len(f["attractors/id"]):
        raise SweepError(f"{path}: the file has no attractor to follow (its attractor "
                         "table is empty or missing)")
    par = _parameter_axes(scene)
    if not par and len(scene.start_axes) != 2:
        raise SweepError(f"{path}: the sweep has no parameter axis to follow attractors along "
                         "(and is no basin of two swept start coordinates)")
    for a in par:
        if np.unique(a.array).size != a.array.size:
            raise SweepError(f"{path}: sweep.{a.name} repeats a value; attractors are followed "
                             "between distinct values")
    need = scene.spec.seed_observable
    words = f["attractors/word"][...].astype(str)
    if par and need and any(w != CHAOTIC for w in words) and not all(
            fld.name in f for fld in scene.spec.observables[need]):
        raise SweepError(f"{path}: the file does not keep {need!r}, from which a "
                         f"{scene.model} orbit is solved (sweep it with output.keep "
                         f"containing {need!r})")
    return scene


def _as_read(br, tab):
    """The branch table as ``attractors.read_branches`` gives it, from ``build``'s result
    (``explain`` prints the same whether it stored the table or not)."""
    out = _columns(br, tab)
    for k, v in out.items():
        if isinstance(v, np.ndarray) and v.dtype.kind in "SO":
            out[k] = np.array([x.decode() if isinstance(x, bytes) else str(x) for x in v],
                              dtype=object)
    out["axes"] = list(br.axes)
    out["branch"] = br.branch_of
    if br.edges:
        out["edges"] = {k: (np.array([x.decode() for x in v], dtype=object)
                            if v.dtype.kind == "O" else v)
                        for k, v in _edge_columns(br, tab).items()}
    return out


BASIN_BOX = 5        # cells per side of a box of the basin entropy


def basin_lines(f, scene, tab) -> list:
    """``explain`` of a basin (two swept start coordinates, no parameter axis): each
    attractor's share of the cells (a quadrature of its basin's area, with its cells on a
    boundary as the bound of its error), the basin entropy and boundary basin entropy
    (Daza et al. 2016) over boxes of BASIN_BOX x BASIN_BOX cells and the uncertainty
    exponent (Grebogi et al. 1983), from the cells' outcomes (each attractor, and each code,
    its own label; the first start of a cell)."""
    (nu, _), (nv, _) = sorted(scene.start_axes.items(), key=lambda kv: kv[1][0])
    labels = f["attractor"][...][..., 0]          # the grid's axes: the two, in order
    n = labels.size
    out = [f"{scene.name}: a basin of {labels.shape[0]} x {labels.shape[1]} starts "
           f"(initial.{nu}, initial.{nv}), {len(tab['id'])} attractors"]
    # a grid's share is a quadrature of the basin's area: its error at this resolution is
    # bounded by the share of its cells on a boundary (a neighbour along an axis differs)
    edge = np.zeros(labels.shape, bool)
    for ax in range(labels.ndim):
        d = np.diff(labels, axis=ax) != 0
        lo = [slice(None)] * labels.ndim
        hi = [slice(None)] * labels.ndim
        lo[ax], hi[ax] = slice(None, -1), slice(1, None)
        edge[tuple(lo)] |= d
        edge[tuple(hi)] |= d
    for r in range(len(tab["id"])):
        mine = labels == tab["id"][r]
        k = int(mine.sum())
        name = ("chaotic attractor" if tab["word"][r] == CHAOTIC else
                f"{tab['word'][r]!r} (period {tab['period'][r]})")
        out.append(f"  attractor {tab['id'][r]}: {name}: {k} cells, share {k / n:.4g} (a grid "
                   f"quadrature: {int((mine & edge).sum())} of its cells lie on a boundary, "
                   f"{(mine & edge).sum() / n:.3g} of the grid, the bound of its error at this "
                   "resolution)")
    none = int(np.sum(labels < 0))
    if none:
        out.append(f"  no attractor (codes): {none} cells, share {none / n:.4g}")
    if min(labels.shape) < BASIN_BOX:
        out.append(f"basin entropy: not computed (boxes of {BASIN_BOX} x {BASIN_BOX} cells do "
                   f"not fit in {labels.shape[0]} x {labels.shape[1]})")
    else:
        sb, sbb, nb = basin_entropy(labels, box=BASIN_BOX)
        out.append(f"basin entropy Sb = {sb:.4g}, boundary basin entropy Sbb = {sbb:.4g} over "
                   f"{nb} boundary boxes of {BASIN_BOX} x {BASIN_BOX} cells (Daza et al. 2016: "
                   f"Sbb > log 2 = {math.log(2):.4g} is enough for a fractal boundary)")
    alpha, se, eps, frac = uncertainty_exponent(labels)
    if not np.isfinite(alpha):
        out.append(f"uncertainty exponent: not computed (fewer than two scales eps with an "
                   f"uncertain cell on a {labels.shape[0]} x {labels.shape[1]} grid)")
    else:
        out.append(f"uncertainty exponent alpha = {alpha:.3g} +- {se:.2g} (the uncertain share "
                   f"of cells f(eps) ~ eps^alpha over eps = "
                   f"{', '.join(str(int(e)) for e in eps)} cells: f = "
                   f"{', '.join(f'{x:.3g}' for x in frac)}; a smooth boundary has alpha = 1, "
                   "and the boundary's dimension is 2 - alpha)")
    return out


def _share(tab, rows):
    """The share of starts reaching a branch over its points, with its 95 % interval (Wilson:
    right for rare basins, ``basin_stats.share_interval``)."""
    n = int(tab["runs_per_point"])
    points = len(set(int(tab["parameter_point"][r]) for r in rows))
    runs = int(np.sum(tab["runs"][rows]))
    lo, hi = share_interval(runs, n * points)
    return runs / (n * points), float(lo), float(hi)


def _edge_lines(bt, b) -> list:
    """A branch's edges in a sweep of several parameters, per axis and direction: how many
    there are that way (an edge: one of its attractors whose orbit is not an attractor at
    the next grid value), by kind, with the span of the located values."""
    es = bt.get("edges")
    mine = es["branch"] == b if es is not None else np.zeros(0, bool)
    if not mine.any():
        return ["  no edge inside the grid: along every grid line it reaches the range's "
                "ends"]
    out = []
    for k, a in enumerate(bt["axes"]):
        for step, way in ((-1, "down"), (1, "up")):
            sel = mine & (es["axis"] == k) & (es["step"] == step)
            if not sel.any():
                continue
            kinds, counts = np.unique(es["kind"][sel].astype(str), return_counts=True)
            parts = []
            for kind, c in sorted(zip(kinds, counts), key=lambda kc: (-kc[1], kc[0])):
                at = es["at"][sel & (es["kind"] == kind)]
                at = at[np.isfinite(at)]
                where = ("" if not at.size else f" at {a} = {at[0]:.10g}" if at.size == 1
                         else f" at {a} from {at.min():.10g} to {at.max():.10g}")
                parts.append(f"{KINDS[kind]} x {c}{where}")
            out.append(f"  {int(sel.sum())} edge{'s' if sel.sum() > 1 else ''} going {way} "
                       f"in {a}: " + "; ".join(parts))
    return out


def genealogy(bt, tab, scene) -> list:
    """The branch table ``bt`` (``attractors.read_branches``) as text: per branch, where it
    is, how it begins and ends and why, what it coexists with, and the share of starts it
    attracts."""
    axes = bt["axes"]
    m = len(bt["id"])
    rows = [np.flatnonzero(bt["branch"] == b) for b in range(m)]
    pts = [set(tab["parameter_point"][r].tolist()) for r in rows]
    out = [f"{scene.name}: {len(tab['id'])} attractors on {m} branches over "
           + ", ".join(f"{a} in [{tab[f'at_{a}'].min():.6g}, {tab[f'at_{a}'].max():.6g}]"
                       for a in axes)]
    for b in range(m):
        span = ", ".join(f"{a} in [{bt[f'min_{a}'][b]:.10g}, {bt[f'max_{a}'][b]:.10g}]"
                         for a in axes)
        f, lo, hi = _share(tab, rows[b])
        if bt["word"][b] == CHAOTIC:
            lam = tab["lyapunov"][rows[b]]
            what = (f"chaotic attractor (largest Lyapunov exponent {lam.min():.3g} to "
                    f"{lam.max():.3g} over its points, each with its 95 % interval above 0)")
        else:
            what = (f"{bt['word'][b]!r} (period {bt['period'][b]}, "
                    f"{bt['impacts_per_cycle'][b]} impacts per cycle)")
        mu = ("" if bt["word"][b] == CHAOTIC else
              f"; |multipliers| <= {bt['max_abs_multiplier'][b]:.3g}")
        out.append(f"branch {b}: {what}, an attractor at "
                   f"{len(pts[b])} grid value{'s' if len(pts[b]) > 1 else ''}, {span}{mu}")
        if len(axes) == 1:
            for side, name in (("low", "begins"), ("high", "ends")):
                out.append(f"  {name}: {bt[f'{side}_detail'][b]}")
        else:
            out += _edge_lines(bt, b)
        others = [c for c in range(m) if c != b and pts[b] & pts[c]]
        if others:
            out.append("  coexists with branch" + ("es " if len(others) > 1 else " ")
                       + ", ".join(map(str, others[:20]))
                       + (f" and {len(others) - 20} more" if len(others) > 20 else ""))
        out.append(f"  share of starts at its points: {f:.3g} (95 % interval {lo:.3g} to "
                   f"{hi:.3g})")
    return out
