"""Cam profiles (issue 20): any periodic, continuous, piecewise obstacle, certified.

Checked against what does not share the profile code: the built-in obstacles (a profile
of sinusoid or linear pieces is the rectified sine or the triangle), the exhaustive search
of tests/naive.py (its own evaluation of the profile, from the scene's table: formulas of
the motion laws written there, not the package's coefficients), sampled derivatives for the
certified bounds, and the scene validation's messages.
"""

import math

import naive
import numpy as np
import pytest
from click.testing import CliRunner

import cornerbif
from cornerbif.cli import main
from cornerbif.figures import timeseries as FTS
from cornerbif.obstacles import profile as PR

PI = math.pi
RECTIFIED = {"period": PI, "pieces": [{"span": PI, "sine": [1.0, 0.0, 1.0]}]}
BUMP = [0.0, 0.0, 16 / PI ** 2, -32 / PI ** 3, 16 / PI ** 4]     # 16 x^2 (1 - x)^2, x = phi/pi
# a dwell - rise - polynomial - return cam, the return's rise set for continuity
POLY7 = [1.0, 0.2, -0.3, 0.05, 0.01, -0.002, 0.0003, -0.00002]


def cam():
    end = float(PR.Piece(PI / 2, tuple(POLY7)).derivative(PI / 2))
    return {"period": 2 * PI, "pieces": [
        {"law": "dwell", "span": PI / 2},
        {"law": "constant_velocity", "span": PI / 2, "rise": 1.0},
        {"poly": POLY7, "span": PI / 2},
        {"law": "cycloidal", "span": PI / 2, "rise": -end}]}


def starts(n, seed=1, lo=0.5, hi=20.0, v=20.0):
    rng = np.random.default_rng(seed)
    return rng.uniform(lo, hi, n), rng.uniform(-v, v, n)


def same_impacts(a, b, tol):
    for k in ("t", "u", "v_in", "v_out", "corner_offset"):
        assert np.array_equal(np.isnan(a[k]), np.isnan(b[k])), k
        assert np.nanmax(np.abs(a[k] - b[k])) <= tol, (k, np.nanmax(np.abs(a[k] - b[k])))
    for k in ("status", "period", "impacts_per_cycle", "symbols"):
        assert np.array_equal(a[k], b[k]), k


def test_a_sinusoid_profile_is_the_rectified_sine():
    """g = sin(phi) over a period pi: 64 random starts near the corner (omega = 1.999,
    kappa = -0.005), 300 transient and 60 recorded impacts each: the same words, periods and
    statuses, impacts within twice the event tolerance (the two take different certified
    searches, each to 1e-12 in time)."""
    u0, v0 = starts(64)
    kw = dict(omega=1.999, kappa=-0.005, r=0.8, transient=300, record=60)
    a = cornerbif.simulate(u0, v0, obstacle="rectified_sine", **kw)
    b = cornerbif.simulate(u0, v0, obstacle="profile", profile=RECTIFIED, **kw)
    same_impacts(a, b, 4e-12)


def test_a_linear_profile_is_the_triangle():
    """Two linear pieces with the valleys named as corners (corners = [0]): the triangle of
    eq (7), slopes 1.5 and 2.5: equal words and periods, impacts to 1e-12."""
    u0, v0 = starts(64, seed=2)
    w, t1, t2 = 1.9, 1.5, 2.5
    L0, L1 = t1 * PI / (t1 + t2), t2 * PI / (t1 + t2)
    prof = {"period": PI, "corners": [0], "pieces": [
        {"span": L0, "poly": [0.0, t2 / w]}, {"span": L1, "poly": [t2 * L0 / w, -t1 / w]}]}
    kw = dict(omega=w, kappa=-0.01, r=0.8, transient=300, record=60)
    a = cornerbif.simulate(u0, v0, obstacle="triangle", theta1=t1, theta2=t2, **kw)
    b = cornerbif.simulate(u0, v0, obstacle="profile", profile=prof, **kw)
    same_impacts(a, b, 1e-12)


