"""Basin statistics worth publishing: the share of random starts that reach an attractor with
its confidence interval, the basin entropy of a label image, and the uncertainty exponent.

Pure numpy and the standard library (no numba, no scipy, nothing else of cornerbif), so a
figure script or a notebook may use it on any array of labels:

* ``share_interval``: Wilson's (1927) score interval or Clopper and Pearson's (1934) exact
  interval for a share count/total of independent starts, right for rare basins (count 0);
* ``basin_entropy``: the basin entropy Sb and boundary basin entropy Sbb of Daza,
  Wagemakers, Georgeot, Guéry-Odelin and Sanjuán (2016);
* ``uncertainty_exponent``: the exponent alpha of f(eps) ~ eps^alpha of Grebogi, McDonald,
  Ott and Yorke (1983), from the fraction of eps-uncertain cells of a label grid.

A label is any integer: attractor ids and negative outcome codes alike, each its own outcome.
"""

from __future__ import annotations

import math
from statistics import NormalDist

import numpy as np

METHODS = ("wilson", "clopper-pearson")


# ------------------------------------------------------------------ share intervals
def share_interval(count, total, confidence=0.95, method="wilson"):
    """(low, high): a two-sided ``confidence`` interval for the share p of starts that reach
    an outcome, from ``count`` of ``total`` independent random starts (Binomial(total, p)).

    ``method="wilson"``: the score interval of E. B. Wilson, "Probable inference, the law of
    succession, and statistical inference", J. Am. Stat. Assoc. 22, 209 (1927): the p with
    (k/n - p)^2 = z^2 p (1 - p) / n, z the normal quantile at 1 - alpha/2, that is

        (k + z^2/2 -+ z sqrt(k (n - k) / n + z^2 / 4)) / (n + z^2).

    ``method="clopper-pearson"``: the exact interval of C. J. Clopper and E. S. Pearson, "The
    use of confidence or fiducial limits illustrated in the case of the binomial",
    Biometrika 26, 404 (1934): low solves P(X >= k | low) = alpha/2 and high solves
    P(X <= k | high) = alpha/2, i.e. the beta quantiles low = B^-1(alpha/2; k, n - k + 1) and
    high = B^-1(1 - alpha/2; k + 1, n - k); conservative (coverage >= confidence).

    Both give low = 0 at k = 0 and high = 1 at k = n (Clopper-Pearson's high at k = 0 is
    1 - (alpha/2)^(1/n)).  ``count`` and ``total`` may be arrays (broadcast); the result is
    then a pair of arrays, else a pair of floats.  Bad input raises ValueError naming the
    argument.
    """
    k, n = _checked_counts(count, total)
    alpha = 1.0 - _checked_confidence(confidence)
    if method == "wilson":
        low, high = _wilson(k, n, normal_quantile(1.0 - alpha / 2.0))
    elif method == "clopper-pearson":
        low, high = _clopper_pearson(k, n, alpha)
    else:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got method={method!r}")
    if low.ndim == 0:
        return float(low), float(high)
    return low, high


def normal_quantile(p: float) -> float:
    """The standard normal quantile Phi^-1(p), by the standard library's
    ``statistics.NormalDist().inv_cdf``: M. J. Wichura, "Algorithm AS 241: the percentage
    points of the normal distribution", Appl. Stat. 37, 477 (1988), good to about 1e-16
    (z(0.975) = 1.959963984540054)."""
    return NormalDist().inv_cdf(p)


