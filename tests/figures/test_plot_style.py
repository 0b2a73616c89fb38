"""The logic of the figures (issue 21), without pixels: the y-window, marker sizes, the
style sheet check, and diagrams coloured by what each run's orbit is; and diagrams of
millions of points read a slab at a time: the same window, counts and image, pixel for
pixel, as of the whole arrays."""

import contextlib
import os

import numpy as np
import pytest
from click.testing import CliRunner

from cornerbif import plot_base as PB
from cornerbif import plot_data as PDATA
from cornerbif import plot_diagram as PD
from cornerbif import plot_style as PS
from cornerbif.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def test_a_few_outliers_do_not_set_the_y_window():
    """100 000 values in [0, 1] and 20 at 50: the window is the central range (the 20 are
    0.02 % of the values, under the 0.1 % tail), padded by 4 %, and says 20 are left out."""
    rng = np.random.default_rng(1)
    v = np.concatenate([rng.uniform(0.0, 1.0, 100_000), np.full(20, 50.0), [np.nan] * 5])
    lo, hi, out = PS.robust_range(v)
    assert -0.05 < lo < 0.0 and 1.0 < hi < 1.05
    assert out == 20


def test_a_spread_family_keeps_the_full_range():
    """When the far values are a family (5 % of them), not a few points, the window is the
    full range and leaves nothing out; a constant series gets a window around it."""
    rng = np.random.default_rng(2)
    v = np.concatenate([rng.uniform(0.0, 1.0, 95_000), rng.uniform(5.0, 9.0, 5_000)])
    lo, hi, out = PS.robust_range(v)
    assert lo < v.min() and hi > v.max() and out == 0
    lo, hi, out = PS.robust_range(np.full(10, 3.0))
    assert lo < 3.0 < hi and out == 0
    assert PS.robust_range(np.array([np.nan])) is None


def test_marker_size_shrinks_with_the_count_within_bounds():
    sizes = [PS.marker_size(n) for n in (10, 10**3, 10**4, 10**5, 10**6, 10**8)]
    assert sizes == sorted(sizes, reverse=True)
    assert sizes[0] == 3.0 and sizes[-1] == 0.5
    assert PS.marker_size(2e4) == pytest.approx(2.4)


def test_style_sheets_are_checked():
    assert PS.check_style(None) is None
    assert PS.check_style("ggplot") is None
    assert "neither a file" in PS.check_style("no-such-style")


@pytest.fixture(scope="module")
def kappa_sweep(tmp_path_factory):
    """A small Fig. 6(a) kappa sweep at omega = 1.999 with its attractor table (40 values of
    kappa, 8 starts, 40 impacts each)."""
    out = tmp_path_factory.mktemp("kappa") / "d.h5"
    r = CliRunner().invoke(main, ["sweep", os.path.join(ROOT, "configs", "fig06a.toml"), "-o",
                                  str(out), "--no-progress", "--set", "sweep.kappa.num=40",
                                  "--set", "run.transient=200", "--set", "run.record=40"])
    assert r.exit_code == 0, r.output
    return out


