"""Disturbances beyond white noise (envs.identification.disturbances): drift and load.

Cross-checks: the white part of the noise is the v0 noise sample for sample; the load seen in the
measurement of a closed-loop step equals the loop simulated with the load at the plant input (the
superposition the module relies on); the drift's increments have the stated spread.
"""

import math

import numpy as np
import pytest

from envs.identification.closed_loop_experiment import closed_loop_step
from envs.identification.disturbances import Disturbances, DisturbedNoise
from envs.identification.experiment_base import measurement_noise, sample_time
from envs.identification.open_loop_step import open_loop_step
from envs.simulation.open_loop import open_loop_response
from envs.simulation.loops import closed_loop_response
from envs.systems.plants import Plant

PLANT = Plant.from_time_constants(2.0, (5.0, 1.0), 2.0)


def _noise(disturbances: Disturbances | None, steps: int = 4000, seed: int = 0, noise_std: float = 0.01):
    rng = np.random.default_rng(seed)
    dt = sample_time(PLANT, None)
    return measurement_noise(rng, noise_std, steps, disturbances, PLANT, dt), rng, dt


@pytest.mark.parametrize("disturbances", [Disturbances(drift=0.05), Disturbances(load=0.2), Disturbances(0.05, 0.2)])
def test_white_part_and_generator_are_unchanged(disturbances):
    plain, rng_plain, _ = _noise(None)
    disturbed, rng_disturbed, _ = _noise(disturbances)
    assert isinstance(disturbed, DisturbedNoise) and disturbed.drawn_as_needed
    # drawn in parts or at once, the same samples
    parts = np.concatenate([disturbed.first(1000)[:1000].copy(), disturbed.first(4000)[1000:]])
    assert np.array_equal(parts, disturbed.first(4000))
    assert np.array_equal(disturbed.white.first(4000), plain.first(4000))
    assert rng_plain.integers(1 << 30) == rng_disturbed.integers(1 << 30)


def test_no_disturbance_is_the_plain_noise():
    plain, _, _ = _noise(None)
    for inactive in (Disturbances(), Disturbances(drift=0.0, load=0.0)):
        noise, _, _ = _noise(inactive)
        assert type(noise) is type(plain) and np.array_equal(noise.first(500), plain.first(500))


def test_drift_is_a_random_walk_of_the_stated_spread():
    """Increments of ``level sqrt(dt/T)``: their sample standard deviation over 30,000 samples has a
    relative standard error of 1/sqrt(2 n) = 0.4%; 5 of them is the tolerance."""
    level, steps = 0.05, 30_000
    noise, _, dt = _noise(Disturbances(drift=level), steps=steps, noise_std=0.0)
    walk = noise.first(steps)
    step = np.diff(np.r_[0.0, walk])
    assert np.std(step) == pytest.approx(level * math.sqrt(dt / PLANT.step_time_scale()), rel=5 / math.sqrt(2 * steps))
    assert abs(np.mean(step)) < 5 * np.std(step) / math.sqrt(steps)


def test_load_is_the_plants_response_to_an_input_step():
    level, steps = 0.2, 6000
    noise, _, dt = _noise(Disturbances(load=level), steps=steps, noise_std=0.0)
    start, height = noise.load_start, noise.load_input
    assert 0 <= start * dt < 4.0 * PLANT.step_time_scale()
    inputs = np.where(np.arange(steps) >= start, height, 0.0)
    expected = open_loop_response(PLANT.state_space(), PLANT.dead_time, inputs, dt)
    assert np.array_equal(noise.first(steps), expected)
    assert abs(expected[-1]) == pytest.approx(level, rel=1e-6)  # the steady output change is the level


