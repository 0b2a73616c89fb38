"""Local piecewise-linear maps alpha, beta, gamma near (omega, kappa) = (2, 0) (section 5, eqs 56-60).

State and parameters
--------------------
x = (a0, b1): the particle's position u and velocity u' at the Poincare section
t = nT, T = 2 pi/omega (section 3.3.1), scaled as in eqs (20)-(23).  The package
takes epsilon = 1, so

    omega1 = omega - 2,   kappa1 = kappa,   a0 = u(nT),   b1 = u'(nT),

and the maps below are the leading-order Poincare map of the flow with
z = kappa + |sin(omega t)| (beta = 1) and u'' + u = 0.  Write h = pi omega1/2.
Every map has the form (eq 57)

    x' = s [[1, 0], [h, 1]] x + P,     i.e.  a' = s a + P_a,  b' = s (h a + b) + P_b,

with s = r for beta and gamma and s = -r^2 for alpha, and

    P_beta  =  (1 + r) (2, h - kappa1)                       (eqs 34-35, 59)
    P_gamma = -(1 + r) (2, h + kappa1)                       (eqs 37-38, 59)
    P_alpha = (2 (1 + r)^2, h (1 + r)^2 + kappa1 (r^2 - 1))  (eqs 52-53; NOT the printed 58)

Regions (eq 56, 60): C = (pi omega1/4, 1), D = (1, 0), E = 2 + 4/r and
c(x) = C x - kappa1 = (pi omega1/4) a + b - kappa1 (evaluated in exactly this
order, so that every kernel takes the same decision bit for bit):

* ``c >= 0``            -> beta  (1): one impact just after the corner (tau1 >= 0, eq 36);
* ``c < 0 and a < E``   -> alpha (0): two impacts straddling the corner (eqs 54-55);
* ``c < 0 and a >= E``  -> gamma (2): one impact just before the corner (eqs 39, 41);
* anything else (a NaN in x or in the parameters) -> -1, and ``step`` returns NaN.

Points exactly on a switching line (the paper leaves them undefined, eq 56 has
strict inequalities only):

* c == 0 (Sigma_1, impact exactly at the corner, tau1 = 0) counts as beta.  This
  is the convention of :mod:`cornerbif.analysis`, where an impact with corner
  offset 0 is a ``b`` cluster (offset >= 0), and it matches the right-derivative
  rule at corners of the reference simulator.
* a == E (Sigma_2, grazing second impact, eq 40) counts as gamma: the grazing
  impact arrives with zero relative velocity, so law (5) leaves the velocity
  unchanged and the orbit is the one-impact (gamma) orbit; the alpha map's
  second-impact delay delta2 = r (kappa1 - C x)/(4 - r (a - 2)) diverges there.
  Both maps give A0 = 2 at a = E; B1 jumps by r (1 + r) (C x - kappa1)
  (the map is discontinuous across Sigma_2, as the paper notes in section 4.5).

Discrepancies with the printed equations
----------------------------------------
Re-derived from (25)-(26), (42)-(43) and law (5) at leading order in epsilon
(pi/omega = pi/2 - eps pi omega1/4, T = pi - eps pi omega1/2, the obstacle
slope is -2 before and +2 after the corner):

1. **P_alpha (eq 58) is wrong; (52)-(53) are right.**  The two impacts give
   v+ = (1+r) 2 - r ((1+r)(-2) - r v-) = 2 (1+r)^2 + r^2 v-, hence
   A0 = 2 (1+r)^2 - r^2 a0 (eq 51/52), and eliminating delta1, delta2 (below)
   gives exactly (53): B1 = -r^2 h a0 - r^2 b1 + h (1+r)^2 + kappa1 (r^2 - 1).
   The printed (58), P_alpha = (2 (1+r^2), r h (1+r^2) + kappa1 (r^2-1)), is
   not (52)-(53).  Evidence, besides the derivation:

   * the fixed point (63), a_alpha* = 2 (1+r)^2/(1+r^2), and the whole of (63)
     (with kappa_alpha = pi omega1 a_alpha*/4) follow from (52)-(53); with (58)
     the fixed point would be a* = 2 and (63) would not hold;
   * (69), kappa1 > pi omega1 (1+r)^2/(2 (1+r^2)), is the linearisation of the
     double-impact corner curve (17) only with (52)-(53) (with (58) it would be
     kappa1 > pi omega1/2), and at omega = 2 the global double-impact orbit (16)
     has a = 2 (1+r)^2/(1+r^2) = a_alpha*;
   * direct simulation of the flow (the independent reference simulator
     ``tests/naive.py``; eps = 1e-4, omega = 2 - eps, kappa = -3 eps, r = 0.8,
     (u, u') = (a0, eps b1) at t = 0, one period T):

       ========== ================= ==================== ==================
       x=(a0,b1)  flow (A, B/eps)   derived (52)-(53)     printed (58)
       ========== ================= ==================== ==================
       (5, -5)    (3.27968, 4.21742) (3.28000, 4.21717)   (0.08000, 7.24566)
       (4, -6)    (3.91968, 3.85206) (3.92000, 3.85186)   (0.72000, 6.88035)
       (6, -4)    (2.63967, 4.58277) (2.64000, 4.58248)   (-0.5600, 7.61097)
       ========== ================= ==================== ==================

     the flow agrees with (52)-(53) to O(eps) (the gap shrinks tenfold from
     eps = 1e-3 to 1e-4) and differs from (58) by O(1); the beta and gamma maps
     (34)-(35), (37)-(38) agree with the flow in the same way.
   * The paper's own later formulas that use P_alpha were computed with the
     printed (58): the (alpha beta) and (alpha beta gamma) cycle a-values of
     section 5.3.2 and x_alpha** of section 5.4.  With (52) they become
     (alpha beta): a = 2 (1+r+r^2, 1+r-r^2)/(1-r+r^2) (printed:
     2 (1+2r+r^3, 1-r^3)/(1+r^3)); (alpha beta gamma):
     a = 2 (r^4+2r^3+2r^2-1, 1+2r+2r^2-r^4, 1+2r+2r^2+2r^3+r^4)/(1+r^4)
     (printed: 2 (r^4+2r^2-1, 1+2r^2-r^4, 1+2r+2r^3+r^4)/(1+r^4)); tested
     against :func:`cornerbif.theory.word_orbit`; and
     x_alpha** = (2 (1+r)(1-2r^2)/(1-r), -r^2 pi omega1 (1+r)/(1-r)) at
     kappa1 = kappa_beta, with C x** - kappa1 = -2 pi omega1 r^2 (1+r)/(1-r)
     (> 0 for omega1 < 0, so the paper's conclusion x** in S_beta stands).

   * Section 5.3.2 reports the cycles (alpha), (alpha beta) and (alpha beta
     gamma) for kappa1 = 0, omega1 < 0 (and Fig. 5 shows the three in the
     flow).  With (52)-(53) all three are admissible (omega1 = -0.001, r = 0.8),
     and iterating this map from 300 random starts finds exactly these three
     attractors (250, 40, 10 starts).  With the printed (58) the three-cycle
     has the printed a-values (0.978, 2.654, 5.723) and is not admissible (its
     gamma point has a = 5.723 < E = 7 and its alpha point a < 2).

   ``cornerbif.theory.map_matrices(..., variant="printed")`` returns the
   printed (58) for comparisons; every kernel here uses (52)-(53).

2. **Sign of the a0 delta1 term in (44).**  cos(pi/omega - eps delta1)
   = eps (pi omega1/4 + delta1) + O(eps^2), so (44) reads
   pi omega1 a0/4 + a0 delta1 + b1 = kappa1 + 2 delta1, i.e.
   delta1 = (kappa1 - C x)/(a0 - 2) (> 0 in S_alpha, as it must be; the printed
   (48), delta1 = (C x - kappa1)/(a0 + 2), is negative there).  Row 1 of (47)
   and (48)-(50) inherit the sign; row 2 of (47) has a0 where A0 is meant.
   With the corrected delta1, (46) gives delta2 = r (kappa1 - C x)/(4 - r (a0 - 2))
   and (45) gives B1 = pi omega1 A0/4 - kappa1 + (A0 - 2) delta2 with
   A0 - 2 = r (4 - r (a0 - 2)), so (A0 - 2) delta2 = r^2 (kappa1 - C x): (53).
   For gamma the same expansion gives (a0 - 2) tau1 = C x - kappa1 (the paper
   cites (27), whose factor is 2 + a0; the sign condition (39) is unaffected
   because a0 > 2 in S_gamma).
3. **(40)** is garbled (theta1 and theta2 mixed, "-2 - 4/r"); the correct
   condition is v+ = r a0 - 2 (1+r) > 2, i.e. (41) a0 > 2 + 4/r, as printed.
4. Sections 3 and 5.4 (the formulas of :mod:`cornerbif.theory`): the second term
   of (14)/(18) has the wrong sign, (18) writes c_{pi/omega + tau- - tau+} for
   c_{2 pi/omega + tau- - tau+}, and (15) has a spurious minus sign on a; in
   5.4 the b_N line has a spurious factor 1/2, the final N estimate drops the
   factor (1 + r), and "theta_beta omega1 < kappa1 < theta_gamma omega1" should
   read theta_alpha.  The gamma image check gives C x_gamma** - kappa_beta =
   -2 pi omega1 (1 + r) (the printed (pi omega1/2)(1+r)(r^2+r-2)/(1-r) has the
   same sign).  Details and tests are in :mod:`cornerbif.theory`.

Observed dynamics (omega1 = -0.001, r = 0.8; tests/models/test_maps2d.py)
------------------------------------------------------------------
The map reproduces the words the paper reports for the flow: (beta^11 gamma) at
kappa = -0.0127, (beta^12 gamma beta^11 gamma) at -0.0128 (Fig. 17) and the
period-25 (beta^24 gamma) at -0.014 (Fig. 6(d)).  The winding number (share of
gamma) is a non-decreasing staircase from kappa_C up to about -0.0077 only;
there words with three beta-run lengths appear (W drops from 5/21 to 4/17),
alpha enters at -0.0075 and W is not monotone on the rest of [kappa_C, kappa_CC].

Kernels
-------
``region`` and ``step`` are the scalar reference; ``iterate_one`` (serial) and
``iterate_batch`` (threads over parameter points, ``_jit.ItemKernel``) iterate many steps with the
same arithmetic, bit for bit; ``detect_map_cycle`` / ``detect_map_cycles`` find
the period and the word of the recorded tail.  :func:`iterate` and
:func:`find_cycles` are the public, checking and allocating wrappers.
Its speed is measured by ``benchmarks/run.py`` (map2d steps per second; the region
test is predicted by the branch predictor and stays off the dependency chain
b -> h a + b -> s (.) + P_b).
"""

