"""``[plot] kind = "amplitude"`` (cornerbif/figures/amplitude.py): a coordinate's amplitude
(max − min) / 2 over each run's last recorded cycle, computed exactly between the recorded
impacts, and the structure without some dofs in closed form, |H(Ω) F|.

Checked: the amplitude of a synthetic record (the steady harmonic motion of a system whose
contacts are never reached) against |H(Ω) F| solved in the test; the amplitude of runs of
configs/impact_damper_amplitude.toml against scipy's solve_ivp from the same recorded state
(events at the contacts written here, the Newton law applied here); the reference against
the one-dof closed form; the kind's refusals; ``cornerbif plot`` of a small sweep."""

import math
import os

import h5py
import numpy as np
import pytest
from click.testing import CliRunner
from scipy.integrate import solve_ivp

from cornerbif import config
from cornerbif.cli import main
from cornerbif.figures.amplitude import cycle_extremes, run_amplitudes, without_ball
from cornerbif.models.linear.declare import read_system

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
SCENE = os.path.join(ROOT, "configs", "impact_damper_amplitude.toml")


def _system(table):
    system, bad = read_system(table)
    assert not bad, bad
    return system


COUPLED = {   # two masses coupled by a spring, both damped, forced on x; a cavity never reached
    "dofs": ["x", "y"], "mass": [1.0, 0.5], "stiffness": [[1.5, -0.5], [-0.5, 0.5]],
    "damping": [[0.08, 0.0], [0.0, 0.03]], "forcing": [{"on": "x", "F": 0.3, "Omega": 0.8}],
    "contact": [{"name": "R", "gap": {"x": 1.0, "y": -1.0}, "kappa": -50.0}]}


def _steady(table, Omega, t):
    """The steady harmonic motion x(t) = Re(X e^{iΩt}), X = (K − Ω²M + iΩC)⁻¹ F, solved
    here from the table (and v = x')."""
    M, K, C = (np.array(table[k], float) for k in ("mass", "stiffness", "damping"))
    M = np.diag(M) if M.ndim == 1 else M
    F = np.array([0.3, 0.0])
    X = np.linalg.solve(K - Omega ** 2 * M + 1j * Omega * C, F)
    e = np.exp(1j * Omega * np.asarray(t))[..., None]
    return (X * e).real, (1j * Omega * X * e).real, np.abs(X)


@pytest.mark.parametrize("Omega", [0.5, 0.8, 1.3])
def test_the_amplitude_of_a_steady_harmonic_motion_is_its_closed_form(Omega):
    """A record of three 'impacts' one forcing period apart on the steady harmonic motion
    (a cavity of half-width 50 is never reached): the amplitude over the last flight, one
    whole period, is |X_x| and |X_y| of the complex solve above, and the reference
    ``without_ball(..., without=[])`` is the same number, to 1e-10 (measured 6.2e-15).  The
    phase at t0 is arbitrary (t0 = 0.37): the maximum falls inside a flight, located where v
    vanishes."""
    table = dict(COUPLED, forcing=[{"on": "x", "F": 0.3, "Omega": Omega}])
    system = _system(table)
    T = 2 * math.pi / Omega
    t = 0.37 + T * np.arange(3)
    x, v, amp = _steady(table, Omega, t)
    for i in range(2):
        got = run_amplitudes(system, t[None], x[None], v[None], np.array([1]), i)[0]
        assert abs(got - amp[i]) < 1e-10, (i, got, amp[i])
    ref = without_ball(system, [], 0, "x", [Omega])[0]
    assert abs(ref - amp[0]) < 1e-12


def test_the_reference_without_the_ball_is_the_one_dof_closed_form():
    """configs/impact_damper_amplitude.toml without y: F / sqrt((k − mΩ²)² + (cΩ)²) with
    m = k = 1, c = 0.1, F = 0.3 (its peak, 3.0 near Ω = 1, F / (2ζ) with 2ζ = 0.1)."""
    scene = config.load(SCENE)
    system = _system(scene.spec.system_table)
    w = np.linspace(0.6, 1.6, 101)
    ref = without_ball(system, ["y"], 0, "x", w)
    closed = 0.3 / np.sqrt((1 - w ** 2) ** 2 + (0.1 * w) ** 2)
    assert np.max(np.abs(ref - closed)) < 1e-12
    assert abs(without_ball(system, ["y"], 0, "x", [1.0])[0] - 3.0) < 1e-12