@pytest.mark.parametrize("extra", [{}, {"sigma": 0.05}, {"F": 0.5, "Omega": 0.7},
                                   {"F": -1.0, "Omega": 0.0, "sigma": 0.02}])
def test_polynomial_profiles_match_exhaustive_search(extra):
    """A dwell - constant velocity - degree-7 polynomial - cycloidal cam, 8 random starts,
    free, damped, forced and with a spring preload (Omega = 0: a constant force): the first
    8 impacts equal tests/naive.py from the same start to 1e-9."""
    prof = cam()
    u0, v0 = starts(8, seed=3, lo=2.0, hi=6.0, v=3.0)
    kw = dict(omega=1.3, kappa=0.0, r=0.7)
    res = cornerbif.simulate(u0, v0, obstacle="profile", profile=prof, record=8, **kw,
                             **extra)
    assert (res["status"] == 0).all()
    for i in range(u0.size):
        ref = naive.naive_impacts(prof, 1.3, 0.0, 1.0, 0.7, u0[i], v0[i], 8, **extra)
        got = np.stack([res["t"][i], res["u"][i], res["v_in"][i], res["v_out"][i]], -1)
        assert ref.shape == (8, 4)
        assert np.abs(got - ref).max() < 1e-9, (i, np.abs(got - ref).max())


@pytest.mark.parametrize("eps", [1e-3, 1e-6, 1e-9, 1e-12, -1e-12, -1e-9, -1e-6, -1e-3])
def test_grazing_a_polynomial_hump(eps):
    """A flight u = R cos(t - psi) whose lowest point touches the top of a quartic hump
    (16 x^2 (1 - x)^2, then a dwell) with a gap eps: a miss for eps > 0, an impact at the
    top for eps < 0, down to |eps| = 1e-12; the exhaustive search agrees on the gap and,
    where it resolves it (|eps| >= 1e-9), on the impact."""
    prof = {"period": 2 * PI, "pieces": [{"span": PI, "poly": BUMP}, {"span": PI, "poly": [0.0]}]}
    w, kap = 1.7, -5.0
    tg = (2 * PI + PI / 2) / w                   # the top of the second hump
    R_ = -(kap + 1.0 + eps)
    psi = tg - PI
    u0, v0 = R_ * math.cos(psi), R_ * math.sin(psi)
    res = cornerbif.simulate(u0, v0, obstacle="profile", profile=prof, omega=w, kappa=kap,
                             r=0.8, record=3, chatter=1e-12, max_periods=200)
    gmin, _ = naive.naive_gap_min(prof, w, kap, 1.0, u0, v0, 0.0, tg + 1.0)
    assert gmin == pytest.approx(eps, abs=1e-14)
    if eps > 0:
        assert not (np.abs(res["t"][0] - tg) < 1.0).any()
    else:
        # the dip below the hump, to second order: z'' = -16 omega^2 / pi^2 at the top,
        # u'' = R there
        depth = math.sqrt(2 * -eps / (R_ + 16 * w * w / PI ** 2))
        assert abs(res["t"][0, 0] - tg) <= 1.01 * depth + 1e-9
        if abs(eps) >= 1e-9:
            ref = naive.naive_impacts(prof, w, kap, 1.0, 0.8, u0, v0, 1, dt=2e-4)
            assert res["t"][0, 0] == pytest.approx(ref[0, 0], abs=1e-9)


