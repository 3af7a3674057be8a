"""Experiment 2: the open-loop step on the true plant.

:func:`open_loop_step`: ``T_n`` from the area over ``[0, T_ar]`` (Ingimundarson eq. 11), then on to
steady state for ``T_f_bar`` (eq. 22) and the process reaction curve (Marlin 6.3);
:func:`identify_open_loop_step` is its arithmetic on any sampled record.  It takes ``K_n`` and
``T_ar`` identified by experiment 1
(:func:`~envs.identification.closed_loop_experiment.closed_loop_step`).

References
----------
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000, sections 2 and 4.1.
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
    check_rng,
    measurement_noise,
    record_fields,
    sample_time,
    snap_to_integer,
)
from envs.identification.models import FOPDTModel
from envs.identification.open_loop_areas import fopdt_from_area, mismatch_time, step_time_constant
from envs.identification.open_loop_run import _run_to_steady_state, _self_regulating
from envs.identification.reaction_curve import reaction_curve_tangent, reaction_curve_two_point
from envs.identification.sampled_signals import integrate
from envs.systems.plants import Plant
from envs.identification.steady_state import noise_level, window_samples
from envs.validation import require_number

__all__ = ["OpenLoopStepResult", "open_loop_step", "identify_open_loop_step"]


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
    quantization: float = 0.0,
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
    noise_std, dt, excursion_limit, max_duration, disturbances, quantization
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
    noise = measurement_noise(rng, noise_std, steps, disturbances, plant, dt, quantization)
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
