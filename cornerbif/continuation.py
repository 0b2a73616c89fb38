"""Continuation of periodic orbits through corner events, for any model's orbit problem
(docs/continuation.md).

An orbit problem (the protocol ``model.OrbitProblem``; each model's in its own folder,
``models/<name>/orbit.py``) gives the residual of a closed chain of impacts of one itinerary,
its Jacobian, its monitors (corner distances, smallest gap, Floquet multipliers) and the
itinerary on the far side of a corner.  This module holds what is common to all of them:
Newton's method (``newton``), which finds saddles as well as attractors; pseudo-arclength
continuation in one parameter with adaptive steps (``continue_branch``), which watches the
distance of every impact to its corners, the smallest gap of every flight to the obstacle
(grazing: an impact is born), the relative velocity of every impact (a zero-velocity
impact), and the Floquet multipliers (fold: det(J - I) = 0; period doubling: det(J + I) = 0;
torus: a complex pair on the unit circle), and locates each sign change by the secant method
on the arclength; the switch to the far side of a corner collision (``follow``); the
admissibility test every kept point passes (``admissible``); and two-parameter curves of a
corner collision or a fold (``corner_curve``, ``fold_curve``).

``cornerbif continue`` (the scene's seeds, its output file, resume) is
``continuation_run``.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

NEWTON_TOL = 1e-12     # |residual| (scaled) at which Newton stops
NEWTON_STEP_TOL = 1e-14   # |update| (scaled) at rounding: Newton stops (with the residual)
MAX_TURN = 0.4         # rad: a step whose tangent turns more is retried at half the length
MAX_JUMP = 0.5         # a corrector landing further from its predictor (x the step) likewise
NEWTON_MAX = 30
GAP_SAMPLES = 48       # samples per flight in the grazing monitor


class OrbitError(RuntimeError):
    """Newton did not converge to an orbit of the itinerary."""


def failure_words(e: BaseException) -> str:
    """An orbit solve's failure in words: numpy's bare "Singular matrix" said as what it
    means here (the orbit's Jacobian is singular: a fold, a multiplier at +1, or an
    itinerary whose unknowns do not fix the orbit), others as they are."""
    if isinstance(e, np.linalg.LinAlgError):
        return (f"the orbit's equations have a singular Jacobian there ({e}): a fold or a "
                "Floquet multiplier at +1, where the orbit cannot be continued in this "
                "parameter from this point; try a start a little away from it")
    return str(e)


class StepRejected(OrbitError):
    """A corrected step that the continuation must not take (``_advance``): retried shorter."""


def central_d_param(residual, X, lam):
    """dR/dparam by central differences (the parameter enters through packed rows)."""
    h = 1e-6 * max(1.0, abs(lam))
    return (residual(X, lam + h) - residual(X, lam - h)) / (2.0 * h)


def central_jacobian(residual, X, lam):
    """dR/dX by central differences, column by column (steps relative to each unknown)."""
    Jm = np.empty((len(residual(X, lam)), len(X)))
    for c in range(len(X)):
        h = 1e-7 * max(1.0, abs(X[c]))
        e = np.zeros(len(X))
        e[c] = h
        Jm[:, c] = (residual(X + e, lam) - residual(X - e, lam)) / (2.0 * h)
    return Jm


def cached(cache, key, build, limit=64):
    """cache[key], built by ``build()`` the first time; the cache is emptied past
    ``limit`` entries (a continuation visits a few parameter values at a time)."""
    if key not in cache:
        if len(cache) > limit:
            cache.clear()
        cache[key] = build()
    return cache[key]


def converged(residual, step, prev, scale):
    """Newton's stop, on the residual and the update together: the residual is below
    NEWTON_TOL and the update is at rounding (NEWTON_STEP_TOL) or no longer shrinks (it is
    rounding noise, amplified by the condition number).  A small residual alone is not
    enough where the Jacobian is ill-conditioned: near the saddle's degenerate end of
    docs/continuation.md one more update still moved v+ by 6e-10."""
    return residual <= NEWTON_TOL * scale and (step <= NEWTON_STEP_TOL * scale
                                               or step >= 0.5 * prev)


def newton(problem, X, lam):
    """Newton on R(X, lam) = 0 at fixed lam, stopped by ``converged``; OrbitError if it
    does not converge."""
    X = np.array(X, float)
    prev = math.inf
    for _ in range(NEWTON_MAX):
        R = problem.residual(X, lam)
        if not np.all(np.isfinite(R)):
            raise OrbitError("the residual is not finite")
        scale = 1.0 + np.abs(X).max()
        dX = np.linalg.solve(problem.jacobian(X, lam), -R)
        step = np.abs(dX).max()
        if converged(np.abs(R).max(), step, prev, scale):
            return X + dX if step <= NEWTON_STEP_TOL * scale else X
        X = X + dX
        prev = step
    R = problem.residual(X, lam)
    if np.abs(R).max() <= 1e-9 * (1.0 + np.abs(X).max()):
        return X
    raise OrbitError(f"Newton did not converge (residual {np.abs(R).max():.3g})")


EVENTS = ("corner", "grazing", "zero_velocity", "fold", "period_doubling", "torus")

@dataclass
class Point:
    lam: float
    X: np.ndarray
    mu: np.ndarray
    monitors: dict
    problem: object = None     # the itinerary X refers to (pieces change on a smooth obstacle)
    admissible: bool = True    # the admissibility check's outcome (``admissible``)
    margin: float = math.nan   # its smallest margin (``_margins``; >= -ADMISSIBLE_TOL: passes)

    @property
    def condition(self) -> float:
        """The condition number of dR/dX at the point (its largest singular value over its
        smallest): it grows without bound at a fold and near a degenerate end, where the
        point's last digits are uncertain in proportion (Newton at fixed parameter)."""
        prob, X = self.problem, self.X
        if prob is None:
            return math.nan
        try:
            sv = np.linalg.svd(prob.jacobian(X, self.lam), compute_uv=False)
        except (OrbitError, np.linalg.LinAlgError, ArithmeticError, ValueError):
            return math.nan
        return float(sv[0] / sv[-1]) if sv[-1] > 0.0 else math.inf


