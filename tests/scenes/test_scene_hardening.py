"""Scenes and ``validate`` refuse every bad input before any work, with key and value.

Each refusal is checked through the command line: ``cornerbif validate`` and ``cornerbif
sweep`` exit 2, print no traceback, name the key (and the --set it came from) and the value
(shortened when huge), and the sweep leaves no output, .partial or .lock behind.  The
limits quoted are the ones config.py and obstacles/profile.py declare (each says why there).
The last tests throw extreme values at every key of every table of every model
(``from_dict`` gives a Scene or a SceneError, never another exception, and never quotes a
huge value whole) and time ``validate`` on extreme valid scenes in a memory-limited child.
"""

from __future__ import annotations

import copy
import math
import os
import resource
import subprocess
import sys
import tomllib

import numpy as np
import pytest
from click.testing import CliRunner
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from cornerbif import config, plot_style, registry
from cornerbif.cli import main
from cornerbif.obstacles import profile as PR

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CONFIGS = os.path.join(ROOT, "configs")
FIG06A = os.path.join(CONFIGS, "fig06a.toml")
CAM = os.path.join(CONFIGS, "cam_cycloidal.toml")
TINY = ["--set", "sweep.kappa.num=3", "--set", "initial.count=2", "--set", "run.transient=10",
        "--set", "run.record=10"]
PI = math.pi
# a message quotes a value shortened (model.shown: about 80 characters, twice that at most)
MESSAGE_MAX = 1200


def run(*args):
    return CliRunner().invoke(main, [str(a) for a in args])


def refused(tmp_path, scene, sets=(), needles=(), sweep=True):
    """``validate`` and ``sweep`` both refuse ``scene`` with ``sets``: exit 2, no traceback,
    every needle in the message, no line of it past MESSAGE_MAX, nothing written."""
    sets = [x for s in sets for x in ("--set", s)]
    r = run("validate", scene, *sets)
    assert r.exit_code == 2, r.output
    assert "Traceback" not in r.output and "internal error" not in r.output, r.output
    for n in needles:
        assert n in r.output, (n, r.output)
    assert max(len(line) for line in r.output.splitlines()) < MESSAGE_MAX, r.output[:3000]
    if sweep:
        out = tmp_path / "o.h5"
        s = run("sweep", scene, "-o", out, *sets)
        assert s.exit_code == 2, s.output
        assert "Traceback" not in s.output, s.output
        assert sorted(os.listdir(tmp_path)) == sorted(x for x in os.listdir(tmp_path)
                                                      if not x.startswith("o.h5")), s.output
    return r.output


def accepted(scene, sets=()):
    r = run("validate", scene, *[x for s in sets for x in ("--set", s)])
    assert r.exit_code == 0, r.output
    return r.output


# ------------------------------------------------------------------ 1. reading the scene
@pytest.mark.parametrize("digits", [4301, 5000, 20000])
def test_an_integer_of_thousands_of_digits_is_refused_with_its_line(tmp_path, digits):
    """tomllib raises ValueError (Python's 4300-digit limit of int from text): a SceneError
    naming the file, the line and the number of digits; in a --set too."""
    scene = tmp_path / "s.toml"
    text = open(FIG06A).read().replace("r = 0.8", "r = " + "7" * digits)
    assert text != open(FIG06A).read()
    scene.write_text(text)
    line = text[:text.index("7" * 10)].count("\n") + 1
    refused(tmp_path, scene, needles=[str(scene), f"line {line}", f"{digits} digits"])
    refused(tmp_path, FIG06A, ["system.r=" + "1" * digits],
            needles=["--set system.r", f"{digits} digits"])


@pytest.mark.parametrize("depth", [20, 1000, 3000])
def test_lists_nested_thousands_deep_are_refused(tmp_path, depth):
    """A RecursionError in tomllib (or in any walk of the scene) becomes a refusal naming the
    file, or the key past MAX_NESTING levels; in a --set too."""
    scene = tmp_path / "s.toml"
    scene.write_text(open(FIG06A).read() + "\n[plot]\nmarks = " + "[" * depth + "]" * depth
                     + "\n")
    out = refused(tmp_path, scene, needles=[str(scene)])
    assert "nested" in out
    out = refused(tmp_path, FIG06A, ["plot.marks=" + "[" * depth + "]" * depth],
                  needles=["plot.marks", "nested"])
    assert "--set" in out


class _Counted:
    """A file opened by ``config.read_text``, counting the bytes read from it."""

    def __init__(self, fh, log):
        self.fh, self.log = fh, log

    def read(self, n=-1):
        data = self.fh.read(n)
        self.log[-1][1] += len(data)
        return data

    def fileno(self):
        return self.fh.fileno()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.fh.close()


