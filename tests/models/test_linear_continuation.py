"""Continuation of the ``linear`` model's periodic orbits (docs/linear.md, "Continuation";
``cornerbif/models/linear/orbit.py``).

Each expected number comes from outside the orbit problem:

- ``configs/cont_beta.toml`` continued by the ``flow`` model (its own orbit problem, its
  closed-form oscillator: ``models/flow/orbit.py``) and eq (11)'s kappa_C
  (``theory.kappa_C``), against ``configs/cont_beta_linear.toml``, the same system written
  as a linear scene;
- the closed-form Jacobian against ``continuation.central_jacobian`` (finite differences of
  the residual);
- the bouncing ball's period doubling at the closed-form amplitude (derived below);
- the multipliers against the stability pass (``simulate(..., keep=["stability"])``,
  tangent.py: the kernel's flights and its saltation matrices);
- refusals naming the key.
"""

import math
import os
import tomllib

import numpy as np
import pytest
from click.testing import CliRunner

import cornerbif
from cornerbif import config, continuation_run, theory
from cornerbif.cli import main
from cornerbif.config import SceneError
from cornerbif.continuation import central_jacobian, newton
from cornerbif.models.linear import declare
from cornerbif.models.linear.events import ContactObstacle
from cornerbif.models.linear.orbit import LinearOrbit
from cornerbif.models.linear.simulate import simulate as numpy_run

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _quiet(*_):
    pass


def _scene(name, *sets):
    return config.load(os.path.join(ROOT, "configs", name), sets)


def _paired(a, b):
    """The largest distance between two sets of multipliers, each matched to its nearest."""
    a, b = np.asarray(a, complex), np.asarray(b, complex)
    return max(np.abs(b - x).min() for x in a)


@pytest.fixture(scope="module")
def beta_runs():
    """cont_beta continued by the flow model and, as a linear scene, by the linear model."""
    return (continuation_run.run_scene(_scene("cont_beta.toml"), log=_quiet),
            continuation_run.run_scene(_scene("cont_beta_linear.toml"), log=_quiet))


def test_cont_beta_as_a_linear_scene_ends_where_the_flows_does(beta_runs):
    """The beta orbit at omega = 1.999 continued in kappa ("contact.R.kappa") has the flow's
    events: the range's end at -0.02 and the corner collision of its impact, at the flow's
    located kappa to 1e-8 (measured 3.6e-15) and at eq (11)'s kappa_C to 1e-8."""
    flow, lin = beta_runs
    assert len(flow.branches) == len(lin.branches) == 1
    fe = [(e.kind, e.lam) for e in flow.branches[0].events]
    le = [(e.kind, e.lam) for e in lin.branches[0].events]
    assert [k for k, _ in fe] == [k for k, _ in le] == ["end", "corner"], (fe, le)
    for (_, a), (_, b) in zip(fe, le):
        assert abs(a - b) <= 1e-8, (a, b)
    kc = theory.kappa_C(1.999, 0.8)
    assert abs(le[1][1] - kc) <= 1e-8, (le[1][1], kc)
    assert lin.branches[0].word == flow.branches[0].word == "b"


def test_cont_beta_as_a_linear_scene_has_the_flows_orbits(beta_runs):
    """At every point of the flow's branch, the linear orbit solved at the same kappa (Newton
    from the linear branch's nearest point) has the flow's impact (time modulo the period
    pi/omega, height, velocities) to 1e-8 (measured 1e-13) and its multipliers to 1e-8."""
    flow, lin = beta_runs
    lpts = lin.branches[0].points
    lams = np.array([p.lam for p in lpts])
    T = math.pi / 1.999
    worst = 0.0
    for fp in flow.branches[0].points:
        near = lpts[int(np.argmin(np.abs(lams - fp.lam)))]
        prob = near.problem
        X = newton(prob, near.X, fp.lam)
        a = fp.problem.impacts(fp.X, fp.lam)
        b = prob.impacts(X, fp.lam)
        dt = (b["t"][0] - a["t"][0] + T / 2) % T - T / 2
        worst = max(worst, abs(dt), *(abs(b[k][0] - a[k][0]) for k in ("u", "v_in", "v_out")))
        worst = max(worst, _paired(prob.floquet(X, fp.lam)[0], fp.mu))
    assert worst <= 1e-8, worst


