"""Floquet multipliers and Lyapunov exponents of the two-particle model (section 6,
cornerbif/stability.py, docs/stability.md "Two particles").

Against the independent finite-difference reference tests/fd_reference_two_particle.py
(exhaustive event search and closed-form flights in numpy/scipy, no code of cornerbif),
the closed-form determinant, and the multipliers themselves for the exponents.
"""

import math
import os
import sys

import numpy as np
import pytest

import cornerbif
from cornerbif import stability as S
from cornerbif.models.two_particle import tangent as TT
from cornerbif.numerics import saltation as SAL

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import fd_reference_two_particle as FR  # noqa: E402
from test_fd_reference_two_particle import ATTRACTORS, P13  # noqa: E402

CASES = dict(ATTRACTORS, fig19_w1_9995_P13=P13)


def _kernel(p, x0, record=60):
    """cornerbif's run from the cycle point x0 at t = 0 (the system has period
    T = 2 pi / omega0 and no forcing, so the cycle's point at t0 = n T is one at t = 0)."""
    res = cornerbif.simulate(*x0, model="two_particle", transient=4, record=record,
                             keep=["stability"], **p)
    return {k: v[0] for k, v in res.items()}


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(CASES))
def test_multipliers_match_the_fd_reference(name):
    """The four multipliers equal the eigenvalues of the reference's central-difference
    Jacobian of the time map over one cycle (P wall periods) to 1e-6: Fig. 19's orbits of
    periods 1, 3 and 13 (the last with a w-z and a z-u impact 3e-7 apart in time, this
    model's corner), a damped one and mu = 3.  The reference's own error estimate is below
    2e-7 on every entry (its report)."""
    p, _, P, x0, _ = CASES[name]
    T = 2 * math.pi / p["omega0"]
    res = _kernel(p, x0)
    assert res["stability_status"] == S.OK, S.REASONS[int(res["stability_status"])]
    assert math.isclose(res["cycle_duration"], P * T, rel_tol=1e-9)
    J, err = FR.fd_jacobian(p, np.array(x0), 0.0, P * T)
    want = np.linalg.eigvals(J)
    got = res["mu_re"] + 1j * res["mu_im"]
    # pair each multiplier with its nearest reference eigenvalue
    for g in got:
        assert np.min(np.abs(want - g)) < 1e-6, (got, want, err.max())
    assert np.all(np.abs(got[:-1]) >= np.abs(got[1:]))        # sorted by modulus


@pytest.mark.parametrize("name", sorted(ATTRACTORS))
def test_monodromy_determinant_is_the_closed_form(name):
    """det J = exp(-2 (sigma1 + sigma2) T_cycle) r1^(2 N_wz) r2^(2 N_zu) (Liouville for the
    flights, det = r^2 for both impact laws' saltations) to 1e-10 relative, the N's counted
    from the recorded tables."""
    p, _, P, x0, kinds = ATTRACTORS[name]
    res = cornerbif.simulate(*x0, model="two_particle", transient=4, record=60,
                             keep=["impacts", "wall_impacts", "stability"], **p)
    from cornerbif.models.two_particle import packed as TP
    r = cornerbif.simulate(*x0, model="two_particle", transient=4, record=60, **p)
    zu = np.stack([r[k].reshape(-1) for k in ("t", "u", "v_in", "v_out", "y_in", "y_out",
                                              "corner_offset")], -1)[None]
    wz = np.stack([r[k].reshape(-1) for k in ("wz_t", "wz_z", "wz_y_in", "wz_y_out")],
                  -1)[None]
    ipc = np.asarray(r["impacts_per_cycle"]).reshape(1).astype(np.int64)
    prm = TP.pack({k: v.default for k, v in TP.PARAMS.items()} | p)[None]
    out = TT.two_particle_outputs(prm, np.ascontiguousarray(zu), np.ascontiguousarray(wz), ipc)
    n = int(np.isfinite(zu[0, :, 0]).sum())
    t0, t1 = zu[0, n - 1 - ipc[0], 0], zu[0, n - 1, 0]
    n_wz = int(((wz[0, :, 0] > t0) & (wz[0, :, 0] <= t1)).sum())
    assert n_wz == kinds.count("W") and ipc[0] == kinds.count("U")
    sig = p.get("sigma1", 0.0) + p.get("sigma2", 0.0)
    want = math.exp(-2 * sig * (t1 - t0)) * p["r1"] ** (2 * n_wz) * p["r2"] ** (2 * ipc[0])
    assert math.isclose(np.linalg.det(out["monodromy"][0]), want, rel_tol=1e-10)
    # the model's run_items gives the file the same numbers (wiring, not a second check)
    assert np.allclose(out["mu_re"][0], res["mu_re"][0], rtol=0, atol=0)


