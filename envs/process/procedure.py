"""The fixed identification procedure on a process: operating point, commissioning controller, experiments.

On a process nobody knows the true plant, so the procedure runs as on a plant in operation, every
experiment from the operating point and back to it, through the
:class:`~envs.process.protocol.Process` interface (:mod:`envs.process.runs`):

1. **Operating point.**  After :meth:`~envs.process.protocol.Process.reset` the input is held at
   ``u_0`` until the output is steady (two windows of a fifth of the process's ``settling_time``
   agree, :func:`~envs.process.runs.steady_since_previous_window`); ``y_0`` is the mean of the last
   window and the measurement noise ``sigma`` is estimated from its second differences (as the
   steady-state tests do, :mod:`envs.identification.steady_state`).  Every signal below is a deviation
   from ``(u_0, y_0)``, the convention of the simulated experiments (at rest at 0 before the step).
2. **The commissioning controller**: the loop's existing controller if the user gives it
   (``source="given"``), else a conservative PI designed from a first open-loop step of
   ``input_step`` (``source="open-loop step"``): the step's moments give ``K``, ``T_ar`` and ``T_a``
   (Gorez-Klan eq. 2-3 .. 2-6, :func:`~envs.identification.moments.normalized_moments`) and the moment
   FOPDT ``K e^{-(T_ar - T_a) s}/(T_a s + 1)``, for which
   :func:`~envs.identification.commissioning.commissioning_pi` designs the lambda-type PI of the
   environments, detuned to ``Ms <= 1.4`` on that model.
3. **Closed-loop set-point step** of ``setpoint_step`` with the commissioning controller (discrete,
   with anti-windup, :mod:`envs.process.control_laws`), run to steady state (the tests of the
   simulated experiment: the output at the set point, the input steady, over windows of one time
   scale ``T``): ``K_n``, ``T_ar`` (Ingimundarson eq. 10), ``T_a`` (Gorez-Klan appendix B), ``tau``,
   ``theta`` and the SOPDT model (eq. 2-7 .. 2-10), by
   :func:`~envs.identification.closed_loop_experiment.identify_closed_loop_step`.  ``T`` is the first
   step's ``T_ar``, or a fifth of ``settling_time`` when the controller was given.
4. **Open-loop step** of ``setpoint_step/K_n`` (the output rises by about one set-point step, as the
   environments' unit rise), to steady state: ``T_n`` (eq. 11), ``L_n``, ``T_f_bar`` (eq. 22) and the
   reaction curves (Marlin 6.3), by :func:`~envs.identification.open_loop_step.identify_open_loop_step`.
5. **Relay** of amplitude ``setpoint_step/|K_n|`` (within the input limits) and hysteresis
   ``3 sigma`` (the environments' :data:`~envs.episode.RELAY_HYSTERESIS`) until periodic: ``K_u``,
   ``T_u`` (:func:`~envs.identification.relay_cycle.relay_estimates`).  Beyond the papers: it is reported, and
   the fixed procedure's observation does not read it (as in the environments' fixed mode).

The least-squares identification (:mod:`envs.identification.least_squares`) is not run on a
process.  Only self-regulating processes are handled (an integrating one never settles at its
operating point: step 1 says so).

The :class:`~envs.identification.procedure.Identification` of steps 3-4 is what the environments'
fixed mode identifies, with its experiment time (the two experiments' durations), so the rules
(:class:`baselines.rules.registry.RuleInputs`) and the agents' observation
(:func:`envs.episode.features`) read it unchanged.  Every amplitude is in engineering units; a
step that would leave the input limits is refused before it runs, naming the amplitude.

References
----------
.. [GK] R. Gorez, P. Klan, "Simple models for process control", section 2 and appendix B.
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000, sections 2.1-2.3 and 4.1.
.. [AH] K. J. Astrom, T. Hagglund, "Automatic tuning of simple regulators with specifications on
   phase and amplitude margins", Automatica 20 (1984).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from envs.episode import RELAY_HYSTERESIS
from envs.identification.closed_loop_experiment import ClosedLoopStepResult, identify_closed_loop_step
from envs.identification.commissioning import commissioning_pi
from envs.identification.models import FOPDTModel
from envs.identification.moments import apparent_time_constant, fopdt_from_moments, normalized_moments
from envs.identification.open_loop_step import OpenLoopStepResult, identify_open_loop_step
from envs.identification.procedure import Identification
from envs.identification.relay import RelayResult
from envs.identification.relay_cycle import relay_estimates
from envs.identification.steady_state import SteadyStateTest, window_samples
from envs.process.control_laws import discrete_law
from envs.process.protocol import Process, check_process
from envs.process.runs import Record, closed_loop, hold, relay, reset, steady_since_previous_window
from envs.systems.controllers import PID, SeriesPID
from envs.validation import require_number

__all__ = ["OperatingPoint", "Commissioning", "ProcessIdentification", "identify_process", "SETTLING_WINDOWS", "MAX_SETTLING"]

SETTLING_WINDOWS = 5.0
"""Before a model is identified, a steady-state window is ``settling_time/SETTLING_WINDOWS``."""
MAX_SETTLING = 5.0
"""An experiment (or a wait for the operating point) lasts at most ``MAX_SETTLING settling_time``."""


@dataclass(frozen=True)
class OperatingPoint:
    """``(u_0, y_0)``, the time it took to settle there after a reset, and the noise there.

    ``noise_std`` is the RMS of the second differences of the last window over ``sqrt(6)``: white
    noise's standard deviation, and about ``q/sqrt(6)`` for a quantized signal flickering between
    levels ``q`` apart.
    """

    input: float
    output: float
    settle_time: float
    noise_std: float


@dataclass(frozen=True)
class Commissioning:
    """The commissioning controller and where it came from (``"given"`` or ``"open-loop step"``).

    ``model`` is the moment FOPDT of the first open-loop step it was designed on, ``step`` that step's
    record (deviations from the operating point); both None when it was given.
    """

    source: str
    controller: PID | SeriesPID
    model: FOPDTModel | None = None
    step: Record | None = None


@dataclass(frozen=True)
class ProcessIdentification:
    """Everything the procedure measured on a process (engineering units, deviations from the
    operating point).

    Attributes
    ----------
    process : str
    sample_time : float
    input_limits : (float, float)
    operating_point : OperatingPoint
    setpoint_step : float
    commissioning : Commissioning
    identification : Identification
        The fixed procedure (steps 3-4), as the environments' fixed mode identifies it.
    relay : RelayResult or None
        Step 5 (None if not run).
    noise_ratio : float
        ``sigma/|setpoint_step|``, the environments' noise-to-amplitude ratio.
    load_gain : float or None
        The process's ``load_gain`` (the static effect of its load on the output), if it gives one.
    quantization : float
        The process's sensor resolution ``quantization``, in output units (0 if it gives none).
    process_time : float
        Time spent on the process, settling and returns included.
    records : dict of str to Record
        The raw records of each run, by name (``settle``, ``first-step``, ``closed-loop-step``,
        ``open-loop-step``, ``relay``), in absolute units.
    """

    process: str
    sample_time: float
    input_limits: tuple[float, float]
    operating_point: OperatingPoint
    setpoint_step: float
    commissioning: Commissioning
    identification: Identification
    relay: RelayResult | None
    noise_ratio: float
    load_gain: float | None
    process_time: float
    records: dict = field(repr=False, default_factory=dict)
    quantization: float = 0.0

    @property
    def closed_loop(self) -> ClosedLoopStepResult:
        return self.identification.closed_loop

    @property
    def open_loop(self) -> OpenLoopStepResult:
        return self.identification.open_loop


class _Clock:
    """The process time spent by the procedure's runs, and their records by name."""

    def __init__(self, sample_time: float) -> None:
        self.sample_time, self.time, self.records = sample_time, 0.0, {}

    def add(self, name: str, record: Record) -> Record:
        self.time += record.timepts.size * self.sample_time
        self.records[name] = record
        if record.stopped:
            raise ValueError(f"{name}: {record.stopped}")
        return record


