"""Basin statistics (cornerbif/basin_stats.py): share intervals, basin entropy, uncertainty
exponent.  Each test names the number it expects and where that number comes from: a closed
form written out here, a sum of binomial probabilities done here independently of the module,
or a construction whose answer is known (a straight boundary, i.i.d. labels, a Cantor set).
"""

import math

import numpy as np
import pytest

from cornerbif.basin_stats import (
    basin_entropy,
    normal_quantile,
    regularized_beta,
    share_interval,
    uncertainty_exponent,
)

Z975 = 1.959963984540054        # the standard normal quantile at 0.975 (the two-sided 95% point)


def binomial_cdf(k, n, p):
    """P(X <= k) for X ~ Binomial(n, p), summed term by term (exact integer binomials)."""
    return math.fsum(math.comb(n, j) * p ** j * (1.0 - p) ** (n - j) for j in range(k + 1))


# ------------------------------------------------------------------ share intervals
def test_normal_quantile_is_the_tabulated_value():
    """z(0.975) = 1.959963984540054 to 1e-12, and z(0.025) = -z(0.975) (symmetry)."""
    assert abs(normal_quantile(0.975) - Z975) < 1e-12
    assert abs(normal_quantile(0.025) + Z975) < 1e-12


def test_wilson_7_of_20_is_the_closed_form():
    """Wilson (1927): (p + z^2/2n -+ z sqrt(p(1-p)/n + z^2/4n^2)) / (1 + z^2/n) with p = 7/20,
    n = 20, z = 1.959963984540054, i.e. (0.18119..., 0.56714...)."""
    n, p, z = 20, 7 / 20, Z975
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z / (1 + z * z / n) * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    low, high = share_interval(7, 20)
    assert low == pytest.approx(centre - half, abs=1e-12) and high == pytest.approx(centre + half, abs=1e-12)
    assert low == pytest.approx(0.18119182, abs=1e-8) and high == pytest.approx(0.56714572, abs=1e-8)


@pytest.mark.parametrize("n", [1, 20, 200, 10_000])
def test_wilson_at_none_and_all_of_n(n):
    """Wilson's closed form at k = 0 is (0, z^2 / (n + z^2)), at k = n (n / (n + z^2), 1):
    a rare basin seen in none of n starts still gets a non-zero upper end."""
    assert share_interval(0, n) == (0.0, pytest.approx(Z975 ** 2 / (n + Z975 ** 2), rel=1e-12))
    assert share_interval(n, n) == (pytest.approx(n / (n + Z975 ** 2), rel=1e-12), 1.0)


@pytest.mark.parametrize("n", [1, 20, 200, 10_000])
def test_clopper_pearson_at_none_and_all_of_n(n):
    """Clopper-Pearson at k = 0: P(X <= 0 | p) = (1 - p)^n = alpha/2 gives high = 1 - 0.025^(1/n);
    at k = n, low = 0.025^(1/n) (95%)."""
    low, high = share_interval(0, n, method="clopper-pearson")
    assert low == 0.0 and high == pytest.approx(1.0 - 0.025 ** (1.0 / n), rel=1e-12)
    low, high = share_interval(n, n, method="clopper-pearson")
    assert low == pytest.approx(0.025 ** (1.0 / n), rel=1e-12) and high == 1.0


@pytest.mark.parametrize("k,n", [(1, 20), (7, 20), (3, 200), (50, 200), (199, 200)])
def test_clopper_pearson_ends_solve_the_binomial_tails(k, n):
    """The definition (Clopper and Pearson 1934), checked by summing binomial probabilities
    here: P(X <= k | high) = 0.025 and P(X >= k | low) = 1 - P(X <= k-1 | low) = 0.025, to 1e-9."""
    low, high = share_interval(k, n, method="clopper-pearson")
    assert abs(binomial_cdf(k, n, high) - 0.025) < 1e-9
    assert abs(1.0 - binomial_cdf(k - 1, n, low) - 0.025) < 1e-9


def test_regularized_beta_closed_forms():
    """I_x(1, b) = 1 - (1 - x)^b and I_x(a, 1) = x^a (the integrals done by hand), to 1e-14."""
    for x in (1e-6, 0.1, 0.5, 0.97):
        assert regularized_beta(x, 1, 7.5) == pytest.approx(1 - (1 - x) ** 7.5, abs=1e-14)
        assert regularized_beta(x, 3.25, 1) == pytest.approx(x ** 3.25, abs=1e-14)


