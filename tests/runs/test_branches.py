"""Branches across a sweep and their ends (cornerbif.branches, issue 32), against the paper's
closed forms and the maps' exact plateau ends.

* The flow of Fig. 6(a) (omega = 1.999, r = 0.8): the single-impact orbit ``b`` ends at
  kappa_C (eq 11) in a corner collision with no orbit on the other side, and the
  double-impact orbit ``a`` begins at kappa_CC (eq 17) likewise.  Eqs (11) and (17) are
  exact for the flow (docs/discrepancies.md); the ends are located by continuation, so they
  must meet them to 1e-10 (the issue's tolerance; they meet them to about 1e-15).
* The maps (56) at omega = 1.999, r = 0.8: every plateau end that is a corner collision is an
  end of the word's exact admissible interval (``theory.word_interval``, an independent
  linear-inequality computation), to 1e-10.
* The branch ids and the text of ``cornerbif explain`` depend only on the file's attractor
  table: equal on 1 and 2 threads and on other block sizes.

tests/runs/test_branch_ends_brute.py checks the same ends against a brute-force bisection
that uses the simulator only.
"""

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

from cornerbif import config, theory
from cornerbif.attractors import read_branches, read_table
from cornerbif.cli import main
from cornerbif.errors import SweepInterrupted
from cornerbif.sweep import run_sweep

FLOW = """
[scene]
name = "branches_flow"
model = "flow"
[system]
obstacle = "rectified_sine"
omega = 1.999
kappa = 0.0
beta = 1.0
r = 0.8
[sweep]
kappa = {{ start = {lo}, stop = {hi}, num = 3 }}
[initial]
count = 8
seed = 1
u = [0.0, 20.0]
v = [-20.0, 20.0]
[run]
transient = 500
record = 100
[output]
keep = ["impacts"]
"""

MAPS = """
[scene]
name = "branches_maps"
model = "map2d"
[system]
omega = 1.999
kappa = -0.01
r = 0.8
[sweep]
kappa = { start = -0.0055, stop = -0.003, num = 6 }
[initial]
count = 8
seed = 3
u = [0.5, 14.0]
v = [-0.03, 0.03]
[run]
transient = 2000
record = 200
[output]
keep = ["section"]
"""


def _swept(tmp_path, text, name, **kw):
    out = str(tmp_path / f"{name}.h5")
    run_sweep(config.loads(text), out, **kw)
    return out


def _explained(path):
    r = CliRunner().invoke(main, ["explain", path], catch_exceptions=False)
    assert r.exit_code == 0, r.output
    return read_branches(path), r.stdout


def _branch_of_word(bt, word):
    hits = [b for b in range(len(bt["id"])) if bt["word"][b] == word]
    assert len(hits) == 1, (word, list(bt["word"]))
    return hits[0]


def test_beta_ends_at_kappa_C_with_no_orbit_beyond(tmp_path):
    """``b`` at kappa = -0.0143, -0.0142 (one branch), gone at -0.0141: its end is located at
    kappa_C = theta2 (1 + r)/(1 - r) cot(pi/omega) (eq 11) to 1e-10."""
    path = _swept(tmp_path, FLOW.format(lo=-0.0143, hi=-0.0141), "beta")
    bt, text = _explained(path)
    b = _branch_of_word(bt, "b")
    assert bt["attractors"][b] == 2                      # linked across the two grid values
    assert bt["low_kind"][b] == "range"
    assert bt["high_kind"][b] == "corner"
    assert abs(bt["high_at"][b] - theory.kappa_C(1.999, 0.8)) <= 1e-10
    assert "no orbit on the other side" in bt["high_detail"][b]
    assert "ends: a corner collision at kappa = -0.01413716985" in text


def test_alpha_begins_at_kappa_CC_with_no_orbit_beyond(tmp_path):
    """``a`` at kappa = -0.0022 (reached from the starts), not at -0.0032 (kappa_CC lies
    between; at -0.0027 its basin may hold none of the 8 starts): its beginning is located
    at kappa_CC = beta omega (1 + r)^2/(1 + r^2) cot(pi/omega) (eq 17) to 1e-10."""
    path = _swept(tmp_path, FLOW.format(lo=-0.0032, hi=-0.0022), "alpha")
    bt, _ = _explained(path)
    a = _branch_of_word(bt, "a")
    assert bt["low_kind"][a] == "corner"
    assert abs(bt["low_at"][a] - theory.kappa_CC(1.999, 0.8)) <= 1e-10
    assert bt["high_kind"][a] == "range"


