"""Experiments 2-4: open-loop step, ramp and pulse on the true plant.

* :func:`open_loop_step`: ``T_n`` from the area over ``[0, T_ar]`` (Ingimundarson eq. 11), then on
  to steady state for ``T_f_bar`` (eq. 22) and the process reaction curve (Marlin 6.3).
* :func:`open_loop_ramp`: ``T_n`` by eq. 12.
* :func:`open_loop_pulse` (integrating plants): the area ``A`` of eq. 46.

Each takes ``K_n`` and ``T_ar`` (or ``L_n``) identified by experiment 1
(:func:`~envs.identification.closed_loop_experiment.closed_loop_step`); steady state is detected with a window of
the identified ``T_ar`` (``L_n``), see :mod:`envs.identification.steady_state`.

References
----------
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000, sections 2, 4.1 and 5.1.
.. [MA] T. Marlin, "Process Control", section 6.3.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import cached_property

import numpy as np

from envs.identification.experiment_base import (
    ExperimentResult,
    cap_steps,
    fixed_length_steps,
    check_plant,
    check_rng,
    excursion_index,
    MeasurementNoise,
    as_noise,
    measurement_noise,
    record_fields,
    ExperimentRun,
    run_until_settled,
    sample_time,
    snap_to_integer,
)
from envs.identification.models import FOPDTModel, IntegratingModel
from envs.identification.moments import residence_time_from_area
from envs.identification.open_loop_areas import (
    fopdt_from_area,
    mismatch_time,
    pulse_mismatch_area,
    ramp_time_constant,
    step_time_constant,
)
from envs.identification.reaction_curve import reaction_curve_tangent, reaction_curve_two_point
from envs.identification.sampled_signals import integrate
from envs.systems.plants import Plant, StateSpace
from envs.simulation.delay_systems import OpenLoopRun, open_loop_response
from envs.identification.steady_state import SteadyStateTest, noise_level, window_samples
from envs.validation import require_number

__all__ = [
    "OpenLoopStepResult",
    "OpenLoopRampResult",
    "OpenLoopPulseResult",
    "open_loop_step",
    "open_loop_ramp",
    "open_loop_pulse",
    "identify_open_loop_step",
]


# --------------------------------------------------------------------------- helpers
def _run_to_steady_state(
    plant: Plant,
    inputs: np.ndarray,
    noise: MeasurementNoise | np.ndarray,
    dt: float,
    window: int,
    start: int,
    excursion_limit: float | None,
) -> ExperimentRun:
    """Simulate ``inputs`` (held per sample) over growing horizons, from ``start + 6 window``
    samples and doubling, until the measured output is steady from sample ``start`` on
    (:func:`~envs.identification.steady_state.steady_state_index`), the cap (``inputs.size`` samples) or an
    excursion of the true output.  ``noise`` is drawn as the run grows (or given, one sample per input)."""
    noise = as_noise(noise)
    response = OpenLoopRun(plant.state_space(), plant.dead_time, inputs, dt)
    test = SteadyStateTest(window)
    measured = np.empty(inputs.size)
    done = [0]  # each chunk continues the recursion and tests only its new samples (see run_until_settled)

    def trial(steps: int, horizon: int) -> tuple:
        y = response.response(steps)
        old = done[0]
        measured[old:steps] = y[old:] + noise.first(steps)[old:]
        abort = excursion_index(y[old:], excursion_limit)
        hits = np.flatnonzero(test.extend(measured[:steps])[max(start - old, 0) :])
        done[0] = steps
        settle = int(hits[0]) + max(start, old) if hits.size else None
        return np.arange(steps) * dt, inputs[:steps], measured[:steps], y, None if abort is None else abort + old, settle

    return run_until_settled(trial, max(start + 6 * window, 16), inputs.size, chunk=CHUNK_WINDOWS * window)


CHUNK_WINDOWS = 2
"""Windows simulated and tested at a time within a horizon (a run stops within a chunk of settling)."""


def _smoothing_samples(signal: np.ndarray, change: float, residence_time: float, dt: float) -> int:
    """Samples over which to fit slopes and average for the reaction curve.

    With noise ``sigma`` (estimated by :func:`noise_level`), the least-squares slope over ``n``
    samples has standard deviation ``sigma sqrt(12/n^3)/dt``; ``n`` is chosen so that this is a tenth
    of the slope scale ``|Delta|/T_ar``, at most ``T_ar/(4 dt)``.  When that asks for 2 samples or
    fewer the data are clean enough for the finite difference and no smoothing (``n = 1``).
    """
    slope_scale = 0.1 * abs(change) / residence_time
    samples = (12.0 * noise_level(signal) ** 2 / (dt * slope_scale) ** 2) ** (1.0 / 3.0)
    if samples <= 2.0:
        return 1
    return int(min(math.ceil(samples), max(snap_to_integer(residence_time / (4.0 * dt)), 3)))


def _moving_average(signal: np.ndarray, samples: int) -> np.ndarray:
    if samples <= 1:
        return signal
    padded = np.concatenate([np.full(samples // 2, signal[0]), signal, np.full(samples - 1 - samples // 2, signal[-1])])
    return np.convolve(padded, np.ones(samples) / samples, mode="valid")


def _self_regulating(plant: Plant, experiment: str) -> Plant:
    plant = check_plant(plant)
    if plant.integrating:
        raise ValueError(f"plant must be self-regulating for {experiment} (use open_loop_pulse for an integrating plant)")
    return plant


@dataclass(frozen=True)
class OpenLoopStepResult(ExperimentResult):
    """Open-loop step (experiment 2).

    Attributes
    ----------
    height : float
        Step height ``h``.
    settled : bool
        Steady state was reached before the cap (needed for the fields below ``dead_time``).
    area : float
        ``A = int_0^{T_ar} y dt`` (measured output, Ingimundarson eq. 11).
    raw_time_constant : float
        ``T_n = A e/(h K_n)`` (eq. 11), unclipped.
    time_constant, dead_time : float
        ``T_n`` clipped to ``(0, T_ar]`` and ``L_n = T_ar - T_n`` (:func:`~envs.identification.open_loop_areas.fopdt_from_area`).
    model : FOPDTModel or None
        ``K_n e^{-L_n s}/(T_n s + 1)`` with ``K_n`` and ``T_ar`` as given.
    final_output : float
        Steady-state change ``Delta`` (mean of the measured output over the last window).
    mismatch_time : float
        ``T_f_bar = int_0^{t_f} |y/h - y_n| dt / |K_n|`` (eq. 22).
    tangent_model, two_point_model : FOPDTModel or None
        Marlin's process reaction curve, Methods I and II (section 6.3); computed when first read
        (the environments never read them).
    """

    height: float
    settled: bool
    area: float
    raw_time_constant: float
    time_constant: float
    dead_time: float
    model: FOPDTModel | None
    final_output: float
    mismatch_time: float
    _reaction_curves: _ReactionCurves | None = field(default=None, repr=False, compare=False)

    @property
    def tangent_model(self) -> FOPDTModel | None:
        return None if self._reaction_curves is None else self._reaction_curves.models["tangent_model"]

    @property
    def two_point_model(self) -> FOPDTModel | None:
        return None if self._reaction_curves is None else self._reaction_curves.models["two_point_model"]


class _ReactionCurves:
    """The reaction-curve models of a settled step, computed on first use (:func:`_reaction_curve_models`)."""

    def __init__(self, t: np.ndarray, y: np.ndarray, height: float, final: float, residence_time: float) -> None:
        self._arguments = (t, y, height, final, residence_time)

    @cached_property
    def models(self) -> dict:
        return _reaction_curve_models(*self._arguments)


def open_loop_step(
    plant: Plant,
    rng: np.random.Generator,
    height: float,
    residence_time: float,
    gain: float,
    noise_std: float = 0.0,
    dt: float | None = None,
    excursion_limit: float | None = None,
    max_duration: float | None = None,
    *,
    disturbances=None,
) -> OpenLoopStepResult:
    """Open-loop step of height ``h``: ``T_n`` (eq. 11), then on to steady state for ``T_f_bar``.

    Parameters
    ----------
    plant : Plant
        The true, self-regulating plant.
    rng : numpy.random.Generator
        Source of the measurement noise.
    height : float
        Step height ``h`` (non-zero).
    residence_time, gain : float
        ``T_ar`` and ``K_n`` from experiment 1 (:func:`closed_loop_step`).
    noise_std, dt, excursion_limit, max_duration, disturbances
        As in :func:`closed_loop_step`.

    Returns
    -------
    OpenLoopStepResult

    Notes
    -----
    Ingimundarson section 2.3 steps 5-6: ``A = int_0^{T_ar} y dt``, ``T_n`` by eq. 11,
    ``L_n = T_ar - T_n``; section 4.1: the same step run on to steady state gives the mismatch
    ``f = y/h - y_n`` with ``y_n`` the model's step response (eq. 20) and ``T_f_bar = int |f| dt/K_n``
    (eq. 22).  Steady state: two consecutive windows of ``T_ar`` agree and are flat
    (:func:`steady_state_mask`), checked from ``t = 2 T_ar`` on.  The reaction curve (Marlin 6.3)
    uses ``Delta`` = the mean of the last window; on noisy data the tangent's slope is fitted, and
    Method II reads a moving average, over a number of samples chosen from the estimated noise
    (``_smoothing_samples``).
    """
    plant, rng = _self_regulating(plant, "open_loop_step"), check_rng(rng)
    height = require_number(height, "height", nonzero=True)
    residence_time = require_number(residence_time, "residence_time", positive=True)
    gain = require_number(gain, "gain", nonzero=True)
    noise_std = require_number(noise_std, "noise_std", nonnegative=True)
    dt, scale = sample_time(plant, dt), plant.step_time_scale()
    steps = cap_steps(scale, dt, max_duration, minimum=2.0 * residence_time)
    noise = measurement_noise(rng, noise_std, steps, disturbances, plant, dt)
    window = window_samples(residence_time, dt)
    start = math.ceil(snap_to_integer(2.0 * residence_time / dt))
    run = _run_to_steady_state(plant, np.full(steps, height), noise, dt, window, start, excursion_limit)
    return identify_open_loop_step(record_fields(run, scale), height, residence_time, gain, window, run.settled)


def identify_open_loop_step(
    record: dict, height: float, residence_time: float, gain: float, window: int, settled: bool
) -> OpenLoopStepResult:
    """The result of an open-loop step from its sampled record (experiment 2's arithmetic).

    ``record`` holds the :class:`~envs.identification.experiment_base.ExperimentResult` fields in
    deviation variables (at rest at 0 before the step of ``height`` at ``timepts[0]``); ``residence_time``
    and ``gain`` are ``T_ar`` and ``K_n`` of experiment 1, ``window`` the samples of one ``T_ar`` and
    ``settled`` whether the record ends at its steady state.  ``T_n`` by eq. 11, ``L_n``, then (if
    settled) ``T_f_bar`` by eq. 22 and the reaction curves, as :func:`open_loop_step`; a sampled
    process (:mod:`envs.process.procedure`) identifies with this same arithmetic.
    """
    return OpenLoopStepResult(**record, height=height, settled=settled,
                              **_step_identification(record, height, residence_time, gain, window, settled))


def _step_identification(record: dict, height: float, residence_time: float, gain: float, window: int, settled: bool) -> dict:
    t, y = record["timepts"], record["output"]
    nan = float("nan")
    out = dict(area=nan, raw_time_constant=nan, time_constant=nan, dead_time=nan, model=None,
               final_output=nan, mismatch_time=nan, _reaction_curves=None)
    if t[-1] < residence_time:
        return out
    area = integrate(t, y, end=residence_time)
    raw = step_time_constant(area, height, gain)
    model = fopdt_from_area(gain, residence_time, raw)
    out.update(area=area, raw_time_constant=raw, time_constant=model.time_constant, dead_time=model.dead_time, model=model)
    if not settled:
        return out
    final = float(np.mean(y[-window:]))
    out.update(final_output=final, mismatch_time=mismatch_time(t, y / height, model))
    out.update(_reaction_curves=_ReactionCurves(t, y, height, final, residence_time))
    return out


def _reaction_curve_models(t: np.ndarray, y: np.ndarray, height: float, final: float, residence_time: float) -> dict:
    dt = t[1] - t[0]
    smoothing = _smoothing_samples(y, final, residence_time, dt)
    curves = dict(tangent_model=None, two_point_model=None)
    try:
        curves["tangent_model"] = reaction_curve_tangent(t, y, height, final, window=max(smoothing, 2))
    except ValueError:
        pass
    try:
        curves["two_point_model"] = reaction_curve_two_point(t, _moving_average(y, smoothing), height, final)
    except ValueError:
        pass
    return curves


# --------------------------------------------------------------------------- experiment 3: ramp
@dataclass(frozen=True)
class OpenLoopRampResult(ExperimentResult):
    """Open-loop ramp (experiment 3); ``control`` is the ramp ``h t`` at the sample times.

    Attributes
    ----------
    rate : float
        Ramp rate ``h``.
    area : float
        ``A = int_0^{T_ar} y dt``.
    raw_time_constant : float
        ``T_n = sqrt(A/(h K_n (1/2 - e^{-1})))`` (Ingimundarson eq. 12); 0 if ``A/(h K_n) <= 0``.
    time_constant, dead_time : float
        ``T_n`` clipped to ``(0, T_ar]`` and ``L_n = T_ar - T_n``.
    model : FOPDTModel or None
    """

    rate: float
    area: float
    raw_time_constant: float
    time_constant: float
    dead_time: float
    model: FOPDTModel | None


def open_loop_ramp(
    plant: Plant,
    rng: np.random.Generator,
    rate: float,
    residence_time: float,
    gain: float,
    noise_std: float = 0.0,
    dt: float | None = None,
    excursion_limit: float | None = None,
    *,
    disturbances=None,
) -> OpenLoopRampResult:
    """Open-loop ramp of rate ``h`` for ``T_ar``: ``T_n`` by Ingimundarson eq. 12.

    The ramp response of ``G e^{-Ls}`` is the step response of ``G(s)/s e^{-Ls}``: the plant is
    augmented with an integrator at its input (``x' = A x + B z``, ``z' = h``, ``y = C x + D z``) and
    driven by a step of height ``h`` through the exact simulation, so the response is exact.  The
    experiment lasts ``T_ar`` (section 2.2: "The length of the open loop experiment is always
    ``T_ar``").  A ``T_ar`` longer than :data:`~envs.simulation.delay_systems.MAX_RUN_SAMPLES` samples
    (an identification far off, e.g. under a load) stops the ramp there unfinished, as an aborted one.

    Parameters
    ----------
    rate : float
        Ramp rate ``h`` (non-zero).
    residence_time, gain : float
        ``T_ar`` and ``K_n`` from experiment 1.
    """
    plant, rng = _self_regulating(plant, "open_loop_ramp"), check_rng(rng)
    rate = require_number(rate, "rate", nonzero=True)
    residence_time = require_number(residence_time, "residence_time", positive=True)
    gain = require_number(gain, "gain", nonzero=True)
    noise_std = require_number(noise_std, "noise_std", nonnegative=True)
    dt, scale = sample_time(plant, dt), plant.step_time_scale()
    steps, cut = fixed_length_steps(residence_time / dt - 1e-9)
    noise = measurement_noise(rng, noise_std, steps, disturbances, plant, dt).first(steps)  # the ramp runs to its end
    y = open_loop_response(_with_input_integrator(plant.state_space()), plant.dead_time, np.full(steps, rate), dt)
    t = np.arange(steps) * dt
    abort = excursion_index(y, excursion_limit)
    if abort is None and cut:
        abort = steps - 1
    run = ExperimentRun(t, rate * t, y + noise, y, steps - 1 if abort is None else abort, abort is None, abort is not None)
    record = record_fields(run, scale)
    if abort is not None:
        record.update(duration=float(t[abort]), relative_duration=float(t[abort] / scale))
        nan = float("nan")
        return OpenLoopRampResult(**record, rate=rate, area=nan, raw_time_constant=nan, time_constant=nan, dead_time=nan, model=None)
    record.update(duration=residence_time, relative_duration=residence_time / scale)
    area = integrate(t, record["output"], end=residence_time)
    raw = ramp_time_constant(area, rate, gain)
    model = fopdt_from_area(gain, residence_time, raw)
    return OpenLoopRampResult(**record, rate=rate, area=area, raw_time_constant=raw,
                              time_constant=model.time_constant, dead_time=model.dead_time, model=model)


def _with_input_integrator(ss: StateSpace) -> StateSpace:
    n = ss.A.shape[0]
    A = np.zeros((n + 1, n + 1))
    A[:n, :n] = ss.A
    A[:n, n] = ss.B[:, 0]
    B = np.zeros((n + 1, 1))
    B[n, 0] = 1.0
    C = np.hstack([ss.C, ss.D])
    return StateSpace(A=A, B=B, C=C, D=np.zeros((1, 1)))


# --------------------------------------------------------------------------- experiment 4: pulse
@dataclass(frozen=True)
class OpenLoopPulseResult(ExperimentResult):
    """Open-loop pulse into an integrating plant (experiment 4).

    Attributes
    ----------
    height, pulse_duration : float
        ``h_p`` and ``tau_p``.
    settled : bool
        The output settled at its new level before the cap.
    model : IntegratingModel
        The two-parameter model ``K_n e^{-L_n s}/s`` compared against (from experiment 1).
    area : float
        ``A = int |y - y_n| dt/(h_p tau_p)`` (Ingimundarson eq. 46).
    final_output : float
        New steady level (mean over the last window).
    pulse_model : IntegratingModel or None
        The two-parameter model from the pulse alone: ``K_v = y_f/(h_p tau_p)`` and ``L_n`` by
        eq. 10 with the integrated input ``u_i`` (section 2.1), as in section 5.6.
    """

    height: float
    pulse_duration: float
    settled: bool
    model: IntegratingModel
    area: float
    final_output: float
    pulse_model: IntegratingModel | None


def open_loop_pulse(
    plant: Plant,
    rng: np.random.Generator,
    height: float,
    duration: float,
    gain: float,
    dead_time: float,
    noise_std: float = 0.0,
    dt: float | None = None,
    excursion_limit: float | None = None,
    max_duration: float | None = None,
    *,
    disturbances=None,
) -> OpenLoopPulseResult:
    """Pulse of height ``h_p`` and duration ``tau_p`` into an integrating plant; ``A`` of eq. 46.

    Parameters
    ----------
    plant : Plant
        The true, integrating plant.
    height, duration : float
        ``h_p`` (non-zero) and ``tau_p`` (> 0).
    gain, dead_time : float
        ``K_n`` (velocity gain) and ``L_n`` of the two-parameter model, from experiment 1.
    noise_std, dt, excursion_limit, max_duration, disturbances
        As in :func:`closed_loop_step`; ``dt`` is shrunk so that ``tau_p`` is a whole number of samples.

    Notes
    -----
    Runs until the output is flat at its new level: two consecutive windows of
    ``max(L_n, tau_p)`` agree (:func:`steady_state_mask`), checked after the pulse has ended and one
    more window has passed.  ``A`` integrates ``|y - y_n|`` over the whole record (eq. 45-46), so with
    noise it grows with the duration.
    """
    plant, rng = check_plant(plant), check_rng(rng)
    if not plant.integrating:
        raise ValueError("plant must be integrating for open_loop_pulse")
    height = require_number(height, "height", nonzero=True)
    duration = require_number(duration, "duration", positive=True)
    model = IntegratingModel(gain=require_number(gain, "gain", nonzero=True), dead_time=require_number(dead_time, "dead_time", nonnegative=True))
    noise_std = require_number(noise_std, "noise_std", nonnegative=True)
    scale = plant.step_time_scale()
    pulse_samples = max(int(round(duration / sample_time(plant, dt))), 1)
    dt = duration / pulse_samples
    steps = cap_steps(scale, dt, max_duration, minimum=3.0 * (duration + model.dead_time))
    noise = measurement_noise(rng, noise_std, steps, disturbances, plant, dt)
    inputs = np.zeros(steps)  # np.where(np.arange(steps) < pulse_samples, height, 0.0), without the index array
    inputs[:pulse_samples] = height
    window = window_samples(max(model.dead_time, duration), dt)
    start = pulse_samples + window
    run = _run_to_steady_state(plant, inputs, noise, dt, window, start, excursion_limit)
    record = record_fields(run, scale)
    t, y = record["timepts"], record["output"]
    area = pulse_mismatch_area(t, y, model, height, duration) if run.settled else float("nan")
    final = float(np.mean(y[-window:])) if run.settled else float("nan")
    return OpenLoopPulseResult(**record, height=height, pulse_duration=duration, settled=run.settled, model=model,
                               area=area, final_output=final, pulse_model=_pulse_model(t, y, height, duration, final))


def _pulse_model(t: np.ndarray, y: np.ndarray, height: float, duration: float, final: float) -> IntegratingModel | None:
    if not np.isfinite(final) or final == 0.0:
        return None
    integrated_input = height * np.minimum(t, duration)
    dead_time = residence_time_from_area(t, integrated_input, y, initial=(0.0, 0.0), final=(height * duration, final))
    return IntegratingModel(gain=final / (height * duration), dead_time=max(dead_time, 0.0))