def identify_process(
    process: Process,
    *,
    seed: int = 0,
    controller: PID | SeriesPID | None = None,
    setpoint_step: float | None = None,
    input_step: float | None = None,
    operating_input: float | None = None,
    relay_test: bool = True,
) -> ProcessIdentification:
    """Run the procedure of the module docstring on ``process``.

    Parameters
    ----------
    process : Process
    seed : int
        Passed to ``process.reset``.
    controller : PID or SeriesPID, optional
        The loop's existing controller (engineering units); default: designed from a first
        open-loop step.
    setpoint_step, input_step, operating_input : float, optional
        Override the process's own amplitudes (output and input units) and operating input.
    relay_test : bool
        Run the relay (step 5).

    Raises
    ------
    ValueError
        For an invalid process or amplitude (a step that leaves the input limits), a process that
        does not settle at its operating point, a measurement that is not a number (naming the run
        and the time), or an experiment that identifies no usable model.
    """
    process = check_process(process)
    step = require_number(process.setpoint_step if setpoint_step is None else setpoint_step, "setpoint_step", nonzero=True)
    first_height = require_number(process.input_step if input_step is None else input_step, "input_step", nonzero=True)
    if controller is not None and not isinstance(controller, PID | SeriesPID):
        raise ValueError(f"controller must be a PID or series PID (the loop's existing controller), got {type(controller).__name__}")
    if controller is not None and controller.ti is None:
        raise ValueError("controller must have integral action (ti) for the closed-loop step")
    dt = process.sample_time
    u0 = float(process.operating_input) if operating_input is None else require_number(operating_input, "operating_input")
    low, high = process.input_limits
    if not low < u0 < high:
        raise ValueError(f"operating_input {u0:g} is outside the input limits [{low:g}, {high:g}]")
    cap = int(math.ceil(MAX_SETTLING * process.settling_time / dt)) + 1
    window = max(int(round(process.settling_time / SETTLING_WINDOWS / dt)), 3)
    clock = _Clock(dt)
    reset(process, seed)
    point = _operating_point(process, clock, u0, cap, window, step)
    if controller is None:
        _check_input(process, u0, u0 + first_height, "input_step", first_height)
        commissioning = _first_step(process, clock, point, first_height, cap, window, step)
    else:
        commissioning = Commissioning("given", controller)
    scale = commissioning.model.residence_time if commissioning.model is not None else window * dt
    if commissioning.model is not None:
        steady = step / commissioning.model.gain
        _check_input(process, u0, u0 + steady, "setpoint_step", step,
                     f"the closed-loop step's steady input change setpoint_step/K = {steady:.4g} (K of the first step)")
    first = _closed_loop_step(process, clock, point, commissioning.controller, step, cap, scale)
    _return(process, clock, "return-1", u0, cap, window_samples(first.residence_time, dt), step)
    height = step / first.gain
    _check_input(process, u0, u0 + height, "setpoint_step", step, f"the open-loop step setpoint_step/K_n = {height:.4g}")
    second = _open_loop_step(process, clock, point, height, first, cap)
    found_relay = None
    if relay_test:
        _return(process, clock, "return-2", u0, cap, window_samples(first.residence_time, dt), step)
        found_relay = _relay(process, clock, point, first, step, cap)
    identification = Identification(
        integrating=False, gain=first.gain, residence_time=first.residence_time, fopdt=second.model, sopdt=first.sopdt,
        integrating_model=None, mismatch_time=second.mismatch_time, pulse_area=math.nan,
        experiment_time=first.duration + second.duration, closed_loop=first, open_loop=second,
    )  # fmt: skip
    return ProcessIdentification(
        process=str(process.name), sample_time=dt, input_limits=tuple(float(v) for v in process.input_limits),
        operating_point=point, setpoint_step=step, commissioning=commissioning, identification=identification,
        relay=found_relay, noise_ratio=point.noise_std / abs(step), load_gain=getattr(process, "load_gain", None),
        process_time=clock.time, records=clock.records, quantization=float(getattr(process, "quantization", None) or 0.0),
    )  # fmt: skip