def test_a_device_a_fifo_and_a_huge_file_are_refused_unread(tmp_path, monkeypatch):
    """/dev/zero (endless), a FIFO (which would block) and a sparse file past
    MAX_SCENE_BYTES are refused by their kind or size: the first two never opened, the
    third read no further than MAX_SCENE_BYTES + 1 bytes (counted at config's ``open``).
    Through the command line too (the subprocess's timeout only guards against a hang)."""
    fifo = tmp_path / "pipe.toml"
    os.mkfifo(fifo)
    big = tmp_path / "big.toml"
    with open(big, "wb") as fh:
        fh.truncate(config.MAX_SCENE_BYTES + 1)
    cases = (("/dev/zero", "is a character device"), (fifo, "is a FIFO"),
             (big, f"larger than {config.MAX_SCENE_BYTES} bytes"))
    opened = []          # [path, bytes read] of each file config opens

    def counted(path, *args, **kw):
        opened.append([str(path), 0])
        return _Counted(open(path, *args, **kw), opened)
    monkeypatch.setattr(config, "open", counted, raising=False)
    for path, needle in cases:
        with pytest.raises(config.SceneError, match=needle):
            config.load(path)
    assert opened == [[str(big), config.MAX_SCENE_BYTES + 1]]
    monkeypatch.undo()
    for path, needle in cases:
        for cmd in (["validate"], ["sweep", "-o", str(tmp_path / "o.h5")]):
            p = subprocess.run([sys.executable, "-m", "cornerbif.cli", *cmd[:1], str(path),
                                *cmd[1:]], capture_output=True, text=True, timeout=120)
            assert p.returncode == 2, p.stderr
            assert needle in p.stderr and str(path) in p.stderr, p.stderr
            assert "Traceback" not in p.stderr
    with pytest.raises(config.SceneError, match="is a directory"):
        config.load(tmp_path)
    assert not os.path.exists(tmp_path / "o.h5")


@pytest.mark.parametrize("table", ["system", "sweep", "plot", "nosuch"])
def test_a_table_of_a_hundred_thousand_keys_is_refused_at_once(tmp_path, table, monkeypatch):
    """Past MAX_TABLE_KEYS keys a table is refused in one problem, before a problem (and a
    did-you-mean search) is said of each key: 100,000 keys took 19 s and printed 100,000
    lines.  No table is walked (``config._Walk``, which says a problem of each unknown key,
    is never made) and no did-you-mean search is run (``config._suggest``)."""
    scene = tmp_path / "wide.toml"
    scene.write_text(f"[{table}]\n" + "\n".join(f"k{i} = 1" for i in range(100_000)) + "\n")
    calls = []
    for name in ("_Walk", "_suggest"):
        real = getattr(config, name)
        monkeypatch.setattr(config, name, lambda *a, _real=real, _name=name, **kw:
                            calls.append(_name) or _real(*a, **kw))
    out = refused(tmp_path, scene, needles=[f"{table}: 100000 keys; a table of a scene has at "
                                            f"most {config.MAX_TABLE_KEYS}"], sweep=False)
    assert calls == []
    assert len(out.splitlines()) == 2, out[:2000]


def test_a_key_of_a_megabyte_is_named_by_its_start(tmp_path):
    scene = tmp_path / "key.toml"
    scene.write_text('[system]\n"' + "x" * 1_000_000 + '" = 1\n["' + "y" * 1_000_000 + '"]\n')
    refused(tmp_path, scene, needles=["...<1000000 characters>: unknown key",
                                      "...<1000000 characters>: unknown table"], sweep=False)


def test_a_utf8_bom_is_accepted_and_other_bytes_are_named(tmp_path):
    """A scene saved with a byte-order mark (Windows editors) is the same scene; bytes that
    are not UTF-8 are refused naming their offset."""
    scene = tmp_path / "bom.toml"
    scene.write_bytes(b"\xef\xbb\xbf" + open(FIG06A, "rb").read())
    assert config.load(scene).hash == config.load(FIG06A).hash
    accepted(scene)
    bad = tmp_path / "latin.toml"
    bad.write_bytes(open(FIG06A, "rb").read().replace(b"Fig", b"F\xefg", 1))
    refused(tmp_path, bad, needles=["not UTF-8 text (byte"])


# ------------------------------------------------------------------ 2. cam profiles
def _profile_set(pieces, period=None, extra=""):
    per = f"period = {period!r}, " if period is not None else ""
    return f"system.profile={{ {per}pieces = [{', '.join(pieces)}]{extra} }}"