from __future__ import annotations

import math

import numpy as np

from ..._jit import count_done, items_kernel, jit, stop_requested
from ...analysis import smallest_rotation

#: region / symbol codes (out_region values); NONE marks NaN input
ALPHA, BETA, GAMMA, NONE = 0, 1, 2, -1
#: letter of each region code, as in cornerbif.analysis
LETTERS = "abg"
_A, _B, _G = ord("a"), ord("b"), ord("g")

#: columns of the packed parameter vector
P_OMEGA1, P_KAPPA1, P_R = 0, 1, 2
N_PARAMS = 3


@jit
def region(a, b, omega1, kappa1, r):
    """Region of x = (a, b) by eq (56): 0 alpha, 1 beta, 2 gamma, -1 NaN.

    Parameters
    ----------
    a, b : float
        The point x = (a0, b1).
    omega1, kappa1, r : float
        omega - 2, kappa and the coefficient of restitution.

    Returns
    -------
    int
        1 (beta) if C x - kappa1 >= 0, else 0 (alpha) if D x < E, else 2
        (gamma); C x - kappa1 = (pi omega1/4) a + b - kappa1 and E = 2 + 4/r
        (eq 60).  Points on Sigma_1 count as beta, points on Sigma_2 as gamma
        (see the module docstring).  -1 if any input is NaN.
    """
    c = 0.25 * math.pi * omega1 * a + b - kappa1
    if c >= 0.0:
        return 1
    if c < 0.0:
        e = 2.0 + 4.0 / r
        if a < e:
            return 0
        if a >= e:
            return 2
    return -1


