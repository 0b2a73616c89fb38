"""Self-tests of the two-particle finite-difference Jacobian reference
``tests/fd_reference_two_particle.py`` (paper section 6, eqs 72-74).

The reference must be trustworthy before it is used to test cornerbif's stability
code, so every expected number here comes from the paper's impact laws, a closed
form (flight matrices, Liouville's formula, saltation matrices written out below)
or a refinement of the reference's own numerical parameters -- never from cornerbif
(not imported).

Closed forms used
-----------------
Flight of one particle, x'' + 2 s x' + k^2 x = F cos(Omega t + phi): with X = (x, x'),
X' = A X + forcing, A = [[0, 1], [-k^2, -2 s]], so dX(t0 + tau)/dX(t0) = exp(A tau)
and, for s < k, wd = sqrt(k^2 - s^2), c = cos(wd tau), S = sin(wd tau)/wd::

    exp(A tau) = e^{-s tau} [[c + s S, S], [-k^2 S, c - s S]]

(check: it is 1 at tau = 0 and its tau-derivative is A exp(A tau)).  The two
particles fly independently, so between events J = diag(exp(A1 tau), exp(A2 tau));
Liouville: det = exp(tr(A1) + tr(A2)) tau = exp(-2 (sigma1 + sigma2) tau).

Saltation matrix of an event h(x, t) = 0 with reset x+ = g(x-, t) (G = dg/dx, g_t =
dg/dt, n = dh/dx, h_t = dh/dt, f-+ the vector fields just before/after)::

    S = G + (f+ - G f- - g_t) n^T / (n . f- + h_t)

(perturb the state at the fixed event time t*: the event time moves by
-n.dx / (n.f- + h_t); reset there and fly back to t*.)

* 'wz' (h = z - w(t), law (5)): G = diag(1, -r1, 1, 1), g_t = (0, (1 + r1) w'', 0, 0),
  n = (1, 0, 0, 0), h_t = -w'.  Since y+ - w' = -r1 (y- - w'), S[0, 0] = -r1, and
  S has only column 0 changed from G: det S = (-r1)(-r1) = r1^2.
* 'zu' (h = u - z, law (74)): G is the identity on (z, u) and the paper's 2x2 matrix
  [[(mu - r2), (1 + r2)], [mu (1 + r2), (1 - r2 mu)]] / (1 + mu) on (y, v) (det -r2);
  g_t = 0, n = (-1, 0, 1, 0), h_t = 0.  The matrix determinant lemma gives
  det S = det G * (n . G^-1 f+) / (n . f-) = (-r2) (v+ - y+) / (v- - y-) = r2^2.

Hence over a window of length T with N_wz and N_zu transversal events (no grazing,
no simultaneous events) det J = exp(-2 (sigma1 + sigma2) T) r1^(2 N_wz) r2^(2 N_zu),
and J is the product of flight and saltation matrices (checked entrywise below).

Test cases
----------
Periodic attractors at the section t0 = n 2 pi / omega0 (n = 400), found with
``settle(p, (3, 1, 6, -2), 400, 2 pi / omega0)`` and the smallest P <= 80 with
x(t0 + P T) = x(t0) to 1e-10 (relative); the closure is re-checked here.  Event
kinds per cycle: W = 'wz', U = 'zu'.  All events of these orbits cluster just
before the sections (phase 0.99..1.0 of the wall period; the damped ones also
just after), where the wall crosses kappa upwards.
"""

import math
import os
import sys
from functools import cache

import numpy as np
import pytest
from scipy.linalg import expm

sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
import fd_reference_two_particle as fr  # noqa: E402

TWO_PI = 2.0 * math.pi

# the paper's Fig. 19 values (section 6.2): omega1 = 1.001, omega2 = 1, mu = 1000,
# r1 = r2 = 0.8, kappa = 0, beta = 1; omega0 is varied
FIG19 = dict(omega1=1.001, omega2=1.0, mu=1000.0, r1=0.8, r2=0.8, kappa=0.0, beta=1.0)
DAMPED = dict(FIG19, sigma1=0.05, sigma2=0.02)
MU3 = dict(FIG19, mu=3.0)

