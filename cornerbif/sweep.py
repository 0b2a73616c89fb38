"""Grid x initial conditions -> blocks -> parallel kernels -> HDF5 (DESIGN 4, 6).

Data flow is one way: scene -> blocks of grid points -> ``run_batch`` (flow
kernel) -> ``detect_cycles`` (analysis) -> ``io.write_block``.  Blocks are
sized so memory stays flat whatever the grid size; each block is marked done
in the file once its data are flushed, so an interrupted sweep resumes where
it stopped.  Initial conditions are drawn outside the kernels from a
counter-based generator keyed by (seed, grid point, initial condition), so
they do not depend on block size, thread count or resume history.
"""

from __future__ import annotations

import fcntl
import math
import os
import sys
import time

import numpy as np

from . import io
from . import status as S
from .analysis import detect_cycles
from .config import Scene, SceneError
from .models import params as P

BLOCK_BYTES = 48 * 2**20     # working memory per block (kernel outputs)
# run.stop = "period": the kernel stops once the state at the corners repeats to this share of
# run.period_tol (relative), tighter than the analysis so that the orbit has converged well
# beyond what the period test reads (see kernels.flow.cycle_watch)
STOP_TOL_FACTOR = 1e-3
ITEM_FIELDS = 7              # t, u, v_in, v_out, offset, section u, v (+ corner index)


class SweepError(Exception):
    """A sweep that cannot start or continue; the message says what to do."""


class SweepInterrupted(SweepError):
    """The sweep was interrupted; finished points are kept in the partial file."""


# ------------------------------------------------------------------ initial conditions
def _splitmix64(x):
    x = (x + np.uint64(0x9E3779B97F4A7C15)) & np.uint64(0xFFFFFFFFFFFFFFFF)
    z = x
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def uniform(seed, point, ic, coord):
    """Counter-based uniform numbers in [0, 1) keyed by (seed, point, ic, coord)."""
    with np.errstate(over="ignore"):
        key = (np.asarray(point, np.uint64) * np.uint64(1 << 20) + np.asarray(ic, np.uint64)) \
            * np.uint64(4) + np.uint64(coord)
        z = _splitmix64(_splitmix64(np.uint64(seed) ^ np.uint64(0xC0FFEE)) ^ key)
        z = _splitmix64(z)
    return (z >> np.uint64(11)).astype(np.float64) * (1.0 / 9007199254740992.0)


def draw_initial(scene: Scene, flat_points: np.ndarray, z0: np.ndarray):
    """Initial state at t = 0 for grid points ``flat_points`` (shape (n,)).

    ``flow`` and ``map2d``: (n, n_ic, 2) = (u, v); u is uniform on the part of
    ``initial.u`` strictly above the obstacle z(0) = ``z0`` (the same law as drawing
    on the whole range and redrawing points below).  ``two_particle``:
    (n, n_ic, 4) = (z, y, u, v) with w(0) < z <= u: z above the wall ``z0``, u above z.
    """
    n = flat_points.shape[0]
    pts = np.repeat(flat_points.astype(np.uint64), scene.n_ic)
    ics = np.tile(np.arange(scene.n_ic, dtype=np.uint64), n)

    def draw(coord, rng, floor=None):
        x = uniform(scene.seed, pts, ics, coord).reshape(n, scene.n_ic)
        lo, hi = rng
        if floor is None:
            return lo + (hi - lo) * x
        lo = np.maximum(lo, floor)
        return hi - (hi - lo) * x          # in (floor, hi]

    if scene.model == "two_particle":
        z = draw(2, scene.z_range, z0[:, None])
        y = draw(3, scene.y_range)
        u = draw(0, scene.u_range, z)
        v = draw(1, scene.v_range)
        return np.stack([z, y, u, v], axis=-1)
    u = draw(0, scene.u_range, z0[:, None])
    v = draw(1, scene.v_range)
    return np.stack([u, v], axis=-1)


