"""Continuation on cam profiles (issue 31): the flow's orbit problem on a profile's pieces,
its corners read from the profile's own joints.  Checked against the built-in rectified sine
(the same corner collision), the kernel's attractor and a finite-difference Jacobian of the
kernel's own section map (no code of the orbit solver)."""

import math

import numpy as np
import pytest
from click.testing import CliRunner

import cornerbif
from cornerbif import continuation_run as CR
from cornerbif.cli import main
from cornerbif.models.flow import orbit as FO

HALF_PI = math.pi / 2
CV_CAM = {"period": 2 * math.pi, "pieces": [
    {"law": "dwell", "span": HALF_PI},
    {"law": "constant_velocity", "span": HALF_PI, "rise": 1.0},
    {"law": "dwell", "span": HALF_PI},
    {"law": "constant_velocity", "span": HALF_PI, "rise": -1.0}]}
CV_SYSTEM = dict(kappa=0.0, beta=1.0, r=0.5, k=1.0, F=-2.0, Omega=0.0)
CV_SCENE = """[scene]
name = "cam_cv"
model = "flow"
[system]
obstacle = "profile"
omega = 2.5
kappa = 0.0
beta = 1.0
r = 0.5
k = 1.0
F = -2.0
Omega = 0.0
[system.profile]
period = 6.283185307179586
pieces = [
  { law = "dwell", span = 1.5707963267948966 },
  { law = "constant_velocity", span = 1.5707963267948966, rise = 1.0 },
  { law = "dwell", span = 1.5707963267948966 },
  { law = "constant_velocity", span = 1.5707963267948966, rise = -1.0 },
]
[initial]
count = 4
seed = 1
u = [0.0, 3.0]
v = [-1.0, 1.0]
[run]
transient = 200
record = 200
[continue]
parameter = "omega"
range = [1.0, 4.0]
start = 2.5
"""


def _continue(tmp_path, text, name):
    scene = tmp_path / f"{name}.toml"
    scene.write_text(text)
    out = tmp_path / f"{name}.h5"
    r = CliRunner().invoke(main, ["continue", str(scene), "-o", str(out), "--overwrite"])
    assert r.exit_code == 0, r.output
    return CR.read(out), r.output


def test_a_cam_written_as_the_rectified_sine_has_the_same_corner_collision(tmp_path):
    """configs/cont_beta.toml with the rectified sine written as a one-piece cam profile
    (g = sin phi on [0, pi], its joint a corner): the beta orbit ends at the same corner
    collision kappa_C as on the built-in obstacle, to 1e-10."""
    text = open("configs/cont_beta.toml").read()
    builtin, _ = _continue(tmp_path, text, "builtin")
    cam_text = text.replace('obstacle = "rectified_sine"', 'obstacle = "profile"').replace(
        "[initial]", "[system.profile]\nperiod = 3.141592653589793\npieces = [ { span = "
        "3.141592653589793, sine = [1.0, 0.0, 1.0] } ]\n\n[initial]")
    cam, out = _continue(tmp_path, cam_text, "cam")

    def corner(res):
        (e,) = [e for e in res["events"] if e["kind"] == "corner"]
        return e["param"]
    assert abs(corner(cam) - corner(builtin)) < 1e-10, (corner(cam), corner(builtin))
    assert "a corner collision of impact 0" in out


def _kernel_section_map_multipliers(omega, us, vs, ts, h=1e-6):
    """Eigenvalues of the central-difference Jacobian of the kernel's section map over one
    cam period, from the section state (us, vs) at ts (``cornerbif.simulate``, keep
    "section": its first section state is one period after the start)."""
    kw = dict(obstacle="profile", profile=CV_CAM, omega=omega, **CV_SYSTEM)

    def section(u, v):
        res = cornerbif.simulate([u], [v], t0=ts, transient=0, record=12, keep=["section"], **kw)
        return np.array([res["su"][0][0], res["sv"][0][0]])
    J = np.empty((2, 2))
    for c in range(2):
        e = np.zeros(2)
        e[c] = h
        J[:, c] = (section(us + e[0], vs + e[1]) - section(us - e[0], vs - e[1])) / (2 * h)
    return np.sort_complex(np.linalg.eigvals(J))


@pytest.fixture(scope="module")
def cv_branch(tmp_path_factory):
    res, out = _continue(tmp_path_factory.mktemp("cv"), CV_SCENE, "cv")
    return res, out


