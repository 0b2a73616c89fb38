"""Same output: every shipped scene writes the same HDF5 datasets, bit for bit, in two trees.

    python benchmarks/same_output.py OLD NEW [--continue] [--gallery] [--no-sweep]
                                     [--only NAME ...] [--keep DIR]
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
everything compared is equal, 1 otherwise (a difference, or a run that failed in a tree).

``--continue`` also runs ``cornerbif continue SCENE -o OUT.h5`` of every scene with a
``[continue]`` table (the shipped ``configs/cont_*.toml``) in both trees, after the sweeps
(same lane, same numba cache), and compares the files as above.  Their smoke size is the
gallery's: ``smoke_raw`` leaves a continuation scene as it is but for its title (its
``[initial]`` and ``[run]`` find the orbits; with 3 starts of 40 impacts
``cont_hysteresis`` found none), so no ``--set`` is given: once compiled each takes 1-5 s
here, the compile is the cost.  ``continue.over`` only says which sweep the gallery draws
under the branches (``continue`` never reads it); a scene with ``continue.seed_file`` is
reported NOT RUN and counted as a failure (no shipped scene has one).

``--gallery`` also runs ``cornerbif gallery --smoke --configs CONFIGS --out out --data data``
in both trees (NEW's configs folder for both; the relative ``out`` and ``data`` inside a
folder per tree, so that any path a figure or the record prints reads the same), and
compares every PNG of OLD's ``out`` byte for byte; where the bytes differ it decodes both
(Pillow, RGBA) and says whether the pixels are equal (then which PNG chunks differ: e.g.
the ``tEXt`` Software stamp of another matplotlib) or how many pixels differ.  A PNG equal
in pixels only counts as equal, and is listed.  The gallery's data files (``data/*.h5``:
the smoke sweeps and the continuations it drew) are compared as above, and its record
``gallery_run.json`` without its timings.  ``--no-sweep`` skips the sweeps (with
``--continue`` and/or ``--gallery``).  ``--only`` limits the sweeps and continuations, and
is handed on to the gallery (which also takes a figure's name, e.g. fig07b).

Measured 2026-11-27 (HEAD afb6a1f against the work tree, 2 cores, load about 1): ``--continue``
51 of 51 sweeps and 4 of 4 continuations equal in 375 s; ``--gallery`` 51 of 51 sweeps,
45 of 45 PNGs byte for byte, 51 of 51 gallery data files and the record equal in 314 s.
``--continue --gallery`` against a copy of the work tree with the restructuring of issue 29
in progress: all of them equal in 214 s; 7623f9a against 52ddaf5 (the house rebuilt: model
folders with their tangents and orbit problems, obstacle and figure kinds, run results keyed
by the models' fields): 51 of 51 sweeps, 4 of 4 continuations, 45 of 45 PNGs byte for byte,
51 of 51 gallery data files and the record equal in 168 s.
Against a copy with continuation.NEWTON_TOL 1e-10 (``--continue --no-sweep``) 3 of the 4
continuations differ (134 s); with the corner marker's colour changed in plot.py
(``--gallery --no-sweep``) the 3 PNGs that draw a corner collision differ (143 s).
benchmarks/README.md has the commands.

``--peak-memory`` instead runs one larger two_particle sweep (configs/fig19a.toml with the
``--mem-set`` overrides) in each tree, after a tiny warm-up that fills the numba cache, and
reports its peak RSS (``/usr/bin/time -v``, else ``getrusage(RUSAGE_CHILDREN)`` in a
wrapper), the peak RSS of the tiny warm-cached sweep (the baseline of imports and code) and
the "working memory: about X MiB" that ``cornerbif sweep --dry-run`` estimates for it.
"""

from __future__ import annotations

import argparse
import glob
import json
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
W = 21                                   # the scene column: the longest shipped name
SKIP_ROOT = {"created", "completed", "command"}
REF_ATTRS = {"DIMENSION_LIST", "REFERENCE_LIST"}
MEM_SETS = ["sweep.omega0.num=800", "initial.count=64"]
RECORD = "gallery_run.json"                                   # gallery.RECORD
RECORD_TIMES = {"seconds", "plot_seconds", "total_seconds"}  # the record's timings
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
        k = f'"{k}"' if "." in k else k        # a parameter by its path (linear): one key
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


def cont_sets(raw):
    """``--set`` overrides of a continuation (``cornerbif continue``) at smoke size: none, as
    gallery.smoke_raw leaves a scene with a ``[continue]`` table but its title (its
    ``[initial]`` and ``[run]`` find the orbits it continues; its range and steps are the
    continuation).  ``None`` when the scene needs ``continue.seed_file`` (not handled)."""
    return None if "seed_file" in raw["continue"] else []


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


