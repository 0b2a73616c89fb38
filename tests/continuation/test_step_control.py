"""Continuation with its default steps: folds are not jumped, a branch stays in its range and
on the admissible set, Newton stops on its update as well as its residual, and every event
stores the orbit located there (issue 31; docs/continuation.md, "Step control").

The case: the period-one orbit on the smooth ``sine`` wall at omega = 1.999, r = 0.8,
beta = 1, continued in kappa from 0.  Its stable branch turns at a fold within 1e-4 of the
wall's crest (kappa = -1) and comes back as a saddle that ends at kappa = -1 in an impact of
zero relative velocity, where its multipliers diverge.  A step that crosses the fold also
crosses that pole, so det(J - I) changes sign twice within it: before the fold test read the
tangent's parameter component, the default steps reported no fold and no unstable point.
"""

import math

import numpy as np
import pytest
from click.testing import CliRunner

from cornerbif import continuation as C
from cornerbif import continuation_run as CR
from cornerbif.cli import main

R = 0.8
OMEGA = 1.999
SCENE = """[scene]
name = "fold1999"
model = "flow"
[system]
obstacle = "sine"
omega = 1.999
kappa = {kappa}
beta = 1.0
r = 0.8
[initial]
count = 4
seed = 1
u = [1.5, 5.0]
v = [-1.0, 1.0]
[run]
transient = 2000
record = 60
[continue]
parameter = "{param}"
range = [{lo}, {hi}]
start = {start}
{extra}
"""


def _continue(tmp_path, lo, hi, extra="", kappa=0.0, param="kappa", start=0.0):
    scene = tmp_path / "s.toml"
    scene.write_text(SCENE.format(lo=lo, hi=hi, extra=extra, kappa=kappa, param=param,
                                  start=start))
    out = tmp_path / "s.h5"
    r = CliRunner().invoke(main, ["continue", str(scene), "-o", str(out), "--overwrite"])
    assert r.exit_code == 0, r.output
    return CR.read(out)


def _folds(res):
    return [e for e in res["events"] if e["kind"] == "fold"]


@pytest.fixture(scope="module")
def fine(tmp_path_factory):
    """The fine-step run (ds = 1e-3, ds_max = 1e-2 in kappa), which found the fold before."""
    return _continue(tmp_path_factory.mktemp("fine"), -1.1, 0.1, "ds = 1e-3\nds_max = 1e-2")


@pytest.mark.parametrize("lo,hi", [(-1.1, 0.1), (-1.001, 0.05), (-1.05, 0.05), (-1.5, 0.5),
                                   (-2.0, 0.5), (-11.9, 0.1), (-119.9, 0.1)])
def test_the_fold_is_found_with_default_steps_from_any_range(tmp_path, fine, lo, hi):
    """Every range that holds the fold finds the fold of the fine-step run (to 1e-10), and
    ranges 10x and 100x as wide as the fine run's [-1.1, 0.1] find the same events; every
    stored point lies in the range and passes the admissibility test."""
    res = _continue(tmp_path, lo, hi)
    want = _folds(fine)
    assert len(want) == 1
    got = _folds(res)
    assert len(got) == 1, [(e["kind"], e["param"]) for e in res["events"]]
    assert abs(got[0]["param"] - want[0]["param"]) < 1e-10
    kinds = sorted(e["kind"] for e in res["events"] if e["kind"] != "end")
    assert kinds == sorted(e["kind"] for e in fine["events"] if e["kind"] != "end")
    for b in res["branches"]:
        assert np.all((b["param"] >= lo) & (b["param"] <= hi))
        assert np.all(b["admissible"] == 1)


