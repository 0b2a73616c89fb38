"""``cornerbif plot`` and ``cornerbif info`` as safe as ``sweep``: safe outputs, true
messages.

* ``plot -o`` passes the one output guard (``outputs.check_output``) before anything is read:
  never an input, a style sheet, a file that is not a figure of its format; an overlong name
  is said of the output; the figure is written whole or not at all (a file-size limit or an
  interrupt leaves the previous figure as it was, and no temporary file).
* What one figure draws together is checked before drawing (``plot.check_together``): files
  swept over different parameters or of different models, a chart with another file,
  branches over another parameter's diagram are refused by name (exit 2).
* Every option is applied or refused with a reason: ``--color-by``, ``--y``, ``--style``,
  ``--title``.
* Crafted files: an unknown status is shown with its number, a file with no finished point
  is refused, a partial one says how many points are finished.
* ``info`` summarises by status, summarises continuation files, wraps the dataset names and
  bounds every free text.
* No warning of matplotlib's or numpy's reaches the user.

Each refusal: exit 2, no traceback, the file named, no figure left behind.  The scenes are
the shipped ones made tiny (``gallery.smoke_raw``: 3 values per axis, 3 starts, 40 + 40
impacts).
"""

import os
import resource
import shutil
import subprocess
import sys
import textwrap
import tomllib

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from conftest import fill_disk

from cornerbif import config, continuation_run, gallery, plot_style
from cornerbif.cli import main
from cornerbif.sweep import run_sweep

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CONFIGS = os.path.join(ROOT, "configs")
# the shipped scenes each test draws from (tiny versions)
SCENES = ("fig06a", "fig07b_up", "fig07b_down", "fig16a", "fig16b", "fig19a", "chart_flow",
          "chart_flow_lyapunov", "basin_maps", "fig09_flow", "fig09_map", "fig01b",
          "cont_beta")


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def refused(r, *needles):
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output
    for n in needles:
        assert n in r.output, (n, r.output)
    return r.output


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """NAME -> the tiny file of each scene in SCENES (a continuation for cont_*)."""
    d = tmp_path_factory.mktemp("files")
    out = {}
    for name in SCENES:
        scene = gallery.load_scene(os.path.join(CONFIGS, f"{name}.toml"), smoke=True)
        path = str(d / f"{name}.h5")
        if scene.cont:
            continuation_run.write(continuation_run.run_scene(scene, log=lambda *a: None), path)
        else:
            run_sweep(scene, path, overwrite=True, progress=False, command="test")
        out[name] = path
    return out


@pytest.fixture
def work(tmp_path, files):
    """A copy of ``files`` in a fresh folder (each test may craft its own)."""
    out = {}
    for name, p in files.items():
        out[name] = str(tmp_path / os.path.basename(p))
        shutil.copy(p, out[name])
    return out


def no_figures(folder):
    """No figure and no temporary file left in ``folder``."""
    return not [f for f in os.listdir(folder) if f.endswith((".png", ".pdf", ".svg", ".partial"))]


# ------------------------------------------------------------------ 1. the output guard
def test_plot_output_is_guarded_before_anything_is_read(tmp_path, work):
    """-o never replaces an input (a file drawn, a style sheet, whatever its name), a file
    that is not a figure of its format, nor a directory; an overlong name is said of -o
    (before: the file was overwritten, or the error blamed the input file); an existing
    figure is redrawn."""
    sweep = work["fig06a"]
    before = open(sweep, "rb").read()
    refused(run("plot", sweep, "-o", sweep), "must be .png")
    alias = tmp_path / "same.png"
    os.symlink(sweep, alias)
    refused(run("plot", sweep, "-o", alias), "the file to draw itself")
    sheet = tmp_path / "sheet.png"                       # a style sheet with a figure's name
    sheet.write_text("lines.linewidth: 2\n")
    refused(run("plot", sweep, "--style", sheet, "-o", sheet), "the style sheet itself")
    assert sheet.read_text() == "lines.linewidth: 2\n"
    notes = tmp_path / "notes.png"
    notes.write_text("my notes, not a PNG")
    refused(run("plot", sweep, "-o", notes), "-o", "is not a figure of the same format")
    assert notes.read_text() == "my notes, not a PNG"
    pdf_as_png = tmp_path / "x.pdf"
    shutil.copy(os.path.join(ROOT, "docs", "gallery", "fig06a.png"), pdf_as_png)
    refused(run("plot", sweep, "-o", pdf_as_png), "is not a figure of the same format")
    (tmp_path / "d.png").mkdir()
    r = run("plot", sweep, "-o", tmp_path / "d.png")
    assert r.exit_code == 2 and "directory" in r.output
    long_ = tmp_path / ("f" * 250 + ".png")
    out = refused(run("plot", sweep, "-o", long_), "-o", "too long")
    assert sweep not in out.replace(str(long_), "")          # the output is blamed, not the input
    assert open(sweep, "rb").read() == before
    fig = tmp_path / "fig.png"
    assert run("plot", sweep, "-o", fig).exit_code == 0
    first = fig.stat().st_mtime_ns
    r = run("plot", sweep, "-o", fig, "--title", "again")
    assert r.exit_code == 0 and fig.stat().st_mtime_ns >= first
    assert sorted(p.name for p in tmp_path.iterdir() if p.suffix == ".partial") == []


