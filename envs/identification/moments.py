"""The method of moments: ``T_ar``, ``T_a`` and the models they give.

* :func:`normalized_moments` (Gorez-Klan eq. 2-5, 2-6), :func:`residence_time_from_area`
  (Ingimundarson eq. 10), :func:`closed_loop_moments` (Gorez-Klan appendix B);
* :func:`apparent_time_constant` (eq. 2-6), :func:`theta_from_tau` (eq. 2-9, 2-10);
* :func:`fopdt_from_moments`, :func:`sopdt_from_moments` (eq. 2-8), :func:`sopdt_from_theta`.

References
----------
.. [GK] R. Gorez, P. Klan, "Simple models for process control".
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from envs.identification.models import FOPDTModel, SOPDTModel
from envs.identification.sampled_signals import _moments, _signals, _trapezoid
from envs.validation import require_number

__all__ = [
    "theta_from_tau",
    "sopdt_from_moments",
    "sopdt_from_theta",
    "fopdt_from_moments",
    "apparent_time_constant",
    "normalized_moments",
    "residence_time_from_area",
    "ClosedLoopMoments",
    "closed_loop_moments",
]


_THETA_STEP = 2.0 * float(np.finfo(float).eps)  # convergence of theta_from_tau: the step is below machine precision


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
