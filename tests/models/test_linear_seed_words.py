"""``[continue] seed`` words of a linear scene (docs/linear.md, "Continuation"): read in the
system's own letters, its contacts' names (case kept), where its words are those; the
paper's a, b, g where its words are the paper's (one contact on a cornered obstacle).
``config._check_seed_word`` and ``continuation_run._matches`` read them with the one
parser, ``cycles.parse_word(..., alphabet=...)`` (``Model.seed_letters``)."""

import os
import tomllib

import numpy as np
import pytest
from click.testing import CliRunner

from cornerbif import config, continuation_run
from cornerbif.cli import main
from cornerbif.config import SceneError
from cornerbif.cycles import parse_word

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _quiet(*_):
    pass


def _damper(seed) -> str:
    """configs/impact_damper.toml continued in its forcing's Omega over [1.19, 1.21] from
    1.2, where its starts reach two orbits (LLR and LRR; docs/linear.md), in a few steps."""
    raw = tomllib.loads(open(os.path.join(ROOT, "configs", "impact_damper.toml")).read())
    raw.pop("sweep")
    raw.pop("plot", None)
    raw["continue"] = {"parameter": "forcing.0.Omega", "range": [1.19, 1.21], "start": 1.2,
                       "seed": seed, "ds": 0.004, "ds_max": 0.005}
    return config.dumps(raw)


@pytest.fixture(scope="module")
def every_seed():
    """The branches of ``seed = "all"``, by word."""
    res = continuation_run.run_scene(config.loads(_damper("all")), log=_quiet)
    return {b.word: b for b in res.branches}


@pytest.mark.parametrize("seed, word", [("R L^2", "LLR"), ("L R2", "LRR")])
def test_a_contact_word_seeds_the_branch_of_that_word(every_seed, seed, word):
    """A seed word of the contacts' letters (a rotation of the cycle's word, written with a
    repeat count) continues that orbit alone: the branch of the same word that seed "all"
    continues, every point's parameter and unknowns to 1e-10."""
    assert {"LLR", "LRR"} <= set(every_seed), list(every_seed)
    res = continuation_run.run_scene(config.loads(_damper(seed)), log=_quiet)
    assert res.seeds == [word] and [b.word for b in res.branches] == [word], res.seeds
    got, ref = res.branches[0].points, every_seed[word].points
    assert len(got) == len(ref) >= 3
    for p, q in zip(got, ref):
        assert abs(p.lam - q.lam) <= 1e-10
        assert np.abs(np.asarray(p.X) - np.asarray(q.X)).max() <= 1e-10


def test_the_words_alphabet_is_the_contacts_names():
    """The parser reads a word in the letters given, case kept (no lower-casing, no Greek
    letters), and refuses another letter naming the letters; without an alphabet it is the
    clusters' parser as before."""
    assert parse_word("R L^2", alphabet="RL") == "RLL"
    assert parse_word("(LR)^1 T2", alphabet="LRT") == "LRTT"
    for word in ("lr", "LQ", "b", "\u03b2"):
        with pytest.raises(ValueError, match="letters R, L"):
            parse_word(word, alphabet="RL")
    assert parse_word("B^2 \u03b3") == "bbg"


@pytest.mark.parametrize("seed, shown", [("LQ", "'Q'"), ("lr", "'lr'"), ("b", "'b'")])
def test_a_letter_that_is_no_contact_is_refused(seed, shown):
    """A seed word with a letter that is not a contact's name (another letter, the names in
    lower case, the paper's b) is refused naming the key, the value and the letters."""
    with pytest.raises(SceneError) as e:
        config.loads(_damper(seed))
    msg = [p for p in e.value.problems if p.startswith("continue.seed")]
    assert len(msg) == 1, e.value.problems
    assert (f"continue.seed: {seed!r}" in msg[0] and f"cannot read {shown}" in msg[0]
            and "letters R, L" in msg[0] and "contacts' names" in msg[0]), msg


def test_validate_says_the_refusal(tmp_path):
    """``cornerbif validate`` accepts the contacts' word and refuses a bad letter (exit 2)."""
    good = tmp_path / "good.toml"
    good.write_text(_damper(["LR", "L^2 R"]))
    r = CliRunner().invoke(main, ["validate", str(good)])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["validate", str(good), "--set", 'continue.seed="LRX"'])
    assert r.exit_code == 2 and "continue.seed: 'LRX'" in r.output and "letters R, L" in r.output


def test_a_paper_words_scene_reads_the_papers_letters():
    """configs/cont_beta_linear.toml (one contact R on the rectified sine: the paper's words)
    still reads a, b, g: "b" is accepted, its contact's name "R" and x are refused as the
    clusters' parser refuses them."""
    path = os.path.join(ROOT, "configs", "cont_beta_linear.toml")
    assert config.load(path, ['continue.seed="b"']).cont["seed"] == "b"
    config.load(path, ['continue.seed=["b^2 g", "a"]'])
    with pytest.raises(SceneError, match="cannot read 'r' \\(letters a, b, g, x"):
        config.load(path, ['continue.seed="R"'])
    with pytest.raises(SceneError, match="x is the cluster of a smooth obstacle"):
        config.load(path, ['continue.seed="x"'])
