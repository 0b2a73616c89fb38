"""The attractor table (issue 19): every cycle of a file named once, with its basin share.

Checked against what does not use the table: random starts at the same parameter point
(a census of a separate scene, whose shares estimate the same integral as the grid's
cells, within three standard errors), grids at three resolutions (the same attractors,
shares converging), the same scene on other thread counts and block sizes (the same ids),
the maps' own iteration from a table point (it is a point of its cycle), and the per-run
datasets the table summarises.
"""

import os
import tomllib

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from test_basins import KAPPA_AND_U

from cornerbif import attractors as A
from cornerbif import config
from cornerbif.cli import main
from cornerbif.plot_attractors import (
    FIXED,
    PALETTE,
    attractor_colors,
    attractor_labels,
    label_tex,
    preferred_slot,
)
from cornerbif.sweep import run_sweep

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
HYSTERESIS = os.path.join(ROOT, "configs", "basin_hysteresis.toml")
MAPS = os.path.join(ROOT, "configs", "basin_maps.toml")


def grid(tmp, n, scene=HYSTERESIS, extra=(), **kw):
    sc = config.load(scene, [f"sweep.initial.u.num={n}", f"sweep.initial.v.num={n}", *extra])
    out = str(tmp / f"grid{n}_{len(extra)}_{sorted(kw.items())}.h5")
    run_sweep(sc, out, overwrite=True, **kw)
    return A.read_table(out), out


def sampled(tmp, count, scene=HYSTERESIS, seed=3):
    """The same point from ``count`` random starts on the grid's rectangle (no start axes)."""
    with open(scene, "rb") as fh:
        raw = tomllib.load(fh)
    swept = raw.pop("sweep")["initial"]
    raw["initial"] = {"count": count, "seed": seed,
                      **{c: [swept[c]["start"], swept[c]["stop"]] for c in swept}}
    sc = config.from_dict(raw)
    assert not sc.axes and sc.n_ic == count
    out = str(tmp / f"sampled{count}.h5")
    run_sweep(sc, out, overwrite=True)
    return A.read_table(out)


@pytest.fixture(scope="module")
def hysteresis(tmp_path_factory):
    tmp = tmp_path_factory.mktemp("hyst")
    return {n: grid(tmp, n) for n in (41, 81, 161)}, sampled(tmp, 2000)


def shares(table):
    return dict(zip(table["word"], table["fraction"]))


@pytest.mark.slow
def test_table_agrees_with_a_census_from_random_starts(hysteresis):
    """The 81 x 81 grid of the hysteresis wedge (omega = 2.001, kappa = 0.008) and 2000
    random starts on the same rectangle find the same three attractors (words a, b, abg),
    the same cycles (signatures to the match tolerance), and shares within three standard
    errors of the random estimate."""
    grids, rnd = hysteresis
    g = grids[81][0]
    assert sorted(g["word"]) == sorted(rnd["word"]) == ["a", "abg", "b"]
    for w in g["word"]:
        i, j = list(g["word"]).index(w), list(rnd["word"]).index(w)
        ref = rnd["signature"][j]
        assert np.all(np.abs(g["signature"][i] - ref) <= g["match_tolerance"] * (1 + abs(ref)))
        assert abs(g["fraction"][i] - rnd["fraction"][j]) <= 3 * rnd["standard_error"][j], w
    # the random estimate's standard error is the binomial one
    f, n = rnd["fraction"], rnd["runs_per_point"]
    assert np.allclose(rnd["standard_error"], np.sqrt(f * (1 - f) / n))


def test_refining_the_grid_keeps_the_attractors_and_the_shares_converge(hysteresis):
    """41^2, 81^2 and 161^2 cells: the same words and cycles; the shares' distance to the
    finest grid's shrinks (measured 0.011 then 0.0031; at 321^2 the 161^2 shares are within
    0.0019: docs/basins.md)."""
    grids, _ = hysteresis
    ref = shares(grids[161][0])
    for n in (41, 81):
        assert set(shares(grids[n][0])) == set(ref)
    d41 = max(abs(shares(grids[41][0])[w] - ref[w]) for w in ref)
    d81 = max(abs(shares(grids[81][0])[w] - ref[w]) for w in ref)
    assert d81 < 0.5 * d41 and d81 < 0.01, (d41, d81)


