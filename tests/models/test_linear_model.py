"""The ``linear`` model as a model: a scene declares the system, and sweeps, files, figures and
``simulate`` run it (docs/linear.md).

Checked against computations independent of it:

- the bouncing ball's period-one orbit and its period doubling, in closed form (derived in
  ``_ball_closed_form`` and ``test_the_bouncing_ball_doubles_its_period_where_the_closed_form_says``);
- one mass against a rectified sine: the ``flow`` model's kernel, a different code for the
  same physics (its closed-form oscillator and its own certified search);
- what the scene may not say, refused naming the key and the value.
"""

import math
import os
import tomllib
import warnings

import h5py
import numpy as np
import pytest
from click.testing import CliRunner

import cornerbif
from cornerbif import config, registry
from cornerbif.cli import main
from cornerbif.config import SceneError

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

# a ball (unit mass, gravity g = 1: the constant force -1) on a table z = beta sin(omega t)
BALL = """
[scene]
name = "ball"
model = "linear"

[system]
dofs = ["x"]
mass = [1.0]
stiffness = [0.0]
forcing = [{ on = "x", F = -1.0 }]

[[system.contact]]
name = "T"
gap = { x = 1.0 }
obstacle = "sine"
kappa = 0.0
beta = 0.036
omega = 6.0
r = 0.5
"""
G, OMEGA, R = 1.0, 6.0, 0.5


def _ball_table():
    return tomllib.loads(BALL)["system"]


def _ball_closed_form(beta):
    """The period-one orbit of the bouncing ball, one impact per table period T = 2 pi /
    omega (derived here).  The ball leaves the table at t* with velocity v+ and meets it
    again at t* + T, where the table is back at z(t*): v+ T - g T^2 / 2 = 0, so v+ = g T / 2
    and v- = v+ - g T = -g T / 2.  The impact law relative to the table, v+ - z' = -r (v- -
    z'), then gives z'(t*) = g T (1 - r) / (2 (1 + r)): beta omega cos(omega t*) = that, so
    cos(omega t*) = pi (1 - r) / ((1 + r) Gamma), Gamma = beta omega^2 / g.  Of its two
    solutions the stable one has sin(omega t*) > 0 (the doubling test below): the impact
    height u = z(t*) = beta sqrt(1 - cos^2)."""
    gamma = beta * OMEGA ** 2 / G
    c = math.pi * (1 - R) / ((1 + R) * gamma)
    return beta * math.sqrt(1 - c * c), -G * math.pi / OMEGA, G * math.pi / OMEGA


def test_the_bouncing_balls_period_one_orbit_is_the_closed_form():
    rng = np.random.default_rng(3)
    x0, v0 = rng.uniform(0.2, 0.5, 48), rng.uniform(-0.5, 0.5, 48)
    for beta in (0.031, 0.036, 0.041):                 # Gamma = 1.12, 1.30, 1.48
        r = cornerbif.simulate(x0, v0, model="linear", table=_ball_table(), transient=300,
                               record=12, **{"contact.T.beta": beta})
        one = np.flatnonzero(r["period"] == 1)
        assert one.size >= 2, (beta, r["status"])       # most starts chatter to rest (STUCK)
        u, v_in, v_out = _ball_closed_form(beta)
        for i in one:
            assert r["symbols"][i] == "T" and r["impacts_per_cycle"][i] == 1
            np.testing.assert_allclose(r["u"][i], u, atol=1e-9)
            np.testing.assert_allclose(r["v_in"][i], v_in, atol=1e-9)
            np.testing.assert_allclose(r["v_out"][i], v_out, atol=1e-9)