@pytest.mark.parametrize("pieces,period,needles", [
    # the issue's: spans of 1e-70 and 1e-200 (ZeroDivisionError), a period of 1e70
    # (OverflowError), a sinusoid of n = 1e300 (a crash in sturm_bound after validate)
    (['{law = "polynomial_345", span = 1e-70, rise = 1.0}', '{law = "dwell", span = 6.283185307179586}'],
     6.283185307179586, ["pieces[0].span: 1e-70", "times the period"]),
    (['{law = "cycloidal", span = 1e-200, rise = 1.0}', '{law = "dwell", span = 3.141592653589793}'],
     3.141592653589793, ["pieces[0].span: 1e-200"]),
    (['{law = "polynomial_345", span = 1e70, rise = 1.0}'], 1e70,
     ["system.profile.period: 1e+70", "[0.001, 10000]"]),
    (['{span = 3.141592653589793, sine = [1.0, 0.0, 1e300]}'], PI,
     ["pieces[0].sine: n = 1e+300", "at most 1e+06"]),
    # other extremes: tiny, negative, nan, inf periods; huge spans, amplitudes,
    # coefficients; integers past float64; too many pieces; a degree past 7; corners
    (['{span = 3.141592653589793, poly = [0.0]}'], 1e-300, ["period: 1e-300"]),
    (['{span = 3.141592653589793, poly = [0.0]}'], -PI, ["period: -3.14"]),
    (['{span = 3.141592653589793, poly = [0.0]}'], math.nan, ["period: nan"]),
    (['{span = 3.141592653589793, poly = [0.0]}'], math.inf, ["period: inf"]),
    (['{span = 1e308, poly = [0.0]}'], None, ["pieces[0].span: 1e+308"]),
    (['{span = inf, poly = [0.0]}'], None, ["pieces[0].span: inf"]),
    (['{span = -1.0, poly = [0.0]}'], None, ["pieces[0].span: -1.0"]),
    (['{span = 6.283185307179586, poly = [0.0, 1e300]}'], None, ["lift reaches", "in units of beta"]),
    (['{span = 6.283185307179586, poly = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 1e-300, 5e300]}'], None,
     ["degree 8 is past the limit 7"]),
    (['{span = 6.283185307179586, poly = [' + "9" * 400 + ']}'], None,
     ["pieces[0].poly", "an integer of 400 digits"]),
    (['{span = 6.283185307179586, sine = [1e300, 0.0, 1.0]}'], None, ["a and b must be within +-1e+06"]),
    (['{span = 6.283185307179586, sine = [1.0, 0.0, nan]}'], None, ["pieces[0].sine"]),
    (['{law = "constant_velocity", span = 3.141592653589793, rise = 1e300}',
      '{law = "constant_velocity", span = 3.141592653589793, rise = -1e300}'], None,
     ["pieces[0].rise: 1e+300", "pieces[1].rise: -1e+300"]),
    (['{law = "dwell", span = 0.5}'] * 5000, 2500.0, ["5000 smooth pieces at least", "at most 8"]),
    ([], None, ["system.profile.pieces: []"]),
])
def test_profile_numbers_outside_their_ranges_are_refused(tmp_path, pieces, period, needles):
    """Every profile number is checked for the ranges in which the certified bounds and the
    kernels stay finite and meaningful (obstacles/profile.py: MIN_PERIOD..MAX_PERIOD,
    MIN_SPAN_SHARE, MAX_LIFT, MAX_TURN, MAX_PIECES, MAX_DEGREE): validate and sweep refuse
    with the key, the value and the range."""
    refused(tmp_path, CAM, [_profile_set(pieces, period)], needles=needles + ["--set"])


@pytest.mark.parametrize("corners", ["[5]", "[0, 0]", "[-1]", "[true]", "[" + "0, " * 100000 + "0]",
                                     '"all"'])
def test_profile_corner_lists_are_refused(tmp_path, corners):
    pieces = ['{span = 3.141592653589793, sine = [1.0, 0.0, 1.0]}']
    refused(tmp_path, CAM, [_profile_set(pieces, PI, f", corners = {corners}")],
            needles=["system.profile.corners", "each at most once"], sweep=False)


@pytest.mark.parametrize("sets,key", [
    (["sweep.omega={start = 1.0, stop = 1e100, num = 2}"], "sweep.omega: 1e+100"),
    (["system.k=1e200"], "system.k: 1e+200"),
    (["system.k=1e-200"], "system.k: 1e-200"),
])
def test_a_profile_whose_kernel_numbers_would_overflow_is_refused(tmp_path, sets, key):
    """At the scene's extreme omega, k (and beta, sigma, kappa) a profile's certified bounds
    in time (beta omega^4 max|g''''|), its contact-force bound and its Sturm floors (-kappa -
    beta (k^2 g + omega^2 g'')_max / k^2) must be finite (profile.scale_problem)."""
    out = refused(tmp_path, CAM, sets, needles=[key, "overflows float64"])
    if "omega" in key:
        assert "omega at most about" in out


def test_the_follower_start_refusal_quotes_the_real_height(tmp_path):
    """A profile with g(0) = 5 (one constant piece, kappa = 0, beta = 1): the refusal of
    initial.u = [0, 3] quotes z(0) = 5.0, not kappa's 0.0."""
    out = refused(tmp_path, CAM, [_profile_set(['{span = 6.283185307179586, poly = [5.0]}'],
                                               2 * PI, ", corners = [0]")],
                  needles=["initial.u: [0.0, 3.0] lies on or below", "g(0) = 5.0", "up to 5.0"])
    assert "up to 0.0" not in out