# name: (p, n (t0 = n T), P (periods per cycle), x0, event kinds of one cycle)
ATTRACTORS = {
    # the period-1 orbit 'b' of the paper's simple regime omega0 > omega_C = 1.99975
    "fig19_w2.000_P1": (dict(FIG19, omega0=2.0), 400, 1,
                        [0.18982259867467574, 16.49606490380678, 1.7221809107866082,
                         149.66189899401783], "WU"),
    # below omega_C: a period-3 orbit, the W-U order flips in the third period
    "fig19_w1.999_P3": (dict(FIG19, omega0=1.999), 400, 3,
                        [0.33102358171842416, 17.818800985841154, 0.5884766955721608,
                         28.94275670065737], "WU WU UW"),
    "damped_w1.996_P2": (dict(DAMPED, omega0=1.996), 400, 2,
                         [0.13441793607396843, 11.310653802925268, 0.1373804610755841,
                          6.459075052854888], "UWU UW"),
    "mu3_w1.999_P1": (dict(MU3, omega0=1.999), 400, 1,
                      [0.03019693692781706, 6.2410810587820205, 0.11411034554578325,
                       17.841935748010744], "WUW"),
}
# a period-13 orbit (26 events, W and U as close as 3e-7 in time): used for the event
# checks only (its FD Jacobian takes ~5 s; steps down to 1.6e-5 are needed)
P13 = (dict(FIG19, omega0=1.9995), 400, 13,
       [0.26458501052476596, 17.389692234148317, 1.7351572079662885, 103.95819674524904],
       "WU UW WU WU WU UW WU WU WU UW WU WU WU")

# a damped AND forced transient (parameters of tests/models/test_two_particle_damped.py: BASE +
# DAMP): from x0 = (1, 0.5, 3, -1) at t = 0 the events up to t = 8 are
# U 1.5115, W 2.5369, U 2.6204, W 6.1871, U 6.4184 (checked below); the FD window is
# [0, 4] (the first three)
FORCED = dict(omega0=2.0, omega1=1.3, omega2=0.9, mu=5.0, r1=0.7, r2=0.6, kappa=-0.5,
              beta=0.8, sigma1=0.1, sigma2=0.05, F1=0.4, Omega1=1.7, phi1=0.3, F2=0.6,
              Omega2=2.3, phi2=-1.0)
FORCED_CASE = (FORCED, [1.0, 0.5, 3.0, -1.0], 0.0, 4.0, "UWU")


def _kinds(events):
    return "".join("W" if k == "wz" else "U" for _, k in events)


def _window(name):
    """(p, x0, t0, duration, expected kinds) of a named test window."""
    if name == "forced_transient":
        p, x0, t0, dur, kinds = FORCED_CASE
        return p, np.array(x0), t0, dur, kinds
    p, n, P, x0, kinds = ATTRACTORS[name]
    T = TWO_PI / p["omega0"]
    return p, np.array(x0), n * T, P * T, kinds.replace(" ", "")


@cache
def _fd(name):
    """FD Jacobian of a named window, computed once per session."""
    p, x0, t0, dur, _ = _window(name)
    return fr.fd_jacobian(p, x0, t0, dur, full_output=True)


def _pfull(p):
    q = dict(fr.DEFAULTS)
    q.update(p)
    return q


def flight_block(tau, s, k):
    """exp(A tau), A = [[0, 1], [-k^2, -2 s]]: the closed form above (s < k), else expm."""
    if s < k:
        wd = math.sqrt(k * k - s * s)
        c, S = math.cos(wd * tau), math.sin(wd * tau) / wd
        return math.exp(-s * tau) * np.array([[c + s * S, S], [-k * k * S, c - s * S]])
    return expm(np.array([[0.0, 1.0], [-k * k, -2.0 * s]]) * tau)


def flight_matrix(p, tau):
    M = np.zeros((4, 4))
    M[:2, :2] = flight_block(tau, p["sigma1"], p["omega1"])
    M[2:, 2:] = flight_block(tau, p["sigma2"], p["omega2"])
    return M