@dataclass
class Event:
    kind: str          # corner, grazing, zero_velocity, fold, period_doubling, torus, end
    lam: float
    X: np.ndarray
    detail: str = ""
    problem: object = None


def _monitors(problem, X, lam):
    if hasattr(problem, "orbit"):        # a curve of events: watch the orbit on it
        problem, X = problem.orbit(X, lam)
    with np.errstate(invalid="ignore"):  # an orbit past an ending event: NaN multipliers
        return _watch(problem, X, lam)


def _watch(problem, X, lam):
    mu, J = problem.floquet(X, lam)
    imp = problem.impacts(X, lam)
    return {
        "corner": problem.corner_distances(X, lam),
        "grazing": np.array([problem.smallest_gap(X, lam)]),
        "zero_velocity": np.array([-imp["w"].max()]),
        **_multiplier_tests(mu, J),
    }, mu


def _multiplier_tests(mu, J):
    """The test functions of the Floquet multipliers ``mu`` (of the monodromy ``J``)."""
    return {
        "fold": np.array([np.linalg.det(J - np.eye(len(J)))]),
        "period_doubling": np.array([np.linalg.det(J + np.eye(len(J)))]),
        # a pair with mu_i mu_j = 1 (the bialternate product's determinant, det J - 1 in
        # two dimensions): a complex pair on the unit circle; a real pair (a neutral
        # saddle) is dropped by _events_between
        "torus": np.array([_pairs_on_circle(mu)]),
    }


def _monitor(problem, X, lam, kind):
    """One test function of ``_monitors`` (its ``kind``) alone: what the location of an
    event evaluates at each of its iterates (the grazing monitor's sampled flights cost
    ten times the rest, and a corner collision needs none of it)."""
    if hasattr(problem, "orbit"):
        problem, X = problem.orbit(X, lam)
    with np.errstate(invalid="ignore"):
        if kind == "corner":
            return problem.corner_distances(X, lam)
        if kind == "grazing":
            return np.array([problem.smallest_gap(X, lam)])
        if kind == "zero_velocity":
            return np.array([-problem.impacts(X, lam)["w"].max()])
        return _multiplier_tests(*problem.floquet(X, lam))[kind]


def _pairs_on_circle(mu):
    """prod over pairs i < j of (mu_i mu_j - 1): real (the multipliers of a real matrix),
    zero when a pair multiplies to 1."""
    out = 1.0 + 0j
    for i in range(len(mu)):
        for j in range(i + 1, len(mu)):
            out *= mu[i] * mu[j] - 1.0
    return float(out.real)


def _wdot(W, a, b):
    """The weighted inner product sum W_i^2 a_i b_i of the continuation's arclength."""
    return float(np.sum(W * W * a * b))


def _tangent(problem, X, lam, prev=None, W=None):
    """The null vector of [dR/dX, dR/dlam], of unit weighted length, oriented along
    ``prev``."""
    A = np.hstack([problem.jacobian(X, lam), problem.d_param(X, lam)[:, None]])
    _, _, vt = np.linalg.svd(A)
    T = vt[-1]
    W = np.ones_like(T) if W is None else W
    if prev is not None and _wdot(W, T, prev) < 0:
        T = -T
    return T / math.sqrt(_wdot(W, T, T))


def _turn(T, Tn, W):
    """The angle (rad) between two tangents of unit weighted length."""
    return math.acos(max(-1.0, min(1.0, _wdot(W, T, Tn))))


def _fold_test(problem, Y, T, W, n):
    """The parameter component of the branch's tangent at Y, oriented along T: it changes
    sign where the branch turns back in the parameter (a fold), however many times det(J - I)
    changes sign within the same step (a fold next to a pole of the multipliers)."""
    return _tangent(problem, Y[:n], Y[n], T, W)[n]


def _correct(problem, Y0, T, s, base, W):
    """Newton on (R(Y) = 0, <T, Y - base>_W = s) from the predictor Y0."""
    Y = Y0.copy()
    n = len(Y) - 1
    row = W * W * T
    prev = math.inf
    for _ in range(NEWTON_MAX):
        X, lam = Y[:n], Y[n]
        R = problem.residual(X, lam)
        h = row @ (Y - base) - s
        F = np.append(R, h)
        if not np.all(np.isfinite(F)):
            raise OrbitError("not finite")
        scale = 1.0 + np.abs(Y).max()
        A = np.vstack([np.hstack([problem.jacobian(X, lam),
                                  problem.d_param(X, lam)[:, None]]), row])
        dY = np.linalg.solve(A, -F)
        step = np.abs(dY).max()
        if converged(np.abs(F).max(), step, prev, scale):
            return Y + dY if step <= NEWTON_STEP_TOL * scale else Y
        Y = Y + dY
        prev = step
    raise OrbitError("the corrector did not converge")