def _check_input(process: Process, u0: float, value: float, name: str, amount: float, what: str | None = None) -> None:
    low, high = process.input_limits
    if not low <= value <= high:
        what = what or f"the step {name} = {amount:g}"
        raise ValueError(f"{name}: {what} from the operating input {u0:g} gives {value:.4g}, "
                         f"outside the input limits [{low:g}, {high:g}]")


def _operating_point(process: Process, clock: _Clock, u0: float, cap: int, window: int, scale: float) -> OperatingPoint:
    record = clock.add("settle", hold(process, u0, cap, until=lambda ys: steady_since_previous_window(ys, window, scale)))
    if not record.settled:
        raise ValueError(f"the process did not settle at the operating input {u0:g} within {MAX_SETTLING:g} settling times "
                         f"({cap * process.sample_time:g} {process.units.time}): is it integrating, or is settling_time "
                         f"({process.settling_time:g}) too short?")
    last = record.output[-window:]
    noise = math.sqrt(float(np.mean(np.diff(last, 2) ** 2)) / 6.0)
    return OperatingPoint(u0, float(np.mean(last)), record.duration + process.sample_time, noise)


def _return(process: Process, clock: _Clock, name: str, u0: float, cap: int, window: int, scale: float) -> None:
    """Back to the operating point: ``u_0`` held until the output is steady (or the cap)."""
    clock.add(name, hold(process, u0, cap, until=lambda ys: steady_since_previous_window(ys, window, scale)))