def test_the_bouncing_ball_doubles_its_period_where_the_closed_form_says():
    """Linearised about the period-one orbit (impact times t_k, velocities v_k after each
    impact; a = z'(t*), b = z''(t*), D = g T / 2 + a = g T / (1 + r)), the impact map has
    J = [[1, T / D], [(1 + r) b, ((1 + r) b + r g) T / D - r]]: det J = r^2 and
    tr J = 1 + r^2 + (1 + r)^2 b / g.  An eigenvalue -1 (1 + tr + det = 0) needs b / g =
    -2 (1 + r^2) / (1 + r)^2, i.e. Gamma sin(omega t*) = 2 (1 + r^2) / (1 + r)^2: with the
    orbit's Gamma cos(omega t*) = pi (1 - r) / (1 + r),
    Gamma_PD^2 = (pi (1 - r) / (1 + r))^2 + (2 (1 + r^2) / (1 + r)^2)^2 (1.5268 at r = 0.5).
    The sweep finds period 1 below Gamma_PD and period 2 above it, to its grid spacing (the
    multiplier near -1 converges slowly: the points within 0.02 of it are not judged)."""
    g_pd = math.hypot(math.pi * (1 - R) / (1 + R), 2 * (1 + R * R) / (1 + R) ** 2)
    gammas = np.linspace(1.2, 1.64, 23)
    betas = gammas * G / OMEGA ** 2
    rng = np.random.default_rng(5)
    x0, v0 = rng.uniform(0.2, 0.5, 12), rng.uniform(-0.5, 0.5, 12)
    B, X, V = np.meshgrid(betas, x0, v0, indexing="ij", sparse=False)
    r = cornerbif.simulate(X[:, :, 0], V[:, :, 0], model="linear", table=_ball_table(),
                           transient=600, record=16, **{"contact.T.beta": B[:, :, 0]})
    for gamma, period in zip(gammas, r["period"]):
        found = set(int(p) for p in period if p > 0)
        if gamma < g_pd - 0.02:
            assert found == {1}, (gamma, found)
        elif gamma > g_pd + 0.02:
            assert found == {2}, (gamma, found)


FLOW_SCENE = """
[scene]
name = "one_mass_flow"
model = "flow"
[system]
obstacle = "rectified_sine"
omega = 1.8
kappa = 0.0
beta = 1.0
r = 0.8
sigma = 0.05
k = 1.0
"""

LINEAR_SCENE = """
[scene]
name = "one_mass_linear"
model = "linear"
[system]
dofs = ["x"]
mass = [1.0]
stiffness = [1.0]
damping = [0.1]
[[system.contact]]
name = "W"
gap = { x = 1.0 }
obstacle = "rectified_sine"
kappa = 0.0
beta = 1.0
omega = 1.8
r = 0.8
"""


def test_one_mass_against_a_rectified_sine_is_the_flow_model():
    """The flow model's eq (4) with k = 1, sigma = 0.05 against |sin omega t| is the linear
    system m = 1, K = k^2, C = 2 sigma with one contact: over the first 20 impacts the two
    kernels (different codes: the flow's closed-form oscillator and Sturm bounds, the
    linear model's matrix exponentials and Taylor bounds) give the same impacts to 1e-9."""
    omegas = np.array([1.6, 1.8, 1.95, 2.1, 2.4])
    u0 = np.array([5.0, 3.0, 8.0, 1.5, 12.0])
    v0 = np.array([0.0, 1.0, -2.0, 0.5, 3.0])
    f = cornerbif.simulate(u0[:, None], v0[:, None], model="flow", omega=omegas[None, :],
                           obstacle="rectified_sine", kappa=0.0, beta=1.0, r=0.8, sigma=0.05,
                           k=1.0, transient=0, record=20)
    lin = cornerbif.simulate(model="linear", table=tomllib.loads(LINEAR_SCENE)["system"],
                             x0=u0[:, None], v_x0=v0[:, None], transient=0, record=20,
                             **{"contact.W.omega": omegas[None, :]})
    assert np.array_equal(np.isfinite(f["t"]), np.isfinite(lin["t"]))
    for k in ("t", "u", "v_in", "v_out"):
        np.testing.assert_allclose(lin[k], f[k], atol=1e-9, rtol=1e-9, err_msg=k)