def _locate(problem, Ya, T, s_lo, s_hi, f_lo, f_hi, fun, W):
    """The arclength s in (s_lo, s_hi) where fun(Y(s)) changes sign (Illinois secant).

    Where the corrector fails at a trial point, the bracket's midpoint is tried; where that
    fails too (as next to a corner collision of two particles), the bracket's far end
    (``s_hi``, the side past the sign change) moves to the nearer of the two and the search
    goes on by halving: the sign change lies between the last point solved on the near side
    and it."""
    side = 0
    Y = None
    best = None         # (|fun|, point): the point returned, the one closest to the sign change
    halve = False
    for _ in range(120):
        s = (s_hi - f_hi * (s_hi - s_lo) / (f_hi - f_lo) if f_hi != f_lo and not halve
             else 0.5 * (s_lo + s_hi))
        if not (min(s_lo, s_hi) < s < max(s_lo, s_hi)):
            s = 0.5 * (s_lo + s_hi)
        halve = False
        try:
            Y_s = _correct(problem, Ya + s * T, T, s, Ya, W)
        except (OrbitError, np.linalg.LinAlgError):
            mid = 0.5 * (s_lo + s_hi)
            try:
                Y_s = _correct(problem, Ya + mid * T, T, mid, Ya, W)
                s = mid
            except (OrbitError, np.linalg.LinAlgError):
                # neither solved: the far end moves to the nearer of the two, and halving
                # goes on (it stopped here, leaving the point short of the sign change)
                s_hi, side, halve = (mid if abs(mid - s_lo) < abs(s - s_lo) else s), 0, True
                if abs(s_hi - s_lo) <= 1e-14 * max(1.0, abs(s)):
                    break         # the best located point so far
                continue
        Y = Y_s
        f = fun(Y)
        if best is None or abs(f) < best[0]:
            best = (abs(f), Y)
        if f == 0.0 or abs(s_hi - s_lo) <= 1e-15 * (1.0 + abs(s)):
            break
        if (f > 0) == (f_hi > 0):
            s_hi, f_hi = s, f
            if side == 1:
                f_lo *= 0.5
            side = 1
        else:
            s_lo, f_lo = s, f
            if side == -1:
                f_hi *= 0.5
            side = -1
        if abs(s_hi - s_lo) <= 1e-14 * max(1.0, abs(s)):
            break
    if best is None:
        raise OrbitError("no point of the branch was solved between the step's ends")
    return best[1]


def continue_branch(problem, X0, lam0, lam_range, direction=1.0, T0=None, ds=1e-3,
                    ds_min=1e-9, ds_max=None, max_steps=2000, events=EVENTS, log=None):
    """Pseudo-arclength continuation of the orbit (X0, lam0) within param in ``lam_range``.

    The arclength is weighted: the parameter by the range's width, each unknown by
    1 + its size at the start, so that ``ds`` (``ds_min``, ``ds_max``) are parameter
    steps where the branch moves mostly in the parameter, whatever the unknowns' scales
    (impact velocities of 100 beside times of 1).  The first step goes along ``T0`` (a
    tangent) if given, else the way ``direction`` (+1, -1) moves the parameter.  Returns
    (points, events): the accepted points (Point: param, X, multipliers, monitors, the
    admissibility check's outcome) and the located events (Event).  The branch ends at the
    range's end, at an event that ends this itinerary's orbit as the flow's (corner,
    grazing, zero_velocity: its located point is the branch's last; located whether
    ``events`` lists it or not, since past it the solution is no orbit of the flow), where a
    point is not admissible though no test function said so (the branch ends at its last
    admissible point), when the step falls below ``ds_min``, when the step budget runs out,
    or when a step fails (Newton, a singular matrix): the last event, of kind "end" where
    none of the named ones, always says why.  Every point returned is admissible
    (``admissible``); OrbitError if the start is not.
    """
    n = len(X0)
    lo, hi = lam_range
    width = hi - lo
    ds_max = ds_max or 50 * ds
    W = np.append(1.0 / (1.0 + np.abs(np.asarray(X0, float))), 1.0 / width)
    h, h_min, h_max = ds / width, ds_min / width, ds_max / width
    Y = np.append(np.asarray(X0, float), lam0)
    mon, mu = _monitors(problem, Y[:n], Y[n])
    ok, margin = _point_admissible(problem, Y[:n], Y[n], mon)
    if not ok:
        raise OrbitError(f"the orbit is not admissible at the branch's start "
                         f"({_why_not(problem, Y[:n], Y[n])})")
    points = [Point(lam0, Y[:n].copy(), mu, mon, problem, ok, margin)]
    found = []
    T = _tangent(problem, Y[:n], Y[n], T0, W)
    if T0 is None and T[n] * direction < 0:
        T = -T
    if (lam0 <= lo and T[n] < 0) or (lam0 >= hi and T[n] > 0):
        found.append(Event("end", lam0, Y[:n].copy(), "the end of the range", problem))
        return points, found
    for step in range(max_steps + 1):
        if step == max_steps:
            found.append(Event("end", Y[n], Y[:n].copy(),
                               f"the step budget ({max_steps} steps) ran out", problem))
            break
        try:
            Yn = _correct(problem, Y + h * T, T, h, Y, W)
            jump = Yn - (Y + h * T)
            if math.sqrt(_wdot(W, jump, jump)) > MAX_JUMP * h:
                raise OrbitError("the corrector landed away from the predictor")
            Tn = _tangent(problem, Yn[:n], Yn[n], T, W)
            if _turn(T, Tn, W) > MAX_TURN:
                raise OrbitError(f"the tangent turned by {_turn(T, Tn, W):.3g} rad in one step")
        except (OrbitError, np.linalg.LinAlgError) as e:
            h = _shorter(h, h_min, ds_min, str(e) or type(e).__name__, problem, Y, n, found)
            if h is None:
                break
            continue
        before, kept = len(found), len(points)
        try:
            problem, Y, T, mon, h, stop = _advance(problem, Y, Yn, T, Tn, mon, h, h_max, lo,
                                                   hi, events, found, points, n, W)
        except StepRejected as e:
            h = _shorter(h, h_min, ds_min, str(e), problem, Y, n, found)
            if h is None:
                break
            continue
        except (OrbitError, np.linalg.LinAlgError, ArithmeticError, ValueError) as e:
            # a step that cannot be completed (the monitors, an event's location or the next
            # tangent failed): the branch ends at its last complete point, saying so
            if len(points) == kept:
                del found[before:]       # located beyond the last complete point
            last = points[-1]
            found.append(Event("end", last.lam, last.X.copy(),
                               f"the continuation failed after this point "
                               f"({str(e) or type(e).__name__})", last.problem))
            break
        if stop:
            break
        if log:
            log(Y[n])
    return points, found