def test_table_summarises_the_runs(hysteresis):
    """Each id's runs are the table's count; the shares and the outcomes add up to every
    run; each run's word and period are its attractor's."""
    grids, _ = hysteresis
    t, path = grids[81]
    with h5py.File(path) as f:
        words = f["symbols"][...].astype(str)
        period = f["period"][...]
    ids = t["ids"]
    assert ids.min() >= 0 and t["outcomes"][0, 0] == ids.size == t["runs_per_point"]
    assert np.array_equal(np.bincount(ids.ravel()), t["runs"])
    assert abs(t["fraction"].sum() - 1.0) < 1e-12
    for k in range(len(t["id"])):
        assert set(words[ids == k]) == {t["word"][k]}
        assert set(period[ids == k]) == {t["period"][k]}


def test_ids_do_not_depend_on_threads_or_blocks(tmp_path):
    """The same scene on 1 thread in blocks of 7 points and on 2 threads in whole blocks
    writes the same ids and the same table (the Dask backend's bytes are the local one's,
    tests/runs/test_distributed.py)."""
    t1, p1 = grid(tmp_path, 31, threads=1, block_points=7)
    t2, p2 = grid(tmp_path, 31, threads=2)
    assert np.array_equal(t1["ids"], t2["ids"]) and t1["ids"].max() >= 1
    for k in ("word", "signature", "runs", "point"):
        assert np.array_equal(t1[k], t2[k]), k
    assert attractor_colors(attractor_labels(t1)) == attractor_colors(attractor_labels(t2))


def test_a_parameter_axis_has_a_table_per_point(tmp_path):
    """kappa x initial.u with 2 drawn v starts: the runs at one kappa share a point; its
    attractors' shares and the runs without one add up to 1 at each kappa, and the table
    names each row's kappa."""
    sc = config.loads(KAPPA_AND_U, ["sweep.kappa={start=0.002, stop=0.016, num=5}",
                                    "sweep.initial.u={start=1.0, stop=19.0, num=6}",
                                    "run.transient=2000", "run.record=40"])
    out = tmp_path / "s.h5"
    run_sweep(sc, str(out))
    t = A.read_table(str(out))
    assert t["runs_per_point"] == 12
    kap = np.linspace(0.002, 0.016, 5)
    assert np.allclose(t["at_kappa"], kap[t["parameter_point"]])
    total = np.bincount(t["parameter_point"], t["runs"], minlength=5)
    assert np.array_equal(total + t["outcomes"][:, 1:].sum(axis=1), np.full(5, 12))
    assert np.array_equal(total, t["outcomes"][:, 0])
    ids = t["ids"]
    for k in range(len(t["id"])):
        pts = np.nonzero((ids == k).any(axis=(1, 2)))[0]
        assert list(pts) == [t["parameter_point"][k]]
    # below kappa_CC only beta; above kappa_C only alpha (eqs 11, 17 at omega = 2.001)
    words = {p: set(t["word"][t["parameter_point"] == p]) for p in range(5)}
    assert words[0] == {"b"} and "b" not in words[4]


def test_starts_below_the_obstacle_get_their_code(tmp_path):
    """u(0) below z(0) = kappa: status BELOW_OBSTACLE, attractor code FAILED (-4), a share
    of the outcomes, not an attractor."""
    sc = config.load(HYSTERESIS, ["sweep.initial.u={start=-1.0, stop=3.0, num=9}",
                                  "sweep.initial.v.num=3"])
    out = str(tmp_path / "below.h5")
    run_sweep(sc, out)
    t = A.read_table(out)
    u = np.linspace(-1.0, 3.0, 9)
    below = u < 0.008
    assert (t["ids"][below] == A.FAILED).all() and (t["ids"][~below] >= 0).all()
    assert t["outcomes"][0, -A.FAILED] == below.sum() * 3


def test_outcome_codes_from_status():
    """Each status maps to its code; a run with a cycle and a finite signature is 0."""
    from cornerbif import status as S
    st = np.array([S.OK, S.OK, S.STUCK, S.MAX_EVENTS, S.ESCAPED, S.NONFINITE, S.NO_IMPACT,
                   S.BELOW_OBSTACLE, S.STEP_LIMIT, -1, S.OK])
    per = np.array([1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 2])
    sig = np.zeros((st.size, 6))
    sig[-1, 0] = np.nan
    assert list(A.outcome_codes(st, per, sig)) == [0, A.NO_CYCLE, A.STICKS, A.STICKS, A.ESCAPES,
                                                   A.ESCAPES, A.FAILED, A.FAILED, A.FAILED,
                                                   A.NOT_RUN, A.NO_CYCLE]


