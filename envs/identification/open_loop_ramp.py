"""Experiment 3: the open-loop ramp on the true plant, ``T_n`` by Ingimundarson eq. 12.

It takes ``K_n`` and ``T_ar`` identified by experiment 1
(:func:`~envs.identification.closed_loop_experiment.closed_loop_step`).

References
----------
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000, section 2.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envs.identification.experiment_base import (
    ExperimentResult,
    fixed_length_steps,
    check_rng,
    excursion_index,
    measurement_noise,
    record_fields,
    ExperimentRun,
    sample_time,
)
from envs.identification.models import FOPDTModel
from envs.identification.open_loop_areas import fopdt_from_area, ramp_time_constant
from envs.identification.open_loop_run import _self_regulating
from envs.identification.sampled_signals import integrate
from envs.identification.noise import sensor_reading
from envs.systems.plants import Plant
from envs.systems.state_space import StateSpace
from envs.simulation.open_loop import open_loop_response
from envs.validation import require_number

__all__ = ["OpenLoopRampResult", "open_loop_ramp"]


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
    quantization: float = 0.0,
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
    noise_std, dt, excursion_limit, disturbances, quantization
        As in :func:`~envs.identification.closed_loop_experiment.closed_loop_step`.
    """
    plant, rng = _self_regulating(plant, "open_loop_ramp"), check_rng(rng)
    rate = require_number(rate, "rate", nonzero=True)
    residence_time = require_number(residence_time, "residence_time", positive=True)
    gain = require_number(gain, "gain", nonzero=True)
    noise_std = require_number(noise_std, "noise_std", nonnegative=True)
    dt, scale = sample_time(plant, dt), plant.step_time_scale()
    steps, cut = fixed_length_steps(residence_time / dt - 1e-9)
    sensor = measurement_noise(rng, noise_std, steps, disturbances, plant, dt, quantization)
    noise = sensor.first(steps)  # the ramp runs to its end
    y = open_loop_response(_with_input_integrator(plant.state_space()), plant.dead_time, np.full(steps, rate), dt)
    t = np.arange(steps) * dt
    abort = excursion_index(y, excursion_limit)
    if abort is None and cut:
        abort = steps - 1
    run = ExperimentRun(t, rate * t, sensor_reading(y + noise, sensor.quantization), y, steps - 1 if abort is None else abort, abort is None, abort is not None)
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