MAX_MULTIPLIER_JUMP = 0.25   # x (1 + the largest |multiplier|): a larger change in one step
#                            is retried shorter (``_check_multipliers_continuous``)


def _check_multipliers_continuous(mu, mu_n, mon, mon_n):
    """StepRejected where the multipliers jump within one step (each new one farther than
    MAX_MULTIPLIER_JUMP (1 + the largest |mu|) from every old one): the corrector reached
    another orbit.  Not where an ending test function changes sign within the step or an
    impact is slow at either end (the multipliers' pole at a zero-velocity impact)."""
    mu, mu_n = np.asarray(mu, complex), np.asarray(mu_n, complex)
    if not (np.all(np.isfinite(mu)) and np.all(np.isfinite(mu_n))):
        return
    for kind in ENDING:
        if np.any((np.asarray(mon[kind]) > 0) != (np.asarray(mon_n[kind]) > 0)):
            return
    if min(mon["zero_velocity"][0], mon_n["zero_velocity"][0]) < 1e-2:
        return
    scale = 1.0 + max(np.abs(mu).max(), np.abs(mu_n).max())
    jump = max(np.abs(mu - m).min() for m in mu_n)
    if jump > MAX_MULTIPLIER_JUMP * scale:
        raise StepRejected(f"the multipliers jumped by {jump:.3g} in one step")


def _shorter(h, h_min, ds_min, failure, problem, Y, n, found):
    """The step halved after a failed or rejected attempt (``failure`` says why), or None,
    with the branch's end appended to ``found``, where it falls below ds_min."""
    h *= 0.5
    if h >= h_min:
        return h
    found.append(Event("end", Y[n], Y[:n].copy(), f"the step fell below ds_min ({ds_min:.3g}; "
                       f"the last attempt: {failure})", problem))
    return None


def _advance(problem, Y, Yn, T, Tn, mon, h, h_max, lo, hi, events, found, points, n, W):
    """One accepted step of ``continue_branch`` from Y to the corrected Yn (``Tn`` the tangent
    there, oriented along T): the range's end, the events between, the admissibility of Yn,
    the next tangent and step.  Returns (problem, Y, T, monitors, h, stop): the problem is
    another where an impact changed piece on a smooth obstacle (``reindex``)."""
    out = Yn[n] > hi or Yn[n] < lo
    if out:
        edge = hi if Yn[n] > hi else lo

        def sfun(Yv, edge=edge):
            return Yv[n] - edge
        Yn = _locate(problem, Y, T, 0.0, h, sfun(Y), sfun(Yn), sfun, W)
        if abs(Yn[n] - edge) > 1e-9 * max(1.0, abs(edge)):
            raise StepRejected(f"the range's end {edge!r} was not located within the step")
        # a branch never leaves its range: it ends exactly at the range's end, solved there
        Yn[:n], Yn[n] = newton(problem, Yn[:n], edge), edge
        Tn = _tangent(problem, Yn[:n], Yn[n], T, W)
    mon_n, mu_n = _monitors(problem, Yn[:n], Yn[n])
    _check_multipliers_continuous(points[-1].mu, mu_n, mon, mon_n)
    before = len(found)
    ended = _events_between(problem, Y, Yn, T, mon, mon_n, events, found, n, W, Tn)
    span = 1e-12 * max(1.0, abs(lo), abs(hi))
    if any(not lo - span <= e.lam <= hi + span for e in found[before:]):
        # the step left the range and came back within it: an event outside is never kept
        del found[before:]
        raise StepRejected("an event of the step lies outside the range")
    if ended:
        e = found[-1]
        m_e, mu_e = _monitors(problem, e.X, e.lam)
        ok_e, margin_e = _point_admissible(problem, e.X, e.lam, m_e)
        if ok_e:
            points.append(Point(e.lam, e.X.copy(), mu_e, m_e, problem, ok_e, margin_e))
            return problem, Y, T, mon, h, True
        # the located end is not an orbit of the flow either: the branch ends before it
        del found[before:]
        found.append(Event("end", Y[n], Y[:n].copy(),
                           f"its orbit stops being one of the flow within the next step "
                           f"({_why_not(problem, e.X, e.lam)} at the located {e.kind}, "
                           f"{e.lam:.12g}): the branch ends at its last admissible point",
                           problem))
        return problem, Y, T, mon, h, True
    ok_n, margin_n = _point_admissible(problem, Yn[:n], Yn[n], mon_n)
    if not ok_n:
        # no test function changed sign (through a pole, or a non-finite value), yet the
        # next point is no orbit of the flow: it is not stored, and the branch ends here
        del found[before:]
        found.append(Event("end", Y[n], Y[:n].copy(),
                           f"its orbit stops being one of the flow within the next step (at "
                           f"{Yn[n]:.12g}: {_why_not(problem, Yn[:n], Yn[n])}): the branch "
                           "ends at its last admissible point", problem))
        return problem, Y, T, mon, h, True
    points.append(Point(Yn[n], Yn[:n].copy(), mu_n, mon_n, problem, ok_n, margin_n))
    if out:
        found.append(Event("end", Yn[n], Yn[:n].copy(), "the end of the range", problem))
        return problem, Yn, T, mon_n, h, True
    again, Xr = problem.reindex(Yn[:n], Yn[n])
    if again is not problem or not np.array_equal(Xr, Yn[:n]):
        # an impact changed piece: the tangent of the problem it now belongs to
        problem, Yn[:n] = again, Xr
        Tn = _tangent(problem, Yn[:n], Yn[n], T, W)
    # adapt: grow where the tangent turns little
    turn = _turn(T, Tn, W)
    h = min(h_max, h * (1.5 if turn < 0.05 else 1.0 if turn < 0.2 else 0.5))
    return problem, Yn, Tn, mon_n, h, False


