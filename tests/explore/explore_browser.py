"""Helpers of the explorer's browser tests: headless Chromium driven by Selenium, and the
page read through its shadow roots (Panel renders each component in one)."""

from __future__ import annotations

import io
import os
import shutil
import tempfile
import time

import numpy as np

CHROMIUM = shutil.which("chromium") or "/usr/bin/chromium"
CHROMEDRIVER = shutil.which("chromedriver") or "/usr/bin/chromedriver"
FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--window-size=1400,1300")

# every element matching a selector, through the shadow roots
DEEP = """
const sel = arguments[0];
function deep(root, out) {
  root.querySelectorAll(sel).forEach(e => out.push(e));
  root.querySelectorAll('*').forEach(e => { if (e.shadowRoot) deep(e.shadowRoot, out); });
  return out;
}
return deep(document, []);
"""
TEXT = """
function deep(root, out) {
  root.querySelectorAll('*').forEach(e => {
    if (e.shadowRoot) {
      Array.from(e.shadowRoot.children).forEach(c => {
        if (!['STYLE', 'LINK', 'SCRIPT'].includes(c.tagName) && c.innerText) out.push(c.innerText);
      });
      deep(e.shadowRoot, out);
    } });
  return out;
}
return deep(document, [document.body.innerText]).join('\\n');
"""


def missing() -> str | None:
    """Why the browser tests cannot run here, or None."""
    for mod in ("panel", "holoviews", "datashader", "selenium"):
        try:
            __import__(mod)
        except ImportError:
            return f"{mod} is not installed (pip install \".[explore,test]\")"
    for exe in (CHROMIUM, CHROMEDRIVER):
        if not os.path.exists(exe):
            return (f"{exe} is not installed (Debian: apt-get install chromium "
                    "chromium-driver)")
    return None


def start_browser(profile_dir=None):
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    opts = webdriver.ChromeOptions()
    opts.binary_location = CHROMIUM
    for a in FLAGS:
        opts.add_argument(a)
    opts.add_argument(f"--user-data-dir={profile_dir or tempfile.mkdtemp(prefix='chromium-')}")
    return webdriver.Chrome(service=Service(CHROMEDRIVER), options=opts)


def page_text(driver) -> str:
    return driver.execute_script(TEXT)


def wait_text(driver, words, timeout=60.0) -> str:
    """Wait until the page shows every one of ``words``; its text."""
    end = time.time() + timeout
    while True:
        text = page_text(driver)
        if all(w in text for w in words):
            return text
        if time.time() > end:
            raise AssertionError(f"the page never showed {words}; it shows:\n{text[-3000:]}")
        time.sleep(0.25)


def click_button(driver, label):
    buttons = [b for b in driver.execute_script(DEEP, "button") if label in b.text]
    assert buttons, f"no button {label!r}"
    driver.execute_script("arguments[0].click()", buttons[0])


def canvases(driver):
    """The plot canvases' rectangles on the page (x, y, width, height), largest first."""
    rects = driver.execute_script(
        DEEP.replace("return deep(document, []);", "") +
        "return deep(document, []).map(c => { const r = c.getBoundingClientRect();"
        " return [r.x, r.y, r.width, r.height]; });", "canvas")
    return sorted([r for r in rects if r[2] > 50 and r[3] > 50], key=lambda r: -r[2] * r[3])


def screenshot(driver, rect=None, path=None):
    """The page as an RGB array (cropped to ``rect``, page coordinates), saved to ``path``."""
    from PIL import Image
    png = driver.get_screenshot_as_png()
    img = Image.open(io.BytesIO(png)).convert("RGB")
    if path:
        img.save(path)
    a = np.asarray(img)
    if rect is not None:
        scale = a.shape[1] / driver.execute_script("return window.innerWidth")
        x, y, w, h = (int(round(v * scale)) for v in rect)
        a = a[y:y + h, x:x + w]
    return a


def inked(a, inset=4) -> int:
    """Pixels of ``a`` that are not the background (white) nor its near-white greys,
    the frame's edge left out."""
    a = a[inset:-inset, inset:-inset].astype(int)
    return int(np.count_nonzero(a.min(axis=-1) < 200))
