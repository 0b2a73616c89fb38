"""Whole chunks compressed by the writer itself and written past HDF5's filter pipeline.

The per-event datasets are the bulk of a sweep's file, and compressing them took the
writer longer than the kernel took to compute them (zlib, even at level 1, deflates about
0.3 GB/s).  A slab that covers whole chunks of a dataset is therefore shuffled and
deflated here and handed to HDF5 as finished chunks (``write_direct_chunk``): chunks in
the format of the dataset's own filters (HDF5's shuffle, then a zlib stream, as its
deflate filter writes one), readable by any HDF5 reader (h5py, xarray, netCDF, HDFView)
with no plugin, but deflated by ISA-L
(the ``isal`` package) when it is installed, at about 1.5 GB/s for the same size as
zlib's level 1 (``benchmarks/compression.py`` measures the trade).  Chunks a slab
covers only in part (its ragged ends: a followed slab, a ``--block-points`` that is
not a whole number of chunks, a file of another layout) go through HDF5 as before.

Blocks are laid out as whole numbers of chunks (``engine.event_chunk_points``), so a
sweep's blocks take the direct path everywhere but at the grid's last edge.
"""

from __future__ import annotations

import itertools
import zlib

import h5py
import numpy as np

from ._jit import jit

try:                                  # ISA-L: the same deflate streams, several times faster
    from isal import isal_zlib as _deflate
    DEFLATE = "isal"
except ImportError:                   # pragma: no cover - isal is a dependency
    _deflate = zlib
    DEFLATE = "zlib"

LEVEL = 1     # deflate level of the files written (HDF5's own writes use it too)


def shuffle(buf: np.ndarray) -> np.ndarray:
    """HDF5's shuffle filter (H5Z_FILTER_SHUFFLE) on a contiguous chunk: byte j of every
    element first, for j = 0 .. itemsize - 1."""
    size = buf.dtype.itemsize
    if size == 1 or buf.size <= 1:
        return buf.reshape(-1).view(np.uint8)
    out = np.empty(buf.nbytes, np.uint8)
    _shuffle_bytes(buf.reshape(-1).view(np.uint8), size, out)
    return out


@jit
def _shuffle_bytes(raw, size, out):
    """``out[j * n + i] = raw[i * size + j]`` for the n elements of ``size`` bytes in ``raw``,
    without the GIL (beside the kernels).  The 8- and 4-byte elements of the per-event
    datasets take loops written out for their size, about 3 times faster than numpy's
    transposed copy of the (n, size) bytes; other sizes (the words) a generic loop."""
    n = raw.size // size
    if size == 8:
        for i in range(n):
            b = 8 * i
            out[i] = raw[b]
            out[n + i] = raw[b + 1]
            out[2 * n + i] = raw[b + 2]
            out[3 * n + i] = raw[b + 3]
            out[4 * n + i] = raw[b + 4]
            out[5 * n + i] = raw[b + 5]
            out[6 * n + i] = raw[b + 6]
            out[7 * n + i] = raw[b + 7]
    elif size == 4:
        for i in range(n):
            b = 4 * i
            out[i] = raw[b]
            out[n + i] = raw[b + 1]
            out[2 * n + i] = raw[b + 2]
            out[3 * n + i] = raw[b + 3]
    else:
        for j in range(size):
            for i in range(n):
                out[j * n + i] = raw[i * size + j]


class Layout:
    """What writing slabs of a dataset needs to know of it, read from HDF5 once (each
    property of an h5py dataset is a call into HDF5; a sweep writes ~20 datasets a block):
    the dataset, its shape, dtype, chunk shape, fill value, whether it shuffles, and its
    deflate level when its filters are shuffle and deflate alone (else None)."""

    __slots__ = ("ds", "shape", "dtype", "chunks", "fill", "shuffle", "level")

    def __init__(self, ds: h5py.Dataset):
        self.ds = ds
        self.shape, self.dtype, self.chunks = ds.shape, ds.dtype, ds.chunks
        self.fill, self.shuffle = ds.fillvalue, ds.shuffle
        plain = (self.chunks is not None and ds.compression == "gzip" and not ds.fletcher32
                 and ds.scaleoffset is None)
        self.level = int(ds.compression_opts) if plain else None


