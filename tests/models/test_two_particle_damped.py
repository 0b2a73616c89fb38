"""Damping and forcing per particle in the ``two_particle`` model (issue 4: "damping and
forcing allowed as in flow"): z'' + 2 sigma1 z' + omega1^2 z = F1 cos(Omega1 t + phi1),
u'' + 2 sigma2 u' + omega2^2 u = F2 cos(Omega2 t + phi2) in flight (eqs 4, 73).

References: scipy's solve_ivp at tight tolerance, the ``flow`` kernel, the slow
independent simulator ``tests/naive.py`` (its own closed-form flights and an
exhaustive grid + brentq search of gap minima), and conservation laws.
"""

import math

import naive
import numba
import numpy as np
import pytest
from scipy.integrate import solve_ivp

import cornerbif
from cornerbif import config, simulate
from cornerbif import status as S
from cornerbif.models.two_particle import packed as P

DAMP = dict(sigma1=0.1, sigma2=0.05, F1=0.4, Omega1=1.7, phi1=0.3, F2=0.6, Omega2=2.3, phi2=-1.0)
BASE = dict(omega0=2.0, omega1=1.3, omega2=0.9, mu=5.0, r1=0.7, r2=0.6, kappa=-0.5, beta=0.8)


def _rhs(p):
    def f(t, x):
        z, y, u, v = x
        fz = p["F1"] * math.cos(p["Omega1"] * t + p["phi1"])
        fu = p["F2"] * math.cos(p["Omega2"] * t + p["phi2"])
        return [y, -2 * p["sigma1"] * y - p["omega1"] ** 2 * z + fz,
                v, -2 * p["sigma2"] * v - p["omega2"] ** 2 * u + fu]
    return f


@pytest.mark.parametrize("extra", [
    dict(DAMP),                                                    # under-damped, forced
    dict(DAMP, sigma1=1.3, sigma2=0.0),                            # z critically damped
    dict(DAMP, sigma1=0.0, F1=0.0, sigma2=2.5),                    # u over-damped
])
def test_damped_forced_flight_matches_solve_ivp(extra):
    """Free flights (wall far below, u far above): the section states every 0.05 (a
    non-multiple of the wall period, so the forcing phases are carried across sections)
    before the first event equal solve_ivp (rtol = atol = 1e-12) to 1e-9."""
    p = dict(BASE, kappa=-100.0, beta=0.0, **extra)
    ic = (1.0, 0.5, 30.0, -1.0)
    a = cornerbif.simulate(*ic, transient=0, record=80, section_period=0.05, **p, model="two_particle")
    t_ev = min(np.nanmin(a["t"][0], initial=np.inf), np.nanmin(a["wz_t"][0], initial=np.inf))
    st = a["st"][0]
    ok = np.isfinite(st) & (st < t_ev)
    assert ok.sum() >= 30
    sol = solve_ivp(_rhs(p), (0.0, st[ok].max()), ic, t_eval=st[ok], rtol=1e-12, atol=1e-12,
                    method="DOP853")
    got = np.stack([a["sz"][0][ok], a["sy"][0][ok], a["su"][0][ok], a["sv"][0][ok]])
    assert np.abs(got - sol.y).max() < 1e-9