def test_map_plateau_ends_are_the_exact_word_intervals(tmp_path):
    """Every corner-collision end of a branch of the maps is an end of its word's exact
    admissible interval in kappa1 (``theory.word_interval``), to 1e-10; at least the
    plateaus bbg and abbgb are checked at both ends."""
    path = _swept(tmp_path, MAPS, "maps")
    bt, _ = _explained(path)
    checked = []
    for b in range(len(bt["id"])):
        lo, hi = theory.word_interval(bt["word"][b], 1.999 - 2.0, 0.8)
        for side, exact in (("low", lo), ("high", hi)):
            if bt[f"{side}_kind"][b] == "corner":
                assert abs(bt[f"{side}_at"][b] - exact) <= 1e-10, (bt["word"][b], side)
                checked.append((bt["word"][b], side))
    assert {("bbg", "low"), ("bbg", "high"), ("abbgb", "low"), ("abbgb", "high")} <= set(checked)


def test_branch_ids_and_explain_do_not_depend_on_threads_or_blocks(tmp_path):
    """The same scene on 1 thread in blocks of one grid point and on 2 threads in one block:
    equal branch tables and equal ``explain`` text (ids depend on the attractor table only);
    a second ``explain`` reads the stored table and prints the same."""
    text = FLOW.format(lo=-0.0143, hi=-0.0141)
    one = _swept(tmp_path, text, "one", threads=1, block_points=1)
    two = _swept(tmp_path, text, "two", threads=2)
    bt1, out1 = _explained(one)
    bt2, out2 = _explained(two)
    assert out1 == out2
    for k in bt1:
        if k == "axes":
            assert bt1[k] == bt2[k]
        else:
            np.testing.assert_array_equal(bt1[k], bt2[k])
    again = CliRunner().invoke(main, ["explain", one], catch_exceptions=False)
    assert again.stdout == out1
    # every attractor's branch has its word
    with h5py.File(one) as f:
        tab = read_table(f)
    for row, b in enumerate(bt1["branch"]):
        assert tab["word"][row] == bt1["word"][b]


def test_explain_refuses_what_it_cannot_explain(tmp_path):
    """A path that is no sweep, and an unfinished sweep: exit 2, the path named, nothing
    written."""
    junk = tmp_path / "junk.h5"
    junk.write_text("not hdf5")
    r = CliRunner().invoke(main, ["explain", str(junk)])
    assert r.exit_code == 2 and "junk.h5" in r.output and "not an HDF5 file" in r.output
    path = _swept(tmp_path, FLOW.format(lo=-0.0143, hi=-0.0141), "done")
    with h5py.File(path, "r+") as f:
        del f.attrs["completed"]
    before = open(path, "rb").read()
    r = CliRunner().invoke(main, ["explain", path])
    assert r.exit_code == 2 and "not finished" in r.output
    assert open(path, "rb").read() == before


def test_skeleton_figure_needs_the_branch_table(tmp_path):
    """``cornerbif plot --kind branches``: refused (exit 2, saying to run explain) before
    ``explain``, drawn after it."""
    path = _swept(tmp_path, FLOW.format(lo=-0.0143, hi=-0.0141), "skel")
    png = str(tmp_path / "skel.png")
    r = CliRunner().invoke(main, ["plot", path, "-o", png, "--kind", "branches"])
    assert r.exit_code == 2 and "cornerbif explain" in r.output
    _explained(path)
    r = CliRunner().invoke(main, ["plot", path, "-o", png, "--kind", "branches"])
    assert r.exit_code == 0, r.output
    with open(png, "rb") as f:
        assert f.read(8) == b"\x89PNG\r\n\x1a\n"


TWO = """
[scene]
name = "branches_two"
model = "two_particle"
[system]
omega0 = 1.999
[sweep]
omega0 = { start = 1.996, stop = 2.002, num = 4 }
[initial]
count = 4
seed = 19
[run]
transient = 300
record = 100
[output]
keep = ["section"]
"""


