"""The exact time stepping of a plant ``G e^{-Ls}`` under relay feedback, with interpolated switching.

:class:`_RelaySimulation` is the readable reference: one sample at a time (:meth:`~_RelaySimulation.step`),
each switching instant interpolated and each change of the plant input inside a sample stepped to
exactly.  The samples without a switch or an input change run in the compiled :func:`_plain_steps`
beside it, with the same products (the unit tests compare them).
"""

from __future__ import annotations

import math

import numba
import numpy as np
import scipy.linalg

from envs.identification.noise import sensor_reading
from envs.identification.relay_cycle import relay_periodic
from envs.systems.plants import Plant

__all__: list[str] = []


class _RelaySimulation:
    """Exact time stepping of ``G e^{-Ls}`` under relay feedback with interpolated switching.

    The products are ``ndarray.dot``: the same BLAS calls as ``@`` on these small arrays (hence the
    same numbers), with far less overhead per call.
    """

    def __init__(
        self, plant: Plant, dt: float, level: float, hysteresis: float, initial_noise: float, quantization: float = 0.0
    ) -> None:
        ss = plant.state_space()
        self.A, self.B = ss.A, ss.B[:, 0]
        self.C, self.D = ss.C[0], float(ss.D[0, 0])
        self.dead_time, self.dt, self.level, self.hysteresis = plant.dead_time, dt, level, hysteresis
        self.quantization = quantization  # the sensor's resolution: the relay switches on its readings
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
        first = sensor_reading(initial + initial_noise, quantization)
        self.times, self.true, self.measured, self.relay_output = [0.0], [initial], [first], [level]
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
            self.state, self.hysteresis, pending, self.event_tolerance, noise, self.quantization, first, stop,
            limit is not None,
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
        measured = sensor_reading(true + noise, self.quantization)
        switch = self._crossing(start, self.measured[-1], measured)
        if switch is not None:
            self.state = -self.state
            self.switches.append(switch)
            self.events.append((switch + self.dead_time, self.state * self.level))
            if switch + self.dead_time < end - self.event_tolerance:  # dead time shorter than the step
                self.x, self.plant_input, self.next_event = self._advance(saved[0], start, saved[1], saved[2])
                true = float(self.C.dot(self.x)) + self.D * self.plant_input
                measured = sensor_reading(true + noise, self.quantization)
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
        return relay_periodic(self.switches, self.times, self.measured, tolerance, self.quantization)


@numba.njit(cache=True)
def _plain_steps(phi, x, forced, C, D, plant_input, time, dt, state, hysteresis, pending, tolerance, noise, quantum, first,
                 stop, limited, limit, times, true, measured):  # pragma: no cover - compiled
    """The samples of :meth:`_RelaySimulation.plain_steps`: ``x <- phi x + gamma u`` and ``y = C x + D u``
    with the BLAS products of ``ndarray.dot`` (numba's ``np.dot`` calls the same kernels: the unit tests
    compare the results), stopping before a sample whose measured output (floored to a multiple of
    ``quantum`` unless it is 0, the sensor's reading) crosses the relay's threshold
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
        if quantum != 0.0:  # the sensor's reading (envs.identification.noise.sensor_reading)
            now = now - now % quantum
        error = -now
        if (error < threshold) if state > 0 else (error > threshold):
            return done, False, x
        x, time = following, end
        times[done], true[done], measured[done] = end, output, now
        done += 1
        if limited and not abs(output) <= limit:
            return done, True, x
    return done, False, x
