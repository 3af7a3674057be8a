"""The robustness-matched rules (baselines.rules.matched).

* On the model, each matched rule's loop meets its target to 1e-3 (relative), on plants of every
  family and on the papers' benchmark plants (noise-free procedure), or says why not (bracket end,
  refusal) as its module documents.
* On exact FOPDT models, SIMC's ``Ms``-matched ``tau_c`` agrees with an independent computation:
  a dense grid over ``tau_c`` with ``Ms`` from python-control's ``frequency_response`` of the
  rational loop times the exact ``exp(-i omega L)`` on a fine ``omega`` grid.
* The rules are in ``all-rules`` of their structure and in ``deadtime tune``.
"""

from __future__ import annotations

import json
import math

import control
import numpy as np
import pytest

from agents.cli import main
from agents.evaluation.policies import applicable_rules, own_rules
from baselines.rules import matched
from baselines.rules.pid import simc_pi
from baselines.rules.registry import DM_TARGETS, MATCHED, MS_TARGETS, RULES, RuleInputs
from baselines.rules.tune import TR_FLOORS
from envs.design import pid_design
from envs.identification.models import FOPDTModel, IntegratingModel, SOPDTModel
from envs.identification.procedure import identify
from envs.systems.families import sample_plants
from envs.systems.benchmark_batches import benchmark_plants

RELATIVE_TOLERANCE = 1e-3
FAMILIES = ("fopdt", "sopdt", "lag-chain", "integrating", "stable")


def _applies(rule, inputs: RuleInputs) -> bool:
    return rule.plants == "both" or (rule.plants == "integrating") == inputs.integrating


@pytest.fixture(scope="module")
def identified_inputs() -> dict[str, RuleInputs]:
    """Rule inputs of 3 plants of each family and every benchmark plant (noise-free procedure)."""
    plants = {f"{family}-{i}": plant for family in FAMILIES for i, plant in enumerate(sample_plants(family, 3, 0))}
    plants.update(benchmark_plants())
    return {name: RuleInputs.from_identification(identify(plant, np.random.default_rng(0))) for name, plant in plants.items()}


def test_the_matched_rules_are_named_by_their_targets():
    names = {*(f"{r}-ms{t:g}" for r in ("gorez-klan", "fppi", "simc-pi", "imc-pid") for t in MS_TARGETS),
             *(f"msp-dm{t:g}" for t in DM_TARGETS)}
    assert set(MATCHED) == names and names <= set(RULES)
    for name in names:
        assert "Grimholt & Skogestad 2018" in RULES[name].citation


def test_the_brackets_start_at_the_tune_floors():
    assert matched.FPPI_TR_FLOOR == TR_FLOORS["fppi"] and matched.MSP_TR_FLOOR == TR_FLOORS["msp"]


def test_all_rules_holds_the_matched_rules_of_each_structure():
    pid, fppi, msp = (set(applicable_rules(s)) for s in ("pid", "fppi", "msp"))
    simc_imc = {n for n in MATCHED if n.startswith(("simc-pi-", "imc-pid-"))}
    simc = {n for n in simc_imc if n.startswith("simc")}
    assert {n for n in MATCHED if n.startswith("gorez-klan")} | simc_imc <= pid
    assert {n for n in MATCHED if n.startswith("fppi")} | simc_imc <= fppi
    assert {n for n in MATCHED if n.startswith("msp")} | simc <= msp
    # the mu and T_r ones set the environment's own parameter, so they compete for "best rule"
    assert {n for n in MATCHED if n.startswith("gorez-klan")} <= set(own_rules("pid"))
    assert {n for n in MATCHED if n.startswith("msp")} <= set(own_rules("msp"))


