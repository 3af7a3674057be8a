"""Experiment 4: the open-loop pulse into an integrating plant, the area ``A`` of Ingimundarson eq. 46.

It takes ``K_n`` and ``L_n`` identified by experiment 1
(:func:`~envs.identification.closed_loop_experiment.closed_loop_step`).

References
----------
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000, sections 2.1 and 5.1.
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
    sample_time,
)
from envs.identification.models import IntegratingModel
from envs.identification.moments import residence_time_from_area
from envs.identification.open_loop_areas import pulse_mismatch_area
from envs.identification.open_loop_run import _run_to_steady_state
from envs.systems.plants import Plant
from envs.identification.steady_state import window_samples
from envs.validation import require_number

__all__ = ["OpenLoopPulseResult", "open_loop_pulse"]


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
    quantization: float = 0.0,
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
    noise_std, dt, excursion_limit, max_duration, disturbances, quantization
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
    noise = measurement_noise(rng, noise_std, steps, disturbances, plant, dt, quantization)
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
