"""Command line: ``cornerbif sweep | plot | info | validate | continue | gallery`` (click).

Every command ends with one of the exit codes of ``cornerbif.errors`` (0 done, 1 a fault
outside the input after work began, 2 bad input refused before any work, 130 interrupted),
and never with a Python traceback: ``Commands.invoke`` is the one place that turns an
error into its message and its code (docs/guarantees.md, "Exit codes").
"""

from __future__ import annotations

import contextlib
import json
import os
import shlex
import signal
import sys
import textwrap
import threading
import time
import tomllib
import warnings

import click
import numpy as np

from . import config, engine, figures, outputs, plot_style, registry
from . import continuation_run as C
from . import warm as warmup
from .branches import explain_file
from .config import PLOT_COLOR_BY, PLOT_ORBITS, PLOT_Y, SceneError, undrawable
from .errors import EXIT_FAULT, EXIT_INPUT, EXIT_INTERRUPTED, SweepError, SweepInterrupted, WriteFailed
from .estimate import estimate_bytes, estimate_file_bytes, estimate_memory, estimate_time, estimate_words
from .model import cut, did_you_mean
from .plot_style import TITLE_MAX, bounded, quiet


def _fail(msg, code=EXIT_INPUT):
    click.echo(f"error: {msg}", err=True)
    sys.exit(code)


def _load(scene_path, sets):
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

    def make_context(self, info_name, args, parent=None, **extra):
        """The arguments read (click's), an interrupt meanwhile ending as every command's
        does: exit 130 (click would say "Aborted!" and exit 1)."""
        try:
            return super().make_context(info_name, args, parent, **extra)
        except KeyboardInterrupt:
            _fail("interrupted", EXIT_INTERRUPTED)

    def invoke(self, ctx):
        handlers = outputs.install_signal_handlers()
        hook, sys.unraisablehook = sys.unraisablehook, _quiet_failed_hdf5
        try:
            return self._invoke(ctx)
        finally:
            outputs.restore_signal_handlers(handlers)
            sys.unraisablehook = hook

    def _invoke(self, ctx):
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
        except BrokenPipeError:
            raise                      # the reader of the output left (``info | head``):
            #                            click ends quietly (exit 1), as for --help
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
    # the writer thread then gets the core they leave; libgomp reads it when numba first
    # starts its threads, after this
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    scene = _load(scene_path, sets)
    if scheduler is not None:
        from .distributed import parse_scheduler, require_dask  # start-up: loads numba
        try:
            parse_scheduler(scheduler)
        except ValueError:
            # N of local:N that Python does not read as an int (more than 4300 digits, a
            # superscript digit): a number no machine has as many cores
            _fail(f"--scheduler {cut(scheduler)!r}: N in local:N must be a whole number >= 1 "
                  "(ASCII digits), at most this machine's cores")
        require_dask()
    from .sweep import run_sweep  # start-up: loads h5py
    out = outputs.default_output(scene) if out is None else out
    cores = _check_threads(threads)
    from .sweep import check_budget, check_directory, plan_output  # start-up: loads h5py
    check_directory(out)
    # what the sweep will do with its output, refused before anything else is said
    plan = plan_output(scene, out, resume, overwrite, (scene_path,))
    if dry_run:
        for line in _describe(scene, out, threads or cores):
            click.echo(line)
        if plan == "done":
            click.echo(f"ok: {out} is already complete (finished from this scene); --resume "
                       "has nothing to do")
            return
        if plan == "start":
            for note in check_budget(scene, out):
                click.echo(f"note: {note}")
        click.echo(f"ok: the sweep can {'resume ' + out + '.partial' if plan == 'resume' else 'start'}"
                   " (disk, memory) and can write its output")
        return
    if progress is None:
        progress = sys.stderr.isatty() and not os.environ.get("CI")
    if plan != "done":
        eta = estimate_time(scene, threads or cores)
        if eta.high > 60 and plan == "start":
            click.echo(f"this sweep will take {estimate_words(eta)} on {threads or cores} "
                       "thread(s) (cornerbif sweep --dry-run gives the estimates; Ctrl-C keeps "
                       "every finished point, --resume completes it)", err=True)
        engine.announce_compiles(scene, lambda m: click.echo(m, err=True), ("sweep",))
    with engine.compiling_aside(scene, ("sweep",)) if plan != "done" and scheduler is None \
            else contextlib.nullcontext():
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
    """What Python cannot raise where it happens (an exception in a finalizer or a weakref
    callback), while a command runs:

    * an interrupt (Ctrl-C, or SIGTERM: ``outputs.Terminated``) whose handler ran inside a
      finalizer would be printed and lost, and the command would run on to exit 0: the
      signal is sent again, so its handler runs once the finalizer has returned, where the
      command answers it (exit 130);
    * after a write failed inside HDF5, h5py's objects fail again as they are freed
      ("Can't decrement id ref count"), each printing a traceback; the sweep reports the
      failure itself, in one message."""
    if isinstance(unraisable.exc_value, KeyboardInterrupt):
        _raise_again_soon(unraisable.exc_value)
        return
    text = str(unraisable.exc_value)
    if isinstance(unraisable.exc_value, RuntimeError) and "id ref count" in text:
        return
    sys.__unraisablehook__(unraisable)