@dataclass
class Branch:
    problem: object           # an orbit problem (``model.OrbitProblem``)
    points: list
    events: list
    word: str = ""
    origin: str = ""
    stops: list = None        # the events where it stopped (None: its last event)

    def ends(self) -> list:
        """The events at which the branch stopped: the last of each way it was continued."""
        return self.stops if self.stops is not None else self.events[-1:]


MAX_BRANCHES = 6      # branches continued each way from a seed (``follow``)


def follow(problem, X0, lam0, lam_range, direction=1.0, switch=True,
           max_branches=MAX_BRANCHES, **kw):
    """Continue from (X0, lam0) and, at every corner collision, on along the branch of
    the new itinerary (the impact on the other side of its corner) where it exists:
    the tangent of the new itinerary at the collision, oriented so that the impact
    moves into its new piece, says whether the new branch goes on in the same direction
    (a persistence: the word changes) or turns back (a nonsmooth fold: the two branches
    end together).  Returns the branches in order (breadth first, at most
    ``max_branches``; ``follow_step`` is one of them)."""
    out = []
    todo = [(problem, X0, lam0, None, "start")]
    while todo and len(out) < max_branches:
        prob, X, lam, T0, origin = todo.pop(0)
        br, more = follow_step(prob, X, lam, T0, origin, lam_range, direction, switch,
                               room=max_branches - len(out) - 1 - len(todo), **kw)
        out.append(br)
        todo += more
    return out


def follow_step(prob, X, lam, T0, origin, lam_range, direction=1.0, switch=True,
                room=MAX_BRANCHES, **kw):
    """One branch of ``follow``: continue (X, lam) of ``prob`` (along the tangent ``T0``,
    or the way ``direction`` moves the parameter) and, where it ends at a corner
    collision and ``switch``, solve the other side's itinerary there.  Returns (the
    Branch, the branches to continue from it: (problem, X, param, tangent, origin) each).
    ``room``: how many more branches ``follow`` continues; those beyond are said in the
    corner collision's detail and not returned."""
    try:
        pts, evs = continue_branch(prob, X, lam, lam_range, direction, T0, **kw)
    except (OrbitError, np.linalg.LinAlgError, ArithmeticError, ValueError) as e:
        X = np.asarray(X, float).copy()
        try:
            mon, mu = _monitors(prob, X, lam)
            ok, margin = _point_admissible(prob, X, lam, mon)
        except (OrbitError, np.linalg.LinAlgError, ArithmeticError, ValueError):
            mon, mu, ok, margin = {}, np.full(2, complex(math.nan, math.nan)), True, math.nan
        pts = [Point(lam, X, mu, mon, prob, ok, margin)]
        evs = [Event("end", lam, X, f"the continuation failed ({failure_words(e)})", prob)]
    br = Branch(prob, pts, evs, prob.word(pts[0].X, pts[0].lam), origin)
    last = evs[-1] if evs else None
    if (switch and last is not None and last.kind == "grazing"
            and hasattr(last.problem, "across_grazing")):
        more = _across_grazing(last, lam_range)
        if more:
            if room > 0:
                last.detail += f"; across it, the orbit with the new impact is continued as {more[1]!r}"
            else:
                last.detail += (f"; across it, the orbit with the new impact, {more[1]!r}, is not "
                                f"continued (at most {MAX_BRANCHES} branches each way from a seed)")
            return br, [more[0]] if room > 0 else []
        return br, []
    if not (switch and last is not None and last.kind == "corner"):
        return br, []
    more = []
    q = int(last.detail.split(";")[0].split()[-1])
    new, Xs = last.problem.across(q, last.X, last.lam)
    n = len(Xs)
    try:
        Xn = newton(new, Xs, last.lam)
        T = _tangent(new, Xn, last.lam)
    except (OrbitError, np.linalg.LinAlgError) as e:
        last.detail += f"; no orbit of the other side's itinerary ({failure_words(e)})"
        return br, more
    ok, why = new.admissible(Xn, last.lam)
    if not ok:
        last.detail += (f"; the other side's itinerary has no admissible orbit there "
                        f"({why}): the orbit ends at the corner collision")
        return br, more
    word = new.word(Xn, last.lam)
    if np.abs(Xn - Xs).max() > 1e-6 * (1.0 + np.abs(Xs).max()):
        # the map jumps at the corner (the one-sided slopes differ): the other side's
        # orbit is another orbit, not this one going on; follow it both ways
        last.detail += (f"; the map jumps there: the other side's itinerary has the "
                        f"orbit {word!r}, continued both ways")
        origin = (f"the orbit {word!r} on the other side of the corner collision of "
                  f"{q} at {new.param} = {last.lam!r} (a jump)")
        more.append((new, Xn, last.lam, T, origin))
        more.append((new, Xn, last.lam, -T, origin))
    else:
        # a continuous crossing: the orbit goes on, into the new side (the distance of
        # point q to its corner must grow)
        eps = 1e-7 * (1.0 + np.abs(Xn).max())
        Y = np.append(Xn, last.lam)
        d_plus = new.corner_distances((Y + eps * T)[:n], (Y + eps * T)[n])[q]
        d_minus = new.corner_distances((Y - eps * T)[:n], (Y - eps * T)[n])[q]
        if d_minus > d_plus:
            T = -T
        came = pts[-1].lam - pts[-2].lam if len(pts) > 1 else direction
        kind = "persists" if T[n] * came > 0 else "turns back (nonsmooth fold)"
        last.detail += f"; the orbit crosses continuously and {kind} as {word!r}"
        more.append((new, Xn, last.lam, T, f"corner collision of {q} at "
                                           f"{new.param} = {last.lam!r}: {kind}"))
    if len(more) > max(room, 0):
        dropped = len(more) - max(room, 0)
        last.detail += (f"; {'it is' if dropped == len(more) else 'one way is'} not "
                        f"continued (at most {MAX_BRANCHES} branches each way from a seed)")
        more = more[:max(room, 0)]
    return br, more


