"""Runs on a sampled process: holding an input, closing a loop, a relay, with their records.

Every experiment of :mod:`envs.process.procedure` and every test of :mod:`envs.process.performance`
is one of these runs, sample by sample through the :class:`~envs.process.protocol.Process`
interface.  At sample ``k`` (time ``k dt`` from the start of the run) the measurement ``y_k`` is
read, the input ``u_k`` is computed (held, a discrete law of :mod:`envs.process.control_laws`, or the
relay) and applied over ``[k dt, (k + 1) dt)``: the convention of the simulated experiments'
records (``control[k]`` held over sample ``k``, ``output[k] = y(k dt)``), so that their identification
arithmetic reads these records unchanged.

A measurement that is not a finite number, or a ``measure`` or ``apply`` of the process that raises
(a fault of the process: a serial port gone, a bug in a user's process), stops the run there
(:attr:`Record.stopped` says so); the samples before it are kept.  A run may also end early once a test on its samples so far passes
(``until``): steady state, or a periodic relay.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from envs.identification.relay_cycle import relay_periodic
from envs.process.control_laws import DiscreteFPPI, DiscretePID
from envs.process.protocol import Process, ProcessStopped
from envs.simulation._run_kernels import CONFIDENCE, STEADY_STATE_TOLERANCE

__all__ = ["Record", "hold", "closed_loop", "relay", "reset", "steady_since_previous_window"]


@dataclass(frozen=True)
class Record:
    """The samples of one run on a process.

    Attributes
    ----------
    timepts : ndarray
        ``k dt`` from the start of the run.
    control : ndarray
        The input applied (within the limits) over each sample.
    computed : ndarray
        The controller's output before the limits (equal to ``control`` where none acts).
    output : ndarray
        The measurement ``y_k`` at each sample.
    setpoint, load : ndarray
        The set point and the load input at each sample.
    settled : bool
        The run's test passed (steady state, a periodic relay) before its last sample allowed.
    stopped : str or None
        Why the run stopped before its end, if it did: the process returned a measurement that is
        not a finite number.
    """

    timepts: np.ndarray
    control: np.ndarray
    computed: np.ndarray
    output: np.ndarray
    setpoint: np.ndarray
    load: np.ndarray
    settled: bool
    stopped: str | None = None

    @property
    def duration(self) -> float:
        """Time from the first to the last sample."""
        return float(self.timepts[-1]) if self.timepts.size else 0.0


class _Samples:
    """The growing columns of a run."""

    def __init__(self) -> None:
        self.columns: tuple[list[float], ...] = ([], [], [], [], [])  # control, computed, output, setpoint, load

    def add(self, control: float, computed: float, output: float, setpoint: float, load: float) -> None:
        for column, value in zip(self.columns, (control, computed, output, setpoint, load)):
            column.append(value)

    @property
    def output(self) -> list[float]:
        return self.columns[2]

    def record(self, dt: float, settled: bool, stopped: str | None) -> Record:
        control, computed, output, setpoint, load = (np.asarray(c, dtype=float) for c in self.columns)
        return Record(np.arange(output.size) * dt, control, computed, output, setpoint, load, settled, stopped)


def _fault(process: Process, call: str, error: Exception, k: int, dt: float) -> str:
    """Why a run stopped when the process's ``call`` raised ``error`` (its own fault: the run keeps the samples so far)."""
    return (f"the process's {call} raised {type(error).__name__}: {' '.join(str(error).split())[:200]} at t = {k * dt:g} "
            f"{process.units.time}").rstrip()


def _measure(process: Process, k: int, dt: float) -> tuple[float, str | None]:
    try:
        value = process.measure()
    except Exception as error:  # noqa: BLE001  (a fault of the user's process stops the run, named)
        return math.nan, _fault(process, "measure()", error, k, dt)
    try:
        value = float(value)
    except (TypeError, ValueError):
        return math.nan, f"the process returned {value!r}, not a number, at t = {k * dt:g} {process.units.time}".rstrip()
    if not math.isfinite(value):
        return value, f"the process returned {value} at t = {k * dt:g} {process.units.time}".rstrip()
    return value, None


def reset(process: Process, seed: int) -> None:
    """``process.reset(seed)``.

    Raises
    ------
    ProcessStopped
        If it raised, naming the exception (a fault of the process).
    """
    try:
        process.reset(seed)
    except Exception as error:  # noqa: BLE001  (as in _measure)
        raise ProcessStopped(f"the process's reset({seed}) raised {type(error).__name__}: "
                             f"{' '.join(str(error).split())[:200]}") from None


def _apply(process: Process, control: float, load: float, k: int, dt: float) -> str | None:
    """``process.apply(control, load)``; why the run stops if it raised, else None."""
    try:
        process.apply(control, load)
    except Exception as error:  # noqa: BLE001  (as in _measure)
        return _fault(process, "apply()", error, k, dt)
    return None


def _clip(process: Process, value: float) -> float:
    low, high = process.input_limits
    return min(max(value, low), high)