def test_the_folds_multipliers_are_read_from_the_file(fine):
    """The fold's orbit is stored with its event: its multipliers are {1, r^2} (det J = r^2
    for one impact per cycle without damping) to 1e-9, and its impact lies on the wall."""
    fold = _folds(fine)[0]
    orbit = fold["orbit"]
    mu = np.sort(orbit["multiplier_re"] + 1j * orbit["multiplier_im"])
    assert np.abs(mu.imag).max() == 0.0
    assert abs(mu[0].real - R * R) < 1e-9 and abs(mu[1].real - 1.0) < 1e-9, mu
    t, u = orbit["impact_t"][0], orbit["impact_u"][0]
    assert abs(u - (fold["param"] + math.sin(OMEGA * t))) < 1e-12
    assert orbit["word"] and orbit["X"].shape == (2,)
    # the points' condition numbers (dR/dX) grow towards the fold, where dR/dX is singular
    b = fine["branches"][0]
    near = np.argmin(np.abs(b["param"] - fold["param"]))
    assert b["condition_number"][near] > 100.0 * np.median(b["condition_number"])


def closed_form_multipliers(t, u, v_in, D, kappa, beta=1.0, omega=OMEGA, r=R):
    """The multipliers of a period-one orbit with one impact per cycle of u'' + u = 0 against
    z = kappa + beta sin(omega t), from its impact state alone (written here, not taken
    from cornerbif.numerics.saltation): J = Phi(D) S, Phi the rotation of the free flight
    over the cycle's duration D and S the saltation matrix of law (5) at the impact,
    S = [[-r, 0], [-(1 + r)(u + z'')/(v- - z'), -r]]; det J = r^2, tr J = -2 r cos D +
    S21 sin D."""
    zp = beta * omega * math.cos(omega * t)
    zpp = -beta * omega * omega * math.sin(omega * t)
    s21 = -(1.0 + r) * (u + zpp) / (v_in - zp)
    tr = -2.0 * r * math.cos(D) + s21 * math.sin(D)
    disc = tr * tr - 4.0 * r * r
    root = math.sqrt(disc) if disc >= 0 else 1j * math.sqrt(-disc)
    return np.sort(np.array([(tr + root) / 2, (tr - root) / 2], complex))


def _saddle_at(kappa_end):
    """The saddle at ``kappa_end`` (between the fold and the degenerate end at -1), by the
    Python API: the stable orbit at kappa = 0 from a kernel run, continued down with fine
    steps through the fold, then up the saddle branch to a range ending at kappa_end (a
    branch ends exactly at its range's end)."""
    import cornerbif
    from cornerbif.models.flow import orbit as FO
    vals = dict(omega=OMEGA, kappa=0.0, beta=1.0, r=R)
    res = cornerbif.simulate([3.0], [0.0], obstacle="sine", transient=2000, record=60, **vals)
    prob, X = FO.seed_from_run(vals, "sine", "kappa", res["t"][0], res["v_out"][0],
                               res["corner_offset"][0], int(res["impacts_per_cycle"][0]))
    pts, evs = C.continue_branch(prob, X, 0.0, (-1.1, 0.1), -1.0, ds=1e-3, ds_max=1e-2)
    i = max(k for k, p in enumerate(pts) if abs(p.mu).max() > 1.0 and p.lam < kappa_end)
    sad = pts[i]
    pts2, evs2 = C.continue_branch(sad.problem, sad.X, sad.lam, (-1.1, kappa_end), +1.0,
                                   ds=1e-6, ds_max=1e-5)
    assert evs2[-1].detail == "the end of the range" and pts2[-1].lam == kappa_end
    return pts2[-1]


def test_the_saddles_multipliers_near_its_degenerate_end_are_the_closed_form(fine):
    """Along the saddle branch between the fold and the degenerate end, and at kappa =
    -1 - 1e-7 (where the largest multiplier is 81.5), the multipliers equal the closed form
    of the impact state to 1e-8 relative: Newton stops on its update, not on the residual
    alone (before, one more update moved the largest multiplier by 7e-4 there)."""
    b = fine["branches"][0]
    kap = b["param"]
    saddle = np.flatnonzero((b["stable"] == 0) & (kap < -1.0))
    assert saddle.size >= 1
    rows = [(kap[i], b["impact_t"][i, 0], b["impact_u"][i, 0], b["impact_v_in"][i, 0],
             b["cycle_duration"][i], b["multiplier_re"][i] + 1j * b["multiplier_im"][i])
            for i in saddle]
    pt = _saddle_at(-1.0 - 1e-7)
    imp = pt.problem.impacts(pt.X, pt.lam)
    rows.append((pt.lam, imp["t"][0], imp["u"][0], imp["v_in"][0], pt.problem.duration(pt.lam),
                 pt.mu))
    for lam, t, u, v, D, mu in rows:
        want = closed_form_multipliers(t, u, v, D, lam)
        got = np.sort(np.asarray(mu, complex))
        assert np.abs(got - want).max() <= 1e-8 * np.abs(want).max(), (lam, got, want)
    assert np.abs(rows[-1][-1]).max() > 50.0      # 81.5: the pole at kappa = -1 is near