def test_cont_beta_linear_runs_from_the_command_line_and_plots(tmp_path):
    """``cornerbif continue configs/cont_beta_linear.toml`` writes its file, and ``cornerbif
    plot`` draws it."""
    out = tmp_path / "cb.h5"
    r = CliRunner().invoke(main, ["continue", os.path.join(ROOT, "configs",
                                                            "cont_beta_linear.toml"),
                                  "-o", str(out)])
    assert r.exit_code == 0, r.output
    res = continuation_run.read(str(out))
    assert [e["kind"] for e in res["events"]] == ["end", "corner"]
    fig = tmp_path / "cb.png"
    r = CliRunner().invoke(main, ["plot", str(out), "-o", str(fig)])
    assert r.exit_code == 0 and fig.stat().st_size > 0, r.output


def test_the_corner_collision_continued_in_omega_is_eq_11():
    """cont_beta_linear's corner collision continued in a second parameter ([continue] curve
    = "contact.R.omega" over [1.98, 2.02]; ``continuation.EventCurve``: the orbit's equations
    and the impact's corner distance = 0) lies on eq (11)'s kappa_C(omega) (``theory.kappa_C``)
    to 1e-10 over the whole range (measured 7.6e-15)."""
    text = open(os.path.join(ROOT, "configs", "cont_beta_linear.toml")).read()
    text = text.replace('seed = "b"', 'seed = "b"\ncurve = "contact.R.omega"\n'
                        'curve_range = [1.98, 2.02]')
    res = continuation_run.run_scene(config.loads(text), log=_quiet)
    assert len(res.curves) == 1
    _, _, _, om, ka, *_ = res.curves[0]
    assert min(om) == 1.98 and max(om) == 2.02, (min(om), max(om))
    err = max(abs(k - theory.kappa_C(w, 0.8)) for w, k in zip(om, ka))
    assert err <= 1e-10, err


SWEEP = """
[scene]
name = "beta_sweep"
model = "linear"

[system]
dofs = ["x"]
mass = [1.0]
stiffness = [1.0]

[[system.contact]]
name = "R"
gap = { x = 1.0 }
obstacle = "rectified_sine"
kappa = -0.02
beta = 1.0
omega = 1.999
r = 0.8

[initial]
count = 4
seed = 1
x = [0.0, 20.0]
v_x = [-0.02, 0.02]

[run]
transient = 1500
record = 60
"""


def test_a_sweep_file_seeds_a_linear_continuation(tmp_path, beta_runs):
    """``[continue] seed_file``: a sweep of the same [system] table over contact.R.kappa
    seeds the beta orbit, whose corner collision is cont_beta_linear's (1e-12); a sweep of
    another table (r = 0.7) is refused, saying so."""
    sweep = tmp_path / "sweep.toml"
    sweep.write_text(SWEEP + '[sweep]\n"contact.R.kappa" = { start = -0.02, stop = -0.019, '
                             'num = 3 }\n')
    h5 = tmp_path / "sweep.h5"
    r = CliRunner().invoke(main, ["sweep", str(sweep), "-o", str(h5), "--no-progress"])
    assert r.exit_code == 0, r.output
    cont = ('[continue]\nparameter = "contact.R.kappa"\nrange = [-0.02, 0.002]\n'
            f'start = -0.02\nseed_file = "{h5}"\n')
    res = continuation_run.run_scene(config.loads(SWEEP + cont), log=_quiet)
    corner = [e.lam for b in res.branches for e in b.events if e.kind == "corner"]
    want = [e.lam for e in beta_runs[1].branches[0].events if e.kind == "corner"]
    assert len(corner) == 1 and abs(corner[0] - want[0]) <= 1e-12, (corner, want)
    with pytest.raises(Exception, match="another \\[system\\] table"):
        continuation_run.run_scene(config.loads(SWEEP.replace("r = 0.8", "r = 0.7") + cont),
                                   log=_quiet)


