"""The HDF5 file: schema, incremental writing, reading, resume (docs/architecture.md, "Data flow").

Layout (public, keep these names; format version 1; the per-model datasets come from
the model's declaration in ``cornerbif.registry``)::

    /                attrs: format = "cornerbif", format_version, cornerbif_version,
                     scene (TOML as run), scene_hash, created, completed, command,
                     model, obstacle, numpy_version, numba_version, h5py_version,
                     python_version, status_codes, status_counts (once complete),
                     failed_chunks (a distributed run with failed chunks, until resumed)
    /<axis>          one dataset per swept parameter, a dimension scale
    /ic, /record     dimension scales
    /initial/<c>     G + (n_ic,): the start of each start coordinate c
                     (flow: u, v and the start time t; map2d: u, v; two_particle: z, y, u, v)
    /final/<c>       G + (n_ic,): the state at the last section crossed (what follow carries)
    /impacts/t, u, v_in, v_out, corner_offset   G + (n_ic, record), NaN where absent
                     (flow; two_particle: the z-u impacts, offset to the nearest w-z impact)
    /section/u, v    G + (n_ic, record) (map2d: a_n, b_n; two_particle adds section/z, y)
    /wall_impacts/t, z, y_in, y_out   G + (n_ic, record) (two_particle: the w-z impacts)
    /<group>/<axis>, /<group>/ic, /<group>/record   each group's own copies of the scales,
                     so that xarray opens a group with coordinate values
    /status          G + (n_ic,) int8 (names in its attribute ``codes``)
    /period, /impacts_per_cycle   G + (n_ic,) int32
    /symbols         G + (n_ic,) fixed-length ASCII string (record // 2 bytes, NUL-padded;
                     attribute _Encoding = "ascii", so xarray reads text)
    /cycle/signature G + (n_ic, 6): mean, least, largest of the model's two cycle series over
                     the run's last cycle (NaN: no cycle); /cycle/point G + (n_ic, 2) a point
                     of it (models with a ``CycleSeries``; docs/basins.md)
    /done            G uint8: 1 where the grid point is complete
    /attractor, /attractors/*   written when the file is finished: each run's attractor id
                     and the table of attractors (``cornerbif.attractors``)

A sweep writes ``OUT.h5.partial`` in HDF5's single-writer/multiple-reader
mode (its metadata is flushed in an order that keeps the file readable at
every moment), marks each grid point done after its data are flushed, and
renames the file to ``OUT.h5`` when every point is done: a finished file is
never half-written, and an interrupted one still opens and resumes.
"""

from __future__ import annotations

import datetime as _dt
import json
import os
import resource
import shutil
import sys
import tomllib

import h5py
import numpy as np

from . import attractors, engine, outputs, registry
from . import status as S
from ._version import FORMAT_VERSION, __version__
from .config import SceneError, loads, recorded_obstacle, same_run
from .config import scene_difference as what
from .errors import SweepError, WriteFailed
from .model import cut, shown


class FileFormatError(Exception):
    """A file this version cannot read; the message says why."""


def _now():
    return _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")