def test_laws_are_their_formulas_and_join_smoothly():
    """Each motion law as the package expands it (polynomial and sinusoid coefficients)
    against tests/naive.py's formula of the law, at 201 angles; the laws that promise it
    start and end with zero velocity; the corners are where the slope jumps."""
    spec = {"period": 7.0, "pieces": [
        {"law": "dwell", "span": 0.5},
        {"law": "parabolic", "span": 1.0, "rise": 0.8},
        {"law": "simple_harmonic", "span": 1.0, "rise": -0.3},
        {"law": "cycloidal", "span": 1.5, "rise": 0.6},
        {"law": "polynomial_345", "span": 1.0, "rise": -0.5},
        {"law": "constant_velocity", "span": 2.0, "rise": -0.6}]}
    prof = PR.read(spec)
    ref = naive.NaiveProfile(spec)
    th = np.linspace(0.0, 7.0, 2001)[:-1]
    g = prof.lift(th)
    starts_ = np.cumsum([0] + [p["span"] for p in spec["pieces"]])
    m = np.searchsorted(starts_, th, side="right") - 1
    want = np.array([ref.g(k, x - starts_[k])[0] for k, x in zip(m, th)])
    assert np.abs(g - want).max() < 1e-13
    slope = prof.lift(th, 1)
    want1 = np.array([ref.g(k, x - starts_[k])[1] for k, x in zip(m, th)])
    assert np.abs(slope - want1).max() < 1e-12
    # parabolic is two pieces; only the constant velocity law's two ends are corners
    assert len(prof.pieces) == 7
    assert prof.corners == (True, False, False, False, False, False, True)


def test_certified_bounds_hold_on_every_piece():
    """profile.bounds against g, g'', g''', g'''' sampled densely on each piece (the
    Bernstein enclosure of the polynomial plus the sinusoid's amplitude)."""
    for piece in PR.read(cam()).pieces + PR.read(RECTIFIED).pieces:
        x = np.linspace(0.0, piece.span, 5001)
        lo, hi, lo2, hi2, m3, m4 = PR.bounds(piece)
        g, g2 = piece.derivative(x), piece.derivative(x, 2)
        assert lo <= g.min() and g.max() <= hi
        assert lo2 <= g2.min() and g2.max() <= hi2
        assert np.abs(piece.derivative(x, 3)).max() <= m3
        assert np.abs(piece.derivative(x, 4)).max() <= m4


def test_the_kernels_obstacle_is_the_profile():
    """obstacle.z_state on the packed profile (Horner in the kernel) against
    Profile.lift (numpy) and its time derivatives, at 400 times over two periods."""
    from cornerbif.models.flow import packed as P
    from cornerbif.numerics.oscillator import derive
    from cornerbif.obstacles.dispatch import derived_tuple_profile, piece_at, z_state
    prof = PR.read(cam())
    w, kap, beta = 1.3, 0.2, 0.7
    p = P.pack({"omega": w, "kappa": kap, "beta": beta}, "profile", 1e-12, 1e-6, 1e6, None,
               profile=prof)
    da = derive(p)
    d = derived_tuple_profile(da, p)        # the kernel's tuples refer to the row p
    pt = P.as_tuple_profile(p)
    for t in np.linspace(0.0, 2 * 2 * PI / w, 400, endpoint=False) + 1e-3:   # off the joints
        j, tau = piece_at(d, t)
        assert (j, tau) == piece_at(da, t)          # the tuple reads what derive's array holds
        z = z_state(pt, j, tau)
        assert z == z_state(p, j, tau)
        want = [kap + beta * prof.lift(w * t)[()]] + [beta * w ** k * prof.lift(w * t, k)[()]
                                                      for k in (1, 2, 3)]
        assert np.allclose(z, want, rtol=1e-10, atol=1e-10), (t, z, want)


