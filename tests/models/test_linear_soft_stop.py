"""Soft stops of the ``linear`` model (law = "spring", docs/linear.md, "Soft stops"): while a
fixed stop's gap g = a . x - kappa is below zero its spring and dashpot act, the force
-(k g + c g') a, and the flight is the exact one of that switched linear system; an entry
(g reaching 0 downwards) is recorded as an impact of the stop with v+ = v-, an exit (g back
to 0 upwards) is not recorded.

Checked here, each against a number from elsewhere:
- a free mass between two soft stops (K = 0, no force): inside a stop g'' = -(k/M) g -
  (c/M) g' (|a| = 1), so from g = 0, g' = w < 0 the time inside is pi / omega_d,
  omega_d = sqrt(k/M - (c/2M)^2), and the exit speed |w| exp(-c/(2M) pi / omega_d) (c = 0:
  a half period pi sqrt(M/k), the speed kept); between the stops the mass flies at its
  speed.  The entries and exits of the pure-numpy run and the kernel's entries equal those
  closed forms to 1e-10;
- a grazing entry (the gap's least value -delta outside, delta down to 1e-12) found at its
  closed form, by both runs;
- the kernel against the pure-numpy run (simulate.py: numpy's expm, events.py's halving) on
  random systems of 1-3 coordinates with a harmonic force, one or two soft stops and
  sometimes a hard one: the same events, times to 1e-9;
- the shipped piecewise-linear oscillator (configs/soft_stop.toml) against scipy's
  solve_ivp (DOP853, rtol = atol = 1e-12, each phase integrated with its own right-hand side
  and its switch located by the integrator's event search): the entries' times and
  velocities to 1e-7 (the integrator's global error at these tolerances over a few periods is
  about 1e-10 and its event location is within its dense output's error; 1e-7 leaves room
  for both);
- the refusals, naming the key and the value.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest

import cornerbif
from cornerbif import config
from cornerbif.config import SceneError
from cornerbif.models.linear.declare import read_system
from cornerbif.models.linear.kernel import OK, run_system
from cornerbif.models.linear.simulate import simulate

ROOT = Path(__file__).resolve().parents[2]


def _two_soft_stops(M, k, c):
    """A free mass (K = 0, no force) between soft stops at x = -1 (L) and x = 1 (R)."""
    table = {"dofs": ["x"], "mass": [M], "stiffness": [0.0],
             "contact": [{"name": "R", "gap": {"x": -1.0}, "kappa": -1.0, "law": "spring", "k": k,
                          "c": c},
                         {"name": "L", "gap": {"x": 1.0}, "kappa": -1.0, "law": "spring", "k": k,
                          "c": c}]}
    system, problems = read_system(table)
    assert problems == []
    return system


@pytest.mark.parametrize("M, k, c", [(1.3, 50.0, 0.0), (1.0, 20.0, 0.0), (0.7, 30.0, 0.4),
                                     (2.0, 80.0, 1.5)])
def test_a_free_mass_between_soft_stops_has_the_closed_form_contacts(M, k, c):
    """Entries and exits against the closed form (module docstring): from x = 0 at speed 0.7
    the mass enters R at t = 1/0.7, stays pi / omega_d, leaves with its speed times
    exp(-gamma pi / omega_d) (gamma = c / 2M), crosses the 2 between the stops, and so on."""
    system = _two_soft_stops(M, k, c)
    gamma = c / (2.0 * M)
    wd = math.sqrt(k / M - gamma ** 2)
    inside = math.pi / wd
    decay = math.exp(-gamma * inside)
    # the closed form: entry k at t_k with speed s_k, exit at t_k + inside with s_k decay
    entries, exits, t, speed, x = [], [], 0.0, 0.7, 0.0
    for i in range(6):
        t += (1.0 - x) / speed if i == 0 else 2.0 / speed
        x = 1.0
        entries.append((t, speed * (-1) ** i))
        t += inside
        speed *= decay
        exits.append((t, -speed * (-1) ** i))
    got_exits = []
    ref, why = simulate(system, [0.0], [0.7], 0.0, 6, exits=got_exits)
    assert why == "ok" and [e.contact for e in ref] == ["R", "L"] * 3
    np.testing.assert_allclose([e.t for e in ref], [e[0] for e in entries], rtol=0, atol=1e-10)
    np.testing.assert_allclose([e.v_in[0] for e in ref], [e[1] for e in entries], rtol=0, atol=1e-10)
    np.testing.assert_array_equal([e.v_in for e in ref], [e.v_out for e in ref])   # no jump
    np.testing.assert_allclose([e.t for e in got_exits], [e[0] for e in exits[:5]], rtol=0, atol=1e-10)
    np.testing.assert_allclose([e.v_in[0] for e in got_exits], [e[1] for e in exits[:5]], rtol=0,
                               atol=1e-10)
    st, out = run_system(system, 0.0, [0.0], [0.7], 6)
    assert st == OK and out["contact"] == ["R", "L"] * 3
    np.testing.assert_allclose(out["t"], [e[0] for e in entries], rtol=0, atol=1e-10)
    np.testing.assert_allclose(out["v_in"][:, 0], [e[1] for e in entries], rtol=0, atol=1e-10)
    np.testing.assert_array_equal(out["v_in"], out["v_out"])
    np.testing.assert_allclose(out["x"][:, 0], [1.0, -1.0] * 3, rtol=0, atol=1e-10)


@pytest.mark.parametrize("delta", [1e-4, 1e-7, 1e-10, 1e-12])
def test_a_grazing_entry_is_found_at_its_closed_form(delta):
    """x'' + x = 0 of amplitude A = 0.5 + delta (from x = 0, x' = A: x = A sin t) beside a
    soft stop at x = 0.5 (k = 10, c = 0): the gap's least value would be -delta.  The entry
    is at t1 = asin(0.5 / A) with speed v_e = sqrt(A^2 - 1/4); inside, xi = x - x* (x* = 5/11,
    the switched system's equilibrium) turns at omega' = sqrt(11) from xi0 = 0.5 / 11 back to
    xi0 after tau = 2 atan2(v_e / omega', xi0) / omega', and leaves at -v_e; outside, the next
    entry comes pi + 2 t1 later.  The kernel's and the numpy run's entries (and the numpy
    run's exits) equal that to 1e-11 + 1e-14 / v_e (a gap resolved to about 1e-14 moves a
    crossing at speed v_e by 1e-14 / v_e; measured 1.4e-9 at delta = 1e-12, v_e = 1e-6)."""
    A = 0.5 + delta
    system, problems = read_system({"dofs": ["x"], "mass": [1.0], "stiffness": [1.0],
                                    "contact": [{"name": "S", "gap": {"x": -1.0}, "kappa": -0.5,
                                                 "law": "spring", "k": 10.0}]})
    assert problems == []
    t1 = math.asin(0.5 / A)
    ve = math.sqrt((A - 0.5) * (A + 0.5))
    w, xi0 = math.sqrt(11.0), 0.5 / 11.0
    tau = 2.0 * math.atan2(ve / w, xi0) / w
    entries = t1 + np.arange(6) * (tau + math.pi + 2.0 * t1)
    tol = 1e-11 + 1e-14 / ve
    st, out = run_system(system, 0.0, [0.0], [A], 6)
    assert st == OK and out["contact"] == ["S"] * 6
    np.testing.assert_allclose(out["t"], entries, rtol=0, atol=tol)
    np.testing.assert_allclose(out["v_in"][:, 0], ve, rtol=0, atol=tol)
    exits = []
    ref, why = simulate(system, [0.0], [A], 0.0, 6, exits=exits)
    assert why == "ok" and len(ref) == 6 and len(exits) == 5
    np.testing.assert_allclose([e.t for e in ref], entries, rtol=0, atol=tol)
    np.testing.assert_allclose([e.t for e in exits], entries[:5] + tau, rtol=0, atol=tol)
    np.testing.assert_allclose([e.v_in[0] for e in exits], -ve, rtol=0, atol=tol)


def _random_system(rng):
    """A random system of 1-3 coordinates: diagonal masses, a stiffness B B^T, light
    damping, one harmonic force; one or two soft stops on fixed obstacles (a coordinate or a
    difference of two, each side), sometimes a hard stop (r = 0.7) beside them."""
    n = int(rng.integers(1, 4))
    dofs = [f"q{i}" for i in range(n)]
    B = rng.uniform(-1.0, 1.0, (n, n))
    table = {"dofs": dofs, "mass": rng.uniform(0.5, 2.0, n).tolist(),
             "stiffness": (B @ B.T + 0.2 * np.eye(n)).tolist(),
             "damping": rng.uniform(0.02, 0.1, n).tolist(),
             "forcing": [{"on": dofs[int(rng.integers(n))], "F": float(rng.uniform(1.5, 3.0)),
                          "Omega": float(rng.uniform(0.5, 2.0)), "phi": float(rng.uniform(0, 6))}]}
    contacts = []
    for name in "ST"[:int(rng.integers(1, 3))]:
        gap = {dofs[int(rng.integers(n))]: float(rng.choice([-1.0, 1.0]))}
        if n > 1 and rng.random() < 0.3:
            other = next(d for d in dofs if d not in gap)
            gap[other] = -next(iter(gap.values()))
        contacts.append({"name": name, "gap": gap, "kappa": float(rng.uniform(-0.6, -0.2)),
                         "law": "spring", "k": float(rng.uniform(5.0, 40.0)),
                         "c": float(rng.choice([0.0, rng.uniform(0.0, 0.5)]))})
    if rng.random() < 0.4:
        contacts.append({"name": "H", "gap": {dofs[0]: float(rng.choice([-1.0, 1.0]))},
                         "kappa": -1.2, "r": 0.7})
    table["contact"] = contacts
    system, problems = read_system(table)
    assert problems == []
    return system


@pytest.mark.parametrize("seed", range(12))
def test_the_kernel_equals_the_numpy_run_on_random_soft_stop_systems(seed):
    """The same events (contacts in order) and times to 1e-9 over the first 10, from a start
    clear of every stop (x = 0)."""
    rng = np.random.default_rng(1000 + seed)
    system = _random_system(rng)
    v0 = rng.uniform(-2.0, 2.0, system.n)
    x0 = np.zeros(system.n)
    ref, why = simulate(system, x0, v0, 0.0, 10, horizon=400.0)
    st, out = run_system(system, 0.0, x0, v0, 10, t_max=400.0)
    assert len(ref) >= 3, why
    k = min(len(ref), len(out["t"]))
    assert k == len(ref) or k == len(out["t"])
    assert out["contact"][:k] == [e.contact for e in ref[:k]]
    np.testing.assert_allclose(out["t"][:k], [e.t for e in ref[:k]], rtol=0, atol=1e-9)
    np.testing.assert_allclose(out["v_in"][:k], [e.v_in for e in ref[:k]], rtol=0, atol=1e-8)
    np.testing.assert_allclose(out["v_out"][:k], [e.v_out for e in ref[:k]], rtol=0, atol=1e-8)


def _soft_stop_scene():
    return tomllib.loads((ROOT / "configs" / "soft_stop.toml").read_text())


def _ivp_entries(t0, x0, v0, inside, count, Omega):
    """The soft stop's next ``count`` entries of configs/soft_stop.toml's oscillator from
    (x0, v0) at t0, by scipy's solve_ivp: x'' + 0.04 x' + x = 0.2 cos(Omega t), plus
    10 (0.5 - x) - 0.02 x' while x > 0.5, each phase with its own right-hand side and its end
    (x = 0.5 crossed) located by the integrator's event search."""
    from scipy.integrate import solve_ivp

    def rhs(inside):
        def f(t, y):
            acc = 0.2 * math.cos(Omega * t) - 0.04 * y[1] - y[0]
            if inside:
                acc += 10.0 * (0.5 - y[0]) - 0.02 * y[1]
            return [y[1], acc]
        return f

    def cross(t, y):
        return y[0] - 0.5
    cross.terminal = True
    out = []
    t, y = t0, np.array([x0, v0])
    while len(out) < count:
        cross.direction = -1.0 if inside else 1.0
        sol = solve_ivp(rhs(inside), (t, t + 200.0), y, method="DOP853", rtol=1e-12, atol=1e-12,
                        events=cross)
        assert sol.t_events[0].size, "no switch within 200"
        t, y = sol.t_events[0][0], sol.y_events[0][0]
        y[0] = 0.5
        inside = not inside
        if inside:
            out.append((t, y[1]))
    return np.array(out)


@pytest.mark.parametrize("Omega", [0.9, 1.2, 1.4])
def test_the_piecewise_linear_oscillator_equals_solve_ivp(Omega):
    """configs/soft_stop.toml's system from a start that reaches the stop: the kernel's
    entries 10-17 (the transient) and 241-248 (the periodic orbit) against solve_ivp's from
    the kernel's entry before them (times and speeds to 1e-7: the module docstring); by then
    the motion is periodic, one entry per forcing period (to 1e-9), the model's cycle (word S,
    period 1) at the same entry speed."""
    table = _soft_stop_scene()["system"]
    table["forcing"][0]["Omega"] = Omega
    system, problems = read_system(table)
    assert problems == []
    st, out = run_system(system, 0.0, [0.0], [2.0], 250, t_max=1e4)
    assert st == OK
    t, v = out["t"], out["v_in"][:, 0]
    for k in (10, 241):          # in the transient, and on the periodic orbit
        ivp = _ivp_entries(t[k - 1], 0.5, v[k - 1], True, 8, Omega)
        np.testing.assert_allclose(t[k:k + 8], ivp[:, 0], rtol=0, atol=1e-7)
        np.testing.assert_allclose(v[k:k + 8], ivp[:, 1], rtol=0, atol=1e-7)
    # periodic: one entry per forcing period, at the same speed
    np.testing.assert_allclose(np.diff(t[241:]), 2.0 * math.pi / Omega, rtol=0, atol=1e-9)
    np.testing.assert_allclose(v[241:], v[-1], rtol=0, atol=1e-9)
    res = cornerbif.simulate(model="linear", table=table, x0=0.0, v_x0=2.0, transient=200,
                             record=16)
    assert (np.asarray(res["period"]).ravel()[0], np.asarray(res["impacts_per_cycle"]).ravel()[0],
            np.asarray(res["symbols"]).ravel()[0]) == (1, 1, "S")
    # (its record is entries 201-216 of that run, a few 1e-9 from the orbit at Omega = 1.4)
    np.testing.assert_allclose(np.asarray(res["v_in"]).ravel(), -v[-1], rtol=0, atol=1e-7)


@pytest.mark.parametrize("contact, needle", [
    ({"law": "spring"}, "system.contact.S.k: missing"),
    ({"law": "spring", "k": 0.0}, "system.contact.S.k: 0.0"),
    ({"law": "spring", "k": -3.0}, "system.contact.S.k: -3.0"),
    ({"law": "spring", "k": 5.0, "c": -0.1}, "system.contact.S.c: -0.1"),
    ({"law": "spring", "k": 5.0, "obstacle": "sine", "beta": 0.1, "omega": 2.0},
     "system.contact.S.obstacle: 'sine'"),
    ({"law": "impact", "k": 5.0}, "system.contact.S.k: 5.0"),
    ({"k": 5.0}, "system.contact.S.k: 5.0"),
    ({"law": "impact", "c": 0.1}, "system.contact.S.c: 0.1"),
])
def test_bad_soft_stops_are_refused_naming_the_key_and_value(contact, needle):
    table = {"dofs": ["x"], "mass": [1.0], "stiffness": [1.0],
             "contact": [{"name": "S", "gap": {"x": -1.0}, "kappa": -0.5, **contact}]}
    system, problems = read_system(table)
    assert system is None and any(needle in p for p in problems), problems


def test_more_soft_stops_than_the_limit_are_refused():
    table = {"dofs": ["x"], "mass": [1.0], "stiffness": [1.0],
             "contact": [{"name": n, "gap": {"x": 1.0}, "kappa": -1.0 - i, "law": "spring", "k": 5.0}
                         for i, n in enumerate("ABCD")]}
    system, problems = read_system(table)
    assert system is None and any(p.startswith("system.contact: ['A', 'B', 'C', 'D'] names 4 soft")
                                  for p in problems), problems


def test_the_scene_sweeps_k_and_c_and_refuses_stability_and_following():
    """contact.S.k and contact.S.c are sweep axes; the stability pass (no saltation through
    a soft stop's switch yet) and a followed sweep (its start in the last recorded flight,
    which a switch may cross) are refused, as are the two-particle model's words."""
    text = (ROOT / "configs" / "soft_stop.toml").read_text()
    base = text.split("[sweep]")[0]
    rest = "\n[initial]" + text.split("[initial]")[1]
    scene = config.loads(base + '[sweep]\n"contact.S.k" = { values = [5.0, 20.0] }\n'
                         '"contact.S.c" = { values = [0.0, 0.1] }\n' + rest)
    assert [a.name for a in scene.axes] == ["contact.S.k", "contact.S.c"]
    with pytest.raises(SceneError) as e:
        config.loads(text.replace('keep = ["impacts"]', 'keep = ["impacts", "stability"]'))
    assert "output.keep: 'stability'" in str(e.value) and "soft stop S" in str(e.value), str(e.value)
    with pytest.raises(SceneError) as e:
        config.loads(text.replace("[initial]", 'follow = "up"\n\n[initial]'))
    assert "sweep.follow" in str(e.value) and "soft stop S" in str(e.value), str(e.value)
    with pytest.raises(SceneError) as e:
        config.loads(text.replace('dofs = ["x"]', 'dofs = ["x"]\nwords = { impacts = "S", '
                                  'corners = "S" }'))
    assert "system.words" in str(e.value), str(e.value)
