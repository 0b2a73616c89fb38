"""Closed forms of the paper (section 3.3): corner curves and simple periodic orbits.

All formulas are written for the obstacle z = kappa + beta |sin(omega t)|
(eq 8), for which t0 = pi/omega, T = 2 pi/omega and theta1 = theta2 = beta omega.
"""

from __future__ import annotations

import math

import numpy as _np

from .analysis import parse_word, winding_number  # noqa: F401  (part of theory's API)
from .obstacles.sine import resonant_amplitude  # noqa: F401  (eq 6: the smooth wall's own)


def kappa_C(omega: float, r: float, beta: float = 1.0) -> float:
    """Corner bifurcation of the single-impact period-T orbit, eqs (10)-(11).

    kappa_C = theta2 (1 + r)/(1 - r) cot(pi/omega) with theta2 = beta omega
    (eq 11 is the case beta = 1).  The orbit exists for kappa < kappa_C (eq 13).
    """
    return beta * omega * (1.0 + r) / (1.0 - r) / math.tan(math.pi / omega)


def kappa_CC(omega: float, r: float, beta: float = 1.0) -> float:
    """Corner bifurcation of the double-impact period-T orbit, eqs (15)-(17).

    kappa_CC = (theta2 + r theta1)(1 + r)/(1 + r^2) cot(pi/omega); with
    theta1 = theta2 = beta omega this is beta omega (1 + r)^2/(1 + r^2) cot(pi/omega).
    The orbit exists for kappa > kappa_CC (eq 19).
    """
    return beta * omega * (1.0 + r) ** 2 / (1.0 + r * r) / math.tan(math.pi / omega)


def _solve_omega(fun, kappa, lo, hi, iters=200):
    """Bisection for fun(omega) = kappa on [lo, hi] (fun is monotone there)."""
    flo = fun(lo) - kappa
    fhi = fun(hi) - kappa
    if flo == 0:
        return lo
    if fhi == 0:
        return hi
    if flo * fhi > 0:
        return math.nan
    for _ in range(iters):
        mid = 0.5 * (lo + hi)
        fm = fun(mid) - kappa
        if fm == 0 or hi - lo < 1e-15 * max(1.0, abs(mid)):
            return mid
        if (fm < 0) == (flo < 0):
            lo, flo = mid, fm
        else:
            hi = mid
    return 0.5 * (lo + hi)


def omega_C(kappa: float, r: float, beta: float = 1.0, lo: float = 1.0 + 1e-9,
            hi: float = 3.0) -> float:
    """omega_C(kappa): eq (11) solved for omega on (lo, hi) by bisection."""
    return _solve_omega(lambda w: kappa_C(w, r, beta), kappa, lo, hi)


def omega_CC(kappa: float, r: float, beta: float = 1.0, lo: float = 1.0 + 1e-9,
             hi: float = 3.0) -> float:
    """omega_CC(kappa): eq (17) solved for omega on (lo, hi) by bisection."""
    return _solve_omega(lambda w: kappa_CC(w, r, beta), kappa, lo, hi)


# ---------------------------------------------------------------------------
# Sections 4-5: the local maps alpha, beta, gamma and their fixed points
# ---------------------------------------------------------------------------
# Conventions as in cornerbif.models.map2d.maps: epsilon = 1, omega1 = omega - 2,
# kappa1 = kappa, x = (a0, b1) = (u, u') at t = nT; h = pi omega1/2.


_NAMES = {"a": "alpha", "alpha": "alpha", "\u03b1": "alpha",
          "b": "beta", "beta": "beta", "\u03b2": "beta",
          "g": "gamma", "gamma": "gamma", "\u03b3": "gamma"}
_VARIANTS = ("derived", "printed")


def _map_name(name: str) -> str:
    try:
        return _NAMES[str(name).strip().lower()]
    except KeyError:
        raise ValueError(f"map name {name!r}: expected one of alpha, beta, gamma (or a, b, g)") from None


def _variant(variant: str) -> str:
    if variant not in _VARIANTS:
        raise ValueError(f"variant {variant!r}: expected one of {_VARIANTS}")
    return variant


