"""The attractor table of a file: every cycle the sweep found, named once.

A sweep's runs each end on a cycle (a word, a period, impacts per cycle) or on no cycle.
When the file is finished (``io.finish``) every run's cycle is matched against the
others at the same parameter point: two runs reach the same attractor when they have the
same word (its smallest rotation, ``analysis.detect_cycle``), period and impacts per
cycle, and the same signature over one cycle (``analysis.cycle_signature_one``: mean,
least and largest of the model's two cycle series, e.g. impact heights and velocities)
to ``MATCH_FACTOR * run.period_tol`` relative to 1 + |value|.  The signature does not
change under a shift along the cycle, so the shifted copies of one orbit (the paper's 2n
equivalent solutions, section 3.2) are one attractor.

The parameter point of a run is its grid index without the swept start coordinates
(``[sweep] initial.<c>``): a basin scene's cells all share one point, and its table
holds the attractors of that point with the share of cells each attracts.

Written to the file::

    /attractor                 G + (n_ic,) int32: the run's attractor id (a row of the
                               table), or a negative code (``CODES``)
    /attractors/id, word, period, impacts_per_cycle, parameter_point   (n,)
    /attractors/at_<axis>      (n,) the value of each swept parameter at its point
    /attractors/signature      (n, 6) its signature (``analysis.SIGNATURE``)
    /attractors/point          (n, 2) a point of the cycle (the model's ``CycleSeries``)
    /attractors/runs, fraction, standard_error   (n,) the runs it attracts, their share
                               of the runs at its point, and sqrt(f (1 - f) / runs there)
                               (the standard error of a share of independent random
                               starts; for a grid of starts, the share of the cells)
    /attractors/multiplier_re, multiplier_im   (n, m) its Floquet multipliers (the first
                               run's, when the file keeps ``stability``)
    /attractors/outcomes       (points, 6) runs at each parameter point: reaching an
                               attractor, then one column per code -1 .. -5

Ids run over the table ordered by (parameter point, period, word, mean of a, mean of b):
they depend only on the runs' values, which do not depend on the thread count, the block
size, the backend or resumes, so the same scene writes the same ids.  The pass reads the
file in slabs (memory: one slab, and about 30 bytes per run for the ids and their
temporaries).
"""

from __future__ import annotations

import json

import numpy as np

from . import registry
from . import status as S
from .analysis import SIGNATURE

NO_CYCLE = -1        # the run ended well but no cycle repeated twice in its recorded window
STICKS = -2          # sticking or chattering without end (STUCK, MAX_EVENTS)
ESCAPES = -3         # the amplitude escaped or a state was not finite (ESCAPED, NONFINITE)
FAILED = -4          # no impact, a start below the obstacle, or the root search's budget
NOT_RUN = -5         # the point was not computed
CODES = {NO_CYCLE: "no cycle within the budget", STICKS: "sticks or chatters",
         ESCAPES: "escapes", FAILED: "no impact, below the obstacle, or search budget",
         NOT_RUN: "not run"}
# two runs on one cycle agree to the detection tolerance of each (period_tol): their
# signatures agree to a small multiple of it
MATCH_FACTOR = 100.0
SLAB_RUNS = 1 << 17       # runs read at a time


def outcome_codes(status, period, signature):
    """Per run: 0 where it reached a cycle (period > 0 and a finite signature), else its
    negative code (``CODES``) from its status."""
    code = np.full(status.shape, FAILED, np.int32)
    code[status == S.OK] = NO_CYCLE
    code[(status == S.STUCK) | (status == S.MAX_EVENTS)] = STICKS
    code[(status == S.ESCAPED) | (status == S.NONFINITE)] = ESCAPES
    code[status < 0] = NOT_RUN
    cycle = (period > 0) & np.isfinite(signature).all(axis=-1)
    code[cycle] = 0
    return code


def parameter_points(shape, start_positions, lo, hi):
    """The flat parameter-point index (the grid without its start axes) of every run in
    the slab [lo, hi) of axis 0, shape slab + (n_ic,) without the ic axis."""
    slab = (hi - lo,) + tuple(shape[1:])
    idx = np.indices(slab)
    idx[0] += lo
    keep = [i for i in range(len(shape)) if i not in start_positions]
    if not keep:
        return np.zeros(slab, np.int64)
    return np.ravel_multi_index(tuple(idx[i] for i in keep), tuple(shape[i] for i in keep))