def test_fig19_as_a_linear_scene_ends_where_the_two_particle_models_orbit_does():
    """Fig. 19's two particles written as a linear scene (configs/fig19a_linear.toml without
    its [system] words, whose orbits are not continued: contacts W, the wall on z, and U, the
    pair on q - z): the period-one orbit (one W and one U impact per wall period) continued
    down in contact.W.omega ends where the U impact meets the W impact (two impacts on
    different contacts meeting: the swap across it has no admissible orbit), at the
    two-particle model's own omega0_C (its orbit problem, laws (5) and (74):
    ``TwoParticleOrbit``, continued here) to 1e-9 (measured 4.4e-16)."""
    from cornerbif import continuation as C
    from cornerbif.models.two_particle import orbit as TO
    from cornerbif.models.two_particle import packed as TPM
    vals = {k: p.default for k, p in TPM.PARAMS.items()} | {"omega0": 2.0}
    x0 = [0.18982259867467574, 16.49606490380678, 1.7221809107866082, 149.66189899401783]
    prob, X = TO.two_particle_seed(vals, "omega0", x0, 1)
    peer = C.follow(prob, X, 2.0, (1.9995, 2.002), -1, ds=1e-4)[0].events[-1]
    assert peer.kind == "corner"
    raw = tomllib.loads(open(os.path.join(ROOT, "configs", "fig19a_linear.toml")).read())
    raw["system"].pop("words")
    raw.pop("sweep")
    raw.pop("plot", None)
    raw["system"]["contact"][0]["omega"] = 2.0
    raw["continue"] = {"parameter": "contact.W.omega", "range": [1.9995, 2.0005],
                       "start": 2.0}
    res = continuation_run.run_scene(config.loads(config.dumps(raw)), log=_quiet)
    ends = [e for b in res.branches for e in b.events if e.kind == "corner"]
    assert len(ends) == 1 and "no admissible orbit" in ends[0].detail, ends
    assert abs(ends[0].lam - peer.lam) <= 1e-9, (ends[0].lam, peer.lam)


# ---------------------------------------------------------------- the Jacobian
def _damper(omega=1.45, word="LR"):
    """The impact damper's (configs/impact_damper.toml) orbit of ``word`` at Omega, seeded
    from the first of six runs of the kernel that reaches it (its last cycle;
    ``Model.orbit_seed``): (problem, X, Omega, the start)."""
    scene = _scene("impact_damper.toml")
    values = {k: v for k, v in scene.system.items() if v is not None}
    values["forcing.0.Omega"] = omega
    rng = np.random.default_rng(2)
    starts = {"x0": rng.uniform(-0.2, 0.2, 6), "y0": rng.uniform(-0.2, 0.2, 6),
              "v_x0": rng.uniform(-0.5, 0.5, 6), "v_y0": rng.uniform(-0.5, 0.5, 6)}
    res = cornerbif.simulate(model="linear", table=scene.spec.system_table, transient=400,
                             record=40, **starts, **{"forcing.0.Omega": omega})
    i = list(res["symbols"]).index(word)
    run = {k: np.asarray(v)[i] for k, v in res.items()}
    run["ipc"] = int(run["impacts_per_cycle"])
    prob, X = scene.spec.orbit_seed(values, scene, "forcing.0.Omega", word, run)
    return prob, X, omega, {k: float(v[i]) for k, v in starts.items()}


COUPLED = {
    # three coordinates, a full M, a damping with a gyroscopic part, a harmonic force, a
    # gap along (1, -0.5, 0.3) against a sine (period 2 pi / 2.1) and a fixed stop: every
    # term of the law and the saltation (tests/models/test_linear_stability.py's system,
    # with Omega = 1.4 so that the system has a period, 2 pi / 0.7)
    "dofs": ["a", "b", "c"],
    "mass": [[2.0, 0.3, 0.1], [0.3, 1.0, 0.2], [0.1, 0.2, 1.5]],
    "stiffness": [[3.0, -1.0, 0.0], [-1.0, 2.0, -0.5], [0.0, -0.5, 1.0]],
    "damping": [[0.1, 0.3, 0.0], [-0.3, 0.05, 0.1], [0.0, -0.1, 0.08]],
    "forcing": [{"on": "b", "F": 0.8, "Omega": 1.4, "phi": 0.4}],
    "contact": [{"name": "S", "gap": {"a": 1.0, "b": -0.5, "c": 0.3}, "obstacle": "sine",
                 "kappa": -0.6, "beta": 0.2, "omega": 2.1, "r": 0.7},
                {"name": "F", "gap": {"b": -1.0}, "kappa": -0.8, "r": 0.9},
                {"name": "Q", "gap": {"c": 1.0}, "obstacle": "rectified_sine",
                 "kappa": -0.25, "beta": 0.1, "omega": 0.7, "r": 0.5}],
}


def _rel(J, F):
    return np.abs(J - F).max() / np.abs(F).max()


