"""Sweeps over initial conditions (issue 19, first part): [sweep] initial.<coordinate>.

Each cell of a start-coordinate axis is one run from that start; checked against
cornerbif.simulate from the same starts (the kernel's Python entry, not the sweep's
engine) and against the scene validation's messages.
"""

import os

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

import cornerbif
from cornerbif import config
from cornerbif.cli import main

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENE = os.path.join(ROOT, "configs", "basin_hysteresis.toml")
# kappa beside a swept start u (v drawn): the hysteresis wedge at omega = 2.001
KAPPA_AND_U = """[scene]
name = "s"
model = "flow"
[system]
omega = 2.001
kappa = 0.008
r = 0.8
[sweep]
kappa = { start = 0.004, stop = 0.012, num = 3 }
initial.u = { start = 1.0, stop = 19.0, num = 4 }
[initial]
count = 2
v = [-0.02, 0.02]
[run]
transient = 300
record = 20
"""


def test_start_axes_are_read_and_written_back():
    """initial.u and initial.v become axes 'initial.u', 'initial.v' (TOML's dotted keys);
    the scene as run reads back to the same axes; count is 1 when every coordinate is
    swept; Scene.point leaves them out of the parameters."""
    sc = config.load(SCENE, ["sweep.initial.u.num=5", "sweep.initial.v.num=3"])
    assert [a.name for a in sc.axes] == ["initial.u", "initial.v"] and sc.n_ic == 1
    again = config.loads(sc.text)
    assert [(a.name, a.values) for a in again.axes] == [(a.name, a.values) for a in sc.axes]
    assert "initial.u" not in sc.point((1, 2)) and sc.start_axes["v"][0] == 1


@pytest.mark.parametrize("sets,needle", [
    (["sweep.initial.w={start=0, stop=1, num=2}"], "sweep.initial.w: 'w' is not a start "
                                                   "coordinate of model 'flow'"),
    (["sweep.follow=\"up\""], "sweep.follow: 'up' carries the final state"),
    (["initial.count=4"], "initial.count: 4 with every start coordinate swept"),
    (["initial.u=[0.0, 1.0]"], "initial.u: [0.0, 1.0] but sweep.initial.u sweeps it"),
    (["sweep.initial.u={start=0, stop=1e400, num=2}"], "sweep.initial.u.stop"),
])
def test_bad_start_axes_are_refused(sets, needle):
    args = ["validate", SCENE]
    for s in sets:
        args += ["--set", s]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 2 and needle in r.output, r.output


def test_each_cell_is_the_run_from_its_start(tmp_path):
    """An 11 x 7 basin of the hysteresis wedge: every cell's stored start is its axis
    values, and its cycle word and period are those cornerbif.simulate finds from that
    start (all 77 cells); the basin image draws."""
    out = tmp_path / "b.h5"
    r = CliRunner().invoke(main, ["sweep", SCENE, "-o", str(out), "--no-progress",
                                  "--set", "sweep.initial.u.num=11",
                                  "--set", "sweep.initial.v.num=7",
                                  "--set", "run.transient=1500"])
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        u, v = f["initial.u"][...], f["initial.v"][...]
        assert np.array_equal(f["initial/u"][..., 0], np.repeat(u[:, None], 7, axis=1))
        assert np.array_equal(f["initial/v"][..., 0], np.repeat(v[None, :], 11, axis=0))
        words = f["symbols"][..., 0].astype(str)
        period = f["period"][..., 0]
    U, V = np.meshgrid(u, v, indexing="ij")
    res = cornerbif.simulate(U, V, omega=2.001, kappa=0.008, r=0.8, transient=1500,
                             record=60)
    assert np.array_equal(res["symbols"], words)
    assert np.array_equal(res["period"], period)
    assert {"a", "b"} <= set(words.ravel())          # both attractors of the wedge
    r = CliRunner().invoke(main, ["plot", str(out), "-o", str(tmp_path / "b.png")])
    assert r.exit_code == 0, r.output


def test_a_start_axis_beside_a_parameter_axis(tmp_path):
    """kappa x initial.u (v drawn from [initial]): each cell's u start is its axis value,
    whatever kappa."""
    scene = tmp_path / "s.toml"
    scene.write_text(KAPPA_AND_U)
    out = tmp_path / "s.h5"
    r = CliRunner().invoke(main, ["sweep", str(scene), "-o", str(out), "--no-progress"])
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        assert f["initial/u"].shape == (3, 4, 2)
        assert np.array_equal(f["initial/u"][...],
                              np.broadcast_to(f["initial.u"][...][None, :, None], (3, 4, 2)))
        iv = f["initial/v"][...]
        assert (iv >= -0.02).all() and (iv <= 0.02).all() and np.unique(iv).size > 4