def map_matrices(name: str, omega1: float, kappa1: float, r: float,
                 variant: str = "derived") -> tuple[_np.ndarray, _np.ndarray]:
    """Q and P of one local map x' = Q x + P (eqs 57-59, corrected 58).

    Parameters
    ----------
    name : {'alpha', 'beta', 'gamma'} (or 'a', 'b', 'g')
    omega1, kappa1, r : float
        omega - 2, kappa, coefficient of restitution (epsilon = 1).
    variant : {'derived', 'printed'}
        'derived' (default, used by every kernel): P_alpha from eqs (52)-(53),
        P_alpha = (2 (1+r)^2, (pi omega1/2)(1+r)^2 + kappa1 (r^2 - 1)).
        'printed': P_alpha exactly as printed in eq (58),
        (2 (1+r^2), r (pi omega1/2)(1+r^2) + kappa1 (r^2 - 1)), which does not
        follow from (52)-(53) (see "Discrepancies" in :mod:`cornerbif.models.map2d.maps`).
        beta and gamma are the same in both.

    Returns
    -------
    Q : (2, 2) ndarray
        s [[1, 0], [pi omega1/2, 1]] with s = r (beta, gamma) or -r^2 (alpha), eq (57).
    P : (2,) ndarray
        P_beta = (1+r) (2, pi omega1/2 - kappa1) (eqs 34-35),
        P_gamma = -(1+r) (2, pi omega1/2 + kappa1) (eqs 37-38), P_alpha as above.
    """
    name = _map_name(name)
    variant = _variant(variant)
    h = 0.5 * math.pi * omega1
    if name == "beta":
        s, P = r, [2.0 * (1.0 + r), (1.0 + r) * (h - kappa1)]
    elif name == "gamma":
        s, P = r, [-2.0 * (1.0 + r), -(1.0 + r) * (h + kappa1)]
    elif variant == "derived":
        s, P = -r * r, [2.0 * (1.0 + r) ** 2, h * (1.0 + r) ** 2 + kappa1 * (r * r - 1.0)]
    else:
        s, P = -r * r, [2.0 * (1.0 + r * r), r * h * (1.0 + r * r) + kappa1 * (r * r - 1.0)]
    Q = s * _np.array([[1.0, 0.0], [h, 1.0]])
    return Q, _np.array(P, dtype=float)


def kappa_dot(name: str, omega1: float, r: float) -> float:
    """kappa_. = pi omega1 a_.*/4, eq (62), with a_.* the fixed point's a.

    kappa_alpha = pi omega1 (1+r)^2/(2 (1+r^2)), kappa_beta = pi omega1 (1+r)/(2 (1-r)),
    kappa_gamma = -kappa_beta.  kappa_beta and kappa_alpha are the linearised
    corner curves (68), (69) (= theta_beta omega1, theta_alpha omega1, section 5.3.1).
    """
    name = _map_name(name)
    if name == "alpha":
        a = 2.0 * (1.0 + r) ** 2 / (1.0 + r * r)
    elif name == "beta":
        a = 2.0 * (1.0 + r) / (1.0 - r)
    else:
        a = -2.0 * (1.0 + r) / (1.0 - r)
    return 0.25 * math.pi * omega1 * a


def fixed_point(name: str, omega1: float, kappa1: float, r: float) -> _np.ndarray:
    """Fixed point x* = (I - Q)^{-1} P (eq 61) in the closed forms (63)-(65).

    x_alpha* = (2 (1+r)^2/(1+r^2), (1-r^2)/(1+r^2) (kappa_alpha - kappa1))  (63)
    x_beta*  = (2 (1+r)/(1-r),     (1+r)/(1-r) (kappa_beta - kappa1))       (64)
    x_gamma* = (-2 (1+r)/(1-r),    (1+r)/(1-r) (kappa_gamma - kappa1))      (65)

    with kappa_. from (62) (:func:`kappa_dot`).  (63) is the fixed point of the
    alpha map of (52)-(53); it is not the fixed point of the printed (58).
    Each map is taken on the whole plane; whether x* lies in its own region is
    :func:`compatibility`.
    """
    name = _map_name(name)
    k = kappa_dot(name, omega1, r)
    if name == "alpha":
        return _np.array([2.0 * (1.0 + r) ** 2 / (1.0 + r * r),
                          (1.0 - r * r) / (1.0 + r * r) * (k - kappa1)])
    f = (1.0 + r) / (1.0 - r)
    a = 2.0 * f if name == "beta" else -2.0 * f
    return _np.array([a, f * (k - kappa1)])


