"""Periodic orbits of any itinerary and their continuation (cornerbif/continuation.py,
docs/continuation.md).

Every number is checked against something the continuation code does not compute: the
paper's corner curves (11) and (17), the closed-form fold of the forced oscillator against
a fixed wall (derived below), the independent finite-difference Jacobian of
tests/fd_reference.py on unstable orbits, and the kernel's attractors.
"""

import math
import os
import sys

import numpy as np
import pytest

import cornerbif
from cornerbif import continuation as C
from cornerbif import continuation_run as CR
from cornerbif import theory
from cornerbif.models.flow import orbit as FO
from cornerbif.models.map2d import orbit as MO
from cornerbif.models.two_particle import orbit as TO

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _seed(values, obstacle, param, word=None, starts=None, transient=1500, **run):
    """A FlowOrbit seeded from the kernel's attractor (the first start reaching ``word``)."""
    u0, v0 = starts if starts is not None else ([5.0], [0.0])
    sys_ = {k: v for k, v in values.items()}
    res = cornerbif.simulate(u0, v0, obstacle=obstacle, transient=transient, record=60,
                             **sys_, **run)
    words = list(res["symbols"])
    i = words.index(word) if word is not None else 0
    return FO.seed_from_run(values, obstacle, param, res["t"][i], res["v_out"][i],
                           res["corner_offset"][i], int(res["impacts_per_cycle"][i]))


def _beta(omega, r, kappa):
    a, b, _ = theory.single_impact_orbit(omega, kappa, r, exact=True)
    return _seed(dict(omega=omega, kappa=kappa, beta=1.0, r=r), "rectified_sine", "kappa",
                 starts=([a], [b]), transient=100)


def _alpha(omega, r, kappa):
    rng = np.random.default_rng(0)
    starts = (rng.uniform(0, 20, 32), rng.uniform(-0.02, 0.02, 32))
    return _seed(dict(omega=omega, kappa=kappa, beta=1.0, r=r), "rectified_sine", "kappa",
                 word="a", starts=starts, transient=3000)


@pytest.mark.parametrize("r", [0.5, 0.8, 0.95])
def test_corner_collision_curves_are_eqs_11_and_17(r):
    """The beta orbit (one impact just after the corner) continued in kappa at
    omega = 1.999 ends where its impact reaches the corner: kappa_C of eq (11); the alpha
    orbit (two impacts straddling it) at omega = 2.001 where both merge at it: kappa_CC of
    eq (17).  Each located collision, continued in omega over [1.98, 2.02] with the impact
    held at the corner (CornerCurve), equals the equation to 1e-10 in kappa at every point
    (measured 2e-11 or better)."""
    for seed, eq, om, direction in ((_beta, theory.kappa_C, 1.999, +1),
                                    (_alpha, theory.kappa_CC, 2.001, -1)):
        kc = eq(om, r)
        start = kc - 0.01 if eq is theory.kappa_C else 0.5 * (theory.kappa_C(om, r) + kc)
        prob, X = seed(om, r, start)
        br = C.follow(prob, X, start, (-1.0, 1.0), direction, switch=False, ds=1e-3)[0]
        ev = br.events[-1]
        assert ev.kind == "corner" and abs(ev.lam - kc) < 1e-10, (ev.kind, ev.lam - kc)
        for d in (+1, -1):
            w, k, _, _, _ = C.corner_curve(ev, "omega", (1.98, 2.02), d, ds=1e-3)
            assert len(w) >= 5 and (w.max() >= 2.02 - 1e-12 or w.min() <= 1.98 + 1e-12)
            err = np.abs(k - np.array([eq(x, r) for x in w]))
            assert err.max() < 1e-10, err.max()


def _fold_closed_form(Om, r, F, m=1):
    """The fold of the period-one impacting orbit of u'' + u = F cos(Omega t) against the
    fixed wall u = kappa (law 5): with the impact at phase theta = Omega tau, the flight of
    T = 2 pi m/Omega from (kappa, v+) back to kappa and law (5) give
    kappa tan(T/2) = P (tan(T/2) cos theta + Omega K sin theta), P = F/(1 - Omega^2),
    K = (1 + r)/(1 - r); a solution exists while |kappa tan(T/2)| <= |P| R,
    R = sqrt(tan^2(T/2) + Omega^2 K^2): the two orbits merge at kappa = |P| R / |tan(T/2)|."""
    T = 2 * math.pi * m / Om
    K = (1 + r) / (1 - r)
    P = F / (1 - Om ** 2)
    return abs(P) * math.hypot(math.tan(T / 2), Om * K) / abs(math.tan(T / 2))


