"""The emulator's conditions: the nominal one is the emulator itself, and each changes what it says."""

from __future__ import annotations

import pytest

from envs.process.procedure import identify_process
from envs.process.tclab_conditions import CONDITIONS, TCLabConditions, emulator_factory
from envs.process.tclab_process import TCLabProcess


def _identified(conditions: TCLabConditions | None):
    factory = None if conditions is None else emulator_factory(conditions)
    return identify_process(TCLabProcess(lab_factory=factory), seed=3)


def test_the_nominal_condition_is_the_emulator_bit_for_bit():
    plain, nominal = _identified(None), _identified(CONDITIONS[0])
    for name, record in plain.records.items():
        assert list(record.output) == list(nominal.records[name].output)


def test_each_condition_moves_what_it_should():
    nominal = _identified(CONDITIONS[0])
    by_name = {c.name: _identified(c) for c in CONDITIONS[1:]}
    # the operating point follows the room; the gain does not (the model is linear)
    assert by_name["cold room"].operating_point.output == pytest.approx(nominal.operating_point.output - 9.0, abs=0.5)
    assert by_name["warm room"].operating_point.output == pytest.approx(nominal.operating_point.output + 9.0, abs=0.5)
    # the gain scales with heater 1's power (the emulator's equations: P1/5720/0.0583 degC per %)
    gain = nominal.identification.closed_loop.gain
    assert by_name["heater at 75%"].identification.closed_loop.gain == pytest.approx(0.75 * gain, rel=0.03)
    assert by_name["heater at 150%"].identification.closed_loop.gain == pytest.approx(1.5 * gain, rel=0.03)
    # the noise level measured at the operating point follows the sensor: with the quantizer's step q it
    # is about sqrt(sigma^2 + q^2/12) (0.098 nominal, 0.196 with sigma = 0.172)
    assert by_name["noisy sensor"].operating_point.noise_std > 1.5 * nominal.operating_point.noise_std
    assert by_name["no quantization"].operating_point.noise_std == pytest.approx(0.043, rel=0.25)


@pytest.mark.parametrize("field, value", [("heater_power", 0.0), ("noise_std", -1.0), ("quantization", float("nan"))])
def test_a_bad_condition_is_refused_naming_it(field, value):
    with pytest.raises(ValueError, match=field):
        TCLabConditions(**{field: value})


def test_an_unmeasured_load_steps_on_at_its_time_after_each_reset():
    process = TCLabProcess(lab_factory=emulator_factory(TCLabConditions("load", disturbance=50.0, disturbance_time=100.0,
                                                                        noise_std=0.0, quantization=0.0)))
    plain = TCLabProcess(lab_factory=emulator_factory(TCLabConditions("plain", noise_std=0.0, quantization=0.0)))
    for p in (process, plain):
        p.reset(0)
    outputs = {}
    for name, p in (("load", process), ("plain", plain)):
        values = []
        for _ in range(400):
            p.apply(30.0, 0.0)
            values.append(p.measure())
        outputs[name] = values
    assert outputs["load"][:100] == outputs["plain"][:100]  # nothing before its time
    assert outputs["load"][-1] > outputs["plain"][-1] + 0.1  # heater 2 warms sensor 1 after it


def test_the_noise_estimate_knows_the_sensor_s_resolution():
    """The nominal emulator's readings (noise 0.043 degC, steps of 0.3223 degC) give the closed-loop
    step's median absolute fourth difference 0, the log's floor; knowing the resolution, the estimate is
    the noise (measured over the eight conditions and seeds 0 and 3: 0.037 to 0.052 degC, quantized
    ones; the tolerance is the step responses' measured range at ``sigma/q = 0.1``, 0.44 to 1.55).
    Without the quantizer the estimate is the plain one."""
    import math

    import gymnasium as gym

    import envs  # noqa: F401
    from envs.episode import LOG_CLIP, evidence_from_identification
    from envs.identification.steady_state import noise_level
    from dataclasses import replace

    assert TCLabProcess().quantization == 0.3223 == TCLabProcess(lab_factory=emulator_factory(CONDITIONS[0])).quantization
    found = _identified(CONDITIONS[0])
    output = found.identification.closed_loop.output
    assert found.quantization == 0.3223 and noise_level(output) == 0.0
    env = gym.make("DeadTime/PID-v3").unwrapped
    options = replace(env.options, quantization=found.quantization)
    evidence = evidence_from_identification(found.identification, options, abs(found.setpoint_step))
    assert 0.44 * 0.043 <= evidence.noise_estimate <= 1.55 * 0.043
    ratio = env.observe(found.identification, evidence)[env.feature_names.index("log_noise_ratio")]
    assert -LOG_CLIP < ratio == pytest.approx(math.log10(evidence.noise_estimate / abs(found.setpoint_step)), abs=1e-6)
    plain = _identified(CONDITIONS[6])  # no quantization
    assert plain.quantization == 0.0 and TCLabProcess(quantization=0.0).quantization == 0.0
    with pytest.raises(ValueError, match="quantization"):
        TCLabProcess(quantization=-1.0)
