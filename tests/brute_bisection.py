"""A brute-force reference for where an attractor is born or dies between two parameter
values, with the simulator (``cornerbif.simulate``) as the only judge.

Nothing here uses the periodic-orbit solvers or the continuation (``cornerbif.continuation``,
``cornerbif.models.*.orbit``, ``cornerbif.branches``): at a trial parameter value the flow is
run from states on the attractor carried along from the values where it was last seen, and
the attractor "exists" there when one of these runs ends on a cycle with the given word.  It
is slow (one simulation of ``transient + record`` impacts per trial) and knows nothing about
the kind of event, which is what makes it a reference for the code that does.

Only the ``flow`` model with a cornered obstacle whose corners are t_k = k pi / omega
(``rectified_sine``, ``triangle``) is handled: the word is checked a second time here, from
the recorded impacts, with the paper's letters (section 4.1: a cluster of two impacts either
side of a corner is alpha ``a``, one impact after it beta ``b``, one before it gamma ``g``).

``bisect_death`` is the bisection; ``follow`` carries an attractor along a list of values
(to reach a small basin, e.g. the double-impact orbit near kappa_CC); ``judge`` is the one
decision both use.  ``single_impact_end`` and ``double_impact_end`` are the references for
the paper's two corner events at omega = 1.999, r = 0.8 (kappa_C, eq 11; kappa_CC, eq 17),
computed once per session, for any test to import (tests/ is on sys.path, conftest.py).
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

import cornerbif

# obstacles whose corners are at t_k = k pi / omega (README: rectified_sine, triangle)
CORNERED = ("rectified_sine", "triangle")


def smallest_rotation(word: str) -> str:
    """A cyclic word's least rotation: the name cornerbif reports a cycle by."""
    return min((word[i:] + word[:i] for i in range(len(word))), default=word)


def letters(t, off, omega) -> tuple[list, list]:
    """The recorded impacts (times ``t``, signed offsets ``off`` to the nearest corner;
    NaN-padded) as clusters: (letters, impacts per cluster).  Impacts belong to one
    cluster when their nearest corner is the same (index round((t - off) omega / pi)); a
    cluster is ``a`` (two impacts, the first before the corner, the second at or after it),
    ``b`` (one impact at or after), ``g`` (one before), else ``x``."""
    t = np.asarray(t, float)
    off = np.asarray(off, float)
    ok = np.isfinite(t) & np.isfinite(off)
    t, off = t[ok], off[ok]
    corner = np.rint((t - off) * omega / math.pi).astype(np.int64)
    out, counts = [], []
    i = 0
    while i < len(t):
        j = i
        while j + 1 < len(t) and corner[j + 1] == corner[i]:
            j += 1
        o = off[i:j + 1]
        if len(o) == 1:
            out.append("b" if o[0] >= 0.0 else "g")
        elif len(o) == 2 and o[0] < 0.0 <= o[1]:
            out.append("a")
        else:
            out.append("x")
        counts.append(len(o))
        i = j + 1
    return out, counts


def periodic_with(seq: list, word: str) -> bool:
    """Whether the letter sequence ``seq`` is a stretch of ``word`` repeated (any phase),
    holding it at least twice."""
    p = len(word)
    if p == 0 or len(seq) < 2 * p:
        return False
    if any(seq[i] != seq[i + p] for i in range(len(seq) - p)):
        return False
    return smallest_rotation("".join(seq[:p])) == smallest_rotation(word)


@dataclass
class Trial:
    """One decision: at ``value`` the attractor ``exists`` (a run ended on its cycle) or not;
    ``words``: what each start reached (simulate's word, '' for none)."""
    value: float
    exists: bool
    words: list
    state: tuple | None = None       # a point of the cycle at a corner (t = 0), when it exists
    min_offset: float = math.nan      # smallest |corner offset| of the witnessed cycle
    residual: float = math.nan        # largest change of (offset, v_in) over one cycle