def test_a_flights_extremes_between_samples_are_exact():
    """One flight of x'' + x = 0 from x = cos(0.01), v = sin(0.01) over 3.5, x(s) = cos(s −
    0.01): its maximum 1 is at s = 0.01 and its minimum −1 at s = π + 0.01, neither a
    sample (3 asked, 5 taken: ‖A‖₁ h + 1): each is found where v vanishes, to 1e-14, not
    read from the samples (which miss the maximum by 5e-5)."""
    system = _system({"dofs": ["x"], "mass": [1.0], "stiffness": [1.0],
                      "contact": [{"name": "R", "gap": {"x": -1.0}, "kappa": -5.0}]})
    hi, lo = cycle_extremes(system, [0.0], [[math.cos(0.01)]], [[math.sin(0.01)]], [3.5], 0,
                            samples=3)
    assert abs(hi[0] - 1.0) < 1e-14 and abs(lo[0] + 1.0) < 1e-14


# ------------------------------------------------------------------ against solve_ivp
@pytest.fixture(scope="module")
def small_sweep(tmp_path_factory):
    """configs/impact_damper_amplitude.toml at Ω = 0.93 (cycles LRRLRR / LLRLLR, 6 impacts)
    and 1.1 (LR), 2 starts each."""
    d = tmp_path_factory.mktemp("amplitude")
    out = str(d / "amp.h5")
    r = CliRunner().invoke(main, ["sweep", SCENE, "-o", out, "--set",
                                  'sweep."forcing.0.Omega"={start=0.93, stop=1.1, num=2}',
                                  "--set", "initial.count=2"])
    assert r.exit_code == 0, r.output
    return out


def _brute(system, t0, x0, v0, impacts):
    """The primary's (max, min) over ``impacts`` impacts from the state (x0, v0) just after an
    impact at t0, by scipy's DOP853 (rtol = atol = 1e-12): events at the two cavity walls
    (gap a . x − kappa = 0, approached), the Newton law v+ = v− − (1 + r) w M⁻¹a / (aᵀM⁻¹a)
    applied here, and x's extrema at the events v_x = 0."""
    M, K, C = system.mass, system.stiffness, system.damping
    Minv = np.linalg.inv(M)
    f = system.forcing[0]

    def rhs(t, y):
        force = np.array([f.F * math.cos(f.Omega * t + f.phi), 0.0])
        return np.concatenate([y[2:], Minv @ (force - C @ y[2:] - K @ y[:2])])

    walls = []
    for c in system.contacts:
        def ev(t, y, a=c.gap, k=c.kappa):
            return a @ y[:2] - k
        ev.terminal, ev.direction = True, -1
        walls.append(ev)

    def turn(t, y):
        return y[2]
    y, t = np.concatenate([x0, v0]), t0
    top = bottom = y[0]
    for _ in range(impacts):
        s = solve_ivp(rhs, (t, t + 100.0), y, method="DOP853", rtol=1e-12, atol=1e-12,
                      events=walls + [turn])
        hit = [i for i in range(len(walls)) if s.t_events[i].size]
        assert hit, "no impact within 100"
        for yt in s.y_events[-1]:
            top, bottom = max(top, yt[0]), min(bottom, yt[0])
        i = hit[0]
        t, y = s.t_events[i][0], s.y_events[i][0].copy()
        top, bottom = max(top, y[0]), min(bottom, y[0])
        c = system.contacts[i]
        w = c.gap @ y[2:]
        m = Minv @ c.gap
        y[2:] = y[2:] - (1 + c.r) * w * m / (c.gap @ m)
    return top, bottom


