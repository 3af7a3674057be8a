"""Noise-aware steady-state detection and noise estimation for sampled experiment signals.

Steady state is detected causally (:func:`steady_state_index`): the first time the mean of the
last window is within ``CONFIDENCE`` standard errors of its target (or of the previous window)
and the fitted slope is insignificant; without noise, the tolerance floor is
``STEADY_STATE_TOLERANCE`` times the change of the signal.  The noise is estimated from the data
(second differences inside a window, fourth differences for :func:`noise_level`), so no noise
level has to be known in advance.

The compiled running sums and window tests live in :mod:`envs.simulation._run_kernels`, with the loop
recursion, so that the closed-loop step can simulate and test in one compiled call.
"""

from __future__ import annotations

import math

import numpy as np

from envs.simulation._run_kernels import CONFIDENCE, STEADY_STATE_TOLERANCE, _extend_sums, _tests

__all__ = [
    "STEADY_STATE_TOLERANCE",
    "CONFIDENCE",
    "steady_state_index",
    "steady_state_mask",
    "noise_level",
]


def steady_state_index(
    timepts: np.ndarray,
    signal: np.ndarray,
    window: int,
    *,
    target: float | None = None,
    start: int = 0,
) -> int | None:
    """First sample ``k >= start`` at which ``signal`` is in steady state, judged causally.

    Over the window of the last ``window`` samples ending at ``k`` (``n`` samples, length ``W``):

    * noise ``sigma`` is estimated as the RMS of the second differences over ``sqrt(6)``;
    * the fitted slope ``b`` is insignificant: ``|b| W <= c sigma sqrt(12/n) + tol``;
    * with a ``target``: ``|mean - target| <= c sigma/sqrt(n) + tol``; without: the mean equals the
      previous window's, ``|mean_k - mean_{k-n}| <= c sigma sqrt(2/n) + tol``, and differs from the
      initial value 0 by more than ``c sigma/sqrt(n) + tol`` (the response has started);

    with ``c = CONFIDENCE`` and ``tol = STEADY_STATE_TOLERANCE`` times ``|target|`` (or ``|mean|``).
    Returns ``None`` if no sample qualifies.
    """
    mask = steady_state_mask(timepts, signal, window, target=target)
    hits = np.flatnonzero(mask[start:])
    return int(hits[0]) + start if hits.size else None


def steady_state_mask(timepts: np.ndarray, signal: np.ndarray, window: int, *, target: float | None = None) -> np.ndarray:
    """Per sample, whether the window ending there passes the tests of :func:`steady_state_index`.

    The samples are taken as equally spaced (``timepts`` is for the interface's symmetry).
    """
    return steady_state_tail(signal, window, 0, target=target)


def steady_state_tail(signal: np.ndarray, window: int, first: int, *, target: float | None = None) -> np.ndarray:
    """``steady_state_mask(timepts, signal, window, target=target)[first:]``, bit for bit, with the
    tests evaluated for the windows ending at or after ``first`` only (the running sums still start at
    sample 0, so every value is computed exactly as in the whole mask).

    A run extended over a growing horizon tests only its new samples with it: the mask is causal.
    """
    y = np.asarray(signal, dtype=float)
    n = int(window)
    if n < 3:
        raise ValueError(f"window must be >= 3 samples, got {window!r}")
    first = max(int(first), 0)
    mask = np.zeros(max(y.size - first, 0), dtype=bool)
    if y.size < n or first >= y.size:
        return mask
    lo = max(first - (n - 1), 0)  # index of the first window tested, among the window ends n - 1, n, ...
    ends = np.arange(n - 1 + lo, y.size)  # window [k - n + 1, k]
    all_sums = _window_sums(y, n)
    sums = all_sums[lo:]
    mean = sums / n
    index = np.arange(y.size, dtype=float)
    centered = _window_sums(index * y, n)[lo:] - (ends - (n - 1) / 2.0) * sums
    change = centered / (n * (n * n - 1) / 12.0) * (n - 1)  # fitted slope times the window length
    curvature = np.concatenate([[0.0, 0.0], np.diff(y, 2)])
    sigma = np.sqrt(_window_sums(curvature**2, n)[lo:] / n / 6.0)
    scale = abs(target) if target is not None else np.abs(mean)
    tol = STEADY_STATE_TOLERANCE * scale
    ok = np.abs(change) <= CONFIDENCE * sigma * math.sqrt(12.0 / n) + tol
    if target is not None:
        ok &= np.abs(mean - target) <= CONFIDENCE * sigma / math.sqrt(n) + tol
    else:
        all_mean = all_sums / n
        previous = np.concatenate([np.full(n, np.inf), all_mean[:-n]])[lo:]
        ok &= np.abs(mean - previous) <= CONFIDENCE * sigma * math.sqrt(2.0 / n) + tol
        ok &= np.abs(mean) > CONFIDENCE * sigma / math.sqrt(n) + tol
    mask[ends - first] = ok
    return mask


class SteadyStateTest:
    """:func:`steady_state_mask` of a signal that grows, computed for the new samples only.

    ``extend(signal)``, given the signal so far (whose earlier samples are those of the previous
    calls), returns ``steady_state_mask(timepts, signal, window, target=target)[previous size:]`` bit for
    bit: the running sums are continued from their last value in the same order as one ``cumsum`` of
    the whole signal, and every test is the same elementwise expression.  A ``resolution`` (not 0;
    readings of a sensor of that step) widens the test against the ``target`` by it.
    """

    def __init__(self, window: int, *, target: float | None = None, resolution: float = 0.0) -> None:
        self._n = int(window)
        if self._n < 3:
            raise ValueError(f"window must be >= 3 samples, got {window!r}")
        self._target, self._resolution = target, float(resolution)
        self._size = 0
        self._sums = np.zeros((3, 1025))  # running sums of y, k y and curvature^2, from 0 at sample 0

    def extend(self, signal: np.ndarray) -> np.ndarray:
        y = np.asarray(signal, dtype=float)
        old, size, n = self._size, y.size, self._n
        if size <= old:
            return np.zeros(0, dtype=bool)
        if size + 1 > self._sums.shape[1]:
            grown = np.zeros((3, max(size + 1, 2 * self._sums.shape[1])))
            grown[:, : old + 1] = self._sums[:, : old + 1]
            self._sums = grown
        _extend_sums(self._sums, y, old, size)
        self._size = size
        mask = np.zeros(size - old, dtype=bool)
        first = max(old, n - 1)
        if first < size:
            target = self._target
            _tests(self._sums, n, first, size, 0.0 if target is None else float(target), target is not None,
                   self._resolution, mask[first - old :])  # fmt: skip
        return mask


def _window_sums(values: np.ndarray, n: int) -> np.ndarray:
    """Sums over each run of ``n`` consecutive values (one per window end ``k >= n - 1``)."""
    c = np.concatenate([[0.0], np.cumsum(values)])
    return c[n:] - c[:-n]


def window_samples(scale: float, dt: float) -> int:
    return max(int(round(scale / dt)), 3)


def noise_level(signal: np.ndarray) -> float:
    """Robust white-noise standard deviation from fourth differences (MAD/0.6745/sqrt(70)).

    Fourth differences of a smooth signal are of order ``y^(4) dt^4`` (negligible at the sample
    times used here), those of white noise have standard deviation ``sqrt(70) sigma``; the median
    ignores the few samples near kinks (a dead time ending, a relay switching).
    """
    fourth = np.diff(np.asarray(signal, dtype=float), 4)
    return float(np.median(np.abs(fourth)) / 0.6745 / math.sqrt(70.0)) if fourth.size else 0.0
