"""The HDF5 file: schema, incremental writing, reading, resume (DESIGN 5).

Layout (public, keep these names)::

    /                attrs: format = "cornerbif", format_version, cornerbif_version,
                     scene (TOML as run), scene_hash, created, completed, command,
                     numpy_version, numba_version, h5py_version, status_codes
    /<axis>          one dataset per swept parameter, a dimension scale
    /ic, /record     dimension scales
    /initial/u, v    G + (n_ic,)
    /impacts/t, u, v_in, v_out, corner_offset   G + (n_ic, record), NaN where absent
    /section/u, v    G + (n_ic, record)
    /status          G + (n_ic,) int8 (names in its attribute ``codes``)
    /period, /impacts_per_cycle   G + (n_ic,) int32
    /symbols         G + (n_ic,) fixed-length ASCII string (record // 2 bytes, NUL-padded)
    /final/u, v      G + (n_ic,): state at the last section crossed (what follow carries)
    /done            G uint8: 1 where the grid point is complete

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
import sys

import h5py
import numpy as np

from . import FORMAT_VERSION, __version__
from . import status as S

IMPACT_FIELDS = ("t", "u", "v_in", "v_out", "corner_offset")
SECTION_FIELDS = ("u", "v")
UNITS = {
    "t": ("time", "impact time t"),
    "u": ("length", "impact height u = z(t)"),
    "v_in": ("length/time", "velocity just before impact v-"),
    "v_out": ("length/time", "velocity just after impact v+ (law 5)"),
    "corner_offset": ("time", "signed offset of the impact to the nearest corner (t - t_k)"),
}


class FileFormatError(Exception):
    """A file this version cannot read; the message says why."""


def _now():
    return _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")


def create(path, scene, n_ic, command="", versions=None):
    """Create the partial file with every dataset allocated and its scales attached."""
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
    f.attrs["obstacle"] = scene.obstacle
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

    def make(name, shape, dtype, fill, scales, **attrs):
        nb = np.dtype(dtype).itemsize
        trailing = int(np.prod(shape[len(G):])) if len(shape) > len(G) else 1
        per = max(1, (256 * 1024) // max(1, trailing * nb))
        ch = [1] * len(G) + list(shape[len(G):])
        if G:
            ch[len(G) - 1] = min(G[-1], per)
        kw = dict(chunks=tuple(ch) if shape else None)
        ds = f.create_dataset(name, shape=shape, dtype=dtype, fillvalue=fill,
                              compression="gzip", compression_opts=4, shuffle=True, **kw)
        for i, sc in enumerate(scales):
            ds.dims[i].attach_scale(sc)
        for k, v in attrs.items():
            ds.attrs[k] = v
        return ds

    gsc = list(dims)
    make("initial/u", G + (n_ic,), "f8", np.nan, gsc + [ic], long_name="initial position u(0)")
    make("initial/v", G + (n_ic,), "f8", np.nan, gsc + [ic], long_name="initial velocity v(0)")
    if "impacts" in scene.keep:
        for fld in IMPACT_FIELDS:
            units, ln = UNITS[fld]
            make(f"impacts/{fld}", G + (n_ic, rec), "f8", np.nan, gsc + [ic, recd],
                 units=units, long_name=ln)
    if "section" in scene.keep:
        make("section/u", G + (n_ic, rec), "f8", np.nan, gsc + [ic, recd],
             long_name="u at the Poincare section t = nT")
        make("section/v", G + (n_ic, rec), "f8", np.nan, gsc + [ic, recd],
             long_name="v at the Poincare section t = nT")
    if scene.model == "two_particle":
        # section 6: the heavy particle z (velocity y) and the wall-particle impacts
        make("initial/z", G + (n_ic,), "f8", np.nan, gsc + [ic], long_name="initial z(0)")
        make("initial/y", G + (n_ic,), "f8", np.nan, gsc + [ic], long_name="initial y(0) = z'(0)")
        make("final/z", G + (n_ic,), "f8", np.nan, gsc + [ic], long_name="z at the last section")
        make("final/y", G + (n_ic,), "f8", np.nan, gsc + [ic], long_name="y at the last section")
        if "section" in scene.keep:
            make("section/z", G + (n_ic, rec), "f8", np.nan, gsc + [ic, recd],
                 long_name="z at the Poincare section t = n 2 pi/omega0")
            make("section/y", G + (n_ic, rec), "f8", np.nan, gsc + [ic, recd],
                 long_name="y at the Poincare section")
        if "wall_impacts" in scene.keep:
            for fld, ln in (("t", "wall-particle impact time"), ("z", "impact height z = w"),
                            ("y_in", "velocity of z before the impact"),
                            ("y_out", "velocity of z after the impact (law 5, r1)")):
                make(f"wall_impacts/{fld}", G + (n_ic, rec), "f8", np.nan, gsc + [ic, recd],
                     long_name=ln)
    make("final/u", G + (n_ic,), "f8", np.nan, gsc + [ic],
         long_name="u at the last section crossed (the state a followed sweep carries on)")
    make("final/v", G + (n_ic,), "f8", np.nan, gsc + [ic],
         long_name="v at the last section crossed")
    make("status", G + (n_ic,), "i1", -1, gsc + [ic],
         codes=json.dumps({str(k): v for k, v in S.NAMES.items()}),
         long_name="how the run ended (-1: not run)")
    make("period", G + (n_ic,), "i4", 0, gsc + [ic],
         long_name="clusters per cycle (Poincare-map iterates near omega = 2); 0: none found")
    make("impacts_per_cycle", G + (n_ic,), "i4", 0, gsc + [ic], long_name="impacts per cycle")
    # fixed length (no global heap): a period needs two cycles in the window, so at
    # most record // 2 letters; stays consistent for readers of an interrupted file
    make("symbols", G + (n_ic,), symbol_dtype(rec), b"", gsc + [ic],
         long_name="cycle word: a alpha, b beta, g gamma, x other; smallest rotation")
    d = f.create_dataset("done", shape=G, dtype="u1", fillvalue=0,
                         chunks=(tuple([1] * (len(G) - 1) + [min(G[-1], 65536)]) if G else None))
    for i, sc in enumerate(gsc):
        d.dims[i].attach_scale(sc)
    d.attrs["long_name"] = "1 where the grid point is complete"
    return f


def symbol_dtype(record):
    """Fixed-length ASCII dtype of the ``symbols`` dataset."""
    return h5py.string_dtype("ascii", max(1, record // 2))


def write_block(f, index, block):
    """Write one finished block (a slab of the grid) and mark it done, flushing in order."""
    for name, arr in block.items():
        if name in f:
            f[name][index] = arr
    f.flush()
    f["done"][index] = 1
    f.flush()


def check_readable(path):
    """Open a file only if it is a cornerbif file this version can read.

    Raises FileFormatError with a specific message otherwise; never opens any
    other file (external links, external storage and virtual datasets are refused).
    """
    if not os.path.exists(path):
        raise FileFormatError(f"{path}: no such file")
    if os.path.getsize(path) == 0:
        raise FileFormatError(f"{path}: the file is empty")
    if not h5py.is_hdf5(path):
        raise FileFormatError(f"{path}: not an HDF5 file")
    try:
        f = h5py.File(path, "r", locking=False)
    except Exception as e0:  # noqa: BLE001 - h5py raises a zoo of errors for damaged files
        if "already open for write" not in str(e0):
            raise FileFormatError(f"{path}: cannot be opened as HDF5 ({e0})") from None
        try:
            # a sweep killed while writing leaves HDF5's "open for writing" flags set;
            # its single-writer/multiple-reader layout still reads consistently
            f = h5py.File(path, "r", swmr=True, locking=False)
        except Exception as e:  # noqa: BLE001
            raise FileFormatError(f"{path}: cannot be opened as HDF5 ({e})") from None
    try:
        if f.attrs.get("format") != "cornerbif":
            raise FileFormatError(f"{path}: not a cornerbif file (root attribute format is "
                                  f"{f.attrs.get('format')!r})")
        ver = int(f.attrs.get("format_version", -1))
        if ver > FORMAT_VERSION:
            raise FileFormatError(f"{path}: format version {ver} is newer than this cornerbif "
                                  f"reads ({FORMAT_VERSION}); upgrade cornerbif")
        bad = []

        def visit(name, link):
            if isinstance(link, (h5py.ExternalLink, h5py.SoftLink)):
                bad.append(f"link {name}")
        f.visititems_links(visit)
        for name in _datasets(f):
            ds = f[name]
            if ds.is_virtual:
                bad.append(f"virtual dataset {name}")
            elif ds.external:
                bad.append(f"external storage in {name}")
        if bad:
            raise FileFormatError(f"{path}: refers to other files ({', '.join(bad)}); refused")
        for req in ("status", "done", "initial/u"):
            if req not in f:
                raise FileFormatError(f"{path}: required dataset {req!r} is missing")
    except FileFormatError:
        f.close()
        raise
    except Exception as e:  # noqa: BLE001
        f.close()
        raise FileFormatError(f"{path}: damaged file ({e})") from None
    return f


def _datasets(f):
    out = []
    f.visititems(lambda n, o: out.append(n) if isinstance(o, h5py.Dataset) else None)
    return out


def versions():
    import numba
    return {"numpy": np.__version__, "numba": numba.__version__, "h5py": h5py.__version__,
            "python": sys.version.split()[0]}
