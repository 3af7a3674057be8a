"""The loop ``L(i w)`` of :mod:`envs.analysis.loop_transfer`, compiled: at one frequency (:func:`transfer_at`), on
an array (:func:`_values`) and on numpy's grids (:func:`_linspace`, :func:`_logspace`), for the robustness
analysis of :mod:`envs.analysis._robustness_kernels`.

A plant-controller loop is a ratio of quasi-polynomials; each side is evaluated as its polynomial at
the summed coefficients plus the terms of its dead times (:func:`_quasi_polynomial_at`), so that its
root at the origin is exact.  The loop arrives as :func:`_prepare` gives it.
"""

from __future__ import annotations

import math

import numba
import numpy as np

__all__ = ["transfer_at"]

LN10 = math.log(10.0)

jit = numba.njit(cache=True, error_model="numpy")
inline = numba.njit(cache=True, error_model="numpy", inline="always")


@inline
def _polynomial_at(rows, i, w):  # pragma: no cover - compiled
    """``(Re, Im)`` of ``a(i w)``, ``a = rows[i]``, by Horner's rule in real arithmetic."""
    re, im = 0.0, 0.0
    for k in range(rows.shape[1]):
        re, im = rows[i, k] - im * w, re * w
    return re, im


@jit
def _prepare(numerator, numerator_delays, denominator, denominator_delays):  # pragma: no cover - compiled
    """The loop as :func:`transfer_at` takes it: each side's rows, dead times, summed coefficients
    (:func:`_summed`) and whether its one row equals them (:func:`_quasi_polynomial_at`)."""
    numerator_sums, denominator_sums = _summed(numerator), _summed(denominator)
    return (
        numerator, numerator_delays, numerator_sums, _same_row(numerator, numerator_sums),
        denominator, denominator_delays, denominator_sums, _same_row(denominator, denominator_sums),
    )  # fmt: skip


@inline
def _summed(rows):  # pragma: no cover - compiled
    """The coefficients of ``sum_i a_i``, ``a_i = rows[i]``, each summed from ``0.0`` in row order."""
    sums = np.empty(rows.shape[1])
    for k in range(rows.shape[1]):
        c = 0.0
        for i in range(rows.shape[0]):
            c += rows[i, k]
        sums[k] = c
    return sums


@inline
def _same_row(rows, sums):  # pragma: no cover - compiled
    """Whether ``rows`` is one row equal to ``sums`` bit for bit (sign of zero included)."""
    if rows.shape[0] != 1:
        return False
    for k in range(sums.size):
        if not (rows[0, k] == sums[k] and math.copysign(1.0, rows[0, k]) == math.copysign(1.0, sums[k])):
            return False
    return True


@inline
def _quasi_polynomial_at(rows, delays, sums, same, w):  # pragma: no cover - compiled
    """``sum_i a_i(i w) e^{-i w alpha_i}`` as ``(sum_i a_i)(i w) + sum_i a_i(i w) (e^{-i w alpha_i} - 1)``,
    ``a_i = rows[i]``, ``alpha_i = delays[i]``: the polynomial ``sum_i a_i`` from the summed
    coefficients ``sums``, so that its root at the origin is exact.  If ``same`` (one row, equal
    to ``sums``), ``a_0(i w)`` is that polynomial's value (the same operations on the same numbers)."""
    re, im = 0.0, 0.0
    for k in range(sums.size):
        re, im = sums[k] - im * w, re * w
    sum_re, sum_im = re, im
    for i in range(rows.shape[0]):
        if delays[i] == 0.0:
            continue
        a_re, a_im = (sum_re, sum_im) if same else _polynomial_at(rows, i, w)
        half = 0.5 * w * delays[i]
        sin, cos = math.sin(half), math.cos(half)
        e_re, e_im = -2.0 * sin * sin, -2.0 * sin * cos  # e^{-i w alpha} - 1
        re += a_re * e_re - a_im * e_im
        im += a_re * e_im + a_im * e_re
    return complex(re, im)


@inline
def transfer_at(transfer, w):  # pragma: no cover - compiled
    """``L(i w)`` of ``transfer = _prepare(*QuasiRational.arrays)`` at one frequency.

    Inlined where it is called (:func:`_values`, :func:`_crossing_function`): a call of a compiled
    function with array arguments costs more than the evaluation itself (reference counting).
    """
    numerator, numerator_delays, numerator_sums, numerator_same = transfer[0], transfer[1], transfer[2], transfer[3]
    denominator, denominator_delays, denominator_sums, denominator_same = transfer[4], transfer[5], transfer[6], transfer[7]
    return _quasi_polynomial_at(numerator, numerator_delays, numerator_sums, numerator_same, w) / _quasi_polynomial_at(
        denominator, denominator_delays, denominator_sums, denominator_same, w
    )


@jit
def _evaluate(arrays, omega):  # pragma: no cover - compiled
    """``L(i omega)`` on an array, of the loop ``arrays = QuasiRational.arrays``."""
    return _values(_prepare(arrays[0], arrays[1], arrays[2], arrays[3]), omega)


@jit
def _values(transfer, omega):  # pragma: no cover - compiled
    """``L(i omega)`` on an array (``transfer`` as :func:`_prepare` gives it)."""
    values = np.empty(omega.size, dtype=np.complex128)
    for i in range(omega.size):
        values[i] = transfer_at(transfer, omega[i])
    return values


@inline
def _magnitude(z):  # pragma: no cover - compiled
    """``abs(z)`` (without ``hypot``'s guard against overflow, which these values do not need)."""
    return math.sqrt(z.real * z.real + z.imag * z.imag)


@inline
def _linspace(start, stop, count):  # pragma: no cover - compiled
    """``numpy.linspace(start, stop, count)``, computed as numpy does (``count >= 2``)."""
    div = count - 1
    delta = stop - start
    step = delta / div
    y = np.empty(count)
    for i in range(count):
        y[i] = (i / div * delta if step == 0 else i * step) + start
    y[-1] = stop
    return y


@inline
def _logspace(start, stop, count):  # pragma: no cover - compiled
    """``numpy.logspace(start, stop, count)`` (``count >= 2``) as ``e^{y ln 10}`` (within a few ulp
    of ``10^y``, at a third of the cost)."""
    y = _linspace(start, stop, count)
    for i in range(count):
        y[i] = math.exp(LN10 * y[i])
    return y