@dataclass
class Edge:
    """Where the attractor ``word`` ends: it was seen at ``inside`` and not at ``outside``
    (|inside - outside| <= tol); ``at`` is their midpoint.  ``slack`` is the further error the
    simulator's event tolerance allows (see ``bisect_death``), ``trust`` = width / 2 + slack
    the error to trust ``at`` to."""
    word: str
    param: str
    inside: float
    outside: float
    at: float
    slack: float
    trust: float
    offset_rate: float                # min |corner offset| per unit of |value - at|
    state: tuple                      # a point of the cycle at ``inside``
    steps: int                        # trials after the two ends
    rechecks: int                     # "not there" overturned when judged again from nearer
    trials: list = field(default_factory=list)

    @property
    def width(self) -> float:
        return abs(self.outside - self.inside)


def _section_point(su, sv):
    """A point of the cycle at a corner: of the recorded section states the one with the
    largest v (canonical up to rounding, so that points at neighbouring values are on the
    same part of the cycle and can be extrapolated)."""
    su = np.asarray(su, float)
    sv = np.asarray(sv, float)
    ok = np.isfinite(su) & np.isfinite(sv)
    if not ok.any():
        return None
    k = int(np.argmax(np.where(ok, sv, -np.inf)))
    return float(su[k]), float(sv[k])


def judge(system: dict, word: str, param: str, value: float, starts, *, transient: int = 1000,
          record: int = 600, model_tol: float = 1e-12) -> Trial:
    """Run the flow at ``param = value`` from every state of ``starts`` ((u, v) at t = 0, a
    corner) and decide whether the attractor ``word`` exists there: some run has status OK,
    simulate's word equal to ``word`` up to rotation, and its whole recorded window (the
    first and last clusters dropped, which the window may cut) decoded here (``letters``)
    is ``word`` repeated.  The first such run is the witness: its cycle point
    (``_section_point``) is carried to the next value."""
    sysd = dict(system)
    sysd[param] = float(value)
    if sysd.get("obstacle") not in CORNERED:
        raise ValueError(f"brute bisection needs a cornered obstacle {CORNERED}, "
                         f"not {sysd.get('obstacle')!r}")
    omega = float(sysd["omega"])
    u0 = np.array([s[0] for s in starts], float)
    v0 = np.array([s[1] for s in starts], float)
    res = cornerbif.simulate(u0, v0, transient=transient, record=record, tol=model_tol, **sysd)
    target = smallest_rotation(word)
    words = [str(w) for w in res["symbols"]]
    for i in range(len(starts)):
        if res["status"][i] != 0 or smallest_rotation(words[i]) != target:
            continue
        seq, counts = letters(res["t"][i], res["corner_offset"][i], omega)
        if not periodic_with(seq[1:-1], word):
            continue
        state = _section_point(res["su"][i], res["sv"][i])
        if state is None:
            continue
        off = res["corner_offset"][i]
        vin = res["v_in"][i]
        ok = np.isfinite(off)
        n = int(res["impacts_per_cycle"][i])
        o, w = off[ok], vin[ok]
        residual = float(max(np.abs(o[n:] - o[:-n]).max(), np.abs(w[n:] - w[:-n]).max()))
        return Trial(float(value), True, words, state, float(np.abs(o).min()), residual)
    return Trial(float(value), False, words)


def _starts(witnessed, value, start):
    """The states to try at ``value``: the cycle point extrapolated from the witnessed
    values nearest to it (quadratic through three, secant through two), the cycle point at
    the nearest one, and the caller's start."""
    near = sorted(witnessed, key=lambda tr: abs(tr.value - value))
    out = []
    for m in (3, 2):
        xs = [tr.value for tr in near[:m]]
        if len(xs) < m or len(set(xs)) < m:
            continue
        # Lagrange weights of the m nearest witnesses at ``value``
        w = [math.prod((value - xs[j]) / (xs[i] - xs[j]) for j in range(m) if j != i)
             for i in range(m)]
        out.append(tuple(sum(wi * tr.state[c] for wi, tr in zip(w, near)) for c in range(2)))
    if near:
        out.append(near[0].state)
    out.append(tuple(start))
    return out