def test_newton_stops_on_its_update_too():
    """``converged``: a small residual with an update still well above rounding and
    shrinking goes on; at rounding, or no longer shrinking, it stops."""
    assert not C.converged(1e-13, 1e-9, 1e-5, 10.0)
    assert C.converged(1e-13, 1e-15, 1e-9, 10.0)
    assert C.converged(1e-13, 1e-12, 1e-12, 10.0)          # stagnating: rounding noise
    assert not C.converged(1e-9, 1e-16, 1e-9, 10.0)        # the residual too large


def test_a_branch_never_leaves_its_range(tmp_path):
    """Continued in omega over [1.5, 2.5] from kappa = -1.00005 (the branch turns at its
    fold at omega = 1.99929 and comes back as a saddle): before, a point was stored at
    omega = 0.33, below the range.  Now every point lies in the range and each end that is
    the range's end sits on it exactly."""
    res = _continue(tmp_path, 1.5, 2.5, kappa=-1.00005, param="omega", start=1.999)
    for b in res["branches"]:
        assert np.all((b["param"] >= 1.5) & (b["param"] <= 2.5)), b["param"].min()
        assert np.all(b["cycle_duration"] > 0.0)
        assert np.all(b["admissible"] == 1)
    ends = [e for e in res["events"] if e["detail"] == "the end of the range"]
    assert ends and all(e["param"] in (1.5, 2.5) for e in ends)
    assert len(_folds(res)) == 1


def test_the_fold_curve_ends_where_the_impact_velocity_vanishes(tmp_path):
    """The fold of the omega continuation above, continued in kappa over [-1.01, -0.99]:
    its orbits stay orbits of the flow and the curve ends at the wall's crest with a
    zero-velocity impact, at (kappa, omega) = (-1, 2) to 1e-12.  Before, it ran on to
    omega = 2.00045, where the impact arrives from below; the fold equation is now scaled by
    the impacts' velocities (``FoldCurve._condition``), which cancels the multipliers' pole."""
    res = _continue(tmp_path, 1.5, 2.5, kappa=-1.00005, param="omega", start=1.999,
                    extra='curve = "kappa"\ncurve_range = [-1.01, -0.99]')
    (curve,) = res["curves"]
    assert curve["ends"].startswith("zero_velocity at kappa = -1;"), curve["ends"]
    k = int(np.argmax(curve["param"]))
    assert abs(curve["param"][k] + 1.0) < 1e-12 and abs(curve["event_param"][k] - 2.0) < 1e-12
    assert np.all(curve["event_param"] <= 2.0 + 1e-12)


def test_a_step_whose_multipliers_jump_is_retried():
    """``_check_multipliers_continuous``: multipliers that move by more than a quarter of
    (1 + the largest) in one step reject it; a move through a pole (an ending test function
    changing sign, or a slow impact at either end) and a small move do not."""
    calm = {k: np.array([1.0]) for k in ("corner", "grazing", "zero_velocity")}
    C._check_multipliers_continuous([0.8, 0.5], [0.82, 0.49], calm, calm)
    with pytest.raises(C.StepRejected, match="multipliers jumped"):
        C._check_multipliers_continuous([0.8, 0.5], [0.8, -0.9], calm, calm)
    crossing = dict(calm, grazing=np.array([-1.0]))
    C._check_multipliers_continuous([0.8, 0.5], [0.8, -0.9], calm, crossing)
    slow = dict(calm, zero_velocity=np.array([1e-3]))
    C._check_multipliers_continuous([0.8, 0.5], [30.0, 0.01], calm, slow)