def test_one_mass_cycles_have_the_flows_impacts_per_cycle():
    """After a transient, runs of both models that reach a cycle find it with the same
    impacts per cycle, the same impacts, and (one contact on a cornered obstacle: the
    paper's words, ``model.paper_words``) the same word and period in corner clusters."""
    omegas = np.linspace(1.6, 2.4, 9)
    f = cornerbif.simulate(5.0, 0.0, model="flow", omega=omegas, obstacle="rectified_sine",
                           kappa=0.0, beta=1.0, r=0.8, sigma=0.05, k=1.0, transient=300,
                           record=40)
    lin = cornerbif.simulate(model="linear", table=tomllib.loads(LINEAR_SCENE)["system"],
                             x0=5.0, v_x0=0.0, transient=300, record=40,
                             **{"contact.W.omega": omegas})
    both = (f["impacts_per_cycle"] > 0) & (lin["impacts_per_cycle"] > 0)
    assert both.sum() >= 6
    assert np.array_equal(f["impacts_per_cycle"][both], lin["impacts_per_cycle"][both])
    np.testing.assert_allclose(lin["u"][both], f["u"][both], atol=1e-7)
    np.testing.assert_array_equal(lin["symbols"][both], f["symbols"][both])
    np.testing.assert_array_equal(lin["period"][both], f["period"][both])


def _scene(text, *sets):
    raw = tomllib.loads(text)
    return config.from_dict(raw) if not sets else config.loads(text, list(sets))


@pytest.mark.parametrize("edit, needle", [
    (("mass = [1.0]", "mass = [-1.0]"), "system.mass"),
    (("dofs = [\"x\"]", "dofs = [\"x\", \"x\"]"), "system.dofs"),
    (("name = \"T\"", "name = \"TT\""), "system.contact"),
    (("r = 0.5", "r = 1.5"), "1.5"),
    (("r = 0.5", "law = \"spring\"\nk = 10.0"), "spring"),
    (("[[system.contact]]", "[[system.contactx]]"), "system.contact"),
    (("dofs = [\"x\"]", "dofs = [\"v_x\"]"), "system.dofs.0"),
    (("dofs = [\"x\"]", "dofs = [\"count\"]"), "system.dofs.0"),
])
def test_a_bad_system_is_refused_naming_the_key_and_value(edit, needle):
    with pytest.raises(SceneError) as e:
        config.loads(BALL.replace(*edit))
    assert needle in str(e.value), str(e.value)


def test_a_sweep_through_a_bad_system_is_refused_naming_the_point():
    """A value out of its own range is refused by its axis; values each allowed that make a
    system that is not (an off-diagonal mass entry of 2 between masses of 1: M is not
    positive-definite) are refused naming the point."""
    with pytest.raises(SceneError) as e:
        config.loads(BALL + '[sweep]\n"mass.x" = { values = [1.0, 0.5, -0.5] }\n')
    assert "mass.x" in str(e.value) and "-0.5" in str(e.value), str(e.value)
    two = BALL.replace('dofs = ["x"]', 'dofs = ["x", "y"]').replace(
        "mass = [1.0]", "mass = [[1.0, 0.5], [0.5, 1.0]]").replace(
        "stiffness = [0.0]", "stiffness = [0.0, 1.0]")
    config.loads(two)
    with pytest.raises(SceneError) as e:
        config.loads(two + '[sweep]\n"mass.x.y" = { values = [0.5, 0.9, 2.0] }\n')
    assert "system.mass" in str(e.value) and "sweep.mass.x.y = 2.0" in str(e.value), str(e.value)


def test_unknown_coordinates_and_axes_are_refused():
    with pytest.raises(SceneError) as e:
        config.loads(BALL + "[initial]\ny = [0.0, 1.0]\n")
    assert "initial.y" in str(e.value)
    with pytest.raises(SceneError) as e:
        config.loads(BALL + '[sweep]\n"contact.T.bta" = { values = [0.03] }\n')
    assert "contact.T.bta" in str(e.value)
    # a followed sweep is a linear scene's too (tests/models/test_linear_follow.py)
    assert config.loads(BALL + '[sweep]\n"contact.T.beta" = { values = [0.03, 0.04] }\n'
                        'follow = "up"\n').follow == "up"


def test_the_scene_as_run_reads_back_to_the_same_model():
    """The scene a file stores (its [system] as given, its axes' paths quoted) is read back
    to the same coordinates, parameters and values."""
    s = config.loads(BALL + '[sweep]\n"contact.T.beta" = { values = [0.03, 0.04] }\n'
                     '[initial]\nx = [0.2, 0.5]\nv_x = [-0.5, 0.5]\n')
    again = config.loads(s.text)
    assert again.spec.start_names == s.spec.start_names == ("x", "v_x", "t")   # t: the start time
    assert list(again.spec.params) == list(s.spec.params)
    assert again.axes == s.axes and again.system == s.system and again.text == s.text
    assert s.spec is not registry.get("linear")