@pytest.mark.parametrize("omega, u0, v0, r, extra", [
    (2.5, 3.0, 0.0, 0.8, dict(sigma2=0.05, F2=0.3, Omega2=1.3, phi2=0.4)),
    (1.7, 2.0, 1.0, 0.8, dict(sigma2=0.2)),
    (2.1, 5.0, -1.0, 0.5, dict(F2=1.5, Omega2=2.1, phi2=-0.7)),
])
def test_damped_forced_u_on_rectified_sine_matches_flow(omega, u0, v0, r, extra):
    """z held on the rectified-sine path |sin(omega t)| (wall fixed at 0, r1 = 1,
    omega1 = omega, z(0) = 0, y(0) = omega, mu = inf: the existing reduction test) and
    damping + forcing on u: u sees eq (8) with kappa = 0, beta = 1, so its impacts must
    equal the ``flow`` kernel's with the same sigma, F, Omega, phi (k = omega2 = 1), to
    1e-9 (both locate events to tol = 1e-12)."""
    a = cornerbif.simulate(0.0, omega, u0, v0, transient=0, record=20, omega0=omega,
                              omega1=omega, omega2=1.0, mu=math.inf, r1=1.0, r2=r,
                              kappa=0.0, beta=0.0, **extra, model="two_particle")
    fl = {{"sigma2": "sigma", "F2": "F", "Omega2": "Omega", "phi2": "phi"}[k]: v
          for k, v in extra.items()}
    b = simulate(u0, v0, transient=0, record=20, obstacle="rectified_sine", omega=omega,
                 kappa=0.0, beta=1.0, r=r, **fl)
    assert a["status"][0] == S.OK and b["status"][0] == S.OK
    for k in ("t", "u", "v_in", "v_out"):
        assert np.abs(a[k] - b[k]).max() < 1e-9, k


def _replay(p, ic, a, t_end):
    """Rebuild both damped, forced free flights from the recorded events with the
    independent closed forms of ``naive.free_flight`` (events sorted by time, w-z first
    at equal times: the documented policy) and sample both gaps every 1e-3."""
    ev = [(t, 0, z, yo, 0.0) for t, z, yo in zip(a["wz_t"][0], a["wz_z"][0], a["wz_y_out"][0])
          if np.isfinite(t)]
    ev += [(t, 1, u, yo, vo) for t, u, yo, vo in zip(a["t"][0], a["u"][0], a["y_out"][0],
                                                       a["v_out"][0]) if np.isfinite(t)]
    ev.sort(key=lambda e: (e[0], e[1]))
    zk = dict(sigma=p["sigma1"], k=p["omega1"], F=p["F1"], Omega=p["Omega1"], phi=p["phi1"])
    uk = dict(sigma=p["sigma2"], k=p["omega2"], F=p["F2"], Omega=p["Omega2"], phi=p["phi2"])
    zr = (0.0, ic[0], ic[1])
    ur = (0.0, ic[2], ic[3])

    def wall(t):
        return p["kappa"] + p["beta"] * np.sin(p["omega0"] * t)

    worst = np.inf
    t_prev = 0.0
    n = 0
    for t, kind, x, yo, vo in ev:
        if t > t_end:
            break
        ts = np.linspace(t_prev, t, max(3, int((t - t_prev) / 1e-3)))[1:-1]
        if ts.size:
            z, _ = naive.free_flight(ts, *zr, **zk)
            u, _ = naive.free_flight(ts, *ur, **uk)
            worst = min(worst, (z - wall(ts)).min(), (u - z).min())
        zt, _ = naive.free_flight(t, *zr, **zk)
        assert abs(zt - x) < 1e-8
        if kind == 1:
            ut, _ = naive.free_flight(t, *ur, **uk)
            assert abs(ut - x) < 1e-8
            ur = (t, x, vo)
        zr = (t, x, yo)
        t_prev = t
        n += 1
    return worst, n


@pytest.mark.parametrize("extra", [DAMP, dict(DAMP, sigma1=1.3, sigma2=1.5, F2=2.0)])
def test_no_impact_is_missed_with_damping_and_forcing(extra):
    """Between recorded events both independently replayed gaps stay >= 0 (to rounding)
    on a 1e-3 grid and each event lies where its gap closes (1e-8): no impact skipped."""
    p = dict(BASE, **extra)
    ic = (3.0, 1.0, 6.0, -2.0)
    a = cornerbif.simulate(*ic, transient=0, record=500, chatter=1e-12,
                              **p, model="two_particle")
    t_end = np.nanmax(a["t"][0])
    worst, n = _replay(p, ic, a, t_end)
    assert n > 100
    assert worst > -1e-9