def _raise_again_soon(interrupt):
    """Raise ``interrupt`` (a KeyboardInterrupt) in the main thread a millisecond from now, by
    a one-shot timer signal (SIGALRM), so that it is raised after the finalizer and the
    hook that lost it have returned (``signal.raise_signal`` would run its handler inside
    the hook, where it is lost again; a thread started here would wait on a lock the
    handler interrupts).  Landing in another finalizer, it comes back here and is tried
    again."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "setitimer"):
        return

    def again(signum, frame):
        signal.signal(signal.SIGALRM, previous)
        raise interrupt
    previous = signal.signal(signal.SIGALRM, again)
    signal.setitimer(signal.ITIMER_REAL, 0.001)


def _check_threads(threads):
    """The cores numba may use here; refuse ``--threads`` above them (exit 2)."""
    import numba  # start-up: loads numba
    cores = numba.config.NUMBA_NUM_THREADS
    if threads and threads > cores:
        _fail(f"--threads {threads}: numba can use at most {cores} threads on this machine "
              "(its cores, or NUMBA_NUM_THREADS)")
    return cores


def _numba_threads() -> int:
    """``numba.config.NUMBA_NUM_THREADS`` (the cores numba may use here), read as numba reads
    it, without importing numba where that reading is plain: ``validate`` describes a scene
    without loading numba (start-up time).  NUMBA_NUM_THREADS when it is a positive integer,
    else the cores this process may run on; numba itself answers once it is loaded, and
    where its own reading may differ (a .numba_config.yaml in the working directory, another
    value of NUMBA_NUM_THREADS, which numba warns of or refuses)."""
    if "numba" not in sys.modules and not os.path.exists(".numba_config.yaml"):
        given = os.environ.get("NUMBA_NUM_THREADS")
        if given is None:
            try:
                return max(1, len(os.sched_getaffinity(0)))
            except AttributeError:  # pragma: no cover - not Linux
                return max(1, os.cpu_count() or 1)
        text = given.strip()
        # ASCII digits of a count a machine can have (Python reads no integer past 4300
        # digits); anything else is numba's to read (and to refuse)
        if text.isascii() and text.isdigit() and len(text) <= 9 and int(text) > 0:
            return int(text)
    import numba  # start-up: loads numba
    return numba.config.NUMBA_NUM_THREADS


def _describe(scene, out, threads):
    """What a scene will do, in lines: grid, runs, output size, memory and time."""
    n_points = 1
    for n in scene.shape:
        n_points *= n
    n_items = n_points * scene.n_ic
    lines = [f"scene {scene.name}: model {scene.model}"
             + (f", obstacle {scene.extra['obstacle']}" if scene.spec.obstacles else "")]
    for a in scene.axes:
        lo, hi = min(a.values), max(a.values)
        lines.append(f"  axis {a.name}: {len(a.values)} values from {lo:.10g} to {hi:.10g}")
    lines.append(f"  {n_points} grid points x {scene.n_ic} starts = {n_items} runs of "
                 f"{scene.transient} + {scene.record} events"
                 + (f", then {scene.transient} + {scene.lyapunov_impacts} more each for the "
                    "streamed Lyapunov exponents (run.lyapunov_impacts)"
                    if scene.lyapunov_impacts else ""))
    low, typical, high = estimate_file_bytes(scene)
    lines.append(f"output {out}: about {typical / 2**20:.1f} MiB on disk ({low / 2**20:.1f} to "
                 f"{high / 2**20:.1f} MiB at the compression ratios measured on the shipped "
                 f"scenes; at most {estimate_bytes(scene) / 2**20:.1f} MiB uncompressed)")
    lines.append(f"working memory: about {estimate_memory(scene) / 2**20:.1f} MiB (the "
                 "process's peak)")
    early = " (at most: runs stop once their cycle is found)" if scene.stop == "period" else ""
    lines.append(f"time: {estimate_words(estimate_time(scene, threads))} on {threads} "
                 f"thread(s){early}, at this machine's measured speed "
                 "(benchmarks/estimate_time.py)")
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
@click.option("--kind", "kind", metavar="KIND",
              help="The figure kind, instead of the scene's [plot] kind (e.g. branches: the "
                   "skeleton of a file explained by cornerbif explain).")
@click.option("--orbits", "orbits", type=click.Choice(list(PLOT_ORBITS)),
              help="Colour a diagram's orbits by word, by family (beta^N gamma for every N) "
                   "or by branch (cornerbif explain's), instead of the scene's [plot] orbits.")
def plot(files, out, y, title, color_by, style, kind, orbits):
    """Draw the diagram(s) in FILES (several files are overlaid, e.g. follow up and down);
    continuation files (``cornerbif continue``) are drawn over the diagram, or alone.

    Files drawn together: sweeps of one parameter and one model (overlaid), a flow against
    its map (two files, flow and map2d, at the same system values), continuation files over
    the diagram of their parameter; anything else is refused before drawing. An existing
    figure at OUT is replaced (only a figure of its format; never a file drawn, a style
    sheet or any other file), whole or not at all."""
    from .io import FileFormatError  # start-up: loads h5py
    out = os.path.splitext(files[0])[0] + ".png" if out is None else out
    ext = os.path.splitext(out)[1].lower()
    if ext not in (".png", ".pdf", ".svg"):
        _fail(f"-o {out}: the figure must be .png, .pdf or .svg")
    problem = plot_style.check_style(style, "--style")
    if problem:
        _fail(problem)
    if title is not None:
        title = _plot_title(title)
    if kind is not None:
        _check_kind(kind)
    inputs = [("the file to draw", f) for f in files]
    if style and os.path.isfile(style):
        inputs.append(("the style sheet", style))
    outputs.check_output(out, False, inputs=inputs, kind="figure", option="-o",
                         suffixes=(".partial",))

    from .plot import draw_files  # start-up: loads numba
    try:
        # what matplotlib or numpy still say (plot_style.quiet silences what files hold by
        # design) is said after the figure, one line each
        with warnings.catch_warnings(record=True) as said:
            draw_files(list(files), out, y=y, title=title, color_by=color_by, style=style,
                       kind=kind, orbits=orbits)
    except FileFormatError as e:
        _fail(str(e))
    except KeyboardInterrupt:
        raise SweepInterrupted(f"interrupted: no figure written ({out}, if it existed, is "
                               "unchanged)") from None
    except (SweepError, RecursionError, MemoryError):
        raise
    except Exception as e:  # noqa: BLE001 - a file crafted past the readers' checks
        if os.environ.get("CORNERBIF_DEBUG"):
            raise
        why = cut(f"{type(e).__name__}: {e}", 300)
        _fail(f"{', '.join(files)}: cannot be drawn ({why}); nothing was written. The files "
              "hold values cornerbif does not write (damaged or crafted), or this is a bug in "
              "cornerbif: CORNERBIF_DEBUG=1 shows the traceback")
    for w in {cut(str(w.message).splitlines()[0] if str(w.message) else
                   w.category.__name__, 200) for w in said}:
        click.echo(f"note: drawing {out}: {w}", err=True)
    click.echo(f"wrote {out}")


def _check_kind(kind):
    """``--kind``: one of the registered figure kinds (``figures.registered``), refused
    (exit 2) naming the kinds otherwise; what each kind needs of a file is asked of the
    file's scene before drawing (``plot.check_together``)."""
    kinds = figures.registered()
    if kind not in kinds:
        _fail(f"--kind {cut(kind, 100)!r}: not a figure kind{did_you_mean(kind, kinds)}; "
              f"allowed: {', '.join(kinds)}")


