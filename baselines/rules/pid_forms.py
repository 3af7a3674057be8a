"""PID forms, the ultimate point and the model quantities the tuning rules read.

* :func:`series_to_ideal`, :func:`ideal_to_series`: exact conversions between the unfiltered
  series form ``K_c (1 + 1/(T_i s)) (1 + T_d s)`` and the ideal form
  ``K_c (1 + 1/(T_i s) + T_d s)`` (Marlin eq. 8.27).
* :func:`ultimate_point`: ultimate gain and period from the exact frequency response
  (Marlin eq. 10.39-10.40).
* :func:`reaction_curve`: ``a = K L/T`` and the dead time of the process reaction curve; for an
  integrating model the ramp asymptote ``K_v (t - L - T)``.
* :func:`half_rule`: Skogestad's SOPDT -> FOPDT reduction.

References are listed in :mod:`baselines.rules.pid`.
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np
import scipy.optimize

from envs.identification.models import FOPDTModel, IntegratingModel, SOPDTModel
from envs.systems.plants import Plant

__all__ = [
    "Model",
    "UltimatePoint",
    "ReactionCurve",
    "series_to_ideal",
    "ideal_to_series",
    "ultimate_point",
    "reaction_curve",
    "half_rule",
]

Model = FOPDTModel | SOPDTModel | IntegratingModel


# --------------------------------------------------------------------------- forms
def series_to_ideal(kp: float, ti: float, td: float) -> tuple[float, float, float]:
    """Exact ideal equivalent of the unfiltered series PID.

    ``kp (1 + 1/(ti s)) (1 + td s) = kp' (1 + 1/(ti' s) + td' s)`` with
    ``kp' = kp (1 + td/ti)``, ``ti' = ti + td``, ``td' = ti td/(ti + td)`` ([AH95] ch. 3).

    Parameters
    ----------
    kp, ti, td : float
        Series gain, integral time ``> 0`` and derivative time ``>= 0``.

    Returns
    -------
    (kp, ti, td) : tuple of float
        The ideal-form parameters; ``ti' >= 4 td'`` always holds.
    """
    _check_times(ti, td)
    return kp * (1.0 + td / ti), ti + td, ti * td / (ti + td)


def ideal_to_series(kp: float, ti: float, td: float) -> tuple[float, float, float]:
    """Exact series equivalent of the unfiltered ideal PID, which exists iff ``ti >= 4 td``.

    The series times are the roots of ``x^2 - ti x + ti td = 0`` (the zeros of
    ``ti td s^2 + ti s + 1``); the larger one is taken as the integral time:
    ``ti_s = ti (1 + sqrt(1 - 4 td/ti))/2``, ``td_s = ti td/ti_s``, ``kp_s = kp ti_s/ti``
    ([AH95] ch. 3).

    Raises
    ------
    ValueError
        If ``ti < 4 td`` (complex zeros: no real series form).
    """
    _check_times(ti, td)
    if ti < 4.0 * td:
        raise ValueError(f"an ideal PID has a series form only if ti >= 4 td, got ti={ti!r}, td={td!r}")
    ti_series = 0.5 * ti * (1.0 + math.sqrt(1.0 - 4.0 * td / ti))
    return kp * ti_series / ti, ti_series, ti * td / ti_series


def _check_times(ti: float, td: float) -> None:
    if not (math.isfinite(ti) and ti > 0):
        raise ValueError(f"ti must be finite and > 0, got {ti!r}")
    if not (math.isfinite(td) and td >= 0):
        raise ValueError(f"td must be finite and >= 0, got {td!r}")


# --------------------------------------------------------------------------- ultimate point
class UltimatePoint(NamedTuple):
    """Ultimate gain ``K_u`` and period ``T_u`` (Marlin eq. 10.39-10.40); unpacks as a pair."""

    gain: float
    period: float

    @property
    def frequency(self) -> float:
        """Phase-crossover frequency ``w_u = 2 pi/T_u``."""
        return 2.0 * math.pi / self.period


def ultimate_point(model: Model | Plant) -> UltimatePoint:
    """Ultimate gain and period from the exact frequency response (no relay, no Pade).

    ``w_u`` is the lowest frequency with ``arg G(i w) e^{-i w L} = -pi`` (``brentq`` on the
    continuous phase, bracketed on a grid of 100 points per decade), ``K_u = 1/|G(i w_u)|`` and
    ``T_u = 2 pi/w_u`` (Marlin eq. 10.39, 10.40).  The phase is that of ``G/sign(K)``, and
    ``K_u`` carries the sign of the process gain, so that ``K_u G(i w_u) = -1``.

    Parameters
    ----------
    model : FOPDTModel, SOPDTModel, IntegratingModel or Plant

    Raises
    ------
    ValueError
        If the phase never reaches ``-pi`` (e.g. a first- or second-order lag without dead time).

    Examples
    --------
    Marlin Example 10.10, ``0.039/(5 s + 1)^3``: ``w_u = tan(pi/3)/5``, ``K_u = 8/0.039``.

    >>> point = ultimate_point(Plant.from_time_constants(0.039, [5.0, 5.0, 5.0]))
    >>> round(point.gain, 3), round(point.period, 3)
    (205.128, 18.138)
    """
    plant = model if isinstance(model, Plant) else model.plant()
    phase = _continuous_phase(plant)
    scale = plant.step_time_scale()
    omega = np.logspace(-4, 5, 901) / scale
    excess = phase(omega) + math.pi
    below = np.flatnonzero(excess <= 0.0)
    if below.size == 0:
        raise ValueError("the model's phase never reaches -180 degrees: no ultimate point")
    i = int(below[0])
    if i == 0:
        raise ValueError("the model's phase is already below -180 degrees at low frequency")
    def excess_at(w: float) -> float:
        return float(phase(np.array([w]))[0] + math.pi)

    w_u = scipy.optimize.brentq(excess_at, omega[i - 1], omega[i], xtol=1e-300, rtol=4 * np.finfo(float).eps)
    response = complex(plant.frequency_response(w_u))
    return UltimatePoint(gain=float(math.copysign(1.0 / abs(response), plant.gain)), period=2.0 * math.pi / w_u)


def _continuous_phase(plant: Plant):
    """``w -> arg(G(i w)/sign(K)) - w L``, continuous in ``w > 0``, ``0`` (or ``-pi/2`` with an
    integrator) at ``w -> 0``: a sum of factor angles, each taken on a branch that does not cut
    the positive imaginary axis."""
    zeros, poles = np.roots(plant.num), np.roots(plant.den)
    lead = plant.num[0] / plant.den[0] * math.copysign(1.0, plant.gain)

    def factor_angles(roots: np.ndarray, w: np.ndarray) -> np.ndarray:
        total = np.zeros_like(w)
        for r in roots:
            if r.real > 0:  # arg(i w - r) = pi + arg(r - i w), Re(r - i w) > 0
                total += math.pi + np.angle(r - 1j * w)
            else:
                total += np.angle(1j * w - r)
        return total

    def raw(w: np.ndarray) -> np.ndarray:
        return np.angle(lead) + factor_angles(zeros, w) - factor_angles(poles, w) - w * plant.dead_time

    start = -0.5 * math.pi if plant.integrating else 0.0
    offset = 2.0 * math.pi * round((raw(np.array([1e-12 / plant.step_time_scale()]))[0] - start) / (2.0 * math.pi))
    return lambda w: raw(np.asarray(w, dtype=float)) - offset


# --------------------------------------------------------------------------- model access
class ReactionCurve(NamedTuple):
    """The process reaction curve's ``a = R L`` and dead time ``L`` (and ``T``, ``None`` if
    integrating), ``R`` the maximum slope of the unit step response ([ZN], [AH95] ch. 2)."""

    a: float
    dead_time: float
    time_constant: float | None


def reaction_curve(model: FOPDTModel | IntegratingModel, rule: str = "rule") -> ReactionCurve:
    """``(a, L, T)`` of a FOPDT model (``a = K L/T``) or of an integrating model's ramp
    asymptote ``K_v (t - L_a)``, ``L_a = L + T`` (``a = K_v L_a``, ``T = None``).

    Raises
    ------
    ValueError
        For another model type, a zero dead time, or a FOPDT model without lag (``a`` infinite).
    """
    if isinstance(model, IntegratingModel):
        dead_time = model.dead_time + (model.time_constant or 0.0)
        _positive_dead_time(dead_time, rule)
        return ReactionCurve(model.gain * dead_time, dead_time, None)
    gain, time_constant, dead_time = _fopdt(model, rule)
    return ReactionCurve(gain * dead_time / time_constant, dead_time, time_constant)


def _fopdt(
    model: FOPDTModel, rule: str, *, need_lag: bool = True, need_dead_time: bool = True
) -> tuple[float, float, float]:
    """``(K, T, L)`` of a FOPDT model, refused (naming ``rule``) if ``L`` or ``T`` must be > 0."""
    _check_model(model, rule, (FOPDTModel,))
    if need_dead_time:
        _positive_dead_time(model.dead_time, rule)
    if need_lag and model.time_constant <= 0:
        raise ValueError(f"{rule} needs time_constant > 0, got {model.time_constant!r}")
    return model.gain, model.time_constant, model.dead_time


def _positive_dead_time(dead_time: float, rule: str) -> None:
    if dead_time <= 0:
        raise ValueError(f"{rule} needs dead_time > 0, got {dead_time!r}")


def _check_model(model: object, rule: str, accepted: tuple[type, ...]) -> None:
    if not isinstance(model, accepted):
        names = " or ".join(cls.__name__ for cls in accepted)
        raise ValueError(f"{rule} needs a {names}, got {type(model).__name__}")


def half_rule(model: SOPDTModel) -> FOPDTModel:
    """Skogestad's half rule ([SK]): the smaller lag ``T_2`` is split evenly between
    the larger lag and the dead time, ``K e^{-(L + T_2/2) s}/((T_1 + T_2/2) s + 1)``."""
    _check_model(model, "half_rule", (SOPDTModel,))
    t1, t2 = sorted(model.time_constants, reverse=True)
    return FOPDTModel(gain=model.gain, time_constant=t1 + t2 / 2, dead_time=model.dead_time + t2 / 2)
