"""How fast ``cornerbif explore`` draws, zooms and refines a diagram of 10^7 points, and how
its server's memory grows with the file.

A real sweep of Fig. 6(a) (kappa in [-0.02, 0.002], N values x 8 starts x 100 recorded
impacts: 10^7 points at N = 12500; output.keep = ["impacts"]) is swept once.  Then, in this
process, warm (a first round not counted), median of ``--rounds``:

* read: the file's points read into the explorer's arrays (``points.Diagram``), once;
* first render: the page's diagram built (``app.Explorer``) and its plot rendered by
  HoloViews on Bokeh, the Datashader aggregation and shading of every point at the frame's
  860 x 480 pixels included (what the server does for a new page, before the image is sent);
* zoom: the view's range changed (the ``RangeXY`` stream's event, as a wheel zoom sends it)
  and the diagram re-aggregated and re-shaded;
* refine, first block: a window of 800 values x 8 starts swept in the background
  (``jobs.start_refine``, 8 blocks) until the first block is readable in its partial file,
  as the page's poll reads it.

Server memory: ``cornerbif explore FILE --no-browser`` in a process of its own, one page
requested (a session built), its resident set read from /proc, for files of 10^6, 3 10^6
and 10^7 points (the 10^6 and 3 10^6 ones swept too).  The browser's own time (the image's
transfer, the canvas) is not in these numbers.

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
    page = state["page"]
    (x0, x1), (y0, y1) = page.window
    windows = [((x0 + f * (x1 - x0), x0 + (f + 0.25) * (x1 - x0)), (y0, y1))
               for f in (0.1, 0.3, 0.5, 0.6, 0.7, 0.2, 0.4, 0.55)]
    it = iter(windows * (rounds + 2))

    def zoom():
        xr, yr = next(it)
        page.range.event(x_range=xr, y_range=yr)
    zoom_med, zoom_all = median_time(zoom, rounds)
    return read, (first_med, first_all), (zoom_med, zoom_all), dia.size


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


def server_memory(path):
    """The resident MiB of a ``cornerbif explore`` server over ``path`` after one page."""
    env = dict(os.environ, TMPDIR=tempfile.mkdtemp(prefix="explore-bench-"))
    proc = subprocess.Popen([sys.executable, "-c", ENTRY, "explore", path, "--no-browser"],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env)
    try:
        url = None
        while url is None:
            line = proc.stdout.readline()
            if not line:
                raise RuntimeError("the server ended without a URL")
            m = re.search(r"(http://\S+\?token=\S+)", line)
            url = m.group(1) if m else None
        with urllib.request.urlopen(url, timeout=300) as r:
            r.read()
        time.sleep(1.0)
        kib = [int(line.split()[1]) for line in open(f"/proc/{proc.pid}/status")
               if line.startswith("VmRSS")]
        return kib[0] / 1024
    finally:
        proc.terminate()
        proc.wait(30)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--num", type=int, default=12500, help="kappa values (x 8 x 100 points)")
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--data", default=os.path.join(tempfile.gettempdir(), "explore_bench"),
                    help="where the swept files are kept between runs")
    ap.add_argument("--smoke", action="store_true")
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
    read, first, zoom, points = render_and_zoom(big, a.rounds)
    res.update(points=points, file_mib=os.path.getsize(big) / 2**20, read_seconds=read,
               first_render_seconds=first[0], first_render_all=first[1],
               zoom_seconds=zoom[0], zoom_all=zoom[1])
    res["refine_first_block_seconds"], res["refine_first_block_all"] = \
        refine_first_block(big, max(a.rounds, 3) if not a.smoke else 1)
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