def create(path, scene, n_ic, command="", versions=None):
    """Create the partial file with every dataset allocated and its scales attached.

    The schema is the model's declaration (``cornerbif.registry``): ``initial/<c>`` and
    ``final/<c>`` per state coordinate, one dataset per Field of each kept observable,
    and the per-run summary every model shares (status, period, impacts_per_cycle,
    symbols) with the grid's ``done`` mask.
    """
    from . import chunkwrite  # start-up: loads numba (jitted), imported by the commands that write
    spec = scene.spec
    G = scene.shape
    rec = scene.record
    f = h5py.File(path, "w", libver="latest")
    f.attrs["format"] = "cornerbif"
    f.attrs["format_version"] = FORMAT_VERSION
    f.attrs["cornerbif_version"] = __version__
    f.attrs["scene"] = scene.text
    f.attrs["scene_hash"] = scene.hash
    f.attrs["created"] = _now()
    f.attrs["completed"] = ""
    f.attrs["command"] = command
    f.attrs["model"] = scene.model
    f.attrs["obstacle"] = recorded_obstacle(scene)
    for k, v in (versions or {}).items():
        f.attrs[f"{k}_version"] = v
    f.attrs["status_codes"] = json.dumps({str(k): v for k, v in S.NAMES.items()})

    dims = []
    for a in scene.axes:
        ds = f.create_dataset(a.name, data=a.array)
        ds.attrs["long_name"] = f"swept parameter {a.name}"
        ds.make_scale(a.name)
        dims.append(ds)
    ic = f.create_dataset("ic", data=np.arange(n_ic, dtype=np.int32))
    ic.make_scale("ic")
    ic.attrs["long_name"] = "initial condition index"
    recd = f.create_dataset("record", data=np.arange(rec, dtype=np.int32))
    recd.make_scale("record")
    recd.attrs["long_name"] = "recorded event index"

    def axis_scale(name, size):
        """A root dimension scale 0 .. size - 1 for a per-run field's trailing axis."""
        if name not in f:
            ds = f.create_dataset(name, data=np.arange(size, dtype=np.int32))
            ds.make_scale(name)
            ds.attrs["long_name"] = f"{name} index"
        return f[name]

    def local(scale, group):
        """The group's own copy of a root dimension scale: xarray opens a group
        (``group="impacts"``) with coordinate values only from scales inside it."""
        name = f"{group}/{scale.name.rsplit('/', 1)[-1]}"
        if name not in f:
            ds = f.create_dataset(name, data=scale[...])
            ds.attrs["long_name"] = scale.attrs["long_name"]
            ds.make_scale(name.rsplit("/", 1)[-1])
        return f[name]

    def make(name, shape, dtype, fill, scales, event=False, **attrs):
        if "/" in name:
            scales = [local(sc, name.split("/")[0]) for sc in scales]
        # blocks are whole numbers of chunks, so the writer compresses whole chunks itself
        # (cornerbif.chunkwrite): per event ~CHUNK_BYTES, per run one block
        per = engine.event_chunk_points(scene) if event else engine.block_points_max(scene)
        ch = [1] * len(G) + list(shape[len(G):])
        if G:
            ch[len(G) - 1] = min(G[-1], per)
        kw = dict(chunks=tuple(ch) if shape else None)
        ds = f.create_dataset(name, shape=shape, dtype=dtype, fillvalue=fill,
                              compression="gzip", compression_opts=chunkwrite.LEVEL,
                              shuffle=True, **kw)
        for i, sc in enumerate(scales):
            ds.dims[i].attach_scale(sc)
        for k, v in attrs.items():
            ds.attrs[k] = v
        return ds

    gsc = list(dims)
    per_run = G + (n_ic,)
    per_event = G + (n_ic, rec)
    for c in spec.starts:
        make(f"initial/{c.name}", per_run, "f8", np.nan, gsc + [ic], long_name=c.initial_doc)
    for fld in spec.fields(scene.keep):
        units = {"units": fld.units} if fld.units else {}
        if fld.axis is None:
            shape, scales = per_event, gsc + [ic, recd]
        elif not fld.axis:
            shape, scales = per_run, gsc + [ic]
        else:
            shape, scales = per_run + (fld.axis[1],), gsc + [ic, axis_scale(*fld.axis)]
        make(fld.name, shape, fld.dtype, fld.fill, scales, event=fld.axis is None, **units,
             long_name=fld.long_name)
    for c in spec.finals:
        make(f"final/{c.name}", per_run, "f8", np.nan, gsc + [ic], long_name=c.final_doc)
    make("status", per_run, "i1", -1, gsc + [ic],
         codes=json.dumps({str(k): v for k, v in S.NAMES.items()}),
         long_name="how the run ended (-1: not run)")
    make("period", per_run, "i4", 0, gsc + [ic],
         long_name="clusters per cycle (Poincare-map iterates near omega = 2); 0: none found")
    make("impacts_per_cycle", per_run, "i4", 0, gsc + [ic], long_name="impacts per cycle")
    # fixed length (no global heap): a period needs two cycles in the window, so at
    # most record // 2 letters; stays consistent for readers of an interrupted file
    make("symbols", per_run, symbol_dtype(rec), b"", gsc + [ic],
         long_name="cycle word: a alpha, b beta, g gamma, x other; smallest rotation",
         _Encoding="ascii")      # read back as text (CF / xarray), not bytes
    if spec.cycle is not None:
        from .analysis import SIGNATURE  # start-up: loads numba
        cs = spec.cycle
        make("cycle/signature", per_run + (len(SIGNATURE),), "f8", np.nan,
             gsc + [ic, axis_scale("statistic", len(SIGNATURE))],
             long_name=f"the cycle's signature over one cycle, a = {cs.long_names[0]}, b = "
                       f"{cs.long_names[1]}: " + ", ".join(SIGNATURE) + " (NaN: no cycle)",
             names=json.dumps(SIGNATURE))
        make("cycle/point", per_run + (2,), "f8", np.nan, gsc + [ic, axis_scale("coordinate", 2)],
             long_name=f"a point of the cycle: ({cs.names[0]}, {cs.names[1]}) where "
                       f"{cs.names[1]} is largest (NaN: no cycle)", names=json.dumps(cs.names))
    d = f.create_dataset("done", shape=G, dtype="u1", fillvalue=0,
                         chunks=(tuple([1] * (len(G) - 1) + [min(G[-1], 65536)]) if G else None))
    for i, sc in enumerate(gsc):
        d.dims[i].attach_scale(sc)
    d.attrs["long_name"] = "1 where the grid point is complete"
    return f