def follow(system: dict, word: str, values, start, *, param: str = "kappa", **run) -> list:
    """Carry the attractor ``word`` along ``values`` (in order) from ``start``: at each value
    the states of ``_starts`` are judged; returns the Trials (each with its cycle point).
    Raises ValueError where it is lost (the value, and the words reached, said)."""
    seen = []
    for x in values:
        tr = judge(system, word, param, x, _starts(seen, x, start), **run)
        if not tr.exists:
            raise ValueError(f"{word!r} lost at {param} = {x!r}: the starts reached {tr.words}")
        seen.append(tr)
    return seen


def bisect_death(system: dict, word: str, lo: float, hi: float, start, tol: float = 1e-9, *,
                 param: str = "kappa", transient: int = 1000, record: int = 600,
                 model_tol: float = 1e-12, max_steps: int = 200) -> Edge:
    """Where the attractor with cycle word ``word`` (as ``simulate`` reports it, any rotation)
    is born or dies between ``param = lo`` and ``param = hi``, by bisection with the flow as
    the only judge; the bracket is narrowed until it is narrower than ``tol``.

    ``system``: the flow's [system] values without ``param`` (e.g. obstacle =
    "rectified_sine", omega, beta, r, sigma, k).  ``start``: a state (u, v) at t = 0 from
    which the flow reaches the attractor at the end where it exists.  Either end may be that
    one, and lo > hi is allowed: the start is run at both, and exactly one must reach
    ``word`` (ValueError otherwise).  Each midpoint is judged (``judge``) from several
    states at once (``_starts``): the cycle point extrapolated from the witnessed values
    nearest to it (quadratic and secant), the cycle point at the nearest one, and
    ``start``; the attractor's end of the bracket moves to the midpoint when one of them
    ends on its cycle, the other end otherwise.  When the bracket is narrow enough, its
    outer end is judged again from the witnesses now within ``tol`` of it; where that
    finds the attractor after all (a "no" from witnesses that were too far away), the
    bisection goes on from there towards the nearest value still without it
    (``Edge.rechecks`` counts these).  Each run has ``transient`` impacts (default 1000)
    before a window of ``record`` (default 600) in which the word is checked twice: by
    simulate's cycle detection and by decoding every cluster of the window here.

    How far to trust the answer (``Edge.trust`` = width / 2 + ``Edge.slack``):

    * Small basins.  "Exists" is witnessed (a run that ended on the cycle, its whole window
      the word repeated), so the true end is not on the attractor's side of ``inside``.
      "Does not exist" only means that none of the starts reached it.  Near a corner event
      the basin shrinks with the distance d to the event: for alpha at kappa_CC (omega =
      1.999, r = 0.8) every start within about 0.1 d of the cycle point (the state at the
      section) reaches it, from d to 100 d only a narrow wedge (2 of 16 around a circle),
      while the cycle point moves by about 0.22 (in v) per unit of kappa.  So the point
      carried from a value 1e-4 away (2e-5 off) misses it at d = 3e-6 (seen: the "no" that
      the recheck overturns in the test).  The extrapolated starts are within O(h^2) of the
      cycle (h the distance to the nearest witnesses), and the final recheck judges
      ``outside`` from witnesses within ``tol`` of it: a wrong "no" survives only where the
      basin is narrower than that extrapolation error, i.e. within about ``tol`` of the
      event.  Not covered: an attractor whose basin does not contain a neighbourhood of its
      cycle that shrinks no faster than d (then the answer can end early, on the
      attractor's side).
    * Slow transients.  The decision needs the transient to reach the cycle and the window
      to show the far side's word whole.  At a corner event the cycle's multipliers stay
      away from modulus 1 (about 0.8 here), so convergence does not slow down towards the
      event; what grows is the time the far side's orbit lingers near the ghost of the
      cycle: the beta^N gamma orbits beyond kappa_C have N + 1 = 39 impacts at 1e-5 from it,
      about 11 more per decade, 146 at 1e-15, so a window of 600 impacts holds them whole
      (and sees their gamma) down to the rounding of kappa.  At an event where a multiplier
      reaches modulus 1 (fold, period doubling, torus) the transient needed grows without
      bound as the bracket shrinks: there ``transient`` must grow with it, or the answer
      ends early (on the attractor's far side: a slow run is judged "no").
    * The simulator's event tolerance.  An impact time is certified to ``model_tol``
      (docs/guarantees.md), so a cluster's letter (which side of its corner) is certified
      where its impacts are farther than that from the corner.  At a corner event the
      cycle's smallest |corner offset| shrinks linearly to 0 at the event (measured from
      the witnesses: ``Edge.offset_rate``, 0.50 for beta at kappa_C, 0.40 for alpha at
      kappa_CC), so the decisions closer than model_tol / rate to the event are not
      certified; ``slack`` = 4 model_tol / rate (about 1e-11 for the default 1e-12) covers
      that and the accumulation of per-impact errors along the cycle.  In practice the side
      is right far closer (to about 1e-15 in kappa at both events of the tests), so
      ``tol`` = 1e-9, and 1e-12 and below, are reachable; trust the answer to ``trust``
      (about 1e-11 for any ``tol`` below it), not to ``tol``.  Where the witnesses' offsets
      do not shrink towards the event (not a corner event) the rate is NaN and ``slack``
      is 0: the event tolerance then does not decide the side of any impact.
    """
    if param in system:
        raise ValueError(f"system must not hold {param!r}: it is the bisected parameter")
    if not (math.isfinite(lo) and math.isfinite(hi)) or lo == hi:
        raise ValueError(f"{param} ends must be finite and distinct, not {lo!r}, {hi!r}")
    run = dict(transient=transient, record=record, model_tol=model_tol)
    at_lo = judge(system, word, param, lo, [tuple(start)], **run)
    at_hi = judge(system, word, param, hi, [tuple(start)], **run)
    if at_lo.exists == at_hi.exists:
        where = "both ends" if at_lo.exists else "neither end"
        raise ValueError(f"{word!r} is reached from the start at {where} ({param} = {lo!r}: "
                         f"{at_lo.words}, {hi!r}: {at_hi.words}); it must exist at exactly one")
    inside, outside = (at_lo, at_hi) if at_lo.exists else (at_hi, at_lo)
    sign = 1.0 if outside.value > inside.value else -1.0     # towards the far side
    witnessed = [inside]
    negatives = [outside.value]
    trials = [at_lo, at_hi]
    x_in, x_out = inside.value, outside.value
    steps = rechecks = 0

    def decide(x):
        nonlocal steps
        if steps >= max_steps:
            raise RuntimeError(f"no bracket narrower than {tol!r} after {steps} steps")
        steps += 1
        tr = judge(system, word, param, x, _starts(witnessed, x, start), **run)
        trials.append(tr)
        if tr.exists:
            witnessed.append(tr)
        else:
            negatives.append(x)
        return tr.exists

    while True:
        while abs(x_out - x_in) >= tol:
            mid = 0.5 * (x_in + x_out)
            if mid in (x_in, x_out):
                break                    # the bracket is two neighbouring floats
            if decide(mid):
                x_in = mid
            else:
                x_out = mid
        # x_out was judged from the witnesses of its time, perhaps far from it (a basin
        # smaller than their extrapolation error says "no" wrongly): judged again from the
        # witnesses now within tol of it, and where it has the attractor after all the
        # bisection goes on towards the next value judged without it
        if not decide(x_out):
            break
        rechecks += 1
        x_in = x_out
        beyond = [x for x in negatives if sign * (x - x_in) > 0]
        if not beyond:
            raise ValueError(f"{word!r} exists at both ends ({lo!r}, {hi!r}) when carried along")
        x_out = min(beyond, key=lambda x: abs(x - x_in))
    at = 0.5 * (x_in + x_out)
    rate = _offset_rate(witnessed, at, abs(x_out - x_in))
    slack = 4.0 * model_tol / rate if rate > 0 else 0.0
    last = min(witnessed, key=lambda tr: abs(tr.value - at))
    return Edge(word, param, x_in, x_out, at, slack, 0.5 * abs(x_out - x_in) + slack, rate,
                last.state, steps, rechecks, trials)