def test_two_particle_attractors_link_across_the_grid(tmp_path):
    """two_particle's orbit problem spells its itinerary in events (U, W), the table in
    corner letters: linked by the series and signature, 'ab' at omega0 = 1.996 and 1.998 is
    one branch, and so is 'b' at 2.0 and 2.002 (each attractor of the table at two grid
    values, the same orbit continued)."""
    text = TWO
    base = open("configs/fig19a.toml").read()
    system = base[base.index("[system]"):base.index("[sweep]")]
    text = text.replace('[system]\nomega0 = 1.999\n', system)
    path = _swept(tmp_path, text, "two")
    bt, _ = _explained(path)
    with h5py.File(path) as f:
        tab = read_table(f)
    for word in ("ab", "b"):
        rows = [r for r in range(len(tab["id"])) if tab["word"][r] == word]
        assert len(rows) == 2, (word, list(tab["word"]))
        assert bt["branch"][rows[0]] == bt["branch"][rows[1]], word


def _run_cli(*args):
    return CliRunner().invoke(main, list(args))


def test_explain_refuses_files_it_cannot_follow(tmp_path):
    """exit 2, nothing written: no attractor in the table (a scene where every run escapes
    or finds no cycle), a flow file that does not keep the impacts its orbits are solved
    from, an axis with a repeated value."""
    nokeep = _swept(tmp_path, FLOW.format(lo=-0.0143, hi=-0.0141).replace(
        'keep = ["impacts"]', "keep = []"), "nokeep")
    before = open(nokeep, "rb").read()
    r = _run_cli("explain", nokeep)
    assert r.exit_code == 2 and "does not keep 'impacts'" in r.output, r.output
    assert open(nokeep, "rb").read() == before
    # beta = 0 (a fixed wall) with kappa above the forced motion's reach: no run impacts
    none = """
[scene]
name = "none"
model = "flow"
[system]
obstacle = "sine"
omega = 2.5
beta = 0.0
r = 0.8
F = 1.0
Omega = 2.5
[sweep]
kappa = { start = 1.5, stop = 1.6, num = 2 }
[initial]
count = 4
seed = 1
u = [0.6, 3.0]
v = [-1.0, 1.0]
[run]
transient = 3000
record = 60
[output]
keep = ["impacts"]
"""
    path = _swept(tmp_path, none, "none")
    before = open(path, "rb").read()
    r = _run_cli("explain", path)
    assert r.exit_code == 2 and "no attractor to follow" in r.output, r.output
    assert open(path, "rb").read() == before
    dup = FLOW.format(lo=0, hi=0).replace(
        "kappa = { start = 0, stop = 0, num = 3 }", "kappa = { values = [-0.0143, -0.0142, -0.0142] }")
    path = _swept(tmp_path, dup, "dup")
    r = _run_cli("explain", path)
    assert r.exit_code == 2 and "repeats a value" in r.output, r.output


def test_unsorted_values_are_followed_in_their_order(tmp_path):
    """kappa = [-0.0142, -0.0141, -0.0143]: 'b' at -0.0142 and -0.0143 is one branch, and it
    ends at kappa_C (eq 11) between -0.0142 and -0.0141 as on a sorted grid."""
    text = FLOW.format(lo=0, hi=0).replace(
        "kappa = { start = 0, stop = 0, num = 3 }", "kappa = { values = [-0.0142, -0.0141, -0.0143] }")
    path = _swept(tmp_path, text, "unsorted")
    bt, _ = _explained(path)
    b = _branch_of_word(bt, "b")
    assert bt["attractors"][b] == 2
    assert bt["high_kind"][b] == "corner"
    assert abs(bt["high_at"][b] - theory.kappa_C(1.999, 0.8)) <= 1e-10
    assert bt["low_kind"][b] == "range"


def test_explain_prints_but_never_breaks_a_file_it_may_not_write(tmp_path):
    """A read-only file: explained (exit 0), the table printed, the file unchanged and said
    not stored.  A link: the table is stored in the file it points to, the link stays a
    link."""
    import os
    path = _swept(tmp_path, FLOW.format(lo=-0.0143, hi=-0.0141), "ro")
    os.chmod(path, 0o444)
    before = open(path, "rb").read()
    r = _run_cli("explain", path)
    assert r.exit_code == 0 and "not stored" in r.output and "the file is read-only" in r.output
    assert open(path, "rb").read() == before
    assert os.stat(path).st_mode & 0o777 == 0o444
    target = _swept(tmp_path, FLOW.format(lo=-0.0143, hi=-0.0141), "target")
    link = tmp_path / "link.h5"
    os.symlink(target, link)
    r = _run_cli("explain", str(link))
    assert r.exit_code == 0 and "not stored" not in r.output, r.output
    assert os.path.islink(link)
    assert read_branches(target) is not None


