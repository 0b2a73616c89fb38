"""Command line: ``cornerbif sweep | plot | info | validate | continue | gallery`` (click).

Every command ends with one of the exit codes of ``cornerbif.errors`` (0 done, 1 a fault
outside the input after work began, 2 bad input refused before any work, 130 interrupted),
and never with a Python traceback: ``Commands.invoke`` is the one place that turns an
error into its message and its code (docs/guarantees.md, "Exit codes").
"""

from __future__ import annotations

import os
import sys

import click

from .config import PLOT_COLOR_BY, PLOT_Y, SceneError
from .errors import EXIT_FAULT, EXIT_INPUT, EXIT_INTERRUPTED, SweepError, WriteFailed


def _fail(msg, code=EXIT_INPUT):
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
        sys.exit(EXIT_INPUT)


def _end_broken(msg):
    """A write failed inside HDF5: this process's HDF5 state is unusable, so the command
    ends now, without its clean-up (which would write into the same error and flood the
    terminal, or crash)."""
    click.echo(f"error: {msg}", err=True)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(EXIT_FAULT)


class Commands(click.Group):
    """The command group: every command runs inside ``invoke``, which maps what ends it
    to one exit code and one message (``cornerbif.errors``):

    * ``SweepError`` and its kinds: their ``exit_code`` (bad input 2, ``Fault`` and
      ``WriteFailed`` 1, ``SweepInterrupted`` 130), the message as given;
    * ``SceneError``: 2, every problem listed;
    * an interrupt (Ctrl-C, or SIGTERM: ``outputs.install_signal_handlers``) that no
      command caught: 130;
    * ``MemoryError`` and ``OSError``: 1, in a few words;
    * anything else is a bug: 1, one line that says so (``CORNERBIF_DEBUG=1`` shows the
      traceback).
    """

    def invoke(self, ctx):
        from . import outputs
        outputs.install_signal_handlers()
        sys.unraisablehook = _quiet_failed_hdf5
        try:
            return super().invoke(ctx)
        except (click.exceptions.Exit, click.ClickException, click.Abort):
            raise
        except SceneError as e:
            click.echo("error: the scene cannot be run:", err=True)
            for p in e.problems:
                click.echo(f"  {p}", err=True)
            sys.exit(EXIT_INPUT)
        except WriteFailed as e:
            if e.broken:
                _end_broken(str(e))
            _fail(str(e), e.exit_code)
        except SweepError as e:
            _fail(str(e), e.exit_code)
        except KeyboardInterrupt:
            _fail("interrupted", EXIT_INTERRUPTED)
        except RecursionError:
            _fail("an input nested too deeply to be read", EXIT_INPUT)
        except MemoryError:
            _fail("out of memory (the machine could not give what this input asks for; "
                  "shrink it)", EXIT_FAULT)
        except OSError as e:
            _fail(f"{getattr(e, 'filename', None) or 'input/output'}: {outputs.reason(e)}",
                  EXIT_FAULT)
        except Exception as e:  # noqa: BLE001 - a bug: one line, never a traceback
            if os.environ.get("CORNERBIF_DEBUG"):
                raise
            _fail(f"internal error ({type(e).__name__}: {str(e)[:300]}); this is a bug in "
                  "cornerbif: run again with CORNERBIF_DEBUG=1 for the traceback and report it",
                  EXIT_FAULT)