def _across_grazing(last, lam_range):
    """At a located grazing (an Event), the orbit with the impact it gives birth to: the
    problem with one impact more (``across_grazing``) holds the grazing orbit itself, at a
    fold of its solutions (the new impact's arrival velocity w- ~ sqrt of the distance to
    the grazing, one sign on each side).  Corrected onto those solutions on the hyperplane
    through it normal to their tangent, and continued the way the new impact arrives from
    above (w- < 0: an orbit of the flow).  Returns the branches to continue (none, with the
    reason in the event's detail, where neither way is one): (the branch to continue,
    its word), or None."""
    new, Xs, k = last.problem.across_grazing(last.X, last.lam)
    n = len(Xs)
    lo, hi = lam_range
    W = np.append(1.0 / (1.0 + np.abs(Xs)), 1.0 / (hi - lo))

    def born(Y, _=None):
        """The new itinerary's equations and the new impact's arrival velocity w- = 0: the
        grazing itself, a regular solution in (X, param)."""
        return np.append(new.residual(Y[:n], Y[n]), new.impacts(Y[:n], Y[n])["w"][k])
    Y = np.append(Xs, last.lam)
    try:
        for _ in range(NEWTON_MAX):
            F = born(Y)
            dY = np.linalg.solve(central_jacobian(born, Y, 0.0), -F)
            Y = Y + dY
            if np.abs(dY).max() <= 1e-13 * (1.0 + np.abs(Y).max()):
                break
        else:
            raise OrbitError("the grazing of the new itinerary was not solved")
        T = _tangent(new, Y[:n], Y[n], None, W)
    except (OrbitError, np.linalg.LinAlgError) as e:
        last.detail += f"; no orbit with the impact it gives birth to ({e})"
        return None
    # along the new itinerary's solutions w- of the new impact changes sign at the grazing:
    # the branch starts a short step (1e-4 of the arclength's scale) the way it turns
    # negative (the impact arrives from above), where its parameter's direction is clear
    # (the grazing may be a fold of these solutions)
    h = 1e-4

    def along(sign):
        Z = _correct(new, Y + sign * h * T, sign * T, h, Y, W)
        return Z, float(np.max(new.impacts(Z[:n], Z[n])["w"]))
    try:
        Z, w_max = min((along(1.0), along(-1.0)), key=lambda zw: zw[1])
        Tz = _tangent(new, Z[:n], Z[n], Z - Y, W)
        ok = w_max < 0.0 and lo <= Z[n] <= hi and admissible(new, Z[:n], Z[n])[0]
    except (OrbitError, np.linalg.LinAlgError):
        ok = False
    if not ok:
        last.detail += ("; across it, the orbit with the impact it gives birth to is not one "
                        "of the flow on either side")
        return None
    return ((new, Z[:n].copy(), float(Z[n]), Tz,
             f"the grazing at {new.param} = {last.lam!r}: the orbit with the impact it "
             "gives birth to"), new.word(Z[:n], Z[n]))


ADMISSIBLE_TOL = 1e-9


def _margins(cd, gap, w_max, scale):
    """The three margins of the admissibility test, each >= -tol for an orbit of the flow:
    the smallest distance of an impact to its corner (time), the smallest gap of a flight
    to the obstacle and minus the largest arrival velocity w- (both relative to the
    orbit's scale, 1 + its largest unknown)."""
    cd = np.asarray(cd, float)
    return (float(cd.min()) if cd.size else math.inf, float(gap) / scale,
            -float(w_max) / scale)


def admissible(problem, X, lam, tol=ADMISSIBLE_TOL):
    """Whether the orbit is one of the flow: every impact on its own piece (corner
    distances >= -tol), every flight above the obstacle (smallest gap >= -tol) and every
    impact arriving from above (w- < tol).  Returns (ok, reason)."""
    scale = 1.0 + np.abs(X).max()
    cd = problem.corner_distances(X, lam)
    g = problem.smallest_gap(X, lam)
    w = problem.impacts(X, lam)["w"]
    m_cd, m_gap, m_w = _margins(cd, g, w.max(), scale)
    if m_cd < -tol:
        return False, f"impact {int(np.argmin(cd))} beyond its corner by {-cd.min():.3g}"
    if m_gap < -tol:
        return False, f"a flight crosses the obstacle (gap {g:.3g})"
    if m_w < -tol:
        return False, f"impact {int(np.argmax(w))} arrives from below (w- = {w.max():.3g})"
    return True, ""


def _orbit_of(problem, X, lam):
    """(orbit problem, its X) of a point: a curve of events (CornerCurve, FoldCurve) holds
    an orbit of the flow at each of its points."""
    return problem.orbit(X, lam) if hasattr(problem, "orbit") else (problem, X)


def _point_admissible(problem, X, lam, mon, tol=ADMISSIBLE_TOL):
    """(ok, margin): the admissibility test (``admissible``) of a point from the monitors
    already computed there (``_monitors``: the corner distances, the smallest gap and the
    largest arrival velocity), without computing them again."""
    prob, Xo = _orbit_of(problem, X, lam)
    m = _margins(mon["corner"], mon["grazing"][0], -mon["zero_velocity"][0],
                 1.0 + np.abs(Xo).max())
    if any(math.isnan(x) for x in m):
        return False, math.nan
    margin = min(m)
    return bool(margin >= -tol), margin


def _why_not(problem, X, lam):
    """Why a point is not admissible, in the orbit problem's own words."""
    try:
        prob, Xo = _orbit_of(problem, X, lam)
        ok, why = prob.admissible(Xo, lam)
        return why or "a test function is not finite"
    except (OrbitError, np.linalg.LinAlgError, ArithmeticError, ValueError) as e:
        return f"it cannot be evaluated: {e}"


ENDING = ("corner", "grazing", "zero_velocity")
# what each ending event does to the orbit, for the branch's end (``stop_reason``)
ENDING_WORDS = {"corner": "a corner collision: impact {q} reaches its corner",
                "grazing": "a grazing: a flight touches the obstacle (an impact is born)",
                "zero_velocity": "a zero-velocity impact: an impact arrives with the "
                                 "obstacle's velocity"}