def test_the_amplitude_equals_solve_ivps(small_sweep):
    """Each run's amplitude over its last cycle (the figure's ``run_amplitudes``) against
    the brute force from the same recorded impact, through the cycle's impacts: equal to
    1e-6 (the brute force's own tolerance is 1e-12 over a few periods; measured 2.8e-12 on
    the 6-impact cycles at Ω = 0.93 and the LR cycles at 1.1)."""
    with h5py.File(small_sweep) as f:
        scene = config.loads(f.attrs["scene"])          # the file's own sweep
        t = f["impacts/t"][...]
        x = np.stack([f["impacts/x"][...], f["impacts/y"][...]], -1)
        v = np.stack([f["impacts/v_x"][...], f["impacts/v_y"][...]], -1)
        ipc = f["impacts_per_cycle"][...]
        omegas = f["forcing.0.Omega"][...]
    checked = 0
    for p, w in enumerate(omegas):
        system, bad = scene.spec.system_of(scene.point((p,)))
        assert not bad
        amp = run_amplitudes(system, t[p], x[p], v[p], ipc[p], 0)
        for r in range(t.shape[1]):
            q = int(ipc[p, r])
            assert q > 0, (w, r)
            k = np.isfinite(t[p, r]).sum() - 1 - q
            hi, lo = _brute(system, t[p, r, k], x[p, r, k], v[p, r, k], q)
            assert abs(0.5 * (hi - lo) - amp[r]) < 1e-6, (w, r, 0.5 * (hi - lo), amp[r])
            checked += 1
    assert checked == 4


def test_cornerbif_plot_draws_the_amplitude(small_sweep, tmp_path):
    out = str(tmp_path / "amp.png")
    r = CliRunner().invoke(main, ["plot", small_sweep, "-o", out])
    assert r.exit_code == 0, r.output
    assert open(out, "rb").read(8) == b"\x89PNG\r\n\x1a\n"


# ------------------------------------------------------------------ refusals
def _problems(path, *sets):
    try:
        config.load(path, list(sets))
    except config.SceneError as e:
        return str(e)
    return ""


def test_the_scene_is_valid():
    assert _problems(SCENE) == ""
    assert _problems(SCENE, "plot.without=[]") == ""


@pytest.mark.parametrize("sets,needles", [
    (['plot.coordinate="z"'], ["plot.coordinate: 'z' is not a dof of the system; its dofs: x, y"]),
    (['plot.without=["q"]'], ["plot.without: 'q' is not a dof of the system; its dofs: x, y"]),
    (['plot.without=["x"]'], ["plot.without: ['x'] removes 'x', the plot.coordinate drawn"]),
    (['plot.without="y"'], ["plot.without: 'y' must be a list of dof names"]),
    (['sweep={"contact.R.kappa"={start=-2.0, stop=-1.0, num=3}}'],
     ["plot.without: ['y']", "\"forcing.<k>.Omega\"", "'contact.R.kappa'"]),
    (['system.forcing=[{on="x", F=0.3, Omega=1.0}, {on="x", F=0.1, Omega=2.0}]'],
     ["plot.without", "system.forcing.1", "acts on a kept dof too"]),
    (['system.forcing=[{on="y", F=0.3, Omega=1.0}]'],
     ["plot.without: ['y'] removes 'y', on which the swept force forcing.0"]),
    (['output.keep=[]'], ["plot.kind: 'amplitude'", "output.keep must contain \"impacts\""]),
    (['sweep={"forcing.0.Omega"={start=0.9, stop=1.0, num=2}, "mass.y"={start=0.1, stop=0.2, '
      'num=2}}'], ["plot.kind: 'amplitude' draws each run's amplitude against one swept "
                   "parameter; the scene sweeps 2"]),
])
def test_refusals_name_the_key_and_the_value(sets, needles):
    said = _problems(SCENE, *sets)
    for n in needles:
        assert n in said, said


def test_a_scene_of_another_model_is_refused():
    said = _problems(os.path.join(ROOT, "configs", "fig04c.toml"), 'plot.kind="amplitude"')
    assert "plot.kind: 'amplitude' draws a coordinate of a 'linear' scene" in said
    assert "the scene's model is 'flow'" in said


def test_a_missing_coordinate_is_refused():
    text = open(SCENE).read().replace('coordinate = "x"\n', "")
    with pytest.raises(config.SceneError) as e:
        config.loads(text)
    assert "plot.coordinate: missing; 'amplitude' draws one dof's amplitude (one of x, y)" \
        in str(e.value)