@click.group(cls=Commands, invoke_without_command=True,
             context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(package_name="cornerbif")
@click.pass_context
def main(ctx):
    """Bifurcation sweeps for impact oscillators with non-smooth forcing.

    Exit codes (every command): 0 done, 1 a fault outside the input after work began (disk,
    I/O; what was finished is kept), 2 bad input refused before any work, 130 interrupted
    (what was finished is kept).
    """
    if ctx.invoked_subcommand is None:
        click.echo(ctx.get_help())


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
    # numba's OpenMP threads sleep between a block's parallel regions instead of spinning:
    # the writer thread then gets the core they leave (2-thread sweep, benchmarks: 1.09-1.12 s
    # against 1.11-1.25 s spinning, best of 3 in each of 5 alternating turns); libgomp reads
    # it when numba first starts its threads, after this
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    scene = _load(scene_path, sets)
    if scheduler is not None:
        from .distributed import parse_scheduler, require_dask
        parse_scheduler(scheduler)
        require_dask()
    from .sweep import default_output, run_sweep
    out = out or default_output(scene)
    cores = _check_threads(threads)
    if dry_run:
        for line in _describe(scene, out, threads or cores):
            click.echo(line)
        from .sweep import check_budget, check_output
        check_output(out, overwrite or resume, (scene_path,))
        check_budget(scene, out)
        click.echo("ok: the sweep fits (disk, memory) and can write its output")
        return
    if progress is None:
        progress = sys.stderr.isatty() and not os.environ.get("CI")
    from .sweep import duration, estimate_seconds
    eta = estimate_seconds(scene, threads or cores)
    if eta > 60 and not resume:
        click.echo(f"this sweep will take about {duration(eta)} on {threads or cores} thread(s) "
                   "(cornerbif sweep --dry-run gives the estimates; Ctrl-C keeps every finished "
                   "point, --resume completes it)", err=True)
    from .engine import kernel_cache_cold
    if kernel_cache_cold(scene):
        click.echo("compiling the numba kernels: the first run after an install takes tens of "
                   "seconds (cached afterwards) ...", err=True)
    path = run_sweep(scene, out, threads=threads, resume=resume, overwrite=overwrite,
                     progress=progress, command=_command_line(scene_path, out, sets, threads,
                                                              resume, overwrite, block_points,
                                                              scheduler),
                     block_points=block_points, scheduler=scheduler, inputs=(scene_path,),
                     echo=lambda m: click.echo(m, err=True))
    if path is None:
        return            # --resume of a finished output: said so, nothing to do
    click.echo(f"wrote {path}")


def _quiet_failed_hdf5(unraisable):
    """After a write failed inside HDF5, h5py's objects fail again as they are freed
    ("Can't decrement id ref count"), each printing a traceback; the sweep reports the
    failure itself, in one message."""
    text = str(unraisable.exc_value)
    if isinstance(unraisable.exc_value, RuntimeError) and "id ref count" in text:
        return
    sys.__unraisablehook__(unraisable)


def _check_threads(threads):
    """The cores numba may use here; refuse ``--threads`` above them (exit 2)."""
    import numba
    cores = numba.config.NUMBA_NUM_THREADS
    if threads and threads > cores:
        _fail(f"--threads {threads}: numba can use at most {cores} threads on this machine "
              "(its cores, or NUMBA_NUM_THREADS)")
    return cores


def _describe(scene, out, threads):
    """What a scene will do, in lines: grid, runs, output size, memory and time."""
    from .sweep import duration, estimate_bytes, estimate_memory, estimate_seconds
    n_points = 1
    for n in scene.shape:
        n_points *= n
    n_items = n_points * scene.n_ic
    lines = [f"scene {scene.name}: model {scene.model}"
             + (f", obstacle {scene.obstacle}" if scene.spec.obstacles else "")]
    for a in scene.axes:
        lo, hi = min(a.values), max(a.values)
        lines.append(f"  axis {a.name}: {len(a.values)} values from {lo:.10g} to {hi:.10g}")
    lines.append(f"  {n_points} grid points x {scene.n_ic} starts = {n_items} runs of "
                 f"{scene.transient} + {scene.record} events")
    lines.append(f"output {out}: up to {estimate_bytes(scene) / 2**20:.1f} MiB (uncompressed)")
    lines.append(f"working memory: about {estimate_memory(scene) / 2**20:.1f} MiB (the "
                 "process's peak)")
    early = " (at most: runs stop once their cycle is found)" if scene.stop == "period" else ""
    lines.append(f"time: about {duration(estimate_seconds(scene, threads))} on {threads} "
                 f"thread(s){early}, at this machine's measured speed (benchmarks/run.py)")
    c = scene.cont
    if c:
        seeds = c["seed"] if isinstance(c["seed"], list) else [c["seed"]]
        lines.append(f"cornerbif continue: {c['parameter']} over {c['range']} from "
                     f"{c['start']!r}, seeds {', '.join(map(str, seeds))}"
                     + (f" (from {c['seed_file']})" if "seed_file" in c else "")
                     + (f"; corner and fold curves in {c['curve']} over {c['curve_range']}"
                        if "curve" in c else "")
                     + f"; events {', '.join(c['events'])}")
    return lines


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
@click.option("--y", "y", type=click.Choice(list(PLOT_Y)),
              help="What to draw against the swept parameter (impact_height: u - kappa, the "
                   "height above the corner).")
@click.option("--title", help="Figure title (default: the scene's).")
@click.option("--color-by", "color_by", type=click.Choice(list(PLOT_COLOR_BY)),
              help="Colour the diagram (or the chart's left panel) by each run's largest "
                   "Lyapunov exponent or largest |Floquet multiplier| (files kept with "
                   "\"stability\").")
@click.option("--style", "style", metavar="STYLE",
              help="A matplotlib style sheet (a name or a .mplstyle file) over the project's "
                   "style (default: [plot] style).")
def plot(files, out, y, title, color_by, style):
    """Draw the diagram(s) in FILES (several files are overlaid, e.g. follow up and down);
    continuation files (``cornerbif continue``) are drawn over the diagram, or alone."""
    from .io import FileFormatError
    from .plot import figure
    out = out or os.path.splitext(files[0])[0] + ".png"
    ext = os.path.splitext(out)[1].lower()
    if ext not in (".png", ".pdf", ".svg"):
        _fail(f"-o {out}: the figure must be .png, .pdf or .svg")
    from .errors import SweepError
    from .sweep import check_directory
    try:
        check_directory(out)
    except SweepError as e:
        _fail(str(e))
    if any(os.path.exists(x) and os.path.exists(out) and os.path.samefile(x, out) for x in files):
        _fail(f"-o {out}: that is one of the files to draw; name another figure")
    from .plot import figure_branches, is_continuation
    conts = [x for x in files if is_continuation(x)]
    sweeps = [x for x in files if x not in conts]
    try:
        if sweeps:
            figure(sweeps, out, y=y, title=title, color_by=color_by, branches=conts,
                   style=style)
        else:
            figure_branches(conts, out, y=y, title=title, style=style)
    except (FileFormatError, ValueError) as e:
        _fail(str(e))
    except Exception as e:  # noqa: BLE001 - a file crafted past check_readable: say so, exit 2
        _fail(f"{', '.join(files)}: cannot be drawn ({type(e).__name__}: {e}); the file is "
              "damaged or was not written by cornerbif")
    click.echo(f"wrote {out}")


@main.command("continue")
@click.argument("scene_path", metavar="SCENE.toml", type=click.Path(dir_okay=False))
@click.option("-o", "--out", "out", type=click.Path(dir_okay=False),
              help="Output HDF5 file (default: the scene's name + '_continue.h5').")
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
              help="Override a scene key, e.g. --set continue.range=[-0.02,0.01].")
