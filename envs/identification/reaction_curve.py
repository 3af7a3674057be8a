"""Marlin's process reaction curve: an FOPDT model read off an open-loop step response.

:func:`reaction_curve_tangent` (Method I) and :func:`reaction_curve_two_point` (Method II).

References
----------
.. [MA] T. Marlin, "Process Control", ch. 6, section 6.3 "The process reaction curve", eq. 6.1-6.6.
"""

from __future__ import annotations

import math

import numpy as np

from envs.identification.models import FOPDTModel
from envs.identification.sampled_signals import _signals
from envs.validation import require_number

__all__ = ["reaction_curve_tangent", "reaction_curve_two_point"]


# Marlin's Method II levels: 1 - e^{-1/3} (printed 28.3%) and 1 - e^{-1} (63.2%), eq. 6.5.
_LEVEL_28 = 1.0 - math.exp(-1.0 / 3.0)
_LEVEL_63 = 1.0 - math.exp(-1.0)


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
