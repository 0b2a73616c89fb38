"""Command line: ``cornerbif sweep | plot | info | validate`` (click).

Bad input ends with exit code 2 and every problem listed (key, value, what is
allowed), never a traceback.
"""

from __future__ import annotations

import os
import sys

import click

from .config import SceneError


def _fail(msg, code=2):
    click.echo(f"error: {msg}", err=True)
    sys.exit(code)


def _load(scene_path, sets):
    from . import config
    try:
        return config.load(scene_path, sets)
    except SceneError as e:
        click.echo(f"error: {scene_path}: the scene cannot be run:", err=True)
        for p in e.problems:
            click.echo(f"  {p}", err=True)
        sys.exit(2)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="cornerbif")
def main():
    """Bifurcation sweeps for impact oscillators with non-smooth forcing."""


@main.command()
@click.argument("scene_path", metavar="SCENE.toml", type=click.Path(dir_okay=False))
@click.option("-o", "--out", "out", type=click.Path(dir_okay=False),
              help="Output HDF5 file (default: the scene name + .h5).")
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
              help="Override a scene key, e.g. --set sweep.kappa.num=101.")
@click.option("--threads", type=click.IntRange(min=1), help="Numba threads (default: all cores).")
@click.option("--resume", is_flag=True, help="Complete an interrupted sweep (OUT.h5.partial).")
@click.option("--overwrite", is_flag=True, help="Replace an existing output.")
@click.option("--dry-run", is_flag=True, help="Validate, print the work and output estimate, run nothing.")
@click.option("--progress/--no-progress", default=None,
              help="Progress bar on stderr (default: when stderr is a terminal).")
@click.option("--block-points", type=click.IntRange(min=1), default=None,
              help="Grid points per block (the unit that is written and marked done).")
@click.option("--scheduler", metavar="ADDRESS|local:N", default=None,
              help="Run the blocks on a Dask cluster: a scheduler address (tcp://host:8786) "
                   "or local:N for N local worker processes; --threads is then the numba "
                   'threads of each worker. Needs pip install "cornerbif[dask]".')
def sweep(scene_path, out, sets, threads, resume, overwrite, dry_run, progress, block_points,
          scheduler):
    """Run SCENE.toml and write the diagram to HDF5."""
    scene = _load(scene_path, sets)
    if scheduler is not None:
        from .distributed import parse_scheduler, require_dask
        from .errors import SweepError
        try:
            parse_scheduler(scheduler)
            require_dask()
        except SweepError as e:
            _fail(str(e))
    from .errors import WriteFailed
    from .sweep import SweepError, SweepInterrupted, estimate_bytes, estimate_memory, run_sweep
    out = out or f"{scene.name}.h5"
    import numpy as np
    n_points = int(np.prod(scene.shape or (1,)))
    n_items = n_points * scene.n_ic
    if dry_run:
        click.echo(f"scene {scene.name}: model {scene.model}, grid {scene.shape or '(single point)'}, "
                   f"{scene.n_ic} starts -> {n_items} runs of {scene.transient + scene.record} impacts")
        click.echo(f"output {out}: up to {estimate_bytes(scene) / 2**20:.1f} MiB (uncompressed)")
        click.echo(f"working memory: about {estimate_memory(scene) / 2**20:.1f} MiB")
        return
    if progress is None:
        progress = sys.stderr.isatty() and not os.environ.get("CI")
    from .engine import kernel_cache_cold
    if kernel_cache_cold(scene):
        click.echo("compiling the numba kernels: the first run after an install takes tens of "
                   "seconds (cached afterwards) ...", err=True)
    try:
        path = run_sweep(scene, out, threads=threads, resume=resume, overwrite=overwrite,
                         progress=progress, command=_command_line(scene_path, out, sets, threads,
                                                                  resume, overwrite, block_points,
                                                                  scheduler),
                         block_points=block_points, scheduler=scheduler)
    except SweepInterrupted as e:
        _fail(str(e), 130)
    except WriteFailed as e:
        if e.broken:
            # HDF5's state in this process is unusable after a failed write: end now, without
            # its clean-up (which would write into the same error and flood the terminal)
            click.echo(f"error: {e}", err=True)
            sys.stdout.flush()
            sys.stderr.flush()
            os._exit(1)
        _fail(str(e), 1)
    except SweepError as e:
        # failed chunks on a cluster: a run-time failure (1), not bad input (2)
        _fail(str(e), 1 if getattr(e, "failures", None) else 2)
    click.echo(f"wrote {path}")


