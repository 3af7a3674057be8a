"""Fast paths of an environment's reset against the numpy/scipy code they replace, bit for bit.

* :func:`envs.identification.sampled_signals._trapezoid`, ``_trapezoid_of_distance`` and ``_moments`` (compiled
  terms, numpy's sum) against ``numpy.trapezoid``;
* :func:`envs.identification.sampled_signals._signals` (compiled checks) against its numpy checks and errors;
* :func:`envs.identification.commissioning._pi_loop_on_grid` (compiled) against
  :meth:`envs.systems.plants.Plant.frequency_response` (to rounding), the PI it chooses against the numpy
  path's, and ``_first_violation_fast`` against ``_first_violation``;
* :func:`envs.systems.state_space._balanced` against ``scipy.linalg.matrix_balance``, :func:`envs.systems.coefficients._roots`
  against ``numpy.roots``, and :func:`envs.systems.coefficients.shape_residence_time` against a built plant.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from envs.identification import commissioning
from envs.identification import sampled_signals as identification
from envs.systems.families import sample_plants
from envs.systems.plants import Plant
from envs.systems.coefficients import _roots, shape_residence_time
from envs.systems.state_space import _balanced


def _bits(value) -> bytes:
    return np.ascontiguousarray(np.asarray(value)).tobytes()


SIZES = [*range(2, 140), 255, 256, 257, 1000, 1031, 4096, 12345, 70001]


@pytest.mark.parametrize("size", SIZES)
def test_compiled_trapezoids_equal_numpy(size):
    rng = np.random.default_rng(size)
    t = np.cumsum(rng.uniform(0.01, 1.0, size))
    y = rng.normal(size=size) * np.exp(rng.uniform(-8, 8, size))
    z = rng.normal(size=size)
    assert _bits(identification._trapezoid(y, t)) == _bits(float(np.trapezoid(y, t)))
    assert _bits(identification._trapezoid_of_distance(y, z, t)) == _bits(float(np.trapezoid(np.abs(y - z), t)))
    complement = 1.0 - (y - 0.25) / (1.5 - 0.25)
    expected = (float(np.trapezoid(complement, t)), float(np.trapezoid((t - t[0]) * complement, t)))
    assert _bits(identification._moments(t, y, 0.25, 1.5)) == _bits(expected)


def test_trapezoid_of_an_empty_interval_is_zero_as_in_numpy():
    t, y = np.array([1.0]), np.array([2.0])
    assert identification._trapezoid(y, t) == float(np.trapezoid(y, t)) == 0.0


def test_fast_signal_checks_keep_the_values_and_the_errors():
    t = np.linspace(0.0, 1.0, 50)
    columns = np.stack([np.sin(t), np.cos(t)], axis=1)  # non-contiguous columns, as the experiments' signals
    out = identification._signals(t, a=columns[:, 0], b=columns[:, 1])
    assert all(v.flags.c_contiguous for v in out)
    assert [_bits(v) for v in out] == [_bits(t), _bits(columns[:, 0]), _bits(columns[:, 1])]
    bad_t = t.copy()
    bad_t[10] = bad_t[9]
    with pytest.raises(ValueError, match="timepts must be finite and strictly increasing"):
        identification._signals(bad_t, a=columns[:, 0])
    bad_t[10] = np.inf
    with pytest.raises(ValueError, match="timepts must be finite and strictly increasing"):
        identification._signals(bad_t, a=columns[:, 0])
    bad = columns[:, 1].copy()
    bad[3] = np.nan
    with pytest.raises(ValueError, match="b must be finite"):
        identification._signals(t, a=columns[:, 0], b=bad)
    with pytest.raises(ValueError, match="a must have one value per time point"):
        identification._signals(t, a=columns[:-1, 0])


@pytest.mark.parametrize("family", ["stable", "integrating", "benchmark", "lag-chain"])
def test_commissioning_loop_on_the_grid_equals_the_frequency_response(family):
    for plant in sample_plants(family, 40, 11):
        omega = commissioning._sensitivity_grid(plant)
        for sign, reset_rate in ((np.float64(1.0), 0.37 / plant.step_time_scale()), (np.float64(-1.0), 0.0)):
            expected = sign * plant.frequency_response(omega) * (1.0 + reset_rate / (1j * omega))
            got = commissioning._pi_loop_on_grid(plant, omega, sign, reset_rate)
            np.testing.assert_allclose(got, expected, rtol=1e-12, atol=0)


def test_pi_loop_with_a_long_delay_equals_numpy():
    plant = Plant((2.0,), (1.0, 3.0, 1.0), 1e4)  # cos and sin of large arguments
    omega = commissioning._sensitivity_grid(plant)
    expected = np.float64(-1.0) * plant.frequency_response(omega) * (1.0 + 0.5 / (1j * omega))
    got = commissioning._pi_loop_on_grid(plant, omega, np.float64(-1.0), 0.5)
    np.testing.assert_allclose(got, expected, rtol=1e-12, atol=0)


@pytest.mark.parametrize("family", ["stable", "integrating", "benchmark", "lag-chain"])
def test_commissioning_pi_equals_the_numpy_path(family, monkeypatch):
    """The compiled grid and decision choose the same PI as the numpy expression and the reference decision."""
    plants = sample_plants(family, 60, 17)
    fast = [commissioning.commissioning_pi(p).to_dict() for p in plants]

    def numpy_loop(plant, omega, sign, reset_rate):
        return sign * plant.frequency_response(omega) * (1.0 + reset_rate / (1j * omega))

    monkeypatch.setattr(commissioning, "_pi_loop_on_grid", numpy_loop)
    monkeypatch.setattr(commissioning, "_first_violation_fast", commissioning._first_violation)
    assert [commissioning.commissioning_pi(p).to_dict() for p in plants] == fast


@pytest.mark.parametrize("family", ["stable", "integrating", "benchmark", "lag-chain"])
def test_fast_first_violation_equals_the_reference(family):
    for plant in sample_plants(family, 40, 13):
        omega = commissioning._sensitivity_grid(plant)
        rule = commissioning._integrating_rule if plant.integrating else commissioning._lambda_rule
        kp, reset_rate = rule(plant, commissioning._DETUNING)
        loop = commissioning._pi_loop_on_grid(plant, omega, np.sign(kp[-1]), reset_rate)
        for target in (1.05, 1.2, 1.4, 2.0):
            for scale in (0.1, 1.0, 30.0):
                gains = np.abs(kp) * scale
                assert commissioning._first_violation_fast(loop, gains, target) == commissioning._first_violation(
                    loop, gains, target
                )
    loop[5] = complex(-np.inf, 1.0)  # non-finite: left to the reference
    with np.errstate(invalid="ignore"):
        assert commissioning._first_violation_fast(loop, gains, 1.4) == commissioning._first_violation(loop, gains, 1.4)


@pytest.mark.parametrize("family", ["stable", "integrating", "benchmark"])
def test_balanced_equals_scipy_matrix_balance(family):
    for plant in sample_plants(family, 40, 5):
        num, den = np.asarray(plant.num), np.asarray(plant.den)
        A = np.zeros((den.size - 1, den.size - 1))
        A[0] = -den[1:] * np.exp(np.arange(1, den.size) * 3.0)  # badly scaled, so that balancing acts
        A[1:, :-1] += np.eye(den.size - 2) if den.size > 2 else 0.0
        B, scaling = _balanced(A)
        expected, (factors, _) = scipy.linalg.matrix_balance(A, permute=False, separate=True)
        assert _bits(B) == _bits(expected) and _bits(scaling) == _bits(factors)
        assert B.flags.f_contiguous == expected.flags.f_contiguous
    with pytest.raises(ValueError, match="must not contain infs or NaNs"):
        _balanced(np.array([[np.inf]]))


def test_roots_equal_numpy_roots():
    rng = np.random.default_rng(4)
    for size in range(2, 12):
        for _ in range(20):
            coefficients = rng.uniform(0.1, 10.0, size)
            assert _bits(np.sort_complex(_roots(coefficients))) == _bits(np.sort_complex(np.roots(coefficients)))


@pytest.mark.parametrize("family", ["stable", "lag-chain", "integrating"])
def test_shape_residence_time_equals_the_plants(family):
    for plant in sample_plants(family, 60, 2):
        num, den = plant.rational_part
        scaled = tuple(3.0 * v for v in num), tuple(3.0 * v for v in den)  # not monic, as a shape may be
        assert _bits(shape_residence_time(*scaled)) == _bits(Plant(*scaled, 0.0).residence_time)


@pytest.mark.parametrize("family", ["stable", "lag-chain", "integrating", "benchmark"])
def test_compiled_controllable_form_equals_the_numpy_one(family):
    from envs.systems.state_space import _controllable_form, _scaled_controllable_form

    for plant in sample_plants(family, 60, 8):
        scale = plant.step_time_scale()
        powers = np.arange(plant.order, -1, -1)
        num = np.asarray(plant.num) * scale ** -powers[len(powers) - len(plant.num) :]
        den = np.asarray(plant.den) * scale**-powers
        A, B, C, D = _controllable_form(num, den)
        expected = (A / scale, B / scale, C, D)
        got = _scaled_controllable_form(num, den, scale)
        assert [(x.shape, _bits(x)) for x in got] == [(x.shape, _bits(x)) for x in expected]


def test_pulse_distance_equals_the_numpy_expression():
    from envs.identification.models import IntegratingModel
    from envs.identification.open_loop_areas import _pulse_distance

    rng = np.random.default_rng(6)
    for size in (2, 3, 50, 129, 1000, 5003):
        t = np.arange(size) * 0.37
        for gain, dead_time, height, duration in ((1.5, 3.0, 0.7, 1.1), (-0.2, 0.0, -2.0, 0.37), (3.0, 0.37 * 7, 1.0, 0.37 * 2)):
            model = IntegratingModel(gain=gain, dead_time=dead_time)
            clean = height * (model.step_response(t) - model.step_response(t - duration))
            for y in (clean, clean + rng.normal(size=size) * 0.01):
                expected = float(np.trapezoid(np.abs(y - clean), t))
                assert _bits(_pulse_distance(t, y, gain, dead_time, height, duration)) == _bits(expected)


@pytest.mark.parametrize("family", ["stable", "integrating", "lag-chain"])
def test_relay_with_compiled_plain_samples_equals_the_sample_by_sample_run(family, monkeypatch):
    from envs.identification import relay

    def run_all():
        results = []
        for i, plant in enumerate(sample_plants(family, 12, 17)):
            for noise, hysteresis, limit in ((0.0, 0.0, None), (0.01, 0.03, 5.0), (0.05, 0.0, 0.5)):
                rng = np.random.default_rng(i)
                r = relay.relay_feedback(plant, rng, 1.0 / abs(plant.gain), hysteresis=hysteresis, noise_std=noise, excursion_limit=limit)
                results.append([_bits(getattr(r, f)) for f in ("timepts", "control", "output", "true_output", "switching_times")]
                               + [r.converged, r.aborted, _bits(r.ultimate_period), _bits(r.harmonic_amplitude), _bits(r.duration)])
        return results

    fast = run_all()
    monkeypatch.setattr(relay._RelaySimulation, "plain_steps", lambda self, noise, first, stop, limit: (first, False))
    assert run_all() == fast  # every sample by _RelaySimulation.step, as before the compiled path
