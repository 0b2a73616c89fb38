"""Exact flights of a linear system: M x'' + C x' + K x = f(t), f a sum of
harmonic forces F cos(Omega t + phi) and constant ones, over any time, in one closed form
for every case: damped or not, rigid-body modes (K singular: a free particle, gravity),
repeated eigenvalues, forcing at resonance.

**The augmented system.**  The forces are themselves the solution of a linear system: each
harmonic force's phase (c, s) = (cos, sin)(Omega t + phi) obeys c' = -Omega s,
s' = Omega c, and a constant force is carried by a state 1 with 1' = 0.  With them the
flight is autonomous: y = (x, v, forcing states), y' = A y,

    A = [[0,        I,        0     ],
         [-M^-1 K,  -M^-1 C,  M^-1 B],
         [0,        0,        S     ]],

B the columns of the forces (F e_on on each c, nothing on each s, the constants' sum on
1) and S the rotations of the phases.  So y(t0 + h) = expm(A h) y(t0) exactly: no modal
decomposition, which would need a diagonalisable A (a free particle has the Jordan block
[[0, 1], [0, 0]]; an undamped oscillator forced at its own frequency has a double pair
+-i Omega, whose solution grows like t sin t), and no particular solution to solve for.

**expm** is Higham's scaling and squaring with the [13/13] Pade approximant (N. J. Higham,
SIAM J. Matrix Anal. Appl. 26 (2005) 1179-1193): A / 2^s with ||A / 2^s||_1 <= theta_13,
whose approximant has a backward error below the unit roundoff, then s squarings; exact up
to rounding, as the flow's closed-form flights (eq 4) are.

Pure numpy: the reference for the kernel's flights (``kernel.ladder``), and its tests
(tests/models/test_linear_flight.py).
"""

from __future__ import annotations

import numpy as np

from .system import LinearSystem

# Higham (2005), Table 2.3 and eq (2.4): the [13/13] Pade coefficients and the largest
# ||A||_1 for which it has backward error below 2^-53
PADE13 = (64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0,
          129060195264000.0, 10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0,
          40840800.0, 960960.0, 16380.0, 182.0, 1.0)
THETA13 = 5.371920351148152


def expm(A) -> np.ndarray:
    """exp(A) of a real square matrix: scaling and squaring with the [13/13] Pade
    approximant (module docstring)."""
    A = np.asarray(A, dtype=float)
    n = A.shape[0]
    norm = np.linalg.norm(A, 1) if n else 0.0
    s = int(max(0, np.ceil(np.log2(norm / THETA13)))) if norm > THETA13 else 0
    A = A / 2.0 ** s
    b = PADE13
    eye = np.eye(n)
    A2 = A @ A
    A4 = A2 @ A2
    A6 = A4 @ A2
    U = A @ (A6 @ (b[13] * A6 + b[11] * A4 + b[9] * A2) + b[7] * A6 + b[5] * A4 + b[3] * A2
             + b[1] * eye)
    V = A6 @ (b[12] * A6 + b[10] * A4 + b[8] * A2) + b[6] * A6 + b[4] * A4 + b[2] * A2 + b[0] * eye
    X = np.linalg.solve(V - U, V + U)
    for _ in range(s):
        X = X @ X
    return X


def soft_contacts(system: LinearSystem) -> list:
    """The indices of the system's soft stops (law "spring"), in order: soft stop number b
    is bit b of an active set (``augmented``'s ``active``)."""
    return [i for i, c in enumerate(system.contacts) if c.law == "spring"]


def has_constant_state(system: LinearSystem) -> bool:
    """Whether the augmented state ends with the state 1: a constant force, or a soft stop
    (whose spring against z = kappa pushes by k kappa a while it acts)."""
    return any(f.Omega == 0.0 for f in system.forcing) or bool(soft_contacts(system))