def _command_line(scene_path, out, sets, threads, resume, overwrite, block_points,
                  scheduler=None):
    """The sweep command as run, for the file's provenance."""
    import shlex
    parts = ["cornerbif", "sweep", scene_path, "-o", out]
    for s in sets:
        parts += ["--set", s]
    if threads:
        parts += ["--threads", str(threads)]
    if block_points:
        parts += ["--block-points", str(block_points)]
    if scheduler:
        parts += ["--scheduler", scheduler]
    parts += ["--resume"] if resume else []
    parts += ["--overwrite"] if overwrite else []
    return " ".join(shlex.quote(str(p)) for p in parts)


@main.command()
@click.argument("files", nargs=-1, required=True, type=click.Path(dir_okay=False))
@click.option("-o", "--out", "out", type=click.Path(dir_okay=False),
              help="Figure file (.png, .pdf or .svg; default: first file with .png).")
@click.option("--y", "y", type=click.Choice(["impact_u", "impact_v", "section_u", "section_v",
                                             "winding", "period"]),
              help="What to draw against the swept parameter.")
@click.option("--title", help="Figure title (default: the scene's).")
def plot(files, out, y, title):
    """Draw the diagram(s) in FILES (several files are overlaid, e.g. follow up and down)."""
    from .io import FileFormatError
    from .plot import figure
    out = out or os.path.splitext(files[0])[0] + ".png"
    ext = os.path.splitext(out)[1].lower()
    if ext not in (".png", ".pdf", ".svg"):
        _fail(f"-o {out}: the figure must be .png, .pdf or .svg")
    try:
        figure(list(files), out, y=y, title=title)
    except FileFormatError as e:
        _fail(str(e))
    except ValueError as e:
        _fail(str(e))
    click.echo(f"wrote {out}")


@main.command()
@click.argument("file", type=click.Path(dir_okay=False))
def info(file):
    """Summarise a cornerbif HDF5 file."""
    import json

    import numpy as np

    from .io import FileFormatError, check_readable
    try:
        f = check_readable(file)
    except FileFormatError as e:
        _fail(str(e))
    with f:
        a = f.attrs
        click.echo(f"{file}: cornerbif format {a['format_version']}, written by cornerbif "
                   f"{a['cornerbif_version']}")
        click.echo(f"  created {a['created']}, completed {a['completed'] or 'NO (partial)'}")
        import tomllib
        sc = tomllib.loads(a["scene"])
        click.echo(f"  scene {sc['scene']['name']}: {sc['scene'].get('title', '')}")
        from . import registry
        model = sc["scene"]["model"]
        spec = registry.models().get(model)
        obstacle = sc["system"].get("obstacle")
        click.echo(f"  model {model}" + (f", obstacle {obstacle}" if obstacle else "")
                   + (f": {spec.doc}" if spec else " (not a model of this version)"))
        rn = sc.get("run", {})
        click.echo(f"  run: preset {rn.get('preset', 'paper')} -> transient {rn.get('transient')}, "
                   f"record {rn.get('record')}, tol {rn.get('tol')}, chatter {rn.get('chatter')}")
        for k, v in sc.get("sweep", {}).items():
            if k != "follow":
                vals = v["values"]
                click.echo(f"  axis {k}: {len(vals)} values in [{min(vals)}, {max(vals)}]")
        done = f["done"][...]
        click.echo(f"  grid points done: {int(done.sum())} / {done.size}")
        st = f["status"][...].ravel()
        codes = json.loads(a["status_codes"])
        counts = {codes.get(str(c), "NOT_RUN") if c >= 0 else "NOT_RUN": int((st == c).sum())
                  for c in np.unique(st)}
        click.echo(f"  status: {counts}")
        per = f["period"][...].ravel()
        per = per[per > 0]
        if per.size:
            vals, cnt = np.unique(per, return_counts=True)
            top = sorted(zip(cnt, vals), reverse=True)[:8]
            click.echo("  periods (count): " + ", ".join(f"{v} ({c})" for c, v in top))
        names = _names(f)
        if spec:
            kept = [k for k in spec.observables if any(n.startswith(k + "/") for n in names)]
            click.echo(f"  observables kept: {', '.join(kept) or 'none (summary only)'}; "
                       f"state {', '.join(spec.coords)}")
        click.echo(f"  datasets: {', '.join(sorted(n for n in names if not f[n].is_scale))}")
    from .plot import PlotData, attractor_summary
    click.echo(f"  {attractor_summary(PlotData(file), tex=False)}")


