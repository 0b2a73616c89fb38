"""How fast ``cornerbif explore`` draws, zooms and refines a diagram of 10^7 points, and how
its server's memory grows with the file.

A real sweep of Fig. 6(a) (kappa in [-0.02, 0.002], N values x 8 starts x 100 recorded
impacts: 10^7 points at N = 12500; output.keep = ["impacts"]) is swept once.  Then, in this
process, warm (a first round not counted), median of ``--rounds``:

* open: the file opened by the server (``points.Diagram``: one pass over its values to count
  them and find the grid rows with a point; the points are not held), once per server;
* first render: the page's diagram built (``app.Explorer``, its y window read once per
  server) and its plot rendered by HoloViews on Bokeh (what the server does for a new page,
  before the image is sent); the file's image of that view is kept by the server
  (``Diagram.image``) after the first page, so a new page does not read it again;
* first render, image not kept: the same with the kept images dropped first: every point
  read from the file a slab at a time and put into the frame's 860 x 480 pixels
  (``points.raster``);
* zoom: the view's range changed (the ``RangeXY`` stream's event, as a wheel zoom sends it)
  and the diagram re-aggregated and re-shaded;
* refine, first block: a window of 800 values x 8 starts swept in the background
  (``jobs.start_refine``, 8 blocks) until the first block is readable in its partial file,
  as the page's poll reads it.

In headless Chromium (Selenium; ``--no-browser`` leaves it out), against a ``cornerbif
explore`` server in a process of its own (``browser_times``): a page's first render, from
the navigation's start to the frame in which the diagram's points appear, and a wheel zoom,
from the wheel to the canvas's last change (the view final: the browser first rescales the
image it has, the server's re-render comes after).

Server memory: ``cornerbif explore FILE --no-browser`` in a process of its own, one page
requested (a session built), its resident set read from /proc, for files of 10^6, 3 10^6
and 10^7 points (the 10^6 and 3 10^6 ones swept too).

    python benchmarks/explore_speed.py [--num 12500] [--rounds 5] [--out benchmarks/results]
    python benchmarks/explore_speed.py --smoke

Writes ``explore_speed.json`` into ``--out``.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time
import urllib.request

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
SCENE = os.path.join(ROOT, "configs", "fig06a.toml")
ENTRY = "from cornerbif._entry import main; main()"


def sweep(num, out):
    """Fig. 6(a) at ``num`` kappa values into ``out`` (kept when it is there): its seconds."""
    if os.path.exists(out):
        return None
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", ENTRY, "sweep", SCENE, "-o", out, "--no-progress",
                    "--set", f"sweep.kappa.num={num}", "--set", 'output.keep=["impacts"]'],
                   check=True, capture_output=True, text=True)
    return time.perf_counter() - t0


def median_time(fn, rounds):
    """The median seconds of ``rounds`` calls of ``fn`` after one not counted (warm)."""
    fn()
    times = []
    for _ in range(rounds):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), times


def render_and_zoom(path, rounds):
    """(read seconds, first-render times, zoom times, points) in this process."""
    import holoviews as hv

    from cornerbif.explorer.app import Explorer, Files
    files = Files([path], tempfile.mkdtemp(prefix="explore-bench-"))
    t0 = time.perf_counter()
    dia = files.get(0)
    read = time.perf_counter() - t0
    renderer = hv.renderer("bokeh")
    state = {}

    def first():
        state["page"] = Explorer(files)
        state["plot"] = renderer.get_plot(state["page"]._overlay())
    first_med, first_all = median_time(first, rounds)

    def first_unkept():                     # the file's image not kept yet: read and drawn
        dia._images.clear()
        first()
    unkept_med, _ = median_time(first_unkept, rounds)
    page = state["page"]
    (x0, x1), (y0, y1) = page.window
    windows = [((x0 + f * (x1 - x0), x0 + (f + 0.25) * (x1 - x0)), (y0, y1))
               for f in (0.1, 0.3, 0.5, 0.6, 0.7, 0.2, 0.4, 0.55)]
    it = iter(windows * (rounds + 2))

    def zoom():
        xr, yr = next(it)
        page.range.event(x_range=xr, y_range=yr)
    zoom_med, zoom_all = median_time(zoom, rounds)
    return read, (first_med, first_all), (zoom_med, zoom_all), dia.size, unkept_med


def refine_first_block(path, rounds):
    """The median seconds from a refine's start to its first block readable, and all."""
    from cornerbif.explorer import jobs
    from cornerbif.explorer.app import _partial_points
    from cornerbif.explorer.points import Diagram
    dia = Diagram(path)
    side = tempfile.mkdtemp(prefix="explore-bench-")
    times = []
    for k in range(rounds + 1):
        x0 = -0.006 + 0.0001 * k          # a new window each round (a fresh sweep)
        scene, _ = jobs.window_scene(dia.data.scene_text, dia.axis, x0, x0 + 0.002, 800,
                                     threads=os.cpu_count() or 1)
        out = os.path.join(side, f"refine_{k}.h5")
        t0 = time.perf_counter()
        job = jobs.start_refine(scene, out)
        while job.running:
            got = _partial_points(job.partial, dia.kind, dia.axis)
            if got is not None:
                break
            time.sleep(0.01)
        first = time.perf_counter() - t0
        job.join()
        if k:                             # the first round warms the kernels
            times.append(first)
    return statistics.median(times), times