def _plot_title(title):
    """``--title``: at most ``plot_style.TITLE_MAX`` characters (the rest cut, said on
    stderr), refused (exit 2) when matplotlib cannot draw its formulas."""
    if len(title) > plot_style.TITLE_MAX:
        click.echo(f"note: --title has {len(title)} characters; the figure shows the first "
                   f"{plot_style.TITLE_MAX}", err=True)
        title = plot_style.bounded(title, plot_style.TITLE_MAX)
    problem = undrawable(plot_style.title_tex(title), "--title")
    if problem:
        _fail(problem)
    return title


@main.command("continue")
@click.argument("scene_path", metavar="SCENE.toml", type=click.Path(dir_okay=False))
@click.option("-o", "--out", "out", type=click.Path(dir_okay=False),
              help="Output HDF5 file (default: the scene's name + '_continue.h5').")
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
              help="Override a scene key, e.g. --set continue.range=[-0.02,0.01].")
@click.option("--resume", is_flag=True,
              help="Complete an interrupted continuation (OUT.h5.partial: every branch and "
                   "curve finished before is kept); on a finished output of this scene, "
                   "nothing to do.")
@click.option("--overwrite", is_flag=True,
              help="Replace an existing output (a continuation file only; never the scene, "
                   "the seed file or another file).")
