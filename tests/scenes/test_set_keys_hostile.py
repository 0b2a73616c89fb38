"""``--set`` keys and refusals of any size and shape: each refused with exit 2, its key
(shortened), its value and what is allowed, one problem a key, and the --set it came from.

Found by a hostile audit: a list index of more than 4300 digits ended in "internal error"
(Python's ``int`` refuses such a text), a linear scene's names of any length were listed
whole in "allowed: ...", a did-you-mean offered the refused value back as its own
correction, ``plot.marks`` of the wrong shape was refused twice in two ways, and two
refusals caused by a --set (a contact renamed to a name another holds, a cam piece's span)
did not say which --set.
"""

from __future__ import annotations

import os

import pytest
from click.testing import CliRunner

from cornerbif import config
from cornerbif.cli import main
from cornerbif.config import SceneError

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
CONFIGS = os.path.join(ROOT, "configs")
HUGE = "9" * 5000            # past Python's 4300 digits of an int's text
# a refusal quotes every key and value shortened (model.cut, model.shown; config.listed)
MESSAGE_MAX = 1200


def validate(scene, *sets):
    r = CliRunner().invoke(main, ["validate", os.path.join(CONFIGS, scene),
                                  *[a for s in sets for a in ("--set", s)]])
    assert "Traceback" not in r.output and "internal error" not in r.output, r.output[:2000]
    return r


def problems(scene, *sets) -> list:
    """The problems ``config.load`` says of a shipped scene with these --set overrides."""
    with pytest.raises(SceneError) as e:
        config.load(os.path.join(CONFIGS, scene), list(sets))
    return e.value.problems


# ------------------------------------------------------------------ a list index of any size
@pytest.mark.parametrize("scene, key", [
    ("two_stops.toml", f"system.contact.{HUGE}.r=0.5"),
    ("bouncing_ball.toml", f"system.mass.{HUGE}=1"),
    ("cam_345.toml", f"system.profile.pieces.{HUGE}.span=1"),
    ("fig06a.toml", f"initial.u.{HUGE}=1"),
    ("fig06a.toml", f"plot.ylim.{HUGE}=1"),
    ("two_stops.toml", f"system.forcing.{HUGE}.Omega=3"),
])
def test_a_list_index_of_5000_digits_is_an_index_out_of_range(scene, key):
    """Every --set key part that picks a list's entry is read as an index without Python's
    ``int`` of its text (``config.list_index``): 5000 digits were "internal error
    (ValueError: Exceeds the limit (4300 digits) ...)", exit 1.  Now exit 2, the key named
    shortened, the part said to be an index out of range."""
    r = validate(scene, key)
    assert r.exit_code == 2, r.output[:2000]
    line = next(x for x in r.output.splitlines() if "--set" in x)
    assert "picks none (an index out of range" in line, line[:2000]
    assert line.lstrip().startswith("--set " + key.split(HUGE)[0] + "999"), line[:200]
    assert "characters>" in line and len(line) < MESSAGE_MAX, line[:2000]


def test_list_index_reads_digits_by_their_count():
    """``list_index``: ASCII digits naming an entry, leading zeros allowed; anything longer
    than the list's length can name is out of range before it is read, a superscript digit
    (which ``str.isdigit`` accepts and ``int`` refuses) is no index."""
    assert config.list_index("1", 2) == 1
    assert config.list_index("0001", 2) == 1
    assert config.list_index("2", 2) is None
    assert config.list_index(HUGE, 2) is None
    assert config.list_index("0" * 5000, 2) == 0
    assert config.list_index("\u00b2", 5) is None
    assert config.list_index("x", 5) is None


def test_a_huge_index_inside_a_named_list_is_named_by_its_index():
    """``_named_key`` (how a problem names a list's entry) reads the same parts: a huge
    index there is left as it is, never an error."""
    raw = {"system": {"contact": [{"name": "L"}, {"name": "R"}]}}
    assert config._named_key(raw, ["system", "contact", "1", "r"]) == "system.contact.R.r"
    assert config._named_key(raw, ["system", "contact", HUGE, "r"]).endswith(f"{HUGE}.r")


def test_scheduler_local_n_of_any_text_is_refused_by_name(tmp_path):
    """``--scheduler local:N``: N past 4300 digits, or a superscript digit, was "internal
    error (ValueError: ...)", exit 1; now exit 2 naming the option, shortened."""
    for n in (HUGE, "\u00b2"):
        r = CliRunner().invoke(main, ["sweep", os.path.join(CONFIGS, "fig06a.toml"), "-o",
                                      str(tmp_path / "x.h5"), "--scheduler", f"local:{n}",
                                      "--dry-run"])
        assert r.exit_code == 2, r.output[:2000]
        assert "N in local:N must be a whole number" in r.output, r.output[:2000]
        assert "internal error" not in r.output and len(r.output) < MESSAGE_MAX
        assert not (tmp_path / "x.h5.partial").exists()


def test_numba_num_threads_of_5000_digits_is_left_to_numba(monkeypatch):
    """``validate`` reads NUMBA_NUM_THREADS itself (numba not loaded); a value Python's
    ``int`` refuses was a ValueError there."""
    monkeypatch.setenv("NUMBA_NUM_THREADS", HUGE)
    from cornerbif import cli
    monkeypatch.setattr(cli.sys, "modules", {k: v for k, v in cli.sys.modules.items()
                                             if k != "numba"})
    assert cli._numba_threads() >= 1


