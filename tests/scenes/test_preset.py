"""``run.preset``: the accuracy presets "fast" | "paper" | "precise" (config.PRESETS).

Expected values: the preset table documented in benchmarks/README.md (measured there);
"paper" is the run settings every paper scene in configs/ was drawn with
(transient 500, tol 1e-12, chatter 1e-6, e.g. configs/fig04c.toml).
"""

import pytest
from click.testing import CliRunner

from cornerbif import config
from cornerbif.cli import main

BASE = """
[scene]
name = "p"
[system]
omega = 1.999
[sweep]
kappa = {{ values = [-0.012, -0.010] }}
[initial]
count = 1
[run]
{run}
"""


def _scene(run=""):
    return config.loads(BASE.format(run=run))


def test_default_is_the_paper_settings_and_leaves_the_scene_text_unchanged():
    s = _scene()
    assert s.preset == "paper"
    assert (s.transient, s.tol, s.chatter) == (500, 1e-12, 1e-6)
    # no preset key in the text as run: files written before presets keep their hash
    assert "preset" not in s.text
    assert _scene('preset = "paper"').transient == 500


@pytest.mark.parametrize("name, expect", [("fast", (300, 1e-8, 1e-4)),
                                          ("precise", (3000, 1e-14, 1e-6))])
def test_preset_resolves_to_its_values(name, expect):
    s = _scene(f'preset = "{name}"')
    assert s.preset == name
    assert (s.transient, s.tol, s.chatter) == expect
    assert s.record == 100                          # not part of any preset
    assert f'preset = "{name}"' in s.text
    # the text as run reloads to the same scene (same hash: --resume works)
    again = config.loads(s.text)
    assert again.hash == s.hash and again.transient == expect[0]


def test_explicit_keys_override_the_preset():
    s = _scene('preset = "fast"\ntransient = 777\nchatter = 1e-7')
    assert (s.transient, s.tol, s.chatter) == (777, 1e-8, 1e-7)
    s2 = config.loads(BASE.format(run='preset = "precise"'), ["run.tol=1e-10"])
    assert (s2.transient, s2.tol) == (3000, 1e-10)
    s3 = config.loads(BASE.format(run=""), ["run.preset=fast"])
    assert (s3.preset, s3.transient) == ("fast", 300)


@pytest.mark.parametrize("value, words", [('"fsat"', ["run.preset", "'fsat'", "did you mean 'fast'",
                                                     "fast, paper, precise"]),
                                         ("3", ["run.preset", "3", "fast, paper, precise"])])
def test_bad_preset_names_key_value_and_allowed(value, words):
    with pytest.raises(config.SceneError) as e:
        _scene(f"preset = {value}")
    msg = str(e.value)
    for w in words:
        assert w in msg, (w, msg)


def test_validate_and_info_show_what_the_preset_resolved_to(tmp_path):
    scene = tmp_path / "p.toml"
    scene.write_text(BASE.format(run='preset = "fast"\nrecord = 20'))
    r = CliRunner().invoke(main, ["validate", str(scene)])
    assert r.exit_code == 0, r.output
    assert "run.preset 'fast' -> transient 300, tol 1e-08, chatter 0.0001" in r.output
    out = tmp_path / "p.h5"
    r = CliRunner().invoke(main, ["sweep", str(scene), "-o", str(out), "--no-progress"])
    assert r.exit_code == 0, r.output
    r = CliRunner().invoke(main, ["info", str(out)])
    assert r.exit_code == 0, r.output
    assert "run: preset fast -> transient 300, record 20, tol 1e-08, chatter 0.0001" in r.output
    r = CliRunner().invoke(main, ["validate", str(scene), "--set", "run.preset=slow"])
    assert r.exit_code == 2
    assert "run.preset: 'slow' is not a preset" in r.output
