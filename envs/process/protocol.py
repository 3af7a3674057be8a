"""The interface of a sampled process: what the procedure, the rules and the agents need of it.

A :class:`Process` is anything that can be sampled: the project's own plants
(:class:`~envs.process.plant_process.PlantProcess`), the TCLab emulator
(:class:`~envs.process.tclab_process.TCLabProcess`), a user's simulator, or hardware.  It holds
one input (the manipulated variable) and one measurement, in engineering units, and a load input
(the disturbance of the load test).  Time passes only in :meth:`Process.apply`::

    process.reset(seed)                # the initial state, its noise seeded
    y = process.measure()              # the measurement now (no time passes)
    process.apply(u, load)             # u and the load held for one sample time

A process that cannot be reset (hardware) starts from where it is; the procedure always settles
it at the operating point first (:mod:`envs.process.procedure`).  Nothing here imports gymnasium or
torch: a process and everything run on it are numerics.

:func:`check_process` validates an object against the protocol (every attribute present, numbers
finite, the limits ordered, the operating input inside them), naming what is wrong;
:func:`check_load_step` a load step against the load input's range.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol, runtime_checkable

from envs.validation import require_number

__all__ = ["MAX_SAMPLES_PER_SETTLING", "Process", "Units", "check_load_step", "check_process", "ProcessStopped"]

MAX_SAMPLES_PER_SETTLING = 100_000
"""Samples in one settling time of a process (``settling_time / sample_time``), at most.  An experiment
lasts at most five settling times and a test a few, so a run of a process holds at most a few million
samples (tens of megabytes); the TCLab has 900 (a settling time of 15 minutes at 1 s).  A process
beyond it (``sample_time=1e-300``, ``settling_time=1e300``) is refused before anything runs."""


@dataclass(frozen=True)
class Units:
    """Names of a process's units, for the output (``"s"``, ``"%"``, ``"degC"``)."""

    time: str = "s"
    input: str = ""
    output: str = ""
    load: str = ""


@runtime_checkable
class Process(Protocol):
    """A sampled single-loop process (see the module docstring).

    Attributes
    ----------
    name : str
        A short name for the output.
    sample_time : float
        The time of one :meth:`apply`, in the process's time unit (> 0).
    input_limits : (float, float)
        The range of the input (``low < high``; ``-inf``/``inf`` for none).  A process clips its
        input to it (a heater at 0 or 100 % is the normal case); the controllers know the limits
        and do not wind up.
    operating_input : float
        The input ``u_0`` of the operating point, strictly inside the limits; the operating output
        ``y_0`` is measured by settling there.
    settling_time : float
        A conservative time for the output to settle after a step of the input (> 0): before a
        model is identified, steady state is judged over windows of a fifth of it, and an
        experiment is given at most five of it.
    setpoint_step : float
        The set-point step of the closed-loop experiment and of the set-point test, in output units
        (non-zero).
    input_step : float
        The input step of the first open-loop step (when no existing controller is given), in input
        units (non-zero).
    load_step : float
        The step of the load input in the load test, in load units (non-zero).
    load_limits : (float, float) or None, optional
        The range of the load input, if it saturates (an attribute a process may leave out; None: no
        limit).  The load test steps the load from 0 to ``load_step``, which must lie in this range:
        beyond it the load saturates while the cost is still divided by the requested step.
    load_gain : float or None, optional
        The static gain from the load to the output, if known (an attribute a process may leave out): the load test's cost is normalized
        by ``|load_gain load_step|``, as the environments' by ``|K|`` for a unit load at the plant
        input (None: the identified ``K_n``, the load taken as entering at the input).
    quantization : float, optional
        The resolution of the output's sensor, in output units, if known (an attribute a process may
        leave out; 0 or absent: none known): the observation's noise estimate then reads the records
        as quantized (:func:`envs.identification.quantized_noise.quantized_noise_level`).
    units : Units
    """

    name: str
    sample_time: float
    input_limits: tuple[float, float]
    operating_input: float
    settling_time: float
    setpoint_step: float
    input_step: float
    load_step: float
    load_gain: float | None
    units: Units

    def reset(self, seed: int) -> None:
        """Return to the initial state, with the process's noise seeded by ``seed``."""

    def measure(self) -> float:
        """The measurement at the present sample (no time passes); NaN if it has none."""

    def apply(self, control: float, load: float = 0.0) -> None:
        """Hold ``control`` (clipped to the limits) and ``load`` for one sample time."""

    def close(self) -> None:
        """Release what the process holds (a serial port, a model); safe to call twice."""