def test_explain_of_a_basin_gives_its_statistics(tmp_path):
    """A basin (two swept start coordinates, Fig. 7(b)'s wedge at omega = 2.001, kappa =
    0.008, 31 x 21 starts): ``explain`` prints its size in the axes' order, each attractor's
    cells and share (a grid quadrature) with its cells on a boundary (counted here cell by
    cell: a 4-neighbour of another label), the basin entropy and the uncertainty exponent of
    ``basin_stats`` (tested against closed forms in test_basin_stats.py), the counts adding
    up to the cells.  A 4 x 4 basin is too small for boxes of 5 and for two scales: said,
    not computed."""
    from cornerbif.basin_stats import basin_entropy, uncertainty_exponent
    text = open("configs/basin_hysteresis.toml").read()
    text = text.replace("transient = 3000", "transient = 1500")
    text = text.replace("initial.u = { start = 0.5, stop = 20.0, num = 201 }",
                        "initial.u = { start = 0.5, stop = 20.0, num = 31 }")
    text = text.replace("initial.v = { start = -0.02, stop = 0.02, num = 201 }",
                        "initial.v = { start = -0.02, stop = 0.02, num = 21 }")
    path = _swept(tmp_path, text, "basin")
    r = CliRunner().invoke(main, ["explain", path], catch_exceptions=False)
    assert r.exit_code == 0, r.output
    assert "a basin of 31 x 21 starts (initial.u, initial.v)" in r.stdout
    with h5py.File(path) as f:
        labels = f["attractor"][...][..., 0]
        tab = read_table(f)
    assert labels.shape == (31, 21)
    counts = [int(np.sum(labels == i)) for i in tab["id"]]
    assert sum(counts) + int(np.sum(labels < 0)) == 31 * 21
    for i, k in zip(tab["id"], counts):
        edge = sum(1 for x in range(31) for y in range(21) if labels[x, y] == i and any(
            0 <= x + dx < 31 and 0 <= y + dy < 21 and labels[x + dx, y + dy] != i
            for dx, dy in ((1, 0), (-1, 0), (0, 1), (0, -1))))
        assert f"attractor {i}: " in r.stdout
        assert f"{k} cells, share {k / 651:.4g} (a grid quadrature: {edge} of its cells" in r.stdout
    sb, sbb, nb = basin_entropy(labels, box=5)
    assert f"basin entropy Sb = {sb:.4g}, boundary basin entropy Sbb = {sbb:.4g} over {nb} " in r.stdout
    alpha, se, _, _ = uncertainty_exponent(labels)
    assert f"uncertainty exponent alpha = {alpha:.3g} +- {se:.2g}" in r.stdout
    small = text.replace("num = 31", "num = 4").replace("num = 21", "num = 4")
    path = _swept(tmp_path, small, "small")
    r = CliRunner().invoke(main, ["explain", path], catch_exceptions=False)
    assert r.exit_code == 0, r.output
    assert "basin entropy: not computed" in r.stdout
    assert "uncertainty exponent: not computed" in r.stdout


FOLD = """
[scene]
name = "branches_fold"
model = "flow"
[system]
obstacle = "sine"
omega = 2.5
kappa = 0.5
beta = 0.0
r = 0.8
sigma = 0.0
k = 1.0
F = 1.0
Omega = 2.5
[sweep]
kappa = { start = 0.5, stop = 1.6, num = 6 }
[initial]
count = 4
seed = 1
u = [0.6, 3.0]
v = [-1.0, 1.0]
[run]
transient = 3000
record = 60
[output]
keep = ["impacts"]
"""


