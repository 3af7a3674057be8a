"""The compiled kernels of :mod:`envs.systems.controllers`: the matrices of the controllers' blocks.

:meth:`~envs.systems.controllers.FPPI.block`, :meth:`~envs.systems.controllers.MSP.block` and the
rational controllers' blocks fill their ten matrices here, column by column, with the scalar
operations that the row algebra of numpy would do (the readable form of each is in the docstring
of its caller); :func:`~envs.systems.controllers.packed_block` packs them into one flat array for
:func:`envs.simulation.loops.loop_rows`.  The tests hold the compiled blocks equal to those built
with :class:`~envs.simulation.delay_systems.SystemBuilder`.

Every compiled function calls only compiled functions of this package, whose numba cache
:mod:`envs._kernel_cache` drops whenever any of its kernel modules changes.
"""

from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True)
def _rational_matrices(num, den):  # pragma: no cover - compiled
    """The ten matrices of :func:`~envs.systems.controllers._rational_block`, by the same operations as with numpy."""
    first = 0
    while den[first] == 0.0:  # without leading zeros
        first += 1
    n = den.size - first - 1
    if num.size > n + 1:
        raise ValueError("the controller must be proper")
    padded, normalized = np.zeros(n + 1), np.empty(n + 1)  # num and den divided by den[first]
    for i in range(num.size):
        padded[n + 1 - num.size + i] = num[i] / den[first]
    for i in range(n + 1):
        normalized[i] = den[first + i] / den[first]
    A = np.zeros((n, n))
    for i in range(n):
        A[0, i] = -normalized[i + 1]
        if i > 0:
            A[i, i - 1] = 1.0
    B1 = np.zeros((n, 2))
    for i in range(n):
        B1[i, 1] = -B1[i, 0]  # -0.0, as numpy's -b
    if n:
        B1[0, 0], B1[0, 1] = 1.0, -1.0
    c = np.empty((1, n))
    for i in range(n):
        c[0, i] = padded[i + 1] - padded[0] * normalized[i + 1]
    d = padded[0]
    D11 = np.array([[d, -d]])
    return A, B1, np.zeros((n, 0)), c, D11, np.zeros((1, 0)), np.zeros((0, n)), np.zeros((0, 2)), np.zeros((0, 0)), np.zeros(0)


@numba.njit(cache=True)
def _packed(A, B1, B2, C1, D11, D12, C2, D21, D22, delays):  # pragma: no cover - compiled
    """The flat array of :func:`~envs.systems.controllers.packed_block` from the ten matrices, and the numbers of states and delays."""
    n, nv = A.shape[0], delays.size
    flat = np.empty((n + 1 + nv) * (n + 2 + nv) + nv)
    start = _put_matrix(flat, 0, A)
    start = _put_matrix(flat, start, B1)
    start = _put_matrix(flat, start, B2)
    start = _put_matrix(flat, start, C1)
    start = _put_matrix(flat, start, D11)
    start = _put_matrix(flat, start, D12)
    start = _put_matrix(flat, start, C2)
    start = _put_matrix(flat, start, D21)
    start = _put_matrix(flat, start, D22)
    for i in range(nv):
        flat[start + i] = delays[i]
    return flat, n, nv


@numba.njit(cache=True)
def _put_matrix(flat, start, matrix):  # pragma: no cover - compiled
    """``matrix`` row by row into ``flat`` from ``start``; where the next one starts (explicit
    loops: they compile several times faster than numba's ravel and slice assignments)."""
    for r in range(matrix.shape[0]):
        for c in range(matrix.shape[1]):
            flat[start] = matrix[r, c]
            start += 1
    return start


@numba.njit(cache=True)
def _packed_rational(num, den):  # pragma: no cover - compiled
    """:func:`~envs.systems.controllers.packed_block` of a rational controller (:func:`_rational_matrices`)."""
    A, B1, B2, C1, D11, D12, C2, D21, D22, delays = _rational_matrices(num, den)
    return _packed(A, B1, B2, C1, D11, D12, C2, D21, D22, delays)


@numba.njit(cache=True)
def _packed_fppi(k, gain, time_constant, tf, dead_time):  # pragma: no cover - compiled
    """:func:`~envs.systems.controllers.packed_block` of an :class:`~envs.systems.controllers.FPPI` (:func:`_fppi_matrices`)."""
    A, B1, B2, C1, D11, D12, C2, D21, D22, delays = _fppi_matrices(k, gain, time_constant, tf, dead_time)
    return _packed(A, B1, B2, C1, D11, D12, C2, D21, D22, delays)