def test_the_jacobian_is_the_finite_difference_one():
    """The closed-form dR/dX equals central differences of the residual
    (``continuation.central_jacobian``) to 1e-6 of its largest entry: on the impact damper's
    orbits (2 dofs): LR at Omega = 1.45 and LLR at Omega = 1.2 (three impacts per cycle, two
    on one wall), each at the orbit and off it (X moved by 1e-3); the beta orbit of
    cont_beta_linear (a rectified sine, its impact on a fixed piece); and a chain of six
    impacts of the coupled three-coordinate system (three contacts: a sine, a fixed stop and
    a rectified sine; the impacts of a numpy run, Q S Q S Q F, not an orbit: the residual is
    not 0 there).  Measured: at most 1.3e-9 (damper), 6.7e-9 (beta), 1.9e-9 (coupled)."""
    worst = []
    rng = np.random.default_rng(1)
    for omega, word in ((1.45, "LR"), (1.2, "LLR")):
        prob, X, lam, _ = _damper(omega, word)
        assert len(prob.contacts) == len(word)
        for Y in (X, X + 1e-3 * rng.standard_normal(len(X))):
            worst.append(_rel(prob.jacobian(Y, lam), central_jacobian(prob.residual, Y, lam)))
    scene = _scene("cont_beta_linear.toml")
    state = continuation_run._seeds(scene, _quiet, None)
    seed = state["seeds"][0]
    prob = continuation_run._problem_from(seed["problem"])
    X = np.array(seed["X"])
    assert all(j >= 0 for j in prob.pieces)
    worst.append(_rel(prob.jacobian(X, -0.02), central_jacobian(prob.residual, X, -0.02)))
    system, bad = declare.read_system(COUPLED)
    assert not bad, bad
    imp, why = numpy_run(system, [0.4, 0.2, -0.1], [0.5, -0.3, 0.2], 0.0, 12)
    assert len(imp) == 12, why
    chain = imp[4:10]
    names = [c.name for c in system.contacts]
    assert {i.contact for i in chain} == set(names), [i.contact for i in chain]
    T = 2 * math.pi / 0.7
    m = int(math.ceil((chain[-1].t - chain[0].t) / T)) + 1
    pieces = []
    for i in chain:
        c = system.contacts[names.index(i.contact)]
        if c.obstacle == "rectified_sine":       # the piece its impact lies on
            pieces.append(int(ContactObstacle(c.obstacle, c.kappa, c.beta, c.omega)
                              .piece_at(i.t)[0]))
        else:
            pieces.append(-1)
    prob = LinearOrbit(COUPLED, declare.numeric_paths(COUPLED), "forcing.0.F",
                       tuple(names.index(i.contact) for i in chain), tuple(pieces), m)
    X = np.concatenate([np.concatenate([[i.t], i.x, i.v_out]) for i in chain])
    worst.append(_rel(prob.jacobian(X, 0.8), central_jacobian(prob.residual, X, 0.8)))
    assert max(worst) <= 1e-6, worst


# ---------------------------------------------------------------- the bouncing ball
BALL = """
[scene]
name = "ball_continued"
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

[initial]
count = 16
seed = 1
x = [0.2, 0.5]
v_x = [-0.5, 0.5]

[run]
transient = 300
record = 12

[continue]
parameter = "contact.T.beta"
range = [0.031, 0.05]
start = 0.036
"""


def test_the_bouncing_balls_period_doubling_is_the_closed_form():
    """The ball (g = 1, omega = 6, r = 0.5: configs/bouncing_ball.toml) on z = beta sin(omega
    t): its period-one orbit leaves the table with v+ = g T / 2 and meets it a table period
    T = 2 pi / omega later with v- = -g T / 2, so z'(t*) = g T (1 - r) / (2 (1 + r)), i.e.
    Gamma cos(omega t*) = pi (1 - r) / (1 + r), Gamma = beta omega^2 / g.  Its impact map's
    Jacobian has det r^2 and trace 1 + r^2 + (1 + r)^2 z''(t*) / g
    (tests/models/test_linear_model.py derives it), so a multiplier -1 (1 + tr + det = 0)
    where Gamma sin(omega t*) = 2 (1 + r^2) / (1 + r)^2: Gamma_PD = hypot(pi (1 - r) / (1 + r),
    2 (1 + r^2) / (1 + r)^2) = 1.5268, beta_PD = Gamma_PD g / omega^2.  The continued orbit
    (contact.T.beta over [0.031, 0.05]) has its one period doubling there to 1e-6
    (measured 1e-13 relative), with a multiplier -1 at it (1e-6)."""
    R, W = 0.5, 6.0
    beta_pd = math.hypot(math.pi * (1 - R) / (1 + R), 2 * (1 + R * R) / (1 + R) ** 2) / W ** 2
    res = continuation_run.run_scene(config.loads(BALL), log=_quiet)
    pd = [e for b in res.branches for e in b.events if e.kind == "period_doubling"]
    assert len(pd) == 1, [(e.kind, e.lam) for b in res.branches for e in b.events]
    assert abs(pd[0].lam - beta_pd) <= 1e-6 * beta_pd, (pd[0].lam, beta_pd)
    mu = pd[0].problem.floquet(pd[0].X, pd[0].lam)[0]
    assert np.abs(mu + 1.0).min() <= 1e-6, mu
    assert res.branches[0].word == "T"