def test_each_matched_rule_meets_its_target_on_the_model(identified_inputs):
    exact, total = 0, 0
    for plant, inputs in identified_inputs.items():
        model_plant = inputs.model.plant()
        for name, solve in MATCHED.items():
            rule = RULES[name]
            if not _applies(rule, inputs):
                continue
            total += 1
            try:
                result = solve(inputs)
            except ValueError as error:  # documented refusal: missed at the least aggressive end
                assert "least aggressive end" in str(error), (plant, name, error)
                continue
            figure = "delay_margin" if name.startswith("msp") else "ms"
            scale = inputs.integrating_model.dead_time if figure == "delay_margin" else 1.0
            # the rule's own controller, analyzed afresh on the model
            value = matched.loop_figure(model_plant, rule(inputs), figure, scale)
            assert value == pytest.approx(result.value, rel=1e-12), (plant, name)
            if result.at_bracket_end:  # met at the aggressive end already: on the safe side
                assert (value < result.target) if figure == "ms" else (value > result.target), (plant, name)
                assert result.parameter == result.bracket[0]
            else:
                exact += 1
                assert value == pytest.approx(result.target, rel=RELATIVE_TOLERANCE), (plant, name, result)
            if rule.parameter is not None:
                assert rule.parameter(inputs) == result.parameter
    assert exact >= 0.9 * total, f"only {exact} of {total} matched exactly"


@pytest.mark.parametrize("model", [
    FOPDTModel(2.5, 12.0, 4.0), FOPDTModel(-1.0, 1.0, 3.0), SOPDTModel(1.0, (5.0, 2.0), 1.0),
    IntegratingModel(1.0, 5.0), IntegratingModel(0.5, 2.0, 1.0),
], ids=["fopdt", "fopdt-negative-gain-dead-time-dominant", "sopdt", "integrating", "integrating-lag"])
def test_given_models_meet_their_targets(model):
    inputs = RuleInputs.from_model(model)
    for name, solve in MATCHED.items():
        if not _applies(RULES[name], inputs):
            continue
        result = solve(inputs)
        if not result.at_bracket_end:
            assert result.value == pytest.approx(result.target, rel=RELATIVE_TOLERANCE), (name, result)


def test_a_stricter_ms_gives_a_less_aggressive_parameter():
    inputs = RuleInputs.from_model(FOPDTModel(2.5, 12.0, 4.0))
    for prefix in ("gorez-klan-ms", "fppi-ms", "simc-pi-ms", "imc-pid-ms"):
        parameters = [MATCHED[f"{prefix}{t:g}"](inputs).parameter for t in MS_TARGETS]
        assert parameters == sorted(parameters, reverse=True), prefix
    msp = [MATCHED[f"msp-dm{t:g}"](RuleInputs.from_model(IntegratingModel(1.0, 5.0))).parameter for t in DM_TARGETS]
    assert msp == sorted(msp)


def test_an_unreachable_target_is_refused_and_a_met_one_takes_the_aggressive_end():
    model = SOPDTModel(1.0, (5.0, 2.0), 1.0)
    plant = model.plant()
    with pytest.raises(ValueError, match=r"misses Ms = 1.001 even at the least aggressive end .* where Ms = 1\.0"):
        matched.match_parameter(lambda mu: pid_design(model, mu), plant, "ms", 1.001, (0.3, 300.0), name="x")
    result = matched.match_parameter(lambda mu: pid_design(model, mu), plant, "ms", 3.0, (2.0, 300.0))
    assert result.at_bracket_end and result.parameter == 2.0 and result.value < 3.0
    with pytest.raises(ValueError, match="bracket must be"):
        matched.match_parameter(lambda mu: pid_design(model, mu), plant, "ms", 1.5, (3.0, 2.0))


def test_the_least_aggressive_root_is_taken_when_ms_is_not_monotone():
    # the MSP's Ms on its exact model rises to 2.37 near T_r = 0.5 L_n, then falls (module docstring):
    # an Ms target of 2.2 is crossed twice; the rule's root is the larger T_r, above which Ms <= 2.2
    from envs.design import msp_design

    model = IntegratingModel(1.0, 5.0)
    result = matched.match_parameter(lambda tr: msp_design(model, tr), model.plant(), "ms", 2.2, (0.05, 500.0))
    assert result.value == pytest.approx(2.2, rel=RELATIVE_TOLERANCE) and result.parameter > model.dead_time
    for tr in np.geomspace(result.parameter * 1.01, 500.0, 20):
        assert matched.loop_figure(model.plant(), msp_design(model, tr), "ms") <= 2.2