@numba.njit(cache=True)
def _packed_msp(kr, k0, gain, lead, dead_time, extension):  # pragma: no cover - compiled
    """:func:`~envs.systems.controllers.packed_block` of an :class:`~envs.systems.controllers.MSP` (:func:`_msp_matrices`)."""
    A, B1, B2, C1, D11, D12, C2, D21, D22, delays = _msp_matrices(kr, k0, gain, lead, dead_time, extension)
    return _packed(A, B1, B2, C1, D11, D12, C2, D21, D22, delays)


@numba.njit(cache=True)
def _unit(column, index):  # pragma: no cover - compiled
    """Column ``column`` of the coefficient row of signal ``index`` (:class:`~envs.simulation.delay_systems.SystemBuilder`)."""
    return 1.0 if column == index else 0.0


@numba.njit(cache=True)
def _built(derivatives, outputs, delayed, n, delays):  # pragma: no cover - compiled
    """The ten matrices of ``SystemBuilder(n, 2, delays.size).build(...)`` from its rows."""
    d = n + 2
    return (
        derivatives[:, :n].copy(), derivatives[:, n:d].copy(), derivatives[:, d:].copy(), outputs[:, :n].copy(),
        outputs[:, n:d].copy(), outputs[:, d:].copy(), delayed[:, :n].copy(), delayed[:, n:d].copy(),
        delayed[:, d:].copy(), delays,
    )  # fmt: skip


@numba.njit(cache=True)
def _fppi_matrices(k, gain, time_constant, tf, dead_time):  # pragma: no cover - compiled
    """:meth:`~envs.systems.controllers.FPPI.block`'s matrices: the rows of its equations, column by column, with the scalar
    operations that the row algebra of numpy does on each column."""
    filtered, delayed = tf > 0, dead_time > 0
    n = 3 if filtered else 2
    size = n + 2 + (1 if delayed else 0)
    derivatives, outputs, delayed_rows = np.empty((n, size)), np.empty((1, size)), np.empty((1 if delayed else 0, size))
    for j in range(size):  # the states [int e, m, (c)], the inputs [r, y], the delayed [m(t - L_n)]
        integral, model, r, y = _unit(j, 0), _unit(j, 1), _unit(j, n), _unit(j, n + 1)
        model_delayed = _unit(j, n + 2) if delayed else model
        correction = _unit(j, 2) if filtered else y - model_delayed
        error = r - model - correction
        u = k * error + (k / time_constant) * integral  # T_i = T_n
        derivatives[0, j], derivatives[1, j] = error, (gain * u - model) / time_constant
        if filtered:
            derivatives[2, j] = (y - model_delayed - _unit(j, 2)) / tf
        outputs[0, j] = u
        if delayed:
            delayed_rows[0, j] = model
    return _built(derivatives, outputs, delayed_rows, n, np.full(1 if delayed else 0, dead_time))


@numba.njit(cache=True)
def _msp_matrices(kr, k0, gain, lead, dead_time, extension):  # pragma: no cover - compiled
    """:meth:`~envs.systems.controllers.MSP.block`'s matrices: the rows of its equations, column by column, with the scalar
    operations that the row algebra of numpy does on each column."""
    n = 2 if extension else 1
    size = n + 3
    derivatives, outputs, delayed_rows = np.empty((n, size)), np.empty((1, size)), np.empty((1, size))
    for j in range(size):  # the states [m, (lead)], the inputs [r, y], the delayed [m(t - L_n)]
        model, r, y = _unit(j, 0), _unit(j, n), _unit(j, n + 1)
        disturbance = y - _unit(j, n + 2)
        u_r = kr * (r - model - disturbance)
        derivatives[0, j] = gain * u_r
        if extension:
            derivatives[1, j] = (disturbance - _unit(j, 1)) / lead
            correction = k0 * (10 * disturbance - 9 * _unit(j, 1))
        else:
            correction = k0 * disturbance
        outputs[0, j] = u_r - correction
        delayed_rows[0, j] = model
    return _built(derivatives, outputs, delayed_rows, n, np.full(1, dead_time))