def compatibility(name: str, omega1: float, kappa1: float, r: float) -> float:
    """c = C x* - kappa1 = pi omega1 a*/4 + b* - kappa1 (section 5.2), computed directly.

    x_beta* exists (lies in S_beta) iff c > 0; x_alpha* iff c < 0 (and a* < E,
    which holds for every r); x_gamma* never (a* < 0).
    """
    a, b = fixed_point(name, omega1, kappa1, r)
    return 0.25 * math.pi * omega1 * a + b - kappa1


def c_beta(omega1: float, kappa1: float, r: float) -> float:
    """c_beta = 2/(1-r) (kappa_beta - kappa1), section 5.2 (checked against :func:`compatibility`).

    c_beta > 0 iff kappa1 < pi omega1 (1+r)/(2 (1-r)) (eq 68), the linearisation
    of (13).
    """
    return 2.0 / (1.0 - r) * (kappa_dot("beta", omega1, r) - kappa1)


def c_alpha(omega1: float, kappa1: float, r: float) -> float:
    """c_alpha = 2/(1+r^2) (kappa_alpha - kappa1), section 5.2 (checked against :func:`compatibility`).

    c_alpha < 0 iff kappa1 > pi omega1 (1+r)^2/(2 (1+r^2)) (eq 69), the
    linearisation of (19).
    """
    return 2.0 / (1.0 + r * r) * (kappa_dot("alpha", omega1, r) - kappa1)


def theta_beta(r: float) -> float:
    """theta_beta = pi (1+r)/(2 (1-r)) (section 5.3.1): the beta fixed point exists for
    kappa1 < theta_beta omega1."""
    return math.pi * (1.0 + r) / (2.0 * (1.0 - r))


def theta_alpha(r: float) -> float:
    """theta_alpha = pi (1+r)^2/(2 (1+r^2)) (section 5.3.1): the alpha fixed point exists for
    kappa1 > theta_alpha omega1."""
    return math.pi * (1.0 + r) ** 2 / (2.0 * (1.0 + r * r))


def corner_lines(omega1: float, r: float) -> tuple[float, float]:
    """Linearised corner curves (theta_beta omega1, theta_alpha omega1), eqs (68)-(69).

    They are the tangents at (omega, kappa) = (2, 0) of kappa_C(omega) (11) and
    kappa_CC(omega) (17): cot(pi/(2 + omega1)) = pi omega1/4 + O(omega1^2).
    """
    return theta_beta(r) * omega1, theta_alpha(r) * omega1


# ---------------------------------------------------------------------------
# Section 3.3: single and double impact period-T orbits
# ---------------------------------------------------------------------------
def single_impact_orbit(omega: float, kappa: float, r: float, beta: float = 1.0,
                        exact: bool = False) -> tuple[float, float, float]:
    """Single-impact period-T orbit (a, b, tau) of eq (10) for z = kappa + beta |sin omega t|.

    T = 2 pi/omega, t0 = pi/omega; (a, b) = (u(0), u'(0)) and tau in (t0, T) is
    the impact time.  Eq (10) with slope s and height h at the impact reads

        (a, b) = s (1+r)/(1-r) ((sin tau - sin(tau-T)), (cos(tau-T) - cos tau))/(1 - cos T),
        h = s (1+r)/(1-r) cot(T/2).

    Parameters
    ----------
    exact : bool
        False (the paper's eq 10): the obstacle is its corner approximation (7),
        s = theta2 = beta omega, h = kappa + theta2 (tau - t0), so
        tau = t0 + (kappa_C - kappa)/theta2.
        True: the rectified sine itself, s = z'(tau), h = z(tau); with
        phi = omega tau - pi this is beta (omega K cos phi - sin phi) = kappa,
        K = (1+r)/(1-r) cot(pi/omega), solved in closed form (the branch with
        phi = 0 at kappa = kappa_C).  This orbit is an exact fixed point of the
        flow's Poincare map (as long as the free flight does not touch z
        elsewhere, which is not checked).

    Returns
    -------
    (a, b, tau) : floats, all NaN where the orbit does not exist (kappa > kappa_C,
        eq 13, i.e. tau < t0).  At kappa = kappa_C: tau = t0, b = 0 and a as in (12).
    """
    T = 2.0 * math.pi / omega
    t0 = 0.5 * T
    K = (1.0 + r) / (1.0 - r) / math.tan(t0)
    if not exact:
        s = beta * omega
        tau = t0 + (s * K - kappa) / s
        if not tau >= t0:
            return math.nan, math.nan, math.nan
    else:
        wk = omega * K
        R = math.hypot(wk, 1.0)
        psi = math.atan2(1.0, wk)
        x = kappa / (beta * R)
        if not -1.0 < x <= 1.0:
            return math.nan, math.nan, math.nan
        phi = math.acos(x) - psi
        if not phi >= 0.0 or phi >= math.pi:
            return math.nan, math.nan, math.nan
        tau = (math.pi + phi) / omega
        s = beta * omega * math.cos(phi)
    f = s * (1.0 + r) / (1.0 - r) / (1.0 - math.cos(T))
    a = f * (math.sin(tau) - math.sin(tau - T))
    b = f * (math.cos(tau - T) - math.cos(tau))
    return a, b, tau