def _fold_branch():
    Om, r, F = 2.5, 0.8, 1.0
    vals = dict(omega=Om, kappa=0.5, beta=0.0, r=r, sigma=0.0, F=F, Omega=Om)
    prob, X = _seed(vals, "sine", "kappa", starts=([1.5], [0.0]), transient=3000)
    return C.follow(prob, X, 0.5, (-3.0, 3.0), +1, ds=0.01)[0], _fold_closed_form(Om, r, F)


def test_fold_and_its_saddle_branch():
    """The forced oscillator against a fixed wall (beta = 0): the stable period-one
    impacting orbit, continued in kappa, turns at a fold located at the closed form to
    1e-10 (measured 3e-15) where one multiplier is 1; the saddle branch beyond it has a
    multiplier > 1 and is continued until it ends, in a grazing (its flight touches the
    wall: kappa = 0.3593)."""
    br, kf = _fold_branch()
    kinds = [e.kind for e in br.events]
    assert kinds[:2] == ["fold", "grazing"], kinds
    fold = br.events[0]
    assert abs(fold.lam - kf) < 1e-10, fold.lam - kf
    mu, _ = fold.problem.floquet(fold.X, fold.lam)
    assert abs(mu[0] - 1.0) < 1e-7
    # past the fold (in the branch's order) every point is a saddle until the grazing
    i_fold = min(range(len(br.points)), key=lambda i: abs(br.points[i].lam - fold.lam))
    after = br.points[i_fold + 2:-1]
    assert len(after) > 5 and all(abs(p.mu[0]) > 1.0 > abs(p.mu[1]) for p in after)


def _fd_multipliers(prob, X, lam):
    """Eigenvalues of tests/fd_reference.py's central-difference Jacobian of the time map
    over one cycle from the orbit's section state (no code of cornerbif)."""
    import fd_reference as FD
    p, _ = prob.packed(lam)
    vals = dict(prob.values, **{prob.param: lam})
    T = 2 * math.pi / vals["omega"]
    u, v = FO.section_state(prob, X, lam, T)
    t0 = math.ceil(prob.impacts(X, lam)["t"][0] / T) * T
    kw = {k: vals[k] for k in ("sigma", "k", "F", "Omega", "phi") if k in vals}
    J, err = FD.fd_jacobian(prob.obstacle, vals["omega"], vals["kappa"], vals["beta"],
                            vals["r"], u, v, t0, prob.duration(lam), **kw)
    return np.linalg.eigvals(J), err


def test_unstable_orbits_multipliers_match_the_fd_reference():
    """On unstable orbits too the solver's multipliers equal the eigenvalues of the
    independent finite-difference Jacobian to 1e-6: the saddle of the fold above at
    kappa = 1.0, and Fig. 1(a)'s period-one orbit at omega = 2.8, past its period
    doubling at 2.653 (one multiplier below -1)."""
    br, _ = _fold_branch()
    pt = min((p for p in br.points if abs(p.mu[0]) > 1.2),
             key=lambda p: abs(p.lam - 1.0))
    sad = C.newton(pt.problem, pt.X, 1.0)
    mu, _ = pt.problem.floquet(sad, 1.0)
    fd, err = _fd_multipliers(pt.problem, sad, 1.0)
    assert abs(mu[0]) > 1.0
    assert np.allclose(np.sort_complex(mu), np.sort_complex(fd), atol=1e-6), (mu, fd, err)
    prob, X = _seed(dict(omega=2.2, kappa=0.0, beta=1.0, r=0.8), "sine", "omega")
    br = C.follow(prob, X, 2.2, (2.0, 2.8), +1, ds=0.01)[0]
    assert [e.kind for e in br.events][:1] == ["period_doubling"]
    end = br.points[-1]
    mu, _ = end.problem.floquet(end.X, end.lam)
    fd, err = _fd_multipliers(end.problem, end.X, end.lam)
    assert mu.real.min() < -1.0
    assert np.allclose(np.sort_complex(mu), np.sort_complex(fd), atol=1e-6), (mu, fd, err)


