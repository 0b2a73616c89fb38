"""Starts given as a list (``[initial] points``) or in a text file (``points_file``), besides
a grid or a random box (issue 32): the runs of the sweep are those of ``cornerbif.simulate``
from the same starts (the one engine, two doors), the scene as run lists the points, and
what cannot be a list of starts is refused naming the key."""

import h5py
import numpy as np
import pytest

import cornerbif
from cornerbif import config
from cornerbif.config import SceneError
from cornerbif.sweep import run_sweep

SCENE = """
[scene]
name = "given"
model = "flow"
[system]
obstacle = "rectified_sine"
omega = 1.999
kappa = -0.005
r = 0.8
[sweep]
kappa = {{ start = -0.006, stop = -0.004, num = 3 }}
[initial]
{initial}
[run]
transient = 300
record = 50
[output]
keep = ["impacts"]
"""
STARTS = [[5.0, 0.0], [10.0, -3.0, 0.5], [2.0, 1.0]]


def test_given_starts_run_as_simulate_runs_them(tmp_path):
    """Every grid point runs the three starts (the flow's start time 0 where left out); at
    kappa = -0.005 the impact times equal ``cornerbif.simulate``'s from the same starts,
    bit for bit; the scene as run (the file's) lists them."""
    out = str(tmp_path / "g.h5")
    run_sweep(config.loads(SCENE.format(initial=f"points = {STARTS}")), out)
    with h5py.File(out) as f:
        u0, t0 = f["initial/u"][...], f["initial/t"][...]
        assert np.array_equal(u0, np.tile([5.0, 10.0, 2.0], (3, 1)))
        assert np.array_equal(t0, np.tile([0.0, 0.5, 0.0], (3, 1)))
        t = f["impacts/t"][1]
        text = str(f.attrs["scene"])
    r = cornerbif.simulate(np.array([5.0, 10.0, 2.0]), np.array([0.0, -3.0, 1.0]),
                           t0=np.array([0.0, 0.5, 0.0]), transient=300, record=50,
                           obstacle="rectified_sine", omega=1.999, kappa=-0.005, r=0.8)
    assert np.array_equal(r["t"], t, equal_nan=True)
    assert "points = [[5.0, 0.0, 0.0], [10.0, -3.0, 0.5], [2.0, 1.0, 0.0]]" in text
    again = config.loads(text)
    assert again.points == ((5.0, 0.0, 0.0), (10.0, -3.0, 0.5), (2.0, 1.0, 0.0))


def test_a_points_file_is_read_beside_the_scene(tmp_path):
    """``points_file`` (one start per line, commas or spaces, # comments) is read relative
    to the scene file, and gives the same scene as the inline list."""
    (tmp_path / "starts.txt").write_text("# u v t0\n5.0, 0.0\n10.0 -3.0 0.5\n\n2.0,1.0\n")
    (tmp_path / "s.toml").write_text(SCENE.format(initial='points_file = "starts.txt"'))
    from_file = config.load(str(tmp_path / "s.toml"))
    inline = config.loads(SCENE.format(initial=f"points = {STARTS}"))
    assert from_file.points == inline.points and from_file.n_ic == 3
    assert from_file.text == inline.text


@pytest.mark.parametrize("initial,says", [
    ("points = [[5.0]]", "initial.points: "),
    ("points = [[5.0, 0.0, 0.0, 1.0]]", "initial.points: "),
    ('points = [[5.0, "a"]]', "initial.points: "),
    ("points = []", "initial.points: "),
    ("points = [[5.0, 0.0]]\ncount = 4", "initial.count has no use"),
    ("points = [[5.0, 0.0]]\nu = [0.0, 1.0]", "initial.u has no use"),
    ('points = [[5.0, 0.0]]\npoints_file = "x.txt"', "give one of the two"),
    ('points_file = "no_such_file.txt"', "initial.points_file: 'no_such_file.txt' cannot be read"),
])
def test_what_is_no_list_of_starts_is_refused(initial, says):
    with pytest.raises(SceneError) as e:
        config.loads(SCENE.format(initial=initial))
    assert any(says in p for p in e.value.problems), e.value.problems


def test_points_beside_a_swept_start_coordinate_are_refused():
    """A swept start coordinate would be ignored by given starts: refused, naming both."""
    text = SCENE.format(initial="points = [[5.0, 0.0]]").replace(
        "kappa = { start = -0.006, stop = -0.004, num = 3 }",
        "kappa = { start = -0.006, stop = -0.004, num = 3 }\n"
        "initial.u = { start = 0.5, stop = 5.0, num = 3 }")
    with pytest.raises(SceneError) as e:
        config.loads(text)
    assert any("sweep.initial.u" in p and "initial.points" in p for p in e.value.problems)


def test_a_points_file_that_is_no_regular_file_or_too_big_is_refused(tmp_path, monkeypatch):
    """A FIFO is never opened (reading it would wait for a writer forever), nor a folder;
    a file past the size read is refused, not cut (a cut could end inside a number)."""
    import os
    os.mkfifo(tmp_path / "fifo.txt")
    (tmp_path / "dir.txt").mkdir()
    for name in ("fifo.txt", "dir.txt"):
        (tmp_path / "s.toml").write_text(SCENE.format(initial=f'points_file = "{name}"'))
        with pytest.raises(SceneError) as e:
            config.load(str(tmp_path / "s.toml"))
        assert any("not a regular file" in p for p in e.value.problems), e.value.problems
    monkeypatch.setattr(config, "MAX_POINTS_BYTES", 20)
    (tmp_path / "big.txt").write_text("1.0 2.0\n" * 4)
    (tmp_path / "s.toml").write_text(SCENE.format(initial='points_file = "big.txt"'))
    with pytest.raises(SceneError) as e:
        config.load(str(tmp_path / "s.toml"))
    assert any("more than 20 characters" in p for p in e.value.problems), e.value.problems