class Served:
    """A ``cornerbif explore FILE --no-browser`` server in a process of its own: ``url``
    (with its token), ``proc``."""

    def __init__(self, path):
        env = dict(os.environ, TMPDIR=tempfile.mkdtemp(prefix="explore-bench-"))
        self.proc = subprocess.Popen([sys.executable, "-c", ENTRY, "explore", path,
                                      "--no-browser"], stdout=subprocess.PIPE,
                                     stderr=subprocess.STDOUT, text=True, env=env)
        self.url = None
        while self.url is None:
            line = self.proc.stdout.readline()
            if not line:
                raise RuntimeError("the server ended without a URL")
            m = re.search(r"(http://\S+\?token=\S+)", line)
            self.url = m.group(1) if m else None

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.proc.terminate()
        self.proc.wait(30)


def server_memory(path):
    """The resident MiB of a ``cornerbif explore`` server over ``path`` after one page."""
    with Served(path) as srv:
        with urllib.request.urlopen(srv.url, timeout=300) as r:
            r.read()
        time.sleep(1.0)
        kib = [int(line.split()[1]) for line in open(f"/proc/{srv.proc.pid}/status")
               if line.startswith("VmRSS")]
        return kib[0] / 1024


# In the page from its first instant (Chromium's Page.addScriptToEvaluateOnNewDocument): at
# every animation frame the largest canvas (the diagram's, through Panel's shadow roots) is
# sampled (every 7th value of its pixels); each change of the sample is recorded with its
# time (performance.now(), from the navigation's start) and its count of coloured pixels
# (the diagram's points; the axes are black and grey).
WATCH = """
window.__changes = [];
(function () {
  let last = null;
  function largest(root, best) {
    root.querySelectorAll('canvas').forEach(c => {
      if (!best || c.width * c.height > best.width * best.height) best = c; });
    root.querySelectorAll('*').forEach(e => { if (e.shadowRoot) best = largest(e.shadowRoot, best); });
    return best;
  }
  function frame() {
    const c = largest(document, null);
    if (c && c.width > 500) {
      try {
        const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
        let sum = 0, coloured = 0;
        for (let i = 0; i < d.length; i += 28) {
          sum = (sum * 31 + d[i] + 7 * d[i + 1] + 13 * d[i + 2]) % 1000000007;
          const mx = Math.max(d[i], d[i + 1], d[i + 2]), mn = Math.min(d[i], d[i + 1], d[i + 2]);
          if (d[i + 3] > 0 && mx - mn > 60) coloured += 1;
        }
        if (sum !== last) { window.__changes.push([performance.now(), coloured]); last = sum; }
      } catch (e) {}
    }
    requestAnimationFrame(frame);
  }
  requestAnimationFrame(frame);
})();
"""


