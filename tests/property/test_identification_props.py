"""Invariants of identification: the method of moments recovers a known FOPDT, results scale
with time and gain, and the Gorez-Klan relations (eq. 2-8 .. 2-10) hold everywhere."""

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from envs.identification.experiments import closed_loop_step, open_loop_step
from envs.identification.moments import sopdt_from_moments, theta_from_tau
from envs.systems.plants import Plant

taus = st.floats(min_value=0.0, max_value=1.0)
normalized_dead_times = st.floats(min_value=0.05, max_value=0.95)
magnitudes = st.floats(min_value=0.1, max_value=10.0)
scales = st.floats(min_value=0.1, max_value=100.0)
signs = st.sampled_from([-1.0, 1.0])
FAST = settings(max_examples=8, deadline=None)


@given(taus, taus)
def test_theta_solves_eq_2_9_and_is_monotone(tau, other):
    theta = theta_from_tau(tau)
    assert abs((1 - theta) * math.sqrt(1 + theta * theta) - (1 - tau)) <= 4e-16
    if tau <= other:
        assert theta <= theta_from_tau(other)


@given(magnitudes, scales, taus)
def test_sopdt_keeps_the_two_moments(gain, residence_time, tau):
    model = sopdt_from_moments(gain, residence_time, tau)
    t1, t2 = model.time_constants
    assert model.residence_time == pytest.approx(residence_time, rel=1e-12)
    assert t1 * t1 + t2 * t2 == pytest.approx((residence_time * (1 - tau)) ** 2, rel=1e-9, abs=1e-12 * residence_time**2)


@FAST
@given(magnitudes, signs, scales, normalized_dead_times)
def test_experiments_recover_a_known_fopdt(magnitude, sign, residence_time, tau):
    gain, time_constant, dead_time = sign * magnitude, (1 - tau) * residence_time, tau * residence_time
    plant = Plant.from_time_constants(gain, [time_constant], dead_time)
    closed = closed_loop_step(plant, np.random.default_rng(0), amplitude=sign)
    assert closed.gain == pytest.approx(gain, rel=1e-4)
    assert closed.residence_time == pytest.approx(residence_time, rel=1e-4)
    assert closed.normalized_dead_time == pytest.approx(tau, abs=0.01)
    step = open_loop_step(plant, np.random.default_rng(0), 1.0, closed.residence_time, closed.gain)
    assert step.time_constant == pytest.approx(time_constant, abs=1e-3 * residence_time)
    assert step.dead_time == pytest.approx(dead_time, abs=1e-3 * residence_time)
    assert step.mismatch_time < 1e-3 * residence_time
    # The output lags the input by exactly the dead time.
    t = step.timepts
    assert np.all(step.true_output[t <= dead_time] == 0.0)
    assert np.all(step.true_output[t > dead_time + 1e-9 * residence_time] != 0.0)


@FAST
@given(scales, magnitudes, signs)
def test_identification_is_time_scale_and_gain_invariant(time_scale, magnitude, sign):
    base = Plant.from_time_constants(1.0, [2.0, 1.0], 1.5)
    scaled = Plant.from_time_constants(sign * magnitude, [2.0 * time_scale, time_scale], 1.5 * time_scale)
    reference = closed_loop_step(base, np.random.default_rng(1), noise_std=0.01)
    result = closed_loop_step(scaled, np.random.default_rng(1), noise_std=0.01)
    # Same measured output samples, input scaled by 1/K: everything dimensionless agrees.
    assert result.relative_duration == pytest.approx(reference.relative_duration, rel=1e-9)
    assert result.residence_time / time_scale == pytest.approx(reference.residence_time, rel=1e-6)
    assert result.gain / (sign * magnitude) == pytest.approx(reference.gain, rel=1e-6)
    assert result.normalized_dead_time == pytest.approx(reference.normalized_dead_time, rel=1e-6, abs=1e-9)