# ------------------------------------------------------------------ the PNGs
def _chunks(data):
    """A PNG's chunks as (type, payload); ``None`` when ``data`` is no PNG."""
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    out, i = [], 8
    while i + 8 <= len(data):
        n = int.from_bytes(data[i:i + 4], "big")
        out.append((data[i + 4:i + 8].decode("latin-1"), data[i + 8:i + 8 + n]))
        i += 12 + n
    return out


def compare_png(old, new):
    """("bytes", None) when the two files are equal byte for byte; ("pixels", why) when only
    chunks outside the image differ and the decoded pixels are equal; (None, why) otherwise."""
    with open(old, "rb") as fo, open(new, "rb") as fn:
        a, b = fo.read(), fn.read()
    if a == b:
        return "bytes", None
    ca, cb = _chunks(a), _chunks(b)
    if ca is None or cb is None:
        return None, "not a PNG in " + ("OLD" if ca is None else "NEW")
    meta = sorted({t for t, _ in set(ca) ^ set(cb) if t != "IDAT"})
    from PIL import Image  # matplotlib writes its PNGs with Pillow

    with Image.open(old) as io_, Image.open(new) as in_:
        pa, pb = np.asarray(io_.convert("RGBA")), np.asarray(in_.convert("RGBA"))
    also = f"; chunks differing besides the image data: {', '.join(meta)}" if meta else ""
    if pa.shape != pb.shape:
        return None, f"size {pa.shape[1]} x {pa.shape[0]} -> {pb.shape[1]} x {pb.shape[0]}{also}"
    if not np.array_equal(pa, pb):
        ne = (pa != pb).any(axis=-1)
        return None, f"{int(ne.sum())} of {ne.size} pixels differ{also}"
    return "pixels", "bytes differ, decoded pixels equal (" + (
        f"chunks {', '.join(meta)}" if meta else "only the compressed image data") + " differ)"


def _record(path):
    """The gallery's record without its timings (the seconds each step took)."""
    def drop(o):
        if isinstance(o, dict):
            return {k: drop(v) for k, v in o.items() if k not in RECORD_TIMES}
        return [drop(v) for v in o] if isinstance(o, list) else o
    with open(path) as fh:
        return drop(json.load(fh))


# ------------------------------------------------------------------ the scenes
def run_lane(tree, cache, tasks, results):
    """Run every task (key, cornerbif arguments, working folder) in ``tree``, one after the
    other; results[key] = (rc, seconds, stderr)."""
    for key, args, cwd in tasks:
        t0 = time.perf_counter()
        p = cli(tree, cache, args, cwd=cwd)
        results[key] = (p.returncode, time.perf_counter() - t0, p.stderr.strip())


def _failed(res, key, label, sets=()):
    """The ERROR line of a task that failed in either tree (None when both ran)."""
    (rc_o, _, e_o), (rc_n, _, e_n) = res["old"][key], res["new"][key]
    if not (rc_o or rc_n):
        return None
    return (f"{label}  ERROR: exit {rc_o} (OLD) / {rc_n} (NEW)"
            + (f" with --set {' '.join(sets)}" if sets else "")
            + f"\n    OLD: {e_o[-600:]}\n    NEW: {e_n[-600:]}")


def _h5_row(res, key, name, old, new):
    """(bad, the line of one pair of files) for the table of sweeps or continuations."""
    row = f"{name:<{W}} {res['old'][key][1]:6.1f} {res['new'][key][1]:6.1f}"
    n, fails, added = compare(old, new)
    return bool(fails), (f"{row} {n:8d}  " + ("OK" if not fails else f"DIFF {fails[0]}" + (
        f" (+{len(fails) - 1} more)" if len(fails) > 1 else ""))
        + (f"; added: {', '.join(added)}" if added else ""))


