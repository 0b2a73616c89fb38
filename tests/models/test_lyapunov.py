"""Lyapunov exponents through flights, impacts and corners (cornerbif/stability.py,
docs/stability.md, "Lyapunov exponents").

Each against something independent of the QR code: the cycle's Floquet multipliers
(lambda_i = log|mu_i| / duration), the closed-form determinant (lambda_1 + lambda_2),
Benettin's two-trajectory estimate run on the slow exhaustive simulator tests/naive.py (no
code of cornerbif), and for the maps a generic QR of the product of their linear parts.
"""

import math
import os
import sys

import fd_reference as FD
import numpy as np
import pytest

import cornerbif
from cornerbif import stability as S
from cornerbif.models.flow import tangent as FT
from cornerbif.models.map2d import tangent as MT

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _run(omega, record, obstacle="rectified_sine", u0=5.0, v0=0.0, transient=600, **system):
    res = cornerbif.simulate([u0], [v0], omega=omega, kappa=0.0, obstacle=obstacle,
                             transient=transient, record=record, keep=["impacts", "stability"],
                             **system)
    return {k: v[0] for k, v in res.items()}


def _floquet(res):
    mu = res["mu_re"] + 1j * res["mu_im"]
    return mu, np.log(np.abs(mu)) / res["cycle_duration"]


@pytest.mark.parametrize("omega,system", [(1.8, {}), (2.3, {"sigma": 0.02, "k": 1.2})])
def test_real_multipliers_give_the_exponents_to_1e8(omega, system):
    """Cycles with real multipliers (a period-4 cycle of four impacts at omega = 1.8; a
    damped two-impact cycle): after the warm-up the basis is aligned with the leading
    eigenvector, so over whole cycles lambda_i = log|mu_i| / duration to rounding
    (measured 6e-11 and 3e-12 with 200 recorded impacts)."""
    res = _run(omega, 200, **system)
    mu, want = _floquet(res)
    assert res["stability_status"] == S.OK and res["lyapunov_status"] == S.OK
    assert np.all(mu.imag == 0) and abs(mu[0]) > abs(mu[1])
    assert np.allclose(res["lyapunov"], want, rtol=0, atol=1e-8), (res["lyapunov"], want)


@pytest.mark.parametrize("omega,record", [(1.5, 200), (2.3, 200), (2.1, 1000)])
def test_complex_pair_exponents_within_the_conditioning_bound(omega, record):
    """Period-1 cycles with a complex pair |mu| e^(+-i theta): the exact exponents are both
    log|mu| / T, and a finite window can only reach them up to the shape of the rotation:
    with J = P (|mu| R_theta) P^-1 (P = [Re v, Im v], v an eigenvector of the monodromy
    at the window's first impact), |J^N q| / |mu|^N lies in [1/cond(P), cond(P)] for a
    unit q, so |lambda_1 - log|mu|/T| <= log cond(P) / window (measured errors 2.0e-3,
    6.6e-4, 2.2e-4 against bounds 2.2e-3, 2.3e-3, 3.4e-4).  The sum is exact: lambda_1 + lambda_2 =
    (2 N log r - 2 sigma W) / W (det S = r^2, det M = exp(-2 sigma tau))."""
    res = _run(omega, record)
    mu, want = _floquet(res)
    assert mu[0].imag != 0
    win = res["lyapunov_window"]
    n = int(np.isfinite(res["t"]).sum())
    first = n - 1 - int(round(win / res["cycle_duration"])) * int(res["impacts_per_cycle"])
    assert math.isclose(res["t"][n - 1] - res["t"][first], win, rel_tol=1e-12)
    prm = cornerbif.models.flow.packed.pack(dict(omega=omega, kappa=0.0), "rectified_sine",
                                       1e-12, 1e-6, 1e6, None)
    J = FT.cycle_multipliers(prm, res["t"], res["u"], res["v_in"], res["v_out"],
                            res["corner_offset"], first, int(res["impacts_per_cycle"]))
    w, V = np.linalg.eig(J["jacobian"])
    P = np.column_stack([V[:, 0].real, V[:, 0].imag])
    bound = math.log(np.linalg.cond(P)) / win
    err = np.abs(res["lyapunov"] - want)
    assert err.max() <= bound, (err, bound)
    n_imp = n - 1 - first
    assert math.isclose(res["lyapunov"].sum(), 2 * n_imp * math.log(0.8) / win, rel_tol=1e-12)


