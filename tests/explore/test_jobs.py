"""The explorer's refusals and side files, without a browser: a degenerate or oversized
window is refused with a message (on the page: ``Explorer.say``), a file changed under the
server is said, a refine's scene is the file's with the axis replaced, only the given files
are opened, and ``cornerbif.explore`` gives a Panel object."""

from __future__ import annotations

import math
import os
import shutil
import tomllib

import pytest
from explore_server import small_file  # noqa: F401 (a fixture)

from cornerbif.explorer import jobs

FIG06A = os.path.join(os.path.dirname(__file__), "..", "..", "configs", "fig06a.toml")


def scene_text():
    return open(FIG06A, encoding="utf-8").read()


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
    os.utime(path, ns=(1, 1))
    page.poll()
    assert "changed on disk" in page.warning.object
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