# ------------------------------------------------------------------ packing
def pack_points(scene: Scene, index_list):
    """Packed parameter rows for a list of grid indices.

    ``flow``: the kernel's parameter vector (``models.params``); ``map2d``: rows
    [omega1, kappa1, r] with epsilon = 1 (omega1 = omega - 2, kappa1 = kappa).
    """
    if scene.model == "map2d":
        vals = [scene.point(idx) for idx in index_list]
        return np.array([[v["omega"] - 2.0, v["kappa"], v["r"]] for v in vals],
                        dtype=float).reshape(len(index_list), 3)
    if scene.model == "two_particle":
        from .models import two_particle as TP
        rows = [TP.pack(scene.point(idx), scene.tol, scene.chatter, scene.escape,
                        scene.section_period) for idx in index_list]
        return np.array(rows).reshape(len(index_list), TP.NPARAM)
    rows = []
    stop_tol = STOP_TOL_FACTOR * scene.period_tol if scene.stop == "period" else 0.0
    for idx in index_list:
        vals = scene.point(idx)
        rows.append(P.pack(vals, scene.obstacle, scene.tol, scene.chatter, scene.escape,
                           scene.section_period, stop_tol))
    return np.array(rows).reshape(len(index_list), P.NPARAM)


def int_settings(scene: Scene) -> np.ndarray:
    if scene.model == "two_particle":
        from .models import two_particle as TP
        ints = np.zeros(TP.NINT, np.int64)
        ints[TP.I_TRANSIENT] = scene.transient
        ints[TP.I_RECORD] = scene.record
        ints[TP.I_MAX_EVENTS] = scene.max_events
        ints[TP.I_MAX_PERIODS] = scene.max_periods
        return ints
    ints = np.zeros(P.NINT, np.int64)
    ints[P.I_TRANSIENT] = scene.transient
    ints[P.I_RECORD] = scene.record
    ints[P.I_MAX_EVENTS] = scene.max_events
    per_pieces = 4  # at most 4 pieces per obstacle period (triangle, sine: 2)
    ints[P.I_MAX_PIECES] = scene.max_periods * per_pieces
    return ints