def test_grazing_family_with_damping_against_the_slow_search():
    """Damped, forced z (sigma1 = 0.2, F1 = 0.5) against a sine wall, u out of reach
    (mu = inf).  kappa shifts the gap z - w uniformly, so with g_min the minimum over
    [0, t1] of z - (0.8 sin 2t) found by the exhaustive slow search
    (``naive.naive_gap_min``: grid 1e-4 + brentq on every local minimum), kappa =
    g_min - d gives a first approach of depth exactly d.  The kernel must report a w-z
    impact in [0, t1] iff d < 0, down to |d| = 1e-9, and for d = -1e-3 at the first root
    of the naive gap (1e-9)."""
    zk = dict(sigma1=0.2, F1=0.5, Omega1=1.7, phi1=0.3)
    z0, y0, t1 = 2.0, -0.5, 2.2
    gmin, tmin = naive.naive_gap_min("sine", 2.0, 0.0, 0.8, z0, y0, 0.0, t1, sigma=0.2, k=1.3,
                                     F=0.5, Omega=1.7, phi=0.3, dt=1e-4)
    assert 0.2 < tmin < t1 - 0.2                      # an interior minimum: a grazing approach
    for d in (1e-3, 1e-5, 1e-7, 1e-9, -1e-9, -1e-7, -1e-5, -1e-3):
        kap = gmin - d
        a = cornerbif.simulate(z0, y0, 1e3, 0.0, transient=0, record=1, omega0=2.0,
                                  omega1=1.3, omega2=0.05, mu=math.inf, kappa=kap, beta=0.8,
                                  max_periods=2, **zk, model="two_particle")
        first = a["wz_t"][0, 0] if np.isfinite(a["wz_t"][0, 0]) else np.inf
        if d > 0:
            assert first > t1, (d, first)
        else:
            assert first <= tmin + 1e-9, (d, first)
        if d == -1e-3:
            def g(t, kap=kap):
                z, _ = naive.free_flight(t, 0.0, z0, y0, sigma=0.2, k=1.3, F=0.5, Omega=1.7,
                                         phi=0.3)
                return z - kap - 0.8 * math.sin(2.0 * t)
            from scipy.optimize import brentq
            ts = np.linspace(0.0, tmin, 2001)
            gs = np.array([g(t) for t in ts])
            i = np.nonzero(gs <= 0)[0][0]
            root = brentq(g, ts[i - 1], ts[i], xtol=1e-15)
            assert abs(first - root) < 1e-9


def test_momentum_and_restitution_at_every_zu_impact_with_damping():
    """Random damped, forced runs: at every z-u impact mu y + v is conserved and
    v+ - y+ = -r2 (v- - y-) (law 74), to rounding."""
    rng = np.random.default_rng(7)
    n = 40
    prm = dict(omega0=rng.uniform(0.5, 3, n), omega1=rng.uniform(0.5, 2, n),
               omega2=rng.uniform(0.5, 2, n), mu=rng.choice([1.0, 10.0, 1000.0], n),
               r1=rng.choice([0.3, 0.8, 1.0], n), r2=rng.choice([0.3, 0.8, 1.0], n),
               kappa=rng.uniform(-1, 1, n), beta=rng.uniform(0, 1.5, n),
               sigma1=rng.uniform(0, 0.3, n), sigma2=rng.uniform(0, 0.3, n),
               F1=rng.uniform(-1, 1, n), Omega1=rng.uniform(0.5, 3, n),
               F2=rng.uniform(-1, 1, n), Omega2=rng.uniform(0.5, 3, n))
    z0 = prm["kappa"] + 1.0
    a = cornerbif.simulate(z0, 0.0, z0 + 3.0, 1.0, transient=0, record=60, **prm, model="two_particle")
    ok = np.isfinite(a["t"])
    assert ok.sum() > 1000
    mu = prm["mu"][:, None] * np.ones_like(a["t"])
    yi, yo, vi, vo = a["y_in"][ok], a["y_out"][ok], a["v_in"][ok], a["v_out"][ok]
    scale = mu[ok] * (np.abs(yi) + np.abs(yo)) + np.abs(vi) + np.abs(vo)
    assert (np.abs(mu[ok] * (yo - yi) + (vo - vi)) <= 1e-14 * scale).all()
    r2 = (prm["r2"][:, None] * np.ones_like(a["t"]))[ok]
    assert (np.abs((vo - yo) + r2 * (vi - yi)) <= 1e-13 * (np.abs(vi) + np.abs(yi) + 1)).all()
    assert set(np.unique(a["status"])) <= set(S.NAMES)


