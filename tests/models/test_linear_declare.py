"""The ``[system]`` table of a ``linear`` scene (issue 33): ``declare.read_system`` builds the
declared system or refuses it naming the key and the value; ``numeric_paths`` and
``with_value`` name and set every number by its path.  Pure Python: no numba is loaded."""

from __future__ import annotations

import copy
import dataclasses
import os
import subprocess
import sys
import tomllib
import warnings

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from cornerbif.model import shown
from cornerbif.models.linear.declare import numeric_paths, read_system, with_value
from cornerbif.models.linear.system import MAX_CONTACTS, MAX_DOFS, MAX_SOFT

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))

SKETCH = """
[system]
dofs = ["x", "y"]
mass = [1.0, 0.1]
stiffness = [[1.0, 0.0], [0.0, 0.0]]
damping = [[0.05, 0.0], [0.0, 0.0]]
forcing = [{ on = "x", F = 0.7, Omega = 0.9, phi = 0.0 }]

[[system.contact]]
name = "R"
gap = { y = 1.0, x = -1.0 }
obstacle = "fixed"
kappa = -0.4
r = 0.5

[[system.contact]]
name = "L"
gap = { x = 1.0, y = -1.0 }
obstacle = "fixed"
kappa = -0.4
law = "spring"
k = 50.0
c = 0.1
"""


def sketch() -> dict:
    return tomllib.loads(SKETCH)["system"]


def paper_flow(obstacle="rectified_sine") -> dict:
    """The flow model's u'' + 2 sigma u' + u = F cos(Omega t) against z = kappa + beta
    shape(omega t), written as a linear system with N = 1."""
    return {"dofs": ["x"], "mass": [1.0], "stiffness": [[1.0]], "damping": [[0.1]],
            "forcing": [{"on": "x", "F": 0.3, "Omega": 1.5}],
            "contact": [{"name": "A", "gap": {"x": 1.0}, "obstacle": obstacle, "kappa": -0.1,
                         "beta": 1.0, "omega": 2.2, "r": 0.8}]}


def test_the_issue_sketch_parses_into_its_arrays():
    """The impact damper of issue 33: M = diag(1, 0.1), K, C as written, one harmonic
    force on x, an impact contact R (gap a = (-1, 1), r = 0.5) and a soft stop L (a = (1, -1),
    k = 50, c = 0.1)."""
    s, problems = read_system(sketch())
    assert problems == []
    assert s.dofs == ("x", "y") and s.n == 2
    np.testing.assert_array_equal(s.mass, np.diag([1.0, 0.1]))
    np.testing.assert_array_equal(s.stiffness, [[1.0, 0.0], [0.0, 0.0]])
    np.testing.assert_array_equal(s.damping, [[0.05, 0.0], [0.0, 0.0]])
    (f,) = s.forcing
    assert (f.on, f.F, f.Omega, f.phi) == (0, 0.7, 0.9, 0.0)
    R, L = s.contacts
    assert (R.name, R.obstacle, R.kappa, R.law, R.r) == ("R", "fixed", -0.4, "impact", 0.5)
    np.testing.assert_array_equal(R.gap, [-1.0, 1.0])
    assert (L.name, L.law, L.k, L.c, L.kappa) == ("L", "spring", 50.0, 0.1, -0.4)
    np.testing.assert_array_equal(L.gap, [1.0, -1.0])
    assert not s.mass.flags.writeable     # a frozen declaration holds read-only arrays


def test_defaults():
    """No damping: C = 0; no forcing, no contact: empty; Omega and phi default to 0; an
    impact's r to 0.8 (the flow model's), a spring's c to 0; obstacle "fixed", kappa 0."""
    t = {"dofs": ["x"], "mass": [2.0], "stiffness": [[0.0]],
         "forcing": [{"on": "x", "F": -1.0}],
         "contact": [{"name": "g", "gap": [1.0]}, {"name": "s", "gap": [-1.0], "law": "spring", "k": 3}]}
    s, problems = read_system(t)
    assert problems == []
    np.testing.assert_array_equal(s.damping, [[0.0]])
    assert (s.forcing[0].Omega, s.forcing[0].phi) == (0.0, 0.0)
    g, sp = s.contacts
    assert (g.obstacle, g.kappa, g.law, g.r) == ("fixed", 0.0, "impact", 0.8)
    assert (sp.k, sp.c) == (3.0, 0.0)
    s, problems = read_system({"dofs": ["x"], "mass": [1.0], "stiffness": [1.0]})
    assert problems == [] and s.forcing == () and s.contacts == ()


@pytest.mark.parametrize("obstacle", ["rectified_sine", "sine", "triangle"])
def test_the_paper_flow_as_one_dof(obstacle):
    """N = 1 with a = (1,) against a moving obstacle: the paper's flow (eqs 1-5)."""
    s, problems = read_system(paper_flow(obstacle))
    assert problems == []
    (c,) = s.contacts
    np.testing.assert_array_equal(c.gap, [1.0])
    assert (c.obstacle, c.kappa, c.beta, c.omega, c.r) == (obstacle, -0.1, 1.0, 2.2, 0.8)
    assert s.mass.shape == s.stiffness.shape == s.damping.shape == (1, 1)


def test_a_full_mass_matrix_and_a_rigid_body_mode():
    """A symmetric positive-definite full M; K singular (a free mass: a rigid-body mode)."""
    t = {"dofs": ["a", "b"], "mass": [[2.0, 0.5], [0.5, 1.0]], "stiffness": [[1.0, -1.0], [-1.0, 1.0]]}
    s, problems = read_system(t)
    assert problems == []
    np.testing.assert_array_equal(s.mass, [[2.0, 0.5], [0.5, 1.0]])


def _set(path, value):
    """The sketch with the key at ``path`` (a list of keys and indices) set to ``value``, or
    removed (value ``DEL``)."""
    def change(t):
        *head, last = path
        for p in head:
            t = t[p]
        if value is DEL:
            del t[last]
        else:
            t[last] = value
    return change