def double_impact_kappa(omega: float, tau_minus: float, tau_plus: float, r: float,
                        theta1: float, theta2: float, variant: str = "derived") -> float:
    """kappa of the double-impact period-T orbit with impacts at tau-, tau+ (eqs 14, 18).

    With T = 2 pi/omega, t0 = pi/omega, L = T + tau- - tau+ (the free flight from
    the second impact to the next first impact) and c = cos L:

        kappa = (theta2 + r theta1)(1+r)/(1+r^2) cot(L/2)
                - [theta1 (1 - r^2 c)(t0 - tau-) + theta2 (r^2 - c)(tau+ - t0)]/((1+r^2)(1 - c)).

    Derivation: with constant velocity between the two close impacts, law (5)
    twice gives v_out = (1+r)(theta2 + r theta1) + r^2 v_in; the free flight of
    length L takes (h2, v_out) to (h1, v_in), h1 = kappa + theta1 (t0 - tau-),
    h2 = kappa + theta2 (tau+ - t0); eliminating v_in, v_out gives the formula
    (it equals the solution of the paper's first four equations of section
    3.3.2, tested).  The printed (14) has "+" before the second term and (18)
    writes c_{pi/omega + tau- - tau+}; ``variant="printed"`` returns the printed
    (14) for comparison.  At tau- = tau+ = t0 this is kappa_CC, eq (17).
    The fifth equation (the linear flight between the impacts) is a relation
    between tau- and tau+ and is not used here.
    """
    variant = _variant(variant)
    T = 2.0 * math.pi / omega
    t0 = 0.5 * T
    L = T + tau_minus - tau_plus
    c = math.cos(L)
    r2 = r * r
    first = (theta2 + r * theta1) * (1.0 + r) / (1.0 + r2) / math.tan(0.5 * L)
    second = ((theta1 * (1.0 - r2 * c) * (t0 - tau_minus) + theta2 * (r2 - c) * (tau_plus - t0))
              / ((1.0 + r2) * (1.0 - c)))
    return first - second if variant == "derived" else first + second


# ---------------------------------------------------------------------------
# Sections 5.3-5.4: cycles of the piecewise-linear map, words, period adding
# ---------------------------------------------------------------------------
# the words' grammar and W are analysis.parse_word and analysis.winding_number (imported above)


def _orbit(letters, Qs, Ps):
    """Periodic orbit of x_{i+1} = Q_i x_i + P_i (indices mod len): iterates (L, 2)."""
    M = _np.eye(2)
    c = _np.zeros(2)
    for ch in letters:
        M = Qs[ch] @ M
        c = Qs[ch] @ c + Ps[ch]
    x = _np.empty((len(letters), 2))
    x[0] = _np.linalg.solve(_np.eye(2) - M, c)
    for i in range(1, len(letters)):
        ch = letters[i - 1]
        x[i] = Qs[ch] @ x[i - 1] + Ps[ch]
    return x


def _letter_matrices(omega1, kappa1, r, variant):
    Qs, Ps = {}, {}
    for ch in "abg":
        Qs[ch], Ps[ch] = map_matrices(ch, omega1, kappa1, r, variant)
    return Qs, Ps


def _admissible_point(ch, a, b, omega1, kappa1, r, margin):
    """Strict check that x = (a, b) lies in the region named by ch (see word_orbit)."""
    from .models.map2d.maps import LETTERS, region  # start-up: loads numba

    k = region(float(a), float(b), float(omega1), float(kappa1), float(r))
    if k < 0 or LETTERS[k] != ch:
        return False
    c = 0.25 * math.pi * omega1 * a + b - kappa1
    e = 2.0 + 4.0 / r
    if ch == "b":
        return c > margin
    if ch == "a":
        return c < -margin and a < e - margin
    return c < -margin and a > e + margin


