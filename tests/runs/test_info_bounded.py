"""``cornerbif info`` prints every text a file holds cut at a bounded length, on lines of
bounded length, whatever the file declares.

Found by a hostile audit: a linear scene with a coordinate named with 100,000 characters
(its names are bounded now where a scene is read, but a file holds what it holds) made info
print a 200,000-character line "observables kept: impacts; state xxxx...".
"""

from __future__ import annotations

import os

import pytest
from click.testing import CliRunner

from cornerbif import cli, plot_data
from cornerbif.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
TWO_STOPS = os.path.join(ROOT, "configs", "two_stops.toml")
LONG = "x" * 100_000


@pytest.fixture(scope="module")
def linear_file(tmp_path_factory):
    out = tmp_path_factory.mktemp("info") / "ts.h5"
    r = CliRunner().invoke(main, ["sweep", TWO_STOPS, "-o", str(out), "--set",
                                  'sweep."forcing.0.Omega".num=2', "--set", "initial.count=2",
                                  "--set", "run.transient=20", "--set", "run.record=10",
                                  "--no-progress"])
    assert r.exit_code == 0, r.output
    return out


class _LongNames:
    """A model as a file may declare it: coordinates named with 100,000 characters, and
    many of them."""

    def __init__(self, spec):
        self._spec = spec
        self.coords = (LONG, "v_" + LONG) + tuple(f"c{i}" for i in range(200))

    def __getattr__(self, name):
        return getattr(self._spec, name)


def test_a_coordinate_of_100000_characters_is_cut(linear_file, monkeypatch):
    """The state's names are each cut (``plot_style.bounded``) and counted past MAX_LISTED;
    every line info prints is within MAX_INFO_LINE characters (and its cut mark)."""
    real = plot_data.PlotData

    class Long(real):
        def __init__(self, *a, **kw):
            super().__init__(*a, **kw)
            self.spec = _LongNames(self.spec)
    monkeypatch.setattr(plot_data, "PlotData", Long)
    r = CliRunner().invoke(main, ["info", str(linear_file)])
    assert r.exit_code == 0, r.output[:3000]
    line = next(x for x in r.output.splitlines() if "observables kept" in x)
    assert "; state xxxx" in line and "more" in line, line[:300]
    assert len(line) < cli.MAX_INFO_LINE, len(line)
    assert max(map(len, r.output.splitlines())) <= cli.MAX_INFO_LINE + 40


def test_every_line_is_bounded_whatever_it_gathers(linear_file, monkeypatch):
    """A line info makes of a file's fields is cut at MAX_INFO_LINE characters, with the
    length it had (``model.cut``), whatever field it holds."""
    monkeypatch.setattr(cli, "_sweep_lines", lambda f: ["  short", "  " + "y" * 10**6])
    r = CliRunner().invoke(main, ["info", str(linear_file)])
    assert r.exit_code == 0, r.output[:3000]
    lines = r.output.splitlines()
    assert lines[0] == "  short"
    assert len(lines[1]) <= cli.MAX_INFO_LINE + 40 and lines[1].endswith("characters>")


def test_names_line_cuts_each_name_and_counts_the_rest():
    text = cli._names_line([LONG, "v"] + [f"n{i}" for i in range(100)])
    assert text.startswith("xxx") and ", v, n0," in text, text[:200]
    assert text.endswith(f"and {102 - cli.MAX_LISTED} more") and len(text) < 1000