@pytest.mark.parametrize("obstacle,omega,kappa,extra", [
    ("rectified_sine", 2.001, 0.008, {}),
    ("sine", 1.7, 0.0, {}),
    ("triangle", 1.9, -0.01, {"theta1": 1.9, "theta2": 2.5}),
    ("rectified_sine", 1.3, 0.0, {"sigma": 0.05, "F": 0.4, "Omega": 1.1}),
])
def test_a_start_time_is_the_run_from_that_phase(obstacle, omega, kappa, extra):
    """simulate(t0=...) (the kernel started inside a piece of the obstacle) against the
    exhaustive search of tests/naive.py from the same (t0, u0, v0): the first 6 impacts'
    times, heights and velocities to 1e-8, at starts spread over an obstacle period."""
    from naive import naive_impacts
    per = np.pi / omega * (2 if obstacle == "sine" else 1)
    t0 = np.array([0.0, 0.13, 0.5, 0.77, 0.999]) * per + np.array([0, 0, 0, 1, 3]) * per
    u0 = np.array([3.0, 1.5, 1.6, 2.2, 4.0])
    v0 = np.array([0.5, -1.0, 2.0, 0.0, -3.0])
    res = cornerbif.simulate(u0, v0, t0=t0, obstacle=obstacle, omega=omega, kappa=kappa,
                             r=0.8, record=6, **extra)
    assert (res["status"] == 0).all()
    for i in range(t0.size):
        ref = naive_impacts(obstacle, omega, kappa, 1.0, 0.8, u0[i], v0[i], 6, t0=t0[i],
                            **extra)
        assert ref.shape == (6, 4)
        got = np.stack([res["t"][i], res["u"][i], res["v_in"][i], res["v_out"][i]], -1)
        assert np.allclose(got, ref, rtol=0, atol=1e-8), (i, np.abs(got - ref).max())


def test_a_start_time_axis_draws_u_above_the_obstacle_at_its_time(tmp_path):
    """[sweep] initial.t beside drawn u, v: every start's time is its cell's, and its
    drawn u clears z(t0) (not only z(0) = kappa); a negative start time is refused."""
    text = KAPPA_AND_U.replace("initial.u = { start = 1.0, stop = 19.0, num = 4 }",
                               "initial.t = { start = 0.0, stop = 1.5, num = 5 }")
    sc = config.loads(text, ["sweep.kappa.num=2", "initial.u=[0.0, 2.0]"])
    from cornerbif import engine
    blk = engine.compute_block(sc, engine.blocks(sc)[0])
    t0 = blk["initial/t"]
    assert np.array_equal(t0, np.broadcast_to(np.linspace(0, 1.5, 5)[None, :, None], t0.shape))
    z = 0.008 + np.abs(np.sin(2.001 * t0))
    assert (blk["initial/u"] > z).all() and (blk["status"] == 0).all()
    r = CliRunner().invoke(main, ["validate", SCENE, "--set", "initial.t=[-1.0, 0.0]"])
    assert r.exit_code == 2 and "initial.t: [-1.0, 0.0] must not be negative" in r.output


def test_drawn_u_must_clear_the_obstacle_over_the_start_times():
    """With start times drawn ([initial] t), u's range must reach above the obstacle's top
    (kappa + beta for the rectified sine), not only above z(0) = kappa."""
    scene = """[scene]
name = "t"
model = "flow"
[system]
omega = 1.999
kappa = 0.0
[initial]
count = 20
u = [0.05, 0.5]
t = [0.0, 1.5]
"""
    with pytest.raises(config.SceneError) as e:
        config.loads(scene)
    assert "initial.u: [0.05, 0.5] does not reach above the obstacle's top z = 1.0" in str(e.value)
    assert config.loads(scene.replace("u = [0.05, 0.5]", "u = [0.05, 1.5]")).n_ic == 20


def test_early_stop_from_a_start_time_finds_the_same_cycles():
    """run.stop = "period" (the kernel's early stop, which compares states at corners)
    from starts at random times up to 300 obstacle periods: the same words and periods as
    without it, for 300 starts."""
    rng = np.random.default_rng(5)
    n = 300
    t0 = rng.uniform(0.0, 300 * np.pi / 2.001, n)
    u0 = rng.uniform(1.2, 20.0, n)
    v0 = rng.uniform(-5.0, 5.0, n)
    kw = dict(t0=t0, omega=2.001, kappa=0.008, r=0.8, transient=1500, record=60)
    a = cornerbif.simulate(u0, v0, stop="none", **kw)
    b = cornerbif.simulate(u0, v0, stop="period", **kw)
    assert np.array_equal(a["period"], b["period"]) and np.array_equal(a["symbols"], b["symbols"])
    assert (a["period"] > 0).mean() > 0.9