@pytest.mark.slow
def test_diagram_colours_runs_by_their_orbit(tmp_path, kappa_sweep):
    """A kappa sweep at omega = 1.999 drawn by attractor: every run's points take its
    word's colour (attractor_colors of the labels shown), the legend names the words in
    the paper's notation, the runs on other cycles are black; vector output and a user's
    style sheet work, and a bad style is refused naming it."""
    import h5py
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cornerbif import attractors as A
    from cornerbif import plot_attractors as PA
    out = kappa_sweep
    table = A.read_table(str(out))
    idx, names = PA.run_labels(table)
    # the labels of the runs are their table rows' labels
    labels = PA.attractor_labels(table)
    ids = table["ids"]
    for i in np.flatnonzero(ids.ravel() >= 0)[:50]:
        assert names[idx.ravel()[i]] == labels[ids.ravel()[i]]
    with h5py.File(out) as f:
        u = f["impacts/u"][...]
        x = f["kappa"][...]
    fig, ax = plt.subplots()
    handles = PA.draw_diagram_by_label(ax, str(out), x, u, 1.0, shown=3)
    shown = [h.get_label() for h in handles]
    counts = np.bincount(idx[idx >= 0], minlength=len(names))
    top = [names[i] for i in np.argsort(-counts, kind="stable")[:3]]
    assert shown[:3] == [PA.label_tex(lab) for lab in top]
    colors = PA.attractor_colors(top)
    assert [h.get_color() for h in handles[:3]] == [colors[lab] for lab in top]
    plt.close(fig)
    # continued branches drawn over it share one colour map with the diagram's orbits: a
    # branch's word never takes the colour of another orbit shown
    for extra in (["bbbbbbbbbg"], [top[0]], ["bbbg", "bg"]):
        fig, ax = plt.subplots()
        shared = {}
        handles = PA.draw_diagram_by_label(ax, str(out), x, u, 1.0, shown=3, also=extra,
                                           colors_out=shared)
        assert set(shared) == set(top) | set(extra)
        assert len(set(shared.values())) == len(shared)
        assert [h.get_color() for h in handles[:3]] == [shared[lab] for lab in top]
        plt.close(fig)
    for ext, extra in ((".pdf", []), (".svg", ["--style", "ggplot"]),
                       (".png", ["--y", "impact_height"])):
        r = CliRunner().invoke(main, ["plot", str(out), "-o", str(tmp_path / f"d{ext}"), *extra])
        assert r.exit_code == 0, r.output
        assert (tmp_path / f"d{ext}").stat().st_size > 1000
    r = CliRunner().invoke(main, ["plot", str(out), "-o", str(tmp_path / "e.png"), "--style",
                                  "no-such-style"])
    assert r.exit_code == 2 and "no-such-style" in r.output


def test_the_obstacle_figure_draws_eq_8(tmp_path):
    """[plot] kind = "obstacle" (Fig. 2) draws the kernels' obstacle: at the scene's values
    it is kappa + beta |sin omega t| (eq 8) to rounding, its period pi / omega."""
    from cornerbif.figures.obstacle import obstacle_curve
    from cornerbif.plot_data import PlotData
    out = tmp_path / "o.h5"
    r = CliRunner().invoke(main, ["sweep", os.path.join(ROOT, "configs", "fig02.toml"), "-o",
                                  str(out), "--no-progress", "--set", "system.kappa=0.3",
                                  "--set", "system.omega=1.7"])
    assert r.exit_code == 0, r.output
    t = np.linspace(0.0, 7.0, 501)
    z_of, per, _ = obstacle_curve(PlotData(str(out)))
    z = z_of(t)
    assert np.max(np.abs(z - (0.3 + np.abs(np.sin(1.7 * t))))) < 1e-12
    assert per == pytest.approx(np.pi / 1.7, rel=1e-15)
    r = CliRunner().invoke(main, ["plot", str(out), "-o", str(tmp_path / "o.pdf")])
    assert r.exit_code == 0, r.output