# ------------------------------------------------------------------ names listed, shortened
def test_allowed_names_are_each_shortened_and_counted():
    """``config.listed``: each name cut to KEY_CHARS, at most MAX_LISTED_NAMES of them and
    the count of the rest: an "allowed: ..." list stays a few lines whatever a scene
    declares (a dof of 100,000 characters listed whole made a 200,000-character line)."""
    names = ["count", "x" * 100_000] + [f"n{i}" for i in range(100)]
    text = config.listed(names)
    assert text.startswith("count, " + "x" * config.KEY_CHARS + "...<100000 characters>")
    assert text.endswith(f", ... and {len(names) - config.MAX_LISTED_NAMES} more")
    assert len(text) < MESSAGE_MAX


def test_an_unknown_key_beside_long_names_is_one_short_problem():
    """A table's unknown key is refused with the keys it allows (``_Walk.unknown``), which a
    scene may declare (a linear scene's coordinates): a name of 100,000 characters was
    listed whole (``initial.v_x: unknown key; allowed: ..., v_xxxx...``)."""
    w = config._Walk({"initial": {"v_x": [0.0, 1.0]}})
    allowed = ("count", "seed", "x" * 100_000, "v_" + "x" * 100_000)
    w.unknown("initial", allowed)
    line, = w.problems
    assert line.startswith("initial.v_x: unknown key; allowed: count, seed, xxx"), line[:200]
    assert "...<100000 characters>" in line and len(line) < MESSAGE_MAX, len(line)


# ------------------------------------------------------------------ did you mean, never itself
def test_a_did_you_mean_never_offers_the_value_itself():
    """``continue.curve = "kappa"`` where kappa is the parameter continued was refused
    "(did you mean 'kappa'?)": the value offered back as its own correction.  Now it says
    why kappa cannot be the curves' parameter, and a near miss is offered only among the
    parameters the key allows."""
    ps = problems("cont_beta.toml", 'continue.curve="kappa"')
    line = next(p for p in ps if p.startswith("continue.curve"))
    assert "did you mean 'kappa'" not in line, line
    assert "is the parameter continued" in line and "(from --set" in line, line
    ps = problems("cont_beta.toml", 'continue.curve="kapa"')
    line = next(p for p in ps if p.startswith("continue.curve"))
    assert "did you mean 'kappa'" not in line, line            # kappa is not allowed there
    assert config._suggest("kappa", ["kappa", "kapa"]) == " (did you mean 'kapa'?)"
    assert config._suggest("kappa", ["kappa"]) == ""


# ------------------------------------------------------------------ one problem a key
@pytest.mark.parametrize("value", ["[{at=1}]", "{a=1}", "[[1, {a=1}]]"])
def test_malformed_marks_are_one_problem(value):
    """``plot.marks`` holding a table was refused twice, in two ways ("must be a string, a
    number or a list of them" and "must be a list of [value, \\"label\\"] pairs"); now once,
    by the key's own check (the generic one speaks only of a key no check named)."""
    ps = problems("fig06a.toml", f"plot.marks={value}")
    marks = [p for p in ps if p.startswith("plot.marks")]
    assert len(marks) == 1, marks
    assert "[value, \"label\"] pairs" in marks[0] and "(from --set" in marks[0], marks


def test_an_unknown_plot_key_holding_a_table_is_one_problem():
    ps = problems("fig06a.toml", "plot.zz={a=1}")
    assert [p for p in ps if p.startswith("plot.zz")] == [
        p for p in ps if p.startswith("plot.zz: unknown key")], ps
    assert len([p for p in ps if p.startswith("plot.zz")]) == 1, ps


# ------------------------------------------------------------------ tagged with their --set
@pytest.mark.parametrize("scene, key, said", [
    ("two_stops.toml", 'system.contact.L.name="R"', "system.contact.1.name"),
    ("two_stops.toml", 'system.contact.0.name="R"', "system.contact.1.name"),
    ("cam_345.toml", "system.profile.pieces.0.span=1e-100", "system.profile.pieces[0].span"),
])
def test_refusals_caused_by_a_set_say_which(scene, key, said):
    """A contact renamed (by its name) to the name another contact holds is refused at the
    other contact's key (by its index); a cam piece's span at ``pieces[0]``: both problems
    came without the "(from --set ...)" every other --set refusal carries."""
    ps = problems(scene, key)
    line = next(p for p in ps if p.startswith(said))
    assert line.endswith(f"(from --set {key})"), line


def test_a_contact_set_by_name_tags_only_that_key_of_the_list():
    """The tag of a --set that named a list's entry reaches the same key of the list's other
    entries (a duplicate name), not any key of the list: a problem of another contact's
    own value, in the scene file, is not said to come from it."""
    text = open(os.path.join(CONFIGS, "two_stops.toml")).read().replace(
        "kappa = -1.0\nr = 0.8\n\n[[system.contact]]\nname = \"R\"",
        "kappa = -1.0\nr = 0.8\n\n[[system.contact]]\nname = \"R\"\nbogus = 1", 1)
    assert "bogus" in text
    with pytest.raises(SceneError) as e:
        config.loads(text, ["system.contact.L.r=0.5"])
    bogus = [p for p in e.value.problems if "bogus" in p]
    assert bogus and not any("from --set" in p for p in bogus), e.value.problems
