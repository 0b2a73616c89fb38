"""The explorer's refusals and side files, without a browser: a degenerate or oversized
window is refused with a message (on the page: ``Explorer.say``), a file changed under the
server is said, a refine's scene is the file's with the axis replaced, only the given files
are opened, and ``cornerbif.explore`` gives a Panel object."""

from __future__ import annotations

import math
import os
import re
import shutil
import tomllib

import pytest
from explore_server import small_file  # noqa: F401 (a fixture)

from cornerbif.explorer import jobs

FIG06A = os.path.join(os.path.dirname(__file__), "..", "..", "configs", "fig06a.toml")


def scene_text():
    return open(FIG06A, encoding="utf-8").read()


def page_of_scene(tmp_path, scene, name, *sets):
    """A page of the explorer over ``scene`` swept (``--set`` each of ``sets``) into
    ``tmp_path / name``."""
    from explore_server import cornerbif

    from cornerbif.explorer.app import Files
    from cornerbif.explorer.session import page_for
    path = str(tmp_path / name)
    r = cornerbif("sweep", scene, "-o", path, "--no-progress",
                  *[a for s in sets for a in ("--set", s)])
    assert r.returncode == 0, r.stderr
    return page_for(Files([path], str(tmp_path)))


def wait_continued(page, timeout=300):
    """Poll ``page`` until its continuation is done."""
    import time
    end = time.time() + timeout
    while page.cont_job is not None and time.time() < end:
        page.poll()
        time.sleep(0.05)
    assert page.cont_path is not None, page.status.object


@pytest.mark.parametrize("x0, x1, why", [
    (-0.01, -0.01, "no width"), (-0.005, -0.01, "no width"),
    (math.nan, 0.0, "not finite"), (-math.inf, 0.0, "not finite"),
    (1.0, 1.0 + 1e-14, "below double precision"),
])
def test_a_degenerate_window_is_refused(x0, x1, why):
    with pytest.raises(jobs.Refused, match=why):
        jobs.window_raw(scene_text(), "kappa", x0, x1, 860)


def test_the_window_is_the_files_scene_with_the_axis_replaced():
    raw = jobs.window_raw(scene_text(), "kappa", -0.006, -0.004, 800)
    orig = tomllib.loads(scene_text())
    assert raw["sweep"]["kappa"] == {"start": -0.006, "stop": -0.004, "num": 800}
    assert raw["plot"]["xlim"] == [-0.006, -0.004]
    for table in ("system", "initial", "run", "output"):
        assert raw[table] == orig[table]


def test_an_oversized_refine_is_refused():
    with pytest.raises(jobs.Refused, match="would take|runs is more than"):
        jobs.window_scene(scene_text(), "kappa", -0.02, 0.002, 100_000, threads=1)
    text = scene_text().replace("count = 8", "count = 64")
    with pytest.raises(jobs.Refused, match="runs is more than"):
        jobs.window_scene(text, "kappa", -0.02, 0.002, 40_000, threads=64)


def test_a_window_scene_config_refuses_is_refused():
    with pytest.raises(jobs.Refused, match="refused"):
        jobs.window_scene(scene_text().replace("r = 0.8", "r = 1.8"), "kappa", -0.01, 0.0, 10)


def test_continuation_needs_a_parameter_axis():
    with pytest.raises(jobs.Refused, match="start coordinate"):
        jobs.continue_raw(scene_text(), "initial.u", 1.0, [1.0, 0.0], 0.0, 2.0)
    raw = jobs.continue_raw(scene_text(), "kappa", -0.01, [1.0, 2.0, 0.0], -0.02, 0.002)
    assert "sweep" not in raw and raw["initial"] == {"points": [[1.0, 2.0, 0.0]]}
    assert raw["continue"]["start"] == -0.01 and raw["system"]["kappa"] == -0.01


def test_a_job_that_fails_says_so_and_raises_nothing():
    job = jobs.Job("refine").start(lambda: 1 / 0)
    job.join(10)
    assert job.state == "failed" and "ZeroDivisionError" in job.message


