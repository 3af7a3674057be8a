"""The open-loop runs the step and the pulse share: the plant driven by a held input until its
measured output is steady (:func:`_run_to_steady_state`), and the check that a plant is
self-regulating for the step and the ramp.

Steady state is detected with a window of the identified ``T_ar`` (``L_n``), see
:mod:`envs.identification.steady_state`.
"""

from __future__ import annotations

import numpy as np

from envs.identification.experiment_base import (
    check_plant,
    excursion_index,
    MeasurementNoise,
    as_noise,
    ExperimentRun,
    run_until_settled,
)
from envs.identification.noise import sensor_reading
from envs.systems.plants import Plant
from envs.simulation.open_loop import OpenLoopRun
from envs.identification.steady_state import SteadyStateTest

__all__: list[str] = []


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
    excursion of the true output.  ``noise`` is drawn as the run grows (or given, one sample per input);
    the measurement is read through the sensor (:func:`~envs.identification.noise.sensor_reading`)."""
    noise = as_noise(noise)
    response = OpenLoopRun(plant.state_space(), plant.dead_time, inputs, dt)
    test = SteadyStateTest(window)
    measured = np.empty(inputs.size)
    done = [0]  # each chunk continues the recursion and tests only its new samples (see run_until_settled)

    def trial(steps: int, horizon: int) -> tuple:
        y = response.response(steps)
        old = done[0]
        measured[old:steps] = sensor_reading(y[old:] + noise.first(steps)[old:], noise.quantization)
        abort = excursion_index(y[old:], excursion_limit)
        hits = np.flatnonzero(test.extend(measured[:steps])[max(start - old, 0) :])
        done[0] = steps
        settle = int(hits[0]) + max(start, old) if hits.size else None
        return np.arange(steps) * dt, inputs[:steps], measured[:steps], y, None if abort is None else abort + old, settle

    return run_until_settled(trial, max(start + 6 * window, 16), inputs.size, chunk=CHUNK_WINDOWS * window)


CHUNK_WINDOWS = 2
"""Windows simulated and tested at a time within a horizon (a run stops within a chunk of settling)."""


def _self_regulating(plant: Plant, experiment: str) -> Plant:
    plant = check_plant(plant)
    if plant.integrating:
        raise ValueError(f"plant must be self-regulating for {experiment} (use open_loop_pulse for an integrating plant)")
    return plant
