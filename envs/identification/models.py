"""The low-order models that identification produces.

Frozen dataclasses, each with ``to_dict``, ``plant`` and an exact ``step_response``:

* :class:`FOPDTModel` ``K e^{-L s}/(T s + 1)`` (Gorez-Klan eq. 2-1, Ingimundarson eq. 1);
* :class:`SOPDTModel` ``K e^{-D_2 s}/((T_1 s + 1)(T_2 s + 1))`` (Gorez-Klan eq. 2-2);
* :class:`IntegratingModel` ``K_v e^{-L s}/(s (T s + 1))``, the two-parameter model
  ``K_v e^{-L s}/s`` (Ingimundarson eq. 2) when ``T`` is ``None``.

:func:`model_from_dict` reads the JSON form ``to_dict`` writes.  The formulas that produce the
models from sampled signals are in :mod:`.moments` (method of moments), :mod:`.open_loop_areas`
(Ingimundarson's areas), :mod:`.reaction_curve` (Marlin's process reaction curve) and
:mod:`.least_squares`; the experiments that produce the signals in :mod:`.experiments`.

References
----------
.. [GK] R. Gorez, P. Klan, "Simple models for process control".
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from envs.systems.plants import Plant
from envs.validation import check_keys, require_number

__all__ = ["FOPDTModel", "SOPDTModel", "IntegratingModel", "Model", "model_from_dict"]


@dataclass(frozen=True)
class FOPDTModel:
    """First order plus dead time ``K e^{-L s}/(T s + 1)`` (Gorez-Klan eq. 2-1; Ingimundarson eq. 1).

    Attributes
    ----------
    gain : float
        Static gain ``K`` (``K_n``), non-zero.
    time_constant : float
        ``T`` (``T_a`` or ``T_n``), ``>= 0``; zero is a pure dead time.
    dead_time : float
        ``L`` (``D_a`` or ``L_n``), ``>= 0``, with ``T + L > 0``.
    """

    gain: float
    time_constant: float
    dead_time: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "gain", require_number(self.gain, "gain", nonzero=True))
        object.__setattr__(self, "time_constant", require_number(self.time_constant, "time_constant", nonnegative=True))
        object.__setattr__(self, "dead_time", require_number(self.dead_time, "dead_time", nonnegative=True))
        if self.time_constant + self.dead_time <= 0.0:
            raise ValueError("time_constant + dead_time must be > 0, got 0")

    @property
    def residence_time(self) -> float:
        """``T_ar = T + L`` (Gorez-Klan eq. 2-5)."""
        return self.time_constant + self.dead_time

    @property
    def normalized_dead_time(self) -> float:
        """``tau = L/(L + T)`` (Gorez-Klan eq. 2-7)."""
        return self.dead_time / self.residence_time

    def plant(self) -> Plant:
        """The model as a :class:`~envs.systems.plants.Plant`."""
        return Plant(num=(self.gain,), den=(self.time_constant, 1.0), dead_time=self.dead_time)

    def step_response(self, timepts: np.ndarray) -> np.ndarray:
        """Unit-step response ``K (1 - e^{-(t - L)/T})`` for ``t > L`` (Ingimundarson eq. 20)."""
        shifted = np.asarray(timepts, dtype=float) - self.dead_time
        return self.gain * _first_order_step(shifted, self.time_constant)

    def to_dict(self) -> dict[str, Any]:
        """``{"type": "fopdt", "gain", "time_constant", "dead_time"}``."""
        return {"type": "fopdt", "gain": self.gain, "time_constant": self.time_constant, "dead_time": self.dead_time}


@dataclass(frozen=True)
class SOPDTModel:
    """Second order plus dead time ``K e^{-D_2 s}/((T_1 s + 1)(T_2 s + 1))`` (Gorez-Klan eq. 2-2).

    Attributes
    ----------
    gain : float
        Static gain ``K``, non-zero.
    time_constants : tuple of two floats
        ``(T_1, T_2)``, each ``>= 0``.
    dead_time : float
        ``D_2 >= 0``; ``T_1 + T_2 + D_2 > 0``.
    """

    gain: float
    time_constants: tuple[float, float]
    dead_time: float

    def __post_init__(self) -> None:
        object.__setattr__(self, "gain", require_number(self.gain, "gain", nonzero=True))
        values = self.time_constants
        if isinstance(values, str | bytes) or not hasattr(values, "__len__") or len(values) != 2:
            raise ValueError(f"time_constants must be a pair [T1, T2], got {values!r}")
        pair = tuple(require_number(v, f"time_constants[{i}]", nonnegative=True) for i, v in enumerate(values))
        object.__setattr__(self, "time_constants", pair)
        object.__setattr__(self, "dead_time", require_number(self.dead_time, "dead_time", nonnegative=True))
        if self.residence_time <= 0.0:
            raise ValueError("time_constants and dead_time must not all be 0")

    @property
    def residence_time(self) -> float:
        """``T_ar = T_1 + T_2 + D_2`` (Gorez-Klan eq. 2-5)."""
        return self.time_constants[0] + self.time_constants[1] + self.dead_time

    def plant(self) -> Plant:
        """The model as a :class:`~envs.systems.plants.Plant` (zero time constants are dropped)."""
        lags = [t for t in self.time_constants if t > 0]
        return Plant.from_time_constants(self.gain, lags, self.dead_time)

    def step_response(self, timepts: np.ndarray) -> np.ndarray:
        """Exact unit-step response (``T_1 = T_2`` and zero time constants included)."""
        t = np.asarray(timepts, dtype=float) - self.dead_time
        t1, t2 = sorted(self.time_constants, reverse=True)
        if t2 == 0.0:
            return self.gain * _first_order_step(t, t1)
        tp = np.maximum(t, 0.0)
        if math.isclose(t1, t2, rel_tol=1e-9):
            shape = 1.0 - (1.0 + tp / t1) * np.exp(-tp / t1)
        else:
            shape = 1.0 - (t1 * np.exp(-tp / t1) - t2 * np.exp(-tp / t2)) / (t1 - t2)
        return self.gain * np.where(t > 0, shape, 0.0)

    def to_dict(self) -> dict[str, Any]:
        """``{"type": "sopdt", "gain", "time_constants": [T1, T2], "dead_time"}``."""
        return {
            "type": "sopdt",
            "gain": self.gain,
            "time_constants": list(self.time_constants),
            "dead_time": self.dead_time,
        }


@dataclass(frozen=True)
class IntegratingModel:
    """``K_v e^{-L s}/(s (T s + 1))``; with ``time_constant=None`` the two-parameter model
    ``K_v e^{-L s}/s`` of Ingimundarson eq. 2 (and eq. 35).

    Attributes
    ----------
    gain : float
        Velocity gain ``K_v`` (``K_n``), non-zero.
    dead_time : float
        ``L`` (``L_n``), ``>= 0``.
    time_constant : float or None
        ``T >= 0`` of the lag additional to the integrator, or ``None``.
    """

    gain: float
    dead_time: float
    time_constant: float | None = None

    def __post_init__(self) -> None:
        object.__setattr__(self, "gain", require_number(self.gain, "gain", nonzero=True))
        object.__setattr__(self, "dead_time", require_number(self.dead_time, "dead_time", nonnegative=True))
        if self.time_constant is not None:
            object.__setattr__(self, "time_constant", require_number(self.time_constant, "time_constant", nonnegative=True))

    @property
    def residence_time(self) -> float:
        """``T_ar = L + T`` of the dynamics additional to the integrator (Ingimundarson section 2.1)."""
        return self.dead_time + (self.time_constant or 0.0)

    def plant(self) -> Plant:
        """The model as an integrating :class:`~envs.systems.plants.Plant`."""
        lags = [self.time_constant] if self.time_constant else []
        return Plant.from_time_constants(self.gain, lags, self.dead_time, integrating=True)

    def step_response(self, timepts: np.ndarray) -> np.ndarray:
        """Exact unit-step response ``K_v (t' - T (1 - e^{-t'/T}))``, ``t' = max(t - L, 0)``."""
        tp = np.maximum(np.asarray(timepts, dtype=float) - self.dead_time, 0.0)
        lag = self.time_constant or 0.0
        ramp = tp - lag * _first_order_step(tp, lag) if lag > 0 else tp
        return self.gain * ramp

    def to_dict(self) -> dict[str, Any]:
        """``{"type": "integrating", "gain", "dead_time", "time_constant"}`` (``None`` -> ``null``)."""
        return {"type": "integrating", "gain": self.gain, "dead_time": self.dead_time, "time_constant": self.time_constant}


