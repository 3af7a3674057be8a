"""Ingimundarson's open-loop areas: the time constant from a step or a ramp, and the mismatch.

:func:`step_time_constant` (eq. 11), :func:`ramp_time_constant` (eq. 12), :func:`fopdt_from_area`
(section 2.3), :func:`mismatch_time` (eq. 20-22) and :func:`pulse_mismatch_area` (eq. 45-46).

References
----------
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000.
"""

from __future__ import annotations

import math

import numpy as np

from envs.identification._sampled_signals_kernels import _pulse_distance_terms
from envs.identification.models import FOPDTModel, IntegratingModel
from envs.identification.sampled_signals import _signals, _trapezoid_of_distance
from envs.validation import require_number

__all__ = [
    "MIN_TIME_CONSTANT_FRACTION",
    "step_time_constant",
    "ramp_time_constant",
    "fopdt_from_area",
    "mismatch_time",
    "pulse_mismatch_area",
]


MIN_TIME_CONSTANT_FRACTION = 1e-3
"""Lower clip of an identified time constant, as a fraction of ``T_ar`` (see :func:`fopdt_from_area`)."""


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