def _offset_rate(witnessed, at, width):
    """min |corner offset| / |value - at| over the witnesses far enough from ``at`` (100
    widths) for the ratio to mean something; NaN unless the offsets shrink towards the
    event (the nearest witness's offset below a hundredth of the farthest's)."""
    far = [tr for tr in witnessed if abs(tr.value - at) > 100 * width]
    if len(far) < 2:
        return math.nan
    ratios = [tr.min_offset / abs(tr.value - at) for tr in far]
    offs = [tr.min_offset for tr in sorted(far, key=lambda tr: abs(tr.value - at))]
    if not offs[0] < 0.01 * offs[-1]:
        return math.nan
    return float(min(ratios))


# ------------------------------------------------ the paper's two corner events (Fig. 6)
# the flow of Fig. 6: omega = 1.999, r = 0.8, z = kappa + |sin omega t|, no damping or forcing
FIG6 = dict(obstacle="rectified_sine", omega=1.999, beta=1.0, r=0.8, sigma=0.0, k=1.0)
# the references' bracket width: below the event tolerance's slack (about 1e-11), and cheap
# (about 30 trials)
REFERENCE_TOL = 1e-12


@functools.cache
def single_impact_end(tol: float = REFERENCE_TOL) -> Edge:
    """Where the single-impact period-T orbit (word ``b``) dies as kappa increases, by brute
    force: it is the attractor at the grid value kappa = -0.0142 (reached from (5, 3)) and
    not at -0.0141.  Eq (11) puts it at kappa_C = -0.0141371698509."""
    return bisect_death(FIG6, "b", -0.0142, -0.0141, (5.0, 3.0), tol=tol)