@pytest.mark.slow
def test_the_page_says_what_it_refuses_and_a_changed_file(small_file, tmp_path, monkeypatch):
    pytest.importorskip("panel")
    import numpy as np
    import panel as pn

    import cornerbif
    from cornerbif.explorer.app import Explorer, Files
    path = str(tmp_path / "copy.h5")
    shutil.copy(small_file, path)
    files = Files([path], str(tmp_path / "side"))
    os.mkdir(files.side_dir)
    assert files.index("copy.h5") == 0 and files.index("0") == 0
    assert files.index("/etc/passwd") is None and files.index("1") is None
    page = Explorer(files)
    page.window = ((-0.01, -0.01), page.window[1])
    page.start_refine()
    assert "refine refused" in page.status.object and "no width" in page.status.object
    page.window = ((-0.02, 0.002), page.window[1])
    monkeypatch.setattr(jobs, "REFINE_RUNS", 1000)
    page.start_refine()
    assert "refine refused" in page.status.object
    page.start_continuation()
    assert "click a point first" in page.status.object
    from cornerbif.explorer.points import raster
    xr, yr = page.window
    assert np.isfinite(raster(page.dia, page.col, xr, yr, 40, 30)).any()
    os.utime(path, ns=(1, 1))
    page.poll()
    assert "changed on disk" in page.warning.object
    # its points are no longer read (the runs' colours are the file's as it was read)
    assert not np.isfinite(raster(page.dia, page.col, xr, yr, 40, 30)).any()
    assert os.listdir(files.side_dir) == []          # nothing run, nothing written
    assert isinstance(cornerbif.explore(small_file), pn.viewable.Viewable)


@pytest.mark.slow
def test_a_refine_is_drawn_block_by_block_into_a_side_file(small_file, tmp_path):
    """The page's poll draws the refine's finished blocks while it runs (read from its
    partial file), then the whole side file; the file explored is untouched."""
    pytest.importorskip("panel")
    import time

    from cornerbif.explorer.app import Explorer, Files
    before = os.stat(small_file).st_mtime_ns, os.path.getsize(small_file)
    files = Files([small_file], str(tmp_path))
    page = Explorer(files)
    page.window = ((-0.006, -0.004), page.window[1])
    page.start_refine(num=400)
    said = []
    end = time.time() + 120
    while page.refine.state != "shown" and time.time() < end:
        page.poll()
        said.append(page.status.object)
        time.sleep(0.01)
    assert any("values swept" in s and "new points drawn" in s for s in said), set(said)
    # the blocks arrive one by one while the refine runs (its partial file read as a SWMR
    # reader: before, the copy was refused until the end, and nothing came early)
    swept = {int(m.group(1)) for s in said if (m := re.search(r"(\d+) of 400 values swept", s))}
    assert len(swept - {400}) >= 2, swept
    assert "refine: done" in said[-1]
    assert page.refined.size > 0 and page.refined.path.startswith(str(tmp_path))
    assert (os.stat(small_file).st_mtime_ns, os.path.getsize(small_file)) == before


@pytest.mark.slow
def test_a_scene_is_swept_beside_it_first(tmp_path):
    pytest.importorskip("panel")
    from cornerbif.explorer.server import sweep_first
    scene = tmp_path / "tiny.toml"
    scene.write_text(scene_text().replace("num = 2001", "num = 11").replace("count = 8",
                                                                            "count = 2"))
    said = []
    out = sweep_first(str(scene), echo=said.append)
    assert out == str(tmp_path / "fig06a.h5") and os.path.exists(out)
    assert any(f"into {out}" in s for s in said)
    assert sweep_first(str(scene), echo=said.append) == out      # swept once


@pytest.mark.slow
def test_a_chart_is_drawn_clicked_refined_and_saved_as_a_scene_of_its_cells(tmp_path,
                                                                           monkeypatch):
    """A file of two swept parameters opens on a chart's page: a click shows its cell's
    orbit, the view saved as a scene sweeps to the file's very cells, a refine of a zoomed
    window is drawn block by block, and the view saved then sweeps to the refine's cells."""
    pytest.importorskip("panel")
    import time

    import h5py
    import numpy as np
    from explore_server import cornerbif

    from cornerbif.explorer.app import Files
    from cornerbif.explorer.session import page_for
    path = str(tmp_path / "chart.h5")
    r = cornerbif("sweep", "configs/chart_flow.toml", "-o", path, "--no-progress",
                  "--set", "sweep.omega.num=15", "--set", "sweep.kappa.num=11")
    assert r.returncode == 0, r.stderr
    page = page_for(Files([path], str(tmp_path)))
    assert type(page).__name__ == "ChartPage" and not page.dia.basin
    page._on_tap(x=float(page.dia.xv[3]), y=float(page.dia.yv[7]))
    page.orbit_job.join(120)
    page.poll()
    facts = dict(page.orbit.facts)
    assert facts["grid point, start"] == "3, 7, 0"
    assert facts["word (recomputed)"] == facts["word in the file"]
    page.save_scene()
    scene = page.status.object.split("saved the view as a scene: ")[1].split(" ")[0]
    again = str(tmp_path / "again.h5")
    r = cornerbif("sweep", scene, "-o", again, "--no-progress")
    assert r.returncode == 0, r.stderr
    with h5py.File(path, "r") as a, h5py.File(again, "r") as b:
        for name in ("omega", "kappa", "period", "symbols", "status"):
            np.testing.assert_array_equal(a[name][...], b[name][...], err_msg=name)
    from cornerbif.explorer import chart
    monkeypatch.setattr(chart, "CELL_PX", 40)          # 21 x 12 cells
    page.range.event(x_range=(1.999, 2.001), y_range=(-0.01, 0.01))
    page.start_refine()
    said = []
    end = time.time() + 120
    while page.refine.state not in ("shown", "failed") and time.time() < end:
        page.poll()
        said.append(page.status.object)
        time.sleep(0.01)
    assert page.refine.state == "shown", said[-1]
    assert page.refined.xv.size == 21 and page.refined.yv.size == 12
    assert page.refined.path.startswith(str(tmp_path))
    page.save_scene()
    scene = page.status.object.split("saved the view as a scene: ")[1].split(" ")[0]
    r = cornerbif("sweep", scene, "-o", str(tmp_path / "again2.h5"), "--no-progress")
    assert r.returncode == 0, r.stderr
    with h5py.File(page.refined.path, "r") as a, h5py.File(tmp_path / "again2.h5", "r") as b:
        for name in ("omega", "kappa", "period", "symbols", "status", "final/u"):
            np.testing.assert_array_equal(a[name][...], b[name][...], err_msg=name)