Model = FOPDTModel | SOPDTModel | IntegratingModel

_MODEL_KEYS = {
    "fopdt": (FOPDTModel, {"gain", "time_constant", "dead_time"}, set()),
    "sopdt": (SOPDTModel, {"gain", "time_constants", "dead_time"}, set()),
    "integrating": (IntegratingModel, {"gain", "dead_time"}, {"time_constant"}),
}


def model_from_dict(data: Any) -> Model:
    """Parse the JSON form written by ``to_dict`` of any model.

    Raises
    ------
    ValueError
        Naming the offending key, e.g. ``"model.time_constant must be >= 0, got -1.0"``.
    """
    if not isinstance(data, dict):
        raise ValueError(f"model must be a JSON object, got {type(data).__name__}")
    kind = data.get("type")
    if kind not in _MODEL_KEYS:
        raise ValueError(f"model.type must be one of {sorted(_MODEL_KEYS)}, got {kind!r}")
    cls, required, optional = _MODEL_KEYS[kind]
    check_keys(set(data) - {"type"}, "model", required, optional, kind)
    fields = {k: v for k, v in data.items() if k != "type"}
    if kind == "sopdt" and not isinstance(fields["time_constants"], list | tuple):
        raise ValueError(f"model.time_constants must be a list [T1, T2], got {fields['time_constants']!r}")
    try:
        return cls(**fields)
    except ValueError as error:
        raise ValueError(f"model.{error}") from None


def _first_order_step(t: np.ndarray, time_constant: float) -> np.ndarray:
    """``1 - e^{-t/T}`` for ``t > 0`` and 0 before (a unit step at ``t = 0`` if ``T = 0``)."""
    t = np.asarray(t, dtype=float)
    if time_constant == 0.0:
        return (t >= 0).astype(float)
    return np.where(t > 0, -np.expm1(-np.maximum(t, 0.0) / time_constant), 0.0)