def test_profiles_at_the_edge_of_the_ranges_validate_and_sweep(tmp_path):
    """Just inside every limit a profile is accepted, and a tiny sweep of it ends (exit 0,
    a status for every run): the limits refuse nothing the kernels cannot run."""
    edge = _profile_set(['{law = "cycloidal", span = 1e-9, rise = 1e6}',
                         '{law = "cycloidal", span = 0.000999999, rise = -1e6}'], 1e-3)
    sine = _profile_set(['{span = 3.141592653589793, sine = [0.0, 1e6, 318000.0]}'], PI,
                        ", corners = [0]")
    for s in (edge, sine):
        accepted(CAM, [s, "initial.u=[0.0, 3e6]"])
    out = tmp_path / "edge.h5"
    r = run("sweep", CAM, "-o", out, "--set", "sweep.omega.num=2", "--set", "initial.count=2",
            "--set", "run.transient=5", "--set", "run.record=5", "--set", sine, "--set",
            "initial.u=[0.0, 3e6]", "--set", "run.escape=1e9", "--set", "run.max_periods=50")
    assert r.exit_code == 0, r.output


@pytest.mark.parametrize("omega,beta,k,sigma", [(2.0, 1.0, 1.0, 0.1), (1.0, 1.0, 1e-200, 0.0),
                                                (1.0, 1.0, 1e160, 0.0), (1e40, 1.0, 1.0, 1e250)])
def test_the_profile_scale_check_is_the_kernels_arithmetic(omega, beta, k, sigma):
    """``profile.scale_problem`` takes the bounds of the contact force's N'' and the Sturm
    floors from the kernels' own code: the row ``params.pack`` gives the kernels (Sturm
    bounds and floors included) and ``obstacle.npp_bound``, which the kernels'
    ``profile_npp`` calls (it re-derived both).  Run as Python on that row, the N'' bound is
    the compiled one to the bit; where the check refuses sigma or k for it, the kernels'
    bound is not finite, and where it refuses a Sturm floor, the row's floor is not."""
    from cornerbif.models.flow import packed as P
    from cornerbif.obstacles import dispatch as O
    prof = PR.read(tomllib.loads(open(CAM).read())["system"]["profile"])
    with np.errstate(all="ignore"):
        row = P.pack({"omega": omega, "beta": beta, "k": k, "kappa": 0.0, "sigma": sigma},
                     "profile", 0.0, 0.0, 0.0, None, profile=prof)
        compiled = O.profile_npp(row, 0.0)
        python = O.npp_bound.py_func(row[P.BETA], row[P.OMEGA], row[P.SIGMA], row[P.K],
                                     O.profile_g2_abs.py_func(row),
                                     O._profile_max.py_func(row, P.PC_G3),
                                     O._profile_max.py_func(row, P.PC_G4))
    assert np.float64(compiled).tobytes() == np.float64(python).tobytes()
    found = PR.scale_problem(prof, omega, beta, k, 0.0, sigma)
    floors = [row[P.PROFILE0 + m * P.PIECE_STRIDE + P.PC_FLOOR] for m in range(len(prof.pieces))]
    if found is None:
        assert math.isfinite(compiled) and all(math.isfinite(x) for x in floors)
    elif "contact force" in found[1]:
        assert not math.isfinite(compiled)
    else:
        assert "Sturm" in found[1] and not all(math.isfinite(x) for x in floors)


# ------------------------------------------------------------------ 3. free text
def test_every_message_cuts_a_text_alike(tmp_path):
    """One helper (``model.cut``) bounds every text a message quotes: a key of a cam
    profile or of a piece, a --set as given, a word: its start on one line, control
    characters (a terminal's escapes) as spaces, and its length ("...<N characters>").
    Before, a profile's key was cut at 60 characters silently, its escapes kept; a --set
    was quoted with its escapes; a word ended in "..." without its length."""
    from cornerbif import analysis
    key = "\x1b[2J" + "k" * 1000
    toml_key = '"' + key.replace("\x1b", "\\u001b") + '"'
    s = _profile_set(["{span = 6.283185307179586, poly = [0.0], " + toml_key + " = 1}"],
                     2 * PI, ", " + toml_key + " = 1")
    out = refused(tmp_path, CAM, [s], needles=["system.profile.", "pieces[0].",
                                               "...<1004 characters>: unknown key"], sweep=False)
    assert "\x1b" not in out
    r = run("validate", FIG06A, "--set", "system.omega=\x1b[31mred")
    assert r.exit_code == 2 and "(from --set system.omega= [31mred)" in r.output, r.output
    assert "\x1b" not in r.output
    with pytest.raises(ValueError, match=r"word 'qqqq.*'...<20000 characters> is 20000"):
        analysis.parse_word("q" * 20000)


