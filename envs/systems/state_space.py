"""The state-space realization of a plant's rational part ``G(s) = num(s)/den(s)``.

:class:`StateSpace` holds ``x' = A x + B u``, ``y = C x + D u``.  :meth:`envs.systems.plants.Plant.state_space`
builds it in controllable canonical form (:func:`_controllable_form`, ``scipy.signal.tf2ss`` bit for
bit; compiled with the time scaling in :func:`_scaled_controllable_form` beside it), balanced by
LAPACK's ``dgebal`` (:func:`_balanced`, ``scipy.linalg.matrix_balance`` without its overhead).  The
unit tests compare each with the library call it replaces.
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np
import scipy.linalg
import scipy.signal

__all__ = ["StateSpace"]


@dataclass(frozen=True)
class StateSpace:
    """A continuous-time state-space realization ``x' = A x + B u``, ``y = C x + D u``."""

    A: np.ndarray
    B: np.ndarray
    C: np.ndarray
    D: np.ndarray


def _read_only(state_space: StateSpace) -> StateSpace:
    for matrix in (state_space.A, state_space.B, state_space.C, state_space.D):
        matrix.setflags(write=False)
    return state_space


def _balanced(A: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``scipy.linalg.matrix_balance(A, permute=False, separate=True)`` as ``(B, scaling)``: the same
    LAPACK ``dgebal`` call, without its generic validation and permutation bookkeeping (most of its cost).

    A matrix that is not finite, or a LAPACK error, is left to ``matrix_balance`` (its error).
    """
    if A.dtype == np.float64 and A.ndim == 2 and A.shape[0] == A.shape[1] > 0 and np.isfinite(A).all():
        B, lo, hi, ps, info = _DGEBAL(A, scale=1, permute=0)
        if info >= 0:
            scaling = np.ones_like(ps, dtype=float)
            scaling[lo : hi + 1] = ps[lo : hi + 1]
            return B, scaling
    B, (scaling, _) = scipy.linalg.matrix_balance(A, permute=False, separate=True)
    return B, scaling


_DGEBAL = scipy.linalg.get_lapack_funcs("gebal", (np.zeros((1, 1)),))  # the dgebal matrix_balance uses


def _controllable_form(num: np.ndarray, den: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``scipy.signal.tf2ss(num, den)``, bit for bit, of a proper ``num/den`` with ``den[0] != 0``
    and at least one pole, without its generic conversions and checks (most of its cost).

    A numerator whose normalized leading coefficient is within 1e-14 of zero, which tf2ss trims
    with a warning, is left to tf2ss.
    """
    num, den = num / den[0], den / den[0]
    if abs(num[0]) <= 1e-14:
        return scipy.signal.tf2ss(num, den)
    n = den.size - 1
    num = np.concatenate([np.zeros(den.size - num.size), num])
    A = np.zeros((n, n))
    A[0] = -den[1:]
    A[1:, :-1] = np.eye(n - 1)
    B = np.zeros((n, 1))
    B[0, 0] = 1.0
    C = num[None, 1:] - num[0] * den[None, 1:]
    return A, B, C, np.array([[num[0]]])


@numba.njit(cache=True)
def _scaled_controllable_form(num, den, scale):  # pragma: no cover - compiled
    """``A, B, C, D = _controllable_form(num, den)`` followed by ``A / scale``, ``B / scale``: the same
    elementwise operations, for a numerator whose normalized leading coefficient is not trimmed."""
    n = den.size - 1
    lead = den[0]
    padded = np.zeros(den.size)  # num / den[0], padded to the size of den
    for i in range(num.size):
        padded[den.size - num.size + i] = num[i] / lead
    monic = np.empty(den.size)
    for i in range(den.size):
        monic[i] = den[i] / lead
    A = np.zeros((n, n))  # its zeros stay +0.0 = 0.0 / scale (scale > 0)
    for j in range(n):
        A[0, j] = -monic[j + 1] / scale
    for i in range(1, n):
        A[i, i - 1] = 1.0 / scale
    B = np.zeros((n, 1))
    B[0, 0] = 1.0 / scale
    C = np.empty((1, n))
    for j in range(n):
        C[0, j] = padded[j + 1] - padded[0] * monic[j + 1]
    D = np.empty((1, 1))
    D[0, 0] = padded[0]
    return A, B, C, D
