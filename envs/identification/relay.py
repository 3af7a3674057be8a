"""Experiment 5: relay feedback around the true plant, ultimate period and gain.

:func:`relay_feedback` closes a relay (with optional hysteresis) around the plant, time-stepped
exactly with interpolated switching instants, until the oscillation is periodic, and returns
``T_u`` and ``K_u = 4 d/(pi a)`` by the describing function (Astrom-Hagglund 1984), also from the
first harmonic of the output (harmonic balance).

References
----------
.. [AH] K. J. Astrom, T. Hagglund, "Automatic tuning of simple regulators with specifications on
   phase and amplitude margins", Automatica 20 (1984): relay feedback.
.. [MA] T. Marlin, "Process Control", section 10.7: ultimate gain and period.
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

import numba
import numpy as np
import scipy.linalg

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
from envs.systems.plants import NEGLIGIBLE_DEAD_TIME, Plant
from envs.identification.steady_state import noise_level
from envs.validation import require_number

__all__ = ["RelayResult", "relay_feedback", "relay_estimates", "relay_periodic"]


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
    noise_std, excursion_limit, max_duration, disturbances
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
    noise = measurement_noise(rng, noise_std, steps, disturbances, plant, dt)
    values = noise.first(NOISE_BLOCK).tolist()
    sign = 1.0 if plant.gain > 0 else -1.0
    relay = _RelaySimulation(plant, dt, amplitude * sign, hysteresis, values[0])
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


class _RelaySimulation:
    """Exact time stepping of ``G e^{-Ls}`` under relay feedback with interpolated switching.

    The products are ``ndarray.dot``: the same BLAS calls as ``@`` on these small arrays (hence the
    same numbers), with far less overhead per call.
    """

    def __init__(self, plant: Plant, dt: float, level: float, hysteresis: float, initial_noise: float) -> None:
        ss = plant.state_space()
        self.A, self.B = ss.A, ss.B[:, 0]
        self.C, self.D = ss.C[0], float(ss.D[0, 0])
        self.dead_time, self.dt, self.level, self.hysteresis = plant.dead_time, dt, level, hysteresis
        self.full_step = self._propagator(dt)
        self._full_step_matrix = np.ascontiguousarray(self.full_step[0])  # for _plain_steps (the same products)
        self.event_tolerance = 1e-12 * dt  # an event this close to the end of a step belongs to the next
        self._forced = (None, None)  # (plant input u, gamma u) of the full step, for the last u
        self.x = np.zeros(self.A.shape[0])
        self.state = 1.0  # relay output sign
        self.events: list[tuple[float, float]] = [(self.dead_time, level)]  # plant input changes
        self.next_event = 0
        self.plant_input = 0.0
        if self.dead_time == 0.0:
            self.plant_input, self.next_event = level, 1
        initial = self.D * self.plant_input
        self.times, self.true, self.measured, self.relay_output = [0.0], [initial], [initial + initial_noise], [level]
        self.switches: list[float] = []

    def _propagator(self, span: float) -> tuple[np.ndarray, np.ndarray]:
        n = self.A.shape[0]
        block = np.zeros((n + 1, n + 1))
        block[:n, :n], block[:n, n] = self.A * span, self.B * span
        e = scipy.linalg.expm(block)
        return e[:n, :n], e[:n, n]

    def _advance(self, x: np.ndarray, start: float, plant_input: float, next_event: int) -> tuple[np.ndarray, float, int]:
        """Exact state at ``start + dt`` through the plant-input events inside the interval."""
        now, end = start, start + self.dt
        while next_event < len(self.events) and self.events[next_event][0] < end - self.event_tolerance:
            when, value = self.events[next_event]
            if when > now:
                phi, gamma = self._propagator(when - now)
                x, now = phi.dot(x) + gamma * plant_input, when
            plant_input, next_event = value, next_event + 1
        if now == start:
            phi, gamma = self.full_step
        else:
            phi, gamma = self._propagator(end - now)
        return phi.dot(x) + gamma * plant_input, plant_input, next_event

    def plain_steps(self, noise: np.ndarray, first: int, stop: int, limit: float | None) -> tuple[int, bool]:
        """Samples ``first .. stop - 1`` (noise ``noise[j]``) as :meth:`step` runs them, up to the first
        that switches the relay or has a plant-input event inside it (not run; :meth:`step` runs it).

        Returns the next sample to run and whether the last one run left ``[-limit, limit]`` (it
        stops there).  A plant without states is left to :meth:`step`.
        """
        if self.A.shape[0] == 0 or first >= stop:
            return first, False
        if self._forced[0] != self.plant_input:
            self._forced = (self.plant_input, self.full_step[1] * self.plant_input)
        pending = self.events[self.next_event][0] if self.next_event < len(self.events) else math.inf
        count = stop - first
        times, true, measured = np.empty(count), np.empty(count), np.empty(count)
        done, aborted, x = _plain_steps(
            self._full_step_matrix, self.x, self._forced[1], self.C, self.D, self.plant_input, self.times[-1], self.dt,
            self.state, self.hysteresis, pending, self.event_tolerance, noise, first, stop, limit is not None,
            0.0 if limit is None else float(limit), times, true, measured,
        )  # fmt: skip
        if done:
            self.x = x
            self.times.extend(times[:done].tolist())
            self.true.extend(true[:done].tolist())
            self.measured.extend(measured[:done].tolist())
            self.relay_output.extend([self.state * self.level] * done)
        return first + done, aborted

    def step(self, noise: float) -> bool:
        """Advance one sample; True if the relay switched."""
        start = self.times[-1]
        end = start + self.dt
        saved = (self.x, self.plant_input, self.next_event)
        if self.next_event < len(self.events) and self.events[self.next_event][0] < end - self.event_tolerance:
            self.x, self.plant_input, self.next_event = self._advance(saved[0], start, saved[1], saved[2])
        else:  # no event inside the step (most steps): _advance's full step, with gamma u kept while u holds
            if self._forced[0] != self.plant_input:
                self._forced = (self.plant_input, self.full_step[1] * self.plant_input)
            self.x = self.full_step[0].dot(self.x) + self._forced[1]
        true = float(self.C.dot(self.x)) + self.D * self.plant_input
        measured = true + noise
        switch = self._crossing(start, self.measured[-1], measured)
        if switch is not None:
            self.state = -self.state
            self.switches.append(switch)
            self.events.append((switch + self.dead_time, self.state * self.level))
            if switch + self.dead_time < end - self.event_tolerance:  # dead time shorter than the step
                self.x, self.plant_input, self.next_event = self._advance(saved[0], start, saved[1], saved[2])
                true = float(self.C.dot(self.x)) + self.D * self.plant_input
                measured = true + noise
        self.times.append(end)
        self.true.append(true)
        self.measured.append(measured)
        self.relay_output.append(self.state * self.level)
        return switch is not None

    def _crossing(self, start: float, before: float, after: float) -> float | None:
        """Switching instant if the error ``e = -y_m`` crossed the active threshold."""
        e0, e1 = -before, -after
        threshold = -self.hysteresis if self.state > 0 else self.hysteresis
        crossed = e1 < threshold if self.state > 0 else e1 > threshold
        if not crossed:
            return None
        if (e0 - threshold) * (e1 - threshold) >= 0 or e1 == e0:
            return start + self.dt
        return start + (threshold - e0) / (e1 - e0) * self.dt

    def aborted(self, limit: float | None) -> bool:
        return limit is not None and not abs(self.true[-1]) <= limit

    def unresolved(self) -> bool:
        """The last 20 switches came within 40 samples: the relay chatters at the sample rate
        (no phase crossover to oscillate at, or noise without hysteresis)."""
        return len(self.switches) > 20 and self.switches[-1] - self.switches[-21] < 40.0 * self.dt

    def periodic(self, tolerance: float) -> bool:
        """The last three periods (each between switches of the same direction) agree."""
        return relay_periodic(self.switches, self.times, self.measured, tolerance)


def relay_periodic(switches: list[float], times: list[float], measured: list[float], tolerance: float) -> bool:
    """Whether the last three periods of a relay's switching instants (each period between switches
    of the same direction) agree to ``tolerance``, widened by the period jitter the noise of the
    ``measured`` output since the first of them explains (:func:`_period_tolerance`); needs seven
    switches (three periods after the first half period).  The simulated relay and a sampled
    process's (:mod:`envs.process.runs`) use this same test."""
    if len(switches) < 7:
        return False
    s = np.asarray(switches[-5:])
    last = s[2:] - s[:-2]
    return bool(np.ptp(last) <= _period_tolerance(times, measured, tolerance, s[0]) * np.mean(last))