def test_energy_decays_with_damping_and_is_kept_without():
    """Fixed wall (beta = 0), elastic impacts (r1 = r2 = 1), no forcing: the total energy
    E = mu (y^2 + omega1^2 z^2)/2 + (v^2 + omega2^2 u^2)/2 (per unit m) is conserved by
    both impact laws and, in flight, dE/dt = -2 mu sigma1 y^2 - 2 sigma2 v^2.  On sections
    every 0.1: E constant to 1e-12 (relative) without damping, never increasing (to
    rounding) and strictly lower at the end with damping."""
    base = dict(omega0=1.0, omega1=1.1, omega2=0.9, mu=3.0, r1=1.0, r2=1.0, kappa=-1.0,
                beta=0.0)
    out = []
    for sig in (0.0, 0.02):
        a = cornerbif.simulate(0.5, 1.0, 2.0, -1.0, transient=0, record=400,
                                  section_period=0.1, sigma1=sig, sigma2=sig, **base, model="two_particle")
        z, y, u, v = a["sz"][0], a["sy"][0], a["su"][0], a["sv"][0]
        E = 3.0 * (y ** 2 + 1.21 * z ** 2) / 2 + (v ** 2 + 0.81 * u ** 2) / 2
        assert np.isfinite(E).all() and np.isfinite(a["t"][0, :10]).all()
        out.append(E)
    E0, E1 = out
    assert np.abs(E0 / E0[0] - 1).max() < 1e-12
    assert (np.diff(E1) <= 1e-12 * E1[0]).all() and E1[-1] < 0.8 * E1[0]


def test_damped_chattering_ends_stuck_on_the_wall():
    """kappa = 1, beta = 0.1, omega0 = 0.5, omega1 = omega2 = 1, sigma1 = sigma2 = 0.1: the
    wall-borne forces N = w'' + 2 sigma w' + w = 1 + 0.075 sin + 0.01 cos > 0 always (eq 4
    with x = w), so both particles chatter down, stick and stay: STUCK, z = u = w, y = v."""
    p = dict(omega0=0.5, omega1=1.0, omega2=1.0, mu=10.0, r1=0.5, r2=0.5, kappa=1.0, beta=0.1,
             sigma1=0.1, sigma2=0.1)
    a = cornerbif.simulate(2.0, 0.0, 3.0, 0.0, transient=0, record=1000, max_periods=200,
                              **p, model="two_particle")
    assert a["status"][0] == S.STUCK
    z, y, u, v = a["final"][0]
    w = 1.0 + 0.1 * math.sin(0.5 * 200 * 2 * math.pi / 0.5)
    assert z == pytest.approx(w, abs=1e-9) and u == pytest.approx(w, abs=1e-9)
    assert y == pytest.approx(v, abs=1e-12)


def test_forced_pair_is_released_where_the_contact_force_changes_sign():
    """omega1 = omega2 = 1, no damping, F1 = 0, F2 = cos(0.3 t), mu = inf, wall out of
    reach: u stuck on z feels lambda2/m = f1 - f2 = -cos(0.3 t) (``pair_force``), so it
    stays only where cos(0.3 t) < 0 and leaves where it turns positive.  Sections every
    0.05: every stuck sample has cos(0.3 t) < 0 (1e-12), and each stuck stretch ends
    within one sample (cos changes by <= 0.015 per sample) after a zero."""
    W = 0.3
    p = dict(omega0=1.0, omega1=1.0, omega2=1.0, mu=math.inf, r1=0.8, r2=0.3, kappa=-10.0,
             beta=0.0, F2=1.0, Omega2=W)
    a = cornerbif.simulate(1.0, 0.0, 1.2, 0.0, transient=0, record=3000, max_periods=3000,
                              section_period=0.05, **p, model="two_particle")
    st, su, sz = a["st"][0], a["su"][0], a["sz"][0]
    stuck = su == sz
    assert stuck.sum() > 50
    assert np.cos(W * st[stuck]).max() < 1e-12
    ends = np.where(stuck[:-1] & ~stuck[1:])[0]
    assert ends.size >= 2
    ce = np.cos(W * st[ends + 1])
    assert (ce > -1e-12).all() and (ce <= 0.015 + 1e-12).all()
    assert np.nanmin(su - sz) > -1e-12