# ---------------------------------------------------------------- the multipliers
def test_the_multipliers_are_the_stability_passs():
    """At a point of a branch, the continued orbit's multipliers equal those of the
    stability pass (``simulate(..., keep=["stability"])``: the kernel's flights and
    tangent.py's saltations over the run's last recorded cycle) to 1e-9: the impact
    damper's LR at Omega = 1.45 and LLR at 1.2 (four multipliers; measured 1.1e-12 and
    2.4e-12) and the beta orbit of cont_beta_linear at kappa = -0.02 (two; 1.2e-15)."""
    for omega, word in ((1.45, "LR"), (1.2, "LLR")):
        prob, X, lam, start = _damper(omega, word)
        res = cornerbif.simulate(model="linear", table=prob.table, **start, transient=400,
                                 record=40, keep=["stability"], **{"forcing.0.Omega": lam})
        mu = np.asarray(res["mu_re"])[0] + 1j * np.asarray(res["mu_im"])[0]
        got = prob.floquet(X, lam)[0]
        assert len(got) == 4 and _paired(got, mu) <= 1e-9, (word, got, mu)
    scene = _scene("cont_beta_linear.toml")
    state = continuation_run._seeds(scene, _quiet, None)
    seed = state["seeds"][0]
    prob = continuation_run._problem_from(seed["problem"])
    X = np.array(seed["X"])
    res = cornerbif.simulate(model="linear", table=prob.table, x0=1.0, v_x0=0.01,
                             transient=1500, record=20, keep=["stability"],
                             **{"contact.R.kappa": -0.02})
    assert res["symbols"][0] == "b", res["symbols"]
    mu = np.asarray(res["mu_re"])[0] + 1j * np.asarray(res["mu_im"])[0]
    got = prob.floquet(X, -0.02)[0]
    assert _paired(got, mu) <= 1e-9, (got, mu)


# ---------------------------------------------------------------- refusals
def _with_continue(name, parameter, lo, hi):
    raw = tomllib.loads(open(os.path.join(ROOT, "configs", name)).read())
    raw.pop("sweep", None)
    if name == "two_stops.toml":      # made autonomous: a constant force, fixed stops
        raw["system"]["forcing"] = [{"on": "x", "F": 0.1}]
    raw["continue"] = {"parameter": parameter, "range": [lo, hi], "start": lo}
    return config.dumps(raw)


@pytest.mark.parametrize("name, parameter, lo, hi, key", [
    ("soft_stop.toml", "forcing.0.Omega", 0.8, 1.2, "system.contact.S.law: 'spring'"),
    ("fig19a_linear.toml", "contact.W.omega", 1.99, 2.01, "system.words: "),
    ("two_stops.toml", "contact.L.kappa", -1.1, -0.9, "system: no period T"),
])
def test_scenes_whose_orbits_are_not_continued_are_refused_naming_the_key(name, parameter, lo,
                                                                         hi, key):
    """A soft stop (law "spring"), the two-particle model's words and an autonomous system
    (no period T: its orbit would need a phase condition) are refused when the scene has a
    [continue] table, naming the key; without it the scene is as valid as before."""
    text = _with_continue(name, parameter, lo, hi)
    with pytest.raises(SceneError) as e:
        config.loads(text)
    assert any(key in p for p in e.value.problems), e.value.problems
    raw = tomllib.loads(text)
    raw.pop("continue")
    config.loads(config.dumps(raw))