class ProcessStopped(ValueError):
    """The process returned a measurement that is not a finite number (it stops the run)."""


_ATTRIBUTES = ("name", "sample_time", "input_limits", "operating_input", "settling_time", "setpoint_step",
               "input_step", "load_step", "units", "reset", "measure", "apply")


def check_process(process: object) -> Process:
    """``process`` if it has every attribute of :class:`Process` with valid values.

    Raises
    ------
    ValueError
        Naming the first missing attribute or invalid value, e.g.
        ``"process.operating_input 120.0 is outside the input limits [0, 100]"``.
    """
    missing = [name for name in _ATTRIBUTES if not hasattr(process, name)]
    if missing:
        raise ValueError(f"process ({type(process).__name__}) has no attribute {missing[0]!r} of the Process interface "
                         "(envs.process.protocol.Process)")
    require_number(process.sample_time, "process.sample_time", positive=True)
    require_number(process.settling_time, "process.settling_time", positive=True)
    for name in ("setpoint_step", "input_step", "load_step"):
        require_number(getattr(process, name), f"process.{name}", nonzero=True)
    if getattr(process, "load_gain", None) is not None:
        require_number(process.load_gain, "process.load_gain", nonzero=True)
    if getattr(process, "quantization", None) is not None:
        require_number(process.quantization, "process.quantization", nonnegative=True)
    check_load_step(process, process.load_step, "process.load_step")
    limits = process.input_limits
    if not (isinstance(limits, tuple | list) and len(limits) == 2):
        raise ValueError(f"process.input_limits must be a pair (low, high), got {limits!r}")
    low, high = (float(v) for v in limits)
    if math.isnan(low) or math.isnan(high) or not low < high:
        raise ValueError(f"process.input_limits must be increasing, got {limits!r}")
    u0 = require_number(process.operating_input, "process.operating_input")
    if not low < u0 < high:
        raise ValueError(f"process.operating_input {u0:g} is outside the input limits [{low:g}, {high:g}]")
    if process.settling_time > MAX_SAMPLES_PER_SETTLING * process.sample_time:
        raise ValueError(f"process.settling_time {process.settling_time:g} must be at most {MAX_SAMPLES_PER_SETTLING} sample "
                         f"times ({MAX_SAMPLES_PER_SETTLING * process.sample_time:g}; envs.process.protocol.MAX_SAMPLES_PER_SETTLING): "
                         "an experiment takes up to five settling times of samples")
    if process.settling_time < 15 * process.sample_time:
        raise ValueError(f"process.settling_time {process.settling_time:g} must be at least 15 sample times "
                         f"({15 * process.sample_time:g}): a steady-state window is a fifth of it, of at least 3 samples")
    units = process.units
    if not all(isinstance(getattr(units, name, None), str) for name in ("time", "input", "output", "load")):
        raise ValueError(f"process.units must be a Units (names of the time, input, output and load units), got {units!r:.60}")
    return process


def check_load_step(process: object, load_step: float, name: str = "load_step") -> float:
    """``load_step`` if it is a non-zero number inside the process's ``load_limits`` (if it has any).

    Raises
    ------
    ValueError
        e.g. ``"load_step 200 is outside the load input's range [0, 100] (% heater 2)"``.
    """
    load_step = require_number(load_step, name, nonzero=True)
    limits = getattr(process, "load_limits", None)
    if limits is not None:
        low, high = (float(v) for v in limits)
        if not low <= load_step <= high:
            units = getattr(getattr(process, "units", None), "load", "")
            raise ValueError(f"{name} {load_step:g} is outside the load input's range [{low:g}, {high:g}]"
                             f"{f' ({units})' if units else ''}: the load would saturate")
    return load_step
