"""Parsing ``--policies`` of ``deadtime evaluate``, the rule sets of each structure, the failure cost."""

from __future__ import annotations

import pytest

from agents.evaluation.policies import PolicySpec, applicable_rules, own_rules, parse_policies
from agents.evaluation.run import FAILURE_COST
from baselines.rules.registry import RULES


def test_failure_costs_an_unstable_loop():
    from envs.analysis.scoring import FEASIBLE_CAP, UNSTABLE_GRADE

    assert FAILURE_COST == FEASIBLE_CAP + 1 + UNSTABLE_GRADE


def test_violation_cost_is_the_scorings():
    from agents.evaluation.seed_statistics import VIOLATION_COST
    from envs.analysis.scoring import FEASIBLE_CAP

    assert VIOLATION_COST == FEASIBLE_CAP + 1


@pytest.mark.parametrize(
    "structure, own",
    [
        ("pid", ["gorez-klan-mu-1.3", "gorez-klan-mu-1.5", "gorez-klan-mu-2", "gorez-klan-mu-3", "gorez-klan-pm-60", "gorez-klan-gm-3",
                 "gorez-klan-ms1.4", "gorez-klan-ms1.6", "gorez-klan-ms1.8"]),
        ("fppi", ["fppi-eq28", "fppi-eq34", "ppi-kappa1", "fppi-ms1.4", "fppi-ms1.6", "fppi-ms1.8"]),
        ("msp", ["msp-eq43", "msp-eq50", "msp-tr-tn", "msp-dm0.3", "msp-dm0.5", "msp-dm0.7"]),  # with the matched rules
    ],
)
def test_own_structure_rules(structure, own):
    assert own_rules(structure) == own
    assert set(own) <= set(applicable_rules(structure))


def test_all_rules_follow_the_plants_and_the_controller_class():
    pid, fppi, msp = (set(applicable_rules(s)) for s in ("pid", "fppi", "msp"))
    assert {"simc-pi", "cohen-coon-pid", "haalman-pid", "gorez-klan-mu-2"} <= pid & fppi
    fppi_rules = {"fppi-eq28", "fppi-eq34", "ppi-kappa1", "fppi-ms1.4", "fppi-ms1.6", "fppi-ms1.8"}
    assert not fppi_rules & pid  # the other compensator's rules
    assert fppi_rules <= fppi
    assert fppi - pid == fppi_rules
    assert not {"msp-eq43", "msp-eq50", "msp-tr-tn", "msp-dm0.5"} & (pid | fppi)
    assert {"msp-eq43", "zn-step-pi", "simc-pi"} <= msp
    assert not {"cohen-coon-pi", "gorez-klan-mu-2", "fppi-eq28"} & msp
    assert pid | fppi | msp == set(RULES)


def test_parse_keeps_order_and_drops_duplicates(tmp_path):
    agent = tmp_path / "model.zip"
    specs = parse_policies(f"oracle,simc-pi,oracle-full,simc-pi,mine={agent},{agent}", "pid")
    assert specs == [
        PolicySpec("oracle", "oracle"),
        PolicySpec("simc-pi", "rule"),
        PolicySpec("oracle-full", "oracle-full"),
        PolicySpec("mine", "agent", str(agent)),
        PolicySpec("", "agent", str(agent)),
    ]
    expanded = parse_policies("all-rules,oracle", "msp")
    assert [s.name for s in expanded] == applicable_rules("msp") + ["oracle"]


@pytest.mark.parametrize(
    "text, message",
    [
        ("simc-pi,no-such-rule", "unknown rule 'no-such-rule'"),
        ("", "comma-separated"),
        ("oracle,,simc-pi", "comma-separated"),
        ("agent=", "no agent path"),
    ],
)
def test_bad_policies_are_named(text, message):
    with pytest.raises(ValueError, match=message):
        parse_policies(text, "pid")


def test_rule_parameters_are_dimensionless_like_the_oracles():
    """``mu`` as is; ``T_r`` over ``T_n`` (FPPI) or ``L_n`` (MSP); none for the full PI/PID rules."""
    from baselines.rules.registry import RuleInputs, get_rule
    from envs.identification.models import FOPDTModel, IntegratingModel

    stable = RuleInputs.from_model(FOPDTModel(gain=2.0, time_constant=4.0, dead_time=1.0))
    assert get_rule("gorez-klan-mu-2").relative_parameter(stable) == pytest.approx(get_rule("gorez-klan-mu-2").parameter(stable))
    assert get_rule("ppi-kappa1").relative_parameter(stable) == pytest.approx(1.0)  # T_r = T_n
    assert get_rule("simc-pi").relative_parameter(stable) is None
    integrating = RuleInputs.from_model(IntegratingModel(gain=0.5, dead_time=3.0))
    assert get_rule("msp-eq50").relative_parameter(integrating) == pytest.approx(0.5)  # T_r/L_n = 2*0.2/0.8