def test_a_fold_is_located_at_its_closed_form(tmp_path):
    """A fixed stop (beta = 0) at kappa under u'' + u = F cos(Omega t + phi), r = 0.8: the
    single-impact period-T orbit (T = 2 pi / Omega) with impact velocity -V, phase phi and
    P = F / (1 - Omega^2) satisfies, from u(T) = kappa and u'(T) = -V after u'(0) = r V
    (derived in docs/basins.md):
        P cos(phi) = kappa - a V,  P sin(phi) = b V,  a = (1 + r)/2 cot(T/2),  b = (1 - r)/(2 Omega),
    so (a^2 + b^2) V^2 - 2 a kappa V + kappa^2 - P^2 = 0 has real roots only for
    kappa <= |P| sqrt(a^2 + b^2) / b: the saddle-node (fold) of the orbit, 1.405479843094...
    The branch of this orbit ends there, in a fold, to 1e-10 (measured: 3e-16)."""
    import math
    P = 1.0 / (1.0 - 2.5 ** 2)
    T = 2.0 * math.pi / 2.5
    a = 0.9 / math.tan(T / 2.0)
    b = 0.2 / (2.0 * 2.5)
    kappa_fold = abs(P) * math.hypot(a, b) / b
    path = _swept(tmp_path, FOLD, "fold")
    bt, text = _explained(path)
    one = [b_ for b_ in range(len(bt["id"])) if bt["period"][b_] == 1
           and bt["impacts_per_cycle"][b_] == 1]
    assert len(one) == 1, text
    assert bt["high_kind"][one[0]] == "fold", text
    assert abs(bt["high_at"][one[0]] - kappa_fold) <= 1e-10, (bt["high_at"][one[0]], kappa_fold)


def test_a_period_doubling_is_located_at_its_closed_form(tmp_path):
    """The same fixed stop and orbit as the fold's, at small kappa.  Its monodromy over one
    period is J = S M(T): the flight M(T) = [[cos T, sin T], [-sin T, cos T]] (k = 1,
    sigma = 0) and the saltation of law (5) at a wall at rest, S = [[-r, 0], [q, -r]], with
    q = (1 + r) A / v-, v- = -V and A = u'' at the impact = -kappa + F cos(phi) =
    -Omega^2 kappa - (1 - Omega^2) a V (derived here from the saltation formula
    S = G + (f+ - G f-) n^T / (n^T f-), G = diag(1, -r), n = (1, 0); not the kernel's code).
    det J = r^2, so a multiplier crosses -1 where tr J = -2 r cos T + q sin T = -(1 + r^2):
    with V(kappa) the larger root of the fold's quadratic, bisection gives kappa_PD =
    -0.0766752106693865.  Below it the orbit, going down in kappa, ends in a period
    doubling located there to 1e-10 (measured: 1e-17)."""
    import math
    F, W, r = 1.0, 2.5, 0.8
    P = F / (1.0 - W * W)
    T = 2.0 * math.pi / W
    a = (1.0 + r) / 2.0 / math.tan(T / 2.0)
    b = (1.0 - r) / (2.0 * W)

    def excess(kappa):             # tr J + 1 + det J along the orbit
        A2, B, C = a * a + b * b, -2.0 * a * kappa, kappa * kappa - P * P
        V = (-B + math.sqrt(B * B - 4.0 * A2 * C)) / (2.0 * A2)
        A = -W * W * kappa - (1.0 - W * W) * a * V
        return -2.0 * r * math.cos(T) - (1.0 + r) * A * math.sin(T) / V + 1.0 + r * r

    lo, hi = -0.19, 0.0            # V > 0 above kappa = -|P| = -0.1905 (a grazing there)
    assert excess(lo) < 0.0 < excess(hi)
    for _ in range(200):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if excess(mid) < 0.0 else (lo, mid)
    text = FOLD.replace("kappa = { start = 0.5, stop = 1.6, num = 6 }",
                        "kappa = { start = -0.1, stop = 0.2, num = 7 }")
    bt, out = _explained(_swept(tmp_path, text, "pd"))
    one = _branch_of_word(bt, "x")
    assert bt["low_kind"][one] == "period_doubling", out
    assert abs(bt["low_at"][one] - lo) <= 1e-10, (bt["low_at"][one], lo)


def test_a_diagram_coloured_by_branch(tmp_path):
    """``cornerbif plot --kind diagram --orbits branches``: refused (exit 2, saying to run
    explain) before ``explain``; after it, drawn, with one label per branch ("#branch N")."""
    from cornerbif import plot_attractors as PA
    path = _swept(tmp_path, FLOW.format(lo=-0.0143, hi=-0.0141), "colour")
    png = str(tmp_path / "c.png")
    args = ["plot", path, "-o", png, "--kind", "diagram", "--orbits", "branches"]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 2 and "cornerbif explain" in r.output, r.output
    bt, _ = _explained(path)
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
    names, row = PA.label_rows(PA.read_table(path), branches=True)
    assert len(names) == len(bt["id"])
    assert all(n.split("#branch ")[1].isdigit() for n in names)