def test_maps_table_points_lie_on_their_cycles(tmp_path):
    """The maps at omega = 1.999, kappa = -0.0078 (basin_maps, 41 x 41): the two beta/gamma
    cycles of docs/discrepancies.md (W = 3/13 and 1/4) and no other; each row's point is an
    iterate of its word's closed-form periodic orbit (theory.word_orbit, a linear solve,
    admissible), and its signature that orbit's mean, least and largest a and b."""
    from cornerbif import theory
    from cornerbif.analysis import winding_number
    t, _ = grid(tmp_path, 41, scene=MAPS)
    assert sorted(t["word"]) == ["bbbbbbgg", "bbbbgbbbgbbbg"]
    assert sorted(winding_number(w) for w in t["word"]) == [3 / 13, 1 / 4]
    for k in range(2):
        x, ok = theory.word_orbit(t["word"][k], 1.999 - 2.0, -0.0078, 0.8)
        assert ok
        d = np.abs(x - t["point"][k]).max(axis=1)
        assert d.min() < 1e-9, d.min()
        sig = [x[:, 0].mean(), x[:, 1].mean(), x[:, 0].min(), x[:, 0].max(), x[:, 1].min(),
               x[:, 1].max()]
        assert np.allclose(t["signature"][k], sig, rtol=0, atol=1e-9)


def test_colours_follow_the_label_not_the_figure():
    """b, a, g keep fixed slots; another label gets its hashed slot whatever else is in the
    figure, unless that slot is taken (b, a and g's slots always; the light partner of
    one while that orbit is in the figure), then the next free one; distinct labels get
    distinct colours up to the palette's free slots."""
    assert attractor_colors(["a", "b"])["b"] == PALETTE[FIXED["b"]]
    w = "bbbbgbbbgbbbg"
    alone = attractor_colors([w])[w]
    assert alone == PALETTE[preferred_slot(w)]
    assert attractor_colors(["a", "b", "g", "abg", w])[w] == alone or \
        preferred_slot(w) in ({preferred_slot(x) for x in ("a", "b", "g", "abg")}
                              | {FIXED[x] + 1 for x in ("a", "b", "g")})
    assert alone not in {PALETTE[s] for s in FIXED.values()}
    free = len(PALETTE) - len(FIXED)            # b, a, g's colours are never another's
    many = [f"b{'b' * i}g" for i in range(free)]
    cols = attractor_colors(many)
    assert len(set(cols.values())) == free
    assert not set(cols.values()) & {PALETTE[s] for s in FIXED.values()}
    assert attractor_colors(list(reversed(many))) == cols
    assert label_tex("bbbg#2") == r"$\beta^{3}\,\gamma$ #2"


def test_basin_and_fraction_figures_draw(tmp_path, hysteresis):
    grids, _ = hysteresis
    r = CliRunner().invoke(main, ["plot", grids[41][1], "-o", str(tmp_path / "b.png")])
    assert r.exit_code == 0, r.output
    sc = os.path.join(ROOT, "configs", "fractions_hysteresis.toml")
    out = tmp_path / "fr.h5"
    r = CliRunner().invoke(main, ["sweep", sc, "-o", str(out), "--no-progress",
                                  "--set", "sweep.kappa.num=4", "--set", "initial.count=20",
                                  "--set", "run.transient=500"])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["plot", str(out), "-o", str(tmp_path / "fr.png")])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["validate", sc, "--set", "sweep.omega={start=2, stop=2.1, "
                                  "num=3}"])
    assert r.exit_code == 2 and "plot.kind: 'fractions'" in r.output, r.output


def test_table_multipliers_are_their_runs(tmp_path):
    """With stability kept, each attractor's multipliers are those of its runs: the table
    holds the first run's, and every run of that id has the same to 1e-6 (the runs are
    different starts converging on one cycle)."""
    t, path = grid(tmp_path, 15, extra=("output.keep=[\"stability\"]",))
    with h5py.File(path) as f:
        mu = f["stability/multiplier_re"][...] + 1j * f["stability/multiplier_im"][...]
    ids = t["ids"]
    m = t["multiplier_re"] + 1j * t["multiplier_im"]
    assert m.shape == (len(t["id"]), 2) and np.isfinite(m).all()
    for k in range(len(t["id"])):
        runs = mu[ids == k]
        first = runs[0]
        assert np.array_equal(first, m[k])
        assert np.abs(runs - first).max() < 1e-6, k