def _limited(limit):
    def pre():
        resource.setrlimit(resource.RLIMIT_FSIZE, (limit, limit))
    return pre


def test_a_file_size_limit_keeps_the_previous_figure(tmp_path, work):
    """Under ``ulimit -f`` smaller than the figure, plot ends with one message naming -o and
    exit 1; the figure drawn before is byte for byte as it was and no temporary file is
    left (before: a truncated figure in its place, and exit 2 calling the input damaged)."""
    fig = tmp_path / "f.png"
    assert run("plot", work["fig06a"], "-o", fig).exit_code == 0
    old = fig.read_bytes()
    assert len(old) > 20000
    r = subprocess.run([sys.executable, "-m", "cornerbif.cli", "plot", work["fig06a"], "-o",
                        str(fig), "--title", "another"], capture_output=True, text=True,
                       timeout=300, preexec_fn=_limited(8192),
                       env=dict(os.environ, MPLBACKEND="Agg"))
    assert r.returncode == 1, r.stderr
    assert "Traceback" not in r.stderr
    errors = [x for x in r.stderr.splitlines() if x.startswith("error:")]
    assert len(errors) == 1 and str(fig) in errors[0] and "EFBIG" in errors[0], r.stderr
    assert "unchanged" in errors[0]
    assert fig.read_bytes() == old
    assert not os.path.exists(str(fig) + ".partial")


def test_a_full_disk_keeps_the_previous_figure(work, tmpfs):
    """A real full filesystem (a 4 MiB tmpfs, filled; skipped where mounting is refused):
    plot ends with one message naming -o and ENOSPC, exit 1; the figure drawn before is as
    it was and no temporary file is left (before: a truncated figure in its place)."""
    mnt = tmpfs("4M")
    fig = mnt / "f.png"
    assert run("plot", work["fig06a"], "-o", fig).exit_code == 0
    old = fig.read_bytes()
    fill_disk(mnt / "filler")
    r = run("plot", work["fig06a"], "-o", fig, "--title", "another")
    assert r.exit_code == 1, r.output
    assert "Traceback" not in r.output
    assert str(fig) in r.output and "ENOSPC" in r.output and "unchanged" in r.output
    assert fig.read_bytes() == old
    assert not os.path.exists(str(fig) + ".partial")


