"""The coefficients of a plant's transfer function ``num(s)/den(s)`` (descending powers of ``s``).

:func:`_as_coefficients` checks and trims them as :class:`~envs.systems.plants.Plant` takes them (at
most :data:`MAX_COEFFICIENTS`); :func:`_roots` is ``numpy.roots`` on the same companion matrix;
:func:`_taylor_coefficients` gives ``p_1``, ``p_2`` of ``G(s) e^{-L s}/K = 1 + p_1 s + p_2 s^2 + ...``
(Gorez-Klan appendix A), and :func:`shape_residence_time` the residence time ``T_ar = -p_1`` of a
shape before it is scaled into a plant.
"""

from __future__ import annotations

import math
import reprlib
from typing import Any

import numpy as np

__all__ = ["MAX_COEFFICIENTS", "shape_residence_time"]


MAX_COEFFICIENTS = 101
"""The documented largest plant: at most this many coefficients in ``num`` and in ``den`` (order 100;
the lag chains of the plant families reach order 10).  Larger ones are refused (``num``, ``den``): the
poles' computation grows with the cube of the order (3,000 coefficients take half a minute, 6,000
over two), so a plant of millions would never finish."""


def _as_coefficients(values: Any, field: str) -> tuple[float, ...]:
    if isinstance(values, list | tuple | np.ndarray) and len(values) > MAX_COEFFICIENTS:
        raise ValueError(f"{field} must have at most {MAX_COEFFICIENTS} coefficients (the documented limit, "
                         f"envs.systems.plants.MAX_COEFFICIENTS), got {len(values)}")
    if type(values) is tuple and values and all(isinstance(v, float) and math.isfinite(v) for v in values):  # usual
        for k, v in enumerate(values):
            if v != 0.0:
                return tuple(float(c) for c in values[k:])
        raise ValueError(f"{field} must not be all zero")
    array = _numbers(values, field)
    if array.size == 0:
        raise ValueError(f"{field} must not be empty")
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{field} must be finite numbers, got {reprlib.repr(values)}")
    nonzero = np.flatnonzero(array)
    if nonzero.size == 0:
        raise ValueError(f"{field} must not be all zero")
    return tuple(float(v) for v in array[nonzero[0]:])


def _numbers(values: Any, field: str) -> np.ndarray:
    """``values`` as a flat float array; booleans and strings, which numpy would convert, are refused."""
    items = values if isinstance(values, list | tuple) else [values]
    if any(isinstance(v, bool | str | bytes | np.bool_) for v in items):
        raise ValueError(f"{field} must be a list of numbers, got {reprlib.repr(values)}")
    try:
        array = np.asarray(values)
        if array.dtype.kind not in "iufO":  # O: e.g. Fraction or sympy numbers, converted by float()
            raise TypeError
        return array.astype(float).ravel()
    except (TypeError, ValueError, OverflowError):
        raise ValueError(f"{field} must be a list of numbers, got {reprlib.repr(values)}") from None


def _roots(coefficients: np.ndarray) -> np.ndarray:
    """``numpy.roots`` of coefficients without leading or trailing zeros: the eigenvalues of the same
    companion matrix, without its trimming (and, for a single root, without LAPACK)."""
    p = np.asarray(coefficients, dtype=float)
    if p.size < 2:
        return np.zeros(0)
    if p.size == 2:
        return np.array([-p[1] / p[0]])
    m = p.size - 1
    companion = np.zeros((m, m))  # numpy.roots's np.diag(np.ones(m - 1), -1), without its calls
    companion.ravel()[m :: m + 1] = 1.0
    companion[0, :] = -p[1:] / p[0]
    return np.linalg.eigvals(companion)


def _taylor_coefficients(num: tuple[float, ...], den: tuple[float, ...], dead_time: float) -> tuple[float, float]:
    """``(p1, p2)`` of :meth:`Plant.taylor_coefficients` for the rational part ``num/den`` (without the
    integrator) and the dead time ``dead_time``.

    Only the three lowest coefficients enter, so they are read as Python floats (the same divisions
    as on arrays, without building them).
    """
    n1 = num[-2] / num[-1] if len(num) > 1 else 0.0  # ascending, normalized: 1 + n1 s + n2 s^2
    n2 = num[-3] / num[-1] if len(num) > 2 else 0.0
    d1 = den[-2] / den[-1] if len(den) > 1 else 0.0
    d2 = den[-3] / den[-1] if len(den) > 2 else 0.0
    g1 = n1 - d1  # appendix A: n1 = g1 + d1
    g2 = n2 - d1 * g1 - d2  # n2 = g2 + d1 g1 + d2
    L = dead_time
    p1 = g1 - L  # times e^{-Ls} = 1 - L s + L^2 s^2 / 2
    p2 = g2 - L * g1 + L * L / 2
    return float(p1), float(p2)


def shape_residence_time(num: Any, den: Any) -> float:
    """``T_ar`` of ``Plant(num, den, 0.0)`` (stable ``num/den``), without building and validating the plant.

    For samplers that only need the residence time of a shape they then scale into a plant, which is
    validated; the coefficients are normalized exactly as :class:`Plant` does.
    """
    num, den = _as_coefficients(num, "num"), _as_coefficients(den, "den")
    scale = den[0]
    num = tuple(v / scale for v in num)
    den = tuple(v / scale for v in den)
    if den[-1] == 0.0:
        den = den[:-1]
    return -_taylor_coefficients(num, den, 0.0)[0]