def test_an_inset_goes_where_the_data_is_not():
    """Points along the diagonal from lower left to upper right: the inset takes the upper
    left corner (the lower right is as empty; upper left comes first), never a corner the
    line crosses; with the upper left filled too, the lower right."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots()
    x = np.linspace(0.0, 1.0, 500)
    ax.set_xlim(0, 1)
    ax.set_ylim(0, 1)
    assert PS.emptiest_corner(ax, x, x)[:2] == [0.07, 0.56]
    blob = np.full(200, 0.2), np.full(200, 0.8)
    assert PS.emptiest_corner(ax, np.r_[x, blob[0]], np.r_[x, blob[1]])[:2] == [0.59, 0.08]
    plt.close(fig)


def test_orbit_families_merge_the_powers():
    """[plot] orbits = "families": beta^N gamma for every N is one family (section 5's
    period adding), beta^N alpha another; a word of two powers keeps both places."""
    from cornerbif.plot_attractors import family, family_tex
    assert family("bbbbg") == family("bbg") == "b^N g"
    assert family("bbbba#2") == "b^N a" != family("bbbbg")
    assert family("abbgbbbg") == "a b^N g b^N g"
    assert family("b") == "b" and family("ab") == "a b"
    assert family_tex("b^N g") == r"$\beta^N\,\gamma$"


def test_the_raster_puts_each_value_in_its_pixel_the_higher_layer_on_top():
    """plot_style.raster_runs on a 16 x 16 pixel axes: a value lands in the pixel of its
    (x, y), a run of layer -1 is not drawn, where two layers meet the higher shows, and
    values outside the window are left out."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.colors import to_rgba
    fig = plt.figure(figsize=(1, 1))
    ax = fig.add_axes([0, 0, 1, 1])
    x = np.array([0.05, 0.55, 0.95])                      # three grid points
    y = np.array([[[0.05], [0.05]], [[0.55], [0.55]], [[0.95], [2.0]]])   # 2 starts, 1 value
    layer = np.array([[0, 1], [1, -1], [0, 1]], np.int16)
    PS.raster_runs(ax, x, y, layer, ["r", "b"], (0.0, 1.0), (0.0, 1.0), ms=0, dpi=16)
    img = ax.get_images()[0].get_array()
    assert img.shape == (16, 16, 4)
    assert np.allclose(img[0, 0], to_rgba("b"))           # layers 0 and 1 meet: 1 on top
    assert np.allclose(img[8, 8], to_rgba("b"))
    assert np.allclose(img[15, 15], to_rgba("r"))         # the other start is at y = 2
    assert np.count_nonzero(img[..., 3]) == 3
    plt.close(fig)


def test_the_window_ignores_infinities_and_sees_every_branch_of_a_large_file():
    """Infinities are not values of the window; past the sample size, a period-2 orbit whose
    two branches alternate along the record keeps both in the window (a strided sample in
    step with the period once saw one branch only)."""
    lo, hi, out = PS.robust_range(np.array([1.0, 2.0, np.inf, -np.inf, np.nan]))
    assert np.isfinite(lo) and np.isfinite(hi) and lo < 1.0 and 2.0 < hi and out == 0
    y = np.empty((15000, 8, 20))
    y[..., 0::2] = np.linspace(0.0, 1.0, 15000)[:, None, None]
    y[..., 1::2] = 5.0 + np.linspace(0.0, 1.0, 15000)[:, None, None]
    lo, hi, out = PS.robust_range(y)
    assert lo < 0.0 and hi > 6.0 and out == 0


def test_marks_and_the_obstacle_figure_are_checked_against_the_scene():
    from cornerbif import config
    with pytest.raises(config.SceneError, match=r"plot.marks\[0\]: 1.5 \('far'\) is outside the swept"):
        config.load(os.path.join(ROOT, "configs", "fig06a.toml"),
                    ['plot.marks=[[1.5, "far"]]'])
    with pytest.raises(config.SceneError, match="obstacle 'sine'"):
        config.load(os.path.join(ROOT, "configs", "fig02.toml"), ['system.obstacle="sine"'])


def test_the_scenes_y_window_holds_for_its_own_y_only():
    """[plot] ylim is in the scene's y: kept for that y (given or the file's default),
    dropped for another --y (Fig. 6(a)'s window in u would hide every impact velocity)."""
    from cornerbif.plot_base import cfg_for_y
    cfg = {"ylim": [-0.0155, 0.0125], "orbits": "families"}
    assert cfg_for_y(cfg, None, "impact_u") == cfg
    assert cfg_for_y(cfg, "impact_u", "impact_u") == cfg
    assert cfg_for_y(cfg, "impact_v", "impact_u") == {"orbits": "families"}
    assert cfg_for_y(dict(cfg, y="section_v"), "section_v", "impact_u")["ylim"] == cfg["ylim"]


def _rows(a):
    """``a`` as plot_style.Rows: each slab a copy read on demand, counting the passes."""
    passes = []

    def opened():
        passes.append(1)
        return contextlib.nullcontext()
    return PS.Rows(a.shape, lambda i, j: a[i:j].copy(), opened), passes