class _Reps:
    """The representatives found so far: one per attractor, in order of discovery."""

    def __init__(self, tol):
        self.tol = tol
        self.by_key = {}
        self.key, self.sig, self.point, self.runs, self.mult = [], [], [], [], []

    def add(self, key, sig, point, mult, runs=0):
        """A new representative (one row's signature, point and multipliers): its serial."""
        s = len(self.key)
        self.key.append(key)
        self.sig.append(sig.copy())
        self.point.append(point.copy())
        self.runs.append(runs)
        self.mult.append(None if mult is None else mult.copy())
        self.by_key.setdefault(key, []).append(s)
        return s

    def match(self, key, sig, point, mult):
        """Serial numbers of the representatives of rows ``sig`` (all with one key), new ones
        made from the first unmatched row in order (deterministic in the file's order)."""
        out = np.full(sig.shape[0], -1, np.int64)
        for s in self.by_key.get(key, []):
            self._claim(out, sig, s)
        while (out < 0).any():
            first = int(np.flatnonzero(out < 0)[0])
            s = self.add(key, sig[first], point[first], None if mult is None else mult[first])
            self._claim(out, sig, s)
        for s, c in zip(*np.unique(out, return_counts=True)):
            self.runs[s] += int(c)
        return out

    def _claim(self, out, sig, s):
        ref = self.sig[s]
        free = out < 0
        close = np.all(np.abs(sig - ref) <= self.tol * (1.0 + np.abs(ref)), axis=-1)
        out[free & close] = s