def _names(f):
    import h5py
    out = []
    f.visititems(lambda n, o: out.append(n) if isinstance(o, h5py.Dataset) else None)
    return out


@main.command()
@click.option("--configs", "config_dir", default="configs", show_default=True,
              type=click.Path(file_okay=False), help="Folder of scenes (every *.toml).")
@click.option("--out", "out", default="docs/gallery", show_default=True,
              type=click.Path(file_okay=False), help="Folder of the figures (FIG.png).")
@click.option("--data", "data", default="gallery_data", show_default=True,
              type=click.Path(file_okay=False), help="Folder of the sweeps (NAME.h5), reused.")
@click.option("--only", "only", multiple=True, metavar="NAME",
              help="Only this figure or scene (repeatable), e.g. --only fig05 --only fig07b.")
@click.option("--smoke", is_flag=True,
              help="Tiny version of every scene (3 grid values, 3 starts, 40 + 40 impacts).")
@click.option("--threads", type=click.IntRange(min=1), help="Numba threads (default: all cores).")
def gallery(config_dir, out, data, only, smoke, threads):
    """Sweep every scene whose file is missing or stale, then draw every figure."""
    import json
    import time

    from . import gallery as G
    from .errors import SweepError
    t = time.perf_counter()
    try:
        recs = G.run(config_dir, out, data, only=only, smoke=smoke, threads=threads, echo=click.echo)
    except SceneError as e:
        _fail("a scene cannot be run:\n  " + "\n  ".join(e.problems))
    except (SweepError, ValueError) as e:
        _fail(str(e))
    total = time.perf_counter() - t
    swept = sum(1 for r in recs for s in r["scenes"].values() if s["action"] != "reused")
    click.echo(f"{len(recs)} figures in {out}; {swept} scenes swept; {total:.1f} s in all")
    # the record of the last run of each figure: an --only run updates its figures only
    path = os.path.join(out, "gallery_run.json")
    old = {}
    if only and os.path.exists(path):
        with open(path) as fh:
            old = json.load(fh)
    figs = {r["figure"]: r for r in old.get("figures", [])}
    figs.update({r["figure"]: r for r in recs})
    run = {"total_seconds": round(total, 1), "smoke": smoke, "threads": threads, "only": list(only)}
    doc = {"figures": [figs[k] for k in sorted(figs)],
           "runs": ([run] + old.get("runs", []))[:5] if only else [run]}
    with open(path, "w") as fh:
        json.dump(doc, fh, indent=1)


@main.command()
@click.argument("scene_path", metavar="SCENE.toml", type=click.Path(dir_okay=False))
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE")
def validate(scene_path, sets):
    """Check a scene and print it as it would run (run.preset resolved to its values)."""
    scene = _load(scene_path, sets)
    click.echo(f"# run.preset {scene.preset!r} -> transient {scene.transient}, tol {scene.tol!r}, "
               f"chatter {scene.chatter!r} (explicit [run] keys override the preset)")
    click.echo(scene.text)


if __name__ == "__main__":
    main()