def deflate_level(ds, arr: np.ndarray, grid_axes: int):
    """The deflate level with which whole chunks of ``ds`` (a dataset or its ``Layout``)
    may be written here, or None when they may not: the dataset must be chunked only along
    the last grid axis (extent 1 on the others, whole along the trailing axes), filtered
    by nothing but shuffle and deflate, and of ``arr``'s dtype (numbers or fixed-length
    strings)."""
    lay = ds if isinstance(ds, Layout) else Layout(ds)
    ch = lay.chunks
    if (lay.level is None or arr.dtype != lay.dtype or arr.dtype.kind not in "fiuS"
            or grid_axes == 0):
        return None
    if any(c != 1 for c in ch[:grid_axes - 1]) or tuple(ch[grid_axes:]) != lay.shape[grid_axes:]:
        return None
    return lay.level


def compress(chunk: np.ndarray, shuffled: bool, level: int) -> bytes:
    """The stored bytes of one chunk: shuffled (if the dataset shuffles), then deflated
    (zlib stream, as HDF5's deflate filter writes it)."""
    data = shuffle(chunk) if shuffled else chunk.reshape(-1).view(np.uint8)
    if DEFLATE == "isal":
        level = min(level, 3)         # ISA-L's levels are 0 .. 3
    return _deflate.compress(data, level)


class Slab:
    """A slab of a dataset ready to be written: the chunks it covers whole, compressed here
    (``direct``: (chunk offset, stored bytes)), and its ragged ends, which go through
    HDF5 (``ragged``: (index, array)).  ``nbytes`` bounds what writing it adds to the
    file (the compressed chunks, the ragged ends uncompressed), so that the room for a
    block is checked against what it will take, not its size in memory."""

    __slots__ = ("lay", "direct", "ragged")

    def __init__(self, lay, direct, ragged):
        self.lay, self.direct, self.ragged = lay, direct, ragged

    @property
    def nbytes(self) -> int:
        return (sum(len(b) for _, b in self.direct)
                + sum(np.asarray(a).nbytes for _, a in self.ragged))

    def write(self) -> None:
        ds = self.lay.ds
        for index, arr in self.ragged:
            ds[index] = arr
        for offset, data in self.direct:
            ds.id.write_direct_chunk(offset, data)


def prepare_slab(ds, index: tuple, arr) -> Slab:
    """``ds[index] = arr`` for a slab of the grid (``index``: one slice per grid axis;
    ``arr``: the slab's shape plus the dataset's trailing axes), prepared: every chunk the
    slab covers whole compressed here, to be written directly by ``Slab.write``.  ``ds``:
    the dataset, or its ``Layout`` (kept by a writer that writes it again)."""
    lay = ds if isinstance(ds, Layout) else Layout(ds)
    arr = np.asarray(arr)
    g = len(index)
    level = deflate_level(lay, arr, g)
    if level is None:
        return Slab(lay, [], [(index, arr)])
    extent = lay.chunks[g - 1]
    n = lay.shape[g - 1]
    a, b = index[-1].start, index[-1].stop
    first = -(-a // extent) * extent          # the first chunk boundary at or after a
    whole = []                                # (lo, hi) of the chunks covered whole
    lo = first
    while lo < b and min(lo + extent, n) <= b:
        whole.append((lo, min(lo + extent, n)))
        lo += extent
    if not whole:
        return Slab(lay, [], [(index, arr)])
    lead = index[:-1]
    head = (a, whole[0][0])
    tail = (whole[-1][1], b)
    ragged = []
    for lo, hi in (head, tail):               # the ragged ends, through HDF5
        if hi > lo:
            ragged.append((lead + (slice(lo, hi),),
                           arr[(slice(None),) * (g - 1) + (slice(lo - a, hi - a),)]))
    trailing = lay.shape[g:]
    fill = lay.fill
    zeros = (0,) * len(trailing)
    direct = []
    for pos in itertools.product(*[range(s.stop - s.start) for s in lead]):
        offset = tuple(s.start + p for s, p in zip(lead, pos))
        for lo, hi in whole:
            part = arr[pos + (slice(lo - a, hi - a),)]
            if hi - lo < extent:              # the grid's edge: HDF5 stores whole chunks
                full = np.full((extent,) + trailing, fill, lay.dtype)
                full[:hi - lo] = part
                part = full
            direct.append((offset + (lo,) + zeros,
                           compress(np.ascontiguousarray(part), lay.shuffle, level)))
    return Slab(lay, direct, ragged)


def write_slab(ds, index: tuple, arr) -> None:
    """``ds[index] = arr`` for a slab of the grid, with every chunk the slab covers whole
    compressed here and written directly (``prepare_slab``, then ``Slab.write``)."""
    prepare_slab(ds, index, arr).write()