def test_a_window_that_sticks_has_exponents_minus_infinity():
    """Smooth wall (sine), omega = 5: the particle sticks once a period (the record's
    flights do not join its impacts): the tangent collapses to zero, lambda = -inf, and the
    cycle's multipliers are exactly 0 (docs/stability.md, sticking)."""
    res = _run(5.0, 100, obstacle="sine", transient=500)
    assert res["lyapunov_status"] == S.STICKING and res["stability_status"] == S.STICKING
    assert np.all(res["lyapunov"] == -np.inf)
    assert np.all(res["mu_re"] == 0) and np.all(res["mu_im"] == 0)


@pytest.mark.parametrize("omega,chaotic", [(2.85, True), (1.5, False)])
def test_fig1a_exponent_against_benettin_on_the_slow_simulator(omega, chaotic):
    """Fig. 1(a) (smooth wall, r = 0.8): at omega = 2.85 (no cycle found, a chaotic
    window) the largest exponent is positive, at omega = 1.5 (period 1) negative, and both
    agree with Benettin's estimate on the independent simulator over a window of the same
    length, started from the kernel's last section state, within 0.05 on the chaotic
    window (the spread of either estimate over windows of ~1200 time units is about 0.01
    at omega = 2.85, one standard deviation over 16 starts, docs/stability.md) and 5e-3
    on the periodic one (a complex pair: the finite-window bound); measured 0.2053 against
    0.1968, and -0.05315 against -0.05345."""
    res = _run(omega, 1000, obstacle="sine", transient=500)
    lam = res["lyapunov"][0]
    assert res["lyapunov_status"] == S.OK
    T = 2 * math.pi / omega
    n_sec = int(np.isfinite(res["su"]).sum())
    t0 = n_sec * T           # the kernel's last recorded section, t = n T (sections 1..n)
    periods = int(res["lyapunov_window"] / T)
    ref = FD.benettin(omega, res["su"][n_sec - 1], res["sv"][n_sec - 1], t0, periods)
    if chaotic:
        assert res["period"] == 0 and lam > 0.1 and ref > 0.1
        assert abs(lam - ref) < 0.05, (lam, ref)
    else:
        assert res["period"] == 1 and lam < -0.02 and ref < -0.02
        assert abs(lam - ref) < 5e-3, (lam, ref)


