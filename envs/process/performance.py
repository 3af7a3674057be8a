"""A controller on a process: its set-point and load tests, measured on the process itself.

Each test is a run of the discrete law (:mod:`envs.process.control_laws`) on the process, from the
same state: :meth:`~envs.process.protocol.Process.reset` with the protocol's seed, the operating input
held for the settling time the procedure measured (so every controller meets the same noise, sample
for sample), then the loop closed bumplessly at the operating point (the integral at ``u_0``) and at
the same sample ``t = 0``:

* **set-point test**: the set point steps from ``y_0`` to ``y_0 + setpoint_step``;
* **load test**: the set point stays at ``y_0`` and the load input steps by ``load_step``
  (heater 2 on the TCLab; the plant input for a :class:`~envs.process.plant_process.PlantProcess`,
  as ``deadtime analyze``'s load).

Each runs ``HORIZON`` identified residence times (``T_ar`` of the closed-loop step); the figures:

* ``IAE = int |r - y| dt`` (Marlin ch. 9), trapezoidal with the sign changes split
  (:func:`envs.analysis.performance.integrated_absolute_error`), on the *measurement*: a process has
  nothing else, so the noise (on the TCLab the quantization's flicker) adds about ``E|n|`` per unit
  time to every controller's IAE (:attr:`ProcessPerformance.noise_floor` estimates that share);
* ``overshoot``: the largest excess of the set-point response over its step, relative to the step,
  after a centred moving average over ``T_ar/20`` (so that a quantization step of the measurement
  is not an overshoot);
* ``saturated_fraction``: the share of the samples of both tests in which the limits cut the
  controller's output.

A test that receives a measurement that is not a number stops there; its IAE is then unknown (NaN)
and :attr:`ProcessPerformance.stopped` says which test and when.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from envs.analysis.performance import integrated_absolute_error
from envs.process.control_laws import discrete_law
from envs.process.procedure import ProcessIdentification
from envs.process.protocol import Process
from envs.process.runs import Record, closed_loop, hold, reset
from envs.systems.controllers import Controller
from envs.validation import require_number

__all__ = ["HORIZON", "RunProtocol", "ProcessPerformance", "closed_loop_performance"]

HORIZON = 10.0
"""Length of each test in identified residence times ``T_ar`` (the first horizon of ``deadtime analyze``)."""

SMOOTHING = 20.0
"""The overshoot reads the response averaged over ``T_ar/SMOOTHING``."""


@dataclass(frozen=True)
class RunProtocol:
    """How every controller is tested on one process (see the module docstring).

    Attributes
    ----------
    seed : int
        ``reset`` seed of every test.
    operating_input, operating_output : float
        ``u_0``, ``y_0``.
    settle_time : float
        Time ``u_0`` is held after the reset before the loop closes.
    setpoint_step, load_step : float
    residence_time : float
        The identified ``T_ar``; each test lasts ``horizon`` of it.
    horizon : float
    """

    seed: int
    operating_input: float
    operating_output: float
    settle_time: float
    setpoint_step: float
    load_step: float
    residence_time: float
    horizon: float = HORIZON

    @classmethod
    def from_identification(cls, found: ProcessIdentification, load_step: float, seed: int = 0,
                            horizon: float = HORIZON) -> RunProtocol:
        point = found.operating_point
        return cls(int(seed), point.input, point.output, point.settle_time, found.setpoint_step,
                   require_number(load_step, "load_step", nonzero=True), found.identification.residence_time,
                   require_number(horizon, "horizon", positive=True))

    def to_dict(self) -> dict:
        return dict(self.__dict__)


@dataclass(frozen=True)
class ProcessPerformance:
    """The figures of one controller's tests on the process (see the module docstring).

    ``iae_setpoint``, ``iae_load`` are in output units times time units; NaN if the test stopped.
    ``noise_floor`` is ``E|y - y_0|`` of the operating point's settle times the test's duration: about
    the share of each IAE that the measurement noise alone contributes.
    """

    iae_setpoint: float
    iae_load: float
    overshoot: float
    saturated_fraction: float
    noise_floor: float
    setpoint_run: Record
    load_run: Record
    stopped: str | None


def _test(process: Process, controller: Controller, protocol: RunProtocol, setpoint: float, load: float) -> tuple[Record, float]:
    """One test: the reset, the settling, the loop; its record and ``E|y - y_0|`` of the settling's last
    tenth (the noise floor per unit time)."""
    dt = process.sample_time
    reset(process, protocol.seed)
    settle = hold(process, protocol.operating_input, int(round(protocol.settle_time / dt)))
    if settle.stopped:
        return settle, math.nan
    tail = settle.output[-max(settle.output.size // 10, 1):]
    law = discrete_law(controller, dt, process.input_limits)
    law.start(protocol.operating_input)
    steps = int(math.ceil(protocol.horizon * protocol.residence_time / dt)) + 1
    record = closed_loop(process, law, steps, setpoint=setpoint, load=load)
    return record, float(np.mean(np.abs(tail - protocol.operating_output)))


def _overshoot(record: Record, protocol: RunProtocol, dt: float) -> float:
    samples = max(int(round(protocol.residence_time / SMOOTHING / dt)), 1)
    z = (record.output - protocol.operating_output) / protocol.setpoint_step
    if samples > 1 and z.size >= samples:
        z = np.convolve(z, np.ones(samples) / samples, mode="valid")
    return float(max(np.max(z) - 1.0, 0.0)) if z.size else math.nan


def closed_loop_performance(process: Process, controller: Controller, protocol: RunProtocol) -> ProcessPerformance:
    """The set-point and load tests of ``controller`` on ``process`` (see the module docstring).

    Raises
    ------
    ValueError
        If the controller has no discrete law here (:func:`~envs.process.control_laws.discrete_law`).
    """
    dt = process.sample_time
    discrete_law(controller, dt, process.input_limits)  # refuses a controller without a law before any run
    y0 = protocol.operating_output
    setpoint_run, floor = _test(process, controller, protocol, y0 + protocol.setpoint_step, 0.0)
    load_run, _ = _test(process, controller, protocol, y0, protocol.load_step)
    figures = {}
    for name, record in (("setpoint", setpoint_run), ("load", load_run)):
        figures[name] = math.nan if record.stopped else integrated_absolute_error(record.setpoint - record.output, dt)
    stopped = [f"{name} test: {record.stopped}" for name, record in (("set-point", setpoint_run), ("load", load_run))
               if record.stopped]
    runs = [r for r in (setpoint_run, load_run) if r.computed.size]
    cut = sum(int(np.count_nonzero(r.computed != r.control)) for r in runs)
    total = sum(r.computed.size for r in runs)
    return ProcessPerformance(
        iae_setpoint=figures["setpoint"], iae_load=figures["load"],
        overshoot=math.nan if setpoint_run.stopped else _overshoot(setpoint_run, protocol, dt),
        saturated_fraction=cut / total if total else math.nan,
        noise_floor=floor * protocol.horizon * protocol.residence_time,
        setpoint_run=setpoint_run, load_run=load_run, stopped="; ".join(stopped) or None,
    )  # fmt: skip
