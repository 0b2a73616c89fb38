"""The explorer in a real browser (headless Chromium driven by Selenium): the page loads and
draws, a wheel zoom narrows the window and redraws, a refine sweeps the window and its
points arrive, a click shows the clicked run's orbit, "Continue from here" draws its branch,
and the view saved as a scene sweeps (``cornerbif sweep``) to the refine's very points.

The steps are one test (one xdist worker, one server, one browser: each step goes on from
the last one's page), each step a function of its own that says what failed.  Screenshots
are checked for what they show: ink in the plot's frame, its change on zoom and refine, the
branch's colour."""

from __future__ import annotations

import os
import re
import time

import h5py
import numpy as np
import pytest
from explore_browser import (
    canvases,
    click_button,
    inked,
    missing,
    screenshot,
    start_browser,
    wait_text,
)
from explore_server import cornerbif, server, small_file  # noqa: F401 (fixtures)

pytestmark = [pytest.mark.slow,
              pytest.mark.skipif(missing() is not None, reason=str(missing()))]

BRANCH_RGB = (0xff, 0x00, 0xff)        # app.BRANCH_COLOR


def test_explore_in_a_browser(server, tmp_path):
    """Load, zoom, refine, click, continue, save as a scene (swept again) and as a PNG."""
    driver = start_browser(str(tmp_path / "chromium"))
    try:
        driver.get(server.url)
        state = {"shots": tmp_path, "server": server, "tmp": tmp_path}
        page = (driver, state)
        for step in (the_page_loads_and_draws, a_wheel_zoom_narrows_and_redraws,
                     a_refine_sweeps_the_window_and_its_points_arrive, a_click_shows_the_orbit,
                     continue_from_here_draws_the_branch,
                     the_saved_view_sweeps_to_the_refines_points, the_view_saved_as_a_png):
            step(page)
    finally:
        driver.quit()


def _plot(driver):
    """The diagram's canvas rectangle (the widest one on the page)."""
    end = time.time() + 60
    while time.time() < end:
        cv = canvases(driver)
        if cv and cv[0][2] > 500:
            return cv[0]
        time.sleep(0.25)
    raise AssertionError("no diagram on the page")


def _window(text) -> tuple:
    m = re.search(r"window: \S+ in \[([-\de.+]+), ([-\de.+]+)\]", text)
    return float(m.group(1)), float(m.group(2))


def _shot(driver, state, name, rect=None):
    return screenshot(driver, rect, str(state["shots"] / f"{name}.png"))


def _shot_until(driver, state, name, rect, ok, timeout=90.0):
    """Screenshots until ``ok(image)`` holds or ``timeout`` s have passed (on a busy machine
    the server's image comes late): the last one, for the test's own assertion."""
    end = time.time() + timeout
    while True:
        img = _shot(driver, state, name, rect)
        if ok(img) or time.time() > end:
            return img
        time.sleep(0.5)


def the_page_loads_and_draws(page):
    driver, state = page
    text = wait_text(driver, ["window:", "points", "colour"])
    assert "fig06a_small.h5" in text
    time.sleep(2.0)                            # the first datashaded image
    rect = _plot(driver)
    img = _shot_until(driver, state, "loaded", rect, lambda im: inked(im) > 1500)
    state.update(rect=rect, loaded=inked(img), window=_window(text))
    assert state["loaded"] > 1500, "the diagram's frame is (nearly) empty"


def a_wheel_zoom_narrows_and_redraws(page):
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.actions.wheel_input import ScrollOrigin
    driver, state = page
    x, y, w, h = state["rect"]
    before = _shot(driver, state, "before_zoom", state["rect"])
    ActionChains(driver).scroll_from_origin(
        ScrollOrigin.from_viewport(int(x + 0.6 * w), int(y + 0.6 * h)), 0, -400).perform()
    end = time.time() + 30
    while time.time() < end:
        win = _window(wait_text(driver, ["window:"]))
        if win[1] - win[0] < 0.8 * (state["window"][1] - state["window"][0]):
            break
        time.sleep(0.25)
    assert win[1] - win[0] < 0.8 * (state["window"][1] - state["window"][0]), win
    time.sleep(2.0)                            # the zoomed window re-rendered
    after = _shot_until(driver, state, "zoomed", state["rect"], lambda im: np.count_nonzero(
        np.any(before != im, axis=-1)) > 2000 and inked(im) > 1000)
    changed = np.count_nonzero(np.any(before != after, axis=-1))
    assert changed > 2000, "the zoom did not redraw the diagram"
    assert inked(after) > 1000
    state.update(zoomed=inked(after), window=win)