@pytest.mark.parametrize("profile,needle", [
    ({"period": PI, "pieces": [{"span": PI / 2, "poly": [0.0, 1.0]},
                               {"span": PI / 2, "poly": [0.0]}]},
     "system.profile.pieces[1]: the obstacle jumps from"),
    ({"period": PI, "pieces": [{"span": 1.0, "poly": [0.0]}]},
     "the spans add up to 1.0, not the period"),
    ({"period": PI, "pieces": [{"span": PI, "poly": [0.0, "nan"]}]},
     "system.profile.pieces[0].poly"),
    ({"period": PI, "pieces": [{"span": PI, "poly": [0.0] * 9}]},
     "system.profile.pieces[0].poly: degree 8 is past the limit 7"),
    ({"period": PI, "pieces": [{"span": PI, "law": "bouncy"}]},
     "system.profile.pieces[0].law: 'bouncy' is not a motion law"),
    ({"period": 2 * PI, "pieces": [{"span": PI, "law": "constant_velocity", "rise": 1.0},
                                   {"span": PI, "law": "dwell"}]},
     "system.profile.pieces[0]: the obstacle jumps from 1.0 to 0.0 between the end of the "
     "period"),
    ({"period": 9 * 0.5, "pieces": [{"span": 0.5, "law": "dwell"}] * 9},
     "9 smooth pieces"),
    ({"period": PI, "pieces": [{"span": PI, "law": "dwell", "rise": 1.0}]},
     "system.profile.pieces[0].rise: 1.0 but a dwell does not rise"),
    ({"period": PI, "pieces": [{"span": PI, "poly": [0.0], "lift": 2}]},
     "system.profile.pieces[0].lift: unknown key"),
    ({"period": PI, "corners": [3], "pieces": [{"span": PI, "poly": [0.0]}]},
     "system.profile.corners: [3] must be a list of piece indices 0..0"),
])
def test_bad_profiles_are_refused_naming_the_piece(profile, needle):
    with pytest.raises(Exception) as e:
        cornerbif.simulate(1.0, 0.0, obstacle="profile", profile=profile, omega=1.0)
    assert needle in str(e.value), str(e.value)


def test_a_profile_needs_the_profile_obstacle_and_a_table():
    r = CliRunner().invoke(main, ["validate", "configs/cam_cycloidal.toml",
                                  "--set", "system.obstacle=\"sine\""])
    assert r.exit_code == 2 and "system.profile: given, but system.obstacle is 'sine'" in r.output


def test_stability_of_a_profile_is_the_rectified_sines():
    """The multipliers and Lyapunov exponents of the sinusoid profile's runs equal the
    rectified sine's (same cycles, same tangent dynamics), to 1e-9."""
    kw = dict(omega=2.2, kappa=0.0, r=0.8, transient=500, record=40, keep=["stability"])
    a = cornerbif.simulate([3.0, 5.0], [0.0, 1.0], obstacle="rectified_sine", **kw)
    b = cornerbif.simulate([3.0, 5.0], [0.0, 1.0], obstacle="profile", profile=RECTIFIED, **kw)
    for k in ("mu_re", "mu_im", "lyapunov"):
        assert np.allclose(a[k], b[k], rtol=0, atol=1e-9), k


def test_a_profile_scene_continues():
    """A cam profile has an orbit solver (tests/continuation/test_cam_continuation.py): its
    [continue] table validates (continuing omega with its constant force, Omega = 0, runs
    in test_cam_continuation.py)."""
    r = CliRunner().invoke(main, ["validate", "configs/cam_constant_velocity.toml", "--set",
                                  "continue.parameter=\"kappa\"", "--set",
                                  "continue.range=[-0.5, 0.5]"])
    assert r.exit_code == 0, r.output


def test_the_jump_speed_is_where_the_follower_leaves():
    """obstacles.profile.jump_speed (the least contact force of a follower riding the cam
    turns negative) against the full simulation of a follower started on the cam at rest:
    1 % below it the follower rides the whole revolution (no impact after the start);
    1 % above it, it leaves and lands again (impacts).  A constant-velocity cam (corners
    where the slope drops) launches the follower at any speed: jump speed 0."""
    spec = {"period": 2 * PI, "pieces": [
        {"law": "dwell", "span": PI / 2}, {"law": "cycloidal", "span": PI / 2, "rise": 1.0},
        {"law": "dwell", "span": PI / 2}, {"law": "cycloidal", "span": PI / 2, "rise": -1.0}]}
    wj = PR.jump_speed(PR.read(spec), 0.0, 1.0, 1.0, -2.0)
    assert 1.0 < wj < 1.2
    res = {f: cornerbif.simulate(0.0, 0.0, obstacle="profile", profile=spec, omega=f * wj,
                                 kappa=0.0, r=0.5, F=-2.0, Omega=0.0, record=3, max_periods=40)
           for f in (0.99, 1.01)}
    assert np.isfinite(res[0.99]["t"][1:]).sum() == 0
    assert np.isfinite(res[1.01]["t"]).sum() == 3
    cv = {"period": 2 * PI, "pieces": [
        {"law": "dwell", "span": PI / 2}, {"law": "constant_velocity", "span": PI / 2, "rise": 1.0},
        {"law": "dwell", "span": PI / 2},
        {"law": "constant_velocity", "span": PI / 2, "rise": -1.0}]}
    assert PR.jump_speed(PR.read(cv), 0.0, 1.0, 1.0, -2.0) == 0.0