def tabulate(f, scene):
    """Build the attractor table of the finished file ``f`` (open for writing) and write it
    with every run's id (module doc); an earlier table is replaced."""
    spec = registry.get(scene.model)
    if spec.cycle is None or "cycle/signature" not in f:
        return
    G = scene.shape
    n_ic = scene.n_ic
    starts = {pos for pos, _ in scene.start_axes.values()}
    par_axes = [a for i, a in enumerate(scene.axes) if i not in starts]
    n_points = int(np.prod([a.array.size for a in par_axes])) if par_axes else 1
    runs_per_point = n_ic * int(np.prod([G[i] for i in starts])) if starts else n_ic
    reps = _Reps(MATCH_FACTOR * scene.period_tol)
    stab = "stability/multiplier_re" in f
    outcomes = np.zeros((n_points, 1 + len(CODES)), np.int64)
    total = int(np.prod(G)) * n_ic if G else n_ic
    serial = np.empty(total, np.int64)
    G0 = G[0] if G else 1
    row = max(1, total // G0)
    step = max(1, SLAB_RUNS // row)
    pos = 0
    for lo in range(0, G0, step):
        hi = min(G0, lo + step)
        sl = (slice(lo, hi),) if G else ()
        status = f["status"][sl]
        period = f["period"][sl]
        ipc = f["impacts_per_cycle"][sl]
        words = f["symbols"][sl]
        sig = f["cycle/signature"][sl]
        point = f["cycle/point"][sl]
        mult = (f["stability/multiplier_re"][sl] + 1j * f["stability/multiplier_im"][sl]
                if stab else None)
        pp = parameter_points(G, starts, lo, hi) if G else np.zeros((), np.int64)
        pp = np.broadcast_to(pp[..., None], status.shape).ravel()
        code = outcome_codes(status, period, sig).ravel()
        n = code.size
        ser = code.astype(np.int64)       # a representative's serial, or the code
        np.add.at(outcomes, (pp, np.where(code < 0, -code, 0)), 1)
        cyc = np.flatnonzero(code == 0)
        if cyc.size:
            keys = np.empty(cyc.size, dtype=[("p", "i8"), ("per", "i8"), ("ipc", "i8"),
                                             ("w", words.dtype)])
            keys["p"] = pp[cyc]
            keys["per"] = period.ravel()[cyc]
            keys["ipc"] = ipc.ravel()[cyc]
            keys["w"] = words.ravel()[cyc]
            uniq, inv = np.unique(keys, return_inverse=True)
            order = np.argsort(inv, kind="stable")
            bounds = np.searchsorted(inv[order], np.arange(uniq.size + 1))
            sig2 = sig.reshape(n, -1)
            pt2 = point.reshape(n, -1)
            m2 = mult.reshape(n, -1) if mult is not None else None
            # the usual group: every run of a key within tolerance of its first run (in the
            # file's order), which is what ``match`` makes of a key not seen before; such
            # groups become a representative each without a pass of their own
            first = cyc[order[bounds[:-1]]]
            ref = sig2[first][inv]
            close = np.all(np.abs(sig2[cyc] - ref) <= reps.tol * (1.0 + np.abs(ref)), axis=-1)
            whole = np.bincount(inv, weights=~close, minlength=uniq.size) == 0
            size = np.diff(bounds)
            serial_of = np.full(uniq.size, -1, np.int64)
            for k, key in enumerate(uniq.tolist()):
                if whole[k] and key not in reps.by_key:
                    serial_of[k] = reps.add(key, sig2[first[k]], pt2[first[k]],
                                            None if m2 is None else m2[first[k]],
                                            runs=int(size[k]))
                    continue
                rows = cyc[order[bounds[k]:bounds[k + 1]]]
                ser[rows] = reps.match(key, sig2[rows], pt2[rows],
                                       None if m2 is None else m2[rows])
            done = serial_of[inv] >= 0
            ser[cyc[done]] = serial_of[inv[done]]
        serial[pos:pos + n] = ser
        pos += n
    _write(f, scene, spec, reps, serial, outcomes, par_axes, runs_per_point)


def _write(f, scene, spec, reps, serial, outcomes, par_axes, runs_per_point):
    R = len(reps.key)
    rank = sorted(range(R), key=lambda s: (reps.key[s][0], reps.key[s][1], reps.key[s][3],
                                           float(reps.sig[s][0]), float(reps.sig[s][1]), s))
    ident = np.empty(R, np.int64)
    ident[rank] = np.arange(R)
    ids = np.where(serial >= 0, ident[np.maximum(serial, 0)] if R else 0,
                   serial).astype(np.int32)
    if "attractor" in f:                   # an earlier table: its scales let go first
        old = f["attractor"]
        for i, dim in enumerate(old.dims):
            for sc in list(dim.values()):
                old.dims[i].detach_scale(sc)
        del f["attractor"]
    if "attractors" in f:
        del f["attractors"]
    G = scene.shape
    d = f.create_dataset("attractor", data=ids.reshape(G + (scene.n_ic,)),
                         compression="gzip", compression_opts=1, shuffle=True)
    d.attrs["long_name"] = "the run's attractor (a row of /attractors) or a negative code"
    d.attrs["codes"] = json.dumps({str(k): v for k, v in CODES.items()})
    for i, a in enumerate(scene.axes):
        d.dims[i].attach_scale(f[a.name])
    d.dims[len(G)].attach_scale(f["ic"])
    g = f.create_group("attractors")
    g.attrs["match_tolerance"] = MATCH_FACTOR * scene.period_tol
    g.attrs["runs_per_point"] = runs_per_point
    keys = [reps.key[s] for s in rank]
    runs = np.array([reps.runs[s] for s in rank], np.int64)
    frac = runs / runs_per_point
    pts = np.array([k[0] for k in keys], np.int64)
    cols = {"id": np.arange(R, dtype=np.int32),
            "word": np.array([k[3] for k in keys], dtype=f["symbols"].dtype),
            "period": np.array([k[1] for k in keys], np.int32),
            "impacts_per_cycle": np.array([k[2] for k in keys], np.int32),
            "parameter_point": pts,
            "signature": np.array([reps.sig[s] for s in rank]).reshape(R, len(SIGNATURE)),
            "point": np.array([reps.point[s] for s in rank]).reshape(R, 2),
            "runs": runs, "fraction": frac,
            "standard_error": np.sqrt(frac * (1.0 - frac) / runs_per_point)}
    if R and reps.mult[rank[0]] is not None:
        m = np.array([reps.mult[s] for s in rank])
        cols["multiplier_re"], cols["multiplier_im"] = m.real, m.imag
    if par_axes:
        # at_<axis>, not <axis>: a dataset named as a root dimension of another length would
        # stop xarray from opening the group
        sub = np.unravel_index(pts, tuple(a.array.size for a in par_axes))
        for a, i in zip(par_axes, sub):
            cols[f"at_{a.name}"] = a.array[i]
    for name, arr in cols.items():
        g.create_dataset(name, data=arr)
    g["word"].attrs["_Encoding"] = "ascii"
    g["point"].attrs["names"] = json.dumps(spec.cycle.names)
    o = g.create_dataset("outcomes", data=outcomes)
    o.attrs["columns"] = json.dumps(["attractor"] + [CODES[-k] for k in range(1, 6)])


# ------------------------------------------------------------------ reading
def read_table(path_or_file):
    """The attractor table of a file as a dict of arrays (words as str), or None when the
    file has none (written before tables existed, or a model without cycle series)."""
    import h5py
    own = not isinstance(path_or_file, h5py.File)
    f = h5py.File(path_or_file, "r") if own else path_or_file
    try:
        if "attractors" not in f:
            return None
        g = f["attractors"]
        out = {k: g[k][...] for k in g}
        out["word"] = np.array([w.decode() if isinstance(w, bytes) else str(w)
                                for w in out["word"]], dtype=object)
        out["ids"] = f["attractor"][...]
        out["match_tolerance"] = float(g.attrs["match_tolerance"])
        out["runs_per_point"] = int(g.attrs["runs_per_point"])
        return out
    finally:
        if own:
            f.close()

