"""The limit cycle in a relay's record: whether it is periodic, and the ultimate period and gain.

:func:`relay_periodic` (the last three periods agree, widened by the jitter the noise explains) and
:func:`relay_estimates` (the period, and ``K_u = 4 d/(pi a)`` by the describing function, from the
peak amplitude and from the first harmonic) serve the simulated relay
(:mod:`envs.identification.relay`) and a sampled process's (:mod:`envs.process.runs`) alike.

References
----------
.. [AH] K. J. Astrom, T. Hagglund, "Automatic tuning of simple regulators with specifications on
   phase and amplitude margins", Automatica 20 (1984): relay feedback.
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from envs.identification.steady_state import noise_level

__all__ = ["relay_estimates", "relay_periodic"]


def relay_periodic(
    switches: list[float], times: list[float], measured: list[float], tolerance: float, quantization: float = 0.0
) -> bool:
    """Whether the last three periods of a relay's switching instants (each period between switches
    of the same direction) agree to ``tolerance``, widened by the period jitter the noise of the
    ``measured`` output since the first of them explains (:func:`_period_tolerance`); needs seven
    switches (three periods after the first half period).  The simulated relay and a sampled
    process's (:mod:`envs.process.runs`) use this same test.  Readings of a sensor of resolution
    ``quantization`` (not 0) add its error, ``q/sqrt(12)``, to the noise."""
    if len(switches) < 7:
        return False
    s = np.asarray(switches[-5:])
    last = s[2:] - s[:-2]
    return bool(np.ptp(last) <= _period_tolerance(times, measured, tolerance, s[0], quantization) * np.mean(last))


def _period_tolerance(times: list[float], measured: list[float], tolerance: float, since: float, quantization: float = 0.0) -> float:
    """``tolerance`` plus three times the relative period jitter expected from the noise:
    a switching instant moves by ``sigma/|y'|``, and ``|y'| ~ 2 pi a/T`` for an oscillation of
    amplitude ``a`` and period ``T``."""
    first = bisect.bisect_left(times, since)  # numpy.searchsorted of the list, without converting it
    y = np.asarray(measured[first:])
    noise, spread = noise_level(y), 0.5 * np.ptp(y) if y.size else 0.0
    if quantization:  # the quantizer's error, uniform over a step
        noise = math.hypot(noise, quantization / math.sqrt(12.0))
    if noise == 0.0:
        return tolerance
    if spread <= 10.0 * noise:  # chattering on noise (too little hysteresis): not a limit cycle
        return 0.0
    return tolerance + 3.0 * math.sqrt(2.0) * noise / (2.0 * math.pi * spread)


def relay_estimates(t: np.ndarray, y: np.ndarray, switches: np.ndarray, amplitude: float) -> dict:
    """Period, peak and first-harmonic amplitudes over the last two full periods: the identified
    fields of :class:`RelayResult` from a record (``t``, the measured output ``y`` about the relay's
    set point, the switching instants, the relay amplitude ``d``)."""
    nan = float("nan")
    if switches.size < 5:
        return dict(ultimate_period=nan, peak_amplitude=nan, ultimate_gain=nan, harmonic_amplitude=nan, harmonic_ultimate_gain=nan)
    begin, end = switches[-5], switches[-1]
    period = (end - begin) / 2.0
    inside = (t > begin) & (t < end)
    times = np.concatenate([[begin], t[inside], [end]])
    values = np.concatenate([[np.interp(begin, t, y)], y[inside], [np.interp(end, t, y)]])
    peak = 0.5 * (np.max(values) - np.min(values))
    omega = 2.0 * math.pi / period
    harmonic = abs(np.trapezoid(values * np.exp(-1j * omega * times), times)) * 2.0 / (end - begin)
    return dict(
        ultimate_period=period,
        peak_amplitude=peak,
        ultimate_gain=4.0 * amplitude / (math.pi * peak) if peak > 0 else nan,
        harmonic_amplitude=harmonic,
        harmonic_ultimate_gain=4.0 * amplitude / (math.pi * harmonic) if harmonic > 0 else nan,
    )
