"""Figs. 19(a) and 20(a) written as linear scenes, with the two-particle model's words (issue 33:
"... Figs. 19(a) and 20(a) written as linear scenes give the same words and periods at every
run as flow and two_particle, and impacts equal to 1e-10").

Section 6's two particles are a linear system of two coordinates: z of mass 1 (z'' + omega1^2
z = 0) above the wall w = kappa + beta sin(omega0 t) (contact W: the gap z - w, law (5) with
r1), and u (named q: ``u`` is the impacts' own dataset) of mass 1/mu (stiffness omega2^2 /
mu) above z (contact U: the gap q - z, law (74) with r2).  ``[system] words = { impacts = "U",
corners = "W", height = "z", velocity = "q" }`` gives the scene the two-particle model's
words: only the U impacts are recorded, each with its height z, the velocities of q before
and after, and its offset to the W impacts (to the previous one unless the next is strictly
nearer: ``analysis.settle_corner_offsets``, the rule the two-particle kernel calls too), and
its cycles are that model's (``analysis.detect_cycles`` over them).

The expected numbers come from the two-particle kernel (models/two_particle/kernel.py), a
different code: the closed-form harmonic flights of each particle, Sturm-certified event
search and section-relative time, where the linear loop takes matrix exponentials of the
augmented system, gap polynomials and its certified steps. From the same starts over a grid
of omega0, 500 transient and 100 recorded u-z impacts: every run's status, word, period and
impacts per cycle are equal, and every recorded impact's time, v_in, v_out and corner offset
are equal to 1e-10 (measured: at most 6.5e-11 on Fig. 19(a)'s grid of 186 runs, all on
cycles of 14 distinct words; 1.7e-11 on Fig. 20(a)'s, 15 words). The height u = z at the
impact differs by up to 6.6e-10 (Fig. 19(a)) and 2.7e-10 (Fig. 20(a)): there z moves at |z'|
= 17.8 while the gap u - z closes at 0.094, so the impact time, which each kernel resolves
to its tolerance on a slowly closing gap, differs by up to 3.6e-11, and z moves by z' dt in
between; with that taken out (u - z' dt, z' the two-particle kernel's y_in) the heights are
equal to 1e-10 (measured 8.1e-11 and 5.5e-11): the same point of the same flight.
"""

import os
import tomllib

import numpy as np
import pytest

import cornerbif

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
FIGS = ("fig19a", "fig20a")


def _scene(name):
    with open(os.path.join(ROOT, "configs", f"{name}.toml"), "rb") as fh:
        return tomllib.load(fh)


def _grid_and_starts(fig):
    """A grid of 31 omega0 over the figure's axis and 6 starts drawn as the two-particle
    model draws them (z above the wall at t = 0, u above z), in the figure's ranges."""
    s = _scene(fig)
    ax = s["sweep"]["omega0"]
    om = np.linspace(ax["start"], ax["stop"], 31)
    ini = s["initial"]
    rng = np.random.default_rng(3)
    z0 = rng.uniform(*ini["z"], 6)
    y0 = rng.uniform(*ini["y"], 6)
    u0 = z0 + rng.uniform(0.0, ini["u"][1] - ini["z"][1], 6)
    v0 = rng.uniform(*ini["v"], 6)
    return om, (z0, y0, u0, v0)