def continue_(scene_path, out, sets, resume, overwrite):
    """Continue the periodic orbits of SCENE.toml's [continue] table: every attractor found
    at the start (or the seed words), both ways in the parameter, stable or not, through
    corner collisions, grazings, folds and period doublings (docs/continuation.md).

    Each branch and curve is written to OUT.h5.partial as soon as it is finished: Ctrl-C,
    SIGTERM or a full disk keep them, and --resume completes the file as an uninterrupted
    run would have written it."""
    scene = _load(scene_path, sets)
    if not scene.cont:
        _fail(f"{scene_path}: no [continue] table (parameter, range, ...: "
              "docs/continuation.md)")

    out = outputs.default_output(scene).removesuffix(".h5") + "_continue.h5" if out is None else out
    inputs = [("the scene file", scene_path)]
    # what continue will do with its output, refused before anything else is said
    if C.plan_output(scene, out, resume, overwrite, inputs) != "done":
        engine.announce_compiles(scene, lambda m: click.echo(m, err=True), ("continuation",))
    command = ["cornerbif", "continue", scene_path, "-o", out]
    for s in sets:
        command += ["--set", s]
    command += ["--resume"] * resume + ["--overwrite"] * overwrite
    with engine.compiling_aside(scene, ("continuation",)):
        C.run_to_file(scene, out, resume=resume, overwrite=overwrite, log=click.echo,
                      inputs=inputs, command=" ".join(shlex.quote(str(p)) for p in command))


@main.command()
@click.argument("file", type=click.Path(dir_okay=False))
def info(file):
    """Summarise a cornerbif file: a sweep (its scene, its grid, how its runs ended, what it
    keeps) or a continuation (its branches, their events and curves).

    A partial file says how many of its grid points (or branches) are finished and
    summarises those; a sweep with no finished point is refused. Every text the file holds
    is shown on one line, cut at a bounded length."""
    from .io import FileFormatError  # start-up: loads h5py
    from .plot_data import is_continuation, read_continuation  # start-up: loads numba
    try:
        with quiet():             # numpy on the NaN and infinities a file holds by design
            if is_continuation(file):
                lines = _continuation_lines(read_continuation(file))
            else:
                lines = _sweep_lines(file)
    except FileFormatError as e:
        _fail(str(e))
    except (SweepError, RecursionError, MemoryError, KeyboardInterrupt):
        raise
    except Exception as e:  # noqa: BLE001 - a file crafted past the readers' checks
        if os.environ.get("CORNERBIF_DEBUG"):
            raise
        _fail(f"{file}: cannot be summarised ({cut(f'{type(e).__name__}: {e}', 300)}); the "
              "file holds values cornerbif does not write (damaged or crafted), or this is a "
              "bug in cornerbif: CORNERBIF_DEBUG=1 shows the traceback")
    for line in lines:
        click.echo(cut(line, MAX_INFO_LINE))


@main.command()
@click.argument("file", type=click.Path(dir_okay=False))
@click.option("--recompute", is_flag=True,
              help="Locate the branches again, though the file holds them.")
def explain(file, recompute):
    """Explain a finished sweep's diagram: its attractors linked across the grid into
    branches (each attractor's orbit solved and followed to the neighbouring grid values),
    where each branch begins and ends and why (a corner collision, a grazing, a fold, a
    period doubling, ..., located by continuation), what coexists, and the share of starts
    each attracts.  The branch table is stored in FILE (/branches, on a copy renamed over
    it: an interrupt leaves the file as it was) and read back on later calls."""
    from .io import FileFormatError  # start-up: loads h5py
    try:
        with quiet():
            lines = explain_file(file, recompute, log=lambda m: click.echo(m, err=True))
    except FileFormatError as e:
        _fail(str(e))
    for line in lines:
        click.echo(line)