@pytest.mark.parametrize("name", sorted(ATTRACTORS))
def test_exponents_sum_to_the_determinant_and_bracket_the_multipliers(name):
    """The four exponents over the window (QR after every event) sum to log|det| / window
    = (2 N_wz log r1 + 2 N_zu log r2) / W - 2 (sigma1 + sigma2) to 1e-10; each lies within
    log cond(V) / W of log|mu_i| / T_cycle for the multiplier of its rank (V the
    eigenvectors of the cycle's monodromy: the finite-window bound of a complex pair,
    tests/models/test_lyapunov.py), the window 400 impacts long."""
    p, _, P, x0, kinds = ATTRACTORS[name]
    res = _kernel(p, x0, record=400)
    assert res["lyapunov_status"] == S.OK
    W = res["lyapunov_window"]
    cycles = round(W / res["cycle_duration"])
    n_wz, n_zu = cycles * kinds.count("W"), cycles * kinds.count("U")
    sig = p.get("sigma1", 0.0) + p.get("sigma2", 0.0)
    want = (2 * n_wz * math.log(p["r1"]) + 2 * n_zu * math.log(p["r2"])) / W - 2 * sig
    assert math.isclose(res["lyapunov"].sum(), want, rel_tol=1e-10)
    mu = res["mu_re"] + 1j * res["mu_im"]
    pred = np.log(np.abs(mu)) / res["cycle_duration"]
    assert np.all(np.diff(res["lyapunov"]) <= 0)
    J, _ = FR.fd_jacobian(p, np.array(x0), 0.0, P * 2 * math.pi / p["omega0"])
    _, V = np.linalg.eig(J)
    bound = math.log(np.linalg.cond(V)) / W + 1e-12
    assert np.all(np.abs(res["lyapunov"] - pred) <= bound), (res["lyapunov"], pred, bound)


def test_a_two_particle_sweep_stores_four_multipliers_and_exponents(tmp_path):
    """Fig. 19(a), shrunk, keeping "stability": four multipliers (sorted, all stable) and
    exponents (sorted, negative) per run under stability/ with their scales (xarray);
    `cornerbif info` summarises them."""
    import h5py
    from click.testing import CliRunner

    from cornerbif.cli import main
    out = tmp_path / "tp.h5"
    scene = os.path.join(os.path.dirname(__file__), "..", "..", "configs", "fig19a.toml")
    r = CliRunner().invoke(main, ["sweep", scene, "-o", str(out), "--no-progress",
                                  "--set", "sweep.omega0.num=4", "--set", "initial.count=2",
                                  "--set", "run.transient=200", "--set", "run.record=40",
                                  "--set", 'output.keep=["impacts", "stability"]'])
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        assert f["stability/multiplier_re"].shape == (4, 2, 4)
        assert f["stability/lyapunov"].shape == (4, 2, 4)
        st = f["stability/status"][...]
        assert (st == S.OK).sum() >= 6
        mod = np.hypot(f["stability/multiplier_re"][...], f["stability/multiplier_im"][...])
        ok = st == S.OK
        assert np.all(mod[ok] < 1) and np.all(np.diff(mod[ok], axis=-1) <= 1e-15)
        lam = f["stability/lyapunov"][...][f["stability/lyapunov_status"][...] == S.OK]
        assert lam.size and np.all(lam < 0) and np.all(np.diff(lam, axis=-1) <= 0)
    xr = pytest.importorskip("xarray")
    pytest.importorskip("h5netcdf")
    with xr.open_dataset(out, engine="h5netcdf", group="stability") as ds:
        assert ds["multiplier_im"].dims == ("omega0", "ic", "multiplier")
        assert ds["lyapunov"].dims == ("omega0", "ic", "exponent")
    r = CliRunner().invoke(main, ["info", str(out)])
    assert "largest Lyapunov exponent over the window" in r.output