def vector_field(p, x, t):
    z, y, u, v = x
    return np.array([y, -2 * p["sigma1"] * y - p["omega1"] ** 2 * z
                     + p["F1"] * math.cos(p["Omega1"] * t + p["phi1"]),
                     v, -2 * p["sigma2"] * v - p["omega2"] ** 2 * u
                     + p["F2"] * math.cos(p["Omega2"] * t + p["phi2"])])


def law74(mu, r):
    """The paper's eq (74) on (y, v); mu = inf is law (5) for u off a moving z."""
    if math.isinf(mu):
        return np.array([[1.0, 0.0], [1.0 + r, -r]])
    return np.array([[mu - r, 1.0 + r], [mu * (1.0 + r), 1.0 - r * mu]]) / (1.0 + mu)


def saltation(p, ev):
    """Saltation matrix of one event (formulas in the module docstring)."""
    fm, fp = vector_field(p, ev.pre, ev.t), vector_field(p, ev.post, ev.t)
    G = np.eye(4)
    gt = np.zeros(4)
    if ev.kind == "wz":
        om = p["omega0"]
        wp = p["beta"] * om * math.cos(om * ev.t)
        wpp = -p["beta"] * om * om * math.sin(om * ev.t)
        G[1, 1] = -p["r1"]
        gt[1] = (1.0 + p["r1"]) * wpp
        n, ht = np.array([1.0, 0.0, 0.0, 0.0]), -wp
    else:
        G[np.ix_([1, 3], [1, 3])] = law74(p["mu"], p["r2"])
        n, ht = np.array([-1.0, 0.0, 1.0, 0.0]), 0.0
    return G + np.outer(fp - G @ fm - gt, n) / (n @ fm + ht)


def saltation_product(p, x0, t0, dur):
    """Phi(t1 - t_N) S_N ... S_1 Phi(t_1 - t0) from the reference's own events (times
    and pre/post states only)."""
    p = _pfull(p)
    _, evs = fr.trajectory(p, x0, t0, t0 + dur)
    M, t_prev = np.eye(4), t0
    for ev in evs:
        M = saltation(p, ev) @ flight_matrix(p, ev.t - t_prev) @ M
        t_prev = ev.t
    return flight_matrix(p, t0 + dur - t_prev) @ M, evs


def assert_estimate_honest(J, J_exact, err, floor=1e-13):
    """The returned error estimate bounds the true error (10x margin, as in
    tests/models/test_fd_reference.py, plus a floor for the closed form's own rounding)."""
    assert np.all(np.abs(J - J_exact) <= 10.0 * err + floor), (np.abs(J - J_exact), err)


# ---------------------------------------------------------------------------
# the test cases are what they claim to be
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("name", list(ATTRACTORS))
def test_attractor_closes_with_its_event_sequence(name):
    # expected: x(t0 + P T) = x0 (periodic orbit, found by settle; see module docstring)
    p, x0, t0, dur, kinds = _window(name)
    st = fr.state_at(p, x0, t0, t0 + dur)
    assert _kinds(st.events) == kinds
    np.testing.assert_allclose(st.x, x0, rtol=0, atol=1e-9 * np.abs(x0).max())


def test_forced_transient_events():
    p, x0, t0, dur, kinds = _window("forced_transient")
    st = fr.state_at(p, x0, t0, 8.0)
    assert _kinds(st.events) == "UWUWU" and kinds == "UWU"
    np.testing.assert_allclose([t for t, _ in st.events],
                               [1.5115, 2.5369, 2.6204, 6.1871, 6.4184], atol=1e-4)


# ---------------------------------------------------------------------------
# impact laws at every event of a run
# ---------------------------------------------------------------------------
def _law_runs():
    p13, n, P, x0, _ = P13
    T = TWO_PI / p13["omega0"]
    yield p13, np.array(x0), n * T, (n + P) * T  # 26 events, mu = 1000
    p, x0, t0, dur, _ = _window("mu3_w1.999_P1")
    yield p, x0, t0, t0 + 3 * dur  # mu = 3
    p, x0, t0, _, _ = _window("forced_transient")
    yield p, x0, t0, 8.0  # mu = 5, damped, forced
    yield dict(FORCED, mu=math.inf), x0, t0, 8.0  # mu = inf


