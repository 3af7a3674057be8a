"""Shared machinery of the identification experiments: validation, sampling, noise, runs, results.

Private helpers used by :mod:`envs.identification.closed_loop_experiment`, the open-loop
experiments (:mod:`envs.identification.open_loop_step`, ``open_loop_ramp``, ``open_loop_pulse``),
:mod:`envs.identification.relay` and :mod:`envs.identification.commissioning`; the public names are the sampling constants and
:class:`ExperimentResult`, the base of every experiment's result.

Conventions (see :mod:`envs.identification.experiments` for the full list)
------------------------------------------------------------
* The default ``dt`` is ``T/SAMPLES_PER_RESIDENCE_TIME`` with ``T = plant.step_time_scale()``
  (``T_ar`` of the true plant when positive), so the noise bandwidth is fixed relative to the plant.
* Measurement noise is white and Gaussian, ``noise_std`` per sample (:class:`envs.identification.noise.MeasurementNoise`).
  Each experiment draws its noise from a child stream of its own: :func:`measurement_noise` seeds
  a new generator with 128 bits drawn from the episode's ``rng`` (always exactly these, whatever
  the noise level, duration or outcome of the experiment), and the child's standard normals are
  drawn only for the samples actually simulated, as the run grows.  So a seed gives the same noise
  whatever the noise level; the noise of an experiment does not depend on how long the earlier
  ones ran; and an experiment that settles after ``n`` samples draws about ``n`` normals (to the
  end of the block it drew them in), not the ``n_max`` of the longest run allowed (drawing those
  up front was the largest single cost of an environment's reset).  Drawn in parts or at once, a
  stream gives the same normals, so the noise of a sample does not depend on how the run was split
  into horizons, chunks or blocks either.
  The child is seeded from the parent's stream rather than by ``Generator.spawn``: spawned
  children depend on the ``SeedSequence``'s count of children, which is not part of the
  generator's state (a copied, pickled or restored generator would give other noise), while a
  drawn seed makes the noise a function of the generator's state alone.
* A run to steady state ends at its first event, judged causally (each sample on the samples up
  to it only): the first sample that settles, or whose true output leaves
  ``[-excursion_limit, excursion_limit]``, or, in closed loop, at which the loop diverges (a
  component of the next state reaches ``DIVERGENCE_LIMIT`` times the largest input so far; the
  outputs up to that sample are finite); else the cap.  The open-loop runs reach it over growing
  horizons (doubling) in chunks (:func:`run_until_settled`), the closed-loop step sample by sample
  in compiled calls (:func:`envs.identification.closed_loop_run._run_closed_loop`); either way the sample
  and the signals up to it are those of simulating and testing the whole run.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from envs.identification.noise import MeasurementNoise
from envs.systems.plants import Plant
from envs.simulation.delay_systems import MAX_RUN_SAMPLES
from envs.validation import require_number

__all__ = ["SAMPLES_PER_RESIDENCE_TIME", "MAX_DURATION", "ExperimentResult", "MeasurementNoise"]

SAMPLES_PER_RESIDENCE_TIME = 200
"""Default samples per time scale ``T`` (``T_ar``); fine enough for ``K``, ``T_ar`` to 1e-3."""
MAX_DURATION = 150.0
"""Default cap of an experiment, in time scales ``T``."""


# --------------------------------------------------------------------------- validation and sampling
def check_plant(plant: Plant) -> Plant:
    if not isinstance(plant, Plant):
        raise ValueError(f"plant must be an envs.systems.plants.Plant, got {type(plant).__name__}")
    return plant


def check_rng(rng: np.random.Generator) -> np.random.Generator:
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng must be a numpy.random.Generator, got {type(rng).__name__}")
    return rng


def sample_time(plant: Plant, dt: float | None) -> float:
    if dt is None:
        return plant.step_time_scale() / SAMPLES_PER_RESIDENCE_TIME
    return require_number(dt, "dt", positive=True)


def measurement_noise(
    rng: np.random.Generator, noise_std: float, steps: int, disturbances=None, plant: Plant | None = None,
    dt: float | None = None, quantization: float = 0.0,
) -> MeasurementNoise:  # fmt: skip
    """The noise of one experiment of at most ``steps`` samples, from a child stream seeded by ``rng``.

    Draws the child's seed (four 32-bit integers) from ``rng``, and nothing else, whatever
    ``noise_std`` and however long the experiment runs (see the module docstring).  With active
    ``disturbances`` (:class:`envs.identification.disturbances.Disturbances`; they need the ``plant``
    and ``dt``), the noise is white plus the disturbances, drawn from streams spawned from the same
    seed (:class:`envs.identification.disturbances.DisturbedNoise`): the white part is unchanged.
    ``quantization`` (the sensor's resolution, >= 0) is carried to the experiment, which reads its
    measurements through :func:`~envs.identification.noise.sensor_reading`; it draws nothing.
    """
    seed = rng.integers(0, 2**32, size=4, dtype=np.uint64)
    white = MeasurementNoise(noise_std, steps, np.random.Generator(np.random.PCG64(seed)))
    if disturbances is None or not disturbances.active:
        noise = white
    else:
        from envs.identification.disturbances import DisturbedNoise

        noise = DisturbedNoise(white, seed, disturbances, plant, dt, plant.step_time_scale())
    if quantization:
        noise.quantization = require_number(quantization, "quantization", nonnegative=True)
    return noise


def as_noise(noise: MeasurementNoise | np.ndarray) -> MeasurementNoise:
    """``noise``, or the noise with the given samples."""
    return noise if isinstance(noise, MeasurementNoise) else MeasurementNoise.given(noise)


def excursion_index(true_output: np.ndarray, limit: float | None) -> int | None:
    """Index of the first sample whose true output leaves ``[-limit, limit]``."""
    if limit is None:
        return None
    outside = np.flatnonzero(~(np.abs(true_output) <= limit))
    return int(outside[0]) if outside.size else None


def snap_to_integer(ratio: float) -> float:
    """``ratio`` snapped to the nearest integer when within rounding of it.

    Counts of samples (``ceil`` of a duration over ``dt``) are then the same in every unit of time:
    ``MAX_DURATION T/dt`` is an integer on paper and ``4000.0000000000005`` in some units.  A count
    that differs by one draws one more noise sample and shifts the noise of every later experiment.
    """
    nearest = round(ratio)
    return float(nearest) if abs(ratio - nearest) <= 1e-9 * max(1.0, abs(ratio)) else ratio


def cap_steps(scale: float, dt: float, max_duration: float | None, minimum: float = 0.0) -> int:
    """Samples of the longest run allowed: ``max_duration`` time scales, at most
    :data:`~envs.simulation.delay_systems.MAX_RUN_SAMPLES` (a run that reaches it stops unconverged)."""
    cap = MAX_DURATION if max_duration is None else require_number(max_duration, "max_duration", positive=True)
    wanted = snap_to_integer(max(cap * scale, minimum) / dt)
    return max(int(math.ceil(wanted)) + 1, 4) if wanted < MAX_RUN_SAMPLES else MAX_RUN_SAMPLES


def fixed_length_steps(intervals: float) -> tuple[int, bool]:
    """``(samples, cut)`` of a run of a fixed length of ``intervals`` sample intervals (an open-loop ramp,
    a PRBS: a length set by the identified ``T_ar``): ``ceil(intervals) + 1`` samples, at most
    :data:`~envs.simulation.delay_systems.MAX_RUN_SAMPLES`; ``cut`` if the bound shortened the run (its
    experiment then stops there unfinished, as an aborted one: its time charged, no result)."""
    if intervals <= MAX_RUN_SAMPLES - 1:
        return int(math.ceil(intervals)) + 1, False
    return MAX_RUN_SAMPLES, True


# --------------------------------------------------------------------------- results and runs
@dataclass(frozen=True)
class ExperimentResult:
    """Signals and cost common to every experiment.

    Attributes
    ----------
    timepts : ndarray
        Sample times from the start of the experiment.
    control : ndarray
        Plant input ``u`` at ``timepts`` (held over each sample unless stated otherwise).
    output : ndarray
        Measured output ``y + n``.
    true_output : ndarray
        Noise-free output ``y``.
    duration : float
        Time spent, from the start to the last sample used (or to the abort).
    relative_duration : float
        ``duration / T`` with ``T = plant.step_time_scale()`` (``T_ar`` of the true plant).
    aborted : bool
        The true output left ``[-excursion_limit, excursion_limit]`` (or the loop diverged), or a
        run of fixed length was cut at the sample bound (:func:`fixed_length_steps`).
    """

    timepts: np.ndarray
    control: np.ndarray
    output: np.ndarray
    true_output: np.ndarray
    duration: float
    relative_duration: float
    aborted: bool


@dataclass(frozen=True)
class ExperimentRun:
    """A simulated run: the signals up to the horizon simulated, and the last sample used."""

    timepts: np.ndarray
    control: np.ndarray
    output: np.ndarray
    true_output: np.ndarray
    end: int  # last sample used
    settled: bool
    aborted: bool


def run_until_settled(
    trial: Callable[..., tuple], first_steps: int, steps_max: int, chunk: int | None = None
) -> ExperimentRun:
    """Run ``trial(steps)`` over growing horizons, from ``first_steps`` samples and doubling, until
    it settles, reaches the cap (``steps_max`` samples) or aborts.

    ``trial`` returns ``(timepts, control, measured, true_output, abort, settle)`` with ``abort``
    the first sample of an excursion (or divergence) and ``settle`` the first steady sample, each
    None if there is none; an abort at or before the steady sample wins.

    With ``chunk``, each horizon is reached ``chunk`` samples at a time by ``trial(steps, horizon)``,
    which reports on the samples up to ``steps`` of the run over ``horizon``.  A causal trial (the
    samples, the first steady sample and the first abort up to ``steps`` are those of the whole
    horizon's run) gives the same last sample and the same signals up to it, after fewer samples.
    """
    horizon = min(first_steps, steps_max)
    steps = 0
    while True:
        if chunk is None:
            steps = horizon
            t, control, measured, true_output, abort, settle = trial(steps)
        else:
            steps = min(steps + chunk, horizon)
            t, control, measured, true_output, abort, settle = trial(steps, horizon)
        if abort is not None and (settle is None or abort <= settle):
            return ExperimentRun(t, control, measured, true_output, abort, False, True)
        if settle is not None:
            return ExperimentRun(t, control, measured, true_output, settle, True, False)
        if steps == steps_max:
            return ExperimentRun(t, control, measured, true_output, steps - 1, False, False)
        if steps == horizon:
            horizon = min(2 * horizon, steps_max)


def record_fields(run: ExperimentRun, scale: float) -> dict:
    """The :class:`ExperimentResult` fields of a run, truncated at its last sample."""
    k = run.end + 1
    t = run.timepts[:k]
    return dict(
        timepts=t,
        control=run.control[:k],
        output=run.output[:k],
        true_output=run.true_output[:k],
        duration=float(t[-1]),
        relative_duration=float(t[-1] / scale),
        aborted=run.aborted,
    )