def _fold_system():
    """cont_fold's system (u'' + u = cos 2.5t against the wall u = kappa, r = 0.8): its
    stable period-one orbit at kappa = 0.5 and its fold at 1.4054798431."""
    import cornerbif
    from cornerbif.models.flow import orbit as FO
    vals = dict(omega=2.5, kappa=0.5, beta=0.0, r=0.8, sigma=0.0, F=1.0, Omega=2.5)
    res = cornerbif.simulate([1.5], [0.0], obstacle="sine", transient=3000, record=60, **vals)
    return FO.seed_from_run(vals, "sine", "kappa", res["t"][0], res["v_out"][0],
                            res["corner_offset"][0], int(res["impacts_per_cycle"][0]))


@pytest.mark.parametrize("gap", [1e-5, 1.4e-5])
def test_no_fold_is_reported_beyond_the_range(gap):
    """A range ending just before the fold: the step that crosses the range's end also
    crosses the fold and comes back.  Found in review: the tangent at the point outside the
    range made a fold be located at the range's end, and a step out and back within the
    range reported the fold outside it.  Now the branch ends at the range's end, exactly,
    with no fold."""
    prob, X = _fold_system()
    hi = 1.4054798431 - gap
    pts, evs = C.continue_branch(prob, X, 0.5, (-0.5, hi), +1, ds=0.01)
    assert [e.kind for e in evs] == ["end"] and evs[-1].detail == "the end of the range"
    assert pts[-1].lam == hi and all(p.lam <= hi for p in pts)


def test_an_event_read_from_an_older_file_has_no_orbit_and_writes_back(tmp_path):
    """A partial file written before events stored their orbit: its events read back with
    an empty orbit, and the file written from them (a resume) reads back again.  Found in
    review: an empty orbit group without its word made the resumed file unreadable."""
    res = _continue(tmp_path, 1.5, 2.5, kappa=-1.00005, param="omega", start=1.999)
    path = tmp_path / "s.h5"
    attrs, branches, curves, _ = CR._load(path)
    for b in branches:
        b["events"] = [e[:4] + ({},) for e in b["events"]]
    from cornerbif import config
    scene = config.loads((tmp_path / "s.toml").read_text())
    head = {"created": attrs["created"], "seeds": attrs["seeds"], "completed": attrs["created"]}
    again = tmp_path / "again.h5"
    again.write_bytes(CR._image(scene, head, branches, curves))
    back = CR.read(again)
    assert [e["kind"] for e in back["events"]] == [e["kind"] for e in res["events"]]
    assert all(e["orbit"] == {} for e in back["events"])


def test_a_grazing_past_the_branch_limit_says_it_is_not_continued():
    """Found in review: the last grazing of a cascade said its new orbit was continued when
    the branch limit had dropped it."""
    prob, X = _fold_system()
    brs = C.follow(prob, X, 0.5, (-0.5, 1.6), +1, ds=0.01, max_branches=2)
    assert len(brs) == 2
    assert "is continued as" in brs[0].events[-1].detail
    last = brs[1].events[-1]
    assert last.kind == "grazing" and "is not continued (at most" in last.detail


def test_the_hysteresis_alpha_beta_gamma_curve_ends_at_its_corner(tmp_path):
    """cont_hysteresis: the corner curve of the alpha-beta-gamma orbit ends at omega = 2,
    where three impacts sit at corners at once: the end is the corner collision (a grazing
    located at a corner is one), also on a curve (found in review: it was called a
    grazing)."""
    out = tmp_path / "h.h5"
    r = CliRunner().invoke(main, ["continue", "configs/cont_hysteresis.toml", "-o", str(out)])
    assert r.exit_code == 0, r.output
    ends = [c["ends"] for c in CR.read(out)["curves"]]
    assert any("corner at omega = 2" in e for e in ends), ends
    assert not any("grazing at omega = 2" in e for e in ends), ends
