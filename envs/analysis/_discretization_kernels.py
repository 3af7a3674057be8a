"""The one-step map of a closed loop, compiled: :func:`envs.simulation.discretization.discretize` for the IAE.

:func:`envs.analysis._iae_kernels.step_iae` starts from it; :func:`discretize_compiled` is its entry from Python.

The one-step map.  :func:`discretize_compiled` returns the
:class:`~envs.simulation.discretization.DiscreteDelaySystem` of :func:`~envs.simulation.discretization.discretize` (the readable
reference, kept for the experiments): the same sub-intervals between the fractional parts of the
delays, the same zero-order hold of ``d`` and first-order hold of the delayed signals, composed in
the same order.  Two things differ, both exact in exact arithmetic, so the results agree to
rounding (the tests check ``1e-12``):

* each sub-interval of length ``T`` takes one matrix exponential of the smaller block
  ``[[A, B1, B2, 0], [0, 0, 0, 0], [0, 0, 0, I], [0, 0, 0, 0]] T`` (size ``n + n_d + 2 n_v``
  instead of ``3 n``), whose first block row is ``[e^{AT}, psi0 B1, psi0 B2, psi1 B2]`` with
  ``psi0 = int_0^T e^{As} ds`` and ``psi1 = int_0^T e^{As} (T - s) ds`` (Van Loan, "Computing
  integrals involving the matrix exponential", IEEE TAC 23(3), 1978);
* the exponential is :func:`expm`, Higham's scaling and squaring with Pade approximants of degree
  3 to 13 (Higham, SIAM J. Matrix Anal. Appl. 26(4), 2005, Algorithm 2.3), compiled with numba;
  scipy uses the same approximants with the refined choice of the scaling of Al-Mohy and Higham
  (2009).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from envs.simulation.delay_systems import DelaySystem
from envs.simulation.discretization import DiscreteDelaySystem

__all__ = ["discretize_compiled", "expm"]

# Higham (2005), Table 2.3: the largest 1-norm for which the Pade approximant of degree m is accurate
# to double precision, and the coefficients b_k of the approximants (Algorithm 2.3).
_THETA = (1.495585217958292e-2, 2.539398330063230e-1, 9.504178996162932e-1, 2.097847961257068e0, 5.371920351148152e0)
_PADE3 = (120.0, 60.0, 12.0, 1.0)
_PADE5 = (30240.0, 15120.0, 3360.0, 420.0, 30.0, 1.0)
_PADE7 = (17297280.0, 8648640.0, 1995840.0, 277200.0, 25200.0, 1512.0, 56.0, 1.0)
_PADE9 = (17643225600.0, 8821612800.0, 2075673600.0, 302702400.0, 30270240.0, 2162160.0, 110880.0, 3960.0, 90.0, 1.0)
_PADE13 = (
    64764752532480000.0, 32382376266240000.0, 7771770303897600.0, 1187353796428800.0, 129060195264000.0,
    10559470521600.0, 670442572800.0, 33522128640.0, 1323241920.0, 40840800.0, 960960.0, 16380.0, 182.0, 1.0,
)  # fmt: skip



def discretize_compiled(system: DelaySystem, dt: float) -> DiscreteDelaySystem:
    """:func:`envs.simulation.discretization.discretize`, compiled (see the module docstring); same errors."""
    if not dt > 0 or not np.isfinite(dt):
        raise ValueError(f"dt must be finite and > 0, got {dt!r}")
    delays = np.asarray(system.delays, dtype=float)
    if delays.size and np.min(delays) < dt * (1 - 1e-12):
        raise ValueError(f"every delay must be >= dt={dt:g}; got min delay {np.min(delays):g}")
    Phi, Gamma, R, whole, fraction = _discretize(
        np.ascontiguousarray(system.A, dtype=float), np.ascontiguousarray(system.B1, dtype=float),
        np.ascontiguousarray(system.B2, dtype=float), np.ascontiguousarray(delays), float(dt),
    )  # fmt: skip
    return DiscreteDelaySystem(system, float(dt), Phi, Gamma, R, whole, fraction)


@numba.njit(cache=True)
def _discretize(A, B1, B2, delays, dt):  # pragma: no cover - compiled
    """``(Phi, Gamma, R, whole_samples, fraction)`` of :class:`~envs.simulation.discretization.DiscreteDelaySystem`."""
    n, nd, nv = A.shape[0], B1.shape[1], delays.size
    whole = np.empty(nv, np.int64)
    fraction = np.empty(nv)
    for i in range(nv):
        whole[i] = int(math.floor(delays[i] / dt + 1e-9))
        fraction[i] = delays[i] - whole[i] * dt
        if fraction[i] < 1e-9 * dt:
            fraction[i] = 0.0
    breaks = _breaks(fraction, dt)
    size = n + nd + 2 * nv
    block = np.zeros((size, size))
    P = np.eye(n)
    Q = np.zeros((n, nd))
    R = np.zeros((n, nv, 3))
    for b in range(breaks.size - 1):
        start, span = breaks[b], breaks[b + 1] - breaks[b]
        block[:n, :n] = A * span
        block[:n, n : n + nd] = B1 * span
        block[:n, n + nd : n + nd + nv] = B2 * span
        for i in range(nv):
            block[n + nd + i, n + nd + nv + i] = span
        e = expm(block)
        E = e[:n, :n].copy()
        before, after = _channel_weights(start, fraction, dt), _channel_weights(breaks[b + 1], fraction, dt)
        P = _product(E, P)
        Q = _product(E, Q) + e[:n, n : n + nd]
        carried = R.copy()
        for i in range(nv):
            psi0_b2, psi1_b2 = n + nd + i, n + nd + nv + i  # the columns of psi0 B2 and psi1 B2
            for k in range(3):
                slope = (after[i, k] - before[i, k]) / span
                for r in range(n):
                    acc = 0.0
                    for c in range(n):
                        acc += E[r, c] * carried[c, i, k]
                    R[r, i, k] = acc + e[r, psi0_b2] * before[i, k] + e[r, psi1_b2] * slope
    return P, Q, R, whole, fraction


@numba.njit(cache=True)
def _breaks(fraction, dt):  # pragma: no cover - compiled
    """``np.unique([0, dt, *fraction[fraction > 0]])``: the ends of the sub-intervals, sorted."""
    breaks = np.empty(fraction.size + 2)
    breaks[0], count = 0.0, 1
    for f in np.sort(fraction):
        if f > breaks[count - 1]:
            breaks[count] = f
            count += 1
    breaks[count] = dt
    return breaks[: count + 1]


@numba.njit(cache=True)
def _channel_weights(s, fraction, dt):  # pragma: no cover - compiled
    """:func:`envs.simulation.discretization._channel_weights`: ``v_i(j dt + s) = sum_k c[i, k] w_i[j - m_i - 1 + k]``."""
    c = np.zeros((fraction.size, 3))
    for i in range(fraction.size):
        if s <= fraction[i]:
            c[i, 0] = (fraction[i] - s) / dt
            c[i, 1] = (dt - fraction[i] + s) / dt
        else:
            c[i, 1] = 1.0 - (s - fraction[i]) / dt
            c[i, 2] = (s - fraction[i]) / dt
    return c


@numba.njit(cache=True)
def expm(A):  # pragma: no cover - compiled
    """``e^A`` by scaling and squaring (Higham 2005, Algorithm 2.3)."""
    n = A.shape[0]
    norm = 0.0
    for c in range(n):  # the 1-norm; each column summed in order from 0.0, as numba's np.sum does
        column = 0.0
        for r in range(n):
            column += abs(A[r, c])
        norm = max(norm, column)
    identity = np.eye(n)
    squarings = 0
    if norm <= _THETA[3]:
        A2 = _product(A, A)
        if norm <= _THETA[0]:
            b = _PADE3
            U = _product(A, b[3] * A2 + b[1] * identity)
            V = b[2] * A2 + b[0] * identity
        else:
            A4 = _product(A2, A2)
            if norm <= _THETA[1]:
                b = _PADE5
                U = _product(A, b[5] * A4 + b[3] * A2 + b[1] * identity)
                V = b[4] * A4 + b[2] * A2 + b[0] * identity
            else:
                A6 = _product(A4, A2)
                if norm <= _THETA[2]:
                    b = _PADE7
                    U = _product(A, b[7] * A6 + b[5] * A4 + b[3] * A2 + b[1] * identity)
                    V = b[6] * A6 + b[4] * A4 + b[2] * A2 + b[0] * identity
                else:
                    A8 = _product(A4, A4)
                    b = _PADE9
                    U = _product(A, b[9] * A8 + b[7] * A6 + b[5] * A4 + b[3] * A2 + b[1] * identity)
                    V = b[8] * A8 + b[6] * A6 + b[4] * A4 + b[2] * A2 + b[0] * identity
    else:
        squarings = max(0, int(math.ceil(math.log2(norm / _THETA[4]))))
        S = A / 2.0**squarings
        b = _PADE13
        S2 = _product(S, S)
        S4 = _product(S2, S2)
        S6 = _product(S4, S2)
        inner = _product(S6, b[13] * S6 + b[11] * S4 + b[9] * S2)
        U = _product(S, inner + b[7] * S6 + b[5] * S4 + b[3] * S2 + b[1] * identity)
        V = _product(S6, b[12] * S6 + b[10] * S4 + b[8] * S2) + b[6] * S6 + b[4] * S4 + b[2] * S2 + b[0] * identity
    X = V + U
    if not _solve(V - U, X):
        raise ZeroDivisionError("singular Pade denominator")
    for _ in range(squarings):
        X = _product(X, X)
    return X


@numba.njit(cache=True)
def _product(A, B):  # pragma: no cover - compiled
    """``A @ B`` for the small matrices here (no BLAS call), each entry summed over ``k`` in order.

    The terms of a zero ``A[i, k]`` are skipped where the row ``B[k]`` is finite (the matrices of
    the discretization are mostly zero blocks): they are zeros, and a zero added to a sum that
    starts at ``+0.0`` leaves it unchanged (such a sum is never ``-0.0``), so the result is that
    of every term, bit for bit.  Where ``B[k]`` holds an ``inf`` or ``nan`` they are added (``nan``).
    """
    out = np.zeros((A.shape[0], B.shape[1]))
    finite = np.ones(B.shape[0], dtype=np.bool_)
    for k in range(B.shape[0]):
        for j in range(B.shape[1]):
            if not math.isfinite(B[k, j]):
                finite[k] = False
    for i in range(A.shape[0]):
        for k in range(A.shape[1]):
            a = A[i, k]
            if a == 0.0 and finite[k]:
                continue
            for j in range(B.shape[1]):
                out[i, j] += a * B[k, j]
    return out


@numba.njit(cache=True)
def _solve(M, B):  # pragma: no cover - compiled
    """``B <- M^{-1} B`` by Gaussian elimination with partial pivoting (``M`` is overwritten); False,
    with ``B`` left half done, if a pivot is exactly zero (``M`` singular, as LAPACK reports it)."""
    n = M.shape[0]
    for c in range(n):
        pivot = c + np.argmax(np.abs(M[c:, c]))
        if pivot != c:
            for j in range(n):
                M[c, j], M[pivot, j] = M[pivot, j], M[c, j]
            for j in range(B.shape[1]):
                B[c, j], B[pivot, j] = B[pivot, j], B[c, j]
        if M[c, c] == 0.0:
            return False
        for r in range(c + 1, n):
            factor = M[r, c] / M[c, c]
            if factor != 0.0:
                for j in range(c + 1, n):
                    M[r, j] -= factor * M[c, j]
                for j in range(B.shape[1]):
                    B[r, j] -= factor * B[c, j]
    for c in range(n - 1, -1, -1):
        for j in range(B.shape[1]):
            B[c, j] /= M[c, c]
        for r in range(c):
            if M[r, c] != 0.0:
                for j in range(B.shape[1]):
                    B[r, j] -= M[r, c] * B[c, j]
    return True