def test_values_read_by_slab_give_the_whole_arrays_window_and_counts(monkeypatch):
    """robust_range, count_finite and count_outside of plot_style.Rows read in slabs of a
    few rows equal those of the whole array: with the random sample of the tails (SAMPLE
    made small) and without it, with NaN and infinities among the values."""
    rng = np.random.default_rng(3)
    y = np.concatenate([rng.uniform(0.0, 1.0, (300, 4, 10)), rng.uniform(40.0, 50.0, (1, 4, 10))])
    y[rng.random(y.shape) < 0.1] = np.nan
    y[0, 0, :3] = [np.inf, -np.inf, 1e9]
    whole = (PS.robust_range(y), PS.count_finite(y), PS.count_outside(y, 0.1, 0.9))
    assert whole[0][2] > 0
    monkeypatch.setattr(PS, "RASTER_VALUES", 100)       # slabs of 2 rows
    rows, passes = _rows(y)
    assert PS.slab_rows(y.shape)[:2] == [slice(0, 2), slice(2, 4)]
    assert (PS.robust_range(rows), PS.count_finite(rows),
            PS.count_outside(rows, 0.1, 0.9)) == whole
    assert len(passes) == 4     # robust_range: one pass for the window, one to count outside
    monkeypatch.setattr(PS, "SAMPLE", 5000)
    assert PS.robust_range(_rows(y)[0]) == PS.robust_range(y)
    assert PS.robust_range(_rows(np.full((3, 2), np.nan))[0]) is None


def test_the_raster_read_by_slab_is_the_whole_arrays_image(tmp_path, monkeypatch):
    """raster_runs of the values and layers read from an HDF5 file a few rows at a time
    (plot_style.Rows) draws the very image of the whole arrays in memory."""
    import h5py
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    rng = np.random.default_rng(4)
    x = np.linspace(0.0, 1.0, 50)
    y = x[:, None, None] + rng.normal(0.0, 0.1, (50, 3, 20))
    y[rng.random(y.shape) < 0.05] = np.nan
    layer = rng.integers(-1, 3, (50, 3)).astype(np.int16)
    with h5py.File(tmp_path / "r.h5", "w") as f:
        f["y"], f["layer"] = y, layer

    def image(yv, lv):
        fig = plt.figure(figsize=(1, 1))
        ax = fig.add_axes([0, 0, 1, 1])
        PS.raster_runs(ax, x, yv, lv, ["0.5", "r", "b"], (0.0, 1.0), (-0.1, 1.1), ms=2.0,
                       dpi=64)
        img = ax.get_images()[0].get_array().copy()
        plt.close(fig)
        return img
    want = image(y, layer)
    monkeypatch.setattr(PS, "RASTER_VALUES", 70)        # slabs of one row
    with h5py.File(tmp_path / "r.h5", "r") as f:
        got = image(*(PS.Rows(f[n].shape, lambda a, b, n=n: f[n][a:b]) for n in ("y", "layer")))
    assert np.count_nonzero(want[..., 3]) > 100
    assert np.array_equal(got, want)


def test_label_counts_by_slab_are_the_whole_counts(monkeypatch):
    """label_counts of attractor ids read a few rows at a time: the bincount of every run's
    label and the runs without one, as of the whole id array."""
    from cornerbif import plot_attractors as PA
    rng = np.random.default_rng(5)
    ids = rng.integers(-3, 7, (41, 8)).astype(np.int32)
    row = np.array([0, 2, 1, 2, 0, 3, 3])                 # table row -> label
    idx = PA.run_index(ids, row)
    monkeypatch.setattr(PS, "RASTER_VALUES", 16)        # slabs of 2 rows
    counts, none = PA.label_counts(_rows(ids)[0], row, 4)
    assert np.array_equal(counts, np.bincount(idx[idx >= 0], minlength=4))
    assert none == np.count_nonzero(ids < 0)