DEL = object()
NAN, INF = float("nan"), float("inf")
SEVEN = ["a", "b", "c", "d", "e", "f", "g"]
NINE = [{"name": chr(65 + i), "gap": {"x": 1.0}} for i in range(MAX_CONTACTS + 1)]
MOVING = {"name": "R", "gap": {"x": 1.0}, "obstacle": "sine", "beta": 1.0, "omega": 2.0}

REFUSALS = [
    # id, change, key path, the value as shown
    ("dofs empty", _set(["dofs"], []), "system.dofs", "[]"),
    ("dofs not a list", _set(["dofs"], "x"), "system.dofs", "'x'"),
    ("dofs twice", _set(["dofs"], ["x", "x"]), "system.dofs.1", "'x'"),
    ("dofs not a name", _set(["dofs"], ["x", "2y"]), "system.dofs.1", "'2y'"),
    ("dofs not a string", _set(["dofs"], ["x", 3]), "system.dofs.1", "3"),
    ("dofs an impact's dataset", _set(["dofs"], ["x", "u"]), "system.dofs.1", "'u'"),
    ("dofs the contact dataset", _set(["dofs"], ["contact", "y"]), "system.dofs.0", "'contact'"),
    ("dofs too many", _set(["dofs"], SEVEN[:MAX_DOFS + 1]), "system.dofs", "'g'"),
    ("mass not symmetric", _set(["mass"], [[1.0, 2.0], [3.0, 1.0]]), "system.mass",
     "[[1.0, 2.0], [3.0, 1.0]] is not symmetric"),
    ("mass not definite", _set(["mass"], [[1.0, 2.0], [2.0, 1.0]]), "system.mass",
     "[[1.0, 2.0], [2.0, 1.0]] is not positive-definite"),
    ("mass singular", _set(["mass"], [[1.0, 1.0], [1.0, 1.0]]), "system.mass", "[[1.0, 1.0], [1.0, 1.0]]"),
    ("mass near singular", _set(["mass"], [1.0, 1e-14]), "system.mass", "[1.0, 1e-14]"),
    ("mass diagonal <= 0", _set(["mass"], [1.0, -0.1]), "system.mass.y", "-0.1"),
    ("mass diagonal 0", _set(["mass"], [0.0, 1.0]), "system.mass.x", "0.0"),
    ("mass short", _set(["mass"], [1.0]), "system.mass", "[1.0]"),
    ("mass ragged", _set(["mass"], [[1.0, 0.0], [0.0]]), "system.mass", "[[1.0, 0.0], [0.0]]"),
    ("mass mixed", _set(["mass"], [[1.0, 0.0], 1.0]), "system.mass", "[[1.0, 0.0], 1.0]"),
    ("mass bool", _set(["mass"], [1.0, True]), "system.mass.y", "True"),
    ("mass nan", _set(["mass", 1], NAN), "system.mass.y", "nan"),
    ("mass string", _set(["mass"], [[1.0, "0"], ["0", 1.0]]), "system.mass.x.y", "'0'"),
    ("mass missing", _set(["mass"], DEL), "system.mass", "missing"),
    ("mass overflows", _set(["mass"], [[1e308, 1e308], [1e308, 1e308]]), "system.mass", "1e+308"),
    ("stiffness not symmetric", _set(["stiffness", 0, 1], 0.5), "system.stiffness",
     "[[1.0, 0.5], [0.0, 0.0]] is not symmetric"),
    ("stiffness negative", _set(["stiffness"], [[1.0, 0.0], [0.0, -1.0]]), "system.stiffness",
     "[[1.0, 0.0], [0.0, -1.0]]"),
    ("stiffness indefinite", _set(["stiffness"], [[1.0, 2.0], [2.0, 1.0]]), "system.stiffness",
     "[[1.0, 2.0], [2.0, 1.0]]"),
    ("stiffness inf", _set(["stiffness", 1, 1], INF), "system.stiffness.y.y", "inf"),
    ("stiffness shape", _set(["stiffness"], [[1.0, 0.0, 0.0]] * 2), "system.stiffness", "[[1.0, 0.0, 0.0]"),
    ("stiffness missing", _set(["stiffness"], DEL), "system.stiffness", "missing"),
    ("damping shape", _set(["damping"], [[0.05]]), "system.damping", "[[0.05]]"),
    ("damping nan", _set(["damping", 0, 1], NAN), "system.damping.x.y", "nan"),
    ("damping not a list", _set(["damping"], 0.1), "system.damping", "0.1"),
    ("forcing not a list", _set(["forcing"], {"on": "x"}), "system.forcing", "{'on': 'x'}"),
    ("forcing entry", _set(["forcing", 0], 0.7), "system.forcing.0", "0.7"),
    ("forcing on", _set(["forcing", 0, "on"], "z"), "system.forcing.0.on", "'z'"),
    ("forcing on a number", _set(["forcing", 0, "on"], 0), "system.forcing.0.on", "0"),
    ("forcing on missing", _set(["forcing", 0, "on"], DEL), "system.forcing.0.on", "missing"),
    ("forcing F string", _set(["forcing", 0, "F"], "0.7"), "system.forcing.0.F", "'0.7'"),
    ("forcing F missing", _set(["forcing", 0, "F"], DEL), "system.forcing.0.F", "missing"),
    ("forcing Omega < 0", _set(["forcing", 0, "Omega"], -0.9), "system.forcing.0.Omega", "-0.9"),
    # a period 2 pi / Omega of inf (seen: a run crashed in model.system_period)
    ("forcing Omega tiny", _set(["forcing", 0, "Omega"], 5e-324), "system.forcing.0.Omega", "5e-324"),
    ("forcing phi inf", _set(["forcing", 0, "phi"], INF), "system.forcing.0.phi", "inf"),
    ("forcing unknown", _set(["forcing", 0, "omega"], 1.0), "system.forcing.0.omega", "did you mean 'Omega'"),
    ("contacts too many", _set(["contact"], NINE), "system.contact", f"{MAX_CONTACTS + 1} contacts"),
    ("contact not a list", _set(["contact"], {"name": "R"}), "system.contact", "{'name': 'R'}"),
    ("contact not a table", _set(["contact", 1], "L"), "system.contact.1", "'L'"),
    ("contact name long", _set(["contact", 0, "name"], "RR"), "system.contact.0.name", "'RR'"),
    ("contact name digit", _set(["contact", 0, "name"], "1"), "system.contact.0.name", "'1'"),
    ("contact name greek", _set(["contact", 0, "name"], "α"), "system.contact.0.name", "'α'"),
    ("contact name missing", _set(["contact", 0, "name"], DEL), "system.contact.0.name", "missing"),
    ("contact name twice", _set(["contact", 1, "name"], "R"), "system.contact.1.name", "'R'"),
    ("gap unknown dof", _set(["contact", 0, "gap", "z"], 1.0), "system.contact.R.gap.z", "'z'"),
    ("gap all zero", _set(["contact", 0, "gap"], {"x": 0.0, "y": 0.0}), "system.contact.R.gap",
     "{'x': 0.0, 'y': 0.0}"),
    ("gap empty", _set(["contact", 0, "gap"], {}), "system.contact.R.gap", "{}"),
    ("gap length", _set(["contact", 0, "gap"], [1.0]), "system.contact.R.gap", "[1.0]"),
    ("gap list zero", _set(["contact", 0, "gap"], [0.0, 0]), "system.contact.R.gap", "[0.0, 0]"),
    ("gap nan", _set(["contact", 0, "gap", "x"], NAN), "system.contact.R.gap.x", "nan"),
    ("gap bool", _set(["contact", 0, "gap", "x"], False), "system.contact.R.gap.x", "False"),
    ("gap missing", _set(["contact", 0, "gap"], DEL), "system.contact.R.gap", "missing"),
    ("gap a number", _set(["contact", 0, "gap"], 1.0), "system.contact.R.gap", "1.0"),
    ("law unknown", _set(["contact", 0, "law"], "impakt"), "system.contact.R.law", "'impakt'"),
    ("r > 1", _set(["contact", 0, "r"], 1.5), "system.contact.R.r", "1.5"),
    ("r < 0", _set(["contact", 0, "r"], -0.1), "system.contact.R.r", "-0.1"),
    ("r with a spring", _set(["contact", 1, "r"], 0.5), "system.contact.L.r", "0.5"),
    ("k with an impact", _set(["contact", 0, "k"], 50.0), "system.contact.R.k", "50.0"),
    ("k = 0", _set(["contact", 1, "k"], 0.0), "system.contact.L.k", "0.0"),
    ("k missing", _set(["contact", 1, "k"], DEL), "system.contact.L.k", "missing"),
    ("c < 0", _set(["contact", 1, "c"], -0.1), "system.contact.L.c", "-0.1"),
    ("obstacle unknown", _set(["contact", 0, "obstacle"], "sin"), "system.contact.R.obstacle", "'sin'"),
    ("obstacle profile", _set(["contact", 0, "obstacle"], "profile"), "system.contact.R.obstacle",
     "'profile'"),
    ("obstacle a number", _set(["contact", 0, "obstacle"], 1), "system.contact.R.obstacle", "1"),
    ("fixed with beta", _set(["contact", 0, "beta"], 0.5), "system.contact.R.beta", "0.5"),
    ("fixed with omega", _set(["contact", 0, "omega"], 2.0), "system.contact.R.omega", "2.0"),
    ("moving omega 0", _set(["contact", 0], {**MOVING, "omega": 0.0}), "system.contact.R.omega", "0.0"),
    ("moving omega tiny", _set(["contact", 0], {**MOVING, "omega": 1e-310}), "system.contact.R.omega",
     "1e-310"),
    ("moving omega missing", _set(["contact", 0], {k: v for k, v in MOVING.items() if k != "omega"}),
     "system.contact.R.omega", "missing"),
    ("moving beta nan", _set(["contact", 0], {**MOVING, "beta": NAN}), "system.contact.R.beta", "nan"),
    ("moving beta missing", _set(["contact", 0], {k: v for k, v in MOVING.items() if k != "beta"}),
     "system.contact.R.beta", "missing"),
    ("kappa string", _set(["contact", 0, "kappa"], "-0.4"), "system.contact.R.kappa", "'-0.4'"),
    ("contact unknown", _set(["contact", 0, "kapa"], 1.0), "system.contact.R.kapa", "did you mean 'kappa'"),
    ("system unknown", _set(["stifness"], 1.0), "system.stifness", "did you mean 'stiffness'"),
]