# --------------------------------------------------------------------------- independent SIMC check
def _brute_force_ms(model: FOPDTModel, tau_c: float, omega: np.ndarray) -> float:
    """``max |1/(1 + L(i omega))|`` on ``omega``, ``L`` = python-control's rational loop times ``exp(-i omega L)``."""
    controller = simc_pi(model, tau_c)
    pi = control.tf([controller.kp * controller.ti, controller.kp], [controller.ti, 0.0])
    rational = control.tf([model.gain], [model.time_constant, 1.0]) * pi
    response = control.frequency_response(rational, omega)
    loop = response.magnitude * np.exp(1j * response.phase) * np.exp(-1j * omega * model.dead_time)
    return float(np.max(1.0 / np.abs(1.0 + loop)))


@pytest.mark.parametrize("model", [
    FOPDTModel(2.5, 12.0, 4.0), FOPDTModel(1.0, 1.0, 1.0), FOPDTModel(1.0, 1.0, 5.0), FOPDTModel(0.3, 20.0, 1.0),
], ids=["readme", "balanced", "dead-time-dominant", "lag-dominant"])
@pytest.mark.parametrize("target", MS_TARGETS)
def test_simc_matched_tau_c_agrees_with_a_brute_force_grid(model, target):
    theta = model.dead_time
    omega = np.geomspace(1e-3, 1e2, 20_000) / theta
    taus = np.geomspace(0.05, 20.0, 241) * theta  # relative step 2.5 %
    ms = np.array([_brute_force_ms(model, tau, omega) for tau in taus])
    # measured resolution of the omega grid: Ms on a 4x finer grid, at the matched tau_c's neighbours
    i = int(np.flatnonzero(ms > target)[-1])  # last grid point that misses (Ms decreasing in tau_c)
    fine = np.geomspace(1e-3, 1e2, 80_000) / theta
    omega_error = max(abs(_brute_force_ms(model, taus[j], fine) - ms[j]) for j in (i, i + 1))
    assert omega_error < 0.1 * min(ms[i] - target, target - ms[i + 1]) or omega_error < 1e-4
    tau_c = MATCHED[f"simc-pi-ms{target:g}"](RuleInputs.from_model(model)).parameter
    # the crossing lies between the two grid points (to the omega grid's error), and log-linear
    # interpolation between them locates it to much better than the grid step
    assert taus[i] <= tau_c <= taus[i + 1]
    weight = (ms[i] - target) / (ms[i] - ms[i + 1])
    interpolated = math.exp(math.log(taus[i]) + weight * (math.log(taus[i + 1]) - math.log(taus[i])))
    step = taus[i + 1] / taus[i] - 1.0
    assert tau_c == pytest.approx(interpolated, rel=0.1 * step)
    # and the package's Ms at the matched tau_c equals the brute-force Ms there, to the omega grid's error
    assert _brute_force_ms(model, tau_c, fine) == pytest.approx(target, abs=max(omega_error, 1e-4) + 1e-5)


def test_deadtime_tune_simc_pi_ms16_on_the_readme_model(capsys):
    model = {"type": "fopdt", "gain": 2.5, "time_constant": 12, "dead_time": 4}
    status = main(["tune", "--rule", "simc-pi-ms1.6", "--model", json.dumps(model), "--json"])
    result = json.loads(capsys.readouterr().out)
    assert status == 0 and result["problem"] is None and result["controller"]["type"] == "pid"
    assert result["analysis"]["ms"] == pytest.approx(1.6, rel=RELATIVE_TOLERANCE)
    assert result["controller"]["ti"] == 12.0  # tau_I = min(tau_1, 4 (tau_c + theta)) = tau_1