@pytest.mark.slow
def test_a_diagram_past_the_raster_threshold_is_read_by_slab(tmp_path, monkeypatch,
                                                             kappa_sweep):
    """A diagram drawn as one image (RASTER_POINTS made small) is the same PNG, pixel for
    pixel, whether its values, layers and attractors are read in one slab or a few rows at a
    time, for a y of the file and a derived one (impact_height); PlotData's slabs of y and
    its attractors are those of the whole arrays, and the whole y is never read."""
    import matplotlib.image as mimage

    whole = PDATA.PlotData(str(kappa_sweep))
    labels, count = whole.attractors()
    height = whole.y("impact_height")
    assert np.array_equal(height, whole.y("impact_u") - whole.values["kappa"][:, None, None])
    monkeypatch.setattr(PS, "RASTER_POINTS", 1000)
    drawn = []
    raster = PS.raster_runs
    monkeypatch.setattr(PS, "raster_runs", lambda *a, **k: drawn.append(a[2]) or raster(*a, **k))
    pngs = {}
    for per_slab in (1 << 30, 8 * 40 * 3):              # one slab; slabs of 3 kappa values
        monkeypatch.setattr(PS, "RASTER_VALUES", per_slab)
        d = PDATA.PlotData(str(kappa_sweep))
        assert all(np.array_equal(a, b) for a, b in zip(d.attractors(), (labels, count)))
        rows = d.y_rows("impact_height")
        assert np.array_equal(rows[4:9], height[4:9], equal_nan=True)
        assert not dict.__len__(d.data)                 # nothing read whole
        for y in ("impact_u", "impact_height"):
            png = tmp_path / f"{y}_{per_slab}.png"
            r = CliRunner().invoke(main, ["plot", str(kappa_sweep), "-o", str(png), "--y", y])
            assert r.exit_code == 0, r.output
            pngs.setdefault(y, []).append(mimage.imread(png))
    assert len(drawn) == 4 and all(isinstance(y, PS.Rows) for y in drawn)
    for a, b in pngs.values():
        assert np.array_equal(a, b)


@pytest.mark.parametrize("ascii_,tex", [
    ("omega = 1.999", r"$\omega$ = 1.999"),
    ("kappa_CC(omega)", r"$\kappa_{CC}$($\omega$)"),
    ("omega0_C = 1.99975", r"$\omega_{0,C}$ = 1.99975"),
    ("kappa = kappa_beta + 1e-6", r"$\kappa$ = $\kappa_{\beta}$ + 1e-6"),
    ("the paper names it beta^11 gamma beta^12 gamma", r"the paper names it "
                                                      r"$\beta^{11}\gamma\beta^{12}\gamma$"),
    ("regions S_alpha, S_gamma and Sigma_1", r"regions $S_{\alpha}$, $S_{\gamma}$ and "
                                             r"$\Sigma_{1}$"),
    ("alphabet, betamax, omega2 and $\\mu$ = 10", "alphabet, betamax, omega2 and $\\mu$ = 10"),
])
def test_titles_take_the_papers_symbols(ascii_, tex):
    """A scene's ASCII title in the paper's notation: Greek names (with subscripts, the
    omega0 of two particles, superscripts) as mathtext, an orbit's letters run together as
    the paper writes a word; other words, and formulas already written, left alone."""
    assert PS.title_tex(ascii_) == tex


def test_title_lines_break_between_words_only():
    """No line breaks inside a formula, a |...| or an 'a = b', and a line's drawn length
    (a formula's glyphs, not its markup) stays within the width unless one unit is longer."""
    text = ("Smooth wall z = sin(omega t) at omega = 2, r = 0.8: the resonant period-one orbit "
            "u = 18 |sin t| of eq (6), sigma = 0, beta^11 gamma beta^12 gamma (paper Fig. 1b), "
            "lost at kappa_C (eq 11)")
    for width in (12, 20, 30, 45, 60, 200):
        lines = PS.title_lines(text, width).split("\n")
        assert " ".join(lines) == PS.title_tex(text)
        for line in lines:
            assert line.count("$") % 2 == 0 and line.count("|") % 2 == 0
            assert not line.startswith("= ") and not line.endswith(" =")
            assert not line.endswith("(eq") and not line.startswith("11)")
            units = PS._UNBROKEN.sub(lambda m: m.group(0).replace(" ", "_"), line).split()
            assert PS._drawn_length(line) <= width or len(units) == 1
    assert PS._drawn_length(r"$\beta^{11}\gamma$") == 4