def word_orbit(word: str, omega1: float, kappa1: float, r: float, margin: float = 0.0,
               variant: str = "derived") -> tuple[_np.ndarray, bool]:
    """The periodic orbit of the map (56) with a given symbol word, and its admissibility.

    Composes the affine maps of the word's letters (x_{i+1} = Q_i x_i + P_i,
    :func:`map_matrices`), solves x0 = M x0 + c for the composition (section
    5.3.2: e.g. x = Q_beta (Q_alpha x + P_alpha) + P_beta for (alpha beta)) and
    returns every iterate.  I - M is invertible for 0 <= r < 1 (M = m [[1,0],[l,1]]
    with |m| < 1).

    Parameters
    ----------
    word : str
        Letters a/b/g, optionally with exponents ('b^11 g', 'b11 g b12 g');
        letter i is the map applied to iterate i.
    margin : float
        Admissibility margin (>= 0): iterate i must satisfy, strictly,
        'b': C x - kappa1 > margin; 'a': C x - kappa1 < -margin and a < E - margin;
        'g': C x - kappa1 < -margin and a > E + margin, besides
        :func:`cornerbif.models.map2d.maps.region` naming its letter.  With margin = 0 these
        are the strict inequalities of (56): an orbit with a point on a switching
        line is not admissible (it sits at a bifurcation).
    variant : {'derived', 'printed'}
        Which P_alpha (see :func:`map_matrices`).

    Returns
    -------
    x : (len(word), 2) ndarray
        The iterates (a, b); x[i + 1] = letter_i map of x[i], x[0] = last map of x[-1].
    admissible : bool
        True iff every iterate lies in the region its letter names.

    Notes
    -----
    With the derived P_alpha the cycles of section 5.3.2 have a-values
    (alpha beta): 2 (1+r+r^2, 1+r-r^2)/(1-r+r^2) and (alpha beta gamma):
    2 (r^4+2r^3+2r^2-1, 1+2r+2r^2-r^4, 1+2r+2r^2+2r^3+r^4)/(1+r^4); the values
    printed there follow from the printed (58).
    """
    letters = parse_word(word)
    Qs, Ps = _letter_matrices(omega1, kappa1, r, variant)
    x = _orbit(letters, Qs, Ps)
    ok = all(_admissible_point(ch, xi[0], xi[1], omega1, kappa1, r, margin)
             for ch, xi in zip(letters, x))
    return x, bool(ok)


def word_interval(word: str, omega1: float, r: float, margin: float = 0.0,
                  variant: str = "derived") -> tuple[float, float]:
    """Open interval of kappa1 on which the cycle ``word`` is admissible (exact for the map 56).

    Q does not depend on kappa1 and P is affine in it, so every iterate of the
    cycle is affine in kappa1 and a does not depend on it: the conditions of
    :func:`word_orbit` are linear inequalities in kappa1 and the admissible set
    is an interval.  Returns (lo, hi) (possibly infinite), or (nan, nan) if empty.
    Points of the interval are admissible up to rounding at its ends.
    """
    letters = parse_word(word)
    Qs, P0 = _letter_matrices(omega1, 0.0, r, variant)
    _, P1 = _letter_matrices(omega1, 1.0, r, variant)
    dP = {ch: P1[ch] - P0[ch] for ch in "abg"}
    x0 = _orbit(letters, Qs, P0)   # kappa1 = 0
    dx = _orbit(letters, Qs, dP)   # d x / d kappa1
    q = 0.25 * math.pi * omega1
    e = 2.0 + 4.0 / r
    lo, hi = -math.inf, math.inf
    for ch, xi, di in zip(letters, x0, dx):
        c0 = q * xi[0] + xi[1]          # c(kappa1) = c0 + slope kappa1
        slope = q * di[0] + di[1] - 1.0
        if ch == "b":      # c > margin
            bound, upper = margin - c0, slope < 0
        else:              # c < -margin
            bound, upper = -margin - c0, slope > 0
            if ch == "a" and not xi[0] < e - margin:
                return math.nan, math.nan
            if ch == "g" and not xi[0] > e + margin:
                return math.nan, math.nan
        if slope == 0.0:
            if (ch == "b" and not c0 > margin) or (ch != "b" and not c0 < -margin):
                return math.nan, math.nan
            continue
        k = bound / slope
        if upper:
            hi = min(hi, k)
        else:
            lo = max(lo, k)
    if not lo < hi:
        return math.nan, math.nan
    return lo, hi