@functools.cache
def double_impact_word(kappa: float = -0.001) -> tuple:
    """The simulator's word for the double-impact period-T orbit (section 3.3.2: one cycle
    of one cluster, two impacts), and a point of its cycle at ``kappa``: the first of a
    grid of 16 starts whose run ends on a cycle of period 1 with 2 impacts per cycle.
    (Its basin is small near kappa_CC; at -0.001 a third of the starts reach it.)"""
    u0, v0 = np.meshgrid(np.linspace(1.0, 19.0, 4), np.linspace(-15.0, 15.0, 4))
    res = cornerbif.simulate(u0.ravel(), v0.ravel(), transient=1000, record=200, kappa=kappa,
                             **FIG6)
    for i in range(u0.size):
        if res["status"][i] == 0 and res["period"][i] == 1 and res["impacts_per_cycle"][i] == 2:
            return str(res["symbols"][i]), _section_point(res["su"][i], res["sv"][i])
    raise ValueError(f"no start reached a period-1 cycle of 2 impacts at kappa = {kappa}: "
                     f"{sorted(set(map(str, res['symbols'])))}")


@functools.cache
def double_impact_end(tol: float = REFERENCE_TOL) -> Edge:
    """Where the double-impact period-T orbit (``double_impact_word``: ``a``) is lost as
    kappa decreases, by brute force: carried from kappa = -0.001 (where starts reach it)
    down to the grid value -0.0030 in steps of 1e-4 (``follow``; from random starts its
    basin is too small to be found near kappa_CC), then bisected against -0.0032, where
    it is not.  Eq (17) puts it at kappa_CC = -0.0031032811868."""
    word, state = double_impact_word()
    path = follow(FIG6, word, np.linspace(-0.001, -0.003, 21), state)
    return bisect_death(FIG6, word, -0.0030, -0.0032, path[-1].state, tol=tol)