def test_labels_follow_the_model():
    """The maps' section and start are (a_n, b_n) and (a_0, b_1); a flow's v(nT) and
    u(t_0), v(t_0): the fixed wall's continuation was labelled with the maps' b_n."""
    assert PB.y_label("section_v", "map2d") == "$b_n$"
    assert PB.y_label("section_v", "flow") == "$v(nT)$"
    assert "b_n" in PB.y_label("section_v")                 # flow and maps on one axis
    assert PB.axis_label("initial.v", "map2d") == "start $b_1$"
    assert PB.axis_label("initial.v", "flow") == r"start $v(t_0)$"


def test_branches_take_their_orbits_colour():
    """A continued branch is coloured as its orbit is in every diagram (beta blue, alpha
    orange: plot_attractors.FIXED), not by its index in the file (the hysteresis figure
    had alpha blue and beta red)."""
    from cornerbif import plot_attractors as PA
    conts = [{"branches": [{"word": "a"}, {"word": "b"}, {"word": "abg"}]}]
    colors = PB.branch_colors(conts)
    fixed = PA.attractor_colors(["b", "a", "g"])
    assert colors["b"] == fixed["b"] and colors["a"] == fixed["a"]
    assert len(set(colors.values())) == 3


def test_plane_of_exponents_paints_black_only_where_runs_stick():
    """The (omega, kappa) chart of the largest Lyapunov exponent: a point whose every start
    sticks (lambda = -inf) is black; the most stable cycles (below the scale's 2nd
    percentile) take the scale's end colour, not black (chart_flow_lyapunov showed the
    alpha orbit's cells black, as if they stuck)."""
    import types

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rng = np.random.default_rng(1)
    lam = rng.uniform(-0.1, -0.05, (20, 10, 2))
    lam[3, 4] = -5.0                      # far below the others: under the scale
    lam[7, 2] = -np.inf                   # every start sticks
    data = types.SimpleNamespace(axes=["omega", "kappa"], stability={"lyapunov": lam},
                                 values={"omega": np.linspace(1.99, 2.01, 20),
                                         "kappa": np.linspace(-0.01, 0.01, 10)},
                                 scene={"system": {"obstacle": "sine"}}, path="x.h5")
    fig, ax = plt.subplots()
    im = PD.draw_plane_stability(ax, data, "lyapunov")
    rgba = im.to_rgba(im.get_array().reshape(10, 20))
    black = np.array([0.0, 0.0, 0.0, 1.0])
    assert not np.allclose(rgba[4, 3], black)                      # under: the end colour
    assert np.allclose(rgba[4, 3], im.cmap(0.0))
    sticks = ax.collections[1]                                      # the -inf layer
    assert np.isfinite(sticks.get_array()).sum() == 1
    assert any("infty" in t.get_text() for t in ax.get_legend().get_texts())
    plt.close(fig)
    # the largest multiplier: a point whose starts all stick has |mu_1| = 0, black too
    mu = rng.uniform(0.5, 0.9, (20, 10, 2))
    mu[7, 2] = 0.0
    data.stability = {"multiplier": mu}
    fig, ax = plt.subplots()
    im = PD.draw_plane_stability(ax, data, "multiplier")
    shown = np.ma.filled(im.get_array().astype(float), np.nan).reshape(10, 20)
    assert np.isnan(shown[2, 7]) and np.isfinite(shown).sum() == 199      # not on the scale
    assert np.isfinite(ax.collections[1].get_array()).sum() == 1
    assert any("mu_1" in t.get_text() for t in ax.get_legend().get_texts())
    plt.close(fig)


def test_a_continuation_figure_keeps_its_scenes_window_for_its_own_y_only(tmp_path,
                                                                          monkeypatch):
    """``[plot] ylim`` of a continuation scene is a window in its own y: drawn with another
    ``--y`` it is dropped (as for a sweep's figure, PB.cfg_for_y), not applied to values
    it does not fit."""
    import matplotlib.figure

    from cornerbif import plot as P
    br = {"param": np.linspace(0.0, 1.0, 5), "stable": np.ones(5, bool), "word": "b",
          "impact_u": np.linspace(0.01, 0.02, 5), "impact_v_in": np.linspace(-18, -1, 5)}
    cont = {"branches": [br], "events": [], "curves": [], "parameter": "kappa",
            "scene": '[scene]\nmodel = "flow"\n[plot]\nylim = [0.0, 0.03]\n',
            "attrs": {"model": "flow", "completed": "now"}, "path": "c.h5"}
    monkeypatch.setattr(P, "read_continuation", lambda p: cont)
    seen = []
    # the figure is saved whole (outputs.save_figure): the stand-in writes an empty file
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig",
                        lambda fig, out, **k: (seen.append(fig.axes[0].get_ylim()),
                                               open(out, "wb").close()))
    P.figure_branches(["c.h5"], str(tmp_path / "a.png"))
    P.figure_branches(["c.h5"], str(tmp_path / "b.png"), y="impact_v")
    assert seen[0] == (0.0, 0.03)
    assert seen[1][0] < -17 and seen[1][1] > -2


