"""Sampled signals: their validation and integrals by the trapezoidal rule.

:func:`integrate` is the public integral; the private helpers are shared by the identification
formulas (:mod:`.moments`, :mod:`.open_loop_areas`, :mod:`.reaction_curve`).  Integrals use the
trapezoidal rule on the sample grid (second order in the sample time for the continuous signals of
:mod:`envs.simulation.delay_systems`); the terms are formed by the compiled functions of
:mod:`._sampled_signals_kernels` and added by numpy's own ``sum``, so the results are
``numpy.trapezoid``'s bits.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from envs.identification._sampled_signals_kernels import _distance_terms, _moment_terms, _trapezoid_terms

__all__ = ["integrate"]


# --------------------------------------------------------------------------- validation
def _signals(timepts: Any, **signals: Any) -> tuple[np.ndarray, ...]:
    """Validate a time grid and signals sampled on it."""
    t = np.asarray(timepts, dtype=float).ravel()
    if t.size < 2:
        raise ValueError(f"timepts must hold at least 2 samples, got {t.size}")
    if not np.isfinite(t).all() or (t[1:] <= t[:-1]).any():
        raise ValueError("timepts must be finite and strictly increasing")
    out = [t]
    for name, values in signals.items():
        v = np.asarray(values, dtype=float).ravel()
        if v.shape != t.shape:
            raise ValueError(f"{name} must have one value per time point ({t.size}), got {v.size}")
        if not np.isfinite(v).all():
            raise ValueError(f"{name} must be finite")
        out.append(v)
    return tuple(out)


# --------------------------------------------------------------------------- trapezoidal rule
# numpy.trapezoid(y, t) is ``(diff(t) * (y[1:] + y[:-1]) / 2.0).sum()``.  The compiled functions
# (:mod:`._sampled_signals_kernels`) form the same terms without numpy's temporaries, and numpy's own ``sum`` adds them (its pairwise
# summation), so the results are numpy.trapezoid's bits; the unit tests compare them.
def _trapezoid(y: np.ndarray, t: np.ndarray) -> float:
    """``float(numpy.trapezoid(y, t))`` of 1-D float64 arrays of the same size."""
    return float(_trapezoid_terms(y, t).sum())


def _trapezoid_of_distance(y: np.ndarray, z: np.ndarray, t: np.ndarray) -> float:
    """``float(numpy.trapezoid(numpy.abs(y - z), t))``."""
    return float(_distance_terms(y, z, t).sum())


def _moments(t: np.ndarray, s: np.ndarray, initial: float, final: float) -> tuple[float, float]:
    """``(M_0, M_1)`` of :func:`_normalized_moments`: the trapezoids of ``c = 1 - (s - initial)/(final -
    initial)`` and of ``(t - t[0]) c``, with numpy's operations and sums."""
    first, second = _moment_terms(t, s, initial, final)
    return float(first.sum()), float(second.sum())


def integrate(timepts: np.ndarray, values: np.ndarray, end: float | None = None) -> float:
    """Trapezoidal ``int_{t_0}^{end} values dt`` on the sample grid.

    ``end`` defaults to the last sample; between samples the signal is interpolated linearly
    (so the partial last interval is integrated to second order too).
    """
    t, v = _signals(timepts, values=values)
    if end is None or end >= t[-1]:
        return _trapezoid(v, t)
    if end <= t[0]:
        return 0.0
    k = int(np.searchsorted(t, end, side="right"))  # t[k-1] <= end < t[k]
    v_end = np.interp(end, t, v)
    return float(_trapezoid(v[:k], t[:k]) + 0.5 * (v[k - 1] + v_end) * (end - t[k - 1]))