def test_sweep_plot_info_and_resume_end_to_end(tmp_path, monkeypatch):
    """``cornerbif sweep`` writes the file, ``info`` and ``plot`` read it, and a sweep cut
    after its first block and resumed writes the same bytes as one run whole."""
    from cornerbif import engine
    from cornerbif import sweep as sweep_mod
    scene = tmp_path / "ball.toml"
    scene.write_text(BALL + '[sweep]\n"contact.T.beta" = { start = 0.031, stop = 0.05, num = 6 }\n'
                     '[initial]\ncount = 3\nx = [0.2, 0.5]\nv_x = [-0.5, 0.5]\n'
                     '[run]\ntransient = 100\nrecord = 16\n')
    runner = CliRunner()
    full = tmp_path / "full.h5"
    r = runner.invoke(main, ["sweep", str(scene), "-o", str(full), "--no-progress"])
    assert r.exit_code == 0, r.output
    r = runner.invoke(main, ["info", str(full)])
    assert r.exit_code == 0 and "model linear" in r.output, r.output
    r = runner.invoke(main, ["plot", str(full), "-o", str(tmp_path / "ball.png")])
    assert r.exit_code == 0 and os.path.getsize(tmp_path / "ball.png") > 10_000, r.output
    monkeypatch.setattr(engine, "BLOCK_BYTES", 2 * 3 * engine.item_bytes(config.load(scene)))
    calls = {"n": 0}
    real = sweep_mod.io.write_block

    def flaky(f, index, block):
        calls["n"] += 1
        if calls["n"] == 2:
            raise KeyboardInterrupt
        real(f, index, block)

    monkeypatch.setattr(sweep_mod.io, "write_block", flaky)
    part = tmp_path / "part.h5"
    r = runner.invoke(main, ["sweep", str(scene), "-o", str(part), "--no-progress"])
    assert r.exit_code == 130, r.output
    monkeypatch.setattr(sweep_mod.io, "write_block", real)
    r = runner.invoke(main, ["sweep", str(scene), "-o", str(part), "--no-progress", "--resume"])
    assert r.exit_code == 0, r.output
    with h5py.File(full) as f, h5py.File(part) as g:
        names = []
        f.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        assert "impacts/u" in names and "impacts/contact" in names and "initial/v_x" in names
        for n in names:
            a, b = f[n][...], g[n][...]
            assert np.array_equal(a, b, equal_nan=a.dtype.kind == "f"), n
        assert f["period"][...].max() >= 1


def test_the_control_slot_is_the_kernels():
    from cornerbif.models.linear import batch
    assert registry.get("linear").control_slot == batch.I_CONTROL


def _two_stop_flight(x0, v0, t0, s, W, zeta=0.02, F=0.7):
    """x'' + 2 zeta x' + x = F cos(W t) from (x0, v0) at t0, a time s later: the damped
    homogeneous part and the harmonic particular solution X cos(W t - psi), written here."""
    X, psi = F / math.hypot(1 - W * W, 2 * zeta * W), math.atan2(2 * zeta * W, 1 - W * W)
    wd = math.sqrt(1 - zeta * zeta)
    A = x0 - X * math.cos(W * t0 - psi)
    B = (v0 + X * W * math.sin(W * t0 - psi) + zeta * A) / wd
    e, c, sn = math.exp(-zeta * s), math.cos(wd * s), math.sin(wd * s)
    x = e * (A * c + B * sn) + X * math.cos(W * (t0 + s) - psi)
    v = e * (-zeta * (A * c + B * sn) - A * wd * sn + B * wd * c) - X * W * math.sin(W * (t0 + s) - psi)
    return x, v