def augmented(system: LinearSystem, active: int = 0) -> np.ndarray:
    """The matrix A of the augmented flight y' = A y (module docstring), of size
    2N + 2 (harmonic forces) + 1 (when there is a constant force or a soft stop).
    ``active``: the soft stops acting (bit b: soft stop b of ``soft_contacts``), each
    adding its spring and dashpot while g = a . x - kappa < 0: the force -(k g + c g') a,
    so K + k a a^T, C + c a a^T and the constant force k kappa a (docs/linear.md, "Soft
    stops")."""
    n = system.n
    harmonic = [f for f in system.forcing if f.Omega > 0.0]
    constant = [f for f in system.forcing if f.Omega == 0.0]
    m = 2 * len(harmonic) + (1 if has_constant_state(system) else 0)
    A = np.zeros((2 * n + m, 2 * n + m))
    Minv = np.linalg.inv(system.mass)
    K, C = system.stiffness, system.damping
    B = np.zeros((n, m))
    if active:
        K, C = K.copy(), C.copy()
        for b, i in enumerate(soft_contacts(system)):
            if active >> b & 1:
                c = system.contacts[i]
                K += c.k * np.outer(c.gap, c.gap)
                C += c.c * np.outer(c.gap, c.gap)
                B[:, m - 1] += c.k * c.kappa * c.gap
    A[:n, n:2 * n] = np.eye(n)
    A[n:2 * n, :n] = -Minv @ K
    A[n:2 * n, n:2 * n] = -Minv @ C
    for j, f in enumerate(harmonic):
        B[f.on, 2 * j] += f.F                      # on c = cos(Omega t + phi)
        c, s = 2 * n + 2 * j, 2 * n + 2 * j + 1
        A[c, s] = -f.Omega                          # c' = -Omega s
        A[s, c] = f.Omega                           # s' = Omega c
    for f in constant:
        B[f.on, m - 1] += f.F * np.cos(f.phi)       # on the state 1
    A[n:2 * n, 2 * n:] = Minv @ B
    return A


def forcing_state(system: LinearSystem, t: float) -> np.ndarray:
    """The forcing part of the augmented state at time t: (cos, sin)(Omega t + phi) per
    harmonic force, then 1 when there is a constant one."""
    harmonic = [f for f in system.forcing if f.Omega > 0.0]
    out = []
    for f in harmonic:
        out += [np.cos(f.Omega * t + f.phi), np.sin(f.Omega * t + f.phi)]
    if has_constant_state(system):
        out.append(1.0)
    return np.array(out, dtype=float)


def flight(system: LinearSystem, t0: float, x0, v0, h: float, A=None):
    """The state (x, v) at t0 + h of the free flight from (x0, v0) at t0: expm(A h) on the
    augmented state (``A``: ``augmented(system)``, computed when not given; with soft stops
    acting, ``augmented(system, active)``)."""
    A = augmented(system) if A is None else A
    n = system.n
    y0 = np.concatenate([np.asarray(x0, float), np.asarray(v0, float), forcing_state(system, t0)])
    y = expm(A * h) @ y0
    return y[:n], y[n:2 * n]


def holdable(system: LinearSystem) -> list:
    """Whether each contact can be held after it chatters to rest (docs/linear.md, "Sticking"):
    law "impact" on a fixed obstacle, in a system without soft stops."""
    if soft_contacts(system):
        return [False] * len(system.contacts)
    return [c.law == "impact" and c.obstacle == "fixed" for c in system.contacts]


def held(system: LinearSystem, i: int):
    """The flight with contact i held (g = a . x - kappa = 0, g' = 0) and its contact force:
    (A_h, row), A_h the augmented matrix of M x'' = F - K x - C x' + lam a with a . x'' = 0,

        lam = -a^T M^-1 (F - K x - C x') / (a^T M^-1 a)

    (lam >= 0 pushes the coordinates out of the contact, along M^-1 a, since a^T M^-1 a > 0),
    so that x'' = P M^-1 (F - K x - C x'), P = I - M^-1 a a^T / (a^T M^-1 a): A's acceleration
    rows projected.  ``row``: lam = row . y (y the augmented state), scaled to the norm |a|
    (the same root and sign; the kernel's bounds take |c| = |a|), or None where lam is 0 for
    every state (nothing presses the contact)."""
    n = system.n
    A = augmented(system)
    a = np.asarray(system.contacts[i].gap, float)
    d = np.linalg.solve(system.mass, a)             # M^-1 a
    acc = a @ A[n:2 * n, :]                         # a . x'' of the free flight, a row of y
    Ah = A.copy()
    Ah[n:2 * n, :] -= np.outer(d, acc) / (a @ d)
    lam = -acc / (a @ d)
    size = np.linalg.norm(lam)
    if not size > 0.0:
        return Ah, None
    return Ah, lam * (np.linalg.norm(a) / size)