def test_a_stable_branch_lies_on_the_kernels_attractor():
    """The beta branch at omega = 1.999: at points along it the kernel, started elsewhere
    (u = 7, v = 0.01, not on the orbit), settles on an attractor whose impacts are the
    branch's (height and velocities to 1e-9)."""
    prob, X = _beta(1.999, 0.8, -0.02)
    br = C.follow(prob, X, -0.02, (-0.02, 0.0), +1, switch=False, ds=1e-3)[0]
    for pt in br.points[1:-1:3]:
        imp = pt.problem.impacts(pt.X, pt.lam)
        res = cornerbif.simulate([7.0], [0.01], omega=1.999, kappa=pt.lam, r=0.8,
                                 transient=1500, record=20)
        assert res["impacts_per_cycle"][0] == 1
        assert abs(res["u"][0][-1] - imp["u"][0]) < 1e-9
        assert abs(res["v_out"][0][-1] - imp["v_out"][0]) < 1e-9
        assert abs(res["v_in"][0][-1] - imp["v_in"][0]) < 1e-9


def test_one_branch_from_two_starts():
    """Continued from kappa = -0.02 upwards and from -0.016 downwards, the beta branch is
    one branch: at kappa = -0.018 both give the same orbit to 1e-12 (relative)."""
    pa, Xa = _beta(1.999, 0.8, -0.02)
    pb, Xb = _beta(1.999, 0.8, -0.016)
    a = C.follow(pa, Xa, -0.02, (-0.02, -0.018), +1, switch=False, ds=5e-4)[0]
    b = C.follow(pb, Xb, -0.016, (-0.018, -0.016), -1, switch=False, ds=5e-4)[0]
    ea, eb = a.points[-1], b.points[-1]
    assert abs(ea.lam + 0.018) < 1e-12 and abs(eb.lam + 0.018) < 1e-12
    ia, ib = ea.problem.impacts(ea.X, ea.lam), eb.problem.impacts(eb.X, eb.lam)
    assert abs(ia["u"][0] - ib["u"][0]) < 1e-12
    assert abs(ia["v_out"][0] - ib["v_out"][0]) < 1e-12 * (1.0 + abs(ia["v_out"][0]))


def test_the_hysteresis_has_no_saddle_between_its_attractors():
    """At omega = 2.001 the beta and alpha orbits coexist between kappa_CC and kappa_C.
    Neither branch turns in a fold: beta ends at its corner collision kappa_C and alpha
    at kappa_CC, and across each the other side's itinerary has no admissible orbit -- the
    orbit is destroyed at a border collision, and the tool says so rather than inventing
    a saddle between the two attractors."""
    om, r = 2.001, 0.8
    for seed, eq, d in ((_beta, theory.kappa_C, +1), (_alpha, theory.kappa_CC, -1)):
        start = 0.008
        prob, X = seed(om, r, start if seed is _alpha else theory.kappa_C(om, r) - 0.005)
        brs = C.follow(prob, X, prob.values["kappa"], (-0.01, 0.03), d, ds=1e-3)
        assert len(brs) == 1
        kinds = [e.kind for e in brs[0].events]
        assert "fold" not in kinds and kinds[-1] == "corner"
        assert abs(brs[0].events[-1].lam - eq(om, r)) < 1e-10
        assert "no admissible orbit" in brs[0].events[-1].detail