@pytest.mark.parametrize("W", [1.3, 1.6, 2.0, 2.3])
def test_the_two_stop_oscillators_symmetric_motion_is_the_shooting_solution(W):
    """configs/two_stops.toml: the symmetric motion LR (x(t + pi / W) = -x(t)) is, by its
    symmetry, an impact at x = 1 at t0 with incoming speed v, the rebound -r v, and a free
    flight of half a forcing period to x = -1 arriving with speed v: two equations in (t0, v),
    solved here by scipy's fsolve on the closed-form flight above from a grid of guesses.
    The sweep's LR runs have that speed and time (mod the period) to 1e-9."""
    from scipy.optimize import fsolve
    table = tomllib.loads(open(os.path.join(ROOT, "configs", "two_stops.toml")).read())["system"]
    rng = np.random.default_rng(2)
    res = cornerbif.simulate(rng.uniform(-0.9, 0.9, 32), rng.uniform(-2, 2, 32), model="linear",
                             table=table, transient=400, record=8, max_periods=2000,
                             **{"forcing.0.Omega": W})
    lr = np.flatnonzero(res["symbols"] == "LR")
    assert lr.size >= 4
    r, P = 0.8, 2 * math.pi / W
    roots = []
    for guess in np.linspace(0.0, P, 24, endpoint=False):
        for v in (0.5, 1.0, 1.5, 2.0):
            z, _, ok, _ = fsolve(lambda z: [a + b for a, b in zip(
                _two_stop_flight(1.0, -r * z[1], z[0], P / 2, W), (1.0, z[1]))],
                [guess, v], full_output=True, xtol=1e-14)
            if ok == 1 and z[1] > 0:
                roots.append((z[0] % P, z[1]))
    for i in lr:
        k = np.flatnonzero(res["contact"][i] == 1)          # impacts on R (x = 1)
        t_R, v_R = res["t"][i, k], -res["v_in"][i, k]       # a . v = -v on R
        assert np.allclose(res["u"][i, k], -1.0, atol=1e-9)  # u = a . x = -1 there
        near = min(roots, key=lambda z: min(abs(z[0] - t_R[0] % P), P - abs(z[0] - t_R[0] % P)))
        dt = abs(near[0] - t_R[0] % P)
        assert min(dt, P - dt) < 1e-9 and np.allclose(v_R, near[1], atol=1e-9), (near, t_R, v_R)


@pytest.mark.parametrize("W", [1.3, 1.45, 1.6])
def test_the_impact_dampers_symmetric_motion_is_the_shooting_solution(W):
    """configs/impact_damper.toml: the symmetric motion LR of Masri and Caughey (1966), two
    impacts per period on alternate walls, is x(t + pi/W) = -x(t), y(t + pi/W) = -y(t).  Just
    before an impact on R (y = x + 1/2) the state is (t0, x0, x', y'); the generalised Newton
    law with masses M = 1, m = 0.1 (momentum kept, relative velocity reversed with r = 0.6,
    written out here), then half a period of flight (the primary's closed form above, the ball
    in a straight line) must give the mirrored state: four equations, solved by fsolve.  The
    sweep's LR runs have that state just after each R impact, to 1e-9."""
    from scipy.optimize import fsolve
    table = tomllib.loads(open(os.path.join(ROOT, "configs", "impact_damper.toml")).read())["system"]
    M, m, r, d = 1.0, 0.1, 0.6, 0.5
    rng = np.random.default_rng(4)
    n = 16
    res = cornerbif.simulate(model="linear", table=table, x0=rng.uniform(-0.2, 0.2, n),
                             y0=rng.uniform(-0.2, 0.2, n), v_x0=rng.uniform(-0.5, 0.5, n),
                             v_y0=rng.uniform(-0.5, 0.5, n), transient=400, record=8,
                             **{"forcing.0.Omega": W})
    lr = np.flatnonzero(res["symbols"] == "LR")
    assert lr.size >= 4
    P = 2 * math.pi / W

    def after_R(x0, vx, vy):
        w = vx - vy                                   # a . v with a = (1, -1): w < 0
        k = (1 + r) * w / (1 / M + 1 / m)
        return vx - k / M, vy + k / m

    def residual(z):
        t0, x0, vx, vy = z
        ux, uy = after_R(x0, vx, vy)
        x1, vx1 = _two_stop_flight(x0, ux, t0, P / 2, W, zeta=0.05, F=0.3)
        y1 = x0 + d + uy * P / 2
        return [x1 + x0, vx1 + vx, uy + vy, y1 + (x0 + d)]

    for i in lr:
        k = int(np.flatnonzero(res["contact"][i] == 0)[-1])        # the last impact on R
        t, x, ux, uy = res["t"][i, k], res["x_x"][i, k], res["v_x"][i, k], res["v_y"][i, k]
        w = (ux - uy) / -r                                           # back to before the impact
        guess = [t % P + 1e-3, x + 1e-3, ux - 0.01, uy + 0.01]
        with warnings.catch_warnings():       # fsolve says when rounding stops its progress
            warnings.simplefilter("ignore", RuntimeWarning)
            z = fsolve(residual, guess, xtol=1e-14)
        assert np.max(np.abs(residual(z))) < 1e-12, z           # solved (to rounding)
        sx, sy = after_R(z[1], z[2], z[3])
        dt = abs(z[0] % P - t % P)
        assert min(dt, P - dt) < 1e-9 and abs(z[1] - x) < 1e-9, (z, t, x)
        assert abs(sx - ux) < 1e-9 and abs(sy - uy) < 1e-9 and abs(z[2] - z[3] - w) < 1e-9