@pytest.mark.parametrize("change,key,value", [r[1:] for r in REFUSALS], ids=[r[0] for r in REFUSALS])
def test_refusals_name_the_key_and_the_value(change, key, value):
    """Each bad value is refused (no system) by a problem that starts with its key path and
    shows the value."""
    t = sketch()
    change(t)
    s, problems = read_system(t)
    assert s is None
    assert any(p.startswith(key + ":") and value in p for p in problems), problems


def test_a_table_that_is_not_one_is_refused():
    """[system] given as something else than a table."""
    assert read_system([1, 2]) == (None, ["system: [1, 2] must be a table"])


def test_every_path_of_the_sketch_round_trips():
    """numeric_paths names every number of the sketch, the issue's names among them; setting
    each by with_value changes that number (and a symmetric matrix's mirror entry) only,
    in a copy."""
    t = sketch()
    paths = numeric_paths(t)
    assert {"forcing.0.Omega", "contact.R.kappa", "mass.y", "stiffness.x.x", "damping.x.y",
            "contact.R.gap.x", "contact.L.k", "contact.L.c", "contact.R.r"} <= set(paths)
    assert len(paths) == 2 + 4 + 4 + 3 + 4 + 5     # mass, K, C, forcing, R, L
    assert paths["mass.y"] == 0.1 and paths["contact.R.gap.x"] == -1.0
    for path, v in paths.items():
        new = with_value(t, path, v + 0.125)
        got = numeric_paths(new)
        assert got[path] == v + 0.125
        head, *ij = path.split(".")
        mirror = f"{head}.{ij[1]}.{ij[0]}" if head in ("mass", "stiffness") and len(ij) == 2 else path
        changed = {p for p in paths if got[p] != paths[p]}
        assert changed == {path, mirror}, path
        assert numeric_paths(t) == paths             # the original is untouched


