"""Identification formulas and the low-order models they produce.

Pure functions of numbers and sampled signals; the experiments that produce the signals are in
:mod:`envs.identification.experiments`.

Models (frozen dataclasses, each with ``to_dict``, ``plant`` and an exact ``step_response``):

* :class:`FOPDTModel` ``K e^{-L s}/(T s + 1)`` (Gorez-Klan eq. 2-1, Ingimundarson eq. 1);
* :class:`SOPDTModel` ``K e^{-D_2 s}/((T_1 s + 1)(T_2 s + 1))`` (Gorez-Klan eq. 2-2);
* :class:`IntegratingModel` ``K_v e^{-L s}/(s (T s + 1))``, the two-parameter model
  ``K_v e^{-L s}/s`` (Ingimundarson eq. 2) when ``T`` is ``None``.

Formulas:

* method of moments: :func:`normalized_moments` (Gorez-Klan eq. 2-5, 2-6),
  :func:`residence_time_from_area` (Ingimundarson eq. 10), :func:`closed_loop_moments`
  (Gorez-Klan appendix B), :func:`apparent_time_constant` (eq. 2-6), :func:`theta_from_tau`
  (eq. 2-9, 2-10), :func:`fopdt_from_moments`, :func:`sopdt_from_moments` (eq. 2-8);
* open-loop areas: :func:`step_time_constant` (Ingimundarson eq. 11), :func:`ramp_time_constant`
  (eq. 12), :func:`fopdt_from_area`, :func:`mismatch_time` (eq. 20-22) and
  :func:`pulse_mismatch_area` (eq. 45-46);
* process reaction curve (Marlin, *Process Control*, section 6.3, eq. 6.1-6.6):
  :func:`reaction_curve_tangent` (Method I) and :func:`reaction_curve_two_point` (Method II).

Integrals of sampled signals use the trapezoidal rule on the sample grid (second order in the
sample time for the continuous signals of :mod:`envs.simulation.delay_systems`).

References
----------
.. [GK] R. Gorez, P. Klan, "Simple models for process control".
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000.
.. [MA] T. Marlin, "Process Control", ch. 6, section 6.3 "The process reaction curve".
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from envs.identification._models_kernels import (
    _distance_terms,
    _moment_terms,
    _pulse_distance_terms,
    _trapezoid_terms,
)
from envs.systems.plants import Plant
from envs.validation import check_keys, require_number

__all__ = [
    "FOPDTModel",
    "SOPDTModel",
    "IntegratingModel",
    "Model",
    "model_from_dict",
    "theta_from_tau",
    "sopdt_from_moments",
    "sopdt_from_theta",
    "fopdt_from_moments",
    "apparent_time_constant",
    "normalized_moments",
    "residence_time_from_area",
    "ClosedLoopMoments",
    "closed_loop_moments",
    "integrate",
    "step_time_constant",
    "ramp_time_constant",
    "fopdt_from_area",
    "mismatch_time",
    "pulse_mismatch_area",
    "reaction_curve_tangent",
    "reaction_curve_two_point",
    "MIN_TIME_CONSTANT_FRACTION",
]

MIN_TIME_CONSTANT_FRACTION = 1e-3
"""Lower clip of an identified time constant, as a fraction of ``T_ar`` (see :func:`fopdt_from_area`)."""

# Marlin's Method II levels: 1 - e^{-1/3} (printed 28.3%) and 1 - e^{-1} (63.2%), eq. 6.5.
_LEVEL_28 = 1.0 - math.exp(-1.0 / 3.0)
_LEVEL_63 = 1.0 - math.exp(-1.0)
_THETA_STEP = 2.0 * float(np.finfo(float).eps)  # convergence of theta_from_tau: the step is below machine precision


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
# (envs.identification._models_kernels) form the same terms without numpy's temporaries, and numpy's own ``sum`` adds them (its pairwise
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


# --------------------------------------------------------------------------- models
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


# --------------------------------------------------------------------------- method of moments
def theta_from_tau(tau: float) -> float:
    """Solve Gorez-Klan eq. 2-9, ``1 - tau = (1 - theta) sqrt(1 + theta^2)``, for ``theta``.

    By the fixed-point iteration of eq. 2-10, ``theta <- 1 - (1 - tau)/sqrt(1 + theta^2)``, from
    ``theta = tau``, until the step is below machine precision.  The map is a contraction
    (its derivative ``(1 - tau) theta/(1 + theta^2)^{3/2}`` is below 0.385), so it converges for every
    ``tau`` in ``[0, 1]``.

    Parameters
    ----------
    tau : float
        Normalized dead time ``tau = 1 - T_a/T_ar`` (eq. 2-7), in ``[0, 1]``.

    Returns
    -------
    float
        ``theta`` in ``[0, 1]``, with ``theta >= tau``.

    Raises
    ------
    ValueError
        If ``tau`` is not a number in ``[0, 1]``.

    References
    ----------
    Gorez-Klan section 2, eq. 2-9 and 2-10.

    Examples
    --------
    >>> round(theta_from_tau(0.33), 2), round(theta_from_tau(0.68), 2)
    (0.37, 0.74)
    """
    tau = require_number(tau, "tau")
    if not 0.0 <= tau <= 1.0:
        raise ValueError(f"tau must be in [0, 1], got {tau!r}")
    theta = tau
    for _ in range(200):
        updated = 1.0 - (1.0 - tau) / math.sqrt(1.0 + theta * theta)
        if abs(updated - theta) <= _THETA_STEP:
            return updated
        theta = updated
    return theta


def sopdt_from_moments(gain: float, residence_time: float, tau: float) -> SOPDTModel:
    """The Gorez-Klan SOPDT model from ``K``, ``T_ar`` and ``tau``.

    ``T_1 = T_ar (1 - theta)``, ``T_2 = T_ar theta (1 - theta)``, ``D_2 = T_ar theta^2`` (eq. 2-8)
    with ``theta`` from :func:`theta_from_tau` (eq. 2-9, 2-10).

    Raises
    ------
    ValueError
        If ``gain`` is zero, ``residence_time`` is not positive or ``tau`` is outside ``[0, 1]``.

    References
    ----------
    Gorez-Klan section 2, eq. 2-2, 2-8.
    """
    gain = require_number(gain, "gain", nonzero=True)
    residence_time = require_number(residence_time, "residence_time", positive=True)
    return sopdt_from_theta(gain, residence_time, theta_from_tau(tau))


def sopdt_from_theta(gain: float, residence_time: float, theta: float) -> SOPDTModel:
    """:func:`sopdt_from_moments` with ``theta`` already solved (eq. 2-8)."""
    return SOPDTModel(
        gain=gain,
        time_constants=(residence_time * (1.0 - theta), residence_time * theta * (1.0 - theta)),
        dead_time=residence_time * theta * theta,
    )


def apparent_time_constant(residence_time: float, second_moment: float) -> float:
    """``T_a`` from eq. 2-6, ``(T_ar^2 + T_a^2)/2 = int_0^inf t [1 - r(t)/r(inf)] dt``.

    ``T_a^2 = 2 M_1 - T_ar^2`` is negative for plants with a strong right-half-plane zero (for
    ``(1 - T_0 s)/prod(1 + T_k s)``, ``T_a^2 = sum T_k^2 - T_0^2``, appendix A) and can exceed
    ``T_ar^2`` for strong lead; the result is clipped to ``[0, T_ar]`` so that ``tau`` is in ``[0, 1]``.

    References
    ----------
    Gorez-Klan eq. 2-6 and appendix A.
    """
    residence_time = require_number(residence_time, "residence_time", positive=True)
    square = 2.0 * require_number(second_moment, "second_moment") - residence_time**2
    return float(min(math.sqrt(max(square, 0.0)), residence_time))


def fopdt_from_moments(gain: float, residence_time: float, time_constant: float) -> FOPDTModel:
    """``K e^{-D_a s}/(T_a s + 1)`` with ``D_a = T_ar - T_a`` (Gorez-Klan eq. 2-1, 2-5).

    ``time_constant`` is ``T_a`` (e.g. from :func:`apparent_time_constant`), clipped to
    ``[0, T_ar]``.
    """
    gain = require_number(gain, "gain", nonzero=True)
    residence_time = require_number(residence_time, "residence_time", positive=True)
    t_a = min(max(require_number(time_constant, "time_constant"), 0.0), residence_time)
    return FOPDTModel(gain=gain, time_constant=t_a, dead_time=residence_time - t_a)


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


def normalized_moments(timepts: np.ndarray, signal: np.ndarray, initial: float, final: float) -> tuple[float, float]:
    """``(M_0, M_1)`` with ``M_k = int_{t_0}^{t_f} (t - t_0)^k [1 - z(t)] dt``.

    ``z = (signal - initial)/(final - initial)`` is the signal normalized to go from 0 to 1.
    For the step response of ``P(s)/K = 1 + p_1 s + p_2 s^2 + ...``, ``M_0 = -p_1 = T_ar`` and
    ``M_1 = p_2 = (T_ar^2 + T_a^2)/2`` (Gorez-Klan eq. 2-3, 2-5, 2-6): the Laplace transform of
    ``1 - z`` is ``(1 - P(s)/K)/s = -p_1 - p_2 s - ...``.

    Raises
    ------
    ValueError
        If ``final == initial`` or the signals are not finite.
    """
    t, s = _signals(timepts, signal=signal)
    return _normalized_moments(t, s, require_number(initial, "initial"), require_number(final, "final"))


def _normalized_moments(t: np.ndarray, s: np.ndarray, initial: float, final: float) -> tuple[float, float]:
    """:func:`normalized_moments` of signals already validated by :func:`_signals`."""
    if final == initial:
        raise ValueError(f"final must differ from initial, both are {final!r}")
    return _moments(t, s, float(initial), float(final))  # the trapezoids of 1 - z and (t - t_0)(1 - z)


def residence_time_from_area(
    timepts: np.ndarray,
    control: np.ndarray,
    output: np.ndarray,
    initial: tuple[float, float] | None = None,
    final: tuple[float, float] | None = None,
) -> float:
    """``T_ar`` as the area between the normalized input and output (Ingimundarson eq. 10).

    ``T_ar = int_{t_b}^{t_f} (u - u_b)/(u_f - u_b) dt - int_{t_b}^{t_f} (y - y_b)/(y_f - y_b) dt``.

    Parameters
    ----------
    timepts, control, output : ndarray
        Samples of ``u`` and ``y`` over ``[t_b, t_f]``.  For an integrating plant pass the
        integral of the input ``u_i(t) = int_{t_b}^t u dt`` as ``control`` (section 2.1); the result
        is then ``L_n`` of the two-parameter model eq. 2.
    initial, final : (float, float), optional
        ``(u_b, y_b)`` and ``(u_f, y_f)``; default the first and the last samples.  With noisy
        data pass averages over a steady-state window (section 2.3).

    References
    ----------
    Ingimundarson section 2.1, eq. 9 and 10, Fig. 1.
    """
    t, u, y = _signals(timepts, control=control, output=output)
    u_b, y_b = (u[0], y[0]) if initial is None else initial
    u_f, y_f = (u[-1], y[-1]) if final is None else final
    area_u = _normalized_area(t, u, u_b, u_f, "control")
    area_y = _normalized_area(t, y, y_b, y_f, "output")
    return area_u - area_y


def _normalized_area(t: np.ndarray, s: np.ndarray, initial: float, final: float, name: str) -> float:
    if final == initial:
        raise ValueError(f"{name} must change between the initial and the final level, both are {final!r}")
    return _trapezoid((s - initial) / (final - initial), t)


@dataclass(frozen=True)
class ClosedLoopMoments:
    """Taylor coefficients of a PI loop's set-point responses and the plant's characteristics.

    ``G = Y/R = 1 + g_1 s + g_2 s^2 + ...`` and ``Q = K U/R = 1 + q_1 s + q_2 s^2 + ...``
    (Gorez-Klan appendix B); ``residence_time`` ``T_ar = q_1 - g_1`` and ``apparent_time_constant``
    ``T_a = sqrt(2 (g_2 - q_2) + T_ar (T_ar + 2 g_1))`` (clipped to ``[0, T_ar]``).
    """

    g1: float
    g2: float
    q1: float
    q2: float
    residence_time: float
    apparent_time_constant: float


def closed_loop_moments(
    timepts: np.ndarray,
    control: np.ndarray,
    output: np.ndarray,
    final_control: float,
    final_output: float,
) -> ClosedLoopMoments:
    """Gorez-Klan appendix B: ``T_ar`` and ``T_a`` from a closed-loop set-point step.

    The loop starts at rest (deviation variables, ``u = y = 0``) and the set point steps at
    ``timepts[0]``; ``final_output`` is ``y(inf)`` (the set point, with integral action) and
    ``final_control`` is ``u(inf)``.  For an integrating plant pass the integrated input
    ``u_i = int u dt`` as ``control`` (Ingimundarson section 2.1); the results are then those of the
    dynamics additional to the integrator.

    Sign convention.  Appendix B prints ``g_1 = int [1 - y/y(inf)] dt``, but with
    ``G(s) = 1 + g_1 s + ...`` the Laplace transform of ``1 - y/y(inf)`` is ``(1 - G(s))/s``, whose
    value at ``s = 0`` is ``-g_1``: the integral is ``-g_1`` (and likewise ``-q_1``), while the
    printed ``g_2 = int t [1 - y/y(inf)] dt`` is right.  With these signs appendix B's own relations
    hold: ``G = Q (1 + p_1 s + p_2 s^2 + ...)`` gives ``g_1 = q_1 + p_1``, hence
    ``T_ar = -p_1 = q_1 - g_1`` (positive: the input leads the output), and the printed
    ``T_a`` formula, and ``K = T_i/(-g_1 K_p)`` for a PI (``g_1 < 0``).  Taking the printed ``g_1``
    literally would give ``T_ar < 0``.  The unit tests check this against the exact moments of a
    known plant (:meth:`envs.systems.plants.Plant.taylor_coefficients`).

    References
    ----------
    Gorez-Klan appendix B (and appendix A for the Taylor-McLaurin algebra); Ingimundarson eq. 9.
    """
    t, u, y = _signals(timepts, control=control, output=output)
    first_y, second_y = _normalized_moments(t, y, 0.0, require_number(final_output, "final"))
    first_u, second_u = _normalized_moments(t, u, 0.0, require_number(final_control, "final"))
    g1, g2, q1, q2 = -first_y, second_y, -first_u, second_u
    residence_time = q1 - g1
    square = 2.0 * (g2 - q2) + residence_time * (residence_time + 2.0 * g1)
    t_a = min(math.sqrt(max(square, 0.0)), max(residence_time, 0.0))
    return ClosedLoopMoments(g1, g2, q1, q2, float(residence_time), float(t_a))


# --------------------------------------------------------------------------- open-loop areas
def step_time_constant(area: float, height: float, gain: float) -> float:
    """``T_n = A e/(h K_n)`` (Ingimundarson eq. 11), unclipped.

    ``A = int_0^{T_ar} y dt`` for a step of height ``h`` at ``t = 0``: for the FOPDT model eq. 1,
    ``A = h K_n T_n e^{-1}``.
    """
    area = require_number(area, "area")
    return area * math.e / (require_number(height, "height", nonzero=True) * require_number(gain, "gain", nonzero=True))


def ramp_time_constant(area: float, rate: float, gain: float) -> float:
    """``T_n = sqrt(A/(h K_n (1/2 - e^{-1})))`` (Ingimundarson eq. 12); 0 if the radicand is <= 0.

    ``A = int_0^{T_ar} y dt`` for a ramp of rate ``h`` starting at ``t = 0``: for the FOPDT model,
    ``A = h K_n T_n^2 (1/2 - e^{-1})``.  Also valid for a step of height ``h`` into an integrating
    plant with ``K_n`` the velocity gain (section 2.2).
    """
    area = require_number(area, "area")
    square = area / (require_number(rate, "rate", nonzero=True) * require_number(gain, "gain", nonzero=True) * (0.5 - math.exp(-1.0)))
    return math.sqrt(square) if square > 0 else 0.0


def fopdt_from_area(gain: float, residence_time: float, time_constant: float) -> FOPDTModel:
    """The FOPDT model ``K_n e^{-L_n s}/(T_n s + 1)`` with ``L_n = T_ar - T_n`` (Ingimundarson 2.3).

    ``T_n`` (from eq. 11 or 12) is clipped to ``[MIN_TIME_CONSTANT_FRACTION T_ar, T_ar]`` so that
    ``L_n >= 0`` and ``T_n > 0``: an area larger than the FOPDT's (e.g. a plant with lead) means
    "no dead time", and a non-positive area (inverse response, or noise) "practically a pure
    dead time".  The clipping is visible: compare the returned ``time_constant`` with the input.
    """
    gain = require_number(gain, "gain", nonzero=True)
    residence_time = require_number(residence_time, "residence_time", positive=True)
    time_constant = require_number(time_constant, "time_constant")
    t_n = min(max(time_constant, MIN_TIME_CONSTANT_FRACTION * residence_time), residence_time)
    return FOPDTModel(gain=gain, time_constant=t_n, dead_time=residence_time - t_n)


def mismatch_time(timepts: np.ndarray, response: np.ndarray, model: FOPDTModel) -> float:
    """``T_f_bar = int |y(t) - y_n(t)| dt / |K_n|`` (Ingimundarson eq. 20-22, Fig. 5).

    Parameters
    ----------
    timepts : ndarray
        Times from the step (``t = 0``).
    response : ndarray
        The plant's response per unit step height ``y(t)/h``.
    model : FOPDTModel
        The model; ``y_n`` is its unit-step response (eq. 20).

    Notes
    -----
    ``A = int |f| dt`` bounds ``|(P - P_n)(i omega)/(i omega)|`` (eq. 22).  The integral runs over
    the samples given; with measurement noise it grows with the duration (``E|n|`` per unit time),
    and a gain mismatch makes it grow linearly: both are real effects of the experiment.
    """
    t, y = _signals(timepts, response=response)
    return _trapezoid_of_distance(y, model.step_response(t), t) / abs(model.gain)


def pulse_mismatch_area(
    timepts: np.ndarray, output: np.ndarray, model: IntegratingModel, height: float, duration: float
) -> float:
    """``A = int |y - y_n| dt / (h_p tau_p)`` for a pulse (Ingimundarson eq. 45-46, Fig. 12).

    ``y_n`` is the model's response to the pulse of height ``h_p`` on ``[0, tau_p)``,
    ``h_p (s(t) - s(t - tau_p))`` with ``s`` the model's unit-step response.  ``A`` bounds
    ``delta P_0`` of eq. 44 and is used as ``beta`` in eq. 43.
    """
    t, y = _signals(timepts, output=output)
    height, duration = require_number(height, "height", nonzero=True), require_number(duration, "duration", positive=True)
    if not model.time_constant:  # K_v max(t - L, 0): the response and the integral in one compiled pass
        return _pulse_distance(t, y, model.gain, model.dead_time, height, duration) / abs(height * duration)
    model_output = height * (model.step_response(t) - model.step_response(t - duration))
    return _trapezoid_of_distance(y, model_output, t) / abs(height * duration)


def _pulse_distance(t, y, gain, dead_time, height, duration) -> float:
    """``numpy.trapezoid(abs(y - y_n), t)`` for the pulse response ``y_n = h (s(t) - s(t - tau_p))`` of
    ``K_v e^{-L s}/s``, ``s(t) = K_v max(t - L, 0)``: the same operations as
    :meth:`IntegratingModel.step_response` (the sign of a zero ``max``, which numpy's SIMD and scalar
    loops may choose differently, is lost in ``abs``)."""
    return float(_pulse_distance_terms(t, y, gain, dead_time, height, duration).sum())


# --------------------------------------------------------------------------- reaction curve
def reaction_curve_tangent(
    timepts: np.ndarray, output: np.ndarray, height: float, final: float, window: int = 2
) -> FOPDTModel:
    """Marlin's process reaction curve, Method I (the tangent at the steepest slope).

    ``K_p = Delta/delta``, ``tau = Delta/S`` and ``theta`` the intersection of the tangent of
    maximum slope ``S`` with the initial value (Marlin section 6.3, eq. 6.2-6.4, Fig. 6.3).

    Parameters
    ----------
    timepts, output : ndarray
        The response ``y`` to a step of ``height`` (``delta``) at ``t = 0`` from rest at ``y = 0``.
    height : float
        ``delta``.
    final : float
        The steady-state change ``Delta``.
    window : int
        Number of samples of the least-squares line that estimates the slope: 2 is the finite
        difference (and then ``theta`` is exact for a FOPDT whose dead time is on the grid); a
        longer window smooths noise at the cost of a bias of about ``window dt/(2 tau)`` in ``tau``.

    References
    ----------
    T. Marlin, *Process Control*, section 6.3 "The process reaction curve", Method I (adapted from
    Ziegler and Nichols 1942), eq. 6.2-6.4, pp. 179-181.
    """
    t, y = _signals(timepts, output=output)
    height, final = require_number(height, "height", nonzero=True), require_number(final, "final", nonzero=True)
    if not isinstance(window, int | np.integer) or not 2 <= window <= t.size:
        raise ValueError(f"window must be an integer in [2, {t.size}], got {window!r}")
    slopes, centers, levels = _windowed_lines(t, y, int(window))
    k = int(np.argmax(slopes * np.sign(final)))
    slope = slopes[k]
    if slope * final <= 0:
        raise ValueError("output never moves towards final: no tangent of maximum slope")
    dead_time = max(centers[k] - levels[k] / slope, 0.0)
    return FOPDTModel(gain=final / height, time_constant=final / slope, dead_time=dead_time)


def _windowed_lines(t: np.ndarray, y: np.ndarray, window: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Least-squares line over each run of ``window`` samples: slopes, mean times, mean values."""
    kernel = np.ones(window) / window
    t_mean = np.convolve(t, kernel, mode="valid")
    y_mean = np.convolve(y, kernel, mode="valid")
    ty_mean = np.convolve(t * y, kernel, mode="valid")
    tt_mean = np.convolve(t * t, kernel, mode="valid")
    slopes = (ty_mean - t_mean * y_mean) / (tt_mean - t_mean**2)
    return slopes, t_mean, y_mean