@pytest.mark.slow
def test_a_charts_cell_is_continued_and_its_corner_curve_drawn_over_the_chart(tmp_path):
    """On a chart of (omega, kappa), a click on a cell of the period-one orbit beta and
    "Continue from here" (in kappa, the corner collisions continued as curves in omega over
    the chart's width): the branch is drawn as a vertical line at the cell's omega, its
    corner collision at kappa_C(omega) of eq (11) (``theory.kappa_C``, the closed form), and
    the curve drawn over the chart is eq (11) at every point (to 1e-6)."""
    pytest.importorskip("panel")

    import numpy as np

    from cornerbif import theory
    from cornerbif.explorer.chart import _chart_events, _chart_paths
    page = page_of_scene(tmp_path, "configs/chart_flow.toml", "chart.h5", "sweep.omega.num=5",
                         "sweep.kappa.num=11", "initial.count=1")
    assert page.cont_param.value == "kappa"
    i, j = 1, 0                                    # omega = 1.998, kappa = -0.03: beta
    assert page.dia.data.symbols[i, j, 0] == "b"
    page._on_tap(x=float(page.dia.xv[i]), y=float(page.dia.yv[j]))
    page.orbit_job.join(120)
    page.poll()
    page.start_continuation()
    wait_continued(page)
    data = page.branch_pipe.contents["data"]
    cont, along_x, other = data
    omega = float(page.dia.xv[i])
    assert not along_x and other == omega
    corners = [e for e in cont["events"] if e["kind"] == "corner"]
    k_c = theory.kappa_C(omega, 0.8)
    assert any(abs(e["param"] - k_c) < 1e-6 for e in corners), ([e["param"] for e in corners], k_c)
    ev = _chart_events(data).dframe()
    assert ((ev["x"] == omega) & (abs(ev["y"] - k_c) < 1e-6)).any()
    paths = _chart_paths(data).split()
    branch = paths[0].dframe()
    assert (branch["x"] == omega).all() and branch["y"].min() < k_c + 1e-6
    curves = [p.dframe() for p in paths[len(cont["branches"]):]]
    assert curves, "no corner curve drawn"
    on_eq11 = [np.abs(c["y"] - [theory.kappa_C(w, 0.8) for w in c["x"]]).max() for c in curves]
    assert min(on_eq11) < 1e-6, on_eq11
    xs = np.concatenate([c["x"] for c in curves])
    assert xs.min() < 1.9965 and xs.max() > 2.0035        # over the chart's width


@pytest.mark.slow
def test_a_basins_cell_is_continued_in_a_parameter_chosen_on_the_page(tmp_path):
    """On a basin of (u, v) starts (the hysteresis basin at omega = 2.001, kappa = 0.008),
    a clicked cell's orbit continued in kappa over a range typed on the page: the branch is
    drawn in a figure of its own; its parameter values hold the cell's kappa and stay in the
    range; a range that is not two numbers, or does not hold the value, is refused on the
    page."""
    pytest.importorskip("panel")

    page = page_of_scene(tmp_path, "configs/basin_hysteresis.toml", "basin.h5",
                         "sweep.initial.u.num=6", "sweep.initial.v.num=5")
    assert page.dia.basin and "kappa" in page.cont_param.options
    page.cont_param.value = "kappa"
    kappa = page.dia.data.parsed.point((0, 0))["kappa"]
    lo, hi = (float(t) for t in page.cont_range.value.split(","))
    assert lo < kappa < hi                       # the default: the value +- 5 %
    page._on_tap(x=float(page.dia.xv[2]), y=float(page.dia.yv[2]))
    page.orbit_job.join(120)
    page.poll()
    for bad in ("0.1", "a, b", f"{kappa + 0.001}, {kappa + 0.002}"):
        page.cont_range.value = bad
        page.start_continuation()
        assert "continuation refused" in page.status.object, bad
    page.cont_range.value = f"{kappa - 0.004}, {kappa + 0.004}"
    page.start_continuation()
    wait_continued(page)
    assert page.branch_pane.object is not None
    import h5py
    with h5py.File(page.cont_path, "r") as f:
        params = [f["branches"][b]["param"][...] for b in f["branches"]]
    assert any(p.min() <= kappa <= p.max() for p in params)
    assert all(p.min() >= kappa - 0.004 - 1e-12 and p.max() <= kappa + 0.004 + 1e-12
               for p in params)


