"""A rule's family by its knob: the shipped rule at s = 0 bit for bit, more conservative as s grows."""

import math

import numpy as np
import pytest

from baselines.rules.family import knob_kind, member_name, rule_at, split_member_name
from baselines.rules.registry import RULES, RuleInputs, get_rule
from envs.identification.procedure import identify
from envs.systems.plant_sets import benchmark_set


@pytest.fixture(scope="module")
def inputs() -> dict[str, RuleInputs]:
    found = {}
    for structure in ("pid", "msp"):
        plant = next(iter(benchmark_set(structure).values()))
        found["integrating" if plant.integrating else "stable"] = RuleInputs.from_identification(identify(plant, np.random.default_rng(0)))
    return found


def _applies(rule, inputs) -> bool:
    try:
        rule(inputs)
    except ValueError:
        return False
    return True


def _gain(controller) -> float:
    return controller.kp


@pytest.mark.parametrize("name", sorted(RULES))
def test_the_family_at_zero_is_the_rule_and_larger_knobs_lower_the_gain(name, inputs):
    rule = RULES[name]
    for kind, given in inputs.items():
        if not _applies(rule, given):
            continue
        assert rule_at(rule, 0.0)(given).to_dict() == rule(given).to_dict()
        if rule.controller in ("pid", "pid-series"):
            gains = [_gain(rule_at(rule, s)(given)) for s in (-0.5, 0.0, 0.5)]
            assert gains[0] > gains[1] > gains[2], (name, kind, gains)


def test_parameter_rules_scale_their_parameter_and_reach_the_structure_design(inputs):
    rule = get_rule("gorez-klan-mu-2")
    member = get_rule("gorez-klan-mu-2@0.5")
    given = inputs["stable"]
    assert member.name == "gorez-klan-mu-2@0.5" and knob_kind(rule) == "parameter"
    assert member.parameter(given) == pytest.approx(rule.parameter(given) * math.exp(0.5), rel=1e-15)
    # mu -> mu e^s is K_p -> K_p e^-s (Gorez-Klan eq. 3-11), the detuning of the gain
    assert member(given).kp == pytest.approx(rule(given).kp * math.exp(-0.5), rel=1e-12)


def test_kinds_of_knob():
    assert knob_kind(RULES["amigo-pid"]) == "gain" and knob_kind(RULES["zn-ultimate-pid"]) == "gain"
    assert knob_kind(RULES["simc-pi"]) == "time constant" and knob_kind(RULES["msp-dm0.5"]) == "parameter"


def test_member_names_read_back_and_bad_knobs_are_one_clear_error():
    assert split_member_name(member_name("amigo-pid", -0.25)) == ("amigo-pid", -0.25)
    with pytest.raises(ValueError, match="must be a number"):
        get_rule("amigo-pid@x")
    with pytest.raises(ValueError, match="finite number from -5 to 5"):
        get_rule("amigo-pid@9")
    with pytest.raises(ValueError, match="unknown rule"):
        get_rule("no-such-rule@0.5")


def test_a_member_refuses_the_wrong_plant_kind_as_its_rule_does(inputs):
    for name in ("gorez-klan-mu-2", "fppi-eq34", "imc-pid"):
        with pytest.raises(ValueError, match="for self-regulating plants"):
            get_rule(f"{name}@0.5")(inputs["integrating"])
    with pytest.raises(ValueError, match="for integrating plants"):
        get_rule("msp-eq50@0.5")(inputs["stable"])
