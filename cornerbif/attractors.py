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
    /attractors/share_low, share_high   (n,) the share's 95 % Wilson interval
                               (``basin_stats.share_interval``: right for rare basins) for
                               random starts; NaN for a grid of starts (a quadrature)
    /attractors/multiplier_re, multiplier_im   (n, m) its Floquet multipliers (the first
                               run's, when the file keeps ``stability``)
    /attractors/lyapunov, lyapunov_low, lyapunov_high   (n,) a chaotic attractor's largest
                               Lyapunov exponent and its 95 % interval (NaN for a cycle)
    /attractors/outcomes       (points, 6) runs at each parameter point: reaching an
                               attractor, then one column per code -1 .. -5
    /attractors/no_cycle       (points, 6) of the runs that keep NO_CYCLE, why they are on
                               no chaotic attractor (``chaos.REASONS``, attribute columns)

A run that ends well with no cycle in its record is tested for chaos (``chaos.find``: a
long rerun, recurrence on a grid, the Lyapunov exponent with its interval): a chaotic
attractor is a row of the table with word ``chaos.CHAOTIC`` and period 0, its runs take its
id; the others keep NO_CYCLE, "no cycle within the record".

Ids run over the table ordered by (parameter point, period, word, mean of a, mean of b):
they depend only on the runs' values, which do not depend on the thread count, the block
size, the backend or resumes, so the same scene writes the same ids.  The pass reads the
file in slabs (memory: one slab, and about 30 bytes per run for the ids and their
temporaries).
"""

from __future__ import annotations

import json

import numpy as np

from . import chaos
from . import status as S
from .basin_stats import share_interval
from .cycles import SIGNATURE, series_point, series_signature

NO_CYCLE = -1        # the run ended well but no cycle repeated twice in its recorded window
STICKS = -2          # sticking or chattering without end (STUCK, MAX_EVENTS)
ESCAPES = -3         # the amplitude escaped or a state was not finite (ESCAPED, NONFINITE)
FAILED = -4          # no impact, a start below the obstacle, or the root search's budget
NOT_RUN = -5         # the point was not computed
CODES = {NO_CYCLE: "no cycle within the record", STICKS: "sticks or chatters",
         ESCAPES: "escapes", FAILED: "no impact, below the obstacle, or search budget",
         NOT_RUN: "not run"}
# two runs on one cycle agree to the detection tolerance of each (period_tol): their
# signatures agree to a small multiple of it
MATCH_FACTOR = 100.0
# the kinds of a branch's end (``cornerbif.branches``), as the file stores and names them
BRANCH_END_KINDS = {
    "corner": "a corner collision",
    "grazing": "a grazing",
    "fold": "a fold",
    "period_doubling": "a period doubling",
    "torus": "a torus",
    "admissibility": "a loss of admissibility",
    "range": "the range's end",
    "no_orbit": "no periodic orbit on the far side",
    "unsampled": "not reached from the starts",
    "unlocated": "not located",
    "": "not located (a sweep of several parameters: see the branch's edges)",
}
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
    """The representatives found so far: one per attractor, in order of discovery (its
    serial).  Keys in a list, signatures, points, multipliers and run counts in arrays
    that grow by doubling."""

    def __init__(self, tol):
        self.tol = tol
        self.by_key = {}
        self.key = []
        self.n = 0
        self.sig = self.point = self.mult = self.runs = None

    def add_many(self, keys, sig, point, mult, runs):
        """New representatives (rows of ``sig``, ``point``, ``mult``: one each per key, the
        run counts ``runs``): their serials."""
        m, s0 = len(keys), self.n
        if self.sig is None:
            self.sig = np.empty((0,) + sig.shape[1:])
            self.point = np.empty((0,) + point.shape[1:])
            self.mult = None if mult is None else np.empty((0,) + mult.shape[1:], complex)
            self.runs = np.empty(0, np.int64)
        if s0 + m > self.runs.shape[0]:
            cap = max(2 * self.runs.shape[0], s0 + m, 64)
            self.sig, self.point, self.runs = (np.resize(a, (cap,) + a.shape[1:]) for a in
                                               (self.sig, self.point, self.runs))
            if self.mult is not None:
                self.mult = np.resize(self.mult, (cap,) + self.mult.shape[1:])
        self.sig[s0:s0 + m] = sig
        self.point[s0:s0 + m] = point
        if self.mult is not None:
            self.mult[s0:s0 + m] = mult
        self.runs[s0:s0 + m] = runs
        self.key.extend(keys)
        for s, key in enumerate(keys, s0):
            self.by_key.setdefault(key, []).append(s)
        self.n += m
        return np.arange(s0, s0 + m)

    def add(self, key, sig, point, mult, runs=0):
        """A new representative (one row's signature, point and multipliers): its serial."""
        return int(self.add_many([key], sig[None], point[None],
                                 None if mult is None else mult[None], runs)[0])

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


def _group_keys(pp, period, ipc, words):
    """The runs' keys (parameter point, period, impacts per cycle, word) grouped: the
    distinct keys in increasing order (a list of tuples, the word as bytes), each run's
    group, and the runs sorted by group (in the file's order within one)."""
    wu, wcode = np.unique(words, return_inverse=True)    # bytes order, as the words compare
    order = np.lexsort((wcode, ipc, period, pp))         # stable: the file's order in a key
    cols = [c[order] for c in (pp, period, ipc, wcode)]
    new = np.ones(order.size, bool)
    new[1:] = np.any([c[1:] != c[:-1] for c in cols], axis=0)
    starts = np.flatnonzero(new)
    inv = np.empty(order.size, np.int64)
    inv[order] = np.cumsum(new) - 1
    keys = list(zip(cols[0][starts].tolist(), cols[1][starts].tolist(),
                    cols[2][starts].tolist(), wu[cols[3][starts]].tolist()))
    return keys, inv, order


def tabulate(f, scene):
    """Build the attractor table of the finished file ``f`` (open for writing) and write it
    with every run's id (module doc); an earlier table is replaced."""
    spec = scene.spec
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
    point_of = np.empty(total, np.int64)
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
            ser[cyc] = _serials(reps, pp[cyc], period.ravel()[cyc], ipc.ravel()[cyc],
                                words.ravel()[cyc], sig.reshape(n, -1)[cyc],
                                point.reshape(n, -1)[cyc],
                                None if mult is None else mult.reshape(n, -1)[cyc])
        serial[pos:pos + n] = ser
        point_of[pos:pos + n] = pp
        pos += n
    lyap = _chaotic(f, scene, reps, serial, point_of, outcomes, stab)
    _write(f, scene, spec, reps, serial, outcomes, par_axes, runs_per_point, lyap)


def _chaotic(f, scene, reps, serial, point_of, outcomes, stab):
    """The chaotic attractors among the runs with no cycle (``chaos.find``) added to the
    table: their runs take their serials, their points' outcomes move from NO_CYCLE to
    attractors.  Returns their exponents by serial, (mean, low, high), and under
    "no_cycle" the counts per point of why the other runs are on none (``chaos.REASONS``)."""
    cand = np.flatnonzero(serial == NO_CYCLE)
    out = {}
    found, why = chaos.find(f, scene, cand, point_of[cand])
    reasons = np.zeros((outcomes.shape[0], len(chaos.REASONS)), np.int64)
    np.add.at(reasons, (point_of[cand][why >= 0], why[why >= 0]), 1)
    out["no_cycle"] = reasons
    for c in found:
        sig = series_signature(c.a, c.b)
        mult = (np.full(f["stability/multiplier_re"].shape[-1], complex(np.nan, np.nan))[None]
                if stab else None)
        s = int(reps.add_many([(c.point, 0, 0, chaos.CHAOTIC.encode())], sig[None],
                              np.array([series_point(c.a, c.b)]), mult,
                              np.array([c.runs.size]))[0])
        serial[c.runs] = s
        outcomes[c.point, 0] += c.runs.size
        outcomes[c.point, -NO_CYCLE] -= c.runs.size
        out[s] = (c.lyapunov, c.low, c.high)
    return out


def _serials(reps, pp, period, ipc, words, sig, point, mult):
    """The representatives' serials of a slab's runs that reached a cycle (in the file's
    order), new representatives added to ``reps`` as ``_Reps.match`` would add them run
    by run.

    The usual group, every run of a key within tolerance of its first run, is what
    ``match`` makes of a key not seen before: such groups become a representative each
    without a pass of their own, added together where they follow one another in the
    keys' order (the order in which ``match`` meets them)."""
    uniq, inv, order = _group_keys(pp, period, ipc, words)
    bounds = np.searchsorted(inv[order], np.arange(len(uniq) + 1))
    first = order[bounds[:-1]]
    ref = sig[first][inv]
    close = np.all(np.abs(sig - ref) <= reps.tol * (1.0 + np.abs(ref)), axis=-1)
    whole = np.bincount(inv, weights=~close, minlength=len(uniq)) == 0
    whole &= np.fromiter((key not in reps.by_key for key in uniq), bool, len(uniq))
    out = np.empty(pp.size, np.int64)
    serial_of = np.full(len(uniq), -1, np.int64)
    edges = np.flatnonzero(np.diff(np.r_[0, whole.view(np.int8), 0]))
    done_to = 0
    for a, b in list(zip(edges[::2], edges[1::2])) + [(len(uniq), len(uniq))]:
        for k in range(done_to, a):                 # [done_to, a): matched run by run
            rows = order[bounds[k]:bounds[k + 1]]
            out[rows] = reps.match(uniq[k], sig[rows], point[rows],
                                   None if mult is None else mult[rows])
        if b > a:                                   # [a, b): whole groups
            serial_of[a:b] = reps.add_many(uniq[a:b], sig[first[a:b]], point[first[a:b]],
                                           None if mult is None else mult[first[a:b]],
                                           np.diff(bounds)[a:b])
        done_to = b
    done = serial_of[inv] >= 0
    out[done] = serial_of[inv[done]]
    return out


def _write(f, scene, spec, reps, serial, outcomes, par_axes, runs_per_point, lyap):
    R = reps.n
    pts, period, ipc = (np.fromiter((k[i] for k in reps.key), np.int64, R) for i in range(3))
    words = np.array([k[3] for k in reps.key], dtype=f["symbols"].dtype)
    sig = reps.sig[:R] if R else np.empty((0, len(SIGNATURE)))
    # the table's order: parameter point, period, word, mean of a, mean of b, then serial
    rank = np.lexsort((np.arange(R), sig[:, 1], sig[:, 0], words, period, pts))
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
    runs = reps.runs[rank] if R else np.zeros(0, np.int64)
    frac = runs / runs_per_point
    pts = pts[rank]
    cols = {"id": np.arange(R, dtype=np.int32), "word": words[rank],
            "period": period[rank].astype(np.int32),
            "impacts_per_cycle": ipc[rank].astype(np.int32),
            "parameter_point": pts,
            "signature": sig[rank],
            "point": reps.point[rank] if R else np.empty((0, 2)),
            "runs": runs, "fraction": frac,
            "standard_error": np.sqrt(frac * (1.0 - frac) / runs_per_point)}
    if scene.start_axes:
        # a grid of starts: its share is a quadrature of the basin's area, not a sample of
        # independent starts; no sampling interval (``explain`` bounds it by the boundary)
        cols["share_low"] = cols["share_high"] = np.full(R, np.nan)
    else:
        cols["share_low"], cols["share_high"] = (np.asarray(v, float).reshape(R) for v in
                                                 share_interval(runs, runs_per_point))
    lam = np.full((R, 3), np.nan)
    for s, v in lyap.items():
        if s != "no_cycle":
            lam[s] = v
    lam = lam[rank]
    cols["lyapunov"], cols["lyapunov_low"], cols["lyapunov_high"] = lam[:, 0], lam[:, 1], lam[:, 2]
    if R and reps.mult is not None:
        m = reps.mult[rank]
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
    o = g.create_dataset("no_cycle", data=lyap["no_cycle"])
    o.attrs["columns"] = json.dumps(list(chaos.REASONS))


# ------------------------------------------------------------------ reading
def read_table(path_or_file):
    """The attractor table of a file as a dict of arrays (words as str), or None when the
    file has none (written before tables existed, or a model without cycle series)."""
    import h5py  # start-up: loads h5py
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



def _decoded(v):
    """Strings read from HDF5 as str (object array); other arrays as they are."""
    if v.dtype.kind in "SO":
        return np.array([s.decode() if isinstance(s, bytes) else str(s) for s in v],
                        dtype=object)
    return v


def read_branches(path_or_file):
    """The branch table of a file (``cornerbif explain``, ``cornerbif.branches``) as a dict
    of arrays (strings as str, ``axes`` the parameter axes, ``branch`` each attractor's), or
    None when the file has none."""
    import h5py  # start-up: loads h5py
    own = not isinstance(path_or_file, h5py.File)
    f = h5py.File(path_or_file, "r") if own else path_or_file
    try:
        if "branches" not in f or "attractors/branch" not in f:
            return None
        g = f["branches"]
        out = {}
        for k in g:
            out[k] = _decoded(g[k][...])
        out["axes"] = [a for a in str(g.attrs["axes"]).split(",") if a]
        out["branch"] = f["attractors/branch"][...]
        if "branch_edges" in f:
            out["edges"] = {k: _decoded(v[...]) for k, v in f["branch_edges"].items()}
        return out
    finally:
        if own:
            f.close()