def test_with_value_keeps_stiffness_symmetric_and_damping_not():
    """"stiffness.x.y" sets K_xy and K_yx; "damping.x.y" sets C_xy alone."""
    t = with_value(sketch(), "stiffness.x.y", 0.25)
    assert t["stiffness"] == [[1.0, 0.25], [0.25, 0.0]]
    t = with_value(t, "stiffness.y.y", 1.0)
    s, problems = read_system(t)
    assert problems == [] and s.stiffness[0, 1] == s.stiffness[1, 0] == 0.25
    t = with_value(sketch(), "damping.x.y", 0.01)
    assert t["damping"] == [[0.05, 0.01], [0.0, 0.0]]


def test_with_value_sweeps_a_list_gap_and_a_moving_obstacle():
    """A gap given as a list is still named by dof; the paper's flow's omega is a path."""
    t = paper_flow()
    t["contact"][0]["gap"] = [1.0]
    assert with_value(t, "contact.A.gap.x", 2.0)["contact"][0]["gap"] == [2.0]
    assert read_system(with_value(t, "contact.A.omega", 1.9))[0].contacts[0].omega == 1.9


@pytest.mark.parametrize("path", ["stiffness.x.z", "contact.R.kapa", "contact.L.r", "mass.x.y", "dofs"])
def test_an_unknown_path_raises_a_key_error_naming_it(path):
    """A path that is not a number of the table (a typo; a default not written, r of L; an
    entry off a diagonal mass; a name, not a number) is a KeyError naming it."""
    with pytest.raises(KeyError) as e:
        with_value(sketch(), path, 1.0)
    assert repr(path) in str(e.value)
    if path == "contact.R.kapa":
        assert "contact.R.kappa" in str(e.value)


def test_a_dof_cannot_take_an_impacts_dataset_name():
    """The names refused for a coordinate (declare.IMPACT_NAMES) are exactly the impacts'
    own datasets beside the coordinates' (model.BASE_FIELDS, and CORNER_FIELDS with the
    paper's words): impacts/<dof> would be written twice (seen: dofs named u and
    corner_offset crashed the writer with "name already exists")."""
    from cornerbif.models.linear.declare import IMPACT_NAMES
    from cornerbif.models.linear.model import BASE_FIELDS, CORNER_FIELDS
    assert set(IMPACT_NAMES) == {f.name.split("/", 1)[1] for f in BASE_FIELDS + CORNER_FIELDS}


def test_no_numba_is_loaded():
    """Reading a scene's system imports no numba (the issue: checking a scene is quick)."""
    code = ("import sys, tomllib; from cornerbif.models.linear.declare import read_system; "
            f"assert read_system(tomllib.loads({SKETCH!r})['system'])[1] == []; "
            "assert 'numba' not in sys.modules, 'numba imported'")
    subprocess.run([sys.executable, "-c", code], check=True)


# ------------------------------------------------------------------ random systems
FLOATS = st.floats(-2.0, 2.0, allow_subnormal=False)


@st.composite
def systems(draw):
    """A random valid [system] table: N = 1..6, M = A A^T + I (not symmetrized: its rounding
    is tolerated), K = B B^T of any rank, C = D D^T + G - G^T (dissipative with a gyroscopic
    part), forces and contacts."""
    n = draw(st.integers(1, MAX_DOFS))
    dofs = [f"q{i}" for i in range(n)]
    A = np.array(draw(st.lists(FLOATS, min_size=n * n, max_size=n * n))).reshape(n, n)
    rank = draw(st.integers(0, n))
    B = np.array(draw(st.lists(FLOATS, min_size=n * rank, max_size=n * rank))).reshape(n, rank)
    D, G = (np.array(draw(st.lists(FLOATS, min_size=n * n, max_size=n * n))).reshape(n, n) for _ in "DG")
    table = {"dofs": dofs, "mass": (A @ A.T + np.eye(n)).tolist(), "stiffness": (B @ B.T).tolist(),
             "damping": (D @ D.T + G - G.T).tolist(),
             "forcing": [{"on": draw(st.sampled_from(dofs)), "F": f,
                          "Omega": abs(o) if abs(o) >= 1e-300 else 0.0}      # (a period: a float)
                         for f, o in draw(st.lists(st.tuples(FLOATS, FLOATS), max_size=3))]}
    contacts = []
    for name in draw(st.lists(st.sampled_from("ABCDEFGHxyz"), unique=True, max_size=MAX_CONTACTS)):
        gap = dict(zip(dofs, draw(st.lists(FLOATS, min_size=n, max_size=n))))
        gap[draw(st.sampled_from(dofs))] = 1.0         # not all zero
        c = {"name": name, "gap": gap, "kappa": draw(FLOATS)}
        moving = draw(st.booleans())
        if moving:
            c.update(obstacle=draw(st.sampled_from(["sine", "rectified_sine", "triangle"])),
                     beta=draw(FLOATS.filter(lambda b: b != 0.0)),   # 0: the fixed one
                     omega=draw(st.floats(0.1, 5.0)))
        # a soft stop: on a fixed obstacle, at most MAX_SOFT of them
        if not moving and sum(x.get("law") == "spring" for x in contacts) < MAX_SOFT \
                and draw(st.booleans()):
            c.update(law="spring", k=draw(st.floats(0.1, 100.0)), c=draw(st.floats(0.0, 1.0)))
        else:
            c["r"] = draw(st.floats(0.0, 1.0))
        contacts.append(c)
    table["contact"] = contacts
    return table