@pytest.mark.parametrize("fig", FIGS)
def test_the_two_particles_as_a_linear_scene_have_the_two_particle_words(fig):
    om, (z0, y0, u0, v0) = _grid_and_starts(fig)
    s = _scene(fig)
    lin_scene = _scene(f"{fig}_linear")
    run = dict(transient=500, record=100)
    tp = cornerbif.simulate(z0[:, None], y0[:, None], u0[:, None], v0[:, None],
                            model="two_particle", **{**s["system"], "omega0": om[None, :]}, **run)
    lin = cornerbif.simulate(model="linear", table=lin_scene["system"], z0=z0[:, None],
                             v_z0=y0[:, None], q0=u0[:, None], v_q0=v0[:, None],
                             **{"contact.W.omega": om[None, :]}, **run)
    for k in ("status", "symbols", "period", "impacts_per_cycle"):
        np.testing.assert_array_equal(np.asarray(lin[k]), np.asarray(tp[k]), err_msg=k)
    for k in ("t", "v_in", "v_out", "corner_offset", "u"):
        a, b = np.asarray(lin[k], float), np.asarray(tp[k], float)
        np.testing.assert_array_equal(np.isnan(a), np.isnan(b), err_msg=k)
        if k != "u":
            np.testing.assert_allclose(a, b, rtol=0, atol=1e-10, err_msg=k)
    # u = z at the impact: the same point of the same flight (module docstring)
    dt = np.asarray(lin["t"], float) - np.asarray(tp["t"], float)
    du = np.asarray(lin["u"], float) - np.asarray(tp["u"], float) - np.asarray(tp["y_in"]) * dt
    np.testing.assert_allclose(du, 0.0, atol=1e-10)
    np.testing.assert_allclose(np.asarray(lin["u"], float), np.asarray(tp["u"], float),
                               atol=1e-9)
    # the grid crosses the figure's cascades: many words, alpha and gamma clusters among them
    # (measured: 14 distinct words on Fig. 19(a)'s grid, 15 on Fig. 20(a)'s)
    words = set(np.asarray(tp["symbols"]).ravel()) - {""}
    assert len(words) >= 10 and any("a" in w for w in words) and any("g" in w for w in words)
    assert (np.asarray(tp["status"]) == 0).mean() > 0.9


def test_the_shipped_linear_scenes_are_fig19a_and_fig20a():
    """configs/fig19a_linear.toml and fig20a_linear.toml are fig19a.toml's and fig20a.toml's
    system, axis, starts and run settings, written as above."""
    for fig in FIGS:
        lin, tp = _scene(f"{fig}_linear"), _scene(fig)
        p, sy = tp["system"], lin["system"]
        assert sy["dofs"] == ["z", "q"]
        assert sy["mass"] == [1.0, 1.0 / p["mu"]]
        assert sy["stiffness"] == [p["omega1"] ** 2, p["omega2"] ** 2 / p["mu"]]
        assert "damping" not in sy and "forcing" not in sy
        assert sy["words"] == {"impacts": "U", "corners": "W", "height": "z", "velocity": "q"}
        w, u = sy["contact"]
        assert (w["name"], w["gap"], w["obstacle"]) == ("W", {"z": 1.0}, "sine")
        assert (w["kappa"], w["beta"], w["omega"], w["r"]) == \
            (p["kappa"], p["beta"], p["omega0"], p["r1"])
        assert (u["name"], u["gap"], u.get("obstacle", "fixed"), u.get("kappa", 0.0), u["r"]) \
            == ("U", {"z": -1.0, "q": 1.0}, "fixed", 0.0, p["r2"])
        assert lin["sweep"] == {"contact.W.omega": tp["sweep"]["omega0"]}
        assert lin["run"] == tp["run"]
        ini, tini = lin["initial"], tp["initial"]
        assert (ini["count"], ini["seed"]) == (tini["count"], tini["seed"])
        assert (ini["z"], ini["v_z"], ini["q"], ini["v_q"]) == \
            (tini["z"], tini["y"], tini["u"], tini["v"])
        assert lin["plot"] == tp["plot"]
        from cornerbif import config
        scene = config.load(os.path.join(ROOT, "configs", f"{fig}_linear.toml"))
        assert not scene.spec.contact_words
        assert "impacts/corner_offset" in {f.name for f in scene.spec.observables["impacts"]}


BAD_WORDS = {
    # [system] words as given: a piece of the message that must name key and value
    '"U"': r"system\.words: 'U' must be a table naming two contacts",
    '{ impacts = "U" }': r"system\.words\.corners: missing",
    '{ corners = "W" }': r"system\.words\.impacts: missing",
    '{ impacts = "X", corners = "W" }': r"system\.words\.impacts: 'X' is not a contact of the "
                                        r"system; its contacts: W, U",
    '{ impacts = "U", corners = "U" }': r"system\.words\.corners: 'U' is the impacts' contact too",
    '{ impacts = "U", corners = "WW" }': r"system\.words\.corners: 'WW' must be a contact's name",
    '{ impacts = "U", corners = "W", height = "y" }': r"system\.words\.height: 'y' is not a dof "
                                                      r"of the system .*its dofs: z, q",
    '{ impacts = "U", corners = "W", velocity = 1 }': r"system\.words\.velocity: 1 is not a dof",
    '{ impacts = "U", corners = "W", corner = "W" }': r"system\.words\.corner: unknown key",
}


