"""The compiled kernels of :mod:`envs.identification.sampled_signals`: checks and trapezoid terms.

The terms of the trapezoidal rule
(``numpy.trapezoid(y, t)`` is ``(diff(t) * (y[1:] + y[:-1]) / 2.0).sum()``) formed without numpy's
temporaries; numpy's own ``sum`` adds the terms (its pairwise summation) in
:mod:`envs.identification.sampled_signals`, so the results are numpy.trapezoid's bits (the unit tests
compare them).

Every compiled function calls only compiled functions of this package, whose numba cache
:mod:`envs._kernel_cache` drops whenever any of its kernel modules changes.
"""

from __future__ import annotations

import numba
import numpy as np



@numba.njit(cache=True)
def _trapezoid_terms(y, t):  # pragma: no cover - compiled
    """The terms ``(t[i+1] - t[i]) (y[i+1] + y[i]) / 2`` of numpy.trapezoid."""
    terms = np.empty(max(t.size - 1, 0))
    for i in range(terms.size):
        terms[i] = (t[i + 1] - t[i]) * (y[i + 1] + y[i]) / 2.0
    return terms


@numba.njit(cache=True)
def _distance_terms(y, z, t):  # pragma: no cover - compiled
    """The trapezoid terms of ``|y - z|``."""
    terms = np.empty(max(t.size - 1, 0))
    for i in range(terms.size):
        terms[i] = (t[i + 1] - t[i]) * (abs(y[i + 1] - z[i + 1]) + abs(y[i] - z[i])) / 2.0
    return terms


@numba.njit(cache=True)
def _moment_terms(t, s, initial, final):  # pragma: no cover - compiled
    """The trapezoid terms of ``c`` and of ``(t - t[0]) c`` (see :func:`_moments`)."""
    n = t.size
    c = np.empty(n)
    for i in range(n):
        c[i] = 1.0 - (s[i] - initial) / (final - initial)
    first, second = np.empty(max(n - 1, 0)), np.empty(max(n - 1, 0))
    for i in range(n - 1):
        step = t[i + 1] - t[i]
        first[i] = step * (c[i + 1] + c[i]) / 2.0
        second[i] = step * ((t[i + 1] - t[0]) * c[i + 1] + (t[i] - t[0]) * c[i]) / 2.0
    return first, second


@numba.njit(cache=True)
def _pulse_distance_terms(t, y, gain, dead_time, height, duration):  # pragma: no cover - compiled
    """The trapezoid terms of :func:`_pulse_distance`."""
    distance = np.empty(t.size)
    for i in range(t.size):
        now = max(t[i] - dead_time, 0.0)
        before = max((t[i] - duration) - dead_time, 0.0)
        distance[i] = abs(y[i] - height * (gain * now - gain * before))
    terms = np.empty(max(t.size - 1, 0))
    for i in range(terms.size):
        terms[i] = (t[i + 1] - t[i]) * (distance[i + 1] + distance[i]) / 2.0
    return terms