@settings(max_examples=150, deadline=None)
@given(systems())
def test_random_valid_systems_parse(table):
    """Every random valid table parses, into arrays of the declared size."""
    s, problems = read_system(table)
    assert problems == []
    assert s.mass.shape == s.stiffness.shape == s.damping.shape == (s.n, s.n)
    assert len(s.contacts) == len(table["contact"])
    for path, v in numeric_paths(table).items():      # and every number has a path
        assert numeric_paths(with_value(table, path, v)) == numeric_paths(table)


@settings(max_examples=100, deadline=None)
@given(systems().filter(lambda t: len(t["dofs"]) >= 2), st.data())
def test_a_random_non_symmetric_mass_is_refused(table, data):
    """Moving one off-diagonal mass entry by more than rounding is refused as not symmetric."""
    n = len(table["dofs"])
    i, j = data.draw(st.sampled_from([(i, j) for i in range(n) for j in range(n) if i != j]))
    m = copy.deepcopy(table["mass"])
    scale = max(abs(x) for row in m for x in row)
    m[i][j] += data.draw(st.sampled_from([-1, 1])) * data.draw(st.floats(1e-9, 1.0)) * scale
    table["mass"] = m
    s, problems = read_system(table)
    assert s is None
    assert any(p.startswith(f"system.mass: {shown(m)} is not symmetric") for p in problems), problems


def test_a_moving_obstacle_of_no_height_is_refused():
    """beta = 0 on a moving kind is the fixed obstacle z = kappa; on a triangle it would be
    slopes 0 and pieces of 0 / 0 time (seen in review: NaN pieces, an impact at the start).
    Refused, naming the key and the value, for every moving kind."""
    for kind in ("sine", "rectified_sine", "triangle"):
        table = {"dofs": ["x"], "mass": [1.0], "stiffness": [1.0],
                 "contact": [{"name": "R", "gap": {"x": 1.0}, "obstacle": kind, "beta": 0.0,
                              "omega": 2.0}]}
        system, problems = read_system(table)
        assert system is None
        assert any(p.startswith("system.contact.R.beta: 0.0 is 0") and "fixed" in p
                   for p in problems), problems


# ------------------------------------------------------------------ names and their datasets
def _with_dof(name, at=1):
    """The sketch with its dof ``at`` (0: x, 1: y) renamed ``name`` everywhere."""
    t = sketch()
    old = t["dofs"][at]
    t["dofs"][at] = name
    for c in t["contact"]:
        c["gap"] = {name if d == old else d: v for d, v in c["gap"].items()}
    for f in t["forcing"]:
        f["on"] = name if f["on"] == old else f["on"]
    return t


# a dof named so would write a dataset the file holds already: an impact's own (impacts/u),
# its velocity an impact's (in: impacts/v_in), or a group's scale (impacts/ic, impacts/record)
COLLIDING = ["t", "contact", "u", "corner_offset", "in", "out", "ic", "record", "v_in", "v_x"]


@pytest.mark.parametrize("at", [0, 1])
@pytest.mark.parametrize("name", COLLIDING)
def test_a_dof_whose_datasets_the_file_holds_is_refused(name, at):
    """Seen: dofs named "in" and "out" passed validate, then the writer crashed with "name
    already exists" (impacts/v_in twice); "ic" and "record" crashed it the same way (the
    scales each group holds).  Each is refused naming system.dofs.<i> and the value."""
    s, problems = read_system(_with_dof(name, at))
    assert s is None
    assert any(p.startswith(f"system.dofs.{at}: {name!r}") for p in problems), problems


def test_the_names_a_dof_may_not_take_are_the_files_own():
    """declare.FILE_NAMES are the datasets the writer puts beside a dof's in its groups: an
    impact's own (model.BASE_FIELDS and CORNER_FIELDS) and the scales io.create copies
    into each group (ic; record where the impacts are), read from a file the writer made."""
    from cornerbif.models.linear.declare import FILE_NAMES, GROUP_SCALES, IMPACT_NAMES, dataset_names
    from cornerbif.models.linear.model import BASE_FIELDS, CORNER_FIELDS
    assert set(IMPACT_NAMES) == {f.name.split("/", 1)[1] for f in BASE_FIELDS + CORNER_FIELDS}
    assert set(FILE_NAMES) == set(IMPACT_NAMES) | set(GROUP_SCALES)
    assert dataset_names("x") == ("x", "v_x")


NAMES = st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,6}", fullmatch=True) | st.sampled_from(
    ["in", "out", "in_", "_in", "ic", "ic_", "record", "records", "x_in", "u_", "t_", "status", "done",
     "period", "symbols", "impacts", "initial", "final", "cycle", "attractor", "é", "θ_1", "x" * 64])


@settings(max_examples=200, deadline=None)
@given(name=NAMES)
def test_every_dof_name_accepted_makes_a_file_the_writer_can_write(tmp_path_factory, name):
    """Whatever name a dof is allowed, the writer allocates every dataset of the scene
    (io.create: no name twice), its own and its velocity's among them."""
    import h5py

    from cornerbif import io
    table = {"dofs": [name, "q"], "mass": [1.0, 1.0], "stiffness": [1.0, 1.0],
             "contact": [{"name": "R", "gap": {name: 1.0}, "kappa": -1.0}]}
    if read_system(table)[1]:
        return
    text = ("[scene]\nname = \"n\"\nmodel = \"linear\"\n" + _toml_system(table)
            + "[sweep]\n\"contact.R.kappa\" = { values = [-1.0, -0.5] }\n[initial]\ncount = 1\n"
            "[run]\ntransient = 5\nrecord = 5\n")
    from cornerbif import config
    scene = config.loads(text)
    path = tmp_path_factory.mktemp("names") / "n.h5"
    io.create(path, scene, 1).close()
    with h5py.File(path) as f:
        assert {name, f"v_{name}"} <= set(f["impacts"]) and {name, f"v_{name}"} <= set(f["final"])


def _toml_system(table) -> str:
    from cornerbif import config
    return config.dumps({"system": table})


