"""Experiment 5: relay feedback around the true plant, ultimate period and gain.

:func:`relay_feedback` closes a relay (with optional hysteresis) around the plant, time-stepped
exactly with interpolated switching instants, until the oscillation is periodic, and returns
``T_u`` and ``K_u = 4 d/(pi a)`` by the describing function (Astrom-Hagglund 1984), also from the
first harmonic of the output (harmonic balance).  The time stepping is
:mod:`envs.identification.relay_simulation`; the test of the limit cycle and the estimates read
off it, :mod:`envs.identification.relay_cycle`.

References
----------
.. [AH] K. J. Astrom, T. Hagglund, "Automatic tuning of simple regulators with specifications on
   phase and amplitude margins", Automatica 20 (1984): relay feedback.
.. [MA] T. Marlin, "Process Control", section 10.7: ultimate gain and period.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envs.identification.experiment_base import (
    ExperimentResult,
    cap_steps,
    check_plant,
    check_rng,
    measurement_noise,
    record_fields,
    ExperimentRun,
    sample_time,
)
from envs.identification.relay_cycle import relay_estimates
from envs.identification.relay_simulation import _RelaySimulation
from envs.systems.plants import NEGLIGIBLE_DEAD_TIME, Plant
from envs.validation import require_number

__all__ = ["RelayResult", "relay_feedback"]


@dataclass(frozen=True)
class RelayResult(ExperimentResult):
    """Relay feedback (experiment 5); ``control`` is the relay output at the sample times.

    Attributes
    ----------
    amplitude, hysteresis : float
        Relay amplitude ``d`` and hysteresis ``epsilon`` (on the control error).
    converged : bool
        The last three periods agreed to ``period_tolerance`` (plus the noise jitter).
    switching_times : ndarray
        Instants at which the relay switched (interpolated between samples).
    ultimate_period : float
        ``T_u``, mean of the last two full periods.
    peak_amplitude : float
        ``a``, half the peak-to-peak measured output over those periods.
    ultimate_gain : float
        ``K_u = 4 d/(pi a)`` (describing function of the relay, Astrom-Hagglund 1984).
    harmonic_amplitude, harmonic_ultimate_gain : float
        The same with ``a`` the amplitude of the first Fourier harmonic of the output over those
        periods, ``4 d/(pi a_1) = 1/|G(i omega)|`` exactly at the oscillation frequency (harmonic
        balance); robust to noise.
    """

    amplitude: float
    hysteresis: float
    converged: bool
    switching_times: np.ndarray
    ultimate_period: float
    peak_amplitude: float
    ultimate_gain: float
    harmonic_amplitude: float
    harmonic_ultimate_gain: float


def relay_feedback(
    plant: Plant,
    rng: np.random.Generator,
    amplitude: float,
    hysteresis: float = 0.0,
    noise_std: float = 0.0,
    dt: float | None = None,
    excursion_limit: float | None = None,
    max_duration: float | None = None,
    period_tolerance: float = 1e-3,
    *,
    disturbances=None,
    quantization: float = 0.0,
) -> RelayResult:
    """Relay feedback around the plant until the oscillation is periodic: ``T_u`` and ``K_u``.

    The relay output is ``u = sign(K) d s`` with the state ``s = +-1`` acting on the error
    ``e = -y_m`` (set point 0) with hysteresis ``epsilon``: ``s`` switches to ``-1`` when
    ``e < -epsilon`` and to ``+1`` when ``e > epsilon``, starting at ``s = +1`` (the operator knows
    the sign of the process gain, so the loop is negative feedback).
    The plant is time-stepped exactly (zero-order hold, the dead time exact): each switching
    instant is found by linear interpolation of the error between samples, and the plant input
    switches at that instant plus ``L``, inside the sample interval, by an exact sub-step.  So the
    period is accurate to second order in ``dt``.

    The describing function gives ``K_u = 4 d/(pi a)`` and ``T_u`` the period (Astrom-Hagglund
    1984; Marlin section 10.7 for the ultimate gain and period).  For a plant whose output
    oscillation is not sinusoidal this differs from the exact phase crossover: for
    ``K e^{-Ls}/s`` the period is exactly ``4 L`` (the true ``T_u``) but the output is a triangle
    of amplitude ``K d L`` and ``4 d/(pi a) = 4/(pi K L)`` against ``pi/(2 K L)``.  With hysteresis
    the oscillation sits where ``G(i omega) = -(pi a/4 d)(sqrt(1 - (epsilon/a)^2) + i epsilon/a)``,
    below the phase crossover.

    Parameters
    ----------
    plant : Plant
        The true plant.
    rng : numpy.random.Generator
        Source of the measurement noise.
    amplitude : float
        Relay amplitude ``d`` (> 0).
    hysteresis : float
        ``epsilon >= 0``, in output units.
    noise_std, excursion_limit, max_duration, disturbances, quantization
        As in :func:`closed_loop_step`.
    dt : float, optional
        Sample time; default ``T/SAMPLES_PER_RESIDENCE_TIME``, at most ``L/20`` (but not below
        ``NEGLIGIBLE_DEAD_TIME T/20``).  The run stops at ``MAX_RUN_SAMPLES`` samples at most.
    period_tolerance : float
        Relative agreement of the last three periods that counts as periodic; widened by the
        switching jitter expected from the estimated noise.  A swing of less than ten noise
        standard deviations (the relay chattering on noise, for want of hysteresis; use
        ``hysteresis`` of a few ``noise_std``) never counts as periodic, and 20 switches within 40
        samples (chattering at the sample rate) stop the experiment unconverged.

    Returns
    -------
    RelayResult
    """
    plant, rng = check_plant(plant), check_rng(rng)
    amplitude = require_number(amplitude, "amplitude", positive=True)
    hysteresis = require_number(hysteresis, "hysteresis", nonnegative=True)
    noise_std = require_number(noise_std, "noise_std", nonnegative=True)
    period_tolerance = require_number(period_tolerance, "period_tolerance", positive=True)
    dt, scale = _relay_sample_time(plant, dt), plant.step_time_scale()
    steps = cap_steps(scale, dt, max_duration)
    noise = measurement_noise(rng, noise_std, steps, disturbances, plant, dt, quantization)
    values = noise.first(NOISE_BLOCK).tolist()
    sign = 1.0 if plant.gain > 0 else -1.0
    relay = _RelaySimulation(plant, dt, amplitude * sign, hysteresis, values[0], noise.quantization)
    aborted = converged = False
    drawn = noise.first(NOISE_BLOCK)
    j = 1
    while j < steps:
        if j == len(values):
            drawn = noise.first(j + NOISE_BLOCK)
            values = drawn.tolist()
        # The samples without a switch or a plant-input event run compiled (relay.plain_steps); the
        # sample that has one, by relay.step, as every sample did before (the same numbers).
        stop = min(steps, len(values))
        j, aborted = relay.plain_steps(drawn, j, stop, excursion_limit)
        if aborted:
            break
        if j == stop:
            continue
        switched = relay.step(values[j])
        aborted = relay.aborted(excursion_limit)
        converged = not aborted and switched and relay.periodic(period_tolerance)
        if aborted or converged or (switched and relay.unresolved()):
            break
        j += 1
    return _relay_result(relay, scale, amplitude, hysteresis, aborted, converged)


NOISE_BLOCK = 1024
"""Noise samples drawn at a time as the relay runs."""


def _relay_sample_time(plant: Plant, dt: float | None) -> float:
    """Default ``T/SAMPLES_PER_RESIDENCE_TIME``, at most ``L/20``: the limit cycle of a plant
    with a short dead time has a period of a few ``L``.  Not below ``NEGLIGIBLE_DEAD_TIME T/20``: a
    shorter dead time is a sub-sample event (exact), and the run is bounded in samples anyway
    (:func:`~envs.identification.experiment_base.cap_steps`)."""
    if dt is not None:
        return require_number(dt, "dt", positive=True)
    dt = sample_time(plant, None)
    return min(dt, max(plant.dead_time, NEGLIGIBLE_DEAD_TIME * plant.step_time_scale()) / 20.0) if plant.dead_time > 0 else dt


def _relay_result(
    relay: _RelaySimulation, scale: float, amplitude: float, hysteresis: float, aborted: bool, converged: bool
) -> RelayResult:
    t = np.asarray(relay.times)
    run = ExperimentRun(t, np.asarray(relay.relay_output), np.asarray(relay.measured), np.asarray(relay.true), t.size - 1, converged, aborted)
    record = record_fields(run, scale)
    switches = np.asarray(relay.switches)
    return RelayResult(**record, amplitude=amplitude, hysteresis=hysteresis, converged=converged,
                       switching_times=switches, **relay_estimates(t, record["output"], switches, amplitude))