def _checked_counts(count, total):
    k = np.asarray(count)
    n = np.asarray(total)
    for name, v in (("count", k), ("total", n)):
        if v.dtype.kind == "f":
            bad = ~(np.isfinite(v) & (v == np.floor(v)))
            if np.any(bad):
                raise ValueError(f"{name} must be a whole number of starts, got {name}={_first(v, bad)}")
        elif v.dtype.kind not in "iub":
            raise ValueError(f"{name} must be a whole number of starts, got {name}={v!r}")
    k, n = np.broadcast_arrays(k.astype(np.int64), n.astype(np.int64))
    if np.any(n <= 0):
        raise ValueError(f"total must be at least 1, got total={_first(n, n <= 0)}")
    if np.any(k < 0):
        raise ValueError(f"count must not be negative, got count={_first(k, k < 0)}")
    if np.any(k > n):
        bad = np.argmax(k > n)
        raise ValueError(f"count must not exceed total, got count={k.flat[bad]} with total={n.flat[bad]}")
    return k, n


def _first(values, bad):
    """The first offending value of an array, for a message."""
    return np.asarray(values).flat[int(np.argmax(np.asarray(bad)))]


def _checked_confidence(confidence) -> float:
    try:
        c = float(confidence)
    except (TypeError, ValueError):
        c = math.nan
    if not 0.0 < c < 1.0:
        raise ValueError(f"confidence must lie strictly between 0 and 1, got confidence={confidence!r}")
    return c


def _wilson(k, n, z):
    """Wilson's (1927) score interval in closed form (see ``share_interval``); the ends at
    k = 0 and k = n are set to 0 and 1 exactly (the closed form gives them up to rounding)."""
    k = k.astype(float)
    n = n.astype(float)
    centre = (k + z * z / 2.0) / (n + z * z)
    half = z * np.sqrt(k * (n - k) / n + z * z / 4.0) / (n + z * z)
    low = np.where(k == 0, 0.0, np.clip(centre - half, 0.0, 1.0))
    high = np.where(k == n, 1.0, np.clip(centre + half, 0.0, 1.0))
    return low, high


def _clopper_pearson(k, n, alpha):
    """Clopper and Pearson's (1934) exact interval as beta quantiles, one bisection per
    distinct (count, total) pair."""
    pairs, where = np.unique(np.stack([k.ravel(), n.ravel()], axis=1), axis=0, return_inverse=True)
    ends = np.array([_clopper_pearson_one(int(kk), int(nn), alpha) for kk, nn in pairs]).reshape(-1, 2)
    where = np.asarray(where).ravel()
    return ends[where, 0].reshape(k.shape), ends[where, 1].reshape(k.shape)


def _clopper_pearson_one(k: int, n: int, alpha: float):
    low = 0.0 if k == 0 else beta_quantile(alpha / 2.0, k, n - k + 1)
    high = 1.0 if k == n else beta_quantile(1.0 - alpha / 2.0, k + 1, n - k)
    return low, high


def beta_quantile(prob: float, a: float, b: float) -> float:
    """The x in [0, 1] with I_x(a, b) = prob, by bisection on the regularized incomplete beta
    function (increasing in x) until the bracket is two neighbouring floats; at most ~1100
    halvings, about 60 for a quantile above 1e-3."""
    lo, hi = 0.0, 1.0
    while True:
        mid = 0.5 * (lo + hi)
        if mid <= lo or mid >= hi:
            return mid
        if regularized_beta(mid, a, b) < prob:
            lo = mid
        else:
            hi = mid