def test_starts_not_finite_or_past_the_escape_bound_end_with_their_status():
    """A start that is not a number ends at once (NONFINITE), one past ``run.escape`` (or
    infinite) as ESCAPED, as the flow model's do; none of them runs on (a NaN start once
    looped for ever: no time comparison with NaN ends a loop)."""
    from cornerbif import status as S
    r = cornerbif.simulate(model="linear", table=_ball_table(),
                           x0=np.array([np.nan, 0.1, 1e300, 0.1]),
                           v_x0=np.array([0.0, np.inf, 0.0, 0.0]), record=4, escape=1e6)
    assert list(r["status"][:3]) == [S.NONFINITE, S.ESCAPED, S.ESCAPED]
    assert r["status"][3] == S.OK and np.isfinite(r["t"][3]).all()     # a start that runs
    assert np.isnan(r["t"][:3]).all()


TWO_MASSES = """
[scene]
name = "two_masses"
model = "linear"
[system]
dofs = ["x", "y"]
mass = [[1.0, 0.0], [0.0, 1.0]]
stiffness = [[2.0, -0.5], [-0.5, 1.0]]
forcing = [{ on = "x", F = 0.4, Omega = 1.3 }]
[[system.contact]]
name = "S"
gap = { x = -1.0 }
kappa = -1.0
r = 0.7
"""


def test_a_swept_matrix_entry_is_the_system_with_that_entry():
    """Sweeping "stiffness.x.y" runs the system whose K has that entry and its mirror (the
    review found the mirror path's old value written back over it: every value ran alike)."""
    table = tomllib.loads(TWO_MASSES)["system"]
    swept = cornerbif.simulate(model="linear", table=table, x0=0.5, y0=0.0, v_x0=0.0, v_y0=0.0,
                               transient=0, record=10, **{"stiffness.x.y": np.array([-0.5, -0.2])})
    direct = dict(table, stiffness=[[2.0, -0.2], [-0.2, 1.0]])
    one = cornerbif.simulate(model="linear", table=direct, x0=0.5, y0=0.0, v_x0=0.0, v_y0=0.0,
                             transient=0, record=10)
    assert not np.allclose(swept["t"][0], swept["t"][1])
    np.testing.assert_array_equal(swept["t"][1], one["t"][0])
    with pytest.raises(SceneError) as e:
        config.loads(TWO_MASSES + '[sweep]\n"stiffness.x.y" = { values = [-0.5, -0.2] }\n'
                     '"stiffness.y.x" = { values = [-0.5, -0.3] }\n')
    assert "mirror" in str(e.value)


