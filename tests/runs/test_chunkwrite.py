"""The writer's own chunk compression (cornerbif/chunkwrite.py) against HDF5's filters.

What the writer stores must be what HDF5's shuffle + deflate pipeline stores, read back
through that pipeline (h5py, no plugin) to the same values for every kind of slab: whole
chunks, ragged ends, the grid's edge chunk, several leading grid axes, a chunk that HDF5
itself wrote in part before (a resumed block), and datasets the direct path must leave to
HDF5 (other filters, strings).  The raw chunks are also decoded independently here
(zlib + a byte-by-byte unshuffle written out in Python), so the check does not rest on
the writer's own ``shuffle``.
"""

import zlib

import h5py
import numpy as np
import pytest

from cornerbif import chunkwrite


def _data(shape, seed=0):
    rng = np.random.default_rng(seed)
    a = rng.normal(size=shape)
    a[rng.random(shape) < 0.2] = np.nan
    a[..., ::3] = 1.25                 # repeated values, as a periodic orbit writes
    return a


def _dataset(f, name, grid, trailing, extent, **filters):
    shape = tuple(grid) + tuple(trailing)
    chunks = (1,) * (len(grid) - 1) + (extent,) + tuple(trailing)
    opts = dict(compression="gzip", compression_opts=chunkwrite.LEVEL, shuffle=True)
    opts.update(filters)
    return f.create_dataset(name, shape=shape, dtype="f8", fillvalue=np.nan, chunks=chunks,
                            **opts)


def _unshuffle_slow(raw, itemsize, count):
    """HDF5's unshuffle, one byte at a time: element i's byte j is raw[j * count + i]."""
    out = bytearray(itemsize * count)
    for i in range(count):
        for j in range(itemsize):
            out[i * itemsize + j] = raw[j * count + i]
    return bytes(out)


SLABS_1D = [(0, 37), (0, 16), (3, 13), (5, 8), (16, 37), (32, 37), (35, 37), (7, 37)]


@pytest.mark.parametrize("a,b", SLABS_1D)
def test_slab_reads_back_as_written_through_hdf5(tmp_path, a, b):
    """Grid of 37 points, chunks of 8: every slab (aligned, ragged both ends, inside one
    chunk, ending on the partial edge chunk) reads back exactly, and the rest of the grid
    keeps its fill value."""
    grid, trailing = (37,), (3, 5)
    arr = _data((b - a,) + trailing)
    with h5py.File(tmp_path / "d.h5", "w", libver="latest") as f:
        ds = _dataset(f, "x", grid, trailing, 8)
        chunkwrite.write_slab(ds, (slice(a, b),), arr)
    with h5py.File(tmp_path / "d.h5", "r") as f:
        got = f["x"][...]
    assert np.array_equal(got[a:b], arr, equal_nan=True)
    assert np.isnan(got[:a]).all() and np.isnan(got[b:]).all()


def test_whole_chunks_are_written_directly_and_decode_independently(tmp_path):
    """A slab of whole chunks is stored as finished chunks (filter mask 0) whose bytes are
    zlib streams of the shuffled values: decoded here without HDF5, they are the data."""
    grid, trailing, extent = (24,), (2, 7), 8
    arr = _data(grid + trailing, seed=3)
    with h5py.File(tmp_path / "d.h5", "w", libver="latest") as f:
        ds = _dataset(f, "x", grid, trailing, extent)
        chunkwrite.write_slab(ds, (slice(0, 24),), arr)
        for k in range(3):
            mask, raw = ds.id.read_direct_chunk((k * extent, 0, 0))
            assert mask == 0
            plain = _unshuffle_slow(zlib.decompress(raw), 8, extent * 14)
            assert np.array_equal(np.frombuffer(plain, "<f8").reshape((extent,) + trailing),
                                  arr[k * extent:(k + 1) * extent], equal_nan=True)


def test_same_values_as_hdf5s_own_filters(tmp_path):
    """The same slabs written by plain h5py (HDF5 shuffles and deflates) and by the
    writer: equal datasets, and file sizes within 10 % of each other."""
    grid, trailing = (6, 50), (4, 20)
    arr = _data(grid + trailing, seed=5)
    sizes = []
    for k, direct in enumerate((False, True)):
        path = tmp_path / f"{k}.h5"
        with h5py.File(path, "w", libver="latest") as f:
            ds = _dataset(f, "x", grid, trailing, 16)
            for i in range(6):
                for a, b in ((0, 32), (32, 50)):
                    idx = (slice(i, i + 1), slice(a, b))
                    if direct:
                        chunkwrite.write_slab(ds, idx, arr[idx])
                    else:
                        ds[idx] = arr[idx]
        sizes.append(path.stat().st_size)
        with h5py.File(path, "r") as f:
            assert np.array_equal(f["x"][...], arr, equal_nan=True)
    assert abs(sizes[1] / sizes[0] - 1) < 0.1, sizes


