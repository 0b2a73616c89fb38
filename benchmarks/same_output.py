"""Same output: every shipped scene writes the same HDF5 datasets, bit for bit, in two trees.

    python benchmarks/same_output.py OLD NEW [--only NAME ...] [--keep DIR]
    python benchmarks/same_output.py OLD [NEW] --peak-memory [--mem-set KEY=VALUE ...]

OLD and NEW are each a git commit (exported with ``git archive`` to a temporary folder, as
benchmarks/ab.py does) or a directory (e.g. /work/main: the work tree with its uncommitted
changes).  Every ``configs/*.toml`` of NEW (of this repository when NEW is a commit whose
export has none) runs at smoke size in both trees, each through its own CLI in a subprocess
(``python -c "...; from cornerbif.cli import main; main()" sweep SCENE -o OUT.h5 --no-progress
--set ...``) with the tree first on ``sys.path`` (checked), its own fresh NUMBA_CACHE_DIR
(numba's cache can hold stale machine code) and NUMBA_NUM_THREADS=2.  Both trees run the same
scene file.  The two trees run side by side, each its scenes one after the other.

Smoke size is ``cornerbif/gallery.py``'s ``smoke_raw`` (at most 3 values per start/stop/num
axis, the first 2 of a ``values`` axis, at most 3 starts, at most 40 + 40 impacts, plot.ic
kept to the starts that remain) written as ``--set`` overrides computed here from the TOML
(the gallery module is not imported: it may change).  ``min`` keeps run.transient = 0 of the
return_map scenes; run.stop, sweep.follow, output.keep etc. stay as the scene has them.

The files are equal when every dataset and group of OLD is in NEW with the same shape, dtype,
bytes (and, for floats, ``array_equal(equal_nan=True)``), attributes and dimension scales
(per axis its label and the NAME and values of each attached scale, wherever in the file the
scale lives: group-local copies count as the same scale; the reference attributes
DIMENSION_LIST / REFERENCE_LIST are compared through them).  Root attributes are compared
except created, completed, command and the ``*_version`` ones that record software
versions (``format_version`` is compared); ``scene`` (the TOML as run) and ``scene_hash``
are compared.  What only NEW has is reported as "added" and allowed.  Exit code 0 when
every scene is equal, 1 otherwise.

``--peak-memory`` instead runs one larger two_particle sweep (configs/fig19a.toml with the
``--mem-set`` overrides) in each tree, after a tiny warm-up that fills the numba cache, and
reports its peak RSS (``/usr/bin/time -v``, else ``getrusage(RUSAGE_CHILDREN)`` in a
wrapper), the peak RSS of the tiny warm-cached sweep (the baseline of imports and code) and
the "working memory: about X MiB" that ``cornerbif sweep --dry-run`` estimates for it.
"""

from __future__ import annotations

import argparse
import glob
import os
import re
import subprocess
import sys
import tempfile
import threading
import time
import tomllib

import h5py
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
CLI = ("import sys; sys.path.insert(0, {tree!r}); import cornerbif; "
       "assert cornerbif.__file__.startswith({tree!r} + '/'), cornerbif.__file__; "
       "from cornerbif.cli import main; main()")
SMOKE = {"axis_num": 3, "axis_values": 2, "count": 3, "transient": 40, "record": 40}
DEFAULTS = {"count": 8, "transient": 500, "record": 100}      # config.RUN_DEFAULTS, initial
SKIP_ROOT = {"created", "completed", "command"}
REF_ATTRS = {"DIMENSION_LIST", "REFERENCE_LIST"}
MEM_SETS = ["sweep.omega0.num=800", "initial.count=64"]
TINY_SETS = ["sweep.omega0.num=2", "initial.count=2", "run.transient=10", "run.record=10"]


def _tree(spec, tmp, tag):
    """A directory holding the tree ``spec`` (a directory, or a commit exported to tmp/tag)."""
    if os.path.isdir(spec):
        return os.path.abspath(spec)
    out = os.path.join(tmp, tag)
    os.makedirs(out)
    arch = subprocess.run(["git", "-C", ROOT, "archive", spec], check=True, capture_output=True)
    subprocess.run(["tar", "-x", "-C", out], input=arch.stdout, check=True)
    return out


def _toml(v):
    if isinstance(v, list):
        return "[" + ", ".join(_toml(x) for x in v) + "]"
    if isinstance(v, float) and not np.isfinite(v):
        return "nan" if v != v else ("inf" if v > 0 else "-inf")
    return repr(v) if not isinstance(v, str) else '"' + v + '"'