def test_matching_groups_runs_as_a_one_by_one_reference(tmp_path):
    """tabulate's grouping (a vectorised pass for keys whose runs all lie within tolerance
    of their first, ``_Reps.match`` for the rest) against a reference written here, run by
    run: a run joins the first representative of its point, word, period and impacts per
    cycle within tolerance, else founds one.  Synthetic signatures: per point, keys with
    one attractor, with two (far apart) and with runs at 0.5 and 2 tolerances off."""
    from cornerbif import io
    from cornerbif import status as S
    sc = config.load(os.path.join(ROOT, "configs", "fig06a.toml"),
                     ["sweep.kappa.num=5", "initial.count=12", "run.record=8"])
    tol = A.MATCH_FACTOR * sc.period_tol
    rng = np.random.default_rng(7)
    G, n = sc.shape, sc.n_ic
    words = np.array([b"ab", b"b", b"ab", b"abg"])[rng.integers(0, 4, G + (n,))]
    period = np.where(words == b"b", 1, 2)
    sig = np.zeros(G + (n, 6))
    base = rng.integers(0, 2, G + (n,))            # one of two cycles per key
    sig[...] = (1.0 + 5.0 * base)[..., None]
    jitter = rng.choice([0.0, 0.5, 2.0], G + (n,), p=[0.6, 0.3, 0.1])
    sig[..., 0] += jitter * tol * (1.0 + sig[..., 0])
    path = str(tmp_path / "m.h5")
    with io.create(path, sc, n) as f:
        f["status"][...] = S.OK
        f["period"][...] = period
        f["impacts_per_cycle"][...] = period
        f["symbols"][...] = words
        f["cycle/signature"][...] = sig
        f["cycle/point"][...] = sig[..., :2]
        A.tabulate(f, sc)
        ids = f["attractor"][...]
    groups = 0
    for g in range(G[0]):                           # the reference, run by run
        reps = []
        mine = np.empty(n, np.int64)
        for i in range(n):
            key = (words[g, i], period[g, i])
            for r, (k, s) in enumerate(reps):
                if k == key and np.all(np.abs(sig[g, i] - s) <= tol * (1.0 + np.abs(s))):
                    mine[i] = r
                    break
            else:
                reps.append((key, sig[g, i]))
                mine[i] = len(reps) - 1
        groups += len(reps)
        same_ref = mine[:, None] == mine[None, :]
        same_tab = ids[g][:, None] == ids[g][None, :]
        assert np.array_equal(same_ref, same_tab), g
    assert len(np.unique(ids)) == groups
    assert groups > 2 * G[0]            # several attractors per point, split by jitter too


def test_shares_have_wilson_intervals_and_rare_ones_draw_on_a_log_scale(tmp_path,
                                                                        monkeypatch):
    """share_low, share_high are the Wilson 95 % intervals of runs / runs_per_point (the
    score interval written out here); the fractions figure
    bands them, and where the shares drawn span more than a factor 100 (a basin of 1 start
    in 1000 beside one of 999) it draws them on a log scale."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from cornerbif import plot_attractors as PA
    from cornerbif.basin_stats import share_interval
    text = open("configs/fig06a.toml").read().replace("num = 2001", "num = 3")
    out = str(tmp_path / "w.h5")
    run_sweep(config.loads(text), out)
    tab = A.read_table(out)
    z = 1.959963984540054           # the 0.975 quantile of the normal law
    n = tab["runs_per_point"]
    for k, lo, hi in zip(tab["runs"], tab["share_low"], tab["share_high"]):
        p = k / n                   # Wilson (1927): the score interval, written out
        mid, half = p + z * z / (2 * n), z * np.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
        assert lo == pytest.approx((mid - half) / (1 + z * z / n), abs=1e-12)
        assert hi == pytest.approx((mid + half) / (1 + z * z / n), abs=1e-12)
    rare = {"id": np.arange(2), "word": np.array(["b", "a"], dtype=object),
            "period": np.array([1, 1]), "parameter_point": np.array([0, 0]),
            "runs": np.array([999, 1]), "fraction": np.array([0.999, 0.001]),
            "runs_per_point": 1000, "outcomes": np.array([[1000, 0, 0, 0, 0, 0]]),
            "impacts_per_cycle": np.array([1, 2]), "signature": np.zeros((2, 6)),
            "standard_error": np.zeros(2)}
    rare["share_low"], rare["share_high"] = share_interval(rare["runs"], 1000)
    monkeypatch.setattr(PA, "read_table", lambda path: rare)
    fig, ax = plt.subplots()
    PA.draw_fractions(ax, "unused.h5", np.array([0.0]))
    assert ax.get_yscale() == "log"
    assert ax.get_ylim()[0] <= 0.0005
    plt.close(fig)