def test_coverage_for_a_rare_basin():
    """p = 0.01, N = 200 (two expected hits), 4000 draws with seed 20240611.  The exact
    coverage, summed here over the counts whose interval holds p, is 0.9483 (Wilson) and
    0.9840 (Clopper-Pearson, conservative); the simulation gives 0.949 and 0.98375.  Asserted:
    Wilson >= 0.93, Clopper-Pearson >= 0.95, and each within 4 binomial standard errors
    (sqrt(c (1 - c) / 4000) <= 0.0035) of its exact coverage."""
    p, n, draws = 0.01, 200, 4000
    counts = np.random.default_rng(20240611).binomial(n, p, draws)
    every = np.arange(n + 1)
    pmf = np.array([math.comb(n, k) * p ** k * (1 - p) ** (n - k) for k in every])
    for method, floor in (("wilson", 0.93), ("clopper-pearson", 0.95)):
        low, high = share_interval(counts, n, method=method)
        simulated = np.mean((low <= p) & (p <= high))
        low, high = share_interval(every, n, method=method)
        exact = pmf[(low <= p) & (p <= high)].sum()
        assert simulated >= floor, (method, simulated)
        assert abs(simulated - exact) < 4 * math.sqrt(exact * (1 - exact) / draws), (method, simulated, exact)


@pytest.mark.parametrize("method", ["wilson", "clopper-pearson"])
def test_intervals_are_vectorised(method):
    """Arrays of counts against one total (and broadcast totals) give, element by element,
    the scalar intervals, in the counts' shape."""
    counts = np.array([[0, 1, 2], [7, 19, 20]])
    low, high = share_interval(counts, 20, method=method)
    assert low.shape == high.shape == (2, 3)
    for k, lo, hi in zip(counts.ravel(), low.ravel(), high.ravel()):
        assert (lo, hi) == share_interval(int(k), 20, method=method)
    low, high = share_interval(3, np.array([10, 100]), method=method)
    assert (low[1], high[1]) == share_interval(3, 100, method=method)


@pytest.mark.parametrize("kwargs,named", [
    ({"count": 5, "total": 3}, "count=5"),
    ({"count": -1, "total": 3}, "count=-1"),
    ({"count": np.array([0, 2.5]), "total": 3}, "count=2.5"),
    ({"count": 0, "total": 0}, "total=0"),
    ({"count": 1, "total": 3, "confidence": 1.0}, "confidence=1.0"),
    ({"count": 1, "total": 3, "confidence": 0}, "confidence=0"),
    ({"count": 1, "total": 3, "confidence": float("nan")}, "confidence=nan"),
    ({"count": 1, "total": 3, "method": "exact"}, "method='exact'"),
])
def test_share_interval_refuses_bad_input_naming_it(kwargs, named):
    with pytest.raises(ValueError, match=named):
        share_interval(**kwargs)


# ------------------------------------------------------------------ basin entropy
@pytest.mark.parametrize("label", [3, -2])
def test_one_label_has_no_entropy(label):
    """A single outcome (an attractor id or a negative code): every box has S_i = 0, so
    Sb = 0 and there is no boundary box (Sbb undefined: NaN)."""
    sb, sbb, n_boundary = basin_entropy(np.full((100, 100), label), box=5)
    assert sb == 0.0 and math.isnan(sbb) and n_boundary == 0


def test_a_boundary_along_box_edges_is_in_no_box():
    """A straight boundary between columns 51 and 52 lies on the edge between 4-cell boxes:
    no box holds two labels (Sb = 0, no boundary box)."""
    labels = np.zeros((100, 100), dtype=int)
    labels[:, 52:] = -1
    sb, sbb, n_boundary = basin_entropy(labels, box=4)
    assert sb == 0.0 and math.isnan(sbb) and n_boundary == 0


def test_a_boundary_halving_a_column_of_boxes():
    """A straight boundary between columns 49 and 50 cuts each of the 25 boxes (of 625) in
    the column of boxes 48-51 in half: S = log 2 there, so Sbb = log 2 and
    Sb = (25 / 625) log 2 (Daza et al. 2016's averages)."""
    labels = np.zeros((100, 100), dtype=int)
    labels[:, 50:] = 1
    sb, sbb, n_boundary = basin_entropy(labels, box=4)
    assert n_boundary == 25
    assert sbb == pytest.approx(math.log(2), rel=1e-15) and sb == pytest.approx(math.log(2) / 25, rel=1e-14)


