"""The sensor's quantization (the environments' ``quantization``): the TCLab's quantizer, in every
experiment's record, the compiled paths equal to their readable references, and the option's validation.

* :func:`envs.identification.noise.sensor_reading` is ``tclab.TCLabModel.quantize`` without its clip
  (``T - T % 0.3223``, a floor), in Python, numpy and the compiled kernels alike;
* without noise every experiment's measured output is exactly the floored true output;
* the closed-loop step's compiled run and the relay's compiled samples equal, bit for bit, their
  readable references with a quantizing sensor;
* ``quantization=0`` leaves every record as it was (the fingerprint of ``tests/regression`` holds
  the episodes), and a bad value is one ``ValueError`` naming the argument.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (registers the ids)
from envs.identification.closed_loop_experiment import _loop_sample_time, closed_loop_step
from envs.identification.closed_loop_run import _run_closed_loop
from envs.identification.commissioning import commissioning_pi
from envs.identification.experiment_base import MeasurementNoise
from envs.identification.noise import sensor_reading
from envs.identification.open_loop_pulse import open_loop_pulse
from envs.identification.open_loop_ramp import open_loop_ramp
from envs.identification.open_loop_step import open_loop_step
from envs.identification.prbs_experiment import open_loop_prbs
from envs.identification.relay import relay_feedback
from envs.identification.steady_state import window_samples
from envs.systems.families import sample_plants
from envs.systems.plants import Plant

TCLAB_STEP = 0.3223


def _tclab_quantize(T: float, step: float = TCLAB_STEP) -> float:
    """``tclab.TCLabModel.quantize`` without the clip to [-50, 132.2] (the package's own line)."""
    return T - T % step


def test_the_sensor_floors_as_the_tclab_does():
    rng = np.random.default_rng(3)
    values = np.concatenate([rng.normal(0.0, 3.0, 500), [0.0, -0.0, TCLAB_STEP, -TCLAB_STEP, 1e-17, -1e-17]])
    array = sensor_reading(values, TCLAB_STEP)
    for value, read in zip(values.tolist(), array.tolist()):
        assert read == _tclab_quantize(value) == sensor_reading(value, TCLAB_STEP)
        assert read <= value < read + TCLAB_STEP + 1e-15  # a floor, not a rounding
    assert sensor_reading(values, 0.0) is values


def _on_the_steps(readings: np.ndarray, q: float) -> bool:
    """Whether every reading is a whole number of steps (up to the rounding of ``k q``; flooring a
    reading again need not return it: ``3 * 0.1 - (3 * 0.1) % 0.1`` is ``0.2``)."""
    steps = readings / q
    return bool(np.all(np.abs(steps - np.rint(steps)) < 1e-9))


def _floored(result, q: float) -> bool:
    return result.output.tobytes() == sensor_reading(result.true_output, q).tobytes()


@pytest.mark.parametrize("q", [0.003, 0.05])
def test_every_record_is_the_floored_true_output_without_noise(q):
    stable = Plant(num=(1.0,), den=(2.0, 3.0, 1.0), dead_time=1.0)
    integrating = Plant(num=(1.0,), den=(2.0, 1.0, 0.0), dead_time=5.0)
    first = closed_loop_step(stable, np.random.default_rng(1), quantization=q)
    assert _floored(first, q) and np.isfinite(first.gain)
    args = (first.residence_time, first.gain)
    assert _floored(open_loop_step(stable, np.random.default_rng(1), 1.0, *args, quantization=q), q)
    assert _floored(open_loop_ramp(stable, np.random.default_rng(1), 1.0 / first.residence_time, *args, quantization=q), q)
    assert _floored(open_loop_prbs(stable, np.random.default_rng(1), 1.0, first.residence_time, quantization=q), q)
    assert _floored(relay_feedback(stable, np.random.default_rng(1), 1.0, quantization=q), q)
    step = closed_loop_step(integrating, np.random.default_rng(1), quantization=q)
    model = step.integrating_model
    assert _floored(step, q)
    pulse = open_loop_pulse(integrating, np.random.default_rng(1), 1.0, model.dead_time / 3, model.gain, model.dead_time,
                            quantization=q)  # fmt: skip
    assert _floored(pulse, q)


def test_a_noisy_record_is_the_floored_measurement():
    plant = Plant(num=(1.0,), den=(2.0, 3.0, 1.0), dead_time=1.0)
    plain = closed_loop_step(plant, np.random.default_rng(5), noise_std=0.02)
    read = closed_loop_step(plant, np.random.default_rng(5), noise_std=0.02, quantization=0.01)
    k = min(plain.output.size, read.output.size)
    assert read.true_output[:k].tobytes() == plain.true_output[:k].tobytes()  # the loop feeds back y + n
    assert read.output[:k].tobytes() == sensor_reading(plain.output[:k], 0.01).tobytes()


def _sensor(values: np.ndarray, q: float) -> MeasurementNoise:
    noise = MeasurementNoise.given(values)
    noise.quantization = q
    return noise


@pytest.mark.parametrize("family", ["stable", "integrating", "lag-chain"])
def test_the_compiled_closed_loop_run_quantizes_as_the_reference(family):
    for i, plant in enumerate(sample_plants(family, 6, 23)):
        controller = commissioning_pi(plant)
        scale = plant.step_time_scale()
        dt = _loop_sample_time(plant, controller.block(), None)
        window = window_samples(scale, dt)
        values = (0.0, 0.01, 0.05)[i % 3] * np.random.default_rng(i).standard_normal(int(np.ceil(60 * scale / dt)) + 1)
        q = (0.02, 0.004, 0.05)[i % 3]
        new = _run_closed_loop(plant, controller, 1.0, _sensor(values, q), dt, window, None)
        old = _run_closed_loop(plant, controller, 1.0, _sensor(values, q), dt, window, None, method="reference")
        assert (new.end, new.settled, new.aborted) == (old.end, old.settled, old.aborted)
        for field in ("timepts", "control", "output", "true_output", "drive"):
            assert getattr(new, field).tobytes() == getattr(old, field).tobytes(), field
        assert new.output.tobytes() == sensor_reading(new.true_output + values[: new.end + 1], q).tobytes()


@pytest.mark.parametrize("family", ["stable", "integrating", "lag-chain"])
def test_the_relay_switches_on_the_readings_compiled_as_sample_by_sample(family, monkeypatch):
    from envs.identification import relay

    def run_all():
        results = []
        for i, plant in enumerate(sample_plants(family, 6, 17)):
            for noise, hysteresis, q in ((0.0, 0.0, 0.01), (0.01, 0.03, 0.02), (0.05, 0.0, 0.003)):
                r = relay.relay_feedback(plant, np.random.default_rng(i), 1.0 / abs(plant.gain), hysteresis=hysteresis,
                                         noise_std=noise, excursion_limit=5.0, quantization=q)  # fmt: skip
                assert _on_the_steps(r.output, q)
                results.append([r.timepts.tobytes(), r.output.tobytes(), r.true_output.tobytes(),
                                r.switching_times.tobytes(), r.converged, r.aborted])  # fmt: skip
        return results

    fast = run_all()
    monkeypatch.setattr(relay._RelaySimulation, "plain_steps", lambda self, noise, first, stop, limit: (first, False))
    assert run_all() == fast


@pytest.mark.parametrize("value", [-0.1, math.nan, math.inf, "0.1", True])
def test_a_bad_quantization_is_one_clear_error(value):
    with pytest.raises(ValueError, match="quantization"):
        gym.make("DeadTime/PID-v3", quantization=value).reset(seed=0)
    with pytest.raises(ValueError, match="quantization"):
        closed_loop_step(Plant(num=(1.0,), den=(1.0, 1.0), dead_time=0.5), np.random.default_rng(0), quantization=value)


def test_the_environment_s_records_are_quantized():
    q = 0.02
    env = gym.make("DeadTime/FPPI-v3", quantization=q)  # the fixed procedure: closed-loop and open-loop steps
    env.reset(seed=4)
    evidence = env.unwrapped.episode.evidence
    assert evidence.options.quantization == q and len(evidence.results) == 2
    for result in evidence.results.values():
        assert _on_the_steps(result.output, q)


def test_the_measured_observation_reads_the_noise_through_the_quantizer():
    """Noise a quarter of the step: the plain estimate of the readings is about 0, the observation's
    is the noise (the tolerance: the measured range of the estimate at ``q/5``, 0.06 to 2.1,
    tests/unit/envs/identification/test_quantized_noise.py); the closed-loop step settles (its
    readings' mean is within a step of the set point) instead of running to its cap."""
    from envs.episode import LOG_CLIP
    from envs.identification.quantized_noise import quantized_noise_level
    from envs.identification.steady_state import noise_level

    for seed in range(3):
        env = gym.make("DeadTime/FPPI-v3", noise_std=0.005, quantization=0.02)
        observation, _ = env.reset(seed=seed)
        evidence = env.unwrapped.episode.evidence
        output = evidence.closed_loop.output
        assert evidence.noise_estimate == quantized_noise_level(output, 0.02)
        assert 0.06 * 0.005 <= evidence.noise_estimate <= 2.1 * 0.005
        assert observation[env.unwrapped.feature_names.index("log_noise_ratio")] > -LOG_CLIP
        assert evidence.closed_loop.relative_duration < 100.0 and not evidence.closed_loop.aborted
        plain = gym.make("DeadTime/FPPI-v3", noise_std=0.005)
        plain.reset(seed=seed)
        evidence = plain.unwrapped.episode.evidence
        assert evidence.noise_estimate == noise_level(evidence.closed_loop.output)