def same_output(trees, tmp, keep, only, checks):
    """Run the ``checks`` (a subset of sweep, continue, gallery) in both trees and compare:
    {check: (differences and failures, a summary)}."""
    cfg = os.path.join(trees["new"], "configs")
    cfg = cfg if os.path.isdir(cfg) else os.path.join(ROOT, "configs")
    paths = {os.path.splitext(os.path.basename(p))[0]: p
             for p in sorted(glob.glob(os.path.join(cfg, "*.toml")))}
    unknown = [n for n in only if n not in paths and "gallery" not in checks]
    if unknown:
        sys.exit(f"--only: {', '.join(unknown)} not in {cfg}")
    raws = {}
    for name, p in paths.items():
        if not only or name in only:
            with open(p, "rb") as fh:
                raws[name] = tomllib.load(fh)
    sweeps = {n: smoke_sets(r) for n, r in raws.items()} if "sweep" in checks else {}
    conts = ({n: cont_sets(r) for n, r in raws.items() if isinstance(r.get("continue"), dict)}
             if "continue" in checks else {})
    print(f"{len(sweeps)} sweeps, {len(conts)} continuations"
          + (", the smoke gallery" if "gallery" in checks else "")
          + f" from {cfg}; OLD {trees['old']}, NEW {trees['new']}", flush=True)
    base = keep or tmp
    res, lanes, where = {}, [], {}
    for side in ("old", "new"):
        out = os.path.join(base, side)
        where[side] = {"sweep": out, "continue": os.path.join(out, "continue"),
                       "gallery": os.path.join(out, "gallery")}
        for d in where[side].values():
            os.makedirs(d, exist_ok=True)
        tasks = []
        for name, sets in sweeps.items():
            tasks.append((("sweep", name), ["sweep", paths[name], "-o",
                                            os.path.join(out, name + ".h5"), "--no-progress"]
                          + [a for s in sets for a in ("--set", s)], tmp))
        for name, sets in conts.items():
            if sets is None:
                continue
            tasks.append((("continue", name), ["continue", paths[name], "-o",
                                               os.path.join(where[side]["continue"], name + ".h5")]
                          + [a for s in sets for a in ("--set", s)], tmp))
        if "gallery" in checks:     # relative --out and --data: the same text in both trees
            tasks.append((("gallery", ""), ["gallery", "--smoke", "--configs", cfg, "--out", "out",
                                            "--data", "data"]
                          + [a for n in only for a in ("--only", n)], where[side]["gallery"]))
        res[side] = {}
        lanes.append(threading.Thread(target=run_lane, args=(
            trees[side], os.path.join(tmp, f"cache_{side}"), tasks, res[side])))
    for t in lanes:
        t.start()
    for t in lanes:
        t.join()
    summary = {}
    if sweeps:
        bad = 0
        print(f"\nsweeps\n{'scene':<{W}} {'old s':>6} {'new s':>6} {'datasets':>8}  result")
        for name, sets in sweeps.items():
            err = _failed(res, ("sweep", name), f"{name:<{W}}", sets)
            b = 1
            if err is None:
                b, err = _h5_row(res, ("sweep", name), name, *(
                    os.path.join(where[s]["sweep"], name + ".h5") for s in ("old", "new")))
            bad += bool(b)
            print(err)
        summary["sweep"] = (bad, f"{len(sweeps) - bad} of {len(sweeps)} sweeps equal")
    if conts:
        bad = 0
        print(f"\ncontinuations (cornerbif continue)\n{'scene':<{W}} {'old s':>6} {'new s':>6} "
              f"{'datasets':>8}  result")
        for name, sets in conts.items():
            if sets is None:
                bad += 1
                print(f"{name:<{W}} NOT RUN: continue.seed_file needs a sweep file this script "
                      "does not make (no shipped scene has one)")
                continue
            err = _failed(res, ("continue", name), f"{name:<{W}}", sets)
            b = 1
            if err is None:
                b, err = _h5_row(res, ("continue", name), name, *(
                    os.path.join(where[s]["continue"], name + ".h5") for s in ("old", "new")))
            bad += bool(b)
            print(err)
        summary["continue"] = (bad, f"{len(conts) - bad} of {len(conts)} continuations equal")
    if "gallery" in checks:
        summary["gallery"] = compare_gallery(res, where)
    return summary