def test_thread_count_does_not_change_damped_runs():
    """1 and 2 threads give bitwise-equal arrays with damping and forcing."""
    rng = np.random.default_rng(3)
    n = 16
    prm = dict(BASE, omega0=rng.uniform(1.5, 2.5, n), sigma1=rng.uniform(0, 0.3, n),
               F2=rng.uniform(-1, 1, n), Omega2=1.3)
    old = numba.get_num_threads()
    try:
        numba.set_num_threads(1)
        a = cornerbif.simulate(1.0, 0.0, 4.0, 0.0, transient=10, record=30, **prm, model="two_particle")
        numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
        b = cornerbif.simulate(1.0, 0.0, 4.0, 0.0, transient=10, record=30, **prm, model="two_particle")
    finally:
        numba.set_num_threads(old)
    for k in a:
        if a[k].dtype == object:
            assert (a[k] == b[k]).all()
        else:
            np.testing.assert_array_equal(a[k], b[k])


def test_damping_keys_in_scenes_and_their_errors():
    """Scene keys sigma1..phi2 default to 0 (Omega to 1); bad values are rejected with the
    key, the value and the allowed range; ``pack`` rejects them too, and an undamped
    resonant forcing (no bounded closed form: the particular solution of eq 4 divides
    by k^2 - Omega^2)."""
    scene = open("configs/fig19a.toml").read()
    sc = config.loads(scene)
    assert sc.system["sigma1"] == 0.0 and sc.system["Omega2"] == 1.0
    sc = config.loads(scene.replace("beta = 1.0", "beta = 1.0\nsigma2 = 0.1\nF1 = 0.3"))
    assert sc.system["sigma2"] == 0.1 and sc.system["F1"] == 0.3
    for bad, needle in (("sigma1 = -0.1", "system.sigma1: -0.1"),
                        ("Omega2 = 0.0", "system.Omega2: 0.0"),
                        ("F1 = nan", "system.F1"), ("sigma3 = 1.0", "system.sigma3")):
        with pytest.raises(config.SceneError) as e:
            config.loads(scene.replace("beta = 1.0", "beta = 1.0\n" + bad))
        assert needle in str(e.value), str(e.value)
    base = dict(BASE)
    for bad in (dict(sigma2=-1.0), dict(Omega1=0.0), dict(F2=math.nan),
                dict(F2=0.1, Omega2=0.9)):                      # undamped resonance with omega2
        with pytest.raises(ValueError, match=list(bad)[-1]):
            P.pack(dict(base, **bad))


def test_undamped_resonance_on_a_swept_axis_is_refused_before_any_kernel_runs():
    """Omega1 = omega1 with sigma1 = 0 and F1 != 0 (eq 4's particular solution divides by
    omega1^2 - Omega1^2) reached only at one value of a swept axis: the scene is refused by
    the config, naming the axis value, not half-way through the sweep by ``pack``."""
    scene = open("configs/fig19a.toml").read().replace("beta = 1.0", "beta = 1.0\nF1 = 0.1")
    base = config.loads(scene)
    assert base.system["Omega1"] == 1.0
    sw = scene.split("[sweep]")[1].split("\n[")[0]
    bad = scene.replace(sw, sw + "\nomega1 = { values = [0.9, 1.0, 1.1] }\n")
    with pytest.raises(config.SceneError) as e:
        config.loads(bad)
    assert "Omega1: 1.0 equals omega1" in str(e.value) and "sweep.omega1 = 1.0" in str(e.value)
    config.loads(scene.replace(sw, sw + "\nomega1 = { values = [0.9, 1.1] }\n"))   # no resonance