@jit
def step(a, b, omega1, kappa1, r):
    """One iterate of the piecewise-linear map (56): (a', b', region of x).

    a' = s a + P_a and b' = s (h a + b) + P_b with h = pi omega1/2 and
    (s, P) = (r, P_beta), (r, P_gamma) (eqs 34-35, 37-38, 57, 59) or
    (-r^2, P_alpha) with P_alpha from (52)-(53) (not the printed (58), see the
    module docstring).  Returns (nan, nan, -1) for NaN input.
    """
    k = region(a, b, omega1, kappa1, r)
    h = 0.5 * math.pi * omega1
    if k == 1:
        s = r
        pa = 2.0 * (1.0 + r)
        pb = (1.0 + r) * (h - kappa1)
    elif k == 2:
        s = r
        pa = -2.0 * (1.0 + r)
        pb = -(1.0 + r) * (h + kappa1)
    elif k == 0:
        s = -r * r
        pa = 2.0 * (1.0 + r) * (1.0 + r)
        pb = h * (1.0 + r) * (1.0 + r) + kappa1 * (r * r - 1.0)
    else:
        return math.nan, math.nan, -1
    return s * a + pa, s * (h * a + b) + pb, k


#: silent steps between two reads of a sweep's stop flag (``_jit.Control``): well under a
#: millisecond of a run
POLL_STEPS = 1 << 16