def test_a_cut_text_is_one_bounded_line_of_any_value():
    """``model.cut``: at most ``limit`` characters of the text on one line (control
    characters as spaces, or escaped by repr with ``quote``), its length said when it is
    longer (or ``mark``); anything else by its str, a value that has none by its type;
    ``model.shown`` quotes a string by it, ``plot_style.bounded`` cuts a figure's text by it
    and never inside a formula."""
    from cornerbif import plot_style
    from cornerbif.model import cut, shown
    assert cut("abc") == "abc" and cut(12.5) == "12.5"
    assert cut("a\nb\x1b[2J", 10) == "a b [2J"
    assert cut("x" * 100, 10) == "x" * 10 + "...<100 characters>"
    assert cut("x\n" * 50, 4, quote=True) == repr("x\nx\n") + "...<100 characters>"
    assert cut("x" * 100, 10, mark="") == "x" * 10
    assert cut(10 ** 5000) == "<a int too large to show>"
    assert shown("y" * 100, 30) == repr("y" * 30) + "...<100 characters>"
    label = plot_style.bounded("$a$ " * 30, 21)
    assert len(label) <= 21 and label.endswith("...") and label.count("$") % 2 == 0


def test_scenes_and_figures_judge_a_formula_by_one_check(monkeypatch):
    """What matplotlib cannot draw is judged in one place (``plot_style.mathtext_problem``):
    a scene's title or label is refused by it (``config.undrawable``), and a file's title
    drawn with its dollars literal by it (``plot_style.title_lines``).  Checked by making
    that one function refuse a formula matplotlib draws."""
    from cornerbif import plot_style
    text = "$\\omega$ = 2"
    assert config.undrawable(text, "plot.title") is None
    assert "$" in plot_style.title_lines(text, 80).replace("\\$", "")
    monkeypatch.setattr(plot_style, "mathtext_problem", lambda t: (t, "refused here"))
    assert "refused here" in config.undrawable(text, "plot.title")
    assert "$" not in plot_style.title_lines(text, 80).replace("\\$", "")


@pytest.mark.parametrize("key,limit", [("scene.name", config.MAX_NAME),
                                       ("scene.title", config.MAX_TITLE),
                                       ("plot.title", config.MAX_TITLE)])
def test_free_text_is_bounded(tmp_path, key, limit):
    """A name or title one character past its limit is refused with the key and the
    length; at the limit it is accepted (config.py: MAX_NAME, MAX_TITLE)."""
    accepted(FIG06A, [f'{key}="{"n" * limit}"'])
    refused(tmp_path, FIG06A, [f'{key}="{"n" * (limit + 1)}"'],
            needles=[key, f"is {limit + 1} characters; at most {limit}", "--set"])


def test_a_50_mb_title_is_refused_before_it_is_read_whole(tmp_path):
    """The issue's 50 MB scene.title: the file is past MAX_SCENE_BYTES, refused by its size
    in well under a second of reading; a 2 MB one (within the file's limit) is refused by
    the title's, quoting 80 characters of it, not 2 MB."""
    scene = tmp_path / "t.toml"
    body = open(FIG06A).read()
    scene.write_text(body.replace('title = "', 'title = "' + "x" * 50_000_000, 1))
    refused(tmp_path, scene, needles=[f"larger than {config.MAX_SCENE_BYTES} bytes"])
    scene.write_text(body.replace('title = "', 'title = "' + "x" * 2_000_000, 1))
    out = refused(tmp_path, scene, needles=["scene.title", "characters; at most 500"])
    assert len(out) < 3000


@pytest.mark.parametrize("key", ["scene.name", "scene.title", "plot.title"])
@pytest.mark.parametrize("char", ["\\u0000", "\\u001b", "\\u0007", "\\u0085"])
def test_free_text_holds_no_control_characters(tmp_path, key, char):
    """A title is printed by info to a terminal, where an escape sequence would act: only
    newline and tab are allowed; the refusal names the key and the character."""
    refused(tmp_path, FIG06A, [f'{key}="a{char}b"'], needles=[key, "control character"],
            sweep=False)
    accepted(FIG06A, [f'{key}="two\\nlines\\tand a tab"'])


def test_marks_labels_and_count_are_bounded(tmp_path):
    lab = "m" * (config.MAX_MARK_LABEL + 1)
    refused(tmp_path, FIG06A, [f'plot.marks=[[-0.01, "{lab}"]]'],
            needles=["plot.marks[0]", f"{config.MAX_MARK_LABEL + 1} characters"])
    many = ", ".join(['[-0.01, "a"]'] * (config.MAX_MARKS + 1))
    refused(tmp_path, FIG06A, [f"plot.marks=[{many}]"],
            needles=[f"plot.marks: {config.MAX_MARKS + 1} marks; at most {config.MAX_MARKS}"])


@pytest.mark.parametrize("key", ["scene.title", "plot.title"])
def test_a_title_matplotlib_cannot_draw_is_refused(tmp_path, key):
    """mathtext that does not parse (or nests past its parser's recursion) is refused in
    validate with the key, not by matplotlib after the sweep."""
    for bad in ("$x^$", r"$\\nosuchsymbol$", "$" + "{" * 240 + "}" * 240 + "$"):
        refused(tmp_path, FIG06A, [f'{key}="{bad}"'], needles=[key, "matplotlib cannot draw"],
                sweep=False)
    accepted(FIG06A, [f'{key}="omega = 2, kappa_CC, $\\\\beta^2$ and a $ sign"'])


