"""Validation shared by the numerical modules: one clear ``ValueError`` naming the field."""

from __future__ import annotations

import math
from typing import Any, Collection

import numpy as np

__all__ = ["require_number", "require_real_array", "check_keys", "require_dead_time"]


def require_number(
    value: Any, name: str, *, positive: bool = False, nonnegative: bool = False, nonzero: bool = False
) -> float:
    """``value`` as a finite float, or a ``ValueError`` such as ``"tr must be > 0, got -1.0"``.

    Booleans and strings are refused; the flags add the sign conditions.
    """
    if type(value) is not float:  # a float (the usual case) needs no conversion
        if isinstance(value, bool) or not isinstance(value, int | float | np.integer | np.floating):
            raise ValueError(f"{name} must be a number, got {value!r}")
        try:
            value = float(value)
        except OverflowError:
            raise ValueError(f"{name} must be finite, got a number too large for a float") from None
    if not math.isfinite(value):
        raise ValueError(f"{name} must be finite, got {value!r}")
    if positive and value <= 0:
        raise ValueError(f"{name} must be > 0, got {value!r}")
    if nonnegative and value < 0:
        raise ValueError(f"{name} must be >= 0, got {value!r}")
    if nonzero and value == 0:
        raise ValueError(f"{name} must be non-zero, got {value!r}")
    return value


def require_real_array(value: Any, name: str) -> np.ndarray:
    """``value`` as a float64 array of finite real numbers, its shape kept.

    Booleans, complex numbers, strings and objects are refused (``numpy.asarray(..., dtype=float)``
    would turn ``True`` into 1.0 and drop an imaginary part): ``"action must be real numbers, got
    bool"``, ``"action must be finite, got [nan]"``.

    >>> require_real_array([0.5], "action"), require_real_array(1, "action").shape
    (array([0.5]), ())
    """
    array = np.asarray(value)
    if array.dtype.kind not in "iuf":
        raise ValueError(f"{name} must be real numbers, got {array.dtype.name if array.dtype.kind != 'U' else 'text'}")
    array = array.astype(np.float64, copy=False)
    if not np.all(np.isfinite(array)):
        raise ValueError(f"{name} must be finite, got {array.tolist()}")
    return array


def check_keys(
    keys: Collection[str], what: str, required: Collection[str], optional: Collection[str] = (), kind: str | None = None
) -> None:
    """Refuse an unknown or a missing key of the JSON object ``what`` (of type ``kind``, if any)."""
    suffix = f" for type {kind!r}" if kind is not None else ""
    unknown = sorted(set(keys) - set(required) - set(optional))
    if unknown:
        raise ValueError(f"{what} has unknown key {unknown[0]!r}{suffix}")
    missing = sorted(set(required) - set(keys))
    if missing:
        raise ValueError(f"{what} is missing key {missing[0]!r}{suffix}")


def require_dead_time(dead_time: float, relative_degree: int, name: str) -> None:
    """Refuse a plant given without dead time whose step response shows none either.

    The rules and the dead-time structures design from a dead time: Gorez & Klan's PID from ``D_2 =
    theta^2 T_ar`` with ``K_i = 1/(mu K D_2)`` (eq. 2-10, 3-11), Ingimundarson's FPPI and modified Smith
    predictor from ``L`` (``T_r`` in units of ``L``, eq. 14-51).  A delay-free plant of relative degree 2
    or more (``1/(s+1)^4``, Gorez & Klan's P1 and P2) shows an apparent dead time and is accepted; one of
    relative degree 0 or 1 (``1/(10 s + 1)``) shows none, and its episodes would be scored apart from
    the limit of small delays, so ``name`` (the plant's ``delay``) is refused: give it a dead time > 0.
    """
    if dead_time == 0 and relative_degree < 2:
        raise ValueError(f"{name} must be > 0 for a plant of relative degree {relative_degree} (the rules and the "
                         "dead-time structures need a dead time, given or apparent from relative degree 2 or more)")