def _triangle3(w, t1, t2):
    """The triangle of eq (7) as three linear pieces (its rise split), valleys as corners."""
    L0, L1 = t1 * PI / (t1 + t2), t2 * PI / (t1 + t2)
    return {"period": PI, "corners": [0], "pieces": [
        {"span": L0 / 2, "poly": [0.0, t2 / w]}, {"span": L0 / 2, "poly": [t2 * L0 / (2 * w), t2 / w]},
        {"span": L1, "poly": [t2 * L0 / w, -t1 / w]}]}


def test_a_three_piece_profile_has_the_triangles_words_and_multipliers():
    """The triangle split into three pieces (a smooth joint inside its rise): the built-in
    triangle's words and periods, and its Floquet multipliers and Lyapunov exponents to
    1e-9 (the saltation reads the piece of each impact from its time)."""
    u0, v0 = starts(16, seed=4)
    w, t1, t2 = 1.9, 1.5, 2.5
    kw = dict(omega=w, kappa=-0.01, r=0.8, transient=300, record=60, keep=["stability"])
    a = cornerbif.simulate(u0, v0, obstacle="triangle", theta1=t1, theta2=t2, **kw)
    b = cornerbif.simulate(u0, v0, obstacle="profile", profile=_triangle3(w, t1, t2), **kw)
    for k in ("period", "impacts_per_cycle", "symbols"):
        assert np.array_equal(a[k], b[k]), k
    for k in ("mu_re", "mu_im", "lyapunov"):
        assert np.allclose(a[k], b[k], rtol=0, atol=1e-9, equal_nan=True), k


@pytest.mark.parametrize("n", [1, 2, 3])
def test_a_corner_free_profile_is_the_smooth_wall(n):
    """kappa + beta sin(omega t) written as n sinusoid pieces of one period 2 pi (no
    corners): the built-in sine's impacts, periods, impacts per cycle and words (x)."""
    spans = [2 * PI / n] * n
    pieces, start = [], 0.0
    for s in spans:
        pieces.append({"span": s, "sine": [math.cos(start), math.sin(start), 1.0]})
        start += s
    prof = {"period": 2 * PI, "pieces": pieces}
    u0, v0 = starts(12, seed=6, lo=1.5, hi=8.0, v=4.0)
    kw = dict(omega=2.4, kappa=0.2, r=0.8, transient=200, record=40)
    a = cornerbif.simulate(u0, v0, obstacle="sine", **kw)
    b = cornerbif.simulate(u0, v0, obstacle="profile", profile=prof, **kw)
    for k in ("status", "period", "impacts_per_cycle", "symbols"):
        assert np.array_equal(a[k], b[k]), k
    assert np.nanmax(np.abs(a["t"] - b["t"])) < 1e-9


def test_starts_are_drawn_above_the_profile_at_t0(tmp_path):
    """A profile whose lift is not 0 at t = 0 (g = cos phi): drawn u clears z(0) = kappa +
    beta, every run starts above the obstacle, and the scene as run keeps its corners."""
    from cornerbif import config
    from cornerbif.sweep import run_sweep
    text = """[scene]
name = "w"
model = "flow"
[system]
obstacle = "profile"
omega = 1.3
kappa = 0.0
r = 0.8
[system.profile]
period = 3.141592653589793
corners = [0]
pieces = [ { span = 3.141592653589793, sine = [0.0, 1.0, 2.0] } ]
[sweep]
kappa = { start = 0.0, stop = 0.1, num = 4 }
[initial]
count = 6
u = [0.0, 1.5]
[run]
transient = 20
record = 10
"""
    sc = config.loads(text)
    again = config.loads(sc.text)
    assert again.text == sc.text and "corners = [0]" in sc.text
    out = str(tmp_path / "w.h5")
    run_sweep(sc, out)
    import h5py
    with h5py.File(out) as f:
        assert (f["status"][...] != 5).all()
        kap = f["kappa"][...][:, None]
        assert (f["initial/u"][...] > kap + 1.0).all()


