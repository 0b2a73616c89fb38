"""Followed sweeps of the linear model (``sweep.follow``): each point's runs start from the
previous point's final states, taken in flight at the middle of the last recorded flight
(``LinearModel._final``: the exact flight from the last impact but one) and started at the
same phase of the system's period there (``LinearModel.starts_from_carry``).

The check of the phase and the state: between two points whose forcing frequencies differ
by 1e-12, the carried run must go on along the previous run's orbit, so that its first
impact is the previous run's last one, half a flight after its start (the same contact, the
same velocity before impact, to 1e-8), which a wrong phase (t0 off by a fraction of the
period) or a wrong state would not give."""

import h5py
import numpy as np
from click.testing import CliRunner

from cornerbif.cli import main

SCENE = """
[scene]
name = "followed_stops"
model = "linear"
[system]
dofs = ["x"]
mass = [1.0]
stiffness = [1.0]
damping = [0.04]
forcing = [{ on = "x", F = 0.7, Omega = 1.0 }]
[[system.contact]]
name = "L"
gap = { x = 1.0 }
kappa = -1.0
r = 0.8
[[system.contact]]
name = "R"
gap = { x = -1.0 }
kappa = -1.0
r = 0.8
[sweep]
"forcing.0.Omega" = { values = [1.5, 1.500000000001, 1.500000000002] }
follow = "FOLLOW"
[initial]
count = 3
seed = 1
x = [-0.9, 0.9]
v_x = [-1.0, 1.0]
[run]
transient = 0
record = 400
"""


def _sweep(tmp_path, follow):
    scene = tmp_path / f"{follow}.toml"
    scene.write_text(SCENE.replace("FOLLOW", follow))
    out = tmp_path / f"{follow}.h5"
    r = CliRunner().invoke(main, ["sweep", str(scene), "-o", str(out), "--no-progress"])
    assert r.exit_code == 0, r.output
    return h5py.File(out)


def test_a_followed_run_goes_on_along_the_previous_points_orbit(tmp_path):
    f = _sweep(tmp_path, "up")
    t, c, v_in = f["impacts/t"][...], f["impacts/contact"][...], f["impacts/v_in"][...]
    t0, x0, phase = f["initial/t"][...], f["initial/x"][...], f["final/phase"][...]
    T = 2 * np.pi / f["forcing.0.Omega"][...]
    carried = 0
    for p in (1, 2):
        for i in range(3):
            n_prev = np.isfinite(t[p - 1, i]).sum()
            if n_prev < 2 or not np.isfinite(phase[p - 1, i]):
                continue
            carried += 1
            assert t0[p, i] == phase[p - 1, i] * T[p]             # the phase, at this period
            assert x0[p, i] == f["final/x"][p - 1, i]
            last, before = t[p - 1, i, n_prev - 1], t[p - 1, i, n_prev - 2]
            # the first impact: the previous run's last, half a flight after the start
            assert c[p, i, 0] == c[p - 1, i, n_prev - 1]
            assert abs((t[p, i, 0] - t0[p, i]) - 0.5 * (last - before)) < 1e-8
            assert abs(v_in[p, i, 0] - v_in[p - 1, i, n_prev - 1]) < 1e-8
    assert carried >= 4


def test_followed_up_and_down_start_from_their_neighbours(tmp_path):
    """Down: the last value first; each point but the first of the direction starts from the
    next one's final state (where that run recorded two impacts)."""
    f = _sweep(tmp_path, "down")
    t0, x0 = f["initial/t"][...], f["initial/x"][...]
    fx, phase = f["final/x"][...], f["final/phase"][...]
    T = 2 * np.pi / f["forcing.0.Omega"][...]
    moved = [(p, i) for p in (0, 1) for i in range(3) if np.isfinite(phase[p + 1, i])]
    assert moved
    for p, i in moved:
        assert x0[p, i] == fx[p + 1, i] and t0[p, i] == phase[p + 1, i] * T[p]
    assert (t0[2] == 0.0).all()                  # the direction's first point: drawn at t = 0