# ------------------------------------------------------------------ the maps
def test_map_exponents_are_the_mean_log_of_s_and_agree_with_a_generic_qr():
    """map2d: lambda_1 = lambda_2 = mean log|s| per iterate (eq 57, exact), equal to
    log|mu| / period of the cycle's double multiplier to 1e-12; a generic QR started at
    (e1, e2) on the same products (numpy) converges to it like log(N)/N (the Jordan
    block), within (log(N h) + 1)/N."""
    res = cornerbif.simulate([0.01], [0.0], model="map2d", omega=1.999, kappa=-0.004,
                             transient=2000, record=400, keep=["stability"])
    res = {k: v[0] for k, v in res.items()}
    assert res["stability_status"] == S.OK and res["lyapunov_status"] == S.OK
    mu, want = _floquet(res)
    assert np.allclose(res["lyapunov"], want, rtol=1e-12, atol=0)
    # generic QR over the recorded regions: the linear parts (theory.map_matrices)
    from cornerbif import theory
    word = res["symbols"]
    per = int(res["period"])
    h = math.pi * (1.999 - 2.0) / 2
    N = 400
    Q = np.eye(2)
    logs = np.zeros(2)
    steps = (word * (N // len(word) + 1))[:N] if word else ""
    for ch in steps:
        A, _ = theory.map_matrices(ch, 1.999 - 2.0, -0.004, 0.8)
        Q, R = np.linalg.qr(A @ Q)
        logs += np.log(np.abs(np.diag(R)))
    lam_qr = np.sort(logs / len(steps))[::-1]
    assert per > 0 and len(steps) == N
    assert np.all(np.abs(lam_qr - res["lyapunov"]) <= (math.log(N * abs(h) + 1) + 1) / N)


# ------------------------------------------------------------------ the plots
@pytest.mark.slow
def test_plot_colours_by_stability_and_refuses_without_it(tmp_path):
    """`cornerbif plot --color-by lyapunov|multiplier` draws a diagram and a chart from
    files kept with "stability"; a file without it is refused with the way to get it, and
    a scene asking `[plot] color_by` without keeping "stability" is refused before it
    runs."""
    from click.testing import CliRunner

    from cornerbif.cli import main
    root = os.path.join(os.path.dirname(__file__), "..", "..", "configs")
    run = CliRunner()
    diag, chart, plain = tmp_path / "d.h5", tmp_path / "c.h5", tmp_path / "p.h5"
    r = run.invoke(main, ["sweep", os.path.join(root, "fig01a_lyapunov.toml"), "-o",
                          str(diag), "--no-progress", "--set", "sweep.omega.num=40",
                          "--set", "initial.count=2", "--set", "run.transient=100",
                          "--set", "run.record=60"])
    assert r.exit_code == 0, r.output
    r = run.invoke(main, ["sweep", os.path.join(root, "chart_flow_lyapunov.toml"), "-o",
                          str(chart), "--no-progress", "--set", "sweep.omega.num=6",
                          "--set", "sweep.kappa.num=5", "--set", "initial.count=2",
                          "--set", "run.transient=100", "--set", "run.record=40"])
    assert r.exit_code == 0, r.output
    for f in (diag, chart):
        for what in ("lyapunov", "multiplier"):
            png = tmp_path / f"{f.stem}_{what}.png"
            r = run.invoke(main, ["plot", str(f), "-o", str(png), "--color-by", what])
            assert r.exit_code == 0, r.output
            assert png.stat().st_size > 10_000
    r = run.invoke(main, ["sweep", os.path.join(root, "fig01a.toml"), "-o", str(plain),
                          "--no-progress", "--set", "sweep.omega.num=5",
                          "--set", "initial.count=1", "--set", "run.transient=10",
                          "--set", "run.record=10"])
    assert r.exit_code == 0, r.output
    r = run.invoke(main, ["plot", str(plain), "-o", str(tmp_path / "x.png"),
                          "--color-by", "lyapunov"])
    assert r.exit_code == 2 and "stability" in r.output and "output.keep" in r.output
    r = run.invoke(main, ["validate", os.path.join(root, "fig01a_lyapunov.toml"),
                          "--set", 'output.keep=["impacts"]'])
    assert r.exit_code == 2 and "plot.color_by" in r.output
    r = run.invoke(main, ["validate", os.path.join(root, "fig01a_lyapunov.toml"),
                          "--set", 'plot.color_by="period"'])
    assert r.exit_code == 2 and "plot.color_by: 'period' is not allowed" in r.output


def test_map_exponents_use_the_finite_prefix():
    """A region < 0 marks an iterate that was not finite: the exponents average over the
    finite steps before it (log r for beta, 2 log r for alpha); none at all: NO_WINDOW."""
    r = 0.8
    regions = np.array([1, 0, 2, -1, 1], np.int8)
    lam1, lam2, n, st = MT.map_lyapunov(r, regions)
    assert st == S.OK and n == 3
    assert math.isclose(lam1, (4 * math.log(r)) / 3, rel_tol=1e-15) and lam1 == lam2
    assert MT.map_lyapunov(r, np.array([-1, 1], np.int8))[3] == S.NO_WINDOW