def _events_between(problem, Ya, Yb, T, ma, mb, kinds, found, n, W, Tb=None):
    """Locate every sign change of a watched test function between two points; append
    the events in arclength order.  Returns True when one of them ends the branch (its
    located point becomes the branch's last).  The ending kinds (``ENDING``) are watched
    whether ``kinds`` lists them or not: past them the solution is no orbit of the flow.
    One that ``kinds`` leaves out ends the branch as an event of kind "end" saying what it
    was (it is then neither reported as its kind nor switched across).  A fold is the sign
    change of the tangent's parameter component (T at Ya, ``Tb`` at Yb; ``_fold_test``),
    else of det(J - I) (a branch point, where the branch does not turn)."""
    hits = []
    s_b = _wdot(W, T, Yb - Ya)
    watched = tuple(kinds)
    turned = Tb is not None and "fold" in watched and (T[n] > 0) != (Tb[n] > 0)
    if turned:
        def turn_fun(Y):
            return _fold_test(problem, Y, T, W, n)
        Y = _locate(problem, Ya, T, 0.0, s_b, T[n], Tb[n], turn_fun, W)
        hits.append((_wdot(W, T, Y - Ya), -1, "fold", 0, Y))
    order = watched + tuple(k for k in ENDING if k not in watched)
    changes = [(i, kind, q) for i, kind in enumerate(order) if not (kind == "fold" and turned)
               for q in range(len(ma[kind]))
               if (abs(ma[kind][q]) > 1e-12 and (ma[kind][q] > 0) != (mb[kind][q] > 0)
                   and np.isfinite(ma[kind][q]) and np.isfinite(mb[kind][q]))]
    # the corner collisions first (their test is cheap): a sign change that has clearly not
    # yet happened at the first of them (its test there finite, of the start's sign, and
    # beyond the location's tolerance: a tie at the corner, e.g. a grazing there, is
    # located as before) lies beyond the branch's end and is not located
    changes.sort(key=lambda c: c[1] != "corner")
    first_end = None
    for i, kind, q in changes:
        a, b = ma[kind][q], mb[kind][q]
        tol = 1e-6 * max(1.0, abs(a), abs(b))

        def fun(Y, kind=kind, q=q):
            return _monitor(problem, Y[:n], Y[n], kind)[q]
        if first_end is not None and kind != "corner":
            at_end = fun(first_end)
            if np.isfinite(at_end) and abs(at_end) > tol and (at_end > 0) == (a > 0):
                continue
        Y = _locate(problem, Ya, T, 0.0, s_b, a, b, fun, W)
        if not abs(fun(Y)) <= tol:
            continue      # a sign change through a pole (multipliers blowing up)
        s = _wdot(W, T, Y - Ya)
        hits.append((s, i, kind, q, Y))
        if kind in ENDING and (first_end is None or s < _wdot(W, T, first_end - Ya)):
            first_end = Y
    hits.sort(key=lambda h: h[:2])
    for _, _, kind, q, Y in hits:
        if kind == "torus" and problem.floquet(Y[:n], Y[n])[0][0].imag == 0.0:
            continue          # det J = 1 with real multipliers: a neutral saddle
        if kind in ENDING and kind != "corner":
            # a grazing or a zero-velocity impact exactly at a corner is a corner collision
            # (two impacts straddling a corner merge there: the alpha orbit at kappa_CC); on
            # a curve, of its orbit, the impact the curve holds at its corner aside
            prob_o, Xo = _orbit_of(problem, Y[:n], Y[n])
            if hasattr(prob_o, "corner_distances"):
                cd = np.abs(np.asarray(prob_o.corner_distances(Xo, Y[n]), float))
                held = getattr(problem, "q", None)
                if held is not None:
                    cd[held] = math.inf
                if cd.min() <= 1e-9:
                    kind, q = "corner", int(np.argmin(cd))

        if kind in ENDING and kind not in watched:
            found.append(Event("end", Y[n], Y[:n].copy(),
                               ENDING_WORDS[kind].format(q=q) + f" (continue.events does "
                               f"not list {kind!r}: located as the branch's end, not as an "
                               "event, and not continued across)", problem))
            return True
        detail = f"impact {q}" if kind == "corner" else ""
        found.append(Event(kind, Y[n], Y[:n].copy(), detail, problem))
        if kind in ENDING:
            return True
    return False


# ------------------------------------------------------------------ two parameters
def with_value(base, name, value):
    """The orbit problem ``base`` with the (other) parameter ``name`` at ``value``: the
    problems of a curve's second parameter, kept in the base's cache."""
    def build():
        return dataclasses.replace(base, values=dict(base.values) | {name: float(value)},
                                   _cache={})
    return cached(base._cache, (name, float(value)), build, limit=256)


def rebase(prob, values, param):
    """The same itinerary's problem at other ``values``, continued in ``param`` (the
    problem's own ``rebased`` where it has one)."""
    if hasattr(prob, "rebased"):
        return prob.rebased(values, param)
    return dataclasses.replace(prob, values=values, param=param, _cache={})


class _FreeCurve:
    """What a curve in two parameters whose second parameter ``param2`` is its last unknown
    shares (``EventCurve``, ``FoldCurve``): the orbit's equations and one condition
    (``_condition``), continued in the base problem's parameter, the Jacobian by central
    differences."""

    @property
    def n(self) -> int:
        return self.base.n

    def _problem(self, lam2):
        return with_value(self.base, self.param2, lam2)

    def residual(self, Xc, lam):
        prob = self._problem(Xc[-1])
        X = Xc[:-1]
        return np.append(prob.residual(X, lam), self._condition(prob, X, lam))

    def jacobian(self, Xc, lam):
        return central_jacobian(self.residual, Xc, lam)

    def d_param(self, Xc, lam):
        return central_d_param(self.residual, Xc, lam)

    def orbit(self, Xc, lam):
        return self._problem(Xc[-1]), Xc[:-1]

    def reindex(self, Xc, lam):
        return self, Xc