# ------------------------------------------------------------------ the command
def test_cornerbif_continue_writes_branches_and_plots_them(tmp_path):
    """`cornerbif continue` on the beta scene writes one branch ending at kappa_C with its
    events; `cornerbif plot` draws it alone and over a sweep of the same parameter."""
    import h5py
    from click.testing import CliRunner

    from cornerbif.cli import main
    run = CliRunner()
    out = tmp_path / "c.h5"
    r = run.invoke(main, ["continue", os.path.join(ROOT, "configs", "cont_beta.toml"), "-o",
                          str(out), "--set", "run.transient=300"])
    assert r.exit_code == 0, r.output
    cont = CR.read(out)
    assert len(cont["branches"]) == 1 and str(cont["branches"][0]["word"]) == "b"
    kinds = [e["kind"] for e in cont["events"]]
    assert "corner" in kinds
    kc = [e["param"] for e in cont["events"] if e["kind"] == "corner"][0]
    assert abs(kc - theory.kappa_C(1.999, 0.8)) < 1e-10
    with h5py.File(out) as f:
        assert f.attrs["format"] == CR.FORMAT and f["branches/000/multiplier_re"].shape[1] == 2
    r = run.invoke(main, ["plot", str(out), "-o", str(tmp_path / "alone.png")])
    assert r.exit_code == 0, r.output
    sw = tmp_path / "s.h5"
    r = run.invoke(main, ["sweep", os.path.join(ROOT, "configs", "fig06a.toml"), "-o", str(sw),
                          "--no-progress", "--set", "sweep.kappa.num=30",
                          "--set", "initial.count=2", "--set", "run.transient=200"])
    assert r.exit_code == 0, r.output
    r = run.invoke(main, ["plot", str(sw), str(out), "-o", str(tmp_path / "over.png")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "over.png").stat().st_size > 10_000
    r = run.invoke(main, ["continue", os.path.join(ROOT, "configs", "cont_beta.toml"), "-o",
                          str(out)])
    assert r.exit_code == 2 and "--overwrite" in r.output


@pytest.mark.parametrize("sets,needle", [
    (["continue.parameter=\"kapa\""], "continue.parameter: 'kapa' is not a numeric parameter"),
    (["continue.range=[0.1, -0.1]"], "continue.range: [0.1, -0.1] must be"),
    (["continue.start=0.5"], "continue.start: 0.5 must be a number within continue.range"),
    (["continue.seed=\"bq\""], "continue.seed: 'bq'"),
    (["continue.events=[\"cusp\"]"], "continue.events: ['cusp'] must be"),
    (["continue.parameter=\"r\"", "continue.range=[0.5, 1.5]", "continue.start=0.8"],
     "continue.range: 1.5 is out of range"),
    (["continue.ds=1.0", "continue.ds_max=0.1"], "continue.ds: ds_min"),
    (["continue.curve_range=[1.9, 2.1]"], "without continue.curve"),
])
def test_bad_continue_tables_are_refused_before_any_work(sets, needle):
    """A [continue] table that cannot run is refused with its key and value named."""
    from click.testing import CliRunner

    from cornerbif.cli import main
    args = ["validate", os.path.join(ROOT, "configs", "cont_beta.toml")]
    for s in sets:
        args += ["--set", s]
    r = CliRunner().invoke(main, args)
    assert r.exit_code == 2 and needle in r.output, r.output


@pytest.mark.parametrize("word,kappa", [("abbgb", -0.004), ("ab", -0.001), ("bbg", -0.0048)])
def test_map2d_branches_end_where_theory_says(word, kappa):
    """map2d: the orbit of a word is exact (the maps are affine), and its branch in kappa
    ends where one of its points reaches a switching line: at the ends of
    theory.word_interval (the exact interval of admissibility) to 1e-12."""
    prob, X = MO.map_seed(dict(omega=1.999, kappa=kappa, r=0.8), "kappa", word)
    ok, why = prob.admissible(X, kappa)
    assert ok, why
    lo, hi = theory.word_interval(word, -0.001, 0.8)
    ends = []
    for d in (+1, -1):
        br = C.follow(prob, X, kappa, (-0.03, 0.03), d, switch=False, ds=1e-4)[0]
        assert br.events[-1].kind == "corner"
        ends.append(br.events[-1].lam)
    assert abs(ends[0] - hi) < 1e-12 and abs(ends[1] - lo) < 1e-12, (ends, lo, hi)
    mu, _ = prob.floquet(X, kappa)
    s = 0.8 ** (word.count("b") + word.count("g")) * (-0.64) ** word.count("a")
    assert np.allclose(mu, [s, s], rtol=1e-12)


def test_two_particle_period_one_branch_ends_at_omega0_C():
    """Fig. 19 (mu = 1000): the period-one orbit (a z-u impact just before each w-z impact
    in the cycle's order, one of each per wall period) continued down in omega0 ends where
    its z-u impact meets the w-z impact: the corner collision at omega0_C.  Against the
    kernel alone: bisection on omega0 between the simple word 'b' and the period-adding
    words below, to 1e-9 (tests/models/test_two_particle_scene.py's method); and at omega0 = 2 the
    four multipliers equal tests/fd_reference_two_particle.py's to 1e-6."""
    import fd_reference_two_particle as FR

    from cornerbif.models.two_particle import packed as TPM
    vals = {k: p.default for k, p in TPM.PARAMS.items()} | {"omega0": 2.0}
    x0 = [0.18982259867467574, 16.49606490380678, 1.7221809107866082, 149.66189899401783]
    prob, X = TO.two_particle_seed(vals, "omega0", x0, 1)
    mu, _ = prob.floquet(X, 2.0)
    J, _ = FR.fd_jacobian(vals, np.array(x0), 0.0, 2 * math.pi / 2.0)
    fd = np.linalg.eigvals(J)
    assert all(np.min(np.abs(fd - m)) < 1e-6 for m in mu), (mu, fd)
    br = C.follow(prob, X, 2.0, (1.9995, 2.002), -1, ds=1e-4)[0]
    ev = br.events[-1]
    assert ev.kind == "corner" and "no admissible orbit" in ev.detail

    r = cornerbif.simulate(1.0, 0.0, 10.0, 0.0, transient=1000, record=60, omega0=1.9999,
                           model="two_particle")
    xs = r["final"][0]

    def is_b(w):
        q = cornerbif.simulate(*xs, transient=1500, record=80, omega0=w, model="two_particle")
        return q["symbols"][0] == "b"

    lo, hi = 1.99975, 1.99976
    assert not is_b(lo) and is_b(hi)
    while hi - lo > 1e-9:
        m = 0.5 * (lo + hi)
        lo, hi = (lo, m) if is_b(m) else (m, hi)
    assert lo - 2e-9 <= ev.lam <= hi + 2e-9, (ev.lam, lo, hi)


def test_fold_curve_in_two_parameters_is_the_closed_form():
    """The located fold continued in the forcing amplitude F (FoldCurve: the orbit's
    equations and det(J - I) = 0, kappa free) lies on the closed form kappa_f(F) (linear
    in F through P = F/(1 - Omega^2)) to 1e-10 over F in [0.5, 2] (measured 5e-14)."""
    br, _ = _fold_branch()
    fold = br.events[0]
    for d in (+1, -1):
        F, kap, _, _, _ = C.fold_curve(fold, "F", (0.5, 2.0), d, ds=0.02)
        assert len(F) >= 3 and (F.max() >= 2.0 - 1e-12 or F.min() <= 0.5 + 1e-12)
        err = np.abs(kap - np.array([_fold_closed_form(2.5, 0.8, f) for f in F]))
        assert err.max() < 1e-10, err.max()


def test_a_corner_held_at_the_end_of_its_piece_and_the_curve_stays_admissible():
    """The abg orbit at omega = 2.001 loses admissibility where its impact 3 reaches the
    end of its piece (the corner after it): its corner curve, with that impact held at
    L(omega) (the parameter moves the piece's end too), continues away from omega = 2.001,
    and every point of the curve is an orbit of the flow: the curve stops where another
    impact or a flight stops being admissible (located as an event).  Before the review
    mend of CornerCurve.d_param (dL/domega missing) this curve had 1 point each way."""
    rng = np.random.default_rng(0)
    vals = dict(omega=2.001, kappa=0.008, beta=1.0, r=0.8)
    prob, X = _seed(vals, "rectified_sine", "kappa", word="abg",
                    starts=(rng.uniform(0, 20, 32), rng.uniform(-0.02, 0.02, 32)),
                    transient=3000)
    br = C.follow(prob, X, 0.008, (-0.01, 0.03), -1, switch=False, ds=1e-3)[0]
    ev = br.events[-1]
    assert ev.kind == "corner"
    sizes = []
    for d in (+1, -1):
        w, k, curve, pts, evs = C.corner_curve(ev, "omega", (1.98, 2.02), d, ds=4e-4)
        assert curve.at_end
        sizes.append(len(pts))
        for pt in pts:
            prob_k, Xk = curve.orbit(pt.X, pt.lam)
            ok, why = prob_k.admissible(Xk, pt.lam)
            assert ok, (pt.lam, why)
        assert evs[-1].kind in ("end", "corner", "grazing", "zero_velocity")
    # measured: one way 34 points (through omega = 2.008 and back to a grazing at
    # 1.99342), the other 4 (to another impact's corner at omega = 2)
    assert max(sizes) > 20


def test_switching_across_a_jump_follows_the_other_orbit_both_ways():
    """map2d at omega = 1.999: the ab branch ends where its b point reaches Sigma_1
    (kappa = 0.0020861, theory.word_interval); across it the letter b becomes a, and the
    word aa is the alpha fixed point (a jump of the map: the point moves), which is then
    followed both ways: down to its own collision at kappa_CC of the maps (-0.0031033,
    theory.word_interval('a')) and up to the range's end."""
    prob, X = MO.map_seed(dict(omega=1.999, kappa=0.0, r=0.8), "kappa", "ab")
    brs = C.follow(prob, X, 0.0, (-0.01, 0.01), +1, ds=1e-4)
    words = [b.word for b in brs]
    assert words[0] == "ab" and words.count("a") == 2, words
    assert "jumps" in brs[0].events[-1].detail
    lo, hi = theory.word_interval("a", -0.001, 0.8)
    ends = sorted(e.lam for b in brs[1:] for e in b.events)
    assert abs(ends[0] - lo) < 1e-12 and abs(ends[-1] - 0.01) < 1e-12


def test_period_doubling_has_a_multiplier_at_minus_one():
    """The smooth wall's period-one orbit (Fig. 1(a)) continued up from omega = 2.2 loses
    stability in a period doubling: at the located point one multiplier is -1 to 1e-9, and
    the independent finite-difference Jacobian agrees (-1 to 1e-6)."""
    prob, X = _seed(dict(omega=2.2, kappa=0.0, beta=1.0, r=0.8), "sine", "omega")
    br = C.follow(prob, X, 2.2, (2.0, 2.8), +1, ds=0.01)[0]
    pd = next(e for e in br.events if e.kind == "period_doubling")
    mu, _ = pd.problem.floquet(pd.X, pd.lam)
    assert abs(mu.real.min() + 1.0) < 1e-9
    fd, _ = _fd_multipliers(pd.problem, pd.X, pd.lam)
    assert abs(fd.real.min() + 1.0) < 1e-6


def test_a_map2d_scene_continues_and_reads_back(tmp_path):
    """`cornerbif continue` on a map2d scene writes branches whose datasets read back as
    written (the section values of every point of the cycle, those of theory.word_orbit),
    a seed word whose orbit is not admissible at the start is said and skipped, and
    `cornerbif plot` draws the branches alone (y = the maps' b)."""
    from click.testing import CliRunner

    from cornerbif.cli import main
    scene = tmp_path / "m.toml"
    scene.write_text("""[scene]
name = "m"
model = "map2d"
[system]
omega = 1.999
kappa = -0.004
r = 0.8
[initial]
count = 8
u = [0.0, 8.0]
v = [-0.05, 0.05]
[run]
transient = 2000
record = 200
[continue]
parameter = "kappa"
range = [-0.02, 0.01]
seed = ["abbgb", "ab"]
""")
    out = tmp_path / "m.h5"
    r = CliRunner().invoke(main, ["continue", str(scene), "-o", str(out)])
    assert r.exit_code == 0, r.output
    cont = CR.read(out)
    assert cont["attrs"]["model"] == "map2d" and cont["parameter"] == "kappa"
    words = [str(b["word"]) for b in cont["branches"]]
    # ab exists only for kappa in (-0.0035, 0.0021) (theory.word_interval): not at the start
    assert words == ["abbgb"] and "'ab'" in r.output and "not admissible" in r.output
    b = cont["branches"][0]
    prob, X = MO.map_seed(dict(omega=1.999, kappa=float(b["param"][3]), r=0.8), "kappa",
                         "abbgb")
    assert np.allclose(np.sort(b["section_v"][3]), np.sort(X[1::2]), rtol=0, atol=1e-12)
    r = CliRunner().invoke(main, ["plot", str(out), "-o", str(tmp_path / "m.png")])
    assert r.exit_code == 0, r.output


def test_seeds_from_a_sweep_file(tmp_path):
    """`[continue] seed_file`: the attractors of a sweep file at its grid value nearest the
    start seed the branches (here Fig. 6(a)'s beta orbit at kappa = -0.02, ending at
    kappa_C); a file swept with another system (here for the fold scene: another obstacle
    and no forcing) is refused before any work (exit 2: bad input) naming the first key
    that differs, and nothing is written."""
    from click.testing import CliRunner

    from cornerbif.cli import main
    run = CliRunner()
    sw = tmp_path / "s.h5"
    r = run.invoke(main, ["sweep", os.path.join(ROOT, "configs", "fig06a.toml"), "-o", str(sw),
                          "--no-progress", "--set", "sweep.kappa.num=12",
                          "--set", "initial.count=2", "--set", "run.transient=400"])
    assert r.exit_code == 0, r.output
    out = tmp_path / "c.h5"
    r = run.invoke(main, ["continue", os.path.join(ROOT, "configs", "cont_beta.toml"), "-o",
                          str(out), "--set", f'continue.seed_file="{sw}"'])
    assert r.exit_code == 0, r.output
    cont = CR.read(out)
    assert [str(b["word"]) for b in cont["branches"]] == ["b"]
    kc = [e["param"] for e in cont["events"] if e["kind"] == "corner"][0]
    assert abs(kc - theory.kappa_C(1.999, 0.8)) < 1e-10
    r = run.invoke(main, ["continue", os.path.join(ROOT, "configs", "cont_fold.toml"), "-o",
                          str(tmp_path / "x.h5"), "--set", f'continue.seed_file="{sw}"'])
    assert r.exit_code == 2 and "system.F" in r.output and "continue.seed_file" in r.output
    assert not (tmp_path / "x.h5").exists() and not (tmp_path / "x.h5.partial").exists()


def test_two_particle_limits_are_said():
    """What the two-particle continuation does not do is said, not crashed into: a forcing
    whose frequency is not a whole multiple of omega0 (no periodic orbit to seed)."""
    from cornerbif.models.two_particle import packed as TPM
    vals = {k: p.default for k, p in TPM.PARAMS.items()} | {"omega0": 2.0}
    x0 = [0.18982259867467574, 16.49606490380678, 1.7221809107866082, 149.66189899401783]
    with pytest.raises(C.OrbitError, match="not a whole number"):
        TO.two_particle_seed(vals | {"F1": 0.3, "Omega1": 1.3}, "kappa", x0, 1)


def test_a_seed_file_without_what_the_seed_reads_is_refused(tmp_path):
    """A flow sweep file that did not keep the impacts cannot seed: refused before any work
    (exit 2), naming the observable to keep."""
    from click.testing import CliRunner

    from cornerbif.cli import main
    sw = tmp_path / "s.h5"
    r = CliRunner().invoke(main, ["sweep", os.path.join(ROOT, "configs", "fig06a.toml"), "-o",
                                  str(sw), "--no-progress", "--set", "sweep.kappa.num=5",
                                  "--set", "initial.count=2", "--set", "run.transient=100",
                                  "--set", "output.keep=[]"])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["continue", os.path.join(ROOT, "configs", "cont_beta.toml"),
                                  "-o", str(tmp_path / "c.h5"),
                                  "--set", f'continue.seed_file="{sw}"'])
    assert r.exit_code == 2 and "does not keep 'impacts'" in r.output, r.output


def test_validate_says_what_continue_will_do():
    """`cornerbif validate` on a scene with [continue] adds a line with the parameter, the
    range, the start, the seeds and the curves' parameter (the table as resolved)."""
    from click.testing import CliRunner

    from cornerbif.cli import main
    r = CliRunner().invoke(main, ["validate", os.path.join(ROOT, "configs",
                                                           "cont_hysteresis.toml")])
    assert r.exit_code == 0, r.output
    assert ("cornerbif continue: kappa over [-0.005, 0.025] from 0.008, seeds all; corner "
            "and fold curves in omega over [1.98, 2.02]") in r.output