def _load_error(dt: float) -> float:
    """Largest difference between the closed-loop step with a load (0.3) in the measurement and the loop
    simulated with the load at the plant input (``closed_loop_response``), noise free."""
    disturbances = Disturbances(load=0.3)
    result = closed_loop_step(PLANT, np.random.default_rng(4), 1.0, 0.0, disturbances=disturbances, dt=dt)
    replay = measurement_noise(np.random.default_rng(4), 0.0, 10**6, disturbances, PLANT, dt)  # the same draws
    steps = result.timepts.size
    load = np.where(np.arange(steps) >= replay.load_start, replay.load_input, 0.0)
    reference = closed_loop_response(PLANT, result.controller, steps, dt, setpoint=1.0, load=load)
    return float(np.max(np.abs(result.output - reference.output)))


def test_closed_loop_load_equals_the_loop_with_the_load_at_the_plant_input():
    """Superposition: a load at the plant input moves the output by ``G l``, which the closed-loop step
    adds to its measurement.  The measurement is held over each sample (as the noise is), so the
    controller sees a staircase of the continuous ``G l``: an error of first order in ``dt``
    (measured 3.4e-4 of the unit step at ``dt = T/200`` for a load of 0.3, halving with ``dt``)."""
    dt = sample_time(PLANT, None)
    coarse, fine = _load_error(dt), _load_error(dt / 2)
    assert coarse < 5e-4
    assert fine / coarse == pytest.approx(0.5, abs=0.05)


def test_load_biases_the_identified_gain():
    """Why the load matters: the closed-loop step's gain ``r/u_f`` reads the input that also cancels
    the load, ``u_f = r/K - l``."""
    clean = closed_loop_step(PLANT, np.random.default_rng(1), 1.0, 0.0)
    loaded = closed_loop_step(PLANT, np.random.default_rng(1), 1.0, 0.0, disturbances=Disturbances(load=0.2))
    assert clean.gain == pytest.approx(PLANT.gain, rel=1e-4)
    assert abs(loaded.gain / PLANT.gain - 1) == pytest.approx(0.2 / 0.8 if loaded.gain > PLANT.gain else 0.2 / 1.2, rel=0.02)


def test_drift_keeps_an_open_loop_step_from_settling_early():
    clean = open_loop_step(PLANT, np.random.default_rng(2), 0.5, PLANT.residence_time, PLANT.gain, noise_std=0.01)
    drifting = open_loop_step(PLANT, np.random.default_rng(2), 0.5, PLANT.residence_time, PLANT.gain, noise_std=0.01,
                              disturbances=Disturbances(drift=0.02))
    assert drifting.duration > clean.duration


@pytest.mark.parametrize(
    "value, message",
    [
        ({"wind": 0.1}, "disturbances: unknown kind 'wind'; valid kinds: drift, load"),
        ({"drift": -0.1}, r"disturbances\['drift'\] must be >= 0"),
        ({"load": "big"}, r"disturbances\['load'\] must be a number"),
        ([0.1], "disturbances must be a mapping"),
    ],
)
def test_bad_values_name_the_argument(value, message):
    with pytest.raises(ValueError, match=message):
        Disturbances.from_argument(value)


def test_a_spoiled_closed_loop_step_is_repeated_and_charged():
    """With ``attempts``, ``identify`` repeats a closed-loop step that identified no model (here a drift
    of 0.02 keeps it from settling to the cap and leaves a negative ``T_ar``) and charges every run."""
    from envs.identification.procedure import experiment_deviation, identify
    from envs.systems.plant_sets import plant_set

    plant, disturbances = plant_set("stable", "validation", 2)[1], Disturbances(drift=0.02)
    with pytest.raises(ValueError, match="identified no usable model"):
        identify(plant, np.random.default_rng(1), 0.01, disturbances=disturbances)
    spoiled = closed_loop_step(plant, np.random.default_rng(1), 1.0, 0.01, disturbances=disturbances)
    found = identify(plant, np.random.default_rng(1), 0.01, disturbances=disturbances, attempts=3, deviation=True)
    runs = (spoiled, found.closed_loop, found.open_loop)
    assert found.experiment_time == pytest.approx(sum(r.duration for r in runs), rel=1e-12)
    assert found.experiment_deviation == pytest.approx(sum(experiment_deviation(r) for r in runs), rel=1e-12)