def test_three_labels_in_one_box_and_partial_boxes_dropped():
    """One 4x4 box holding labels 0, -2, 7 with shares 1/2, 1/4, 1/4:
    S = (1/2) log 2 + 2 (1/4) log 4 = (3/2) log 2.  The trailing row and columns (other
    labels) make no whole box and are left out."""
    labels = np.full((5, 6), 9)
    labels[:4, :4] = 0
    labels[2:4, :2] = -2
    labels[2:4, 2:4] = 7
    assert basin_entropy(labels, box=4) == (pytest.approx(1.5 * math.log(2), rel=1e-15),
                                            pytest.approx(1.5 * math.log(2), rel=1e-15), 1)


def test_one_dimensional_labels():
    """Boxes of 4 consecutive cells: [0 0 1 1] has S = log 2, [0 0 0 0] has 0, the trailing
    [5 5] is dropped: Sb = (log 2) / 2, Sbb = log 2, one boundary box."""
    sb, sbb, n_boundary = basin_entropy(np.array([0, 0, 1, 1, 0, 0, 0, 0, 5, 5]), box=4)
    assert (sb, sbb, n_boundary) == (pytest.approx(math.log(2) / 2), pytest.approx(math.log(2)), 1)


@pytest.mark.parametrize("k", [2, 3, 5])
def test_iid_labels_approach_log_k(k):
    """k equally likely i.i.d. labels, boxes of m = 400 cells (20x20, 400 boxes): each box's
    plug-in entropy is log k less the bias (k - 1) / (2m) (G. Miller, "Note on the bias of
    information estimates", 1955), with a standard deviation about sqrt(2(k - 1)) / (2m)
    <= 0.0036 per box (2m (log k - S) ~ chi^2 with k - 1 degrees of freedom), so <= 2e-4 for
    the mean of 400 boxes.  Measured: deviations from the bias-corrected value of -1.6e-5,
    -4.4e-5, -2.4e-4 for k = 2, 3, 5 (seed 1); asserted within 1e-3.  Every box is on a
    boundary, so Sbb = Sb."""
    labels = np.random.default_rng(1).integers(0, k, (400, 400))
    sb, sbb, n_boundary = basin_entropy(labels, box=20)
    assert n_boundary == 400 and sbb == sb
    assert abs(sb - (math.log(k) - (k - 1) / (2 * 400))) < 1e-3 and sb < math.log(k)


@pytest.mark.parametrize("kwargs,named", [
    ({"labels": np.zeros((4, 4, 4), dtype=int)}, "labels"),
    ({"labels": np.zeros((10, 10))}, "labels"),
    ({"labels": np.zeros((10, 10), dtype=int), "box": 0}, "box=0"),
    ({"labels": np.zeros((10, 10), dtype=int), "box": 2.5}, "box=2.5"),
    ({"labels": np.zeros((10, 3), dtype=int), "box": 4}, "box=4"),
])
def test_basin_entropy_refuses_bad_input_naming_it(kwargs, named):
    with pytest.raises(ValueError, match=named):
        basin_entropy(**kwargs)


