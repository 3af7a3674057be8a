"""The unit-gain shapes ``G0(s)`` of the random plant families (:mod:`envs.systems.families`).

Each shape draws its parameters uniformly from the ranges of :class:`ShapeRanges` and returns a
unit-static-gain ``(num, den)`` in descending powers of ``s``:

=============  ======================================================  ===========================
shape          ``G0(s)``                                               parameters (uniform)
=============  ======================================================  ===========================
lag            ``1/(s+1)``                                             --
two-lags       ``1/((s+1)(r s+1))``                                    ``r``: time_constant_ratio
underdamped    ``1/(s^2 + 2 zeta s + 1)``                              ``zeta``: damping
lag-n          ``1/(s+1)^n``                                           ``n``: lag_orders (integers)
geometric      ``1/((1+s)(1+as)(1+a^2 s)(1+a^3 s))``                   ``a``: geometric_ratio
nmp            ``(1-as)/(s+1)^m``                                      ``a``: zero_time_constant,
                                                                       ``m``: one of nmp_orders
resonant       ``1/((s+1)(s^2/w^2 + 2 zeta s/w + 1))`` (Ingimundarson  ``w``: resonant_frequency,
               P5: ``w = 3``, ``zeta = 1/3``)                          ``zeta``: resonant_damping
parallel       ``(1-c)/(s+1) + c/(Ts+1)`` (Ingimundarson P6:           ``c``: slow_weight,
               ``c = 0.5``, ``T = 10``)                                ``T``: slow_time_constant
=============  ======================================================  ===========================

Ingimundarson's P7 ``64/((s+1)(s+2)(s+4)(s+8))`` is the geometric shape with ``a = 1/2``.

References
----------
.. [1] R. Gorez, P. Klan, "Simple models for process control", section 4, eq. 4-15, 4-16.
.. [2] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000, section 4.4 (Table 1) and section 5.3 (Table 2).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

__all__ = ["SHAPES", "ShapeRanges"]


def _check_interval(name: str, value: object, condition: Callable[[float, float], bool], requirement: str) -> None:
    try:
        low, high = (float(v) for v in value)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a pair (low, high), got {value!r}") from None
    if not (np.isfinite(low) and np.isfinite(high) and low <= high and condition(low, high)):
        raise ValueError(f"{name} must be (low, high) with low <= high and {requirement}, got {value!r}")


def _positive(name: str, value: object) -> None:
    _check_interval(name, value, lambda low, high: low > 0, "0 < low")


@dataclass(frozen=True)
class ShapeRanges:
    """Ranges of the normalized shape parameters; each is drawn uniformly from its range.

    Attributes
    ----------
    time_constant_ratio : (float, float)
        ``r = T2/T1`` of ``two-lags``, in ``(0, 1]``.  Default ``(0.05, 1.0)``.
    damping : (float, float)
        ``zeta`` of ``underdamped``, ``> 0``.  Default ``(0.4, 1.0)``.
    lag_orders : (int, int)
        Inclusive range of ``n`` of ``lag-n``, ``>= 1``.  Default ``(2, 10)`` (Gorez-Klan P2: 10).
    geometric_ratio : (float, float)
        ``a`` of ``geometric``, in ``(0, 1]``.  Default ``(0.2, 0.9)`` (Gorez-Klan P1: 0.4).
    zero_time_constant : (float, float)
        ``a`` of the right-half-plane zero ``(1 - a s)`` of ``nmp``, ``> 0``.  Default
        ``(0.1, 2.0)`` (Ingimundarson P3: 1, P4: 2).
    nmp_orders : tuple of int
        Orders ``m`` of ``nmp``, one drawn uniformly.  Default ``(3, 5)``.
    resonant_frequency, resonant_damping : (float, float)
        ``w`` (relative to the real pole) and ``zeta`` of ``resonant``.  Defaults ``(1.5, 5.0)``
        and ``(0.2, 0.7)`` (Ingimundarson P5: 3, 1/3).
    slow_weight, slow_time_constant : (float, float)
        ``c`` in ``[0, 1]`` and ``T > 0`` of ``parallel``.  Defaults ``(0.2, 0.8)`` and
        ``(3.0, 30.0)`` (Ingimundarson P6: 0.5, 10).
    """

    time_constant_ratio: tuple[float, float] = (0.05, 1.0)
    damping: tuple[float, float] = (0.4, 1.0)
    lag_orders: tuple[int, int] = (2, 10)
    geometric_ratio: tuple[float, float] = (0.2, 0.9)
    zero_time_constant: tuple[float, float] = (0.1, 2.0)
    nmp_orders: tuple[int, ...] = (3, 5)
    resonant_frequency: tuple[float, float] = (1.5, 5.0)
    resonant_damping: tuple[float, float] = (0.2, 0.7)
    slow_weight: tuple[float, float] = (0.2, 0.8)
    slow_time_constant: tuple[float, float] = (3.0, 30.0)

    def __post_init__(self) -> None:
        for name in ("damping", "zero_time_constant", "resonant_frequency", "resonant_damping", "slow_time_constant"):
            _positive(name, getattr(self, name))
        for name in ("time_constant_ratio", "geometric_ratio"):
            _check_interval(name, getattr(self, name), lambda low, high: 0 < low and high <= 1, "0 < low, high <= 1")
        _check_interval("slow_weight", self.slow_weight, lambda lo, hi: lo >= 0 and hi <= 1, "0 <= low, high <= 1")
        _check_interval(
            "lag_orders", self.lag_orders, lambda low, high: low >= 1 and low == int(low) and high == int(high),
            "integers >= 1",
        )
        if not self.nmp_orders or any(int(m) != m or m < 1 for m in self.nmp_orders):
            raise ValueError(f"nmp_orders must be a non-empty tuple of integers >= 1, got {self.nmp_orders!r}")


def _lags(*time_constants: float) -> np.ndarray:
    den = np.array([1.0])
    for t in time_constants:
        den = np.convolve(den, [t, 1.0])  # numpy.polymul of polynomials without leading zeros
    return den


def _underdamped(rng: np.random.Generator, r: ShapeRanges) -> tuple[np.ndarray, np.ndarray]:
    return np.array([1.0]), np.array([1.0, 2.0 * rng.uniform(*r.damping), 1.0])


def _nmp(rng: np.random.Generator, r: ShapeRanges) -> tuple[np.ndarray, np.ndarray]:
    a = rng.uniform(*r.zero_time_constant)
    order = int(r.nmp_orders[rng.integers(len(r.nmp_orders))])
    return np.array([-a, 1.0]), _lags(*[1.0] * order)


def _resonant(rng: np.random.Generator, r: ShapeRanges) -> tuple[np.ndarray, np.ndarray]:
    w, zeta = rng.uniform(*r.resonant_frequency), rng.uniform(*r.resonant_damping)
    return np.array([1.0]), np.convolve([1.0, 1.0], [1.0 / w**2, 2.0 * zeta / w, 1.0])


def _parallel(rng: np.random.Generator, r: ShapeRanges) -> tuple[np.ndarray, np.ndarray]:
    c, t = rng.uniform(*r.slow_weight), rng.uniform(*r.slow_time_constant)
    return np.array([(1.0 - c) * t + c, 1.0]), _lags(1.0, t)  # (1-c)/(s+1) + c/(ts+1)


# Each shape draws its parameters and returns a unit-static-gain (num, den), descending powers.
_SHAPES: dict[str, Callable[[np.random.Generator, ShapeRanges], tuple[np.ndarray, np.ndarray]]] = {
    "lag": lambda rng, r: (np.array([1.0]), _lags(1.0)),
    "two-lags": lambda rng, r: (np.array([1.0]), _lags(1.0, rng.uniform(*r.time_constant_ratio))),
    "underdamped": _underdamped,
    "lag-n": lambda rng, r: (np.array([1.0]), _lags(*[1.0] * int(rng.integers(*r.lag_orders, endpoint=True)))),
    "geometric": lambda rng, r: (np.array([1.0]), _lags(*(rng.uniform(*r.geometric_ratio) ** np.arange(4)))),
    "nmp": _nmp,
    "resonant": _resonant,
    "parallel": _parallel,
}
SHAPES: tuple[str, ...] = tuple(_SHAPES)