def test_impact_laws_at_every_event():
    """'zu': paper eq (74): positions unchanged, momentum mu y + v conserved, relative
    velocity v - y reversed and scaled by r2, and (y+, v+) = matrix(74) (y-, v-);
    mu = inf: y unchanged, v+ = (1 + r2) y- - r2 v- (law 5).  'wz': law (5), z = w(t),
    y+ - w' = -r1 (y- - w'), u and v unchanged."""
    n_zu = n_wz = 0
    for p, x0, t0, t1 in _law_runs():
        q = _pfull(p)
        _, evs = fr.trajectory(p, x0, t0, t1)
        assert evs
        for ev in evs:
            (z0, y0, u0, v0), (z1, y1, u1, v1) = ev.pre, ev.post
            sc = max(abs(y0), abs(v0), 1.0)
            if ev.kind == "zu":
                n_zu += 1
                assert z1 == z0 and u1 == z0 and abs(u0 - z0) < 1e-12
                assert v1 - y1 == pytest.approx(-q["r2"] * (v0 - y0), abs=1e-13 * sc)
                if math.isinf(q["mu"]):
                    assert y1 == y0
                else:
                    mu = q["mu"]
                    assert mu * y1 + v1 == pytest.approx(mu * y0 + v0, abs=1e-14 * mu * sc)
                np.testing.assert_allclose([y1, v1], law74(q["mu"], q["r2"]) @ [y0, v0],
                                           rtol=0, atol=1e-13 * sc)
            else:
                n_wz += 1
                om = q["omega0"]
                w = q["kappa"] + q["beta"] * math.sin(om * ev.t)
                wp = q["beta"] * om * math.cos(om * ev.t)
                assert z1 == pytest.approx(w, abs=1e-11) and abs(z0 - w) < 1e-11
                assert y1 - wp == pytest.approx(-q["r1"] * (y0 - wp), abs=1e-11 * sc)
                assert (u1, v1) == (u0, v0)
            assert ev.pre[0] < ev.pre[2] or ev.kind == "zu"  # order kept (z < u)
    assert n_zu >= 20 and n_wz >= 20


# ---------------------------------------------------------------------------
# no event: J = diag(exp(A1 tau), exp(A2 tau))
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("extra", [
    dict(),                                                   # paper eq 73
    dict(sigma1=0.05, sigma2=0.02, F1=0.4, Omega1=1.7, phi1=0.3),  # damped, z forced
    dict(sigma1=0.3, sigma2=1.5, F1=0.4, Omega1=1.7),          # u over-damped (expm)
], ids=["undamped", "damped_forced", "overdamped"])
def test_no_event_window_is_block_diagonal_flight(extra):
    # wall at kappa = -100 is never reached; a constant force F2 (Omega2 = 0) holds u
    # around F2 / omega2^2 = 50 while z stays O(1): no event in the window
    p = dict(FIG19, omega0=2.0, kappa=-100.0, F2=50.0, Omega2=0.0, **extra)
    x0, t0, tau = np.array([0.3, -0.4, 50.5, 0.2]), 7.0, 2.5
    J, err, info = fr.fd_jacobian(p, x0, t0, tau, full_output=True)
    assert info["n_events"] == 0
    E = flight_matrix(_pfull(p), tau)
    np.testing.assert_allclose(J, E, rtol=0, atol=1e-8 * np.abs(E).max())
    assert_estimate_honest(J, E, err)
    q = _pfull(p)
    assert np.linalg.det(J) == pytest.approx(math.exp(-2 * (q["sigma1"] + q["sigma2"]) * tau),
                                             rel=1e-8)


# ---------------------------------------------------------------------------
# windows with events: determinant and the full saltation product
# ---------------------------------------------------------------------------
WINDOWS = list(ATTRACTORS) + ["forced_transient"]