def smoke_sets(raw):
    """``--set`` overrides that shrink a scene as gallery.smoke_raw does."""
    sets = []
    shape = []
    for k, spec in raw.get("sweep", {}).items():
        if k == "follow" or not isinstance(spec, dict):
            continue
        if "num" in spec:
            shape.append(min(spec["num"], SMOKE["axis_num"]))
            sets.append(f"sweep.{k}.num={shape[-1]}")
        if "values" in spec:
            vals = spec["values"][:SMOKE["axis_values"]]
            shape.append(len(vals))
            sets.append(f"sweep.{k}.values={_toml(vals)}")
    count = min(raw.get("initial", {}).get("count", DEFAULTS["count"]), SMOKE["count"])
    sets.append(f"initial.count={count}")
    run = raw.get("run", {})
    for k in ("transient", "record"):      # min: transient = 0 (return_map) stays 0
        sets.append(f"run.{k}={min(run.get(k, DEFAULTS[k]), SMOKE[k])}")
    # smoke_raw drops run.max_events / max_periods; --set cannot remove a key (none is shipped)
    pl = raw.get("plot", {})
    if isinstance(pl.get("ic"), list):
        sets.append(f"plot.ic={_toml([i for i in pl['ic'] if i < count] or [0])}")
    if isinstance(pl.get("point"), list):  # smoke_raw drops it; keep it inside the small grid
        sets.append(f"plot.point={_toml([min(i, n - 1) for i, n in zip(pl['point'], shape)])}")
    return sets


def cli(tree, cache, args, wrap=(), cwd=None):
    """Run ``cornerbif ARGS`` of ``tree`` with the numba cache folder ``cache``."""
    cmd = list(wrap) + [sys.executable, "-c", CLI.format(tree=tree)] + list(args)
    env = dict(os.environ, NUMBA_CACHE_DIR=cache, NUMBA_NUM_THREADS="2", MPLBACKEND="Agg")
    return subprocess.run(cmd, capture_output=True, text=True, env=env, cwd=cwd)


# ------------------------------------------------------------------ comparison
def _same(a, b):
    """Bitwise equality of two attribute values (arrays, scalars, strings)."""
    a, b = np.asarray(a), np.asarray(b)
    if a.dtype != b.dtype or a.shape != b.shape:
        return False
    if a.dtype.kind == "O":
        return a.tolist() == b.tolist()
    return a.tobytes() == b.tobytes()


def _how(a, b):
    """How two arrays of one shape and dtype differ."""
    if a.dtype.kind in "fc":
        both_nan = np.isnan(a) & np.isnan(b)
        ne = ~((a == b) | both_nan)
        bits = a.view(np.uint8).reshape(a.shape + (-1,)) != b.view(np.uint8).reshape(b.shape + (-1,))
        nbits = int((bits.any(axis=-1) & ~ne).sum())
        fin = ne & np.isfinite(a) & np.isfinite(b)
        mx = f"{np.abs(a[fin] - b[fin]).max():.3g}" if fin.any() else "-"
        return (f"{int(ne.sum())} of {a.size} elements differ (max abs diff {mx}; NaN in one "
                f"only: {int((np.isnan(a) ^ np.isnan(b)).sum())}; equal but other bits: {nbits})")
    if a.dtype.kind in "iub":
        ne = a != b
        mx = int(np.abs(a[ne].astype(np.int64) - b[ne].astype(np.int64)).max()) if ne.any() else 0
        return f"{int(ne.sum())} of {a.size} elements differ (max abs diff {mx})"
    ne = np.asarray(a != b)
    return f"{int(ne.sum())} of {a.size} elements differ (first at {np.argwhere(ne)[0].tolist()})"


def _attrs(o, n, where, skip=()):
    fails, added = [], []
    for k in o.attrs:
        if k in skip or k in REF_ATTRS or (where == "/" and k.endswith("_version")
                                           and k != "format_version"):
            continue
        if k not in n.attrs:
            fails.append(f"{where} attribute {k!r} missing in NEW")
        elif not _same(o.attrs[k], n.attrs[k]):
            a, b = o.attrs[k], n.attrs[k]
            if isinstance(a, str) and isinstance(b, str):    # e.g. the scene: first other line
                a, b = next(((x, y) for x, y in zip(a.splitlines() + [""], b.splitlines() + [""])
                             if x != y), (a, b))
            fails.append(f"{where} attribute {k!r} differs: {a!r:.80} -> {b!r:.80}")
    added += [f"{where}@{k}" for k in n.attrs if k not in o.attrs]
    return fails, added


