"""Bad scenes, fuzzed: any TOML text or dict gives a Scene or a SceneError, never a
traceback; two axes naming one parameter are refused."""

import os

import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from cornerbif import config, registry

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


FIG06A = os.path.join(ROOT, "configs", "fig06a.toml")


# ---------------------------------------------------------------- fuzzing the scene loader
@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.text(max_size=400))
def test_arbitrary_toml_text_gives_a_scene_or_a_scene_error(text):
    try:
        sc = config.loads(text)
    except config.SceneError as e:
        assert e.problems and all(isinstance(p, str) for p in e.problems)
    else:
        assert isinstance(sc, config.Scene)


KEYS = st.sampled_from(list(config.TABLES) + list(registry.get("flow").params)
                       + ["obstacle", "follow", "start", "stop", "num", "values", "count",
                          "seed", "u", "v", "transient", "record", "tol", "keep", "model",
                          "name", "y", "xlim", "omgea", ""])


SCALARS = (st.none() | st.booleans() | st.integers(-10**6, 10**6) | st.floats(allow_nan=True)
           | st.text(max_size=12) | st.sampled_from(["flow", "sine", "rectified_sine", "up"]))


VALUES = st.recursive(SCALARS, lambda c: st.lists(c, max_size=4) | st.dictionaries(KEYS, c, max_size=5),
                      max_leaves=20)


@pytest.mark.slow
@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.dictionaries(KEYS, VALUES, max_size=7))
@example({"run": {"transient": None}})     # once raised TypeError: None passed as automatic
def test_arbitrary_dicts_give_a_scene_or_a_scene_error(raw):
    try:
        sc = config.from_dict(raw)
    except config.SceneError as e:
        assert e.problems
    else:
        assert isinstance(sc, config.Scene)
        # a valid scene's text reloads to the same scene
        assert config.loads(sc.text).hash == sc.hash


def test_two_axes_naming_one_parameter_is_refused():
    """TOML itself refuses a key twice in a table (line and column named); through --set the
    same axis cannot appear twice either, since overrides address one key."""
    text = open(FIG06A).read().replace("follow = \"none\"",
                                        "kappa = { start = 0.0, stop = 1.0, num = 3 }\nfollow = \"none\"")
    with pytest.raises(config.SceneError) as e:
        config.loads(text)
    assert "line" in str(e.value)