def test_a_forcing_swept_through_zero_frequency_runs_both_sides():
    """Omega = 0 is a constant force, Omega > 0 a harmonic one: their augmented states differ
    in size, and the points of each run in a call of their own."""
    table = tomllib.loads(TWO_MASSES)["system"]
    r = cornerbif.simulate(model="linear", table=table, x0=0.9, y0=0.0, v_x0=1.0, v_y0=0.0,
                           transient=0, record=6, **{"forcing.0.Omega": np.array([1.3, 0.0])})
    alone = cornerbif.simulate(model="linear", table=table, x0=0.9, y0=0.0, v_x0=1.0, v_y0=0.0,
                               transient=0, record=6, **{"forcing.0.Omega": 0.0})
    assert np.isfinite(r["t"]).all()
    np.testing.assert_array_equal(r["t"][1], alone["t"][0])
    assert not np.allclose(r["t"][0], r["t"][1])
    config.loads(TWO_MASSES + '[sweep]\n"forcing.0.Omega" = { values = [0.0, 1.3] }\n')


def test_combinations_of_matrix_entries_are_checked_before_the_run():
    """Entries of M each allowed whose combination is not positive-definite are refused by
    validation (the review's 101 x 101 sweep passed validate and failed mid-sweep), in a
    simulate() array too, naming the element; past MAX_CHECKED_COMBINATIONS they are refused."""
    from cornerbif.models.linear.model import MAX_CHECKED_COMBINATIONS
    grid = '[sweep]\n"mass.x.x" = { start = 0.5, stop = 1.5, num = 101 }\n' \
           '"mass.x.y" = { start = -0.9, stop = 0.9, num = 101 }\n'
    with pytest.raises(SceneError) as e:
        config.loads(TWO_MASSES + grid)
    assert "system.mass" in str(e.value) and "sweep.mass.x.x" in str(e.value), str(e.value)
    big = grid.replace("num = 101", "num = 151")
    with pytest.raises(SceneError) as e:
        config.loads(TWO_MASSES + big)
    assert f"at most {MAX_CHECKED_COMBINATIONS}" in str(e.value)
    with pytest.raises(SceneError) as e:
        cornerbif.simulate(model="linear", table=tomllib.loads(TWO_MASSES)["system"], x0=0.5,
                           y0=0.0, v_x0=0.0, v_y0=0.0, **{"mass.x.x": np.array([1.0, 0.5]),
                                                          "mass.x.y": np.array([0.2, 0.9])})
    assert "system.mass" in str(e.value) and "element 1" in str(e.value), str(e.value)


def test_a_bad_system_is_the_only_problem_said():
    """Once the system is refused, its axes and starts are not judged against a model with
    none (the review saw "not a parameter" and "unknown key" beside the real problem)."""
    text = BALL.replace("r = 0.5", "r = 1.5") + '[sweep]\n"contact.T.beta" = { values = [0.03] }\n' \
        '[initial]\nx = [0.1, 0.2]\n'
    with pytest.raises(SceneError) as e:
        config.loads(text)
    assert len(e.value.problems) == 1 and "1.5" in e.value.problems[0], e.value.problems


def test_set_reaches_an_entry_of_a_list_of_tables():
    s = config.loads(BALL, ["system.forcing.0.F=-2.0", "system.contact.0.r=0.25"])
    assert s.system["forcing.0.F"] == -2.0 and s.system["contact.T.r"] == 0.25


def test_the_figures_read_its_words_and_heights(tmp_path):
    """The plots' reader keeps the contacts' letters as words (it kept only the corner
    clusters' a, b, g, x), and impact_height is each impact's height above its own
    contact's kappa (0 on a fixed stop); info names the scene's coordinates."""
    from cornerbif.plot_data import PlotData
    scene = tmp_path / "two.toml"
    scene.write_text(open(os.path.join(ROOT, "configs", "two_stops.toml")).read())
    out = tmp_path / "two.h5"
    r = CliRunner().invoke(main, ["sweep", str(scene), "-o", str(out), "--no-progress",
                                  "--set", 'sweep."forcing.0.Omega".num=3',
                                  "--set", 'sweep."forcing.0.Omega".start=1.5',
                                  "--set", "initial.count=4"])
    assert r.exit_code == 0, r.output
    d = PlotData(str(out))
    assert "LR" in set(d.symbols.ravel())
    h = d.y("impact_height")
    assert np.nanmax(np.abs(h)) < 1e-9 and np.isfinite(h).any()
    assert d.spec.coords == ("x", "v_x")
    r = CliRunner().invoke(main, ["info", str(out)])
    assert "state x, v_x" in r.output, r.output