def _steady_deviation(y0: float, window: int, start: int, target: float | None = None):
    """``until`` for a run: the deviation ``y - y0`` passes the steady-state tests (window, from sample
    ``start`` on; with ``target``: at it), those of :class:`~envs.identification.steady_state.SteadyStateTest`."""
    test = SteadyStateTest(window, target=target)

    def until(outputs: list[float]) -> bool:
        hits = test.extend(np.asarray(outputs) - y0)
        return bool(len(outputs) > start and hits.size and hits[-1])

    return until


def _deviation_record(record: Record, point: OperatingPoint, scale: float, settled: bool) -> dict:
    """The ExperimentResult fields of a run, as deviations from the operating point (a process has no
    noise-free output: ``true_output`` is the measurement)."""
    t = record.timepts
    output = record.output - point.output
    return dict(timepts=t, control=record.control - point.input, output=output, true_output=output,
                duration=float(t[-1]), relative_duration=float(t[-1] / scale), aborted=False)


def _first_step(process, clock, point, height, cap, window, scale_of_tolerance) -> Commissioning:
    until = _steady_deviation(point.output, window, 2 * window)
    record = clock.add("first-step", hold(process, point.input + height, cap, until=until))
    if not record.settled:
        raise ValueError(f"the first open-loop step (input_step = {height:g}) did not settle within {MAX_SETTLING:g} "
                         "settling times: is settling_time too short?")
    t, y = record.timepts, record.output - point.output
    final = float(np.mean(y[-window:]))
    if final == 0.0:
        raise ValueError(f"the first open-loop step (input_step = {height:g}) did not move the output")
    first_moment, second_moment = normalized_moments(t, y, 0.0, final)
    model = fopdt_from_moments(final / height, first_moment, apparent_time_constant(first_moment, second_moment))
    controller = commissioning_pi(model.plant())
    deviations = Record(t, record.control - point.input, record.computed - point.input, y, record.setpoint, record.load, True)
    _return(process, clock, "return-0", point.input, cap, window, scale_of_tolerance)
    return Commissioning("open-loop step", controller, model, deviations)


def _closed_loop_step(process, clock, point, controller, step, cap, scale) -> ClosedLoopStepResult:
    dt = process.sample_time
    window = window_samples(scale, dt)
    output_test, drive_test = SteadyStateTest(window, target=step), SteadyStateTest(window)

    def until(outputs: list[float], controls: list[float]) -> bool:
        output = output_test.extend(np.asarray(outputs) - point.output)
        drive = drive_test.extend(np.asarray(controls) - point.input)
        return bool(output.size and output[-1] and drive[-1])

    law = discrete_law(controller, dt, process.input_limits)
    law.start(point.input)
    record = clock.add("closed-loop-step", closed_loop(process, law, cap, setpoint=point.output + step, until=until))
    fields = _deviation_record(record, point, scale, record.settled)
    result = identify_closed_loop_step(fields, fields["control"], step, controller, record.settled, window, False)
    if not (record.settled and np.isfinite(result.gain) and result.gain != 0 and result.residence_time > 0):
        raise ValueError(f"the closed-loop step identified no usable model (settled: {record.settled}, gain {result.gain:.4g}, "
                         f"T_ar {result.residence_time:.4g}): is the commissioning controller stable on the process?")
    return result


def _open_loop_step(process, clock, point, height, first, cap) -> OpenLoopStepResult:
    dt = process.sample_time
    window = window_samples(first.residence_time, dt)
    start = int(math.ceil(2.0 * first.residence_time / dt))
    record = clock.add("open-loop-step", hold(process, point.input + height, cap, until=_steady_deviation(point.output, window, start)))
    fields = _deviation_record(record, point, first.residence_time, record.settled)
    result = identify_open_loop_step(fields, height, first.residence_time, first.gain, window, record.settled)
    if result.model is None:
        raise ValueError("the open-loop step identified no FOPDT model (it stopped before T_ar)")
    return result


def _relay(process, clock, point, first, step, cap) -> RelayResult:
    low, high = process.input_limits
    amplitude = min(abs(step / first.gain), point.input - low, high - point.input)
    hysteresis = RELAY_HYSTERESIS * point.noise_std
    run = relay(process, point.input, amplitude, point.output, hysteresis, cap, sign=1.0 if first.gain > 0 else -1.0)
    record = clock.add("relay", run.record)
    fields = _deviation_record(record, point, first.residence_time, record.settled)
    return RelayResult(**fields, amplitude=amplitude, hysteresis=hysteresis, converged=record.settled,
                       switching_times=run.switching_times,
                       **relay_estimates(record.timepts, fields["output"], run.switching_times, amplitude))
