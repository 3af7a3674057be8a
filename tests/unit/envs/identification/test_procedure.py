"""The papers' fixed identification procedure (envs/identification/procedure.py) on the benchmark plants.

* Noise-free, experiment 1 recovers the exact ``K`` (``K_v``) and ``T_ar`` (``L_n``) of the plant:
  measured errors are below ``1e-4`` (the residue of the steady-state detection and the sampled
  integrals), the tolerance is ``1e-3``.
* The pulse area ``A`` (eq. 46) of the integrating plants agrees with an independent computation:
  the exact pulse response of the true plant minus that of the exact two-parameter model
  ``K_v e^{-L_n s}/s``, integrated on a fine grid with scipy's ``lsim``.
* A fixed seed gives the same identification, noise included.
"""

import numpy as np
import pytest
import scipy.signal

from envs.systems.benchmark_batches import benchmark_plants
from envs.identification.procedure import PULSE_LENGTH, identify

PLANTS = benchmark_plants()
INTEGRATING = [name for name, plant in PLANTS.items() if plant.integrating]


@pytest.fixture(scope="module")
def noise_free():
    return {name: identify(plant, np.random.default_rng(0)) for name, plant in PLANTS.items()}


@pytest.mark.parametrize("name", list(PLANTS))
def test_noise_free_identification_recovers_gain_and_residence_time(noise_free, name):
    plant, result = PLANTS[name], noise_free[name]
    assert result.integrating == plant.integrating
    assert result.gain == pytest.approx(plant.gain, rel=1e-3)
    assert result.residence_time == pytest.approx(plant.residence_time, rel=1e-3)
    assert result.experiment_time > 0
    if plant.integrating:
        assert result.fopdt is None and result.sopdt is None and np.isnan(result.mismatch_time)
        assert result.integrating_model.dead_time == pytest.approx(plant.residence_time, rel=1e-3)
    else:
        assert result.integrating_model is None and np.isnan(result.pulse_area)
        assert result.fopdt.residence_time == pytest.approx(result.residence_time, rel=1e-12)
        assert result.sopdt.residence_time == pytest.approx(result.residence_time, rel=1e-9)
        assert result.mismatch_time >= 0


def _reference_pulse_area(plant, height: float, duration: float) -> float:
    """``int |y - y_n| dt/(h tau_p)`` from the exact responses (lsim on a fine grid)."""
    gain, dead_time = plant.gain, plant.residence_time
    horizon = 12.0 * (dead_time + duration)
    t = np.linspace(0.0, horizon, 240001)
    u = np.where(t < duration, height, 0.0)
    _, y, _ = scipy.signal.lsim((plant.num, plant.den), u, t)
    y = np.interp(t - plant.dead_time, t, y, left=0.0)
    ramp = lambda s: gain * np.maximum(s - dead_time, 0.0)  # noqa: E731 - unit-step response of the model
    model = height * (ramp(t) - ramp(t - duration))
    return float(np.trapezoid(np.abs(y - model), t)) / (height * duration)


@pytest.mark.parametrize("name", INTEGRATING)
def test_pulse_area_of_integrating_plants(noise_free, name):
    plant, result = PLANTS[name], noise_free[name]
    pulse = result.open_loop
    assert pulse.pulse_duration == pytest.approx(PULSE_LENGTH * result.integrating_model.dead_time, rel=1e-12)
    assert pulse.height == pytest.approx(1.0 / (result.gain * pulse.pulse_duration), rel=1e-12)  # a unit output rise
    reference = _reference_pulse_area(plant, pulse.height, pulse.pulse_duration)
    assert result.pulse_area == pytest.approx(reference, rel=0.02, abs=2e-3)


def test_pulse_area_vanishes_for_a_plant_equal_to_its_model():
    from envs.systems.plants import Plant

    plant = Plant.from_time_constants(0.5, [], 4.0, integrating=True)
    result = identify(plant, np.random.default_rng(0))
    assert result.pulse_area == pytest.approx(0.0, abs=1e-3)


@pytest.mark.parametrize("name", ["ingimundarson-stable-P3", "ingimundarson-integrating-P2"])
def test_identification_with_noise_is_deterministic_for_a_seed(name):
    plant = PLANTS[name]
    first, again = (identify(plant, np.random.default_rng(7), noise_std=0.02) for _ in range(2))
    other = identify(plant, np.random.default_rng(8), noise_std=0.02)
    fields = ("gain", "residence_time", "experiment_time", "mismatch_time", "pulse_area")
    for field in fields:
        np.testing.assert_equal(getattr(first, field), getattr(again, field), err_msg=field)
    assert (first.fopdt, first.sopdt, first.integrating_model) == (again.fopdt, again.sopdt, again.integrating_model)
    np.testing.assert_array_equal(first.closed_loop.output, again.closed_loop.output)
    assert other.gain != first.gain