def run_map_items(params: np.ndarray, ics: np.ndarray, scene: Scene):
    """Iterate the local maps (56) on n items; outputs shaped like ``run_items``'.

    The iterates x_n = (a_n, b_n) go to the section slots (su, sv), as the flow's
    section values (u, v)(nT); a run is OK unless an iterate is not finite.
    """
    from .maps2d import detect_map_cycles, iterate_batch
    n = params.shape[0]
    rec = scene.record
    a = np.empty((n, rec))
    b = np.empty((n, rec))
    reg = np.empty((n, rec), np.int8)
    iterate_batch(np.ascontiguousarray(params), np.ascontiguousarray(ics), scene.transient, rec,
                  a, b, reg)
    period = np.zeros(n, np.int64)
    sym = np.zeros((n, max(1, rec // 2)), np.uint8)
    detect_map_cycles(reg, a, b, scene.period_tol, period, sym)
    ipc = ((sym == ord("a")) * 2 + (sym == ord("b")) + (sym == ord("g"))).sum(axis=1)
    ok = np.isfinite(b).all(axis=1) & np.isfinite(a).all(axis=1)
    st = np.where(ok, S.OK, S.NONFINITE).astype(np.int8)
    nan = np.full((n, rec), np.nan)
    out = {"t": nan, "u": nan, "v_in": nan, "v_out": nan, "corner_offset": nan, "su": a, "sv": b}
    final = np.stack([a[:, -1], b[:, -1]], axis=1)
    sym_full = np.zeros((n, rec), np.uint8)
    sym_full[:, :sym.shape[1]] = sym
    return out, st, final, period, ipc, sym_full


def run_two_particle_items(params: np.ndarray, ics: np.ndarray, ints: np.ndarray, scene: Scene):
    """The two-particle kernel (section 6) on n items; outputs shaped like ``run_items``'.

    ``t, u, v_in, v_out, corner_offset`` are the u-z impacts (offset to the nearest
    w-z impact, this system's corner); ``su, sv, sz, sy`` the sections; ``wz_*``
    the w-z impacts; ``final`` is (n, 4) = (z, y, u, v).
    """
    from .kernels import two_particle as K
    n = params.shape[0]
    rec = scene.record
    cap = 4 * rec + 8
    o_zu = np.full((n, rec, K.NZU), np.nan)
    corner = np.full((n, rec), -1, np.int64)
    o_wz = np.full((n, cap, K.NWZ), np.nan)
    o_sec = np.full((n, rec, K.NSEC), np.nan)
    st = np.zeros(n, np.int8)
    final = np.full((n, 4), np.nan)
    K.run_batch(np.ascontiguousarray(params), ints, np.ascontiguousarray(ics), o_zu, corner, o_wz,
                o_sec, st, final)
    out = {"t": np.ascontiguousarray(o_zu[:, :, K.ZU_T]), "u": o_zu[:, :, K.ZU_U].copy(),
           "v_in": np.ascontiguousarray(o_zu[:, :, K.ZU_VIN]), "v_out": o_zu[:, :, K.ZU_VOUT].copy(),
           "corner_offset": np.ascontiguousarray(o_zu[:, :, K.ZU_OFF]),
           "su": o_sec[:, :, K.SEC_U].copy(), "sv": o_sec[:, :, K.SEC_V].copy(),
           "sz": o_sec[:, :, K.SEC_Z].copy(), "sy": o_sec[:, :, K.SEC_Y].copy(),
           "wz_t": o_wz[:, :rec, K.WZ_T].copy(), "wz_z": o_wz[:, :rec, K.WZ_Z].copy(),
           "wz_y_in": o_wz[:, :rec, K.WZ_YIN].copy(), "wz_y_out": o_wz[:, :rec, K.WZ_YOUT].copy()}
    period = np.zeros(n, np.int64)
    ipc = np.zeros(n, np.int64)
    sym = np.zeros((n, rec), np.uint8)
    t = np.where(np.isnan(out["corner_offset"]), np.nan, out["t"])
    detect_cycles(t, out["v_in"], out["corner_offset"], corner, np.ones(n, np.bool_),
                  scene.period_tol, period, ipc, sym)
    return out, st, final, period, ipc, sym


def _run_flow(params, ics, ints, scene, fill, cornered):
    """The flow kernel and the cycle analysis on n items; outputs not in ``fill`` start
    unfilled.  Returns (out, status, final, period, impacts per cycle, symbols, first
    recorded impact)."""
    from .kernels.flow import run_batch
    n = params.shape[0]
    rec = scene.record
    out = {k: np.full((n, rec), np.nan) if k in fill else np.empty((n, rec))
           for k in ("t", "u", "v_in", "v_out", "corner_offset", "su", "sv")}
    corner = np.empty((n, rec), np.int64)
    st = np.zeros(n, np.int8)
    final = np.zeros((n, 2))
    rec0 = np.zeros(n, np.int64)
    run_batch(params, ints, ics, out["t"], out["u"], out["v_in"], out["v_out"],
              out["corner_offset"], corner, out["su"], out["sv"], st, final, rec0)
    period = np.zeros(n, np.int64)
    ipc = np.zeros(n, np.int64)
    sym = np.zeros((n, rec), np.uint8)
    detect_cycles(out["t"], out["v_in"], out["corner_offset"], corner, cornered,
                  scene.period_tol, period, ipc, sym)
    return out, st, final, period, ipc, sym, rec0


def kernel_cache_cold(scene: Scene) -> bool:
    """Whether the scene's kernel has nothing in numba's on-disk cache yet: its first call
    then compiles (``cornerbif sweep`` says so before it starts)."""
    from ._jit import cache_is_cold
    if scene.model == "map2d":
        from .maps2d import iterate_batch as kernel
    elif scene.model == "two_particle":
        from .kernels.two_particle import run_batch as kernel
    else:
        from .kernels.flow import run_batch as kernel
    return cache_is_cold(kernel)


def run_items(params: np.ndarray, ics: np.ndarray, ints: np.ndarray, scene: Scene):
    """Run the model's kernel and the cycle analysis on n items (rows of params/ics)."""
    if scene.model == "map2d":
        return run_map_items(params, ics, scene)
    if scene.model == "two_particle":
        return run_two_particle_items(params, ics, ints, scene)
    # NaN marks "no impact" in what is stored and in t, where the analysis reads the end of
    # the recorded window; what is neither is left unfilled (a summary-only chart then
    # touches only the few rows' entries its early-stopped runs write)
    stored = {"impacts": ("u", "v_in", "v_out", "corner_offset"), "section": ("su", "sv")}
    fill = {"t"} | {k for x in scene.keep for k in stored.get(x, ())}
    cornered = params[:, P.OBSTACLE] != P.SINE
    res = _run_flow(params, ics, ints, scene, fill, cornered)
    out, st, final, period, ipc, sym, rec0 = res
    # early stop: a run stopped on a cycle the analysis does not confirm (e.g. a near-grazing
    # impact magnifies the last 1e-9 of the transient beyond period_tol) runs again without it
    redo = np.flatnonzero((rec0 < ints[P.I_TRANSIENT]) & (period == 0))
    if redo.size:
        prm = np.ascontiguousarray(params[redo])
        prm[:, P.STOP_TOL] = 0.0
        again = _run_flow(prm, np.ascontiguousarray(ics[redo]), ints, scene, set(out),
                          cornered[redo])
        for k in out:
            out[k][redo] = again[0][k]
        for whole, part in zip(res[1:], again[1:]):
            whole[redo] = part
    if not cornered.all():
        out["corner_offset"][~cornered] = np.nan
    return out, st, final, period, ipc, sym


def _symbol_bytes(sym, record):
    """uint8 word rows -> fixed-length byte strings for the file (no Python objects)."""
    L = max(1, record // 2)
    return np.ascontiguousarray(sym[:, :L]).view(f"S{L}").reshape(sym.shape[0])


def _words(sym):
    from .analysis import words
    return words(sym)


# ------------------------------------------------------------------ blocks
def blocks(scene: Scene, block_points: int | None = None):
    """Grid slabs in execution order: list of index tuples (of slices).

    A slab holds at most ``block_points`` grid points (default: as many as fit
    in BLOCK_BYTES of kernel output); a followed sweep runs one value of the
    first axis at a time, in the direction of ``follow``.
    """
    G = scene.shape
    per_item = scene.record * ITEM_FIELDS * 8 + 64
    max_points = max(1, BLOCK_BYTES // (per_item * scene.n_ic))
    if block_points:
        max_points = min(max_points, int(block_points))
    if not G:
        return [()]
    if scene.follow != "none":
        order = range(G[0]) if scene.follow == "up" else range(G[0] - 1, -1, -1)
        if len(G) == 1:
            return [(slice(i, i + 1),) for i in order]
        return [(slice(i, i + 1), slice(0, G[1])) for i in order]
    if len(G) == 1:
        return [(slice(a, min(a + max_points, G[0])),) for a in range(0, G[0], max_points)]
    out = []
    for i in range(G[0]):
        for a in range(0, G[1], max_points):
            out.append((slice(i, i + 1), slice(a, min(a + max_points, G[1]))))
    return out


def _indices(scene, blk):
    ranges = [range(s.start, s.stop) for s in blk]
    grid = np.stack(np.meshgrid(*[np.arange(r.start, r.stop) for r in ranges], indexing="ij"),
                    axis=-1).reshape(-1, len(ranges)) if ranges else np.zeros((1, 0), int)
    return [tuple(int(x) for x in row) for row in grid], [len(r) for r in ranges]


def estimate_bytes(scene: Scene) -> int:
    """Upper estimate of the output file size (uncompressed)."""
    n = int(np.prod(scene.shape or (1,))) * scene.n_ic
    per = 4 * 8 + 1 + 4 + 4 + max(1, scene.record // 2)
    if scene.model == "two_particle":
        per += 4 * 8
    if "impacts" in scene.keep:
        per += 5 * 8 * scene.record
    if "section" in scene.keep:
        per += (4 if scene.model == "two_particle" else 2) * 8 * scene.record
    if "wall_impacts" in scene.keep:
        per += 4 * 8 * scene.record
    return n * per


def estimate_memory(scene: Scene) -> int:
    """Upper estimate of the sweep's working memory: one block of kernel outputs (bounded
    by BLOCK_BYTES, twice for the copies the writer makes) plus what grows with the grid
    (the done mask and the block list, ~200 bytes a grid row)."""
    points = int(np.prod(scene.shape or (1,)))
    per_item = scene.record * ITEM_FIELDS * 8 + 64
    block = min(BLOCK_BYTES, per_item * scene.n_ic * points)
    rows = points if len(scene.shape) < 2 else scene.shape[0] * max(1, scene.shape[1] // max(
        1, BLOCK_BYTES // (per_item * scene.n_ic)))
    return 3 * block + points + 200 * rows


def _available_memory():
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        return None
    return None


# ------------------------------------------------------------------ the sweep
def run_sweep(scene: Scene, out_path: str, threads: int | None = None, resume: bool = False,
              overwrite: bool = False, progress: bool = False, command: str = "",
              block_points: int | None = None, scheduler: str | None = None,
              stats: dict | None = None) -> str:
    """Run a scene to ``out_path``; return the path of the finished file.

    ``scheduler``: None runs the blocks here (numba threads); a Dask scheduler address
    or ``local:N`` runs them on a Dask cluster (``cornerbif.distributed``), with this
    process the only writer of the file either way.  ``threads`` is then the numba
    threads of each worker; ``stats`` (a dict) receives what the Dask backend did
    (chunks submitted, failures, compute seconds per chunk).
    """
    import h5py
    import numba

    if scene.model not in ("flow", "map2d", "two_particle"):
        raise SceneError([f"scene.model: {scene.model!r} is not implemented yet"])
    partial = out_path + ".partial"
    lock_path = out_path + ".lock"
    if os.path.exists(out_path) and not overwrite:
        raise SweepError(f"{out_path} exists; pass --overwrite to replace it")
    lock = open(lock_path, "w")
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        lock.close()
        raise SweepError(f"{out_path}: another sweep is writing this output (lock {lock_path} "
                         "is held)") from None
    try:
        if threads and not scheduler:
            numba.set_num_threads(int(threads))
        if os.path.exists(partial):
            if resume:
                f = _reopen(partial, scene)
            elif overwrite:
                os.remove(partial)
                f = None
            else:
                raise SweepError(f"{partial} holds an interrupted sweep; pass --resume to "
                                 "complete it or --overwrite to start again")
        else:
            f = None
        if f is None:
            check_budget(scene, out_path)
            # set the file up under a temporary name: a partial file exists only once
            # every dataset is in place and single-writer/multiple-reader mode is on
            init = partial + ".init"
            f = io.create(init, scene, scene.n_ic, command=command, versions=io.versions())
            f.swmr_mode = True
            os.replace(init, partial)
        try:
            if scheduler:
                from .distributed import run_blocks_dask
                run_blocks_dask(scene, f, scheduler, progress=progress,
                                block_points=block_points, numba_threads=threads,
                                stats=stats)
            else:
                _run_blocks(scene, f, progress, block_points)
        except SweepError as e:
            f.close()
            if getattr(e, "failures", None):
                # the failed chunks, with their errors, on the file --resume will complete
                # (attributes cannot be added in single-writer/multiple-reader mode)
                import json
                with h5py.File(partial, "r+") as g:
                    g.attrs["failed_chunks"] = json.dumps(e.failures)
            raise
        except KeyboardInterrupt:
            f.close()
            raise SweepInterrupted(f"interrupted; finished points are kept in {partial}; "
                             "run again with --resume to complete it") from None
        except OSError as e:
            try:
                f.close()
            except Exception:  # noqa: BLE001
                pass
            raise SweepError(f"writing {partial} failed ({e}); finished points are kept; "
                             "free space and run again with --resume") from None
        f.close()
        with h5py.File(partial, "r+") as g:
            g.attrs["completed"] = io._now()
            if "failed_chunks" in g.attrs:        # left by an earlier distributed run
                del g.attrs["failed_chunks"]
            counts = np.bincount(g["status"][...].ravel().astype(np.int64) + 1, minlength=9)
            g.attrs["status_counts"] = str({S.NAMES.get(i - 1, "NOT_RUN"): int(c)
                                            for i, c in enumerate(counts) if c})
        os.replace(partial, out_path)
        return out_path
    finally:
        fcntl.flock(lock, fcntl.LOCK_UN)
        lock.close()
        try:
            os.remove(lock_path)
        except OSError:
            pass


def check_budget(scene: Scene, out_path: str):
    """Refuse, before any work, a grid whose output would not fit the disk or whose working
    memory would not fit the machine; the message gives the estimate."""
    free = _free_bytes(os.path.dirname(os.path.abspath(out_path)))
    need = estimate_bytes(scene)
    if free is not None and need > free:
        raise SweepError(f"the output needs up to {need / 2**30:.2f} GiB but only "
                         f"{free / 2**30:.2f} GiB are free on its disk; shrink the grid or "
                         "keep less (output.keep)")
    avail = _available_memory()
    mem = estimate_memory(scene)
    if avail is not None and mem > avail:
        raise SweepError(f"the sweep needs about {mem / 2**30:.2f} GiB of memory but only "
                         f"{avail / 2**30:.2f} GiB are available; shrink the grid")


def _free_bytes(d):
    try:
        st = os.statvfs(d)
        return st.f_bavail * st.f_frsize
    except OSError:
        return None


def _reopen(partial, scene):
    """Open an interrupted sweep's partial file for writing.

    A file whose writer was killed keeps HDF5's "open for writing" flags; it still
    opens read-only in SWMR mode, so its finished points are copied into a fresh
    partial file, which replaces it.
    """
    import h5py
    try:
        f = h5py.File(partial, "r+", libver="latest")
    except OSError:
        f = _rebuild(partial, scene)
    if f.attrs.get("scene_hash") != scene.hash:
        f.close()
        raise SweepError(f"{partial}: the scene differs from the one this file was started with; "
                         "--resume needs the same scene (or --overwrite to start again)")
    f.swmr_mode = True
    return f


def _rebuild(partial, scene):
    import h5py
    try:
        src = h5py.File(partial, "r", swmr=True, locking=False)
    except OSError as e:
        raise SweepError(f"{partial}: cannot be read to resume ({e}); start again with "
                         "--overwrite") from None
    try:
        return _copy_done(src, partial, scene)
    except SweepError:
        raise
    except Exception as e:  # noqa: BLE001
        raise SweepError(f"{partial}: cannot be read to resume ({e}); start again with "
                         "--overwrite") from None


def _copy_done(src, partial, scene):
    import h5py
    with src:
        if src.attrs.get("scene_hash") != scene.hash:
            raise SweepError(f"{partial}: the scene differs from the one this file was started "
                             "with; --resume needs the same scene (or --overwrite to start again)")
        tmp = partial + ".rebuild"
        dst = io.create(tmp, scene, scene.n_ic, command=src.attrs.get("command", ""),
                        versions=io.versions())
        dst.attrs["created"] = src.attrs.get("created", "")
        names = []
        dst.visititems(lambda n, o: names.append(n) if isinstance(o, h5py.Dataset) else None)
        scales = {a.name for a in scene.axes} | {"ic", "record"}
        G0 = scene.shape[0] if scene.shape else 1
        step = max(1, G0 // 64)
        for name in names:
            if name in scales or name not in src:
                continue
            if not scene.shape:
                dst[name][...] = src[name][...]
                continue
            for a in range(0, G0, step):
                dst[name][a:a + step] = src[name][a:a + step]
        dst.close()
    os.replace(tmp, partial)
    return h5py.File(partial, "r+", libver="latest")


def compute_block(scene: Scene, blk, carry=None, ints=None) -> dict:
    """The one unit of work of every backend: a grid slab in, its datasets out.

    Pure (no I/O, no global state): packs the slab's parameters, draws its initial
    conditions (``draw_initial``; a followed sweep replaces them by ``carry``, the
    previous slab's final states, where those lie above the obstacle), runs the
    model's kernels and the cycle analysis (``run_items``), and returns a dict from
    dataset name (``io`` schema) to an array shaped ``slab shape + (n_ic, ...)``,
    ready for ``io.write_block``.  The local loop and the Dask workers
    (``cornerbif.distributed``) both call it, so both write the same bytes.
    """
    if ints is None:
        ints = int_settings(scene)
    G = scene.shape
    idx, sub = _indices(scene, blk)
    params = pack_points(scene, idx)
    flat = np.array([np.ravel_multi_index(i, G) if G else 0 for i in idx], np.int64)
    tp = scene.model == "two_particle"
    if scene.model == "map2d":
        kap = np.full(len(idx), -np.inf)     # no obstacle: any (a0, b1) is a start
    elif tp:
        from .models import two_particle as TP
        kap = params[:, TP.KAPPA]             # the wall at t = 0: w(0) = kappa
    else:
        kap = params[:, P.KAPPA]
    ics = draw_initial(scene, flat, kap)
    if carry is not None:
        ok = np.isfinite(carry).all(axis=-1) & (carry[..., 0] > kap[:, None])
        ics = np.where(ok[..., None], carry, ics)
    n = len(idx) * scene.n_ic
    prm = np.repeat(params, scene.n_ic, axis=0)
    out, st, final, period, ipc, sym = run_items(prm, ics.reshape(n, ics.shape[-1]),
                                                 ints, scene)
    shape = tuple(sub) + (scene.n_ic,)
    iu = 2 if tp else 0
    block = {"initial/u": ics[..., iu].reshape(shape),
             "initial/v": ics[..., iu + 1].reshape(shape),
             "status": st.reshape(shape), "period": period.reshape(shape),
             "impacts_per_cycle": ipc.reshape(shape),
             "symbols": _symbol_bytes(sym, scene.record).reshape(shape),
             "final/u": final[:, iu].reshape(shape),
             "final/v": final[:, iu + 1].reshape(shape)}
    if tp:
        block.update({"initial/z": ics[..., 0].reshape(shape),
                      "initial/y": ics[..., 1].reshape(shape),
                      "final/z": final[:, 0].reshape(shape),
                      "final/y": final[:, 1].reshape(shape)})
        if "section" in scene.keep:
            block["section/z"] = out["sz"].reshape(shape + (scene.record,))
            block["section/y"] = out["sy"].reshape(shape + (scene.record,))
        if "wall_impacts" in scene.keep:
            for k in ("t", "z", "y_in", "y_out"):
                block[f"wall_impacts/{k}"] = out[f"wz_{k}"].reshape(shape + (scene.record,))
    if "impacts" in scene.keep:
        for k in io.IMPACT_FIELDS:
            block[f"impacts/{k}"] = out[k].reshape(shape + (scene.record,))
    if "section" in scene.keep:
        block["section/u"] = out["su"].reshape(shape + (scene.record,))
        block["section/v"] = out["sv"].reshape(shape + (scene.record,))
    return block


def _carry_names(scene):
    names = ["final/z", "final/y"] if scene.model == "two_particle" else []
    return names + ["final/u", "final/v"]


def block_carry(scene: Scene, block: dict) -> np.ndarray:
    """What a followed sweep carries to the next slab: the slab's final states,
    shape (points, n_ic, state size), in the kernel's state order."""
    names = _carry_names(scene)
    return np.stack([block[n] for n in names], -1).reshape(-1, scene.n_ic, len(names))


def progress_bar(scene, total, already):
    """The sweep's progress bar on stderr (click), advanced past the finished blocks."""
    import click
    bar = click.progressbar(length=total, label=f"sweep {scene.name}", file=sys.stderr,
                            show_pos=True, show_eta=True)
    bar.__enter__()
    bar.update(already)
    return bar


def todo_blocks(scene, f, block_points=None):
    """(every block in execution order, the ones not yet marked done in ``f``)."""
    done = f["done"][...]
    every = blocks(scene, block_points)
    return every, [b for b in every if not np.all(done[b])]


FOLLOW_BATCH = 256   # followed slabs written together at most


def _run_blocks(scene, f, progress, block_points=None):
    """The local backend: every unfinished block in order, computed here and written."""
    ints = int_settings(scene)
    every, todo = todo_blocks(scene, f, block_points)
    bar = progress_bar(scene, len(every), len(every) - len(todo)) if progress else None
    carry = None  # follow: final states of the previous grid slab
    if scene.follow != "none" and todo:
        carry = _carry_from_file(scene, f, every, todo[0])
    # a followed sweep computes one thin slab at a time; writing each alone costs more
    # than computing it, so consecutive slabs are written together, at least once a second
    pending = []
    last = time.monotonic()
    try:
        for blk in todo:
            block = compute_block(scene, blk, carry, ints)
            pending.append((blk, block))
            if scene.follow != "none":
                carry = block_carry(scene, block)
            if (scene.follow == "none" or len(pending) >= FOLLOW_BATCH
                    or time.monotonic() - last > 1.0):
                _write_pending(f, pending)
                last = time.monotonic()
            if bar is not None:
                bar.update(1)
    finally:
        try:
            _write_pending(f, pending)       # finished slabs are kept on an interrupt too
        finally:
            if bar is not None:
                bar.__exit__(None, None, None)


def _write_pending(f, pending):
    """Write finished slabs, merged into one write where they are neighbours on axis 0.

    The slabs are taken off ``pending`` before writing, so a write that fails (or is
    interrupted) is not attempted again by the caller's clean-up.
    """
    items = sorted(pending, key=lambda item: item[0][0].start if item[0] else 0)
    pending.clear()
    if not items:
        return
    idx = [blk for blk, _ in items]
    contiguous = len(items) > 1 and all(a[0].stop == b[0].start and a[1:] == b[1:]
                                        for a, b in zip(idx, idx[1:]))
    if contiguous:
        blk = (slice(idx[0][0].start, idx[-1][0].stop),) + tuple(idx[0][1:])
        io.write_block(f, blk, {n: np.concatenate([block[n] for _, block in items], axis=0)
                                for n in items[0][1]})
    else:
        for item in items:
            io.write_block(f, *item)


def _carry_from_file(scene, f, all_blocks, first_todo):
    """On resume of a followed sweep: the final states of the previous slab."""
    i = all_blocks.index(first_todo)
    if i == 0:
        return None
    prev = all_blocks[i - 1]
    return block_carry(scene, {n: f[n][prev] for n in _carry_names(scene)})


# ------------------------------------------------------------------ one run, from Python
def simulate(u0, v0, transient=0, record=100, obstacle="rectified_sine", tol=1e-12,
             chatter=1e-6, escape=1e6, period_tol=1e-6, section_period=None,
             max_events=None, max_periods=None, stop="none", **system):
    """Run the flow model for one or many initial states (u0, v0) at t = 0.

    ``system`` takes the names of ``[system]`` (omega, kappa, beta, r, sigma, k,
    F, Omega, phi, theta1, theta2), each a scalar or an array broadcast against
    u0.  Returns a dict of arrays: impacts (t, u, v_in, v_out, corner_offset),
    section (su, sv), status, final, period, impacts_per_cycle, symbols.
    Parameters are validated exactly as a scene's.
    """
    from .config import FLOW_PARAMS, from_dict
    raw = {"system": {"obstacle": obstacle}, "run": {"transient": transient, "record": record,
                                                     "tol": tol, "chatter": chatter,
                                                     "escape": escape, "period_tol": period_tol,
                                                     "stop": stop}}
    if max_events is not None:
        raw["run"]["max_events"] = max_events
    if max_periods is not None:
        raw["run"]["max_periods"] = max_periods
    arrays = {k: np.atleast_1d(np.asarray(v, float)) for k, v in system.items() if v is not None}
    u0 = np.atleast_1d(np.asarray(u0, float))
    v0 = np.atleast_1d(np.asarray(v0, float))
    shape = np.broadcast_shapes(u0.shape, v0.shape, *[a.shape for a in arrays.values()])
    flat = {k: np.broadcast_to(a, shape).ravel() for k, a in arrays.items()}
    n = int(np.prod(shape))
    for k, a in flat.items():
        raw["system"][k] = float(a[0])
    if section_period is not None:
        raw["system"]["section_period"] = section_period
    raw["initial"] = {"u": [float(u0.max()) + 1.0, float(u0.max()) + 2.0]}
    scene = from_dict(raw)
    # every value is checked as a scene's would be, not only the first of each array:
    # ranges per distinct value (their extremes when there are many), undamped exact
    # resonance (F != 0, sigma = 0, Omega = k) element by element
    for k, a in flat.items():
        vals = np.unique(a)
        for v in (vals if vals.size <= 2000 else vals[[0, -1]]):
            from_dict({**raw, "system": {**raw["system"], k: float(v)}})
    get = {k: flat.get(k, np.full(n, float(scene.system.get(k) or 0.0))) for k in
           ("F", "sigma", "Omega", "k")}
    res = (get["F"] != 0.0) & (get["sigma"] == 0.0) & (get["Omega"] == get["k"])
    if res.any():
        i = int(np.argmax(res))
        raise SceneError([f"system.Omega: {get['Omega'][i]!r} equals system.k at element {i} with "
                          "sigma = 0 and F != 0 (undamped exact resonance: no bounded "
                          "closed-form flight); change Omega or k, or add damping sigma > 0"])
    params = np.empty((n, P.NPARAM))
    for i in range(n):
        vals = dict(scene.system)
        for k, a in flat.items():
            if k not in FLOW_PARAMS:
                raise TypeError(f"simulate() got an unknown parameter {k!r}")
            vals[k] = float(a[i])
        params[i] = P.pack(vals, obstacle, tol, chatter, escape, section_period,
                           STOP_TOL_FACTOR * period_tol if stop == "period" else 0.0)
    ics = np.stack([np.broadcast_to(u0, shape).ravel(), np.broadcast_to(v0, shape).ravel()], -1)
    out, st, final, period, ipc, sym = run_items(params, np.ascontiguousarray(ics),
                                                 int_settings(scene), scene)
    res = {k: v.reshape(shape + (record,)) for k, v in out.items()}
    res.update(status=st.reshape(shape), final=final.reshape(shape + (2,)),
               period=period.reshape(shape), impacts_per_cycle=ipc.reshape(shape),
               symbols=_words(sym).reshape(shape))
    return res
