"""Each figure kind says what a scene must hold for it, at ``validate`` (and at ``plot
--kind``, which asks the same check of a file's scene): the section figures read the recorded
section values, and the corner curves are eqs (11) and (17) of the paper's obstacle.

Before: ``plot.kind = "orbit"`` on a scene that keeps no section passed validate and the plot
then failed reading ``section/u`` ("damaged or crafted"); ``corner_curves`` on a linear,
two-particle or map2d file drew the flow's curves with r = 0.8 and beta = 1 made up."""

import os

import pytest

from cornerbif import config

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))


def _problems(name, *sets):
    try:
        config.load(os.path.join(ROOT, "configs", f"{name}.toml"), list(sets))
    except config.SceneError as e:
        return str(e)
    return ""


@pytest.mark.parametrize("kind", ["orbit", "return_map"])
def test_section_figures_need_the_section_kept(kind):
    said = _problems("fig11a", f'plot.kind="{kind}"', 'output.keep=["impacts"]')
    assert f"plot.kind: '{kind}' draws the recorded section values" in said
    assert _problems("fig11a", f'plot.kind="{kind}"', "run.transient=0") == ""


@pytest.mark.parametrize("name", ["two_stops", "fig19a"])
def test_corner_curves_need_the_papers_corner(name):
    said = _problems(name, 'plot.kind="corner_curves"')
    assert "plot.kind: 'corner_curves' draws kappa_C and kappa_CC" in said
    assert _problems("fig07a") == ""