def _tables(p, x0, record=12):
    r = cornerbif.simulate(*x0, model="two_particle", transient=0, record=record, **p)
    zu = np.stack([r[k].reshape(-1) for k in ("t", "u", "v_in", "v_out", "y_in", "y_out",
                                              "corner_offset")], -1)
    wz = np.stack([r[k].reshape(-1) for k in ("wz_t", "wz_z", "wz_y_in", "wz_y_out")], -1)
    return zu, wz


def _flights(p, tau):
    """blockdiag(M_z(tau), M_u(tau)) (tau may be negative: a flight run backwards)."""
    F = np.zeros((4, 4))
    F[:2, :2] = np.reshape(SAL.flight_matrix(p.get("sigma1", 0.0), p["omega1"], tau), (2, 2))
    F[2:, 2:] = np.reshape(SAL.flight_matrix(p.get("sigma2", 0.0), p["omega2"], tau), (2, 2))
    return F


@pytest.mark.parametrize("case", ["forced", "mu_inf"])
def test_steps_between_mid_flight_times_match_the_fd_reference(case):
    """Beyond cycles: the product of two_particle_steps over a stretch of a transient (the
    forced and damped case of the reference's self-tests, mu = 5, and Fig. 19 with
    mu = inf, law (74) as law (5) against z), conjugated by the flights to mid-flight
    times t_a (after the stretch's first z-u impact) and t_b (after its last), equals the
    reference's central-difference Jacobian of the time map t_a -> t_b to 1e-7."""
    from test_fd_reference_two_particle import FORCED

    from cornerbif.models.two_particle import packed as TP
    if case == "forced":
        p, x0 = dict(FORCED), [1.0, 0.5, 3.0, -1.0]
    else:
        p, x0 = dict(ATTRACTORS["fig19_w2.000_P1"][0], mu=math.inf), [0.3, 1.0, 2.0, 3.0]
    full = {k: v.default for k, v in TP.PARAMS.items()} | p
    zu, wz = _tables(full, x0)
    i0, i1 = 0, 2
    G, times, st = TT.two_particle_steps(TP.pack(full), zu, wz, i0, i1)
    assert st == S.OK and len(G) >= 2
    t_i0, t_i1 = zu[i0, 0], zu[i1, 0]
    nxt = zu[i1 + 1, 0] if np.isfinite(zu[i1 + 1, 0]) else t_i1 + 0.2
    later = [t for t in wz[:, 0] if np.isfinite(t) and t > t_i1]
    t_b = 0.5 * (t_i1 + min([nxt] + later))
    t_a = 0.5 * (t_i0 + times[0])      # after impact i0, before the next event
    P = np.eye(4)
    for g in G:
        P = g @ P
    J = _flights(full, t_b - t_i1) @ P @ _flights(full, t_i0 - t_a)
    xa = FR.state_at(full, np.array(x0), 0.0, t_a).x
    Jfd, err = FR.fd_jacobian(full, xa, t_a, t_b - t_a)
    assert np.abs(J - Jfd).max() < 1e-7 * max(1.0, np.abs(Jfd).max()), (J, Jfd, err.max())


def test_a_full_wall_table_is_said_not_read_as_sticking():
    """When the w-z table filled before the cycle's end (its last row is recorded and
    earlier than the last z-u impact), impacts may be missing: status TABLE_FULL, not a
    particle that sticks."""
    from cornerbif.models.two_particle import packed as TP
    p, _, _, x0, _ = ATTRACTORS["fig19_w1.999_P3"]
    full = {k: v.default for k, v in TP.PARAMS.items()} | p
    zu, wz = _tables(full, x0, record=40)
    n_wz = int(np.isfinite(wz[:, 0]).sum())
    short = np.ascontiguousarray(wz[: n_wz // 2])          # a full table of half the rows
    out = TT.two_particle_outputs(TP.pack(full)[None], zu[None], short[None],
                                 np.array([3], np.int64))
    assert out["stability_status"][0] == S.TABLE_FULL
    assert out["lyapunov_status"][0] == S.TABLE_FULL
    assert np.isnan(out["mu_re"][0]).all()