def hold(
    process: Process,
    control: float,
    steps: int,
    *,
    load: float = 0.0,
    until: Callable[[list[float]], bool] | None = None,
) -> Record:
    """Hold ``control`` (clipped to the limits) for at most ``steps`` samples, stopping after the
    first sample at which ``until(outputs so far)`` is true (``settled``)."""
    samples, dt, applied = _Samples(), process.sample_time, _clip(process, control)
    for k in range(int(steps)):
        y, stopped = _measure(process, k, dt)
        if stopped:
            return samples.record(dt, False, stopped)
        samples.add(applied, control, y, math.nan, load)
        stopped = _apply(process, applied, load, k, dt)
        if stopped:
            return samples.record(dt, False, stopped)
        if until is not None and until(samples.output):
            return samples.record(dt, True, None)
    return samples.record(dt, False, None)


def closed_loop(
    process: Process,
    law: DiscretePID | DiscreteFPPI,
    steps: int,
    *,
    setpoint: float,
    load: float = 0.0,
    until: Callable[[list[float], list[float]], bool] | None = None,
) -> Record:
    """The loop of ``law`` (already started at its bias) with a constant ``setpoint`` and ``load`` for
    at most ``steps`` samples, stopping after the first sample at which ``until(outputs, controls)``
    is true (``settled``)."""
    samples, dt = _Samples(), process.sample_time
    controls = samples.columns[0]
    for k in range(int(steps)):
        y, stopped = _measure(process, k, dt)
        if stopped:
            return samples.record(dt, False, stopped)
        computed, applied = law.update(setpoint, y)
        samples.add(applied, computed, y, setpoint, load)
        stopped = _apply(process, applied, load, k, dt)
        if stopped:
            return samples.record(dt, False, stopped)
        if until is not None and until(samples.output, controls):
            return samples.record(dt, True, None)
    return samples.record(dt, False, None)


@dataclass(frozen=True)
class RelayRecord:
    """A relay run: its record and the switching instants (interpolated between samples)."""

    record: Record
    switching_times: np.ndarray


def relay(
    process: Process,
    bias: float,
    amplitude: float,
    setpoint: float,
    hysteresis: float,
    steps: int,
    *,
    sign: float = 1.0,
    period_tolerance: float = 1e-3,
) -> RelayRecord:
    """Relay feedback ``u = bias + sign d s`` around ``setpoint``, ``s = +-1`` switching on the error
    ``e = setpoint - y`` with ``hysteresis`` (Astrom-Hagglund 1984), as the simulated relay of
    :func:`envs.identification.relay.relay_feedback` does, but sampled: the input switches at the
    sample after the crossing, and the switching instant (for the period) is interpolated linearly
    between the two samples around it.  ``sign`` is the sign of the process gain (negative
    feedback).  Stops once the last three periods agree
    (:func:`~envs.identification.relay_cycle.relay_periodic`), else after ``steps`` samples."""
    samples, dt = _Samples(), process.sample_time
    state, switches, times = 1.0, [], []
    previous_error = None
    for k in range(int(steps)):
        y, stopped = _measure(process, k, dt)
        if stopped:
            return RelayRecord(samples.record(dt, False, stopped), np.asarray(switches))
        error = setpoint - y
        threshold = -hysteresis if state > 0 else hysteresis
        crossed = error < threshold if state > 0 else error > threshold
        if crossed:
            state = -state
            if previous_error is None or previous_error == error:
                switches.append(k * dt)
            else:
                switches.append((k - 1 + (threshold - previous_error) / (error - previous_error)) * dt)
        previous_error = error
        applied = _clip(process, bias + sign * amplitude * state)
        samples.add(applied, bias + sign * amplitude * state, y, setpoint, 0.0)
        times.append(k * dt)
        stopped = _apply(process, applied, 0.0, k, dt)
        if stopped:
            return RelayRecord(samples.record(dt, False, stopped), np.asarray(switches))
        if crossed and relay_periodic(switches, times, samples.output, period_tolerance):
            return RelayRecord(samples.record(dt, True, None), np.asarray(switches))
    return RelayRecord(samples.record(dt, False, None), np.asarray(switches))


def steady_since_previous_window(values: list[float], window: int, scale: float) -> bool:
    """Whether the last ``window`` samples are steady and equal to the ``window`` before them.

    The tests of :func:`envs.identification.steady_state.steady_state_mask` without a target (the
    fitted slope over the window insignificant, the mean equal to the previous window's, both within
    ``CONFIDENCE`` standard errors of the noise estimated from second differences), with the
    tolerance floor ``STEADY_STATE_TOLERANCE |scale|``: at an operating point the level itself is
    arbitrary (it may be 0), so the floor is relative to the experiment's scale (the set-point step)
    and the "response has started" test does not apply.
    """
    n = int(window)
    if len(values) < 2 * n:
        return False
    y = np.asarray(values[-2 * n :], dtype=float)
    last, before = y[n:], y[:n]
    sigma = math.sqrt(float(np.mean(np.diff(last, 2) ** 2)) / 6.0) if n > 2 else 0.0
    centered = np.arange(n, dtype=float) - (n - 1) / 2.0
    change = float(centered @ (last - last.mean())) / (n * (n * n - 1) / 12.0) * (n - 1)  # fitted slope times (n - 1)
    tolerance = STEADY_STATE_TOLERANCE * abs(scale)
    flat = abs(change) <= CONFIDENCE * sigma * math.sqrt(12.0 / n) + tolerance
    same = abs(float(last.mean() - before.mean())) <= CONFIDENCE * sigma * math.sqrt(2.0 / n) + tolerance
    return bool(flat and same)
