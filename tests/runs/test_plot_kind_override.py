"""``cornerbif plot --kind KIND``: a figure kind other than the file's own ``[plot] kind``
is asked of the file's scene before anything is drawn, as ``validate`` asks it of a scene
(``FigureKind.check``, through ``config.kind_problems``).

Found by a hostile audit: ``--kind timeseries`` and ``--kind obstacle`` on a genuine
linear sweep were refused (exit 2) as files "that cannot be drawn (ValueError: ... / KeyError:
'obstacle') ... hold values cornerbif does not write (damaged or crafted), or this is a bug":
untrue of a file cornerbif wrote.  Now each kind's own reason is said, and the figure kinds
a file of single runs is pointed to are those that can draw it.
"""

from __future__ import annotations

import os

import pytest
from click.testing import CliRunner

from cornerbif import config
from cornerbif.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CONFIGS = os.path.join(ROOT, "configs")
SMALL = ["--set", "initial.count=2", "--set", "run.transient=20", "--set", "run.record=10",
         "--no-progress"]
# what the reader of an unexpected failure says: never of a file cornerbif wrote
CRAFTED = "damaged or crafted"


def run(*args):
    r = CliRunner().invoke(main, [str(a) for a in args])
    assert "Traceback" not in r.output and "internal error" not in r.output, r.output
    return r


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    """Small genuine sweeps: a linear diagram, a two-particle diagram, a map2d file of
    single runs."""
    d = tmp_path_factory.mktemp("kinds")
    made = {
        "linear": ("two_stops.toml", ["--set", 'sweep."forcing.0.Omega".num=3']),
        "two_particle": ("fig19a.toml", ["--set", "sweep.omega0.num=3"]),
        "map2d_single": ("fig09_map.toml", ["--set", "initial.count=20", "--set",
                                            "run.record=2", "--no-progress"]),
    }
    out = {}
    for name, (scene, extra) in made.items():
        path = d / f"{name}.h5"
        more = SMALL if name != "map2d_single" else []
        r = run("sweep", os.path.join(CONFIGS, scene), "-o", path, *more, *extra)
        assert r.exit_code == 0, r.output
        out[name] = path
    return out


@pytest.mark.parametrize("kind, needle", [
    ("timeseries", "'timeseries' needs model 'flow' (the scene's model is 'linear')"),
    ("obstacle", "it needs model 'flow' with obstacle"),
    ("regions", "draws a scene without sweep axes"),
    ("return_map", "needs run.transient = 0"),
    ("orbit", "(this scene: model 'linear')"),
])
def test_a_kind_that_cannot_draw_a_linear_file_says_its_own_reason(files, tmp_path, kind,
                                                                    needle):
    """The kinds of the flow and its normal form on a linear sweep: exit 2 before drawing,
    the kind's own reason (what ``validate`` says of ``[plot] kind`` on that scene), no
    figure, and never "damaged or crafted"."""
    fig = tmp_path / "k.png"
    r = run("plot", files["linear"], "--kind", kind, "-o", fig)
    assert r.exit_code == 2, r.output
    assert f"cannot be drawn as [plot] kind {kind!r}" in r.output and needle in r.output, r.output
    assert CRAFTED not in r.output and "KeyError" not in r.output, r.output
    assert not fig.exists() and not os.path.exists(str(fig) + ".partial")


@pytest.mark.parametrize("name", ["two_particle", "map2d_single"])
@pytest.mark.parametrize("kind", ["timeseries", "obstacle"])
def test_flow_kinds_on_other_models_say_the_model_they_need(files, tmp_path, name, kind):
    """A time series and the obstacle's figure are the flow's: on a two-particle or map2d
    file each says it needs model 'flow' (they were a ValueError and a KeyError)."""
    r = run("plot", files[name], "--kind", kind, "-o", tmp_path / "k.png")
    assert r.exit_code == 2, r.output
    assert "needs model 'flow'" in r.output and CRAFTED not in r.output, r.output


@pytest.mark.parametrize("kind", ["fractions", "branches"])
def test_kinds_of_swept_files_on_single_runs_say_so(files, tmp_path, kind):
    r = run("plot", files["map2d_single"], "--kind", kind, "-o", tmp_path / "k.png")
    assert r.exit_code == 2, r.output
    assert "this scene sweeps nothing" in r.output and CRAFTED not in r.output, r.output


def test_a_diagram_of_single_runs_names_the_kinds_that_draw_them(files, tmp_path):
    """``--kind diagram`` on a map2d file of single runs: nothing to draw as a diagram,
    and the kinds named are those whose check passes on it (regions, return maps, orbits
    of the maps), not a time series (the flow's only); they draw it."""
    r = run("plot", files["map2d_single"], "--kind", "diagram", "-o", tmp_path / "d.png")
    assert r.exit_code == 2, r.output
    assert "nothing to draw as a diagram" in r.output, r.output
    assert "regions" in r.output and "timeseries" not in r.output, r.output


@pytest.mark.slow
def test_kinds_that_can_draw_a_file_still_draw_it(files, tmp_path):
    """The check refuses only what the kind's own check refuses: a linear diagram drawn as
    a diagram or as basin fractions is drawn, and the map2d file of single runs as the
    regions its refusal of a diagram named."""
    for name, kind in (("linear", "diagram"), ("linear", "fractions"),
                       ("map2d_single", "regions")):
        r = run("plot", files[name], "--kind", kind, "-o", tmp_path / f"{kind}.png")
        assert r.exit_code == 0, r.output
        assert (tmp_path / f"{kind}.png").exists()


def test_an_unknown_kind_is_refused_naming_the_kinds(files, tmp_path):
    r = run("plot", files["linear"], "--kind", "timesries", "-o", tmp_path / "k.png")
    assert r.exit_code == 2, r.output
    assert "--kind 'timesries': not a figure kind (did you mean 'timeseries'?)" in r.output
    assert "allowed: diagram" in r.output


def test_kind_problems_is_the_check_validate_makes(files):
    """``config.kind_problems`` says of a file's scene what ``validate`` says of ``[plot]
    kind`` on that scene (its problems without the key), and nothing of a kind that can
    draw it."""
    import h5py
    with h5py.File(files["linear"]) as f:
        text = str(f.attrs["scene"])
    said = config.kind_problems(text, "timeseries")
    with pytest.raises(config.SceneError) as e:
        config.loads(text, ['plot.kind="timeseries"'])
    assert said and all(any(p in q for q in e.value.problems) for p in said), (said, e.value)
    assert config.kind_problems(text, "diagram") == []
    assert config.kind_problems("not toml [", "diagram") is None


def test_a_kind_given_for_continuation_files_alone_is_refused(tmp_path, monkeypatch):
    """Continuation files alone are drawn as their branches whatever ``--kind`` said: a
    figure of another kind than the one asked was written without a word.  Now refused,
    before the file is read."""
    from cornerbif import plot
    from cornerbif.plot_base import Undrawable
    monkeypatch.setattr(plot, "is_continuation", lambda f: True)
    with pytest.raises(Undrawable) as e:
        plot.draw_files([str(tmp_path / "c.h5")], str(tmp_path / "c.png"), kind="timeseries")
    assert "is a continuation file" in str(e.value) and "--kind timeseries" in str(e.value)