@jit
def iterate_one(omega1, kappa1, r, a, b, transient, record, out_a, out_b, out_region,
                control=0):
    """Serial kernel: ``transient`` silent steps from (a, b), then ``record`` recorded.

    Record j holds x_j and the region of x_j (the map applied to it), so
    ``out_region`` read as letters is the orbit's word.  Same arithmetic as
    :func:`step`, bit for bit; NaN propagates (region -1).  ``control``: the address of
    a sweep's control (0: none), whose stop flag is read every POLL_STEPS silent steps;
    told to stop, the run returns at once and its outputs are incomplete.  Returns whether
    the run finished (False: stopped).
    """
    q = 0.25 * math.pi * omega1
    h = 0.5 * math.pi * omega1
    e = 2.0 + 4.0 / r
    r1 = 1.0 + r
    sg = -r * r
    pab = 2.0 * r1
    pbb = r1 * (h - kappa1)
    pag = -2.0 * r1
    pbg = -r1 * (h + kappa1)
    paa = 2.0 * r1 * r1
    pba = h * r1 * r1 + kappa1 * (r * r - 1.0)
    left = transient
    while left > 0:
        steps = min(left, POLL_STEPS)
        left -= steps
        for _ in range(steps):
            c = q * a + b - kappa1
            if c >= 0.0:
                a, b = r * a + pab, r * (h * a + b) + pbb
            elif c < 0.0 and a < e:
                a, b = sg * a + paa, sg * (h * a + b) + pba
            elif c < 0.0 and a >= e:
                a, b = r * a + pag, r * (h * a + b) + pbg
            else:
                a = math.nan
                b = math.nan
                left = 0
                break
        if left > 0 and stop_requested(control):
            return False
    for j in range(record):
        out_a[j] = a
        out_b[j] = b
        c = q * a + b - kappa1
        if c >= 0.0:
            out_region[j] = 1
            a, b = r * a + pab, r * (h * a + b) + pbb
        elif c < 0.0 and a < e:
            out_region[j] = 0
            a, b = sg * a + paa, sg * (h * a + b) + pba
        elif c < 0.0 and a >= e:
            out_region[j] = 2
            a, b = r * a + pag, r * (h * a + b) + pbg
        else:
            out_region[j] = -1
            a = math.nan
            b = math.nan
    return True


@items_kernel
def iterate_batch(k0, k1, params, x0, transient, record, out_a, out_b, out_region, control=0):
    """Iterate every row of ``params`` = [omega1, kappa1, r] from x0 = [a, b].

    Parameters
    ----------
    params : (n, 3) float64
    x0 : (n, 2) float64
    transient, record : int
        Silent steps, then recorded steps (``record`` <= out_a.shape[1]; the
        wrapper :func:`iterate` allocates exactly ``record`` columns).
    out_a, out_b : (n, record) float64
    out_region : (n, record) int8
        Filled with x_j and the region of x_j (0 alpha, 1 beta, 2 gamma, -1 NaN).
    control : int
        The address of a sweep's control (``_jit.Control``; 0, the default: none): each
        finished row is counted, and its stop flag cuts every row short (outputs
        incomplete; a row cut short is not counted).
    """
    for i in range(k0, k1):
        if iterate_one(params[i, P_OMEGA1], params[i, P_KAPPA1], params[i, P_R], x0[i, 0],
                       x0[i, 1], transient, record, out_a[i], out_b[i], out_region[i], control):
            count_done(control)