def test_two_leading_axes_and_a_resumed_chunk(tmp_path):
    """Slabs with several rows of a 2D grid, after HDF5 wrote part of a chunk itself (a
    block written before with another layout): the direct write replaces the whole chunk,
    the other chunks keep what was there."""
    grid, trailing = (3, 20), (2, 4)
    first = _data(grid + trailing, seed=7)
    second = _data(grid + trailing, seed=8)
    with h5py.File(tmp_path / "d.h5", "w", libver="latest") as f:
        ds = _dataset(f, "x", grid, trailing, 5)
        ds[:, 0:7] = first[:, 0:7]                        # HDF5 writes chunk 0 and part of 1
        _ = ds[:, 5:6]                                   # chunk 1 now in HDF5's cache
        chunkwrite.write_slab(ds, (slice(0, 3), slice(5, 20)), second[:, 5:20])
        got = ds[...]
    assert np.array_equal(got[:, :5], first[:, :5], equal_nan=True)
    assert np.array_equal(got[:, 5:], second[:, 5:], equal_nan=True)


@pytest.mark.parametrize("filters", [dict(compression="lzf", compression_opts=None),
                                     dict(compression=None, compression_opts=None, shuffle=False),
                                     dict(fletcher32=True)])
def test_other_filters_are_left_to_hdf5(tmp_path, filters):
    """A dataset filtered otherwise (lzf, none, a checksum) is written through HDF5."""
    grid, trailing = (20,), (3,)
    arr = _data(grid + trailing, seed=9)
    with h5py.File(tmp_path / "d.h5", "w", libver="latest") as f:
        ds = _dataset(f, "x", grid, trailing, 5, **filters)
        assert chunkwrite.deflate_level(ds, arr, 1) is None
        chunkwrite.write_slab(ds, (slice(0, 20),), arr)
        assert np.array_equal(ds[...], arr, equal_nan=True)


def test_fixed_length_strings_are_written_directly(tmp_path):
    """The cycle words (fixed-length ASCII): whole chunks written here, shuffled by the
    string's length, read back by HDF5 and decoded independently."""
    with h5py.File(tmp_path / "d.h5", "w", libver="latest") as f:
        ds = f.create_dataset("s", shape=(10, 2), dtype=h5py.string_dtype("ascii", 4),
                              chunks=(5, 2), compression="gzip", compression_opts=1,
                              shuffle=True, fillvalue=b"")
        words = np.array([[b"ab", b"bbg"], [b"g", b"abgb"]] * 5, dtype="S4")
        assert chunkwrite.deflate_level(ds, words, 1) == 1
        chunkwrite.write_slab(ds, (slice(0, 10),), words)
        assert (ds[...] == words).all()
        mask, raw = ds.id.read_direct_chunk((5, 0))
        plain = _unshuffle_slow(zlib.decompress(raw), 4, 10)
        assert np.frombuffer(plain, "S4").tolist() == words[5:].ravel().tolist()


def test_another_dtype_is_left_to_hdf5(tmp_path):
    with h5py.File(tmp_path / "d.h5", "w", libver="latest") as f:
        ds = _dataset(f, "y", (10,), (2,), 5)
        ints = np.arange(20, dtype=np.int32).reshape(10, 2)
        assert chunkwrite.deflate_level(ds, ints, 1) is None      # not the dataset's dtype
        chunkwrite.write_slab(ds, (slice(0, 10),), ints)
        assert np.array_equal(ds[...], ints)


@pytest.mark.parametrize("dtype", ["i1", "i2", "i4", "f4", "f8", "S7"])
def test_shuffle_is_hdf5s_byte_order_for_every_element_size(dtype):
    """The writer's shuffle (loops written out for 8 and 4 bytes, a generic one for the
    rest) undone by the byte-by-byte unshuffle above gives the elements back, on an odd
    number of elements (one-byte elements are left as they are)."""
    rng = np.random.default_rng(3)
    raw = rng.integers(0, 256, size=37 * np.dtype(dtype).itemsize, dtype=np.uint8)
    a = raw.view(dtype)
    size = a.dtype.itemsize
    shuffled = chunkwrite.shuffle(a).tobytes()
    assert len(shuffled) == raw.size
    assert _unshuffle_slow(shuffled, size, 37) == raw.tobytes()


def test_int32_chunks_are_written_directly_and_read_back_by_hdf5(tmp_path):
    """A per-run int32 dataset (period, impacts per cycle): whole chunks shuffled by the
    4-byte loop, unshuffled by HDF5's own filter on reading."""
    with h5py.File(tmp_path / "d.h5", "w", libver="latest") as f:
        ds = f.create_dataset("p", shape=(12, 3), dtype="i4", chunks=(4, 3), fillvalue=-1,
                              compression="gzip", compression_opts=1, shuffle=True)
        vals = np.random.default_rng(4).integers(-2**31, 2**31 - 1, size=(12, 3), dtype="i4")
        assert chunkwrite.deflate_level(ds, vals, 1) == 1
        chunkwrite.write_slab(ds, (slice(0, 12),), vals)
        assert np.array_equal(ds[...], vals)