def _scale(s):
    """A dimension scale as what it says: its NAME and its values (not its path: the file
    keeps each group's own copy of the scales since the registry release)."""
    name = s.attrs.get("NAME", b"")
    return (name.decode() if isinstance(name, bytes) else str(name), s[()].tobytes())


def compare(old, new):
    """(datasets compared, failures, added) for two cornerbif files."""
    with h5py.File(old, "r") as fo, h5py.File(new, "r") as fn:
        fails, added = _attrs(fo, fn, "/", SKIP_ROOT)
        objs = {}
        fo.visititems(lambda name, obj: objs.update({name: obj}))   # None: visit them all
        n_ds = 0
        for name, o in objs.items():
            if name not in fn:
                fails.append(f"{name}: missing in NEW")
                continue
            n = fn[name]
            f, a = _attrs(o, n, name)
            fails += f
            added += a
            if isinstance(o, h5py.Group):
                continue
            n_ds += 1
            if not isinstance(n, h5py.Dataset) or (o.shape, o.dtype) != (n.shape, n.dtype):
                fails.append(f"{name}: shape/dtype {o.shape} {o.dtype} -> "
                             f"{getattr(n, 'shape', 'group')} {getattr(n, 'dtype', '')}")
                continue
            dims_o = [(d.label, [_scale(s) for s in d.values()]) for d in o.dims]
            dims_n = [(d.label, [_scale(s) for s in d.values()]) for d in n.dims]
            if dims_o != dims_n:
                fails.append(f"{name}: dimension scales {dims_o} -> {dims_n}")
            a_, b_ = o[()], n[()]
            if not _same(a_, b_) or (a_.dtype.kind in "fc"
                                     and not np.array_equal(a_, b_, equal_nan=True)):
                fails.append(f"{name}: data: {_how(np.asarray(a_), np.asarray(b_))}")
        new_names = []
        fn.visit(new_names.append)
        added += [f"{x} (new {'dataset' if isinstance(fn[x], h5py.Dataset) else 'group'})"
                  for x in new_names if x not in objs]
    return n_ds, fails, added


# ------------------------------------------------------------------ the scenes
def run_lane(tree, cache, scenes, outdir, work, results):
    """Run every scene in ``tree``, one after the other; results[name] = (rc, seconds, err)."""
    for name, (path, sets) in scenes.items():
        args = ["sweep", path, "-o", os.path.join(outdir, name + ".h5"), "--no-progress"]
        for s in sets:
            args += ["--set", s]
        t0 = time.perf_counter()
        p = cli(tree, cache, args, cwd=work)
        results[name] = (p.returncode, time.perf_counter() - t0, p.stderr.strip())


def same_output(trees, tmp, keep, only):
    cfg = os.path.join(trees["new"], "configs")
    cfg = cfg if os.path.isdir(cfg) else os.path.join(ROOT, "configs")
    paths = {os.path.splitext(os.path.basename(p))[0]: p
             for p in sorted(glob.glob(os.path.join(cfg, "*.toml")))}
    unknown = [n for n in only if n not in paths]
    if unknown:
        sys.exit(f"--only: {', '.join(unknown)} not in {cfg}")
    scenes = {}
    for name, p in paths.items():
        if not only or name in only:
            with open(p, "rb") as fh:
                scenes[name] = (p, smoke_sets(tomllib.load(fh)))
    print(f"{len(scenes)} scenes from {cfg}; OLD {trees['old']}, NEW {trees['new']}", flush=True)
    base = keep or tmp
    res = {}
    lanes = []
    for side in ("old", "new"):
        out = os.path.join(base, side)
        os.makedirs(out, exist_ok=True)
        res[side] = {}
        lanes.append(threading.Thread(target=run_lane, args=(
            trees[side], os.path.join(tmp, f"cache_{side}"), scenes, out,
            tmp, res[side])))
    for t in lanes:
        t.start()
    for t in lanes:
        t.join()
    bad = 0
    print(f"{'scene':<14} {'old s':>6} {'new s':>6} {'datasets':>8}  result")
    for name, (_, sets) in scenes.items():
        (rc_o, t_o, e_o), (rc_n, t_n, e_n) = res["old"][name], res["new"][name]
        row = f"{name:<14} {t_o:6.1f} {t_n:6.1f}"
        if rc_o or rc_n:
            bad += 1
            print(f"{row} {'-':>8}  ERROR: exit {rc_o} (OLD) / {rc_n} (NEW) with --set "
                  f"{' '.join(sets)}\n    OLD: {e_o[-600:]}\n    NEW: {e_n[-600:]}")
            continue
        n, fails, added = compare(*(os.path.join(base, s, name + ".h5") for s in ("old", "new")))
        bad += bool(fails)
        print(f"{row} {n:8d}  " + ("OK" if not fails else f"DIFF {fails[0]}"
                                   + (f" (+{len(fails) - 1} more)" if len(fails) > 1 else ""))
              + (f"; added: {', '.join(added)}" if added else ""))
    return bad, len(scenes)