@pytest.mark.parametrize("given", list(BAD_WORDS))
def test_bad_words_are_refused_naming_the_key_and_the_value(given):
    from cornerbif import config
    text = open(os.path.join(ROOT, "configs", "fig19a_linear.toml")).read()
    line = 'words = { impacts = "U", corners = "W", height = "z", velocity = "q" }'
    assert line in text
    with pytest.raises(config.SceneError, match=BAD_WORDS[given]):
        config.loads(text.replace(line, f"words = {given}"))


def test_words_offer_no_stability_and_no_followed_sweep():
    """With [system] words only one contact's impacts are recorded: the stability pass (its
    saltations need every impact) and a followed sweep (its carried flight too) are not
    offered, said naming the key."""
    from cornerbif import config
    text = open(os.path.join(ROOT, "configs", "fig19a_linear.toml")).read()
    with pytest.raises(config.SceneError, match=r"output\.keep: 'stability'"):
        config.loads(text.replace("[run]", '[output]\nkeep = ["impacts", "stability"]\n\n[run]'))
    with pytest.raises(config.SceneError, match=r"sweep\.follow: 'up' with \[system\] words"):
        config.loads(text.replace("[initial]", 'follow = "up"\n\n[initial]'))
    assert "stability" not in config.loads(text).spec.observables


def test_a_sweep_of_the_scene_writes_the_words(tmp_path):
    """``cornerbif sweep`` of fig19a_linear (3 omega0, 3 starts): the file's words are corner
    clusters (a, b, g), its impacts all on U, with their corner offsets."""
    import h5py
    from click.testing import CliRunner

    from cornerbif.cli import main
    out = tmp_path / "f.h5"
    r = CliRunner().invoke(main, ["sweep", os.path.join(ROOT, "configs", "fig19a_linear.toml"),
                                  "-o", str(out), "--no-progress", "--set", "initial.count=3",
                                  "--set", 'sweep."contact.W.omega".num=3', "--set",
                                  "run.transient=200", "--set", "run.record=40"])
    assert r.exit_code == 0, r.output
    with h5py.File(out) as f:
        words = {w.decode() for w in f["symbols"][...].ravel()} - {""}
        assert words and all(set(w) <= set("abgx") for w in words), words
        c = f["impacts/contact"][...]
        assert set(np.unique(c[c >= 0])) == {1}
        off = f["impacts/corner_offset"][...]
        assert np.isfinite(off[c >= 0]).mean() > 0.9


def test_without_height_and_velocity_the_impacts_are_along_the_gap():
    """``words`` without ``height`` and ``velocity``: the same impacts, words and offsets,
    with u = a . x (0 on the fixed stop U: q = z) and v = a . v (q' - z') along U's gap."""
    lin_scene = _scene("fig19a_linear")
    table = {**lin_scene["system"], "words": {"impacts": "U", "corners": "W"}}
    start = dict(z0=0.5, v_z0=0.3, q0=6.0, v_q0=-4.0, transient=100, record=30)
    bare = cornerbif.simulate(model="linear", table=table, **start)
    full = cornerbif.simulate(model="linear", table=lin_scene["system"], **start)
    for k in ("t", "corner_offset", "symbols", "period"):
        np.testing.assert_array_equal(np.asarray(bare[k]), np.asarray(full[k]), err_msg=k)
    np.testing.assert_allclose(bare["u"], 0.0, atol=1e-9)
    # along the gap q - z: after the impact q' - z' (the full run's v_out and v_z), before it
    # -(that) / r2 (Newton's law on a fixed stop, w+ = -r w-)
    np.testing.assert_allclose(bare["v_out"], np.asarray(full["v_out"]) - full["v_z"], atol=1e-12)
    np.testing.assert_allclose(bare["v_in"], -np.asarray(bare["v_out"]) / 0.8, atol=1e-12)