def a_refine_sweeps_the_window_and_its_points_arrive(page):
    driver, state = page
    click_button(driver, "Refine the window")
    text = wait_text(driver, ["refine: done"], timeout=240)
    m = re.search(r"refine: done in [\d.]+ s, (\S+\.h5)", text)
    assert m, text
    state["refine"] = m.group(1)
    time.sleep(2.0)
    img = _shot_until(driver, state, "refined", state["rect"],
                      lambda im: inked(im) > 1.15 * state["zoomed"])
    # the window swept at 860 values instead of the file's few dozen in it: more ink
    assert inked(img) > 1.15 * state["zoomed"], (inked(img), state["zoomed"])
    with h5py.File(state["refine"], "r") as f:
        kappa = f["kappa"][...]
    assert kappa.size == 860
    assert kappa[0] == pytest.approx(state["window"][0], rel=1e-9, abs=1e-12)
    assert kappa[-1] == pytest.approx(state["window"][1], rel=1e-9, abs=1e-12)


def _fact(text, name) -> str:
    m = re.search(re.escape(name) + r"\s*\t\s*(.+)", text)
    return m.group(1).strip() if m else ""


def a_click_shows_the_orbit(page):
    from selenium.webdriver.common.actions.action_builder import ActionBuilder
    driver, state = page
    x, y, w, h = state["rect"]
    n_canvas = len(canvases(driver))
    # a few places, until the point clicked is on a cycle (continued next)
    for fx, fy in ([(0.6, 0.6), (0.3, 0.75), (0.8, 0.4), (0.45, 0.5),
                    (0.15, 0.85)]):
        act = ActionBuilder(driver)
        act.pointer_action.move_to_location(int(x + fx * w), int(y + fy * h)).click()
        act.perform()
        text = wait_text(driver, ["orbit: "], 120)
        end = time.time() + 120
        while time.time() < end:
            text = wait_text(driver, ["word (recomputed)"], 120)
            if "orbit: recomputing" not in text and _fact(text, "grid point, start"):
                break
            time.sleep(0.25)
        if _fact(text, "word (recomputed)") not in ("", "no cycle"):
            break
    state["word"] = _fact(text, "word (recomputed)")
    assert state["word"] not in ("", "no cycle"), text[-2000:]
    # the run recomputed from its start is the file's run
    assert _fact(text, "word in the file") == state["word"]
    assert "attractor id" in text and "share of the starts" in text
    end = time.time() + 30
    while len(canvases(driver)) <= n_canvas and time.time() < end:
        time.sleep(0.25)
    time.sleep(1.5)
    orbit = [r for r in canvases(driver) if r[1] > y + h]       # below the diagram
    assert len(orbit) >= 3, "no orbit plots (u(t), phase portrait, impacts)"
    img = _shot_until(driver, state, "orbit", None, lambda im: min(
        inked(_crop(driver, im, r)) for r in orbit[:3]) > 300)
    assert min(inked(_crop(driver, img, r)) for r in orbit[:3]) > 300


def _crop(driver, img, rect):
    scale = img.shape[1] / driver.execute_script("return window.innerWidth")
    x, y, w, h = (int(round(v * scale)) for v in rect)
    return img[y:y + h, x:x + w]


def _branch_pixels(img) -> int:
    return int(np.count_nonzero(np.all(np.abs(img.astype(int) - BRANCH_RGB) <= 8, axis=-1)))


def continue_from_here_draws_the_branch(page):
    driver, state = page
    before = _branch_pixels(_shot(driver, state, "before_branch", state["rect"]))
    click_button(driver, "Continue from here")
    text = wait_text(driver, ["branch(es)"], timeout=240)
    m = re.search(r"continuation: ([1-9]\d*) branch\(es\).*?, (\S+\.h5)", text)
    assert m, text
    with h5py.File(m.group(2), "r") as f:
        assert f.attrs["format"] == "cornerbif-continuation"
    after = _branch_pixels(_shot_until(driver, state, "branch", state["rect"],
                                       lambda im: _branch_pixels(im) > before + 10))
    assert after > before + 10, (before, after)


def the_saved_view_sweeps_to_the_refines_points(page):
    driver, state = page
    tmp_path = state["tmp"]
    click_button(driver, "Save view as scene")
    text = wait_text(driver, ["saved the view as a scene"], timeout=60)
    scene = re.search(r"saved the view as a scene: (\S+\.toml)", text).group(1)
    assert os.path.dirname(scene) == state["server"].side_dir
    out = str(tmp_path / "again.h5")
    r = cornerbif("sweep", scene, "-o", out, "--no-progress")
    assert r.returncode == 0, r.stderr
    with h5py.File(out, "r") as a, h5py.File(state["refine"], "r") as b:
        for name in ("kappa", "status", "period", "symbols", "impacts/u", "impacts/t"):
            np.testing.assert_array_equal(a[name][...], b[name][...], err_msg=name)


def the_view_saved_as_a_png(page):
    from PIL import Image
    driver, state = page
    click_button(driver, "Save PNG")
    text = wait_text(driver, ["saved the view as a figure"], timeout=120)
    png = re.search(r"saved the view as a figure: (\S+\.png)", text).group(1)
    img = np.asarray(Image.open(png).convert("RGB"))
    assert inked(img) > 5000