def symbol_dtype(record):
    """Fixed-length ASCII dtype of the ``symbols`` dataset."""
    return h5py.string_dtype("ascii", max(1, record // 2))


# bytes kept free beyond a block's data: HDF5's metadata and chunk index, the done marks and
# the attributes written when the file is finished
WRITE_RESERVE = 256 * 1024
# bytes a new file needs beyond its scene attribute before its first block: HDF5's
# superblock, groups and dataset headers (a one-run file of fig02 takes 31 KB in all)
CREATE_RESERVE = 32 * 1024


def free_space(directory) -> int | None:
    """Bytes free for this user on the filesystem of ``directory``, or None."""
    try:
        st = os.statvfs(directory)
    except OSError:
        return None
    return st.f_bavail * st.f_frsize


def size_limit() -> int | None:
    """This process's file-size limit (``ulimit -f``) in bytes, or None."""
    soft = resource.getrlimit(resource.RLIMIT_FSIZE)[0]
    return None if soft == resource.RLIM_INFINITY else soft


def room(path, size=None):
    """Bytes that may still be written to the file at ``path``: the space its filesystem
    gives this user (``free_space``), and the file-size limit of this process
    (``size_limit``) less the file's size (``size``, default its size on disk); None when
    neither can be read."""
    left = free_space(os.path.dirname(os.path.abspath(path)))
    limit = size_limit()
    if limit is not None:
        if size is None:
            size = os.path.getsize(path) if os.path.exists(path) else 0
        left = limit - size if left is None else min(left, limit - size)
    return left


def ensure_room(path, nbytes, size=None, what="the next block", reserve=WRITE_RESERVE,
                then="every finished point is kept; free space and run the same command with "
                     "--resume"):
    """Refuse, before writing, data that the file's disk or size limit cannot take
    (``nbytes``, what the write adds to the file, plus ``reserve`` for HDF5's own
    structures); the message ends with ``then`` (what was kept, what to do)."""
    need = nbytes + reserve
    left = room(path, size)
    if left is not None and left < need:
        def size_text(n):
            return f"{n / 2**20:.1f} MiB" if n >= 2**20 else f"{max(n, 0) / 2**10:.0f} KiB"
        raise WriteFailed(f"{path}: no room for {what} ({size_text(need)} needed, "
                          f"{size_text(left)} left on its disk or under this process's "
                          f"file-size limit); {then}")


def write_block(f, index, block):
    """Write one finished block (a slab of the grid) and mark it done, flushing in order.

    The room for it is checked before anything is written (``ensure_room``): where the disk
    and the file-size limit leave room for the block's size in memory, each dataset's slab
    is compressed and written in turn (``chunkwrite.prepare_slab``, one at a time: the
    memory of a sweep is two blocks, ``estimate.estimate_memory``); where they do not, every
    chunk is compressed first and the room checked against what the block will add to the
    file (the compressed chunks, the parts HDF5 compresses itself counted uncompressed),
    which holds the block's compressed copy as well, only then.  A full disk or a
    file-size limit stops the sweep with the file as it was after the last block, which
    --resume completes."""
    from . import chunkwrite  # start-up: loads numba (jitted), imported by the commands that write
    # each dataset's chunkwrite.Layout (None: a block's array the file does not keep), read
    # from HDF5 at the first block written through this File object and kept on it
    layouts = f.__dict__.setdefault("_cornerbif_layouts", {})
    # f.filename is the name the file was created under (open_partial renames it); the
    # directory is the same, and HDF5 knows the file's size
    size = f.id.get_filesize()
    left = room(f.filename, size)
    roomy = left is None or left >= sum(np.asarray(a).nbytes for a in block.values()) + WRITE_RESERVE
    try:
        names = []
        for name in block:
            if name not in layouts:
                layouts[name] = chunkwrite.Layout(f[name]) if name in f else None
            if layouts[name] is not None:
                names.append(name)
        slabs = None if roomy else [chunkwrite.prepare_slab(layouts[n], index, block[n])
                                    for n in names]
    except (OSError, RuntimeError) as e:      # reading a layout from HDF5
        raise WriteFailed(f"writing {f.filename} failed ({reason(e)}); every point marked "
                          "done before is kept; free space and run the same command with "
                          "--resume", broken=True) from None
    if slabs is not None:
        ensure_room(f.filename, sum(s.nbytes for s in slabs), size)
    try:
        if slabs is None:
            for n in names:
                chunkwrite.prepare_slab(layouts[n], index, block[n]).write()
        else:
            for slab in slabs:
                slab.write()
        f.flush()
        f["done"][index] = 1
        f.flush()
    except (OSError, RuntimeError) as e:      # h5py raises either for a failed write
        raise WriteFailed(f"writing {f.filename} failed ({reason(e)}); every point marked "
                          "done before is kept; free space and run the same command with "
                          "--resume", broken=True) from None
    watch = f.__dict__.get("_cornerbif_watch")
    if watch is not None:
        watch.wrote(f, int(np.prod([s.stop - s.start for s in index])) if index else 1)


class RoomWatch:
    """After each block, the finished file's size projected from the blocks written in this
    run; said once (``echo``) when the file and its finishing copy will not fit the disk,
    or the file not under the file-size limit.  Only a note: the room check of each block
    (``ensure_room``) stops the sweep when the disk is really full."""

    def __init__(self, f, echo):
        done = f["done"][...]
        self.echo, self.size0 = echo, f.id.get_filesize()
        self.left = int(done.size - np.count_nonzero(done)) if done.shape else int(not done)
        self.points, self.warned = 0, False

    def wrote(self, f, points):
        self.points += points
        left = self.left - self.points
        if self.warned or left <= 0 or self.points < max(1, self.left // 100):
            return
        size = f.id.get_filesize()
        grow = (size - self.size0) / self.points * left
        final = size + grow
        free = free_space(os.path.dirname(os.path.abspath(f.filename)))
        limit = size_limit()
        short = ((free is not None and grow + final > free)
                 or (limit is not None and final > limit))
        if short:
            self.warned = True
            self.echo(f"note: at the compression of the {self.points} points written so far, "
                      f"the file will take about {final / 2**20:.1f} MiB (and as much again "
                      "for its copy when it is finished), more than its disk or the file-size "
                      "limit leaves; when it is full the sweep stops with every finished point "
                      "kept: free space and run the same command with --resume")


def watch_room(f, echo):
    """Project the file's size after each block and say once when it will not fit
    (``RoomWatch``)."""
    if echo is not None:
        f.__dict__["_cornerbif_watch"] = RoomWatch(f, echo)


# what a message calls a file of each root attribute ``format`` (``open_checked``)
FORMAT_NAMES = {outputs.SWEEP_FORMAT: "cornerbif file",
                outputs.CONTINUATION_FORMAT: "cornerbif continuation file"}
# the files a refusal of links and virtual datasets names, at most (then: and N more)
NAMED_AT_MOST = 3


def open_checked(path, fmt: str = outputs.SWEEP_FORMAT, version: int = FORMAT_VERSION):
    """Open ``path`` read-only, only if it is a file of root attribute ``format`` = ``fmt``
    and a format version of at most ``version`` (the readers' one opener: ``check_readable``
    for a sweep, ``plot_data.read_continuation`` for a continuation).

    Refused with ``FileFormatError`` saying why, before anything is read: a missing path, a
    directory, a FIFO or a device (never opened: reading one may block or never end), an
    empty file, a file that is not HDF5 or does not open as HDF5, another format, a newer
    version, a file that refers to other files (links, external storage and virtual
    datasets are never followed), and more data than half of this machine's memory.  A
    sweep killed while writing leaves HDF5's "open for writing" flags set; its
    single-writer/multiple-reader layout still reads consistently, and is opened so."""
    path = str(path)
    name = FORMAT_NAMES.get(fmt, f"{fmt} file")
    if not os.path.exists(path):
        raise FileFormatError(f"{path}: no such file")
    kind = outputs.not_a_regular_file(path)
    if kind:
        raise FileFormatError(f"{path}: is {kind}, not a {name} (never opened: reading it "
                              "may never end)")
    if os.path.getsize(path) == 0:
        raise FileFormatError(f"{path}: the file is empty")
    if not h5py.is_hdf5(path):
        raise FileFormatError(f"{path}: not an HDF5 file")
    f = _open_read(path)
    try:
        found = f.attrs.get("format")
        if found != fmt:
            raise FileFormatError(f"{path}: not a {name} (root attribute format is "
                                  f"{shown(found)})")
        ver = int(f.attrs.get("format_version", -1))
        if ver > version:
            raise FileFormatError(f"{path}: format version {ver} is newer than this cornerbif "
                                  f"reads ({version}); upgrade cornerbif")
        _check_self_contained(path, f)
    except FileFormatError:
        f.close()
        raise
    except Exception as e:  # noqa: BLE001 - h5py's zoo of errors for a damaged file
        f.close()
        raise FileFormatError(f"{path}: a damaged {name} ({error_line(e, path)})") from None
    return f


def error_line(e, path) -> str:
    """What an error of h5py (or of a crafted file) says, in one bounded line."""
    first = (str(e).splitlines() or [type(e).__name__])[0].removeprefix(f"{path}: ")
    return cut(first or type(e).__name__, 200)


def _open_read(path):
    """``path`` opened read-only without HDF5's file locking; a file whose writer was killed
    ("already open for write") in single-writer/multiple-reader mode.  A truncated file is
    not retried in that mode: its reader retries checksums without end on a file cut
    short."""
    try:
        return h5py.File(path, "r", locking=False)
    except Exception as e0:  # noqa: BLE001 - h5py raises a zoo of errors for damaged files
        if "already open for write" not in str(e0):
            raise FileFormatError(f"{path}: cannot be opened as HDF5 ({error_line(e0, path)})") \
                from None
    try:
        return h5py.File(path, "r", swmr=True, locking=False)
    except Exception as e:  # noqa: BLE001
        raise FileFormatError(f"{path}: cannot be opened as HDF5 ({error_line(e, path)})") from None


def _check_self_contained(path, f):
    """Refuse a file that refers to other files (soft and external links, virtual datasets,
    external storage: never followed) or holds more data than half of the memory
    available here (what the readers may read whole)."""
    bad = []

    def visit(name, link):
        if isinstance(link, (h5py.ExternalLink, h5py.SoftLink)):
            bad.append(f"link {name}")
    f.visititems_links(visit)
    total = 0
    if not bad:                  # datasets are reached through the links: none followed
        for name in _datasets(f):
            ds = f[name]
            if ds.is_virtual:
                bad.append(f"virtual dataset {name}")
            elif ds.external:
                bad.append(f"external storage in {name}")
            total += ds.size * ds.dtype.itemsize
    if bad:
        more = f" and {len(bad) - NAMED_AT_MOST} more" if len(bad) > NAMED_AT_MOST else ""
        raise FileFormatError(f"{path}: refers to other files "
                              f"({', '.join(cut(b) for b in bad[:NAMED_AT_MOST])}{more}); refused")
    avail = available_memory()
    if avail is not None and total > avail // 2:
        raise FileFormatError(f"{path}: holds {total / 2**30:.1f} GiB of data, more than half "
                              f"of the {avail / 2**30:.1f} GiB of memory available here")


def check_readable(path):
    """Open a file only if it is a cornerbif sweep's file this version can read
    (``open_checked``) holding what the readers need (``_check_contents``).

    Raises FileFormatError with a specific message otherwise; never opens any
    other file (external links, external storage and virtual datasets are refused).
    """
    f = open_checked(path)
    try:
        for req in ("status", "done", "initial"):
            if req not in f:
                raise FileFormatError(f"{path}: required dataset {req!r} is missing")
        if not isinstance(f["initial"], h5py.Group) or not len(f["initial"]):
            raise FileFormatError(f"{path}: required group 'initial' (a start coordinate per "
                                  "dataset) is missing or empty")
        _check_contents(path, f)
    except FileFormatError:
        f.close()
        raise
    except Exception as e:  # noqa: BLE001
        f.close()
        raise FileFormatError(f"{path}: damaged file ({error_line(e, path)})") from None
    return f


# what the readers (plot, info) need of each summary dataset: its kind of dtype
SUMMARY_KINDS = {"status": "i", "period": "iu", "impacts_per_cycle": "iu", "done": "iu",
                 "symbols": "S"}


def _check_contents(path, f):
    """Refuse, before anything is read, a file whose contents the readers cannot take: a
    ``scene`` attribute that is not a scene's TOML, summary datasets of the wrong kind or
    of shapes that do not match the grid (its size: ``open_checked``)."""
    try:
        scene = tomllib.loads(str(f.attrs.get("scene", "")))
        model = scene["scene"]["model"]
    except (tomllib.TOMLDecodeError, KeyError, TypeError):
        raise FileFormatError(f"{path}: its scene attribute is not a cornerbif scene "
                              "(TOML with a [scene] table)") from None
    if model not in registry.models():
        raise FileFormatError(f"{path}: model {model!r} is not one this cornerbif knows "
                              f"({', '.join(registry.models())})")
    for name, kinds in SUMMARY_KINDS.items():
        if name in f and f[name].dtype.kind not in kinds:
            raise FileFormatError(f"{path}: dataset {name!r} has dtype {f[name].dtype}, "
                                  "not what cornerbif writes")
    G = f["done"].shape
    # the start coordinates (the model's; the group also holds its copies of the scales)
    group = f.get("initial")
    starts = ([f"initial/{c}" for c, d in group.items()
               if isinstance(d, h5py.Dataset) and not d.is_scale]
              if isinstance(group, h5py.Group) else [])
    for name in ("status", "period", "impacts_per_cycle", "symbols", *starts):
        if name in f and f[name].shape[:len(G)] != G:
            raise FileFormatError(f"{path}: dataset {name!r} has shape {f[name].shape}, "
                                  f"which does not match the grid {G}")


def check_stored_plot(path, scene_text):
    """Refuse, before a figure draws it, a file whose stored scene's ``[plot]`` the figures
    cannot take (``plot.check_together``; ``info`` reads the file whatever it says), by the
    checks ``validate`` makes (``config._read_plot``: a marker size of 1e300 had a figure run for
    minutes before matplotlib failed), naming the file and the key.  Its other tables are
    not judged here (the file holds what they computed), nor ``plot.style``, which names a
    file seen from where the sweep ran and is checked when the figure applies it, nor
    ``plot.color_by``, applied by a figure only where the file holds its datasets
    (``plot.scene_color_by``)."""
    try:
        loads(scene_text)
    except SceneError as e:
        bad = [p for p in e.problems if p.startswith("plot.")
               and not p.startswith(("plot.style", "plot.color_by"))]
        if bad:
            raise FileFormatError(f"{path}: its stored scene's [plot] cannot be drawn: "
                                  + "; ".join(bad[:3])) from None
    except Exception:  # noqa: BLE001 - the scene's other troubles are the readers' to say
        pass


def available_memory():
    """Bytes this process may still take: the machine's available memory (``MemAvailable``)
    or, where less, what an address-space limit (``ulimit -v``, RLIMIT_AS) leaves above the
    process's present size (``VmSize``); None where neither can be read."""
    found = [_proc_kib("/proc/meminfo", "MemAvailable:")]
    try:
        limit = resource.getrlimit(resource.RLIMIT_AS)[0]
    except (OSError, ValueError):
        limit = resource.RLIM_INFINITY
    size = _proc_kib("/proc/self/status", "VmSize:")
    if limit != resource.RLIM_INFINITY and size is not None:
        found.append(max(0, limit - size))
    found = [x for x in found if x is not None]
    return min(found) if found else None


def _proc_kib(path, key):
    """The value in bytes of the line ``key ... kB`` of a /proc file, or None."""
    try:
        with open(path) as fh:
            for line in fh:
                if line.startswith(key):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def _datasets(f):
    out = []
    f.visititems(lambda n, o: out.append(n) if isinstance(o, h5py.Dataset) else None)
    return out


def versions():
    import numba  # start-up: loads numba
    return {"numpy": np.__version__, "numba": numba.__version__, "h5py": h5py.__version__,
            "python": sys.version.split()[0]}


# ------------------------------------------------------------------ the sweep's file
# The lifecycle of a sweep's output: OUT.h5.partial is created with every dataset
# (``open_partial``), written block by block (``write_block``, ``write_pending``),
# reopened by --resume (``reopen``; rebuilt from a killed writer's file by
# ``rebuild``) and renamed to OUT.h5 once every block is done (``finish``).
def open_partial(partial, scene, command=""):
    """Set a new partial file up under a temporary name: a partial file exists only once
    every dataset is in place and single-writer/multiple-reader mode is on."""
    init = partial + ".init"
    ensure_room(init, 2 * len(scene.text), what="a new file", reserve=CREATE_RESERVE,
                then="nothing was computed; free space and run the same command again")
    outputs.fresh_file(init, (outputs.HDF5_SIGNATURE,))   # never written through a link
    with create(init, scene, scene.n_ic, command=command, versions=versions()):
        pass
    os.replace(init, partial)
    # opened again under its own name (messages name the file that exists), then
    # single-writer/multiple-reader mode before the first block is written
    f = h5py.File(partial, "r+", libver="latest")
    f.swmr_mode = True
    return f


def reopen(partial, scene):
    """Open an interrupted sweep's partial file for writing.

    A file whose writer was killed keeps HDF5's "open for writing" flags; it still
    opens read-only in SWMR mode, so its finished points are copied into a fresh
    partial file, which replaces it.
    """
    try:
        f = h5py.File(partial, "r+", libver="latest")
    except OSError:
        f = rebuild(partial, scene)
    if not _same_scene(f, scene):
        where = _scene_difference(f, scene)
        f.close()
        raise SweepError(f"{partial}: the scene differs from the one this file was started with"
                         f"{where}; --resume needs the same scene ([plot] aside), or "
                         "--overwrite to start again")
    f.swmr_mode = True
    return f


def _same_scene(f, scene) -> bool:
    """Whether an open file was started from ``scene``, ``[plot]`` aside."""
    return f.attrs.get("scene_hash") == scene.hash or same_run(str(f.attrs.get("scene", "")),
                                                               scene.text)


def scene_difference(text_a, text_b) -> str:
    """Where two scene texts differ, in words for a message: ' (system.omega: 1.999 there,
    2.001 here)', or '' when nothing does (``config.scene_difference``)."""
    d = what(text_a, text_b)
    return f" ({d})" if d else ""


def _scene_difference(f, scene) -> str:
    return scene_difference(str(f.attrs.get("scene", "")), scene.text)


def partial_state(path):
    """What lies at a sweep's partial file name: ("none", None) nothing; ("sweep", scene
    text) a cornerbif sweep's partial file (a writer killed in it leaves it readable in
    single-writer/multiple-reader mode); ("damaged", None) an HDF5 file that cannot be read
    (a sweep's, cut short: only ``--overwrite`` may replace it); ("foreign", None) anything
    else (not a regular file, not HDF5, another format): never touched."""
    if not os.path.lexists(path):
        return "none", None
    if os.path.islink(path) or outputs.not_a_regular_file(path):
        return "foreign", None
    try:
        if not h5py.is_hdf5(path):
            return ("damaged", None) if os.path.getsize(path) == 0 else ("foreign", None)
        with _open_read(path) as f:
            fmt = f.attrs.get("format")
            if fmt != outputs.SWEEP_FORMAT:
                return "foreign", None
            return "sweep", str(f.attrs.get("scene", ""))
    except Exception:  # noqa: BLE001 - HDF5 that cannot be read: cut short
        return "damaged", None


def partial_scene(path):
    """The scene text of a sweep's partial file at ``path``, or None (``partial_state``)."""
    kind, text = partial_state(path)
    return text if kind == "sweep" else None


def rebuild(partial, scene):
    """Copy the finished points of a killed writer's partial file into a fresh one.

    A source that cannot be read is refused (start again with --overwrite); a copy that
    cannot be written (no room) leaves the partial file as it was, to resume once there
    is room."""
    try:
        src = h5py.File(partial, "r", swmr=True, locking=False)
    except OSError as e:
        raise SweepError(f"{partial}: cannot be read to resume ({e}); start again with "
                         "--overwrite") from None
    tmp = partial + ".rebuild"
    try:
        outputs.fresh_file(tmp, (outputs.HDF5_SIGNATURE,))   # never written through a link
        ensure_room(tmp, os.path.getsize(partial))
        return _copy_done(src, partial, scene, tmp)
    except SweepError:
        _remove(tmp)
        raise
    except (OSError, RuntimeError) as e:       # writing the copy failed: keep the partial file
        _remove(tmp)
        raise WriteFailed(f"{partial}: resuming needs a copy of its finished points, and "
                          f"writing it failed ({reason(e)}); the partial file is kept as it "
                          "was: free space and run the same command with --resume",
                          broken=True) from None
    except Exception as e:  # noqa: BLE001
        _remove(tmp)
        raise SweepError(f"{partial}: cannot be read to resume ({e}); start again with "
                         "--overwrite") from None


def _remove(path):
    try:
        os.remove(path)
    except OSError:
        pass


def _copy_done(src, partial, scene, tmp):
    with src:
        if not _same_scene(src, scene):
            raise SweepError(f"{partial}: the scene differs from the one this file was started "
                             f"with{_scene_difference(src, scene)}; --resume needs the same "
                             "scene ([plot] aside), or --overwrite to start again")
        dst = create(tmp, scene, scene.n_ic, command=src.attrs.get("command", ""),
                     versions=versions())
        dst.attrs["created"] = src.attrs.get("created", "")
        names = _datasets(dst)
        scales = {a.name for a in scene.axes} | {"ic", "record"}
        G0 = scene.shape[0] if scene.shape else 1
        step = max(1, G0 // 64)
        for name in names:
            if name in scales or name not in src or dst[name].is_scale:
                continue
            if not scene.shape:
                dst[name][...] = src[name][...]
                continue
            for a in range(0, G0, step):
                dst[name][a:a + step] = src[name][a:a + step]
        dst.close()
    os.replace(tmp, partial)
    return h5py.File(partial, "r+", libver="latest")


def unfinished(every, f):
    """The positions in ``every`` (a list of blocks) of the blocks not yet marked done."""
    done = f["done"][...]
    return [i for i, b in enumerate(every) if not np.all(done[b])]


def write_pending(f, pending):
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
        write_block(f, blk, {n: np.concatenate([block[n] for _, block in items], axis=0)
                             for n in items[0][1]})
    else:
        for item in items:
            write_block(f, *item)


def read_block(f, blk, names):
    """The datasets ``names`` of slab ``blk`` as written (a followed sweep's carry on resume)."""
    return {n: f[n][blk] for n in names}


def _amend(partial, dest, change, after=None):
    """Apply ``change`` (a function of the file, open for writing) to a copy of a closed
    partial file and move the copy to ``dest``.

    Outside single-writer/multiple-reader mode HDF5 leaves a file it was writing when
    killed unreadable; the partial file itself is therefore only ever written in that mode,
    and a kill, an interrupt or a full disk during the change leaves it as it was, to
    resume (an interrupt is raised between two of h5py's calls into HDF5, never inside
    one, so the copy it cuts is closed and removed cleanly).  A write that fails inside
    HDF5 leaves this process's HDF5 state unusable, so it is reported as
    ``WriteFailed(broken=True)``: the command ends at once, without HDF5's clean-up, which
    can crash on such a state.  The rename and ``after`` (a function of nothing, run right
    after it) run with SIGINT and SIGTERM deferred, so the rename and what follows it
    happen together or not at all."""
    tmp = partial + ".amend"
    ensure_room(tmp, os.path.getsize(partial), what="the finished file's copy")
    try:
        shutil.copyfile(partial, tmp)          # in the kernel where it can (sendfile)
    except BaseException:
        _remove(tmp)
        raise
    try:
        g = h5py.File(tmp, "r+")
    except (OSError, RuntimeError) as e:
        _remove(tmp)
        raise WriteFailed(f"finishing {partial} failed ({reason(e)}); every point is kept; "
                          "free space and run the same command with --resume") from None
    try:
        change(g)
        g.close()
    except (OSError, RuntimeError) as e:       # h5py raises either for a failed write
        _remove(tmp)
        raise WriteFailed(f"finishing {partial} failed ({reason(e)}); every point is kept "
                          f"in {partial}; free space and run the same command with "
                          "--resume", broken=True) from None
    except BaseException:
        g.close()
        _remove(tmp)
        raise
    with outputs.signals_deferred():
        os.replace(tmp, dest)
        if after is not None:
            after()


def remove_stale(path):
    """Remove a side file left by a kill after its work was done (a finished sweep's
    partial file)."""
    _remove(path)


def finish(partial, out_path, scene=None):
    """Stamp a complete partial file (its attractor table, completion time, status counts)
    and rename it (on a copy: ``_amend``)."""
    def stamp(g):
        if scene is not None:
            attractors.tabulate(g, scene)
            # the scene as finished: a resume may bring other [plot] settings (never other
            # computing ones: io.reopen checks), and the figure follows the latest
            g.attrs["scene"] = scene.text
            g.attrs["scene_hash"] = scene.hash
        g.attrs["completed"] = _now()
        if "failed_chunks" in g.attrs:        # left by an earlier distributed run
            del g.attrs["failed_chunks"]
        counts = np.bincount(g["status"][...].ravel().astype(np.int64) + 1, minlength=9)
        g.attrs["status_counts"] = str({S.NAMES.get(i - 1, "NOT_RUN"): int(c)
                                        for i, c in enumerate(counts) if c})
    # killed between the rename and the removal, OUT.h5 is whole and the partial file is
    # stale (--resume says the output is complete and removes it)
    _amend(partial, out_path, stamp, after=lambda: _remove(partial))


def record_failures(partial, failures):
    """The failed chunks of a distributed run, with their errors, on the partial file that
    --resume completes (attributes cannot be added in single-writer/multiple-reader mode)."""
    def note(g):
        g.attrs["failed_chunks"] = json.dumps(failures)
    _amend(partial, partial, note)


def reason(e: Exception) -> str:
    """An OSError in a few words (HDF5's messages carry a whole error stack)."""
    return outputs.reason(e)