@pytest.mark.parametrize("key, needle", [
    ("system.contact.5.r=0.5", "picks none"),
    ("system.contact.\u00b2.r=0.5", "picks none"),        # a superscript digit is no index
    ("system.contact.X.r=0.5", "a name: T"),
])
def test_set_into_a_list_picks_an_entry_or_is_refused(key, needle):
    with pytest.raises(SceneError) as e:
        config.loads(BALL, [key])
    assert needle in str(e.value), str(e.value)
    s = config.loads(BALL, ["system.contact.T.r=0.25"])          # by the contact's name
    assert s.system["contact.T.r"] == 0.25
    listed = BALL.replace("gap = { x = 1.0 }", "gap = [1.0]")
    with pytest.raises(SceneError) as e:                            # a name inside a list of numbers
        config.loads(listed, ["system.contact.0.gap.x=2.0"])
    assert "picks none" in str(e.value)


def test_simulate_refuses_a_matrix_entry_and_its_mirror_given_together():
    with pytest.raises(SceneError) as e:
        cornerbif.simulate(model="linear", table=tomllib.loads(TWO_MASSES)["system"], x0=0.5,
                           y0=0.0, v_x0=0.0, v_y0=0.0, **{"stiffness.x.y": 0.1, "stiffness.y.x": 0.3})
    assert "mirror" in str(e.value) or "given together" in str(e.value)


def test_impact_height_follows_a_swept_contact_kappa(tmp_path):
    """u - kappa of each impact's contact, at each grid point where the sweep moves it: the
    two stops moved together keep their impacts at height 0 above their own stop."""
    from cornerbif.plot_data import PlotData
    text = open(os.path.join(ROOT, "configs", "two_stops.toml")).read()
    scene = tmp_path / "two.toml"
    scene.write_text(text.replace('"forcing.0.Omega" = { start = 0.4, stop = 3.0, num = 261 }',
                                  '"contact.L.kappa" = { values = [-1.0, -0.8] }'))
    out = tmp_path / "two.h5"
    r = CliRunner().invoke(main, ["sweep", str(scene), "-o", str(out), "--no-progress",
                                  "--set", "initial.count=3",
                                  "--set", "system.forcing.0.Omega=1.5"])
    assert r.exit_code == 0, r.output
    d = PlotData(str(out))
    u, h = d.y("impact_u"), d.y("impact_height")
    c = h5py.File(out)["impacts/contact"][...]
    on_L = c == 0
    assert on_L[1].any() and np.allclose(u[1][on_L[1]], -0.8, atol=1e-9)
    assert np.nanmax(np.abs(h)) < 1e-9
    assert np.isnan(d.y("winding")).all()          # contact words have no winding number


def test_a_flow_files_words_keep_the_corner_letters(tmp_path):
    """The plots' reader takes any letter as a word only for a linear model's file; a flow
    file's word with another letter (a crafted file) still reads as no word."""
    from cornerbif.plot_base import SYMBOL_LETTERS, WORD_LETTERS, symbol_words
    sym = np.array([b"ab", b"aZ", b"L\\x01"], dtype="S4")
    assert list(symbol_words(sym, WORD_LETTERS)) == ["ab", "", ""]
    assert list(symbol_words(sym, SYMBOL_LETTERS)) == ["ab", "aZ", ""]


def test_a_system_that_is_no_table_is_one_problem_and_set_by_index_is_tagged():
    """``--set system=3`` on a linear scene is one problem (its keys were each said missing
    besides, a cascade); a problem of a value set by a list index (system.contact.0.r) says
    that --set caused it, though the problem names the contact by its name (L)."""
    with pytest.raises(SceneError) as e:
        config.loads(BALL, ["system=3"])
    assert e.value.problems == ["system: 3 must be a table [system] (from --set system=3)"]
    text = open(os.path.join(ROOT, "configs", "two_stops.toml")).read()
    with pytest.raises(SceneError) as e:
        config.loads(text, ["system.contact.0.r=1.5"])
    (p,) = e.value.problems
    assert p.startswith("system.contact.L.r: 1.5") and p.endswith(
        "(from --set system.contact.0.r=1.5)"), p