def browser_times(path, rounds):
    """In headless Chromium (Selenium), against a ``cornerbif explore`` server over ``path``:
    (first render times, zoom times).  First render: from the navigation's start to the
    frame in which the diagram's coloured points appear (the page loaded, its session made,
    the server's render sent and drawn).  Zoom: a wheel zoom on the diagram (Selenium's
    wheel action) to the last change of the canvas within 5 s (the browser first rescales
    the image it has; the server's re-render arrives after): the time until the view is
    final.  A first page is not counted (warm)."""
    import shutil

    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service
    from selenium.webdriver.common.action_chains import ActionChains
    from selenium.webdriver.common.actions.wheel_input import ScrollOrigin
    opts = webdriver.ChromeOptions()
    opts.binary_location = shutil.which("chromium") or "/usr/bin/chromium"
    for a in ("--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
              "--window-size=1400,1300", f"--user-data-dir={tempfile.mkdtemp(prefix='chromium-')}"):
        opts.add_argument(a)
    driver = webdriver.Chrome(service=Service(shutil.which("chromedriver") or
                                              "/usr/bin/chromedriver"), options=opts)
    first, zooms = [], []
    try:
        driver.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": WATCH})
        with Served(path) as srv:
            for k in range(rounds + 1):
                driver.get(srv.url)
                end = time.time() + 60
                inked = None
                while inked is None and time.time() < end:
                    time.sleep(0.2)
                    ch = driver.execute_script("return window.__changes")
                    inked = next((t for t, n in ch if n > 200), None)
                if inked is None:
                    raise RuntimeError("the diagram never appeared in the browser")
                if k:
                    first.append(inked / 1000.0)
            time.sleep(1.0)
            rect = driver.execute_script(
                "function l(r,b){r.querySelectorAll('canvas').forEach(c=>{if(!b||c.width*c.height>"
                "b.width*b.height)b=c;});r.querySelectorAll('*').forEach(e=>{if(e.shadowRoot)"
                "b=l(e.shadowRoot,b);});return b;} const r=l(document,null)"
                ".getBoundingClientRect(); return [r.x, r.y, r.width, r.height];")
            x, y, w, h = rect
            for k in range(rounds + 1):
                t0 = driver.execute_script("window.__changes = []; return performance.now()")
                ActionChains(driver).scroll_from_origin(ScrollOrigin.from_viewport(
                    int(x + (0.3 + 0.1 * (k % 4)) * w), int(y + 0.5 * h)), 0,
                    -300 if k % 2 == 0 else 300).perform()
                time.sleep(5.0)
                ch = driver.execute_script("return window.__changes")
                if not ch:
                    raise RuntimeError("a wheel zoom changed nothing on the canvas")
                if k:
                    zooms.append((ch[-1][0] - t0) / 1000.0)
    finally:
        driver.quit()
    return first, zooms


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--num", type=int, default=12500, help="kappa values (x 8 x 100 points)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--data", default=os.path.join(tempfile.gettempdir(), "explore_bench"),
                    help="where the swept files are kept between runs")
    ap.add_argument("--smoke", action="store_true")
    ap.add_argument("--no-browser", action="store_true",
                    help="leave out the times measured in headless Chromium")
    ap.add_argument("--out", default=os.path.join(HERE, "results"))
    a = ap.parse_args(argv)
    if a.smoke:
        a.num, a.rounds = 100, 1
    os.makedirs(a.data, exist_ok=True)
    sizes = sorted({a.num, max(a.num // 10, 10), max(a.num * 3 // 10, 10)})
    files = {n: os.path.join(a.data, f"fig06a_{n}.h5") for n in sizes}
    res = {"when": time.strftime("%Y-%m-%d %H:%M"), "rounds": a.rounds,
           "command": "python benchmarks/explore_speed.py " + " ".join(argv or sys.argv[1:]),
           "sweep_seconds": {n: sweep(n, p) for n, p in files.items()}}
    big = files[a.num]
    read, first, zoom, points, unkept = render_and_zoom(big, a.rounds)
    res.update(points=points, file_mib=os.path.getsize(big) / 2**20, open_seconds=read,
               first_render_seconds=first[0], first_render_all=first[1],
               first_render_image_not_kept_seconds=unkept,
               zoom_seconds=zoom[0], zoom_all=zoom[1])
    res["refine_first_block_seconds"], res["refine_first_block_all"] = \
        refine_first_block(big, max(a.rounds, 3) if not a.smoke else 1)
    if not a.no_browser:
        first, zooms = browser_times(big, a.rounds)
        res.update(browser_first_render_seconds=statistics.median(first),
                   browser_first_render_all=first, browser_zoom_seconds=statistics.median(zooms),
                   browser_zoom_all=zooms)
    res["server_rss_mib"] = {}
    for n, p in files.items():
        res["server_rss_mib"][f"{n * 800} points, {os.path.getsize(p) / 2**20:.0f} MiB file"] = \
            server_memory(p)
    os.makedirs(a.out, exist_ok=True)
    with open(os.path.join(a.out, "explore_speed.json"), "w") as fh:
        json.dump(res, fh, indent=1, default=str)
    print(json.dumps({k: v for k, v in res.items() if not k.endswith("_all")}, indent=1,
                     default=str))


if __name__ == "__main__":
    main()