# ------------------------------------------------------------------ uncertainty exponent
def cantor_labels(levels):
    """3^levels cells of [0, 1]; a cell's label is the parity of the level of the first
    middle third (of the middle-thirds construction) that holds it, cells left after
    ``levels`` levels taking the next level's parity.  Both labels come within a factor 9 of
    every point of the Cantor set, which is the boundary: box-counting dimension
    log 2 / log 3, uncertainty exponent 1 - log 2 / log 3 = 0.3691 (Grebogi et al. 1983)."""
    cell = np.arange(3 ** levels)
    level = np.full(cell.size, levels + 1)
    for j in range(levels, 0, -1):          # the coarsest middle third wins: it is written last
        level[(cell // 3 ** (levels - j)) % 3 == 1] = j
    return (level % 2).astype(np.int8)


def test_a_straight_boundary_has_exponent_one():
    """A straight boundary across a 400x400 grid: the default eps are 1, 2, ..., 64, the cells
    counted are the 272 columns at least 64 from an edge, and the eps-uncertain ones are the
    2 eps columns beside the boundary: f = 2 eps / 272 exactly, alpha = 1 (to rounding)."""
    labels = np.broadcast_to(np.arange(400) >= 200, (400, 400)).astype(int)
    alpha, stderr, eps, fraction = uncertainty_exponent(labels)
    assert eps.tolist() == [1, 2, 4, 8, 16, 32, 64]
    assert fraction == pytest.approx(2 * eps / 272, rel=1e-12)
    assert abs(alpha - 1) < 1e-12 and stderr < 1e-12


def test_a_circle_has_exponent_one():
    """A disc of radius 100 in a 400x400 grid: a smooth boundary, alpha = 1.  Measured 0.968
    with the default eps 1..64 (the band of width 2 x 64 around the circle covers 80% of the
    counted cells, so f flattens at the top), 0.9994 with eps 1..16; asserted within 0.05 and
    0.01."""
    x, y = np.meshgrid(np.arange(400) - 199.5, np.arange(400) - 199.5)
    labels = (x ** 2 + y ** 2 < 100 ** 2).astype(int)
    assert abs(uncertainty_exponent(labels)[0] - 1) < 0.05
    assert abs(uncertainty_exponent(labels, [1, 2, 4, 8, 16])[0] - 1) < 0.01


def test_iid_labels_have_exponent_zero():
    """Labels drawn i.i.d. (two, equally likely) on a 400x400 grid: a cell is uncertain unless
    its 4 neighbours eps away share its label, f = 1 - 2^-4 = 15/16 whatever eps, so alpha = 0.
    Measured -0.0003 +- 0.0002 (seed 2); asserted within 0.05, f within 0.01 of 15/16."""
    labels = np.random.default_rng(2).integers(0, 2, (400, 400))
    alpha, _, _, fraction = uncertainty_exponent(labels)
    assert abs(alpha) < 0.05
    assert np.all(abs(fraction - 15 / 16) < 0.01)


def test_a_cantor_boundary_has_exponent_one_less_its_dimension():
    """The middle-thirds labelling at 12 levels (531441 cells, default eps 1..131072):
    alpha = 1 - log 2 / log 3 = 0.3691.  Measured 0.3648 +- 0.0058; the eps = 2^i sample the
    3^j self-similarity out of phase, so the estimate oscillates with the depth (0.363 to
    0.388 over 9..13 levels): asserted within 0.02."""
    alpha, stderr, eps, _ = uncertainty_exponent(cantor_labels(12))
    assert eps[-1] == 2 ** 17
    assert abs(alpha - (1 - math.log(2) / math.log(3))) < 0.02 and stderr < 0.01


def test_points_without_uncertain_cells_are_left_out():
    """A 1-D boundary at cell 10 of 64: the counted cells are 16..47 (eps up to 16), so only
    eps = 8 (cells 16, 17) and eps = 16 (cells 16..25) find it: f = 0, 0, 0, 2/32, 10/32; the
    fit uses the last two, alpha = log 5 / log 2, its standard error undefined (NaN).  One
    label throughout: f = 0 everywhere, alpha NaN."""
    alpha, stderr, eps, fraction = uncertainty_exponent(np.arange(64) >= 10)
    assert eps.tolist() == [1, 2, 4, 8, 16] and fraction.tolist() == [0, 0, 0, 2 / 32, 10 / 32]
    assert alpha == pytest.approx(math.log(5) / math.log(2), rel=1e-14) and math.isnan(stderr)
    alpha, stderr, _, fraction = uncertainty_exponent(np.zeros((40, 40), dtype=int))
    assert math.isnan(alpha) and math.isnan(stderr) and not fraction.any()


@pytest.mark.parametrize("kwargs,named", [
    ({"labels": np.zeros((4, 4, 4), dtype=int)}, "labels"),
    ({"labels": np.zeros((40, 40))}, "labels"),
    ({"labels": np.zeros((40, 40), dtype=int), "eps_cells": [0, 1]}, "eps_cells"),
    ({"labels": np.zeros((40, 40), dtype=int), "eps_cells": [1.5]}, "eps_cells"),
    ({"labels": np.zeros((40, 40), dtype=int), "eps_cells": [1, 20]}, "eps_cells"),
])
def test_uncertainty_exponent_refuses_bad_input_naming_it(kwargs, named):
    with pytest.raises(ValueError, match=named):
        uncertainty_exponent(**kwargs)