@pytest.mark.slow
def test_branch_ids_are_the_same_on_dask(tmp_path):
    """The same scene on the Dask backend (a local cluster of 2 workers) and locally: equal
    ``explain`` text and branch tables (its files are bitwise the local backend's,
    test_distributed.py; the chaos pass and explain run on the finished file)."""
    pytest.importorskip("distributed")
    text = FLOW.format(lo=-0.0143, hi=-0.0141)
    here = _swept(tmp_path, text, "here")
    there = _swept(tmp_path, text, "there", scheduler="local:2")
    bt1, out1 = _explained(here)
    bt2, out2 = _explained(there)
    assert out1 == out2
    for k in bt1:
        if k != "axes":
            np.testing.assert_array_equal(bt1[k], bt2[k])


CHART = """
[scene]
name = "branches_chart"
model = "{model}"
[system]
{system}
omega = 2.0
kappa = 0.0
r = 0.8
[sweep]
omega = {{ start = {w0}, stop = {w1}, num = {nw} }}
kappa = {{ start = -0.03, stop = 0.03, num = 21 }}
[initial]
count = 4
seed = 1
u = [0.0, 20.0]
v = [-0.02, 0.02]
[run]
transient = {transient}
record = 240
[output]
keep = ["{keep}"]
"""


def _edges_of(bt, f, word, axis, kind="corner"):
    """(attractor's other coordinate, step, located value) of a word's edges along ``axis``
    (0 omega, 1 kappa) of the given kind."""
    E = bt["edges"]
    other = f["attractors/at_" + ("kappa" if axis == 0 else "omega")][...]
    sel = np.flatnonzero(np.isin(E["branch"], [b for b in range(len(bt["id"]))
                                                if bt["word"][b] == word])
                         & (E["axis"] == axis) & (E["kind"] == kind))
    return [(float(other[E["attractor"][i]]), int(E["step"][i]), float(E["at"][i]))
            for i in sel]


def test_map_chart_edges_are_the_exact_word_intervals(tmp_path):
    """A chart of the maps (56) over (omega, kappa): every branch's edges are located along
    both axes, and every corner-collision edge lies on the boundary of its word's exact
    admissible region (``theory.word_interval`` at the edge's omega, an independent
    linear-inequality computation): along kappa the located kappa is the interval's end
    that way, along omega the attractor's kappa is an end of the interval at the located
    omega (or it is the apex (2, 0), where every word's region closes); both to 1e-10.
    ``a`` is one branch over many grid values (linked along both
    axes: its series has one entry per iterate, not per impact)."""
    text = CHART.format(model="map2d", system="", w0=1.998, w1=2.002, nw=5, transient=3000,
                        keep="section")
    path = _swept(tmp_path, text, "chart_maps")
    bt, out = _explained(path)
    a = _branch_of_word(bt, "a")
    assert bt["attractors"][a] > 20
    E = bt["edges"]
    assert (E["kind"] == "corner").sum() > 50
    with h5py.File(path) as f:
        om, ka = f["attractors/at_omega"][...], f["attractors/at_kappa"][...]
    checked = set()
    for i in np.flatnonzero(E["kind"] == "corner"):
        word = bt["word"][E["branch"][i]]
        row, at = E["attractor"][i], E["at"][i]
        if E["axis"][i] == 1:
            lo, hi = theory.word_interval(word, om[row] - 2.0, 0.8)
            assert abs(at - (hi if E["step"][i] > 0 else lo)) <= 1e-10, (word, om[row])
        else:
            lo, hi = theory.word_interval(word, at - 2.0, 0.8)
            if np.isnan(lo):       # the apex (omega, kappa) = (2, 0), where every region
                assert abs(at - 2.0) <= 1e-10 and ka[row] == 0.0     # closes to a point
                continue
            assert min(abs(ka[row] - lo), abs(ka[row] - hi)) <= 1e-10, (word, ka[row])
        checked.add((word, int(E["axis"][i])))
    assert {("a", 0), ("a", 1), ("b", 0), ("b", 1)} <= checked
    assert "edges going down in kappa: a corner collision x " in out