@main.command()
@click.argument("files", nargs=-1, required=True, metavar="FILE.h5|SCENE.toml ...",
                type=click.Path(dir_okay=False, exists=True))
@click.option("--port", type=click.IntRange(min=0, max=65535), default=0, show_default=True,
              help="The port on 127.0.0.1 (0: a free one).")
@click.option("--no-browser", "no_browser", is_flag=True,
              help="Print the URL only (a remote machine: forward the port with ssh -L).")
def explore(files, port, no_browser):
    """Explore sweeps' diagrams in the browser: every point drawn at screen resolution,
    zoom and refine (a fresh sweep of the window, in a side file), click a point for its
    orbit, continue from it, save the view as a scene or a figure (docs/explore.md).  A
    SCENE.toml is swept first, beside it.  The server listens on 127.0.0.1 only and
    needs the token of the URL it prints.  Needs pip install "cornerbif[explore]"."""
    try:
        from .explorer import server  # optional: the explore extra (Panel, HoloViews, Datashader)
    except ImportError as e:
        _fail(f"cornerbif explore needs the explore extra: pip install \"cornerbif[explore]\" "
              f"({cut(str(e), 200)})")
    from .io import FileFormatError  # start-up: loads h5py
    paths = [server.sweep_first(f, echo=lambda m: click.echo(m, err=True))
             if f.endswith(".toml") else f for f in files]
    try:
        server.serve(paths, port=port, browser=not no_browser, echo=click.echo)
    except (FileFormatError, ValueError) as e:
        _fail(str(e))


def _sweep_lines(file):
    """``info`` of a sweep, in lines (``plot_base.PlotData`` reads it: only its finished points)."""


    from .io import check_readable  # start-up: loads h5py
    from .plot_base import attractor_summary, status_name  # start-up: loads numba
    from .plot_data import PlotData  # start-up: loads numba
    d = PlotData(file)
    with check_readable(file) as f:
        a = f.attrs
        done = a.get("completed")
        lines = [f"{file}: cornerbif format {bounded(a.get('format_version', '?'))}, written by "
                 f"cornerbif {bounded(a.get('cornerbif_version', '?'))}",
                 f"  created {bounded(a.get('created', '?'))}, completed "
                 + (bounded(done) if done else "NO (partial)")]
        if a.get("command"):
            lines.append(f"  command: {bounded(a['command'], 300)}")
        sc = d.scene.get("scene", {})
        lines.append(f"  scene {bounded(sc.get('name', '?'))}: {bounded(sc.get('title', ''), TITLE_MAX)}")
        spec = d.spec
        obstacle = d.scene.get("system", {}).get("obstacle")
        lines.append(f"  model {bounded(d.model)}" + (f", obstacle {bounded(obstacle)}" if obstacle
                                                       else "")
                     + (f": {spec.doc}" if spec else " (not a model of this version)"))
        rn = d.scene.get("run", {})
        lines.append(f"  run: preset {bounded(rn.get('preset', 'paper'))} -> transient "
                     f"{bounded(rn.get('transient'))}, record {bounded(rn.get('record'))}, tol "
                     f"{bounded(rn.get('tol'))}, chatter {bounded(rn.get('chatter'))}")
        for k in d.axes:
            vals = d.values[k]
            lines.append(f"  axis {bounded(k)}: {len(vals)} values in [{vals.min():.10g}, "
                         f"{vals.max():.10g}]")
        lines.append(f"  grid points done: {d.n_done} / {d.n_points}")
        if d.partial_note():
            lines.append(f"  {d.partial_note()}")
        try:
            names = json.loads(a.get("status_codes", "{}"))
            names = {str(k): str(v) for k, v in names.items()} if isinstance(names, dict) else None
        except (TypeError, ValueError):
            names = None
        codes, counts = np.unique(d.status, return_counts=True)
        lines.append(f"  status of the {d.status.size} runs: "
                     + _names_line(f"{status_name(c, names)} {n}" for c, n in zip(codes, counts)))
        per = d.period[d.period > 0]
        if per.size:
            vals, cnt = np.unique(per, return_counts=True)
            top = sorted(zip(cnt, vals), reverse=True)[:8]
            lines.append("  periods (count): " + ", ".join(f"{v} ({c})" for c, v in top))
        datasets = _names(f)
        if spec:
            # an observable is kept when every dataset of its Fields is in the file
            kept = [k for k, flds in spec.observables.items()
                    if all(fld.name in datasets for fld in flds)]
            lines.append(f"  observables kept: {_names_line(kept) or 'none (summary only)'}; "
                         f"state {_names_line(spec.coords)}")
        if "stability/status" in f:
            lines.append("  " + _stability_summary(f, d))
        lines += _dataset_lines([n for n in datasets if not f[n].is_scale])
    lines.append(f"  {bounded(attractor_summary(d, tex=False), MAX_INFO_LINE)}")
    return lines