# ------------------------------------------------------------------ 4. numbers
@pytest.mark.parametrize("sets,needles", [
    (["sweep.initial.u={start = -1.7e308, stop = 1.7e308, num = 3}", "sweep.kappa.num=1"],
     ["sweep.initial.u", "overflows float64"]),
    (["sweep.kappa={start = -1e308, stop = 1e308, num = 5}"], ["sweep.kappa", "overflows"]),
    (["sweep.kappa={start = 1.0, stop = 1.0000000000000002, num = 5}"], ["not distinct"]),
    (["initial.u=[-1.7e308, 1.7e308]"], ["initial.u", "high - low overflows"]),
    (["initial.v=[-1e308, 1e308]"], ["initial.v", "high - low overflows"]),
    (["initial.t=[0.0, 1e300]"], ["initial.t: 1e+300", "|t0| <= 1e+06"]),
    (["sweep.initial.t={start = 0.0, stop = 1e20, num = 3}", "sweep.kappa.num=1"],
     ["sweep.initial.t.stop: 1e+20"]),
    (["system.section_period=1e308"], ["system.section_period: 1e+308", "2^52"]),
])
def test_overflowing_axes_and_ranges_are_refused(tmp_path, sets, needles):
    """An axis or an [initial] range whose span overflows (stop - start, high - low not
    finite) was "from nan to nan"; values not distinct in float64; a start time the
    kernels cannot place (MAX_START_TIME); a section period of more whole obstacle periods
    than float64 counts."""
    refused(tmp_path, FIG06A, sets, needles=needles)


# ------------------------------------------------------------------ 5. [plot]
@pytest.mark.parametrize("value,needle", [
    ("nan", "plot.marker_size: nan"), ('"big"', "plot.marker_size: 'big'"),
    ("0", "plot.marker_size: 0"), ("-1.0", "plot.marker_size: -1.0"),
    ("1e308", "plot.marker_size: 1e+308"), ("true", "plot.marker_size: True"),
])
def test_plot_marker_size(tmp_path, value, needle):
    refused(tmp_path, FIG06A, [f"plot.marker_size={value}"],
            needles=[needle, f"(0, {config.MAX_MARKER_SIZE:g}]"])


@pytest.mark.parametrize("key", ["xlim", "ylim"])
@pytest.mark.parametrize("value,needle", [
    ("[0.0, inf]", "must be finite"), ("[-1e308, 1e308]", "must be finite"),
    ("[-1e200, 1e200]", "within +-1e+100"), ("[nan, 1.0]", "must be finite"),
    ("[1.0, 1.0000000000000002]", "wide; a window must be at least"),
    ("[0.0, 1e-300]", "wide; a window"), ("[1.0, 0.0]", "low < high"),
    ("[1.0]", "two numbers"), ('["a", "b"]', "two numbers"),
])
def test_plot_windows_matplotlib_can_draw(tmp_path, key, value, needle):
    refused(tmp_path, FIG06A, [f"plot.{key}={value}"], needles=[f"plot.{key}", needle])


@pytest.mark.parametrize("sets,needle", [
    (["plot.cycles=1e308"], "plot.cycles: 1e+308"), (["plot.cycles=nan"], "plot.cycles: nan"),
    (["plot.max_panels=0"], "plot.max_panels: 0"), (["plot.max_panels=1e9"], "plot.max_panels"),
    (['plot.style="no-such-style"'], "plot.style: 'no-such-style' is neither"),
    (['plot.style="/dev/zero"'], "is not a regular file"),
    (['plot.style="./missing.mplstyle"'], "no such style sheet"),
    (["plot.style=3"], "plot.style: 3"),
    (["plot.ic=[0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0]"], "at most 8 start indices"),
])
def test_other_plot_keys(tmp_path, sets, needle):
    refused(tmp_path, FIG06A, sets, needles=[needle])


def test_a_style_sheet_past_its_size_is_refused_and_a_real_one_accepted(tmp_path):
    sheet = tmp_path / "ok.mplstyle"
    sheet.write_text("lines.linewidth: 2\n")
    accepted(FIG06A, [f'plot.style="{sheet}"'])
    accepted(FIG06A, ['plot.style="ggplot"'])
    big = tmp_path / "big.mplstyle"
    with open(big, "wb") as fh:
        fh.truncate(plot_style.MAX_STYLE_BYTES + 1)
    refused(tmp_path, FIG06A, [f'plot.style="{big}"'],
            needles=[f"a style sheet is at most {plot_style.MAX_STYLE_BYTES}"], sweep=False)