def test_jump_speed_counts_every_corner_and_restitution():
    """The triangle as a profile (corners named [0]): its peaks drop the slope, a launch
    at any speed: 0.  The rectified sine: its valleys raise the slope, which knocks the
    follower off when r > 0 (0), and not when r = 0 (a finite jump speed)."""
    tri = PR.read(_triangle3(1.0, 1.5, 2.5))
    assert PR.jump_speed(tri, 0.0, 1.0, 1.0, -2.0, r=0.0) == 0.0
    rect = PR.read(RECTIFIED)
    assert PR.jump_speed(rect, 0.0, 1.0, 1.0, -2.0, r=0.5) == 0.0
    w0 = PR.jump_speed(rect, 0.0, 1.0, 1.0, -2.0, r=0.0)
    assert w0 is not None and w0 > 0.5
    assert PR.jump_speed(rect, 1.0, 0.0, 1.0, -2.0) is None      # a flat wall holds it


def test_a_profiles_time_series_is_drawn(tmp_path):
    """[plot] kind = "timeseries" rebuilds a profile's flights (trajectory.pack with the
    profile): the cycloidal cam's runs above the jump speed."""
    r = CliRunner().invoke(main, ["sweep", "configs/cam_cycloidal.toml", "-o",
                                  str(tmp_path / "c.h5"), "--no-progress", "--set",
                                  "sweep.omega={start=1.5, stop=1.6, num=2}", "--set",
                                  "run.transient=100"])
    assert r.exit_code == 0, r.output
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots()
    from cornerbif.plot_data import PlotData
    FTS.draw_timeseries(ax, PlotData(str(tmp_path / "c.h5")), (0,), 0)
    plt.close(fig)


@pytest.mark.parametrize("named,angles", [
    (None, [0.0, 0.5 * PI, PI, 1.5 * PI]),       # every joint of the cam is a corner
    ([1, 3], [0.5 * PI, 1.5 * PI]),              # only the two named
])
def test_which_corner_of_the_period_each_impact_is_grouped_by(tmp_path, named, angles):
    """output.keep "corners": impacts/corner is the place, among the period's corners, of
    the corner impacts/corner_offset is measured from.  Checked against the corner at the
    angle omega (t - offset) mod 2 pi, matched to the profile's corner angles (computed
    here from the scene, not from the kernel's ids)."""
    import h5py
    out = tmp_path / "c.h5"
    args = ["sweep", "configs/cam_constant_velocity.toml", "-o", str(out), "--no-progress",
            "--set", "sweep.omega={start=0.6, stop=2.4, num=7}", "--set", "run.transient=60",
            "--set", "run.record=30", "--set", 'output.keep=["impacts", "corners"]']
    if named is not None:
        args += ["--set", f"system.profile.corners={named}"]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        t = f["impacts/t"][...]
        off = f["impacts/corner_offset"][...]
        place = f["impacts/corner"][...]
        w = f["omega"][...][:, None, None] * np.ones(t.shape)
    hit = np.isfinite(t)
    assert hit.sum() > 500 and (place[~hit] == -1).all()
    phase = np.mod(w[hit] * (t[hit] - off[hit]), 2 * PI)
    dist = np.abs(np.angle(np.exp(1j * (phase[:, None] - np.array(angles)[None, :]))))
    assert dist.min(axis=1).max() < 1e-9             # t - offset is a corner
    assert np.array_equal(place[hit], dist.argmin(axis=1))
    assert set(np.unique(place[hit])) == set(range(len(angles)))
    info = CliRunner().invoke(main, ["info", str(out)]).output
    assert "observables kept: impacts, corners;" in info, info