@click.option("--overwrite", is_flag=True, help="Replace an existing output file.")
def continue_(scene_path, out, sets, overwrite):
    """Continue the periodic orbits of SCENE.toml's [continue] table: every attractor found
    at the start (or the seed words), both ways in the parameter, stable or not, through
    corner collisions, grazings, folds and period doublings (docs/continuation.md)."""
    from .config import load
    try:
        scene = load(scene_path, sets)
    except SceneError as e:
        _fail("the scene cannot be run:\n  " + "\n  ".join(e.problems))
    if not scene.cont:
        _fail(f"{scene_path}: no [continue] table (parameter, range, ...: "
              "docs/continuation.md)")
    out = out or f"{scene.name}_continue.h5"
    from .errors import SweepError
    from .sweep import check_directory
    try:
        check_directory(out)
    except SweepError as e:
        _fail(str(e))
    if os.path.exists(out) and not overwrite:
        _fail(f"{out} exists; pass --overwrite to replace it")
    from . import continuation as C
    res = C.run_scene(scene, log=click.echo)
    if not res.branches:
        _fail("no branch to continue (see above): nothing written", code=1)
    C.write(res, out)
    click.echo(f"wrote {out}: {len(res.branches)} branches, "
               f"{sum(len(b.events) for b in res.branches)} events, {len(res.curves)} curves")


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
    try:
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
            from .config import sweep_items
            for k, v in sweep_items(sc.get("sweep", {})):
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
                # an observable is kept when every dataset of its Fields is in the file
                kept = [k for k, flds in spec.observables.items()
                        if all(fld.name in names for fld in flds)]
                click.echo(f"  observables kept: {', '.join(kept) or 'none (summary only)'}; "
                           f"state {', '.join(spec.coords)}")
            if "stability/status" in f:
                click.echo("  " + _stability_summary(f))
            click.echo(f"  datasets: {', '.join(sorted(n for n in names if not f[n].is_scale))}")
        from .plot import PlotData, attractor_summary
        click.echo(f"  {attractor_summary(PlotData(file), tex=False)}")
    except Exception as e:  # noqa: BLE001 - a file crafted past check_readable: say so, exit 2
        _fail(f"{file}: cannot be summarised ({type(e).__name__}: {e}); the file is damaged "
              "or was not written by cornerbif")