@pytest.mark.slow
def test_a_refine_cancelled_keeps_its_finished_blocks_and_resumes(small_file, tmp_path):  # noqa: F811
    """"Cancel the refine" while it runs: the sweep stops as on Ctrl-C (``run_sweep``'s
    ``cancel``), the page says so (no error), the blocks finished are kept in the partial
    file, fewer than all, and ``cornerbif sweep --resume`` of the refine's scene completes
    it."""
    pytest.importorskip("panel")
    import time

    import h5py
    from explore_server import cornerbif

    from cornerbif.explorer.app import Explorer, Files
    page = Explorer(Files([small_file], str(tmp_path)))
    page.window = ((-0.012, -0.004), page.window[1])
    page.start_refine(num=800)
    assert page.cancel_btn.visible
    job = page.refine
    end = time.time() + 120
    while job.running and time.time() < end and "values swept" not in page.status.object:
        page.poll()
        time.sleep(0.01)
    page.cancel_refine()
    while job.running and time.time() < end:
        time.sleep(0.01)
    page.poll()
    assert job.state == "cancelled", job.message
    assert "refine: cancelled" in page.status.object and "#b00020" not in page.status.object
    assert not page.cancel_btn.visible and page.refined is None
    with h5py.File(job.partial, "r") as f:
        done = int(f["done"][...].sum())
    assert 0 < done < 800, done
    scene = job.partial[:-len(".h5.partial")] + ".toml"
    r = cornerbif("sweep", scene, "-o", job.partial[:-len(".partial")], "--resume",
                  "--no-progress")
    assert r.returncode == 0, r.stderr
    with h5py.File(job.partial[:-len(".partial")], "r") as f:
        assert f["done"][...].all()


@pytest.mark.slow
@pytest.mark.parametrize("scene, axis, stability", [
    ("configs/bouncing_ball.toml", '"contact.T.beta"', True),
    ("configs/soft_stop.toml", '"forcing.0.Omega"', False),
])
def test_a_linear_scenes_point_is_recomputed_with_its_table(tmp_path, scene, axis, stability):
    """A click on a diagram of a linear scene (a model its scene declares) recomputes the
    run through ``simulate(table=...)`` with the point's numbers by path: the word and period
    the file holds; the multipliers where the system's stability is run (not through a soft
    stop: the orbit is recomputed without them rather than refused).  "Continue from here"
    continues the bouncing ball's orbit (its number written into the table by path) and
    refuses the soft stop's, naming the key (docs/linear.md, "Continuation")."""
    pytest.importorskip("panel")
    import numpy as np

    page = page_of_scene(tmp_path, scene, "linear.h5", f"sweep.{axis}.num=9",
                         "initial.count=2")
    d = page.dia
    k = next(k for k in range(9) if d.data.period[k, 0] > 0)
    page._start_orbit(d, (k,), 0)
    page.orbit_job.join(120)
    page.poll()
    assert page.orbit is not None, page.status.object
    facts = dict(page.orbit.facts)
    assert facts["word (recomputed)"] == facts["word in the file"]
    assert page.orbit.period == int(d.data.period[k, 0])
    assert ("multipliers (recomputed)" in facts) == stability
    if stability:
        assert np.isfinite(float(facts["multipliers (recomputed)"].split()[0]))
    page.start_continuation()
    if not stability:
        # a soft stop: its orbits are not continued (docs/linear.md, "Continuation"), said
        # naming the key
        assert "continuation refused" in page.status.object, page.status.object
        assert "system.contact.S.law" in page.status.object, page.status.object
        assert page.cont_job is None
        return
    # the bouncing ball: its period-one orbit is continued in contact.T.beta over the
    # file's range, from the clicked point (the number written into its [system] by path)
    wait_continued(page)
    import h5py
    x = float(d.xv[k])
    with h5py.File(page.cont_path, "r") as f:
        params = [f["branches"][b]["param"][...] for b in f["branches"]]
        words = [f["branches"][b].attrs["word"] for b in f["branches"]]
    assert "T" in words, words
    assert any(p.min() <= x <= p.max() for p in params), (x, params)