def test_corners_alone_are_not_impacts_and_simulate_returns_no_kernel_ids(tmp_path):
    """keep = ["corners"] writes impacts/corner only: info does not call that "impacts";
    cornerbif.simulate returns the declared outputs, not the kernel's internal corner ids."""
    out = tmp_path / "c.h5"
    r = CliRunner().invoke(main, ["sweep", "configs/cam_constant_velocity.toml", "-o", str(out),
                                  "--no-progress", "--set", "sweep.omega={start=0.6, stop=2.4, num=3}",
                                  "--set", "run.transient=30", "--set", "run.record=10",
                                  "--set", 'output.keep=["corners"]'])
    assert r.exit_code == 0, r.output
    info = CliRunner().invoke(main, ["info", str(out)]).output
    assert "observables kept: corners;" in info, info
    res = cornerbif.simulate([3.0, 4.0], [0.0, 0.0], obstacle="rectified_sine", omega=2.0,
                             record=6, transient=0)
    assert "corner_id" not in res


def test_the_builtin_obstacles_corners_are_one_per_period(tmp_path):
    """impacts/corner of the rectified sine is 0 at every impact; the sine has none (-1)."""
    import h5py
    for ob, want in (("rectified_sine", 0), ("sine", -1)):
        out = tmp_path / f"{ob}.h5"
        r = CliRunner().invoke(main, ["sweep", "configs/fig06a.toml", "-o", str(out),
                                      "--no-progress", "--set", "sweep.kappa.num=3",
                                      "--set", f'system.obstacle="{ob}"', "--set",
                                      "run.transient=20", "--set", "run.record=10", "--set",
                                      'output.keep=["impacts", "corners"]'])
        assert r.exit_code == 0, r.output
        with h5py.File(out) as f:
            hit = np.isfinite(f["impacts/t"][...])
            place = f["impacts/corner"][...]
        assert hit.any() and (place[hit] == want).all() and (place[~hit] == -1).all()


def test_heights_at_zero_are_the_kernels_bit_for_bit():
    """``profile.heights_at_zero`` (numpy, what a sweep's start draw reads) against the kernel's
    z_state at t = 0 (``kernel.obstacle_heights``): equal bit for bit, on the shipped cams and
    on 200 random profiles (degrees 0-7, sinusoid parts, zero and negative g(0)), at random
    omega, kappa, beta."""
    from cornerbif import config
    from cornerbif.models.flow import packed as P
    from cornerbif.models.flow.kernel import obstacle_heights
    rng = np.random.default_rng(30)
    tables = [config.load(f"configs/{n}.toml").obstacle_table
              for n in ("cam_constant_velocity", "cam_cycloidal", "cam_rectified")]
    tables += [PR.read(cam()), PR.read(RECTIFIED)]
    for _ in range(200):
        deg = int(rng.integers(0, 8))
        poly = list(rng.normal(0.0, 1.0, deg + 1) * rng.choice([0.0, 1.0], deg + 1))
        piece = {"span": PI, "poly": poly}
        if rng.random() < 0.5:
            piece["sine"] = [float(rng.normal()), float(rng.normal()) * (rng.random() < 0.7),
                             2.0]
        a, b, n = piece.get("sine", [0.0, 0.0, 0.0])
        start = poly[0] + b
        end = np.polyval(poly[::-1], PI) + a * math.sin(n * PI) + b * math.cos(n * PI)
        tail = {"span": PI, "poly": [end, (start - end) / PI]}   # back to g(0), continuous
        tables.append(PR.read({"period": 2 * PI, "pieces": [piece, tail], "corners": [0, 1]}))
    rows = []
    for prof in tables:
        for _ in range(3):
            rows.append(P.pack({"omega": float(rng.uniform(0.2, 5.0)),
                                "kappa": float(rng.normal()), "beta": float(rng.uniform(0, 3))},
                               "profile", 1e-12, 1e-6, 1e6, None, profile=prof))
    rows = np.array(rows)
    want = obstacle_heights(rows, np.zeros((len(rows), 1)))[:, 0]
    got = PR.heights_at_zero(rows)
    assert len(rows) > 300
    assert np.array_equal(got.view(np.int64), want.view(np.int64))