def test_a_dof_name_is_at_most_64_characters():
    """A 100 000-character dof name was accepted and written; a coordinate's name has at most
    MAX_NAME characters, and a longer one is refused with its value shortened.  A contact's
    name is one letter: a long one is refused, shortened too."""
    from cornerbif.models.linear.declare import MAX_NAME
    assert MAX_NAME == 64
    assert read_system(_with_dof("y" * 64))[1] == []
    for n in (65, 100_000):
        s, problems = read_system(_with_dof("y" * n))
        assert s is None
        (p,) = [p for p in problems if p.startswith("system.dofs.1:")]
        assert f"is {n} characters long" in p and "at most 64" in p and len(p) < 300, p
        assert f"<{n} characters>" in p or n < 80, p
    t = sketch()
    t["contact"][0]["name"] = "R" * 100_000
    s, problems = read_system(t)
    assert s is None
    (p,) = [p for p in problems if p.startswith("system.contact.0.name:")]
    assert "<100000 characters>" in p and len(p) < 300, p


# ------------------------------------------------------------------ damping
@pytest.mark.parametrize("damping,smallest", [
    ([-1e300, -1e300], "-1e+300"),
    ([[1, 5], [-7, -3]], "-3.23607"),
    ([0.1, -0.01], "-0.01"),
    ([[0.0, 1.0], [1.0, 0.0]], "-1"),          # symmetric, indefinite
])
def test_a_damping_whose_symmetric_part_is_not_semi_definite_is_refused(damping, smallest):
    """Negative damping feeds the free motion without bound (as a K not semi-definite):
    refused naming system.damping, its value and the smallest eigenvalue of (C + C^T) / 2
    (seen: [-1e300, -1e300] and [[1, 5], [-7, -3]] validated "ok")."""
    t = sketch()
    t["damping"] = damping
    s, problems = read_system(t)
    assert s is None
    (p,) = problems
    assert p.startswith(f"system.damping: {shown(damping)} is not positive semi-definite"), p
    assert smallest in p, p


@pytest.mark.parametrize("damping", [
    [[1, 5], [-5, 1]],                   # damped and gyroscopic
    [[0.0, 1.0], [-1.0, 0.0]],           # purely gyroscopic: its symmetric part is 0
    [[1.0, 1.0], [1.0, 1.0]],            # semi-definite (a zero eigenvalue)
    [[1.0, 1.0 + 1e-13], [1.0 + 1e-13, 1.0]],   # indefinite by rounding: within PSD_TOL
    [0.0, 0.0],
])
def test_a_gyroscopic_or_semi_definite_damping_is_allowed(damping):
    t = sketch()
    t["damping"] = damping
    s, problems = read_system(t)
    assert problems == []
    np.testing.assert_array_equal(s.damping, np.diag(damping) if np.ndim(damping) == 1 else damping)


# ------------------------------------------------------------------ sizes past float64
SIZES = [
    # {key path: value}, the key refused (None: accepted)
    ({("mass",): [1e300, 1e300]}, None),
    ({("mass",): [1e-310, 1.0]}, "system.mass"),                 # M^-1 overflows
    ({("mass",): [1e308, 1e308]}, "system.mass"),                # its eigenvalues overflow
    ({("mass",): [1e-300, 1e-300]}, "system.mass"),              # tiny: M^-1 F past MAX_RATE
    ({("stiffness",): [[1e200, 0.0], [0.0, 0.0]]}, "system.stiffness"),
    ({("stiffness",): [[1e20, 0.0], [0.0, 0.0]]}, "system.stiffness"),
    ({("stiffness",): [[1e11, 0.0], [0.0, 0.0]]}, None),
    ({("damping",): [[1e300, 0.0], [0.0, 0.0]]}, "system.damping"),
    ({("forcing", 0, "F"): 1e300}, "system.forcing.0.F"),
    ({("forcing", 0, "Omega"): 1e13}, "system.forcing.0.Omega"),
    ({("contact", 0, "gap"): {"x": 1e200}}, "system.contact.R.gap"),   # a^T M^-1 a overflows
    ({("contact", 0, "gap"): {"x": 1e-160}}, "system.contact.R.gap"),  # ... or underflows
    ({("contact", 0, "gap"): {"x": 1e100}}, None),
    ({("contact", 0, "gap"): {"x": 1e100}, ("stiffness",): [[1e10, 0.0], [0.0, 0.0]]},
     "system.contact.R.gap"),                                      # |a| |A|^20 overflows
    ({("contact", 0, "gap"): {"x": 1e40}, ("stiffness",): [[1e11, 0.0], [0.0, 0.0]]}, None),
]


@pytest.mark.parametrize("changes,key", SIZES, ids=[
    " ".join(f"{'.'.join(map(str, p))}={v}" for p, v in c.items()) for c, _ in SIZES])
def test_sizes_past_float64_are_refused_without_a_warning(changes, key):
    """Numbers each finite whose products or inverses overflow (M^-1, M^-1 K, a^T M^-1 a,
    the kernel's powers of the flight's matrix) are refused naming the key, and no numpy
    RuntimeWarning is raised on the way (seen: declare.py's overflow for mass = [1e300],
    kernel.py's for a stiffness of 1e200); those accepted prepare the kernel's arrays
    without one either."""
    t = sketch()
    for path, value in changes.items():
        _set(list(path), value)(t)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        s, problems = read_system(t)
        if key is None:
            assert problems == []
            from cornerbif.models.linear.kernel import prepare
            s = dataclasses.replace(s, contacts=tuple(c for c in s.contacts if c.law == "impact"))
            got = prepare(s, 0.0, np.zeros(s.n), np.zeros(s.n))
            assert all(np.isfinite(got[k]).all() for k in ("A", "cA", "cAs", "D", "N", "E"))
            return
    assert s is None
    assert any(p.startswith(key + ":") for p in problems), problems
    assert all("nan" not in p for p in problems), problems