@dataclass
class EventCurve(_FreeCurve):
    """A corner collision of any orbit problem as a curve in two parameters: the orbit's
    equations and impact ``q``'s corner distance = 0 (``corner_distances``: the flow's time
    to its corner, the maps' distance to their switching line, the two-particle system's
    time between the two events that meet), with ``param2`` free (the last unknown of X').
    The flow's own curve (``CornerCurve``) holds the impact at its corner exactly instead."""

    base: object
    q: int
    param2: str

    def _condition(self, prob, X, lam):
        return prob.corner_distances(X, lam)[self.q]


@dataclass
class CornerCurve:
    """The corner collision of impact ``q`` as a curve in two parameters: impact q held
    at its corner (tau_q = 0 at its piece's start, or L at its end) and ``param2`` free;
    continued in the base problem's parameter.  X' is X with tau_q replaced by param2.
    """

    base: object              # the flow's orbit problem (``piece_length``)
    q: int
    at_end: bool
    param2: str

    @property
    def n(self) -> int:
        return self.base.n

    def _split(self, Xc, lam):
        X = Xc.copy()
        X[2 * self.q] = self.base.piece_length(self.q, lam) if self.at_end else 0.0
        return X, Xc[2 * self.q]

    def _problem(self, lam2):
        return with_value(self.base, self.param2, lam2)

    def residual(self, Xc, lam):
        X, lam2 = self._split(Xc, lam)
        return self._problem(lam2).residual(X, lam)

    def jacobian(self, Xc, lam):
        X, lam2 = self._split(Xc, lam)
        Jm = self._problem(lam2).jacobian(X, lam)
        h = 1e-6 * max(1.0, abs(lam2))
        Jm[:, 2 * self.q] = (self._problem(lam2 + h).residual(X, lam)
                             - self._problem(lam2 - h).residual(X, lam)) / (2.0 * h)
        return Jm

    def d_param(self, Xc, lam):
        """dR/dparam of the curve's own residual: with the impact held at the end of its
        piece, tau_q = L(param) moves with the parameter too."""
        return central_d_param(self.residual, Xc, lam)

    def orbit(self, Xc, lam):
        """(problem at param2, X) of the point of the curve."""
        X, lam2 = self._split(Xc, lam)
        return self._problem(lam2), X

    def reindex(self, Xc, lam):
        return self, Xc


@dataclass
class FoldCurve(_FreeCurve):
    """A fold (a multiplier at +1) as a curve in two parameters: the orbit's equations
    and det(J - I) = 0 (J the monodromy; scaled, ``_condition``), with ``param2`` free (the
    last unknown of X')."""

    base: object
    param2: str

    def _condition(self, prob, X, lam):
        """det(J - I) w_1 ... w_N / sqrt((1 + w_1^2) ... ), w_i the impacts' arrival
        velocities: each saltation matrix has a pole 1/w_i of rank one, so det(J - I) is
        linear in each 1/w_i and the product cancels it; with the same zeros elsewhere, the
        curve goes on smoothly to an impact of zero velocity (where the zero-velocity test
        ends it) instead of meeting a pole."""
        _, J = prob.floquet(X, lam)
        w = np.asarray(prob.impacts(X, lam)["w"], float)
        scale = float(np.prod(-w / np.sqrt(1.0 + w * w)))
        return np.linalg.det(J - np.eye(len(J))) * scale


def fold_curve(event, param, lam_range, direction=1.0, ds=1e-3, **kw):
    """Continue a located fold (an Event of kind "fold" in ``event.problem.param``) in
    the plane of that parameter and ``param``: (param values, fold parameter values)."""
    prob = event.problem
    base_vals = dict(prob.values)
    base_vals[prob.param] = event.lam
    base = rebase(prob, base_vals, param)
    curve = FoldCurve(base, prob.param)
    Xc = np.append(event.X, event.lam)
    lam0 = float(prob.values[param])
    Xc = newton(curve, Xc, lam0)
    pts, evs = continue_branch(curve, Xc, lam0, lam_range, direction, ds=ds, events=ENDING,
                               **kw)
    return (np.array([pt.lam for pt in pts]), np.array([pt.X[-1] for pt in pts]), curve, pts,
            evs)


def corner_curve(event, param, lam_range, direction=1.0, ds=1e-3, **kw):
    """Continue a located corner collision (an Event of kind "corner" of a branch in
    ``event.problem.param``) in the plane of that parameter and ``param``: returns the
    curve's points as arrays (param values, event parameter values)."""
    prob = event.problem
    q = int(event.detail.split(";")[0].split()[-1])
    base_vals = dict(prob.values)
    base_vals[prob.param] = event.lam
    base = rebase(prob, base_vals, param)
    if hasattr(prob, "piece_length"):         # the flow: the impact held at its corner
        at_end = event.X[2 * q] > 0.5 * prob.piece_length(q, event.lam)
        curve = CornerCurve(base, q, at_end, prob.param)
        Xc = event.X.copy()
        Xc[2 * q] = event.lam
    else:
        curve = EventCurve(base, q, prob.param)
        Xc = np.append(event.X, event.lam)
    lam0 = float(prob.values[param])
    Xc = newton(curve, Xc, lam0)
    # the orbit along the curve must stay one of the flow: the other impacts' corners, the
    # flights' gaps and the impact velocities end the curve (the held impact's own corner
    # distance is 0 throughout and never changes sign)
    pts, evs = continue_branch(curve, Xc, lam0, lam_range, direction, ds=ds,
                               events=ENDING, **kw)
    held = -1 if isinstance(curve, EventCurve) else 2 * q
    return (np.array([pt.lam for pt in pts]), np.array([pt.X[held] for pt in pts]),
            curve, pts, evs)