@pytest.mark.parametrize("name", WINDOWS)
def test_determinant_is_liouville_times_r_squared(name):
    p, x0, t0, dur, kinds = _window(name)
    J, err, info = _fd(name)
    assert _kinds(info["events"]) == kinds
    q = _pfull(p)
    n_wz, n_zu = kinds.count("W"), kinds.count("U")
    # det J = exp(-2 (sigma1 + sigma2) T) r1^(2 N_wz) r2^(2 N_zu) (module docstring)
    expected = (math.exp(-2.0 * (q["sigma1"] + q["sigma2"]) * dur)
                * q["r1"] ** (2 * n_wz) * q["r2"] ** (2 * n_zu))
    det = np.linalg.det(J)
    # first-order propagation of the entrywise estimate: |d det| <= sum |cof_ij| err_ij
    cof = det * np.linalg.inv(J).T
    det_err = float(np.sum(np.abs(cof) * err))
    assert abs(det - expected) <= 10.0 * det_err + 1e-14, (det, expected, det_err)
    assert det == pytest.approx(expected, rel=1e-8)


@pytest.mark.parametrize("name", WINDOWS)
def test_jacobian_matches_saltation_product(name):
    p, x0, t0, dur, kinds = _window(name)
    J, err, _ = _fd(name)
    M, evs = saltation_product(p, x0, t0, dur)
    assert _kinds([(e.t, e.kind) for e in evs]) == kinds
    np.testing.assert_allclose(J, M, rtol=0, atol=1e-8 * np.abs(M).max())
    assert_estimate_honest(J, M, err)


# ---------------------------------------------------------------------------
# no missed event: the run does not change under refinement of the detection grid
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("case", ["P13", "forced_transient", "fig19_w1.999_P3"])
def test_events_stable_under_dt_refinement(case):
    if case == "P13":
        p, n, P, x0, _ = P13
        T = TWO_PI / p["omega0"]
        x0, t0, dur = np.array(x0), n * T, P * T
    else:
        p, x0, t0, dur, _ = _window(case)
    runs = [fr.state_at(p, x0, t0, t0 + dur, dt=dt) for dt in (1e-3, 2.5e-4, 1e-4)]
    base = runs[0]
    for st in runs[1:]:
        assert _kinds(st.events) == _kinds(base.events)
        np.testing.assert_allclose([t for t, _ in st.events], [t for t, _ in base.events],
                                   rtol=0, atol=1e-11)
        np.testing.assert_allclose(st.x, base.x, rtol=0, atol=1e-10)


# ---------------------------------------------------------------------------
# what the reference refuses
# ---------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["forced_transient", "fig19_w2.000_P1"])
def test_event_at_window_end_is_refused(name):
    # a window ending exactly at (or within 1e-12 of) the first event has no step that
    # keeps the event count: t0 = 0 (forced transient, a 'zu' event near 1.5115) and a
    # large t0 = 400 T (the Fig. 19 period-1 orbit, a 'wz' event at phase 0.9958)
    p, x0, t0, dur, kinds = _window(name)
    t_ev = fr.state_at(p, x0, t0, t0 + dur).events[0][0]
    st = fr.state_at(p, x0, t0, t_ev)
    assert _kinds(st.events) == kinds[0]  # an event at t1 counts: the post-event state
    if kinds[0] == "U":
        assert st.x[0] == st.x[2]
    else:
        w = p["kappa"] + p["beta"] * math.sin(p["omega0"] * t_ev)
        assert st.x[0] == pytest.approx(w, abs=1e-11)
    for d in (0.0, 1e-12, -1e-12):
        with pytest.raises(fr.FDStepError, match="nonsmooth"):
            fr.fd_jacobian(p, x0, t0, t_ev + d - t0)


def test_bad_starts_and_chattering_raise():
    p = dict(FIG19, omega0=2.0)
    with pytest.raises(ValueError, match="strictly ordered"):
        fr.state_at(p, [0.5, 0.0, 0.5, 0.0], 0.0, 1.0)  # z = u
    with pytest.raises(ValueError, match="strictly ordered"):
        fr.state_at(p, [0.0, 0.0, 1.0, 0.0], 0.0, 1.0)  # z = w(0) = kappa
    # from (2, 0, 4, 0) the heavy particle ends up bouncing on the wall with vanishing
    # relative velocity (chattering) near t = 3.0: out of scope, refused
    with pytest.raises(RuntimeError, match="chattering"):
        fr.state_at(p, [2.0, 0.0, 4.0, 0.0], 0.0, 5.0)