def test_the_cli_says_no_runtime_warning_for_a_huge_mass():
    """The audit's case: `--set 'system.mass=[1e300]'` on configs/bouncing_ball.toml printed
    declare.py's overflow warning before its verdict."""
    for value, code in (("[1e300]", 0), ("[1e-310]", 2), ("[1e308]", 2)):
        r = subprocess.run([sys.executable, "-m", "cornerbif.cli", "validate", "configs/bouncing_ball.toml",
                            "--set", f"system.mass={value}"], capture_output=True, text=True, cwd=ROOT)
        assert r.returncode == code, r.stderr
        assert "Warning" not in r.stderr and "Traceback" not in r.stderr, r.stderr
        if code:
            assert "system.mass: " in r.stderr and value.strip("[]") in r.stderr.replace("+", ""), r.stderr


# ------------------------------------------------------------------ many settings at once
VALUES = FLOATS | st.sampled_from([0.0, -1.0, 1e-300, -1e-300, 1e300, -1e300, 1e13, 1e-13, 1e154, 5e-324,
                                   1e-310, 1e100, 1e-160, 2.0 ** -30])


@settings(max_examples=150, deadline=None)
@given(systems(), st.data())
def test_refusable_flags_every_setting_read_system_refuses(table, data):
    """declare.refusable (a sweep's combinations, all at once) flags every setting of the
    chosen numbers that read_system refuses, as the sweep sets them (with_value where a
    value differs from the table's), bad values and sizes past float64 among them; the
    table's own values are not flagged."""
    from cornerbif.models.linear.declare import refusable
    defaults = numeric_paths(table)
    chosen = data.draw(st.lists(st.sampled_from(sorted(defaults)), min_size=1, max_size=3, unique=True))
    rows = data.draw(st.lists(st.lists(VALUES, min_size=len(chosen), max_size=len(chosen)),
                              min_size=1, max_size=6))
    rows.append([defaults[p] for p in chosen])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        flags = refusable(table, chosen, rows)
    assert not flags[-1]
    for row, flag in zip(rows, flags):
        t = table
        for p, v in zip(chosen, row):
            if v != defaults[p]:
                t = with_value(t, p, v)
        if read_system(t)[0] is None:
            assert flag, (dict(zip(chosen, row)), read_system(t)[1])


LINEAR = """[scene]
name = "big"
model = "linear"
[system]
dofs = ["a", "b", "c", "d", "e", "f"]
mass = [[2.0, 0.1, 0.0, 0.0, 0.0, 0.0], [0.1, 2.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
        [0.0, 0.0, 0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0, 1.0]]
stiffness = [[2.0, -1.0, 0.0, 0.0, 0.0, 0.0], [-1.0, 2.0, -1.0, 0.0, 0.0, 0.0],
             [0.0, -1.0, 2.0, -1.0, 0.0, 0.0], [0.0, 0.0, -1.0, 2.0, -1.0, 0.0],
             [0.0, 0.0, 0.0, -1.0, 2.0, -1.0], [0.0, 0.0, 0.0, 0.0, -1.0, 2.0]]
damping = [[0.1, 0.0, 0.0, 0.0, 0.0, 0.0], [0.0, 0.1, 0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.1, 0.0, 0.0, 0.0],
           [0.0, 0.0, 0.0, 0.1, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0, 0.1, 0.0], [0.0, 0.0, 0.0, 0.0, 0.0, 0.1]]
forcing = [{ on = "a", F = 0.5, Omega = 1.2 }]
""" + "".join(f'[[system.contact]]\nname = "{n}"\ngap = {g}\nkappa = -1.0\n' for n, g in (
    ("A", "{ a = 1.0 }"), ("B", "{ b = 1.0 }"), ("C", "{ c = 1.0 }"), ("D", "{ d = 1.0 }"),
    ("E", "{ e = 1.0 }"), ("F", "{ f = 1.0 }"), ("G", "{ a = -1.0 }"), ("H", "{ b = 1.0, a = -1.0 }"))) + """
[initial]
count = 1
[run]
transient = 5
record = 5
[sweep]
"""


def test_a_sweep_of_the_most_combinations_is_checked_well_under_a_second():
    """6 dofs, 8 contacts, two matrix entries of 141 values each: 19 881 combinations (under
    MAX_CHECKED_COMBINATIONS), each a system checked before the run.  Read one by one (about
    1.3 ms each) validate took 25 s; all at once (declare.refusable) a few tens of
    milliseconds.  The first bad one is still named as before."""
    import time

    from cornerbif import config
    from cornerbif.config import SceneError
    grid = ('"stiffness.a.b" = { start = -1.0, stop = 0.0, num = 141 }\n'
            '"mass.a.b" = { start = 0.0, stop = 0.5, num = 141 }\n')
    config.loads(LINEAR + grid)                      # (imports and caches warm; CPU seconds:
    #                                                  the test's machine may be busy)
    t0 = time.process_time()
    config.loads(LINEAR + grid)
    assert time.process_time() - t0 < 1.0
    # mass entries past the diagonal's (2.0): M is not positive-definite there
    stiff, mass = np.linspace(-1.0, 0.0, 141).tolist(), np.linspace(0.0, 2.5, 141).tolist()
    bad = f'"stiffness.a.b" = {{ values = {stiff} }}\n"mass.a.b" = {{ values = {mass} }}\n'
    t0 = time.process_time()
    with pytest.raises(SceneError) as e:
        config.loads(LINEAR + bad)
    assert time.process_time() - t0 < 1.0
    from cornerbif import registry
    spec = registry.get("linear").for_system(tomllib.loads(LINEAR)["system"])[0]
    want = _one_by_one(spec, [("stiffness.a.b", tuple(stiff)), ("mass.a.b", tuple(mass))])
    assert want.startswith("system.mass: ") and "sweep.stiffness.a.b = -1.0, " in want, want
    assert e.value.problems == [want], (e.value.problems, want)