def test_a_cam_branch_is_the_kernels_attractor_and_its_multipliers_the_kernels(cv_branch):
    """The constant-velocity cam (four corners) at omega = 2.5: its period-one orbit 'bb'
    continued in omega.  Where stable, the kernel started elsewhere settles on the branch's
    impacts (1e-9); at every tested point, stable or past its period doubling, the
    multipliers equal the eigenvalues of a central-difference Jacobian of the kernel's own
    section map (1e-6)."""
    res, out = cv_branch
    (b,) = [b for b in res["branches"] if b["word"] == "bb"]
    kinds = [e["kind"] for e in res["events"] if e["branch"] == 0]
    assert "period_doubling" in kinds
    n = len(b["param"])
    assert n > 10
    checked_unstable = 0
    for i in range(1, n - 1, 4):
        w = b["param"][i]
        mu = np.sort_complex(b["multiplier_re"][i] + 1j * b["multiplier_im"][i])
        T = 2 * math.pi / w
        ts = math.ceil(b["impact_t"][i][0] / T) * T
        fd = _kernel_section_map_multipliers(w, b["section_u"][i], b["section_v"][i], ts)
        assert np.abs(fd - mu).max() < 1e-6, (w, fd, mu)
        if b["stable"][i]:
            # started off the orbit (its section state moved by 0.05), within its basin
            run = cornerbif.simulate([b["section_u"][i] + 0.05], [b["section_v"][i]], t0=ts,
                                     obstacle="profile", profile=CV_CAM, omega=w,
                                     transient=400, record=8, **CV_SYSTEM)
            assert run["impacts_per_cycle"][0] == 2
            got = sorted(zip(run["u"][0][-2:], run["v_out"][0][-2:]))
            want = sorted(zip(b["impact_u"][i], b["impact_v_out"][i]))
            assert np.abs(np.array(got) - np.array(want)).max() < 1e-9, (w, got, want)
        else:
            checked_unstable += 1
    assert checked_unstable >= 1


def test_a_cam_orbit_problem_keeps_its_table_through_the_resume_state():
    """The problem's plain data (a partial file's resume state) holds the cam's table, and
    the problem read back from it has the same residual, bit for bit."""
    w = 2.5
    run = cornerbif.simulate([2.0], [0.0], obstacle="profile", profile=CV_CAM, omega=w,
                             transient=400, record=8, **CV_SYSTEM)
    values = dict(CV_SYSTEM, omega=w)
    prob, X = FO.seed_from_run(values, "profile", "omega", run["t"][0], run["v_out"][0],
                               run["corner_offset"][0], int(run["impacts_per_cycle"][0]),
                               tables={"profile": CV_CAM})
    again = FO.FlowOrbit.from_doc(prob.to_doc())
    assert again.to_doc()["tables"] == {"profile": CV_CAM}
    assert np.array_equal(again.residual(X, w), prob.residual(X, w))


def test_a_word_seeds_an_unstable_cam_orbit():
    """A seed word on an obstacle with corners other than the rectified sine
    (``orbit.seed_from_transients``): the kernel's runs from a grid of starts are scanned for
    a window spelling the word, and Newton solves it.  At omega = 3.1, past its period
    doubling, the constant-velocity cam's period-one orbit is unstable (multiplier -1.24)
    and spelled 'a' (its two impacts straddle the corner after the first dwell): no start
    settles on it, yet the word 'a' seeds it, equal to the orbit continued there from the
    stable one at omega = 2.5 (1e-10); and through the CLI a scene seeding 'a' continues
    it."""
    from cornerbif import continuation as C
    w = 3.1
    prob, X = FO.seed_from_word(dict(CV_SYSTEM, omega=w), "profile", "omega", "a",
                                cornerbif.simulate, tables={"profile": CV_CAM})
    mu, _ = prob.floquet(X, w)
    assert prob.word(X, w) == "a" and np.abs(mu).max() > 1.2
    start, X0 = FO.seed_from_word(dict(CV_SYSTEM, omega=2.5), "profile", "omega", "bb",
                                  cornerbif.simulate, tables={"profile": CV_CAM})
    pts, _ = C.continue_branch(start, X0, 2.5, (2.5, w), +1.0)
    assert pts[-1].lam == w and list(pts[-1].problem.pieces) == list(prob.pieces)
    assert np.abs(pts[-1].X - X).max() < 1e-10


def test_a_cam_scene_seeds_a_word(tmp_path):
    text = CV_SCENE.replace("start = 2.5", 'start = 3.1\nseed = "a"').replace(
        "omega = 2.5", "omega = 3.1")
    res, out = _continue(tmp_path, text, "word")
    assert "continuing 1 seed(s)" in out and "'a'" in out
    assert res["branches"] and res["branches"][0]["word"] == "a"