def reaction_curve_two_point(timepts: np.ndarray, output: np.ndarray, height: float, final: float) -> FOPDTModel:
    """Marlin's process reaction curve, Method II (the 28% and 63% times).

    ``tau = 1.5 (t_63 - t_28)``, ``theta = t_63 - tau``, ``K_p = Delta/delta`` (Marlin eq. 6.5-6.6,
    Fig. 6.4), with ``t_28`` and ``t_63`` the first times the output reaches ``1 - e^{-1/3}``
    (28.3%) and ``1 - e^{-1}`` (63.2%) of ``Delta``, interpolated linearly between samples.  The
    exact levels (printed rounded as 28 and 63 percent) make the method exact for a FOPDT.
    ``theta`` is clipped at 0 (a plant with lead can reach 28% "too early").

    References
    ----------
    T. Marlin, *Process Control*, section 6.3 "The process reaction curve", Method II, eq. 6.5
    and 6.6, p. 181 (Smith 1972).
    """
    t, y = _signals(timepts, output=output)
    height, final = require_number(height, "height", nonzero=True), require_number(final, "final", nonzero=True)
    normalized = y / final
    t28 = _first_crossing(t, normalized, _LEVEL_28)
    t63 = _first_crossing(t, normalized, _LEVEL_63)
    time_constant = 1.5 * (t63 - t28)
    if time_constant <= 0:
        raise ValueError("the 28% and 63% times coincide: no time constant")
    return FOPDTModel(gain=final / height, time_constant=time_constant, dead_time=max(t63 - time_constant, 0.0))


def _first_crossing(t: np.ndarray, z: np.ndarray, level: float) -> float:
    above = np.flatnonzero(z >= level)
    if above.size == 0:
        raise ValueError(f"output never reaches {100 * level:.1f}% of final")
    k = int(above[0])
    if k == 0:
        return float(t[0])
    return float(t[k - 1] + (level - z[k - 1]) / (z[k] - z[k - 1]) * (t[k] - t[k - 1]))