def _one_by_one(spec, axes):
    """The problem the linear model's check said before it checked many at once: every
    combination of the numbers checked together, then each other axis alone, each system
    read whole (model.system_of) in order; here with the pass of the forces at their largest
    the check adds."""
    import itertools

    from cornerbif.models.linear.model import _checked_together, _grows
    joint = [(n, v) for n, v in axes if _checked_together(n)]
    groups = ([joint] if joint else []) + [[(n, v)] for n, v in axes if not _checked_together(n)]
    grows = [(n, (max(v, key=abs),)) for n, v in axes if not _checked_together(n) and _grows(n)]
    if grows and (joint or len(grows) > 1):
        groups.append(joint + grows)
    for group in groups:
        for combo in itertools.product(*[v for _, v in group]):
            values = dict(zip([n for n, _ in group], combo))
            _, bad = spec.system_of(values)
            if bad:
                where = ", ".join(f"sweep.{k} = {v!r}" for k, v in values.items())
                return f"{bad[0]} (at {where})"
    return None


SWEPT = {
    "mass.a.b": [0.0, 0.5, 1.0, 1.5, 1.9, 2.0, 3.0], "mass.c.c": [1.0, 0.5, 1e-13, -0.1],
    "stiffness.a.b": [-1.0, -1.5, -2.0, 0.5], "stiffness.f.f": [2.0, 0.0, -1.0, 1e14],
    "damping.a.b": [0.0, 0.2, -0.3, 5.0], "damping.b.a": [0.0, -0.2, -5.0],
    "contact.H.gap.a": [-1.0, 0.0, 1e200], "contact.H.gap.b": [1.0, 0.0],
    "forcing.0.F": [0.5, 1e11, 1e13], "forcing.0.Omega": [1.2, 0.0, 1e11],
}


@settings(max_examples=60, deadline=None)
@given(st.data())
def test_the_check_at_once_says_what_one_by_one_said(data):
    """Random sweeps over matrix entries, gap coefficients and forces, valid or not: the
    model's check (declare.refusable, then the flagged ones read whole) names the same first
    bad combination as reading every combination one by one."""
    from cornerbif import registry
    table = tomllib.loads(LINEAR)["system"]
    spec, problems = registry.get("linear").for_system(table)
    assert problems == []
    names = data.draw(st.lists(st.sampled_from(sorted(SWEPT)), min_size=1, max_size=4, unique=True))
    axes = [(n, tuple(data.draw(st.lists(st.sampled_from(SWEPT[n]), min_size=1, max_size=4, unique=True))))
            for n in names]

    from types import SimpleNamespace
    ctx = SimpleNamespace(follow=None, axes=[SimpleNamespace(name=n, values=v) for n, v in axes],
                          ranges={}, swept=lambda name: None)
    got = spec.check(ctx)
    want = _one_by_one(spec, axes)
    assert got == ([want] if want else []), (axes, got, want)


@pytest.mark.slow
@pytest.mark.parametrize("name", ["a", "x1", "in_", "é", "θ_1", "d" * 64])
def test_a_tiny_sweep_writes_a_file_for_unusual_legal_names(name, tmp_path):
    """Legal names close to the refused ones (in_, beside in; x1 beside x_1) and names not
    ASCII run a sweep and write its file: each coordinate's and velocity's dataset in each
    group, beside the impacts' own."""
    import h5py
    from click.testing import CliRunner

    from cornerbif.cli import main
    scene = tmp_path / "s.toml"
    scene.write_text(f'[scene]\nname = "names"\nmodel = "linear"\n[system]\ndofs = ["{name}"]\nmass = [1.0]\n'
                     f'stiffness = [0.0]\nforcing = [{{ on = "{name}", F = -1.0 }}]\n[[system.contact]]\n'
                     f'name = "T"\ngap = {{ "{name}" = 1.0 }}\nobstacle = "sine"\nbeta = 0.036\nomega = 6.0\n'
                     'r = 0.5\n[sweep]\n"contact.T.beta" = { values = [0.036, 0.037] }\n'
                     f'[initial]\n"{name}" = [0.0, 0.5]\n"v_{name}" = [-0.5, 1.0]\n', encoding="utf-8")
    out = tmp_path / "s.h5"
    r = CliRunner().invoke(main, ["sweep", str(scene), "-o", str(out), "--no-progress", "--set",
                                  "initial.count=1", "--set", "run.transient=5", "--set", "run.record=5"])
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        for group in ("initial", "final", "impacts"):
            assert {name, f"v_{name}"} <= set(f[group]), (group, list(f[group]))
        assert {"t", "u", "v_in", "v_out", "contact"} <= set(f["impacts"])
        assert np.isfinite(f[f"impacts/{name}"][...]).any()


def test_a_sweep_whose_mass_and_force_together_pass_the_rates_is_refused():
    """A tiny mass allowed with the table's force and a large force allowed with the table's
    mass make, together (a point of the grid), a flight's matrix past MAX_RATE: the
    matrices' combinations are checked again with each swept F and Omega at its largest,
    and the point is named (else it would be found mid-sweep)."""
    from cornerbif import config
    from cornerbif.config import SceneError
    ball = ('[scene]\nname = "b"\nmodel = "linear"\n[system]\ndofs = ["x"]\nmass = [1.0]\nstiffness = [0.0]\n'
            'forcing = [{ on = "x", F = -1.0 }]\n[[system.contact]]\nname = "T"\ngap = { x = 1.0 }\n'
            '[initial]\ncount = 1\n[sweep]\n')
    config.loads(ball + '"mass.x" = { values = [1.0, 1e-6] }\n')
    config.loads(ball + '"forcing.0.F" = { values = [-1.0, -1e7] }\n')
    with pytest.raises(SceneError) as e:
        config.loads(ball + '"mass.x" = { values = [1.0, 1e-6] }\n'
                     '"forcing.0.F" = { values = [-1.0, -1e7] }\n')
    (p,) = e.value.problems
    assert p.startswith("system.forcing.0.F: -10000000.0 gives the flight's matrix A"), p
    assert "the mass is [1e-06]" in p and "past 1e+12" in p, p
    assert p.endswith("(at sweep.mass.x = 1e-06, sweep.forcing.0.F = -10000000.0)"), p