def _names_line(names) -> str:
    """Names a file declares (a linear scene's coordinates, its status names), for one
    line of ``info``: each cut to a bounded length (``plot_style.bounded``), at most
    MAX_LISTED of them and the count of the rest."""
    names = list(names)
    text = ", ".join(bounded(n) for n in names[:MAX_LISTED])
    return text + (f", ... and {len(names) - MAX_LISTED} more" if len(names) > MAX_LISTED else "")


# the characters of one line ``info`` prints (each field of a file is cut shorter; this
# bounds a line whatever it gathers)
MAX_INFO_LINE = 2000


def _continuation_lines(c):
    """``info`` of a continuation file (``plot_data.read_continuation``), in lines: its scene,
    parameter and seeds; each branch's word, range, points, stable points and why each end
    stopped; the events; the curves."""


    from .plot_base import continuation_note  # start-up: loads numba
    a, p = c["attrs"], bounded(c["parameter"])
    sc = tomllib.loads(c["scene"]).get("scene", {})
    lines = [f"{c['path']}: cornerbif continuation, format {bounded(a.get('format_version', '?'))}"
             f", written by cornerbif {bounded(a.get('cornerbif_version', '?'))}",
             f"  created {bounded(a.get('created', '?'))}, completed "
             + (bounded(a['completed']) if a.get("completed") else "NO (partial)"),
             f"  scene {bounded(sc.get('name', '?'))}: {bounded(sc.get('title', ''), TITLE_MAX)}",
             f"  model {bounded(a.get('model', '?'))}"
             + (f", obstacle {bounded(a['obstacle'])}" if a.get("obstacle") else "")
             + f"; continued in {p}"
             + (f" from the seeds {bounded(a['seeds'], 200)}" if a.get("seeds") else "")]
    if continuation_note(c):
        lines.append(f"  {continuation_note(c)}")
    n = len(c["branches"])
    lines.append(f"  branches: {n}" + ("" if n else " (the continuation found no orbit to "
                                                    "follow)"))
    for b, br in enumerate(c["branches"][:MAX_LISTED]):
        lam = br["param"]
        st = np.asarray(br["stable"]).astype(bool)
        lines.append(f"    branch {b}: {bounded(br.get('word') or '?')} over {p} in "
                     f"[{lam.min():.10g}, {lam.max():.10g}], {lam.size} points ({int(st.sum())} "
                     "stable)")
        stops = br.get("stops")
        stops = [stops] if isinstance(stops, str) else list(stops or [])
        for why in stops[:4]:
            lines.append(f"      stopped at {bounded(why, 200)}")
        if not stops:
            ends = [e for e in c["events"] if e["branch"] == b and e["kind"] == "end"]
            for e in ends[:4]:
                lines.append(f"      stopped at {p} = {e['param']:.12g}: {bounded(e['detail'], 200)}")
    if n > MAX_LISTED:
        lines.append(f"    ... and {n - MAX_LISTED} more branches")
    inner = [e for e in c["events"] if e["kind"] != "end"]
    lines.append(f"  events ({len(inner)}):" if inner else "  events: none")
    for e in inner[:MAX_LISTED]:
        lines.append(f"    branch {e['branch']}: {bounded(e['kind'], 30)} at {p} = "
                     f"{e['param']:.12g}" + (f" ({bounded(e['detail'], 160)})" if e["detail"]
                                             else ""))
    if len(inner) > MAX_LISTED:
        lines.append(f"    ... and {len(inner) - MAX_LISTED} more events")
    lines.append(f"  curves ({len(c['curves'])}):" if c["curves"] else "  curves: none")
    for k, cv in enumerate(c["curves"][:MAX_LISTED]):
        x, y = cv["param"], cv["event_param"]
        rng = (f"{bounded(cv.get('param_name', '?'))} in [{x.min():.6g}, {x.max():.6g}], "
               f"{bounded(cv.get('event_param_name', p))} in [{y.min():.6g}, {y.max():.6g}]"
               if x.size else "no points")
        lines.append(f"    curve {k}: {bounded(cv.get('kind', 'corner'), 20)} curve of branch "
                     f"{int(cv['branch'])} ({bounded(cv.get('what', ''), 80)}), {x.size} points, "
                     f"{rng}")
    if len(c["curves"]) > MAX_LISTED:
        lines.append(f"    ... and {len(c['curves']) - MAX_LISTED} more curves")
    return lines