# ------------------------------------------------------------------ peak memory
def _peak_rss(tree, cache, args, work):
    """(CompletedProcess, peak RSS in MiB) of ``cornerbif ARGS``."""
    rep = os.path.join(work, "rss.txt")
    wrap = (["/usr/bin/time", "-v", "-o", rep] if os.access("/usr/bin/time", os.X_OK) else
            [sys.executable, "-c", "import resource as R, subprocess, sys; c = subprocess.run("
             "sys.argv[2:]).returncode; open(sys.argv[1], 'w').write('Maximum resident set size "
             "(kbytes): %d' % R.getrusage(R.RUSAGE_CHILDREN).ru_maxrss); sys.exit(c)", rep])
    p = cli(tree, cache, args, wrap=wrap, cwd=work)
    if p.returncode:
        sys.exit(f"{' '.join(args)} failed in {tree}:\n{p.stderr}")
    with open(rep) as fh:
        kb = re.search(r"Maximum resident set size \(kbytes\): (\d+)", fh.read())
    return p, int(kb.group(1)) / 1024


def peak_memory(trees, tmp, mem_sets):
    scene = os.path.join(list(trees.values())[-1], "configs", "fig19a.toml")
    scene = scene if os.path.exists(scene) else os.path.join(ROOT, "configs", "fig19a.toml")
    big = [a for s in mem_sets for a in ("--set", s)]
    tiny = [a for s in TINY_SETS for a in ("--set", s)]
    print(f"fig19a with --set {' '.join(mem_sets)}; baseline: --set {' '.join(TINY_SETS)}")
    for side, tree in trees.items():
        cache = os.path.join(tmp, f"mem_cache_{side}")
        out = os.path.join(tmp, f"mem_{side}.h5")
        dry = cli(tree, cache, ["sweep", scene, "-o", out, "--dry-run"] + big, cwd=tmp)
        est = re.search(r"working memory: about ([\d.]+) MiB", dry.stdout)
        run = re.search(r"-> (\d+) runs of (\d+) impacts", dry.stdout)
        sweep = ["sweep", scene, "-o", out, "--no-progress", "--overwrite"]
        _peak_rss(tree, cache, sweep + tiny, tmp)                 # compile into the cache
        _, base = _peak_rss(tree, cache, sweep + tiny, tmp)       # warm: imports + code
        t0 = time.perf_counter()
        _, peak = _peak_rss(tree, cache, sweep + big, tmp)
        wall = time.perf_counter() - t0
        print(f"{side.upper()} {tree}: {run.group(1) if run else '?'} runs of "
              f"{run.group(2) if run else '?'} impacts in {wall:.1f} s; peak RSS {peak:.1f} MiB "
              f"(tiny sweep {base:.1f} MiB, difference {peak - base:.1f} MiB); dry-run "
              f"estimate {est.group(1) if est else '?'} MiB", flush=True)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("old", help="git commit or directory")
    ap.add_argument("new", nargs="?", help="git commit or directory (--peak-memory: optional)")
    ap.add_argument("--only", nargs="+", action="extend", default=[], metavar="NAME")
    ap.add_argument("--keep", metavar="DIR", help="write the h5 files to DIR/old, DIR/new")
    ap.add_argument("--peak-memory", action="store_true",
                    help="measure the peak RSS of one larger fig19a sweep in each tree instead")
    ap.add_argument("--mem-set", action="append", metavar="KEY=VALUE",
                    help=f"overrides of the --peak-memory sweep (default: {' '.join(MEM_SETS)})")
    a = ap.parse_args(argv)
    if a.new is None and not a.peak_memory:
        ap.error("NEW is needed (only --peak-memory may measure one tree)")
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="same_output_") as tmp:
        trees = {"old": _tree(a.old, tmp, "tree_old")}
        if a.new is not None:
            trees["new"] = _tree(a.new, tmp, "tree_new")
        if a.peak_memory:
            peak_memory(trees, tmp, a.mem_set or MEM_SETS)
            print(f"total {time.perf_counter() - t0:.0f} s")
            return 0
        bad, n = same_output(trees, tmp, a.keep and os.path.abspath(a.keep), a.only)
    print(f"{n - bad} of {n} scenes equal, {bad} not; total {time.perf_counter() - t0:.0f} s")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