def _K(n, omega1, r, order=1):
    """K_n = -2 pi omega1 (1+r) n r^n (order 1) or with (n + 1) for n (order 2), section 5.4."""
    m = n if order == 1 else n + 1
    return -2.0 * math.pi * omega1 * (1.0 + r) * m * r ** n


def _check_pa(omega1, r, order):
    if not (omega1 < 0.0 and 0.0 < r < 1.0):
        raise ValueError(f"period adding (section 5.4) needs omega1 < 0 and 0 < r < 1; got {omega1}, {r}")
    if order not in (1, 2):
        raise ValueError(f"order must be 1 or 2, got {order!r}")


def period_adding_N(delta: float, omega1: float, r: float, order: int = 1) -> int:
    """N of the (beta^N gamma) orbit at kappa1 = kappa_beta + delta (section 5.4, r > phi).

    Derivation (corrected constants).  From T = {a = a_beta*, |b| < delta} the
    gamma map gives a0 - a_beta* = (r - 1) a_beta* - 2 (1+r) = -4 (1+r), and by
    (66)-(67) the distance to Sigma_1 after n beta steps is, by (70),

        c_n = c_beta + r^n [pi omega1 (1 + 2n)(a0 - a*)/4 + (b0 - b*)],
        c_beta = -2 delta/(1-r).

    order=1 (the paper's leading order): keep only the n r^n term,
    c_n = K_n - 2 delta/(1-r) with K_n = -2 pi omega1 (1+r) n r^n.  (In the paper's
    b_N line the factor 1/2 is spurious, and its closing estimate
    "-2 N r^N pi omega1 = 2 delta/(1-r)" has lost the factor (1 + r).)
    order=2: keep all three terms at delta -> 0, where b0 - b* -> -pi omega1 (1+r)
    (the image x_gamma** of section 5.4): K_n = -2 pi omega1 (1+r) (n+1) r^n.
    The orbit leaves S_beta at the first n (past the maximum of K_n) with
    c_n <= 0, i.e. K_n <= 2 delta/(1-r).  W = 1/(N+1).

    Against the exact intervals of :func:`word_interval` (omega1 = -0.001,
    r = 0.8), exact/estimate for the interval ends is 1.26 at N = 11 and 1.035
    at N = 30 for order 1 (error ~ 1/N), 1.15 and 1.002 for order 2 (error
    ~ 1/N^2; the terms left out are O(delta)).

    Returns
    -------
    int
        N; raises ValueError unless omega1 < 0, 0 < r < 1 and delta > 0.
    """
    _check_pa(omega1, r, order)
    if not delta > 0.0:
        raise ValueError(f"period_adding_N needs delta = kappa1 - kappa_beta > 0, got {delta}")
    X = 2.0 * delta / (1.0 - r)
    n_top = 1.0 / math.log(1.0 / r) - (order - 1)   # maximum of K_n over real n
    n = max(1, math.ceil(n_top))
    while _K(n, omega1, r, order) > X:
        n += 1
    return n


def period_adding_interval(N: int, omega1: float, r: float, order: int = 1) -> tuple[float, float]:
    """delta interval I_N = [delta_{N+1}, delta_N) of the (beta^N gamma) orbit (section 5.4).

    delta_{N+1} = (1-r) K_N/2 and delta_N = (1-r) K_{N-1}/2 with K_N of
    :func:`period_adding_N` (order 1: K_N = -2 pi omega1 (1+r) N r^N), so that
    the intervals tile (0, ...) without gaps and delta_{N+1}/delta_N -> r.
    The paper's upper end (1-r) K_N/(2 r) (from b_N >= -delta) equals delta_N
    up to a factor N/(N-1), so its intervals overlap and "delta_{N+1} =
    r delta_N" holds only as N -> infinity.  kappa1 = kappa_beta + delta.
    """
    _check_pa(omega1, r, order)
    return (0.5 * (1.0 - r) * _K(N, omega1, r, order),
            0.5 * (1.0 - r) * _K(N - 1, omega1, r, order))