def test_flow_chart_edges_meet_eqs_11_and_17(tmp_path):
    """A chart of the flow at omega = 1.998 and 2.002: along kappa the single-impact orbit
    ``b`` ends at kappa_C(omega) (eq 11) and the double-impact orbit ``a`` begins at
    kappa_CC(omega) (eq 17), on each omega grid line, to 1e-10.  The table is stored in the
    file, and explain's text from it equals the recomputed one."""
    text = CHART.format(model="flow", system='obstacle = "rectified_sine"\nbeta = 1.0',
                        w0=1.998, w1=2.002, nw=2, transient=1500, keep="impacts")
    path = _swept(tmp_path, text, "chart_flow")
    bt, out = _explained(path)
    with h5py.File(path) as f:
        b_ends = _edges_of(bt, f, "b", 1)
        a_ends = _edges_of(bt, f, "a", 1)
    assert sorted((w, s) for w, s, _ in b_ends) == [(1.998, 1), (2.002, 1)]
    assert sorted((w, s) for w, s, _ in a_ends) == [(1.998, -1), (2.002, -1)]
    for w, _, at in b_ends:
        assert abs(at - theory.kappa_C(w, 0.8)) <= 1e-10
    for w, _, at in a_ends:
        assert abs(at - theory.kappa_CC(w, 0.8)) <= 1e-10
    r = CliRunner().invoke(main, ["explain", path, "--recompute"], catch_exceptions=False)
    assert r.exit_code == 0 and r.stdout == out


def test_branch_ids_and_edges_are_the_same_after_a_resume(tmp_path, monkeypatch):
    """The maps' chart swept whole, and swept in blocks of 5 grid points interrupted (an
    interrupt at the third block's write) then resumed: equal branch tables, edges included,
    and equal ``explain`` text."""
    from cornerbif import engine
    from cornerbif import sweep as sweep_mod
    text = CHART.format(model="map2d", system="", w0=1.998, w1=2.002, nw=3, transient=3000,
                        keep="section")
    whole = _swept(tmp_path, text, "whole")
    scene = config.loads(text)
    monkeypatch.setattr(engine, "BLOCK_BYTES", 5 * 4 * engine.item_bytes(scene))
    real = sweep_mod.io.write_block
    calls = {"n": 0}

    def interrupted(f, index, block):
        calls["n"] += 1
        if calls["n"] == 3:
            raise KeyboardInterrupt
        real(f, index, block)

    monkeypatch.setattr(sweep_mod.io, "write_block", interrupted)
    part = str(tmp_path / "part.h5")
    with pytest.raises(SweepInterrupted):
        run_sweep(scene, part)
    monkeypatch.setattr(sweep_mod.io, "write_block", real)
    run_sweep(scene, part, resume=True)
    assert calls["n"] == 3
    bt1, out1 = _explained(whole)
    bt2, out2 = _explained(part)
    assert out1.replace("whole", "") == out2.replace("part", "") and "edges" in bt1
    for k in bt1:
        if k == "axes":
            assert bt1[k] == bt2[k]
        elif k == "edges":
            for c in bt1[k]:
                np.testing.assert_array_equal(bt1[k][c], bt2[k][c])
        else:
            np.testing.assert_array_equal(bt1[k], bt2[k])


def test_a_table_stored_by_an_older_cornerbif_is_located_again(tmp_path):
    """A two-parameter table stored without /branch_edges and without /branches' version
    (an older cornerbif) is not read back as if it had no edges: explain locates it again
    (the edges then stored), and the skeleton is refused, saying to recompute, before
    that."""
    from cornerbif.branches import TABLE_VERSION
    text = CHART.format(model="map2d", system="", w0=1.998, w1=2.002, nw=3, transient=3000,
                        keep="section")
    path = _swept(tmp_path, text, "old")
    bt, out = _explained(path)
    with h5py.File(path, "a") as f:
        del f["branch_edges"]
        del f["branches"].attrs["version"]
    r = CliRunner().invoke(main, ["plot", path, "--kind", "branches", "-o",
                                  str(tmp_path / "s.png")])
    assert r.exit_code != 0 and "--recompute" in r.output
    again, out2 = _explained(path)
    assert out2 == out and len(again["edges"]["branch"]) == len(bt["edges"]["branch"]) > 0
    with h5py.File(path) as f:
        assert f["branches"].attrs["version"] == TABLE_VERSION