def test_an_interrupt_while_saving_keeps_the_previous_figure(tmp_path, work, monkeypatch):
    """Ctrl-C while the figure is being written (half of it on disk): exit 130, a message
    that says nothing was written, the previous figure as it was, no temporary file."""
    import matplotlib.figure
    fig = tmp_path / "f.png"
    assert run("plot", work["fig06a"], "-o", fig).exit_code == 0
    old = fig.read_bytes()

    def half_then_interrupt(self, path, **kw):
        with open(path, "wb") as fh:
            fh.write(old[: len(old) // 2])
        raise KeyboardInterrupt
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", half_then_interrupt)
    r = run("plot", work["fig06a"], "-o", fig)
    assert r.exit_code == 130, r.output
    assert "no figure written" in r.output
    assert fig.read_bytes() == old
    assert not os.path.exists(str(fig) + ".partial")


# ------------------------------------------------------------------ 2. what is drawn together
def test_files_swept_over_different_parameters_are_refused_by_name(tmp_path, work):
    """A map2d kappa sweep with the two-particle omega0 sweep (before: omega0 values drawn at
    'kappa = ...'), a diagram with a chart (before: 'damaged'), two charts (before: the
    second silently left out): exit 2, each file named with what it sweeps, no figure."""
    out = tmp_path / "f.png"
    msg = refused(run("plot", work["fig16b"], work["fig19a"], "-o", out),
                  "sweep the same parameter", work["fig16b"], work["fig19a"], "kappa", "omega0",
                  "map2d", "two_particle")
    assert "damaged" not in msg
    refused(run("plot", work["fig06a"], work["chart_flow"], "-o", out),
            "a chart (two swept parameters) draws one file", work["chart_flow"])
    refused(run("plot", work["chart_flow"], work["chart_flow_lyapunov"], "-o", out),
            "draws one file", work["chart_flow_lyapunov"])
    # one parameter, but of models other than a flow and its map
    refused(run("plot", work["fig06a"], work["fig16a"], work["fig16b"], "-o", out),
            "different models", work["fig16b"])
    assert no_figures(tmp_path)


def test_what_one_figure_draws_together(tmp_path, work):
    """Followed sweeps up and down (Fig. 7(b)), a flow against its map over one parameter
    (Fig. 16) and of single runs (Fig. 9), and branches over the diagram of their parameter
    are drawn (exit 0); a flow and its map at other system values, or over other values, and
    branches over another parameter's diagram or over a chart are refused by name."""
    ok = [(work["fig07b_up"], work["fig07b_down"]), (work["fig16a"], work["fig16b"]),
          (work["fig09_flow"], work["fig09_map"]), (work["fig06a"], work["cont_beta"]),
          (work["cont_beta"],)]
    for i, pair in enumerate(ok):
        r = run("plot", *pair, "-o", tmp_path / f"ok{i}.png")
        assert r.exit_code == 0, (pair, r.output)
    out = tmp_path / "no.png"
    with h5py.File(work["fig16b"], "r+") as f:         # the map at another restitution
        f.attrs["scene"] = f.attrs["scene"].replace("r = 0.8", "r = 0.5")
    refused(run("plot", work["fig16a"], work["fig16b"], "-o", out), "not one system",
            "r = 0.8 and 0.5")
    with h5py.File(work["fig16b"], "r+") as f:
        f.attrs["scene"] = f.attrs["scene"].replace("r = 0.5", "r = 0.8")
        f["kappa"][...] = f["kappa"][...] + 1e-4
    refused(run("plot", work["fig16a"], work["fig16b"], "-o", out), "different values")
    refused(run("plot", work["fig19a"], work["cont_beta"], "-o", out), work["cont_beta"],
            "continued in 'kappa'", "omega0")
    refused(run("plot", work["chart_flow"], work["cont_beta"], "-o", out), work["cont_beta"],
            "drawn over a diagram of one swept parameter")
    with h5py.File(work["cont_beta"], "r+") as f:       # branches of another system
        f.attrs["scene"] = f.attrs["scene"].replace("omega = 1.999", "omega = 2.001")
    refused(run("plot", work["fig06a"], work["cont_beta"], "-o", out), work["cont_beta"],
            "not one system", "omega = 2.001 and 1.999")
    refused(run("plot", work["fig09_flow"], work["fig16b"], "-o", out), work["fig16b"])
    assert not out.exists() and not os.path.exists(str(out) + ".partial")


# ------------------------------------------------------------------ 3. options
def test_every_option_is_applied_or_refused_with_a_reason(tmp_path, work):
    """--color-by on a continuation file (before: silently ignored), on a basin or an overlay;
    --y on a chart (before: ignored) or on a file without it among several (before: a
    crash called 'damaged'); --style naming no sheet or a sheet matplotlib would only warn
    about (before: drawn after matplotlib's warning); --title matplotlib cannot draw (before:
    'damaged'): exit 2, the option named.  A --title of 100 000 characters is cut (said on
    stderr) and drawn."""
    out = tmp_path / "f.png"
    refused(run("plot", work["cont_beta"], "--color-by", "lyapunov", "-o", out),
            "--color-by lyapunov", "stable solid, unstable dashed")
    refused(run("plot", work["basin_maps"], "--color-by", "multiplier", "-o", out),
            "--color-by multiplier", "basin")
    refused(run("plot", work["fig07b_up"], work["fig07b_down"], "--color-by", "lyapunov", "-o",
                out), "--color-by lyapunov", "one file")
    refused(run("plot", work["fig06a"], "--color-by", "lyapunov", "-o", out),
            "no stability/ datasets", work["fig06a"])
    refused(run("plot", work["chart_flow"], "--y", "impact_u", "-o", out), "--y impact_u",
            "chart")
    refused(run("plot", work["fig01b"], "--y", "period", "-o", out), "--y period",
            "'timeseries'")
    refused(run("plot", work["fig16a"], work["fig16b"], "--y", "impact_u", "-o", out),
            work["fig16b"], "holds no impact_u values")
    refused(run("plot", work["fig06a"], "--style", tmp_path / "none.mplstyle", "-o", out),
            "--style", "none.mplstyle")
    bad = tmp_path / "bad.mplstyle"
    bad.write_text("lines.linewidth: 1\nfoo.bar: 3\n")
    refused(run("plot", work["fig06a"], "--style", bad, "-o", out), "--style", "line 2",
            "'foo.bar' is not a matplotlib setting")
    bad.write_text("lines.linewidth: big\n")
    refused(run("plot", work["fig06a"], "--style", bad, "-o", out), "line 1",
            "not a value of lines.linewidth")
    if not plot_style.latex_available():     # (before: drawn, then blamed on the file)
        bad.write_text("text.usetex: True\n")
        refused(run("plot", work["fig06a"], "--style", bad, "-o", out), "--style", "line 1",
                "text.usetex", "LaTeX, which is not installed")
    refused(run("plot", work["fig06a"], "--title", r"$\foo$ x", "-o", out), "--title",
            "matplotlib cannot draw")
    assert no_figures(tmp_path)
    r = run("plot", work["fig06a"], "--title", "t" * 100_000, "-o", out)
    assert r.exit_code == 0 and "--title has 100000 characters" in r.output, r.output[-500:]
    assert out.stat().st_size > 10000


def test_the_scenes_color_by_applies_where_it_can(tmp_path, work):
    """A scene's own [plot] color_by (chart_flow_lyapunov's) is applied to its file alone and
    never refuses a figure; an explicit --color-by that does not apply is refused."""
    assert run("plot", work["chart_flow_lyapunov"], "-o", tmp_path / "a.png").exit_code == 0
    with h5py.File(work["fig06a"], "r+") as f:
        s = f.attrs["scene"]
        f.attrs["scene"] = (s.replace("[plot]\n", '[plot]\ncolor_by = "lyapunov"\n', 1)
                            if "[plot]\n" in s else s + '\n[plot]\ncolor_by = "lyapunov"\n')
    r = run("plot", work["fig06a"], "-o", tmp_path / "b.png")
    assert r.exit_code == 0, r.output


# ------------------------------------------------------------------ 4. crafted files
@pytest.mark.parametrize("name", ["fig06a", "fig19a", "basin_maps", "cont_beta"])
def test_a_stored_plot_table_is_checked_as_validate_checks_it(tmp_path, work, name):
    """A file whose stored scene says ``[plot] marker_size = 1e300`` (or an xlim of inf, a
    kind that is none) is refused at once by plot, naming the file and the key, by the
    check validate makes (config: marker sizes in (0, 100]); before, a sweep, two-particle
    or map file ran 90-110 s before matplotlib's "Exceeded cell block limit".  info still
    summarises it."""
    path = work[name]
    out = tmp_path / "f.png"
    for key, value in (("marker_size", "1e300"), ("xlim", "[0.0, inf]"),
                       ("marker_size", '"big"')):
        with h5py.File(path, "r+") as f:
            s = f.attrs["scene"]
            s = s.replace("[plot]\n", "[plot]\nXX\n", 1) if "[plot]\n" in s else s + "\n[plot]\nXX\n"
            f.attrs["scene"] = s.replace("XX", f"{key} = {value}")
        refused(run("plot", path, "-o", out), path, "stored scene's [plot]", f"plot.{key}")
        assert no_figures(tmp_path)
        assert run("info", path).exit_code == 0
        with h5py.File(path, "r+") as f:
            f.attrs["scene"] = f.attrs["scene"].replace(f"{key} = {value}\n", "")


def test_unknown_status_codes_are_shown_with_their_number(work):
    """Status 99 (no kernel writes it): info shows 'unknown (99)' (before: NOT_RUN), and how
    the runs without a cycle ended, by status."""
    with h5py.File(work["fig06a"], "r+") as f:
        st = f["status"][...]
        st[0, 0], st[1, :] = 99, 4
        f["status"][...] = st
        f["period"][...] = 0
    r = run("info", work["fig06a"])
    assert r.exit_code == 0, r.output
    assert "unknown (99) 1" in r.output and "ESCAPED 3" in r.output
    assert "NOT_RUN" not in r.output
    assert "1 of unknown status 99" in r.output and "3 escaped" in r.output


def test_a_file_with_no_finished_point_is_refused_and_a_partial_one_says_so(tmp_path, work,
                                                                           monkeypatch):
    """done = 0 everywhere: plot and info refuse it by name (before: drawn as if complete);
    one point of three finished: info and the figure say 'partial sweep: 1 of 3 grid points
    finished', and the figure draws that point's values alone."""
    path = work["fig06a"]
    with h5py.File(path, "r+") as f:
        f["done"][...] = 0
        f.attrs["completed"] = ""
    for cmd in ("plot", "info"):
        refused(run(cmd, path, *(["-o", tmp_path / "x.png"] if cmd == "plot" else [])),
                path, "no grid point of its sweep is finished (0 of 3)")
    assert no_figures(tmp_path)
    with h5py.File(path, "r+") as f:
        f["done"][...] = np.array([0, 1, 0], np.uint8)
    r = run("info", path)
    assert r.exit_code == 0 and "partial sweep: 1 of 3 grid points finished" in r.output
    assert "NOT_RUN 6" in r.output
    import matplotlib.figure
    seen = {}
    real = matplotlib.figure.Figure.savefig

    def keep(fig, out, **kw):
        seen["texts"] = [t.get_text() for t in fig.texts]
        seen["x"] = {float(x) for ln in fig.axes[0].lines for x in np.atleast_1d(ln.get_xdata())
                     if ln.get_marker() == "."}
        real(fig, out, **kw)
    monkeypatch.setattr(matplotlib.figure.Figure, "savefig", keep)
    from cornerbif import plot as P
    P.figure([path], str(tmp_path / "p.png"), plot_cfg={})
    assert any("partial sweep: 1 of 3 grid points finished" in t for t in seen["texts"])
    with h5py.File(path) as f:
        finished = float(f["kappa"][1])
    assert seen["x"] <= {finished}


def test_info_says_no_cycle_only_of_runs_that_ended_well(work):
    """Every run escaped, stuck, started below the obstacle or went non-finite: info names
    each way (before: 'no start reached a cycle (chaos, or a period too long ...)' for
    all); runs that ended OK without a cycle are said so, and, the file's table having
    tested them for chaos (cornerbif.chaos), as on no chaotic attractor."""
    with h5py.File(work["fig06a"], "r+") as f:
        f["status"][...] = np.array([[4, 4, 7], [5, 2, 2], [4, 7, 5]], "i1")
        f["period"][...] = 0
    out = run("info", work["fig06a"]).output
    assert "chaos" not in out
    assert "3 escaped" in out and "2 stuck to the obstacle" in out
    assert "2 started below the obstacle" in out and "2 reached a non-finite state" in out
    with h5py.File(work["fig06a"], "r+") as f:
        f["status"][0, :] = 0
    out = run("info", work["fig06a"]).output
    assert "3 ended without one within the record, on no chaotic attractor" in out


# ------------------------------------------------------------------ 5. info
def test_info_summarises_a_continuation_file(work):
    """info of a continuation file (before: 'not a cornerbif file', exit 2): its parameter,
    each branch with its word, range, points and stable points and why each end stopped,
    the events and the curves."""
    r = run("info", work["cont_beta"])
    assert r.exit_code == 0, r.output
    out = r.output
    assert "cornerbif continuation" in out and "continued in kappa" in out
    assert "branch 0: b over kappa in [" in out and "points (" in out and "stable)" in out
    assert "stopped at kappa =" in out
    assert "events (" in out and "corner at kappa =" in out
    assert "curves: none" in out


def test_info_wraps_the_dataset_names_and_bounds_every_text(work):
    """The dataset names are grouped by folder and wrapped (before: 30-40 names on one line of
    600 characters); a 3 MB title, a name with line breaks and a terminal's escapes, a
    100 000-character command are each shown on one line, cut with an ellipsis (before:
    printed whole), and plot draws the file."""
    r = run("info", work["fig06a"])
    lines = r.output.splitlines()
    at = next(i for i, x in enumerate(lines) if x.startswith("  datasets"))
    assert all(len(x) <= 100 for x in lines[at:-1]), lines[at:]
    assert any(x.startswith("    impacts/: ") for x in lines)
    with h5py.File(work["fig06a"], "r+") as f:
        s = f.attrs["scene"]
        s = s.replace('title = "', 'title = "\\u001b[2J' + "x" * 3_000_000 + " ", 1)
        s = s.replace('name = "fig06a"', 'name = "' + "n\\n" * 1000 + '"', 1)
        f.attrs["scene"] = s
        f.attrs["command"] = "cornerbif " + "y" * 100_000
    r = run("info", work["fig06a"])
    assert r.exit_code == 0, r.output[-500:]
    assert max(len(x) for x in r.output.splitlines()) < 600
    assert "\x1b" not in r.output and "..." in r.output
    assert run("plot", work["fig06a"], "-o", work["fig06a"] + ".png").exit_code == 0


# ------------------------------------------------------------------ 6. warnings
WARNING_CASES = [
    ("fig06a",), ("fig06a", "--y", "winding"), ("fig07b_up", "fig07b_down"),
    ("fig16a", "fig16b"), ("fig09_flow", "fig09_map"), ("chart_flow",),
    ("chart_flow_lyapunov", "--color-by", "multiplier"), ("basin_maps",), ("fig01b",),
    ("cont_beta",), ("fig06a", "cont_beta"), ("empty_cont",), ("escapes",), ("allnan",),
    ("one_value",),
]


@pytest.mark.slow
def test_no_warning_reaches_the_user(tmp_path, work):
    """plot and info over a representative set of files (each kind of figure; files of
    escapes, of NaN only, a chart of one value, a continuation with no branch) in a process
    where every UserWarning and RuntimeWarning is an error: each ends 0, and stderr holds
    no 'Warning' and no note of one (before: 'No artists with labels found', singular
    transforms from values near 1e308, ...)."""
    craft = tmp_path / "craft"
    craft.mkdir()
    files = dict(work)
    files["escapes"] = str(craft / "escapes.h5")
    shutil.copy(work["fig06a"], files["escapes"])
    with h5py.File(files["escapes"], "r+") as f:
        f["status"][...] = 4
        f["period"][...] = 0
        u = f["impacts/u"][...]
        u[0], u[1], u[2] = np.inf, 1e308, -1e308
        f["impacts/u"][...] = u
    files["allnan"] = str(craft / "allnan.h5")
    shutil.copy(work["fig06a"], files["allnan"])
    with h5py.File(files["allnan"], "r+") as f:
        for n in ("impacts/u", "impacts/v_in", "section/u", "section/v"):
            f[n][...] = np.nan
    files["one_value"] = str(craft / "one_value.h5")
    one = gallery.load_scene(os.path.join(CONFIGS, "chart_flow.toml"), smoke=True)
    raw = tomllib.loads(one.text)
    raw["sweep"]["omega"] = {"values": raw["sweep"]["omega"]["values"][:1]}
    run_sweep(config.from_dict(raw), files["one_value"], overwrite=True, progress=False,
              command="test")
    files["empty_cont"] = str(craft / "empty_cont.h5")
    cont = gallery.load_scene(os.path.join(CONFIGS, "cont_fold.toml"), smoke=True)
    continuation_run.write(continuation_run.Result(cont, []), files["empty_cont"])
    cases = [[files.get(a, a) for a in case] for case in WARNING_CASES]
    code = textwrap.dedent("""
        import json, sys, warnings
        warnings.simplefilter("error", UserWarning)
        warnings.simplefilter("error", RuntimeWarning)
        from click.testing import CliRunner
        from cornerbif.cli import main
        out = []
        for i, case in enumerate(json.loads(sys.argv[1])):
            names = [a for a in case if a.endswith(".h5")]
            for args in (["plot", *case, "-o", sys.argv[2] + f"/{i}.png"],
                         ["info", names[0]]):
                r = CliRunner().invoke(main, args)
                out.append((args, r.exit_code, r.output))
        print(json.dumps(out))
    """)
    import json
    r = subprocess.run([sys.executable, "-c", code, json.dumps(cases), str(tmp_path)],
                       capture_output=True, text=True, timeout=600,
                       env=dict(os.environ, MPLBACKEND="Agg"))
    assert r.returncode == 0, r.stderr[-3000:]
    assert "Warning" not in r.stderr, r.stderr[-3000:]
    for args, code_, output in json.loads(r.stdout):
        assert code_ == 0, (args, output)
        assert "Warning" not in output and "note: drawing" not in output, (args, output)


# ------------------------------------------------------------------ the readers' one opener
@pytest.mark.parametrize("reader", ["sweep", "continuation"])
def test_a_fifo_or_a_device_is_refused_by_its_kind_by_either_reader(tmp_path, reader):
    """Both readers open a file through ``io.open_checked``: a FIFO or a device is refused
    by its kind and never opened, the path named (the continuation reader called both 'the
    file is empty', their size on stat)."""
    from cornerbif.io import FileFormatError, check_readable
    from cornerbif.plot_data import read_continuation
    fifo = tmp_path / "pipe.h5"
    os.mkfifo(fifo)
    read = check_readable if reader == "sweep" else read_continuation
    for path, kind in ((fifo, "is a FIFO"), ("/dev/null", "is a character device")):
        with pytest.raises(FileFormatError) as e:
            read(path)
        assert str(path) in str(e.value) and kind in str(e.value), e.value
        assert "never opened" in str(e.value) and "empty" not in str(e.value)


@pytest.mark.parametrize("name", ["fig06a", "cont_beta"])
def test_a_file_of_many_links_is_refused_naming_a_few(tmp_path, work, name):
    """A crafted file of 1000 soft links refers to other files: info and plot refuse it
    naming the first three links and how many more (the sweep's reader listed every one, a
    message of 15 kB; the continuation reader three, without saying there were more)."""
    with h5py.File(work[name], "a") as f:
        for i in range(1000):
            f[f"link{i:04d}"] = h5py.SoftLink("/nowhere")
    for args in (("info", work[name]), ("plot", work[name], "-o", tmp_path / "f.png")):
        out = refused(run(*args), work[name], "refers to other files", "and 997 more")
        assert len(out) < 1000, out[:2000]
    assert no_figures(tmp_path)


def test_both_readers_say_the_same_of_the_same_fault(tmp_path, work):
    """One opener for a sweep's file and a continuation's: another format is named by its
    root attribute, a newer version by its number, a truncated file cannot be opened as
    HDF5, in the same words (the continuation reader said 'not a cornerbif continuation
    file' alone, and called a truncated file 'a damaged continuation file')."""
    import re

    from cornerbif.io import FileFormatError, check_readable
    from cornerbif.plot_data import read_continuation
    readers = {"fig06a": check_readable, "cont_beta": read_continuation}
    for name, other, says in (("fig06a", "cont_beta", "not a cornerbif file"),
                              ("cont_beta", "fig06a", "not a cornerbif continuation file")):
        theirs = "cornerbif-continuation" if other == "cont_beta" else "cornerbif"
        with pytest.raises(FileFormatError, match=re.escape(
                f"{work[other]}: {says} (root attribute format is '{theirs}')")):
            readers[name](work[other])
    for name, read in readers.items():
        half = tmp_path / f"{name}_half.h5"
        data = open(work[name], "rb").read()
        half.write_bytes(data[:len(data) // 2])
        with pytest.raises(FileFormatError, match=re.escape(f"{half}: cannot be opened as HDF5")):
            read(half)
        with h5py.File(work[name], "a") as f:
            f.attrs["format_version"] = 99
        with pytest.raises(FileFormatError, match=re.escape(
                f"{work[name]}: format version 99 is newer than this cornerbif reads (1)")):
            read(work[name])