# ------------------------------------------------------------------ 6. smaller ones
def test_keep_as_a_string_gives_one_error(tmp_path):
    out = refused(tmp_path, FIG06A, ['output.keep="impacts"'],
                  needles=['output.keep: \'impacts\' must be a list', 'keep = ["impacts"]'])
    problems = [x for x in out.splitlines() if x.startswith("  ")]
    assert len(problems) == 1, out
    scene = tmp_path / "ts.toml"
    scene.write_text(open(os.path.join(CONFIGS, "fig05.toml")).read())
    out = refused(tmp_path, scene, ["output.keep=7"], needles=["output.keep: 7"], sweep=False)
    assert len([x for x in out.splitlines() if x.startswith("  ")]) == 1, out


@pytest.mark.parametrize("obstacle", ["rectified_sine", "sine", "profile"])
@pytest.mark.parametrize("key", ["system.theta1=1.5", "system.theta2=1.5",
                                 "sweep.theta1={start = 1.0, stop = 2.0, num = 3}"])
def test_triangle_slopes_on_another_obstacle_are_refused(tmp_path, obstacle, key):
    """theta1 and theta2 are the triangle's (Param.obstacles): given for another obstacle,
    validate refuses naming the obstacle they apply to (was accepted silently)."""
    scene = CAM if obstacle == "profile" else FIG06A
    sets = [key] + ([] if obstacle == "profile" else [f'system.obstacle="{obstacle}"'])
    name = key.split("=")[0].split(".")[1]
    refused(tmp_path, scene, sets, needles=[f"{key.split('=')[0]}: {name} is a parameter of "
                                            "obstacle 'triangle' only", f"'{obstacle}'"])
    accepted(FIG06A, ['system.obstacle="triangle"', key])


def test_a_profile_table_on_another_obstacle_is_refused(tmp_path):
    refused(tmp_path, CAM, ['system.obstacle="triangle"'],
            needles=["system.profile: given, but system.obstacle is 'triangle'"])


@pytest.mark.parametrize("sets", [["sweep.kappa.values=[0.005]"],
                                  ["sweep.kappa={values=[0.005]}"],
                                  ["sweep.kappa.values=[-0.01, 0.0]", "sweep.kappa.num=3",
                                   "sweep.kappa.start=-0.01", "sweep.kappa.stop=0.0"]])
def test_set_replaces_an_axis_form(sets):
    """A --set of values replaces a start/stop/num axis (and start/stop/num replace values);
    the inline table replaces the whole axis."""
    accepted(FIG06A, sets)
    sc = config.load(FIG06A, sets)
    want = [0.005] if len(sets) == 1 else [-0.01, -0.005, 0.0]
    assert list(sc.axes[0].values) == want


@pytest.mark.parametrize("sets,needle", [
    (["=5"], "the key '' has an empty part"), (["a..b=1"], "has an empty part"),
    (["sweep=[1]"], "sweep: [1] must be a table [sweep]"),
    (["scene=5"], "scene: 5 must be a table [scene]"),
    (["system.omega.x=1"], "system.omega: {'x': 1} is not a number"),
    ([".".join(["a"] * 40) + "=1"], "the key has 40 parts; at most 16"),
    (["x=" + "{a=" * 100 + "1" + "}" * 100], "nested more than 16 levels"),
    (['system.obstacle="' + "x" * 100_000 + '"'], "...<100000 characters> is not an obstacle"),
])
def test_bad_overrides_give_one_problem_each(tmp_path, sets, needle):
    """Malformed --set keys and values: one problem, naming the override, the value cut."""
    out = refused(tmp_path, FIG06A, sets, needles=[needle], sweep=False)
    assert len([x for x in out.splitlines() if x.startswith("  ")]) == 1, out


def test_every_validate_option_has_help():
    r = run("validate", "--help")
    assert r.exit_code == 0
    cmd = main.commands["validate"]
    for p in cmd.params:
        if p.param_type_name == "option":
            assert p.help, p.name
    assert "--set KEY=VALUE" in r.output and "Override a scene key" in r.output


# ------------------------------------------------------------------ the fuzz
BASES = {"flow": FIG06A, "profile": CAM, "map2d": os.path.join(CONFIGS, "fig09_map.toml"),
         "two_particle": os.path.join(CONFIGS, "fig19a.toml")}
EXTREME = [1e308, -1e308, 1.7976931348623157e308, 1e-308, 5e-324, -5e-324, math.nan, math.inf,
           -math.inf, 0, -1, 2**63, -(2**63), 10**300, 10**400, 10**5000, True, "", "x" * 100_000,
           [], {}, [math.nan] * 3, [1e308, -1e308], [-1e308, 1e308], [0, 10**400],
           {"start": -1e308, "stop": 1e308, "num": 3}, {"values": [math.inf]},
           {"start": 0, "stop": 1, "num": 10**30}, ["$x^$", 1], [[1.0, "y" * 100_000]]]


def _deep(n):
    x = 0
    for _ in range(n):
        x = [x]
    return x