def regularized_beta(x: float, a: float, b: float) -> float:
    """The regularized incomplete beta function I_x(a, b) = B(x; a, b) / B(a, b), a, b > 0:
    W. H. Press, S. A. Teukolsky, W. T. Vetterling, B. P. Flannery, Numerical Recipes, 3rd
    ed. (2007), section 6.4: the prefactor x^a (1 - x)^b / B(a, b) (by ``math.lgamma``) times
    the continued fraction eq. (6.4.5), taken as is for x < (a + 1)/(a + b + 2) and through
    the symmetry I_x(a, b) = 1 - I_{1-x}(b, a) beyond, where it converges fast.  The
    lgamma difference loses about 1e-16 lgamma(a + b) absolutely, so the result is good to
    ~1e-13 for a + b ~ 1e4 and ~1e-11 for a + b ~ 1e6 (checked against mpmath), far below
    any sampling error of a share."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    front = math.exp(math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b)
                     + a * math.log(x) + b * math.log1p(-x))
    if x < (a + 1.0) / (a + b + 2.0):
        return front * beta_continued_fraction(x, a, b) / a
    return 1.0 - front * beta_continued_fraction(1.0 - x, b, a) / b


def beta_continued_fraction(x: float, a: float, b: float) -> float:
    """The continued fraction of the incomplete beta function, Numerical Recipes (2007)
    eqs. (6.4.5)-(6.4.6) (``betacf``), by the modified Lentz method (section 5.2); it needs
    O(sqrt(max(a, b))) terms, and raises ArithmeticError if it has not converged by far more."""
    tiny, eps = 1e-300, 3e-16          # NR's FPMIN; just over the float epsilon
    qab, qap, qam = a + b, a + 1.0, a - 1.0
    c, d = 1.0, 1.0 - qab * x / qap
    d = 1.0 / (d if abs(d) > tiny else tiny)
    h = d
    for m in range(1, 1000 + int(20.0 * math.sqrt(max(a, b)))):
        m2 = 2 * m
        for coeff in (m * (b - m) * x / ((qam + m2) * (a + m2)),             # d_2m
                      -(a + m) * (qab + m) * x / ((a + m2) * (qap + m2))):   # d_2m+1
            d = 1.0 + coeff * d
            d = 1.0 / (d if abs(d) > tiny else tiny)
            c = 1.0 + coeff / c
            c = c if abs(c) > tiny else tiny
            step = d * c
            h *= step
        if abs(step - 1.0) < eps:
            return h
    raise ArithmeticError(f"the incomplete beta continued fraction did not converge (x={x}, a={a}, b={b})")


# ------------------------------------------------------------------ basin entropy
def basin_entropy(labels, box=5):
    """(Sb, Sbb, n_boundary_boxes): the basin entropy and the boundary basin entropy of A.
    Daza, A. Wagemakers, B. Georgeot, D. Guéry-Odelin, M. A. F. Sanjuán, "Basin entropy: a
    new tool to analyze uncertainty in dynamical systems", Sci. Rep. 6, 31416 (2016).

    ``labels`` (a 1-D or 2-D integer array, one outcome per start; each distinct value is its
    own outcome, negative codes included) is covered by non-overlapping boxes of ``box``
    cells along every axis, trailing partial rows/columns dropped.  In box i the Gibbs
    entropy S_i = sum_j p_ij log(1/p_ij) (natural log) over the labels j present, p_ij their
    shares; Sb = (1/N) sum_i S_i over all N boxes and Sbb = (1/N_b) sum_i S_i over the N_b
    boxes with more than one label, the boxes on a boundary (Sbb > log 2 is the paper's
    sufficient condition for a fractal boundary).  Sbb is NaN when no box is on a boundary.

    The shares are plug-in estimates from box**D starts, so S_i is biased low by about
    (m_i - 1) / (2 box**D) for m_i labels (Miller 1955); compare basins at one box size.
    """
    labels = _checked_labels(labels, "labels", dims=(1, 2))
    box = _checked_box(box, labels.shape)
    entropy, n_labels = box_entropies(box_cells(labels, box))
    on_boundary = n_labels > 1
    n_boundary = int(on_boundary.sum())
    sbb = float(entropy[on_boundary].mean()) if n_boundary else math.nan
    return float(entropy.mean()), sbb, n_boundary


def box_cells(labels: np.ndarray, box: int) -> np.ndarray:
    """The labels regrouped as one row per box of ``box`` cells along every axis
    (row-major over the boxes), trailing partial boxes dropped."""
    counts = [n // box for n in labels.shape]
    whole = labels[tuple(slice(0, m * box) for m in counts)]
    split = whole.reshape([v for m in counts for v in (m, box)])
    dims = labels.ndim
    order = list(range(0, 2 * dims, 2)) + list(range(1, 2 * dims, 2))
    return split.transpose(order).reshape(math.prod(counts), box ** dims)


def box_entropies(cells: np.ndarray):
    """(S_i, m_i) per row of ``cells``: the Gibbs entropy sum_j p_ij log(1/p_ij) of the labels
    in the row (Daza et al. 2016) and how many distinct labels it holds."""
    n_boxes, size = cells.shape
    _, code = np.unique(cells, return_inverse=True)
    n_codes = int(code.max()) + 1
    key = np.arange(n_boxes, dtype=np.int64)[:, None] * n_codes + code.reshape(n_boxes, size)
    present, counts = np.unique(key, return_counts=True)
    owner = present // n_codes
    p = counts / size
    entropy = np.bincount(owner, weights=-p * np.log(p), minlength=n_boxes)
    return entropy, np.bincount(owner, minlength=n_boxes)


def _checked_labels(labels, name, dims):
    a = np.asarray(labels)
    if a.ndim not in dims:
        raise ValueError(f"{name} must be a {' or '.join(f'{d}-D' for d in dims)} array, "
                         f"got {name} of shape {a.shape}")
    if a.dtype.kind not in "iub":
        raise ValueError(f"{name} must hold integer labels, got {name} of dtype {a.dtype}")
    return a


def _checked_box(box, shape):
    if isinstance(box, bool) or not isinstance(box, (int, np.integer)) or box < 1:
        raise ValueError(f"box must be a positive whole number of cells, got box={box!r}")
    if min(shape) < box:
        raise ValueError(f"box={box} is larger than the labels (shape {shape}): no whole box")
    return int(box)


# ------------------------------------------------------------------ uncertainty exponent
def uncertainty_exponent(labels, eps_cells=None):
    """(alpha, alpha_stderr, eps, fraction): the uncertainty exponent of C. Grebogi, S. W.
    McDonald, E. Ott, J. A. Yorke, "Final state sensitivity: an obstruction to
    predictability", Phys. Lett. A 99, 415 (1983): the fraction f(eps) of eps-uncertain
    starts scales as f ~ eps^alpha, with alpha = D - d for a boundary of box-counting
    dimension d in D dimensions (alpha = 1 for a smooth boundary, alpha -> 0 as it fills
    space).

    ``labels`` is a 1-D or 2-D integer grid, one start per cell.  A cell is eps-uncertain when
    its label differs from that of a cell ``eps`` cells away along some axis (offsets +-eps
    along each axis).  f(eps) is counted over one fixed set of cells for every eps, those at
    least max(eps) cells from every edge (whose neighbourhoods stay on the grid at every
    eps): a sample that shrank with eps would bias alpha upward (for a straight boundary
    across a 400-cell axis and eps = 1..64, from 1 to 1.08).  ``eps_cells`` defaults to
    1, 2, 4, ... up to a quarter of the shortest axis.

    alpha is the least-squares slope of log f against log eps, alpha_stderr its standard
    error from the regression residuals (NaN with only two points).  Points where f = 0 (no
    uncertain cell, e.g. no boundary in the sample at small eps) have no logarithm: they are
    left out of the fit, and alpha is NaN when fewer than two points remain.  ``eps`` and
    ``fraction`` are returned in full, zeros included.
    """
    labels = _checked_labels(labels, "labels", dims=(1, 2))
    eps = _checked_eps(eps_cells, labels.shape)
    margin = int(eps.max()) if eps.size else 0
    fraction = np.array([uncertain_fraction(labels, int(e), margin) for e in eps])
    alpha, stderr = log_log_slope(eps, fraction)
    return alpha, stderr, eps, fraction


def uncertain_fraction(labels: np.ndarray, eps: int, margin: int) -> float:
    """The share of the cells at least ``margin`` (>= eps) cells from every edge whose label
    differs from the label ``eps`` cells away along some axis, either way (Grebogi et al.
    1983's eps-uncertain starts)."""
    centre = tuple(slice(margin, n - margin) for n in labels.shape)
    own = labels[centre]
    uncertain = np.zeros(own.shape, dtype=bool)
    for axis, n in enumerate(labels.shape):
        for shift in (eps, -eps):
            moved = list(centre)
            moved[axis] = slice(margin + shift, n - margin + shift)
            uncertain |= labels[tuple(moved)] != own
    return float(uncertain.mean())


def log_log_slope(eps, fraction):
    """(slope, standard error) of the least-squares line log f = c + alpha log eps over the
    points with f > 0; the standard error is sqrt(sum r^2 / (n - 2) / sum (x - mean x)^2)
    from the residuals r (NaN for n = 2), and both are NaN for fewer than two points."""
    keep = np.asarray(fraction) > 0
    x = np.log(np.asarray(eps, dtype=float)[keep])
    y = np.log(np.asarray(fraction, dtype=float)[keep])
    if x.size < 2:
        return math.nan, math.nan
    dx = x - x.mean()
    slope = float(dx @ (y - y.mean()) / (dx @ dx))
    if x.size == 2:
        return slope, math.nan
    residual = y - y.mean() - slope * dx
    return slope, float(math.sqrt(residual @ residual / (x.size - 2) / (dx @ dx)))


def _checked_eps(eps_cells, shape):
    shortest = min(shape)
    if eps_cells is None:
        return np.array([2 ** i for i in range(shortest.bit_length()) if 2 ** i <= shortest // 4],
                        dtype=np.int64)
    eps = np.atleast_1d(np.asarray(eps_cells))
    if eps.ndim != 1 or eps.size == 0 or eps.dtype.kind not in "iu" or np.any(eps < 1):
        raise ValueError(f"eps_cells must be positive whole numbers of cells, got eps_cells={eps_cells!r}")
    if 2 * int(eps.max()) >= shortest:
        raise ValueError(f"eps_cells={eps_cells!r} reaches past the grid: 2 * max(eps_cells) must be "
                         f"below the shortest axis ({shortest} cells)")
    return eps.astype(np.int64)


def t_quantile(p: float, dof: int) -> float:
    """The p-quantile (p >= 0.5) of Student's t distribution with ``dof`` degrees of freedom,
    by bisection on its upper tail P(T > t) = I_(dof / (dof + t^2))(dof / 2, 1 / 2) / 2
    (Abramowitz & Stegun 26.7.1 with 26.5.27), ``regularized_beta``."""
    if not 0.5 <= p < 1.0:
        raise ValueError(f"p={p!r}: must be in [0.5, 1)")
    if not (isinstance(dof, (int, np.integer)) and dof >= 1):
        raise ValueError(f"dof={dof!r}: must be a whole number >= 1")
    tail = 1.0 - p
    lo, hi = 0.0, 1.0
    while 0.5 * regularized_beta(dof / (dof + hi * hi), 0.5 * dof, 0.5) > tail:
        hi *= 2.0
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        if 0.5 * regularized_beta(dof / (dof + mid * mid), 0.5 * dof, 0.5) > tail:
            lo = mid
        else:
            hi = mid
        if hi - lo <= 1e-14 * hi:
            break
    return 0.5 * (lo + hi)


def mean_interval(values, confidence: float = 0.95) -> tuple:
    """The mean of independent estimates ``values`` (at least 2) and its Student-t
    confidence interval: mean -+ t_((1 + confidence) / 2, n - 1) s / sqrt(n)."""
    v = np.asarray(values, float)
    if v.ndim != 1 or v.size < 2 or not np.all(np.isfinite(v)):
        raise ValueError(f"values: {v.size} values, all finite and at least 2 needed")
    conf = _checked_confidence(confidence)
    m = float(v.mean())
    half = t_quantile(0.5 * (1.0 + conf), v.size - 1) * float(v.std(ddof=1)) / math.sqrt(v.size)
    return m, m - half, m + half