def _stability_summary(f):
    """One line on the stored stability: how the multipliers were found, the largest
    modulus of the runs' cycles (stable below 1), and the largest Lyapunov exponents
    (positive: chaotic)."""
    import numpy as np

    from .stability import REASONS
    st = f["stability/status"][...].ravel()
    counts = {REASONS.get(int(c), "not run").split(":")[0]: int((st == c).sum())
              for c in np.unique(st)}
    mod = np.hypot(f["stability/multiplier_re"][..., 0], f["stability/multiplier_im"][..., 0])
    mod = mod.ravel()[st == 0]
    line = f"stability: {counts}"
    if mod.size:
        line += (f"; largest |multiplier| of a cycle: median {np.median(mod):.4g}, max "
                 f"{mod.max():.4g} ({int((mod >= 1).sum())} of {mod.size} cycles not stable)")
    if "stability/lyapunov" in f:
        lst = f["stability/lyapunov_status"][...].ravel()
        lam = f["stability/lyapunov"][..., 0].ravel()
        fin = lam[(lst == 0) & np.isfinite(lam)]
        line += (f"; largest Lyapunov exponent over the window: {fin.size} runs, "
                 f"{int((fin > 0).sum())} positive (chaotic)")
        if fin.size:
            line += f", median {np.median(fin):.4g}, max {fin.max():.4g}"
        stuck = int((lst == 2).sum())
        if stuck:
            line += f", {stuck} -inf (the window sticks)"
    return line


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
    _check_threads(threads)
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
@click.option("--toml", is_flag=True, help="Also print the scene as it would run (TOML, "
              "every default explicit, every axis value listed).")
def validate(scene_path, sets, toml):
    """Check a scene: a verdict, what it will do, and with --toml the scene as it would run."""
    from .sweep import default_output
    scene = _load(scene_path, sets)
    click.echo(f"ok: {scene_path} is a valid scene")
    click.echo(f"# run.preset {scene.preset!r} -> transient {scene.transient}, tol {scene.tol!r}, "
               f"chatter {scene.chatter!r} (explicit [run] keys override the preset)")
    import numba
    for line in _describe(scene, default_output(scene), numba.config.NUMBA_NUM_THREADS):
        click.echo(line)
    if toml:
        click.echo(scene.text)


if __name__ == "__main__":
    main()