# the most branches, events, curves or dataset names ``info`` lists (then "... and N more")
MAX_LISTED = 40


def _stability_summary(f, d=None):
    """One line on the stored stability: how the multipliers were found, the largest
    modulus of the runs' cycles (stable below 1), and the largest Lyapunov exponents
    (positive: chaotic).  ``d``: the file's ``plot_base.PlotData`` (its finished points only);
    datasets that do not match its runs are said to, and not read."""

    from .stability import REASONS  # start-up: loads numba
    runs = f["status"].shape
    names = ["stability/status", "stability/multiplier_re", "stability/multiplier_im"]
    if "stability/lyapunov" in f:
        names += ["stability/lyapunov", "stability/lyapunov_status"]
    if any(n not in f or f[n].shape[:len(runs)] != runs for n in names):
        return "stability: its datasets do not match the runs (not summarised)"
    st = f["stability/status"][...]
    if d is not None and d.unfinished is not None:
        st = np.where(d.status == -1, -1, st)
    st = st.ravel()

    def reason(c):
        return "not run" if c == -1 else REASONS.get(c, f"unknown ({c})").split(":")[0]
    counts = {reason(int(c)): int((st == c).sum()) for c in np.unique(st)}
    with np.errstate(all="ignore"):
        mod = np.hypot(f["stability/multiplier_re"][..., 0], f["stability/multiplier_im"][..., 0])
    mod = mod.ravel()[st == 0]
    mod = mod[np.isfinite(mod)]
    line = "stability: " + ", ".join(f"{k} {v}" for k, v in counts.items())
    if mod.size:
        line += (f"; largest |multiplier| of a cycle: median {np.median(mod):.4g}, max "
                 f"{mod.max():.4g} ({int((mod >= 1).sum())} of {mod.size} cycles not stable)")
    if "stability/lyapunov" in f:
        lst = f["stability/lyapunov_status"][...]
        if d is not None and d.unfinished is not None:
            lst = np.where(d.status == -1, -1, lst)
        lst = lst.ravel()
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
    import h5py  # start-up: loads h5py
    out = []
    f.visititems(lambda n, o: out.append(n) if isinstance(o, h5py.Dataset) else None)
    return out


def _dataset_lines(names, width=100):
    """The dataset names, grouped by folder ('impacts/: t, u, v_in'), each group wrapped to
    ``width`` columns; at most MAX_LISTED names of a group and MAX_LISTED groups, each name
    cut to a bounded length."""

    groups = {}
    for n in sorted(names):
        folder, _, leaf = n.rpartition("/")
        groups.setdefault(folder, []).append(leaf)
    lines = [f"  datasets ({len(names)}):"]
    for folder, leaves in list(groups.items())[:MAX_LISTED]:
        shown = [bounded(x) for x in leaves[:MAX_LISTED]]
        if len(leaves) > MAX_LISTED:
            shown.append(f"... and {len(leaves) - MAX_LISTED} more")
        head = f"    {bounded(folder) + '/' if folder else '/'}: "
        lines += textwrap.wrap(", ".join(shown), width, initial_indent=head,
                               subsequent_indent=" " * 6, break_on_hyphens=False)
    if len(groups) > MAX_LISTED:
        lines.append(f"    ... and {len(groups) - MAX_LISTED} more groups")
    return lines


@main.command()
@click.option("--configs", "config_dir", default="configs", show_default=True,
              type=click.Path(file_okay=False), help="Folder of scenes (every *.toml).")
@click.option("--out", "out", default=None, type=click.Path(file_okay=False),
              help="Folder of the figures (FIG.png) and gallery_run.json (default: docs/gallery; "
                   "with --smoke gallery_smoke).")
@click.option("--data", "data", default=None, type=click.Path(file_okay=False),
              help="Folder of the sweeps and continuations (NAME.h5), reused while they match "
                   "their scene (default: gallery_data; with --smoke gallery_smoke/data).")
