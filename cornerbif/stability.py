"""What every model's tangent dynamics shares (docs/stability.md): the status codes of a
cycle's multipliers and of a Lyapunov spectrum, the eigenvalues of a 2x2 or n x n monodromy,
the Gram-Schmidt (QR) step of a Lyapunov basis, the averaging window, and the outputs of the
``stability`` observable.

Each model's own steps through its flights and impacts are in its folder
(``models/<name>/tangent.py``); the flight and saltation matrices of the oscillator are in
``numerics.saltation``.
"""

import math

import numpy as np

from ._jit import jit

# how a cycle's multipliers were found (``stability/status`` in the file)
OK = 0
GRAZING = 1        # an impact with relative velocity ~0: the saltation diverges (NaN)
STICKING = 2       # the cycle sticks: its monodromy is zero, multipliers exactly (0, 0)
NO_CYCLE = 3       # no cycle of at least one impact in the record (NaN)
NO_WINDOW = 4      # fewer than two recorded impacts after the warm-up: no exponents (NaN)
PARTICLE_STICKS = 5  # two_particle: z on the wall or u on z, a partial collapse (NaN)
TABLE_FULL = 6     # two_particle: the w-z table filled before the window's end (NaN)
REASONS = {OK: "ok", GRAZING: "grazing impact (relative velocity ~0): none",
           STICKING: "sticks to the obstacle: multipliers exactly 0, exponents -inf",
           NO_CYCLE: "no cycle with impacts in the record: none",
           NO_WINDOW: "too few recorded impacts for exponents: none",
           PARTICLE_STICKS: "a particle sticks (z on the wall or u on z): partial collapse, "
                            "not derived: none",
           TABLE_FULL: "the w-z impact table filled before the window's end: none"}
# the share of a run's recorded impacts that aligns the Lyapunov basis before the exponents
# are averaged (docs/stability.md, "Lyapunov exponents")
WARMUP_SHARE = 0.25


@jit
def multipliers(j11, j12, j21, j22):
    """The eigenvalues of a real 2x2 matrix, sorted by decreasing modulus:
    (re1, im1, re2, im2).  The discriminant from the entries, ((j11 - j22)/2)^2 + j12 j21
    (not tr^2/4 - det, which cancels: a triangular matrix keeps real eigenvalues); the
    smaller real root as det / (larger), without cancellation."""
    tr = j11 + j22
    det = j11 * j22 - j12 * j21
    half = 0.5 * (j11 - j22)
    disc = half * half + j12 * j21
    if disc >= 0.0:
        s = math.sqrt(disc)
        big = 0.5 * tr + (s if tr >= 0.0 else -s)
        small = det / big if big != 0.0 else 0.0
        return big, 0.0, small, 0.0
    s = math.sqrt(-disc)
    return 0.5 * tr, s, 0.5 * tr, -s


@jit
def recorded_count(t):
    """The number of recorded events: the entries of ``t`` before the first NaN."""
    n = 0
    while n < t.shape[0] and t[n] == t[n]:
        n += 1
    return n


@jit
def lyapunov_window(steps, ipc, warmup_share):
    """The first step of the averaging window over ``steps`` recorded steps: after the
    warm-up (``warmup_share`` of them), trimmed to whole cycles of ``ipc`` steps ending at
    the last when the run has a cycle; -1 when no step is left."""
    w0 = int(warmup_share * steps)
    if steps - w0 < 1:
        return -1
    if ipc > 0 and (steps - w0) >= ipc:
        return steps - ((steps - w0) // ipc) * ipc
    return w0


@jit
def log_or_minus_inf(x):
    """log(x) for x > 0, -inf for x = 0 (an exact collapse: r = 0 makes det S = 0)."""
    return math.log(x) if x > 0.0 else -math.inf


def new_outputs(n):
    """The arrays of the ``stability`` observable for n items, keyed by the Fields'
    sources (``models.flow.model.STABILITY_FIELDS``), in the order the batch kernels fill them."""
    return {"mu_re": np.empty((n, 2)), "mu_im": np.empty((n, 2)),
            "cycle_duration": np.empty(n), "stability_status": np.empty(n, np.int8),
            "lyapunov": np.empty((n, 2)), "lyapunov_window": np.empty(n),
            "lyapunov_status": np.empty(n, np.int8)}


@jit
def store(i, mult, lyap, o_re, o_im, o_dur, o_status, o_lam, o_win, o_lstatus):
    """Item i's multipliers (re1, im1, re2, im2, duration, status) and Lyapunov spectrum
    (lambda1, lambda2, window, status) into the outputs."""
    re1, im1, re2, im2, dur, st = mult
    o_re[i, 0] = re1
    o_re[i, 1] = re2
    o_im[i, 0] = im1
    o_im[i, 1] = im2
    o_dur[i] = dur
    o_status[i] = st
    l1, l2, win, lst = lyap
    o_lam[i, 0] = l1
    o_lam[i, 1] = l2
    o_win[i] = win
    o_lstatus[i] = lst


@jit
def sort_nan_last(a):
    """Sort a short 1-d array in place, ascending, NaN last: what ``a.sort()`` does, by
    insertion (numba's sort compiles a quicksort: 0.8 s of a first compile for 4 values)."""
    for i in range(1, a.shape[0]):
        x = a[i]
        j = i - 1
        while j >= 0 and (a[j] != a[j] or (x == x and a[j] > x)):   # a[j] NaN, or larger
            a[j + 1] = a[j]
            j -= 1
        a[j + 1] = x


@jit
def gram_schmidt(A, logs):
    """Modified Gram-Schmidt on the columns of A in place (A <- Q); logs[i] += log R_ii."""
    n = A.shape[1]
    for a in range(n):
        for b in range(a):
            dot = 0.0
            for r in range(A.shape[0]):
                dot += A[r, b] * A[r, a]
            for r in range(A.shape[0]):
                A[r, a] -= dot * A[r, b]
        nrm = 0.0
        for r in range(A.shape[0]):
            nrm += A[r, a] * A[r, a]
        nrm = math.sqrt(nrm)
        if nrm == 0.0:
            logs[a] += -math.inf      # an exact collapse (r1 or r2 = 0): the column stays 0
            continue
        logs[a] += math.log(nrm)
        for r in range(A.shape[0]):
            A[r, a] /= nrm


@jit
def generic_basis(n):
    """A fixed orthonormal n x n basis aligned with no coordinate block (the Gram-Schmidt
    start of the Lyapunov spectrum)."""
    B = np.empty((n, n))
    for a in range(n):
        for b in range(n):
            B[a, b] = 1.0 / (1.0 + a + 2.0 * b) + (1.0 if a == b else 0.0)
    gram_schmidt(B, np.zeros(n))
    return B


def sorted_eigenvalues(J):
    """Eigenvalues of a stack of square matrices (..., n, n), by decreasing modulus (a
    conjugate pair: positive imaginary part first); NaN rows stay NaN."""
    J = np.asarray(J)
    out = np.full(J.shape[:-1], np.nan + 0j)
    ok = np.isfinite(J).all(axis=(-2, -1))
    if ok.any():
        w = np.linalg.eigvals(J[ok])
        order = np.lexsort((-w.imag, -np.abs(w)), axis=-1)
        out[ok] = np.take_along_axis(w, order, axis=-1)
    return out