def _keys(model):
    """Every key of every table the scene format has, for the base scene of ``model``."""
    spec = registry.get("flow" if model == "profile" else model)
    keys = [f"{t}.{k}" for t, ks in config.TABLES.items() if ks for k in ks]
    keys += [f"system.{p}" for p in spec.params] + [f"sweep.{p}" for p in spec.params]
    keys += [f"sweep.{p}.{x}" for p in spec.params for x in ("start", "stop", "num", "values")]
    keys += [f"sweep.initial.{c}" for c in spec.start_names] + ["sweep.follow", "nosuch.table"]
    keys += [f"initial.{c}" for c in spec.start_names]
    if model == "profile":
        keys += ["system.profile.period", "system.profile.corners", "system.profile.pieces"]
        keys += [f"system.profile.pieces.{i}.{k}" for i in range(4) for k in PR.KEYS]
    return keys


def _set_key(raw, key, value):
    """Set ``key`` (dotted; a number picks a list entry) in ``raw``."""
    parts = key.split(".")
    node = raw
    for p in parts[:-1]:
        if isinstance(node, list):
            node = node[int(p)] if int(p) < len(node) else node[-1]
            continue
        nxt = node.get(p)
        if not isinstance(nxt, (dict, list)):
            nxt = {}
            node[p] = nxt
        node = nxt
    if isinstance(node, dict):
        node[parts[-1]] = value


@st.composite
def extreme_scenes(draw):
    model = draw(st.sampled_from(list(BASES)))
    raw = tomllib.loads(open(BASES[model]).read())
    for _ in range(draw(st.integers(1, 3))):
        key = draw(st.sampled_from(_keys(model)) | st.sampled_from(["system.", "plot.", ""])
                   .map(lambda p: p + "k" * 100_000))
        value = draw(st.sampled_from(EXTREME).map(copy.deepcopy)
                     | st.integers(1, 3000).map(_deep) | st.floats() | st.integers())
        _set_key(raw, key, value)
    return raw


@settings(max_examples=int(os.environ.get("SCENE_FUZZ_EXAMPLES", "150")), deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(extreme_scenes())
def test_extreme_values_at_every_key_give_a_scene_or_a_scene_error(raw):
    """Extreme numbers (+-1e308, 1e-308, nan, inf, huge ints), huge strings, deep nesting
    and wrong types at every key of every table of every model (and of a cam profile):
    ``from_dict`` gives a Scene or a SceneError - never another exception - and no message
    quotes a value whole (each line under MESSAGE_MAX characters); a Scene's text reloads to
    the same scene."""
    try:
        sc = config.from_dict(raw)
    except config.SceneError as e:
        assert e.problems and all(isinstance(p, str) for p in e.problems)
        assert max(len(p) for p in e.problems) < MESSAGE_MAX, max(e.problems, key=len)[:2000]
    else:
        assert isinstance(sc, config.Scene)
        assert config.loads(sc.text).hash == sc.hash


VALID_EXTREMES = [
    [],                                                         # the shipped scene
    ["sweep.kappa={start = -1e300, stop = 1e300, num = 100000}", "initial.u=[0.0, 1e301]"],
    ["sweep.kappa={start = -0.02, stop = 0.0, num = 100000}",
     "sweep.omega={start = 1.0, stop = 3.0, num = 1000}"],
    ["system.omega=1e300", "system.beta=1e-300", "initial.u=[-1e300, 1e300]",
     "initial.v=[-1e300, 1e300]"],
    ["scene.title=\"" + "t" * config.MAX_TITLE + "\"", "initial.count=1048576"],
    ["run.transient=4611686018427387000", "run.record=100000"],
]


@pytest.mark.parametrize("sets", VALID_EXTREMES)
def test_validate_of_extreme_valid_scenes_is_small(sets):
    """A valid scene at the limits validates (exit 0) in a child limited to 2 GiB of address
    space (its grid of up to 10^8 points, its 2^62 events per run are never laid out; the
    child's CPU limit and the timeout only guard against a hang)."""
    def limit():
        resource.setrlimit(resource.RLIMIT_AS, (2 * 2**30, 2 * 2**30))
        resource.setrlimit(resource.RLIMIT_CPU, (120, 120))
    args = [sys.executable, "-m", "cornerbif.cli", "validate", FIG06A]
    args += [x for s in sets for x in ("--set", s)]
    p = subprocess.run(args, capture_output=True, text=True, timeout=300, preexec_fn=limit)
    assert p.returncode == 0, p.stdout + p.stderr


def test_the_limits_are_what_the_docs_say():
    """docs/cams.md states the profile limits the code declares."""
    text = open(os.path.join(ROOT, "docs", "cams.md")).read()
    for x in (f"{PR.MIN_PERIOD:g}", f"{PR.MAX_PERIOD:g}", f"{PR.MIN_SPAN_SHARE:g}",
              f"{PR.MAX_LIFT:g}", f"{PR.MAX_TURN:g}", f"{PR.MAX_ENCLOSURE:g}"):
        assert x in text, x