def compare_gallery(res, where):
    """Compare the two smoke galleries: every PNG of OLD's out/ (bytes, else pixels), every
    file of its data/ (as the sweeps) and its record without timings; (differences and
    failures, a summary)."""
    key = ("gallery", "")
    t_o, t_n = res["old"][key][1], res["new"][key][1]
    print(f"\nsmoke gallery (cornerbif gallery --smoke): {t_o:.1f} s OLD, {t_n:.1f} s NEW")
    err = _failed(res, key, "gallery")
    if err:
        print(err)
        return 1, "the gallery failed"
    out = {s: os.path.join(where[s]["gallery"], "out") for s in ("old", "new")}
    data = {s: os.path.join(where[s]["gallery"], "data") for s in ("old", "new")}
    pngs = sorted(os.path.basename(p) for p in glob.glob(os.path.join(out["old"], "*.png")))
    added = sorted(set(os.path.basename(p) for p in glob.glob(os.path.join(out["new"], "*.png")))
                   - set(pngs))
    bad, by_bytes, by_pixels = 0, 0, 0
    for png in pngs:
        if not os.path.exists(os.path.join(out["new"], png)):
            bad += 1
            print(f"  {png}: missing in NEW")
            continue
        how, why = compare_png(*(os.path.join(out[s], png) for s in ("old", "new")))
        by_bytes += how == "bytes"
        by_pixels += how == "pixels"
        bad += how is None
        if how != "bytes":
            print(f"  {png}: " + ("pixels equal, " if how else "DIFF ") + why)
    print(f"PNG: {len(pngs)} compared, {by_bytes} equal byte for byte, {by_pixels} equal in "
          f"pixels only, {len(pngs) - by_bytes - by_pixels} differ"
          + (f"; added in NEW: {', '.join(added)}" if added else ""))
    h5s = sorted(os.path.basename(p) for p in glob.glob(os.path.join(data["old"], "*.h5")))
    h5_bad = 0
    for h5 in h5s:
        if not os.path.exists(os.path.join(data["new"], h5)):
            h5_bad += 1
            print(f"  data/{h5}: missing in NEW")
            continue
        n, fails, _ = compare(*(os.path.join(data[s], h5) for s in ("old", "new")))
        if fails:
            h5_bad += 1
            print(f"  data/{h5}: DIFF {fails[0]}" + (f" (+{len(fails) - 1} more)"
                                                      if len(fails) > 1 else ""))
    print(f"data: {len(h5s)} files compared, {len(h5s) - h5_bad} equal")
    rec = [os.path.join(out[s], RECORD) for s in ("old", "new")]
    rec_bad = 0
    if all(os.path.exists(r) for r in rec):
        rec_bad = int(_record(rec[0]) != _record(rec[1]))
        print(f"{RECORD} without its timings: {'equal' if not rec_bad else 'DIFFERS'}")
    return bad + h5_bad + rec_bad, (
        f"{by_bytes + by_pixels} of {len(pngs)} gallery PNGs equal ({by_bytes} byte for byte), "
        f"{len(h5s) - h5_bad} of {len(h5s)} of its data files, its record "
        + ("equal" if not rec_bad else "differs"))


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
    ap.add_argument("--only", nargs="+", action="extend", default=[], metavar="NAME",
                    help="only these scenes (with --gallery also a figure name, e.g. fig07b)")
    ap.add_argument("--continue", dest="cont", action="store_true",
                    help="also run `cornerbif continue` of every scene with a [continue] table "
                         "(configs/cont_*.toml) and compare its files")
    ap.add_argument("--gallery", action="store_true",
                    help="also run `cornerbif gallery --smoke` and compare every PNG (bytes, "
                         "else pixels), its data files and its record")
    ap.add_argument("--no-sweep", action="store_true",
                    help="skip the sweeps (with --continue and/or --gallery)")
    ap.add_argument("--keep", metavar="DIR", help="write the outputs to DIR/old, DIR/new "
                    "(sweeps there, continuations in continue/, the gallery in gallery/)")
    ap.add_argument("--peak-memory", action="store_true",
                    help="measure the peak RSS of one larger fig19a sweep in each tree instead")
    ap.add_argument("--mem-set", action="append", metavar="KEY=VALUE",
                    help=f"overrides of the --peak-memory sweep (default: {' '.join(MEM_SETS)})")
    a = ap.parse_args(argv)
    if a.new is None and not a.peak_memory:
        ap.error("NEW is needed (only --peak-memory may measure one tree)")
    checks = ({"sweep"} - ({"sweep"} if a.no_sweep else set())
              | ({"continue"} if a.cont else set()) | ({"gallery"} if a.gallery else set()))
    if not checks:
        ap.error("--no-sweep leaves nothing to compare: add --continue and/or --gallery")
    keep = a.keep and os.path.abspath(a.keep)
    if keep and any(os.path.isdir(d) and os.listdir(d)
                    for d in (os.path.join(keep, "old"), os.path.join(keep, "new"))):
        ap.error(f"--keep {a.keep}: old/ or new/ there is not empty (an earlier run's files "
                 "would be refused, or reused by the gallery): name another folder")
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory(prefix="same_output_") as tmp:
        trees = {"old": _tree(a.old, tmp, "tree_old")}
        if a.new is not None:
            trees["new"] = _tree(a.new, tmp, "tree_new")
        if a.peak_memory:
            peak_memory(trees, tmp, a.mem_set or MEM_SETS)
            print(f"total {time.perf_counter() - t0:.0f} s")
            return 0
        summary = same_output(trees, tmp, keep, a.only, checks)
    bad = sum(b for b, _ in summary.values())
    print("\n" + "; ".join(t for _, t in summary.values()) + f"; {bad} differences or "
          f"failures; total {time.perf_counter() - t0:.0f} s")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
