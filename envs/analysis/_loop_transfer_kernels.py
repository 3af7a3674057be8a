"""The compiled kernels of :mod:`envs.analysis.loop_transfer`: the packed loop in one call.

:func:`~envs.analysis.loop_transfer.loop_packed` hands the plant's coefficients and the
controller's parameters to :func:`_packed_loop`, which forms the array of
``loop_transfer(plant, controller).packed()`` directly.  Polynomials are float arrays of their
exact length (no padding: a leading zero would change the packed widths); each helper is the
Python function of the same name in :mod:`envs.analysis.loop_transfer`, operation for operation,
in the same order (products summed term by term, no fused multiply-adds), so the array is the
same bit for bit (``loop_packed(..., method="reference")`` is the readable path, and
``tests/unit/envs/analysis/test_loop_transfer.py`` holds the two equal).

Every compiled function calls only compiled functions of this package, whose numba cache
:mod:`envs._kernel_cache` drops whenever any of its kernel modules changes.
"""

from __future__ import annotations

import numba
import numpy as np

_PID, _FPPI, _MSP = 0, 1, 2  # the controller kinds of _packed_loop


@numba.njit(cache=True)
def _multiply_c(a, b):  # pragma: no cover - compiled
    """:func:`_multiply`: ``product[i + j] += a[i] b[j]``, ``i`` outer, ``j`` inner."""
    product = np.zeros(a.size + b.size - 1)
    for i in range(a.size):
        for j in range(b.size):
            product[i + j] += a[i] * b[j]
    return product


@numba.njit(cache=True)
def _add_c(a, b):  # pragma: no cover - compiled
    """:func:`_add`: the shorter added to the trailing coefficients of the longer."""
    if a.size < b.size:
        a, b = b, a
    total, pad = _part(a, 0, a.size), a.size - b.size
    for k in range(b.size):
        total[pad + k] = a[pad + k] + b[k]
    return total


@numba.njit(cache=True)
def _scale_c(factor, a):  # pragma: no cover - compiled
    """:func:`_scale`."""
    scaled = np.empty(a.size)
    for k in range(a.size):
        scaled[k] = factor * a[k]
    return scaled


@numba.njit(cache=True)
def _pair(first, second):  # pragma: no cover - compiled
    """The polynomial ``(first, second)``."""
    out = np.empty(2)
    out[0], out[1] = first, second
    return out


@numba.njit(cache=True)
def _packed_c(plant, size, delay, numerator, denominator, denominator_2, beta_2, two_terms):  # pragma: no cover - compiled
    """:func:`packed` of :func:`_loop_terms` for a controller with one numerator term (dead time 0)
    and one or two denominator terms (dead times 0 and ``beta_2``); ``plant`` is the plant's
    numerator (``size`` coefficients) then denominator, ``delay`` its dead time."""
    plant_numerator, plant_denominator = _part(plant, 0, size), _part(plant, size, plant.size)
    top = _multiply_c(plant_numerator, numerator)
    first = _multiply_c(plant_denominator, denominator)
    second = _multiply_c(plant_denominator, denominator_2) if two_terms else first
    rows = 2 if two_terms else 1
    width = max(first.size, second.size)
    flat = np.zeros(top.size + 1 + rows * width + rows)  # rows padded with leading zeros
    _put(flat, 0, top)
    flat[top.size] = delay + 0.0  # plant.dead_time + alpha, alpha = 0.0
    start = top.size + 1
    _put(flat, start + width - first.size, first)
    if two_terms:
        _put(flat, start + 2 * width - second.size, second)
        flat[start + 2 * width], flat[start + 2 * width + 1] = 0.0, beta_2
    else:
        flat[start + width] = 0.0
    return flat, 1, top.size, rows, width


@numba.njit(cache=True)
def _part(values, start, stop):  # pragma: no cover - compiled
    """``values[start:stop].copy()`` (explicit loops compile several times faster than slicing)."""
    part = np.empty(stop - start)
    for k in range(stop - start):
        part[k] = values[start + k]
    return part


@numba.njit(cache=True)
def _put(target, start, values):  # pragma: no cover - compiled
    """``target[start : start + values.size] = values``."""
    for k in range(values.size):
        target[start + k] = values[k]


@numba.njit(cache=True)
def _packed_loop(plant, size, delay, kind, a, b, c, d, e, flag, other_flag):  # pragma: no cover - compiled
    """:func:`loop_packed`: the controller's terms (:func:`_pid_terms`, :func:`_fppi_terms` or
    :func:`_msp_terms` by ``kind``, parameters ``a .. other_flag`` in their order), then the loop
    packed by :func:`_packed_c`.  One entry point for the three kinds: each compiled entry costs
    seconds of cold compilation."""
    if kind == _PID:
        numerator, denominator, denominator_2, beta_2, two_terms = _pid_terms(a, b, c, d, flag, other_flag)
    elif kind == _FPPI:
        numerator, denominator, denominator_2, beta_2, two_terms = _fppi_terms(a, b, c, d, e)
    else:
        numerator, denominator, denominator_2, beta_2, two_terms = _msp_terms(a, b, c, d, e, flag)
    return _packed_c(plant, size, delay, numerator, denominator, denominator_2, beta_2, two_terms)


@numba.njit(cache=True)
def _pid_terms(kp, ti, td, n, has_ti, series):  # pragma: no cover - compiled
    """:func:`_pid`: ``(numerator, denominator, denominator, 0.0, False)`` (one term each side)."""
    num, den = np.ones(1), np.ones(1)
    if has_ti:
        num, den = _pair(ti, 1.0), _pair(ti, 0.0)
    if td > 0 and not series:
        filter_ = _pair(td / n, 1.0)
        num, den = _add_c(_multiply_c(num, filter_), _multiply_c(den, _pair(td, 0.0))), _multiply_c(den, filter_)
    elif td > 0:
        num, den = _multiply_c(num, _pair(td, 1.0)), _multiply_c(den, _pair(td / n, 1.0))
    return _scale_c(kp, num), den, den, 0.0, False


@numba.njit(cache=True)
def _fppi_terms(k, gain, tn, tf, dead_time):  # pragma: no cover - compiled
    """:func:`_fppi`: ``(numerator, rational, (-K K_n,), L_n, True)``."""
    k_kn = k * gain
    rational = np.empty(3)
    rational[0], rational[1], rational[2] = tn * tf, tn + k_kn * tf, k_kn
    return _pair(k * tn, k), rational, np.full(1, -k_kn), dead_time, True


@numba.njit(cache=True)
def _msp_terms(k0, kn, tr, td, dead_time, extension):  # pragma: no cover - compiled
    """:func:`_msp`: ``(numerator, K_n predictor lead, -K_n lead, L_n, True)``."""
    f, lead = (_pair(td, 1.0), _pair(td / 10, 1.0)) if extension else (np.ones(1), np.ones(1))
    predictor = _pair(tr, 1.0)
    lead_s = np.zeros(lead.size + 1)  # lead + (0.0,)
    _put(lead_s, 0, lead)
    numerator = _add_c(_scale_c(k0 * kn, _multiply_c(f, predictor)), lead_s)
    return numerator, _scale_c(kn, _multiply_c(predictor, lead)), _scale_c(-kn, lead), dead_time, True
