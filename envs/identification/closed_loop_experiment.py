"""Experiment 1: closed-loop set-point step, identified by the method of moments.

:func:`closed_loop_step` steps the set point of the plant under its commissioning PI
(:func:`~envs.identification.commissioning.commissioning_pi`) or a given controller, runs to steady state
(:func:`~envs.identification.steady_state.steady_state_mask`, window ``T``) and identifies ``K`` (``K_v``),
``T_ar`` (Ingimundarson eq. 10), ``T_a`` (Gorez-Klan appendix B), ``tau``, ``theta`` and the SOPDT
model (eq. 2-7 .. 2-10).

The run to steady state, compiled and readable, is :mod:`envs.identification.closed_loop_run`;
:func:`identify_closed_loop_step` is the arithmetic on any sampled record.

References
----------
.. [GK] R. Gorez, P. Klan, "Simple models for process control", section 2 and appendix B.
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000, sections 2.1 and 2.3.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envs.identification.commissioning import commissioning_pi
from envs.systems.controllers import Controller
from envs.identification.experiment_base import (
    ExperimentResult,
    cap_steps,
    check_plant,
    check_rng,
    measurement_noise,
    record_fields,
    sample_time,
)
from envs.identification.closed_loop_run import _check_method, _ClosedLoopRun, _run_closed_loop
from envs.identification.models import FOPDTModel, IntegratingModel, SOPDTModel
from envs.identification.moments import closed_loop_moments, fopdt_from_moments, sopdt_from_theta, theta_from_tau
from envs.systems.plants import Plant
from envs.identification.steady_state import window_samples
from envs.validation import require_number

__all__ = ["ClosedLoopStepResult", "closed_loop_step", "identify_closed_loop_step"]


@dataclass(frozen=True)
class ClosedLoopStepResult(ExperimentResult):
    """Closed-loop set-point step (experiment 1).

    Attributes
    ----------
    amplitude : float
        Set-point step ``r``.
    controller : Controller
        The loop's controller.
    settled : bool
        Steady state was reached before the cap.
    gain : float
        ``K = y_f/u_f`` (Gorez-Klan eq. 2-4), or ``K_v = y_f/u_i(t_f)`` if integrating.
    residence_time : float
        ``T_ar`` by Ingimundarson eq. 10 (for an integrating plant: of the dynamics additional to the
        integrator, ``L_n`` of eq. 2).
    apparent_time_constant : float
        ``T_a`` (Gorez-Klan appendix B), clipped to ``[0, T_ar]``.
    normalized_dead_time, theta : float
        ``tau = 1 - T_a/T_ar`` (eq. 2-7) and ``theta`` (eq. 2-10).
    fopdt, sopdt : FOPDTModel or None
        Moment models (eq. 2-1, 2-2/2-8), self-regulating plants only.
    integrating_model : IntegratingModel or None
        ``K_v e^{-T_ar s}/s`` (Ingimundarson eq. 2), integrating plants only.
    """

    amplitude: float
    controller: Controller
    settled: bool
    gain: float
    residence_time: float
    apparent_time_constant: float
    normalized_dead_time: float
    theta: float
    fopdt: FOPDTModel | None
    sopdt: SOPDTModel | None
    integrating_model: IntegratingModel | None


def closed_loop_step(
    plant: Plant,
    rng: np.random.Generator,
    amplitude: float = 1.0,
    noise_std: float = 0.0,
    controller: Controller | None = None,
    dt: float | None = None,
    excursion_limit: float | None = None,
    max_duration: float | None = None,
    *,
    method: str = "compiled",
    disturbances=None,
    quantization: float = 0.0,
) -> ClosedLoopStepResult:
    """Set-point step in closed loop, run to steady state, identified by the method of moments.

    Parameters
    ----------
    plant : Plant
        The true plant.
    rng : numpy.random.Generator
        Source of the measurement noise.
    amplitude : float
        Set-point step ``r`` (non-zero).
    noise_std : float
        Measurement noise standard deviation per sample (>= 0).
    controller : Controller, optional
        A stabilizing controller (of :mod:`envs.systems.controllers`) with integral action, unless the plant
        integrates; default :func:`commissioning_pi`.
    dt : float, optional
        Sample time; default ``T/SAMPLES_PER_RESIDENCE_TIME``, reduced to the smallest dead time
        in the loop if that is shorter (the exact loop simulation needs every delay >= dt).
    excursion_limit : float, optional
        Abort when ``|y|`` exceeds it.
    max_duration : float, optional
        Cap on the experiment, default ``MAX_DURATION`` time scales.
    method : {"compiled", "reference"}
        ``"compiled"`` (default) runs the loop in compiled calls; ``"reference"`` runs the readable
        chunked run (see the module docstring), which gives the same result bit for bit, slower.
    disturbances : Disturbances, optional
        Drift and load beyond the white noise (:mod:`envs.identification.disturbances`).
    quantization : float
        The sensor's resolution (>= 0, output units; 0: none): the measured output is floored to a
        multiple of it (:func:`~envs.identification.noise.sensor_reading`, the TCLab's quantizer) in
        the record and in the steady-state tests (the readings' mean within one step more of the set
        point: a floor reads up to a step low); the commissioning controller acts on the measurement
        before the quantizer.

    Returns
    -------
    ClosedLoopStepResult

    Notes
    -----
    The levels before the step are the known steady state ``u_b = y_b = 0``; after it
    ``y_f = r`` (integral action, Ingimundarson section 2.3) and ``u_f`` is the mean of ``u`` over the
    last window.  For an integrating plant the input is replaced by its integral
    ``u_i = int u dt`` (section 2.1).  ``K``: Gorez-Klan eq. 2-4; ``T_ar``: Ingimundarson eq. 10
    (identical to appendix B's ``q_1 - g_1``); ``T_a``: appendix B; ``tau``, ``theta``, SOPDT:
    eq. 2-7 .. 2-10.

    Raises
    ------
    ValueError
        On invalid arguments, e.g. ``"amplitude must be non-zero, got 0.0"``, or an unknown ``method``.
    """
    _check_method(method)
    plant, rng = check_plant(plant), check_rng(rng)
    amplitude = require_number(amplitude, "amplitude", nonzero=True)
    noise_std = require_number(noise_std, "noise_std", nonnegative=True)
    controller = commissioning_pi(plant) if controller is None else _check_controller(plant, controller)
    scale = plant.step_time_scale()
    block = controller.block()  # built once: its delays set dt, then it closes the loop
    dt = _loop_sample_time(plant, block, dt)
    noise = measurement_noise(rng, noise_std, cap_steps(scale, dt, max_duration), disturbances, plant, dt, quantization)
    window = window_samples(scale, dt)
    run = _run_closed_loop(plant, controller, amplitude, noise, dt, window, excursion_limit, block=block, method=method)
    return _identify_closed_loop(plant, controller, amplitude, run, window, scale)


def _check_controller(plant: Plant, controller: Controller) -> Controller:
    if not hasattr(controller, "block") or not hasattr(controller, "feedback_response"):
        raise ValueError(f"controller must be an envs.systems.controllers controller, got {type(controller).__name__}")
    if controller.integrators < 1 and not plant.integrating:
        raise ValueError("controller must have integral action (e.g. PID with ti set) on a self-regulating plant")
    return controller


def _loop_sample_time(plant: Plant, block, dt: float | None) -> float:
    """The sample time, at most every positive delay of the plant and the controller's ``block()``
    (a negligible plant dead time is simulated as none: :data:`envs.systems.plants.NEGLIGIBLE_DEAD_TIME`)."""
    dt = sample_time(plant, dt)
    delays = [plant.simulation_dead_time] + [float(d) for d in block.delays]
    positive = [d for d in delays if d > 0]
    return min([dt] + positive)


def _identify_closed_loop(
    plant: Plant, controller: Controller, amplitude: float, run: _ClosedLoopRun, window: int, scale: float
) -> ClosedLoopStepResult:
    # run.drive: u, or for an integrating plant its integral (the sums of _cumulative_integral)
    return identify_closed_loop_step(
        record_fields(run, scale), run.drive, amplitude, controller, run.settled, window, plant.integrating
    )


def identify_closed_loop_step(
    record: dict, drive: np.ndarray, amplitude: float, controller: Controller, settled: bool, window: int, integrating: bool
) -> ClosedLoopStepResult:
    """The result of a closed-loop set-point step from its sampled record (experiment 1's arithmetic).

    Parameters
    ----------
    record : dict
        The :class:`~envs.identification.experiment_base.ExperimentResult` fields (``timepts``,
        ``control``, ``output``, ``true_output``, ``duration``, ``relative_duration``, ``aborted``)
        in deviation variables: the loop at rest at 0 before the step of the set point to
        ``amplitude`` at ``timepts[0]``, the record ending at its steady state.
    drive : ndarray
        ``u``, or for an integrating plant its integral ``u_i = int u dt`` (section 2.1).
    amplitude, controller, settled
        The set-point step, the loop's controller and whether the run settled.
    window : int
        Samples of the last window, whose mean of ``drive`` is ``u_f``.
    integrating : bool
        Whether the plant integrates.

    ``K = r/u_f`` (Gorez-Klan eq. 2-4), ``T_ar`` and ``T_a`` by :func:`closed_loop_moments`
    (Ingimundarson eq. 10, Gorez-Klan appendix B), ``tau``, ``theta`` and the models (eq. 2-7 ..
    2-10); NaN and None where the record cannot give them (aborted, shorter than a window, no drive).
    The simulated experiment (:func:`closed_loop_step`) and a sampled process
    (:mod:`envs.process.procedure`) identify with this same arithmetic.
    """
    common = dict(**record, amplitude=amplitude, controller=controller, settled=settled)
    t, y = record["timepts"], record["output"]
    final_drive = float(np.mean(drive[-window:]))
    if record["aborted"] or t.size < window or final_drive == 0.0:
        return ClosedLoopStepResult(**common, **_moment_models(float("nan"), float("nan"), float("nan"), integrating))
    moments = closed_loop_moments(t, drive, y, final_drive, amplitude)
    gain = amplitude / final_drive
    return ClosedLoopStepResult(**common, **_moment_models(gain, moments.residence_time, moments.apparent_time_constant, integrating))


def _moment_models(gain: float, residence_time: float, apparent: float, integrating: bool) -> dict:
    """The identified fields of :class:`ClosedLoopStepResult` (NaN and None where undefined)."""
    fields = dict(
        gain=gain, residence_time=residence_time, apparent_time_constant=apparent,
        normalized_dead_time=float("nan"), theta=float("nan"), fopdt=None, sopdt=None, integrating_model=None,
    )
    if not residence_time > 0:  # NaN (aborted) or a plant with lead: no model
        return fields
    tau = min(max(1.0 - apparent / residence_time, 0.0), 1.0)
    theta = theta_from_tau(tau)
    fields.update(normalized_dead_time=tau, theta=theta)
    if integrating:
        fields.update(integrating_model=IntegratingModel(gain=gain, dead_time=residence_time))
    else:
        fields.update(
            fopdt=fopdt_from_moments(gain, residence_time, apparent),
            sopdt=sopdt_from_theta(gain, residence_time, theta),  # sopdt_from_moments(gain, residence_time, tau)
        )
    return fields
