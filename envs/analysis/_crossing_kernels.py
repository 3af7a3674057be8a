"""The crossovers, peaks and margins of the robustness analysis of :mod:`envs.analysis._robustness_kernels`,
compiled: the roots of ``log |L| = 0`` and ``Im L = 0`` on their brackets (:func:`_crossovers`, by
Chandrupatla's method, :func:`_chandrupatla`), the peaks of the sensitivities (:func:`_peaks`) and
the gain, phase and delay margins from them, each reproducing the function of
:mod:`envs.analysis.robustness` it names.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from envs.analysis._frequency_response_kernels import _linspace, _magnitude, _values, transfer_at

EPS = float(np.finfo(float).eps)

jit = numba.njit(cache=True, error_model="numpy")
inline = numba.njit(cache=True, error_model="numpy", inline="always")


@jit
def _crossovers(transfer, omega, values, magnitudes, xtol, max_iterations):  # pragma: no cover - compiled
    """:func:`envs.analysis.robustness._crossovers`: the gain crossovers (``log |L| = 0``) and the phase
    crossovers (``Im L = 0``), each the grid points where the function is zero and the root of every
    bracket, in increasing order (``magnitudes = |L|`` on the grid; :func:`_roots`)."""
    gains = _roots(transfer, omega, values, magnitudes, 0, xtol, max_iterations)
    return gains, _roots(transfer, omega, values, magnitudes, 1, xtol, max_iterations)


@jit
def _roots(transfer, omega, values, magnitudes, kind, xtol, max_iterations):  # pragma: no cover - compiled
    """The gain crossovers (``kind = 0``) or the phase crossovers (``kind = 1``) of :func:`_crossovers`.

    ``log |L|`` is taken only at the ends of a bracket: elsewhere only its sign enters, which is
    that of ``|L| - 1`` (``log`` is exact at 1 and, away from 1, at least about ``1e-16`` in size,
    far above its rounding), so the tests on ``|L|`` below are those on ``log |L|`` (a product of
    two logarithms cannot underflow to zero)."""
    n = omega.size
    roots, found = np.empty(n), 0
    for i in range(n):
        if kind == 0:
            zero = magnitudes[i] == 1.0
            change = i < n - 1 and (
                (magnitudes[i] < 1.0 and magnitudes[i + 1] > 1.0) or (magnitudes[i] > 1.0 and magnitudes[i + 1] < 1.0)
            )
        else:
            zero = values[i].imag == 0
            change = i < n - 1 and values[i].imag * values[i + 1].imag < 0
        if zero:
            roots[found] = omega[i]
            found += 1
        elif change:
            if kind == 0:
                fa, fb = math.log(magnitudes[i]), math.log(magnitudes[i + 1])
            else:
                fa, fb = values[i].imag, values[i + 1].imag
            x = _chandrupatla(transfer, kind, math.log(omega[i]), math.log(omega[i + 1]), fa, fb, xtol, max_iterations)
            roots[found] = math.exp(x)
            found += 1
    return roots[:found].copy()


@inline
def _crossing_function(transfer, kind, x):  # pragma: no cover - compiled
    """``log |L|`` (``kind = 0``) or ``Im L`` (``kind = 1``) at ``omega = e^x``."""
    at = transfer_at(transfer, math.exp(x))
    return math.log(_magnitude(at)) if kind == 0 else at.imag


@jit
def _chandrupatla(transfer, kind, a, b, fa, fb, xtol, max_iterations):  # pragma: no cover - compiled
    """One bracket of :func:`envs.analysis.robustness._bracketed_roots` (the same iterates)."""
    x1, x2, x3, f1, f2, f3 = b, a, a, fb, fa, fa
    t = 0.5
    for _ in range(max_iterations):
        xt = x1 + t * (x2 - x1)
        ft = _crossing_function(transfer, kind, xt)
        if (ft > 0 and f1 > 0) or (ft < 0 and f1 < 0) or (ft == 0 and f1 == 0):  # np.sign(ft) == np.sign(f1)
            x3, f3 = x1, f1
        else:
            x3, f3, x2, f2 = x2, f2, x1, f1
        x1, f1 = xt, ft
        xm, fm = (x1, f1) if abs(f1) < abs(f2) else (x2, f2)
        tl = (2 * EPS * abs(xm) + xtol) / abs(x2 - x1)
        if tl > 0.5 or fm == 0:
            return xm
        xi = (x1 - x2) / (x3 - x2)
        phi = (f1 - f2) / (f3 - f2)
        t = 0.5
        if phi**2 < xi and (1 - phi) ** 2 < 1 - xi:
            t = f1 / (f2 - f1) * f3 / (f2 - f3) + (x3 - x1) / (x2 - x1) * f1 / (f3 - f1) * f2 / (f3 - f2)
        t = min(max(t, tl), 1 - tl)
    return x1 if abs(f1) < abs(f2) else x2


@inline
def _measure(value, k):  # pragma: no cover - compiled
    """``PEAK_MEASURES[k]`` of :mod:`envs.analysis.robustness`: ``|1/(1+L)|`` (``Ms``), ``|L/(1+L)|`` (``Mt``)."""
    closed = _magnitude(1 + value)
    return 1 / closed if k == 0 else _magnitude(value) / closed


@inline
def _argmax(samples):  # pragma: no cover - compiled
    """``numpy.argmax``: the first maximum (the first ``nan`` if any)."""
    best = 0
    for i in range(samples.size):
        if math.isnan(samples[i]):
            return i
        if samples[i] > samples[best]:
            best = i
    return best


@jit
def _peaks(transfer, omega, magnitudes, closed, points, spacing):  # pragma: no cover - compiled
    """:func:`envs.analysis.robustness._peaks`: ``(Ms, frequency, Mt, frequency)``, each grid maximum refined
    by zoomed sampling and a parabola (``magnitudes = |L|``, ``closed = |1 + L|`` on the grid: the
    terms of :func:`_measure`; :func:`_peak`)."""
    ms, ms_frequency = _peak(transfer, omega, magnitudes, closed, points, spacing, 0)
    mt, mt_frequency = _peak(transfer, omega, magnitudes, closed, points, spacing, 1)
    return ms, ms_frequency, mt, mt_frequency


@jit
def _peak(transfer, omega, magnitudes, closed, points, spacing, k):  # pragma: no cover - compiled
    """One peak of :func:`_peaks`: ``Ms`` (``k = 0``) or ``Mt`` (``k = 1``) and its frequency."""
    samples = np.empty(omega.size)
    for i in range(omega.size):
        samples[i] = 1 / closed[i] if k == 0 else magnitudes[i] / closed[i]
    i = _argmax(samples)
    best, at_best = samples[i], omega[i]
    low, high = math.log(omega[max(i - 1, 0)]), math.log(omega[min(i + 1, omega.size - 1)])
    vertex = math.nan
    while high > low:
        x = _linspace(low, high, points)
        frequencies = np.empty(points)
        for i in range(points):
            frequencies[i] = math.exp(x[i])
        at = _values(transfer, frequencies)
        samples = np.empty(points)
        for i in range(points):
            samples[i] = _measure(at[i], k)
        j = _argmax(samples)
        if samples[j] > best:
            best, at_best = samples[j], math.exp(x[j])
        low, high = x[max(j - 1, 0)], x[min(j + 1, points - 1)]
        if x[1] - x[0] <= spacing:
            vertex = _vertex(x, samples, j)
            break
    if not math.isnan(vertex):
        value = _measure(_values(transfer, np.array([math.exp(vertex)]))[0], k)
        if value > best:
            best, at_best = value, math.exp(vertex)
    return best, at_best


@inline
def _vertex(x, samples, j):  # pragma: no cover - compiled
    """:func:`envs.analysis.robustness._vertex`, with ``nan`` for None."""
    if j == 0 or j == x.size - 1:
        return math.nan
    left, middle, right = samples[j - 1], samples[j], samples[j + 1]
    curvature = left - 2 * middle + right
    if not curvature < 0:
        return math.nan
    return x[j] + 0.5 * (x[1] - x[0]) * (left - right) / curvature


@jit
def _gain_margin(phase_crossovers, values):  # pragma: no cover - compiled
    """:func:`envs.analysis.robustness._gain_margin`."""
    best, frequency = math.inf, math.nan
    for i in range(values.size):
        factor = 1 / abs(values[i])
        if factor > 1 and (math.isnan(frequency) or factor < best):
            best, frequency = factor, phase_crossovers[i]
    return best, frequency


@jit
def _phase_and_delay_margins(gain_crossovers, values):  # pragma: no cover - compiled
    """:func:`envs.analysis.robustness._phase_and_delay_margins` (the phase margin smallest in magnitude)."""
    phase_margin, at_phase, delay_margin, at_delay = math.inf, math.nan, math.inf, math.nan
    margins = np.empty(values.size)
    for i in range(values.size):
        angle = math.atan2(values[i].imag, values[i].real)
        margin = (angle + 2 * math.pi) % (2 * math.pi) - math.pi
        delay = ((angle + math.pi) % (2 * math.pi)) / gain_crossovers[i]
        margins[i] = margin
        if math.isnan(at_phase) or abs(margin) < abs(phase_margin):
            phase_margin, at_phase = margin, gain_crossovers[i]
        if math.isnan(at_delay) or delay < delay_margin:
            delay_margin, at_delay = delay, gain_crossovers[i]
    return phase_margin, at_phase, delay_margin, at_delay, margins