@jit
def detect_map_cycle(regions, a, b, tol, sym_out):
    """Smallest period of a recorded orbit and its word.

    The period is the smallest p such that regions[j] == regions[j + p],
    |a[j] - a[j + p]| <= tol (1 + |a[j]|) and the same for b, for every j of the
    recorded window (the prefix before the first region -1), which must hold at
    least two cycles (p <= n/2).  ``sym_out`` (uint8) receives the word in
    letters a/b/g rotated to its lexicographically smallest rotation (the
    convention of :mod:`cornerbif.analysis`), zero-padded and truncated to
    len(sym_out).  Returns 0 (and an all-zero ``sym_out``) when no cycle is found.
    """
    n = 0
    while n < regions.shape[0] and regions[n] >= 0:
        n += 1
    sym_out[:] = 0
    for p in range(1, n // 2 + 1):
        ok = True
        for j in range(n - p):
            k = j + p
            if regions[j] != regions[k]:
                ok = False
                break
            if abs(a[j] - a[k]) > tol * (1.0 + abs(a[j])):
                ok = False
                break
            if abs(b[j] - b[k]) > tol * (1.0 + abs(b[j])):
                ok = False
                break
        if ok:
            # letters a < b < g have codes 0 < 1 < 2: the same order as the letters
            best = smallest_rotation(regions, 0, p)
            for q in range(min(p, sym_out.shape[0])):
                k = regions[(best + q) % p]
                sym_out[q] = _A if k == 0 else (_B if k == 1 else _G)
            return p
    return 0


@items_kernel
def detect_map_cycles(k0, k1, regions, a, b, tol, o_period, o_sym):
    """``detect_map_cycle`` over all rows in parallel (o_period int64, o_sym uint8 (n, w))."""
    for i in range(k0, k1):
        o_period[i] = detect_map_cycle(regions[i], a[i], b[i], tol, o_sym[i])


# ---------------------------------------------------------------------------
# public layer: check, allocate, call the kernels
# ---------------------------------------------------------------------------
def map_params(omega, kappa, r):
    """Packed (n, 3) [omega1, kappa1, r] from flow parameters (epsilon = 1: omega1 = omega - 2)."""
    omega, kappa, r = np.broadcast_arrays(np.asarray(omega, float), np.asarray(kappa, float),
                                          np.asarray(r, float))
    return np.ascontiguousarray(np.stack([omega.ravel() - 2.0, kappa.ravel(), r.ravel()], axis=1))


def default_x0(params):
    """A start in S_beta for each row: a = a_beta* = 2(1+r)/(1-r), C x - kappa1 = 1e-3.

    Near the corner bifurcation of the beta fixed point this lies in the
    trapping region of section 5.4 (iterates of beta approach x_beta* along
    (0, 1)).
    """
    params = np.asarray(params, float).reshape(-1, N_PARAMS)
    w1, k1, r = params[:, 0], params[:, 1], params[:, 2]
    a = 2.0 * (1.0 + r) / (1.0 - r)
    b = k1 - 0.25 * np.pi * w1 * a + 1e-3
    return np.ascontiguousarray(np.stack([a, b], axis=1))


def iterate(params, x0=None, transient=2000, record=400):
    """Iterate the map (56) for every parameter row; returns (a, b, region).

    Parameters
    ----------
    params : array_like, (n, 3) or (3,)
        Rows [omega1, kappa1, r] (see :func:`map_params`).  NaN rows give NaN
        output; r must satisfy 0 <= r < 1 (not checked in the kernel).
    x0 : array_like, (n, 2) or (2,), optional
        Start points; default :func:`default_x0`.
    transient, record : int
        Steps discarded, then steps recorded.

    Returns
    -------
    a, b : (n, record) float64
    region : (n, record) int8
        Region of each recorded point (0 alpha, 1 beta, 2 gamma, -1 NaN).
    """
    params = np.ascontiguousarray(np.asarray(params, np.float64).reshape(-1, N_PARAMS))
    n = params.shape[0]
    if x0 is None:
        x0 = default_x0(params)
    x0 = np.array(np.broadcast_to(np.asarray(x0, np.float64), (n, 2)), order="C")  # writable: one signature
    transient, record = int(transient), int(record)
    if transient < 0 or record < 1:
        raise ValueError(f"transient must be >= 0 and record >= 1, got {transient}, {record}")
    out_a = np.empty((n, record), np.float64)
    out_b = np.empty((n, record), np.float64)
    out_r = np.empty((n, record), np.int8)
    iterate_batch(params, x0, transient, record, out_a, out_b, out_r, 0)
    return out_a, out_b, out_r


def find_cycles(region, a, b, tol=1e-9):
    """Period and word of each recorded row (see :func:`detect_map_cycle`).

    Returns
    -------
    period : (n,) int64
        0 where no cycle repeats twice in the window.
    words : (n,) object
        Python str, '' where period is 0.
    """
    region = np.ascontiguousarray(np.atleast_2d(region), np.int8)
    a = np.ascontiguousarray(np.atleast_2d(a), np.float64)
    b = np.ascontiguousarray(np.atleast_2d(b), np.float64)
    n, m = region.shape
    period = np.zeros(n, np.int64)
    sym = np.zeros((n, max(1, m // 2)), np.uint8)
    detect_map_cycles(region, a, b, float(tol), period, sym)
    words = np.array([bytes(row[:p]).decode("ascii") for row, p in zip(sym, period)], dtype=object)
    return period, words


def attractor_word(omega1, kappa1, r, x0=None, transient=2000, record=400, tol=1e-9):
    """Word of the attractor reached from x0 (default :func:`default_x0`) at one parameter point."""
    a, b, reg = iterate([omega1, kappa1, r], x0, transient, record)
    period, words = find_cycles(reg, a, b, tol)
    return words[0]