def _period_tolerance(times: list[float], measured: list[float], tolerance: float, since: float) -> float:
    """``tolerance`` plus three times the relative period jitter expected from the noise:
    a switching instant moves by ``sigma/|y'|``, and ``|y'| ~ 2 pi a/T`` for an oscillation of
    amplitude ``a`` and period ``T``."""
    first = bisect.bisect_left(times, since)  # numpy.searchsorted of the list, without converting it
    y = np.asarray(measured[first:])
    noise, spread = noise_level(y), 0.5 * np.ptp(y) if y.size else 0.0
    if noise == 0.0:
        return tolerance
    if spread <= 10.0 * noise:  # chattering on noise (too little hysteresis): not a limit cycle
        return 0.0
    return tolerance + 3.0 * math.sqrt(2.0) * noise / (2.0 * math.pi * spread)


@numba.njit(cache=True)
def _plain_steps(phi, x, forced, C, D, plant_input, time, dt, state, hysteresis, pending, tolerance, noise, first, stop,
                 limited, limit, times, true, measured):  # pragma: no cover - compiled
    """The samples of :meth:`_RelaySimulation.plain_steps`: ``x <- phi x + gamma u`` and ``y = C x + D u``
    with the BLAS products of ``ndarray.dot`` (numba's ``np.dot`` calls the same kernels: the unit tests
    compare the results), stopping before a sample whose measured output crosses the relay's threshold
    or that contains the pending event, and after one whose true output leaves ``[-limit, limit]``.

    Returns ``(samples run, aborted, x)``; the samples' times and outputs are written to ``times``,
    ``true``, ``measured``."""
    threshold = -hysteresis if state > 0 else hysteresis
    done = 0
    for j in range(first, stop):
        end = time + dt
        if pending < end - tolerance:
            return done, False, x
        following = np.dot(phi, x) + forced
        output = np.dot(C, following) + D * plant_input
        now = output + noise[j]
        error = -now
        if (error < threshold) if state > 0 else (error > threshold):
            return done, False, x
        x, time = following, end
        times[done], true[done], measured[done] = end, output, now
        done += 1
        if limited and not abs(output) <= limit:
            return done, True, x
    return done, False, x


def _relay_result(
    relay: _RelaySimulation, scale: float, amplitude: float, hysteresis: float, aborted: bool, converged: bool
) -> RelayResult:
    t = np.asarray(relay.times)
    run = ExperimentRun(t, np.asarray(relay.relay_output), np.asarray(relay.measured), np.asarray(relay.true), t.size - 1, converged, aborted)
    record = record_fields(run, scale)
    switches = np.asarray(relay.switches)
    return RelayResult(**record, amplitude=amplitude, hysteresis=hysteresis, converged=converged,
                       switching_times=switches, **relay_estimates(t, record["output"], switches, amplitude))


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