@click.option("--only", "only", multiple=True, metavar="NAME",
              help="Only this figure or scene (repeatable), e.g. --only fig05 --only fig07b.")
@click.option("--smoke", is_flag=True,
              help="Tiny version of every scene (3 grid values, 3 starts, 40 + 40 impacts), in "
                   "folders of its own; it never replaces a full run's files.")
@click.option("--overwrite", is_flag=True,
              help="Also replace cornerbif files in the way that the gallery did not write (a "
                   "sweep of your own in --data, a figure gallery_run.json does not list); "
                   "never a file of another kind, nor a full run's file in a --smoke run.")
@click.option("--threads", type=click.IntRange(min=1), help="Numba threads (default: all cores).")
def gallery(config_dir, out, data, only, smoke, overwrite, threads):
    """Sweep every scene whose file is missing or stale, then draw every figure.

    Every output is checked before the first sweep: the gallery replaces only files it
    wrote itself (others with --overwrite). Interrupted (Ctrl-C, a kill, a full disk), the
    same command run again continues where it stopped."""
    _check_threads(threads)

    from . import gallery as G  # start-up: loads numba
    t = time.perf_counter()
    recs = G.run(config_dir, out, data, only=only, smoke=smoke, threads=threads,
                 overwrite=overwrite, echo=click.echo)
    swept = sum(1 for r in recs for s in r["scenes"].values() if s["action"] != "reused")
    click.echo(f"{G.plural(len(recs), 'figure')} in {G.defaults(smoke)[0] if out is None else out}; "
               f"{G.plural(swept, 'scene')} swept; {time.perf_counter() - t:.1f} s in all")


@main.command()
@click.argument("scene_path", metavar="SCENE.toml", type=click.Path(dir_okay=False))
@click.option("--set", "sets", multiple=True, metavar="KEY=VALUE",
              help="Override a scene key, as sweep does, e.g. --set sweep.kappa.num=101 or "
                   "--set 'sweep.kappa={values=[0.005]}' (repeatable; the value is TOML).")
@click.option("--toml", is_flag=True, help="Also print the scene as it would run (TOML, "
              "every default explicit, every axis value listed).")
def validate(scene_path, sets, toml):
    """Check a scene: a verdict, what it will do, and with --toml the scene as it would run."""
    scene = _load(scene_path, sets)
    click.echo(f"ok: {scene_path} is a valid scene")
    click.echo(f"# run.preset {scene.preset!r} -> transient {scene.transient}, tol {scene.tol!r}, "
               f"chatter {scene.chatter!r} (explicit [run] keys override the preset)")
    for line in _describe(scene, outputs.default_output(scene), _numba_threads()):
        click.echo(line)
    if toml:
        click.echo(scene.text)



@main.command()
@click.argument("models", nargs=-1, metavar="[MODEL ...]")
@click.option("--all", "all_models", is_flag=True, help="Every model (plug-ins included).")
@click.option("--jobs", type=click.IntRange(min=1), default=None,
              help="Groups compiled side by side, each in a process (default: the cores, at most "
                   "the groups).")
def warm(models, all_models, jobs):
    """Compile ahead of time what a first run compiles (default: the flow model; once per
    install, then cached), for those who prefer to pay once."""
    names = list(registry.models())
    if all_models and models:
        _fail("give model names or --all, not both")
    for m in models:
        if m not in names:
            _fail(f"warm: unknown model {m!r}{did_you_mean(m, names)} (models: {', '.join(names)})")
    chosen = list(names) if all_models else list(dict.fromkeys(models)) or [registry.DEFAULT_MODEL]
    todo = warmup.groups(chosen)
    for m in chosen:
        if not registry.get(m).warmups:
            click.echo(f"{m}: declares no warm-up scenes (Model.warmups): nothing compiled for it",
                       err=True)
    if not todo:
        return
    # the groups side by side: as many as asked, or the cores, never more than the groups
    n = max(1, min(len(todo), jobs or _numba_threads()))
    click.echo(f"warming {', '.join(todo)} ({n} at a time) ...", err=True)
    try:
        seconds = warmup.warm(chosen, n, lambda m: click.echo(m, err=True))
    except RuntimeError as e:
        _fail(str(e), EXIT_FAULT)
    click.echo(f"ready: {', '.join(todo)} in {seconds:.1f} s (numba's cache; later runs start "
               "without compiling)")

if __name__ == "__main__":
    main()