def test_a_diagrams_title_is_its_scenes_and_its_notes_sit_outside_the_axes(tmp_path,
                                                                            kappa_sweep,
                                                                            monkeypatch):
    """The figure's title is the scene's (in the paper's notation; the orbit legend's own
    title once took its place), and the summary line and the count of values outside the
    window are drawn right of the axes, not over the data (Fig. 19(a)'s lay on its lowest
    points)."""
    import matplotlib.figure

    from cornerbif import config
    from cornerbif import plot as P
    seen = {}
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig",
                        lambda fig, out, **k: (seen.setdefault("fig", fig),
                                               open(out, "wb").close()))
    P.figure([str(kappa_sweep)], str(tmp_path / "f.png"),
             plot_cfg={"orbits": "families", "ylim": [-0.016, 0.0]})
    ax = seen["fig"].axes[0]
    scene = config.load(os.path.join(ROOT, "configs", "fig06a.toml"))
    assert ax.get_title() == PS.title_lines(scene.title, 80)
    notes = [t for t in ax.texts if "coexisting" in t.get_text()]
    assert notes and "outside the y window" in notes[0].get_text()
    assert notes[0].get_position()[0] > 1.0 and notes[0].get_transform() == ax.transAxes


def test_cells_of_uneven_values_on_a_log_axis():
    """PD.cell_edges: each value's cell runs to the midpoints with its neighbours (the
    geometric means on a log axis, as mu_sweep's mass ratios 10 ... 1e7 need), so every
    value sits in its own cell and the cells tile the axis."""
    mu = np.array([10.0, 30.0, 100.0, 1e3, 1e4, 1e6, 1e7])
    e = PD.cell_edges(mu, log=True)
    assert np.allclose(e[1:-1], np.sqrt(mu[1:] * mu[:-1]))
    assert np.all((e[:-1] < mu) & (mu < e[1:]))
    assert np.allclose(e[1] / mu[0], mu[0] / e[0])             # the end cell as wide in log
    x = np.array([1.0, 2.0, 4.0])
    assert np.allclose(PD.cell_edges(x), [0.5, 1.5, 3.0, 5.0])


def test_no_orbit_takes_the_light_partner_of_a_fixed_colour():
    """With alpha (orange) in a figure, no other orbit gets the palette's light orange (Fig.
    18(a): alpha and the alpha beta^N family looked alike); likewise for beta and gamma.
    Without alpha, a label may take it; beta's, alpha's and gamma's own colours never."""
    from cornerbif import plot_attractors as PA
    words = ["a", "b", "g"] + [f"b{'b' * k}g" for k in range(12)] + ["ab", "abg", "aab"]
    colors = PA.attractor_colors(words)
    light = {PA.PALETTE[PA.FIXED[w] + 1] for w in ("a", "b", "g")}
    assert not light & {colors[w] for w in words if w not in PA.FIXED}
    assert colors["a"] == PA.PALETTE[PA.FIXED["a"]]
    free = PA.attractor_colors([f"b{'b' * k}g" for k in range(15)])
    assert light & set(free.values())
    assert not {PA.PALETTE[s] for s in PA.FIXED.values()} & set(free.values())
    for n in (14, 40):                  # more labels than free slots: colours repeat, but
        labs = ["b", "a", "g"] + [f"{'b' * k}g" for k in range(1, n + 1)]
        many = PA.attractor_colors(labs)
        own = {PA.PALETTE[s] for s in PA.FIXED.values()} | light
        assert not own & {many[w] for w in labs if w not in PA.FIXED}
