"""The registry of every rule (baselines.rules.registry): names, citations, inputs, and each rule's numbers.

Every rule designs a controller on a benchmark plant (envs.systems.benchmark_batches.benchmark_plants) from the
noise-free fixed procedure; the ``mu`` and ``T_r`` rules equal the design maps of envs.design at
their parameter, and their parameters are checked against the source (Gorez-Klan section 3,
Ingimundarson Tables 1 and 2, eq. 34, 43, 50); the PI/PID rules are the pid_registry rules
(their formulas are tested in test_pid_rules.py).
"""

from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from baselines.rules import dtc as dtc_rules
from baselines.rules.pid_registry import RULES as PID_RULES
from baselines.rules.registry import (
    FPPI_DEAD_TIME_ERROR,
    MSP_RELATIVE_DEAD_TIME_ERROR,
    RULES,
    RuleInputs,
    get_rule,
)
from envs.design import fppi_design, msp_design, pid_design
from envs.systems.benchmark_batches import benchmark_plants
from envs.identification.models import FOPDTModel, IntegratingModel, SOPDTModel
from envs.identification.moments import sopdt_from_moments
from envs.systems.plants import Plant
from envs.identification.procedure import identify

REPO = Path(__file__).resolve().parents[4]
NAME = re.compile(r"^[a-z][a-z0-9.]*(-[a-z0-9.]+)+$")
MU_RULES = {
    "gorez-klan-mu-1.3": 1.3, "gorez-klan-mu-1.5": 1.5, "gorez-klan-mu-2": 2.0, "gorez-klan-mu-3": 3.0,
    "gorez-klan-pm-60": 6 / math.pi, "gorez-klan-gm-3": 6 / math.pi,
}
FPPI_RULES = ("fppi-eq28", "fppi-eq34", "ppi-kappa1")
MSP_RULES = ("msp-eq43", "msp-eq50", "msp-tr-tn")


@pytest.fixture(scope="module")
def benchmark_inputs() -> dict[str, RuleInputs]:
    """The rule inputs of every benchmark plant, by the noise-free fixed procedure (~2.5 s)."""
    return {name: RuleInputs.from_identification(identify(plant, np.random.default_rng(0)))
            for name, plant in benchmark_plants().items()}


def suitable(rule, inputs):
    return rule.plants == "both" or (rule.plants == "integrating") == inputs.integrating


# --------------------------------------------------------------------------- the registry itself
def test_names_are_unique_kebab_case_and_cited():
    assert len(RULES) == len(set(RULES))
    for name, rule in RULES.items():
        assert rule.name == name
        assert NAME.match(name), name
        assert rule.citation.strip(), name
        assert rule.controller in ("pid", "pid-series", "fppi", "msp")
        assert rule.plants in ("stable", "integrating", "both")


def test_the_registry_holds_every_rule_of_the_issue():
    required = {
        "zn-step-pi", "zn-step-pid", "zn-ultimate-pi", "zn-ultimate-pid", "cohen-coon-pi", "cohen-coon-pid",
        "chr-load-0-pid", "amigo-pi", "amigo-pid", "simc-pi", "simc-pid", "isimc-pi", "imc-pid", "haalman-pid",
        *MU_RULES, *FPPI_RULES, *MSP_RULES,
    }
    assert required <= set(RULES)
    assert set(PID_RULES) <= set(RULES)  # every PI/PID rule is adapted, none dropped


def test_unknown_rule_names_the_list():
    with pytest.raises(ValueError, match="unknown rule 'nope'.*--list"):
        get_rule("nope")


@pytest.mark.parametrize("name", list(RULES))
def test_every_rule_designs_a_controller_on_a_benchmark_plant(name, benchmark_inputs):
    rule = RULES[name]
    designed, refusals = [], []
    for plant, inputs in benchmark_inputs.items():
        if not suitable(rule, inputs):
            continue
        try:
            designed.append(rule.design(inputs))
        except ValueError as error:  # e.g. Haalman on a model with theta = 1 (a pure dead time)
            refusals.append(f"{plant}: {error}")
    assert designed, refusals
    assert all(c.to_dict()["type"] == rule.controller for c in designed)
    # refusals are the documented corner cases, at most one plant per rule on these batches
    assert len(refusals) <= 1, refusals


@pytest.mark.parametrize("name", [name for name, rule in RULES.items() if rule.plants != "both"])
def test_rules_refuse_the_other_kind_of_plant_naming_the_rule(name, benchmark_inputs):
    rule = RULES[name]
    other = benchmark_inputs["ingimundarson-integrating-P1" if rule.plants == "stable" else "ingimundarson-stable-P1"]
    with pytest.raises(ValueError, match=f"rule {re.escape(name)} is for"):
        rule.design(other)


# --------------------------------------------------------------------------- adapted PI/PID rules
PID_CASES = [
    (name, plant)
    for name, spec in PID_RULES.items()
    for plant in ("gorez-klan-P1", "ingimundarson-stable-P2", "ingimundarson-integrating-P2")
    if spec.integrating or "integrating" not in plant
]


@pytest.mark.parametrize("name, plant", PID_CASES)
def test_pid_rules_wrap_the_pid_registry(name, plant, benchmark_inputs):
    spec, inputs = PID_RULES[name], benchmark_inputs[plant]
    if inputs.integrating or spec.model == "ultimate":
        model = inputs.model
    else:
        model = inputs.fopdt if spec.model == "fopdt" else inputs.sopdt
    assert RULES[name].design(inputs) == spec.design(model)
    assert RULES[name].controller == ("pid" if spec.form == "ideal" else "pid-series")


# --------------------------------------------------------------------------- mu and T_r rules
@pytest.mark.parametrize("name, mu", MU_RULES.items())
@pytest.mark.parametrize("plant", ["gorez-klan-P1", "gorez-klan-P2", "ingimundarson-stable-P3"])
def test_mu_rules_are_the_design_map_at_their_mu(name, mu, plant, benchmark_inputs):
    inputs = benchmark_inputs[plant]
    rule = RULES[name]
    assert rule.parameter(inputs) == pytest.approx(mu, rel=1e-15)
    assert rule.design(inputs) == pid_design(inputs.sopdt, rule.parameter(inputs))


@pytest.mark.parametrize("name", FPPI_RULES)
@pytest.mark.parametrize("plant", ["gorez-klan-P1", "ingimundarson-stable-P1", "ingimundarson-stable-P6"])
def test_fppi_rules_are_the_design_map_at_their_tr(name, plant, benchmark_inputs):
    inputs = benchmark_inputs[plant]
    rule, model = RULES[name], inputs.fopdt
    assert rule.design(inputs) == fppi_design(model, rule.parameter(inputs))
    expected = {
        "fppi-eq28": dtc_rules.fppi_eq28_29(model.gain, model.time_constant, model.dead_time, inputs.mismatch_time),
        "fppi-eq34": dtc_rules.fppi_eq34(model.gain, model.time_constant, model.dead_time, inputs.mismatch_time,
                                         FPPI_DEAD_TIME_ERROR * model.dead_time),
        "ppi-kappa1": dtc_rules.ppi_default(model.gain, model.time_constant, model.dead_time),
    }[name]
    assert rule.design(inputs) == expected


@pytest.mark.parametrize("name", MSP_RULES)
@pytest.mark.parametrize("plant", ["ingimundarson-integrating-P1", "ingimundarson-integrating-P3", "ingimundarson-integrating-P8"])
def test_msp_rules_are_the_design_map_at_their_tr(name, plant, benchmark_inputs):
    inputs = benchmark_inputs[plant]
    rule, model = RULES[name], inputs.integrating_model
    assert rule.design(inputs) == msp_design(model, rule.parameter(inputs))
    expected = {
        "msp-eq43": dtc_rules.msp_eq43(model.gain, model.dead_time, inputs.pulse_area),
        "msp-eq50": dtc_rules.msp_eq50(model.gain, model.dead_time, MSP_RELATIVE_DEAD_TIME_ERROR),
        "msp-tr-tn": dtc_rules.msp_matausek_micic(model.gain, model.dead_time, inputs.apparent_time_constant),
    }[name]
    assert rule.design(inputs) == expected


def table_inputs(time_constant=None, dead_time=None, mismatch=math.nan, area=math.nan, integrating=False):
    """Rule inputs holding printed model values (Ingimundarson Tables 1 and 2)."""
    if integrating:
        model = IntegratingModel(gain=1.0, dead_time=dead_time)
        return RuleInputs(True, 1.0, dead_time, None, None, model, math.nan, area, model=model, apparent_time_constant=time_constant)
    fopdt = FOPDTModel(gain=1.0, time_constant=time_constant, dead_time=dead_time)
    sopdt = sopdt_from_moments(1.0, fopdt.residence_time, fopdt.normalized_dead_time)
    return RuleInputs(False, 1.0, fopdt.residence_time, fopdt, sopdt, None, mismatch, math.nan, model=sopdt)


# rule, inputs, T_r, kappa (None for the MSP), and the tolerances: half the last printed digit for
# printed values (Table 1: T_r to 0.01, kappa to 0.1; Table 2: T_r to 0.01), 1e-12 for closed forms
SOURCE_ROWS = {
    # Table 1, process 1: T_n = 10.4, L_n = 6.8, T_f_bar = 0.27 -> T_r = 1.68, kappa = 6.2
    "fppi-eq28-table1-p1": ("fppi-eq28", table_inputs(10.4, 6.8, 0.27), (1.68, 0.005), (6.2, 0.05)),
    # eq. 34 (as derived) with Delta L = 0.1 L_n = 0.68 on the same row: T_r = sqrt((0.27 + 0.68) 10.4)
    "fppi-eq34-table1-p1": ("fppi-eq34", table_inputs(10.4, 6.8, 0.27), (math.sqrt(0.95 * 10.4), 1e-12),
                            (math.sqrt(10.4 / 0.95), 1e-12)),
    # eq. 29 active: T_f_bar > T_n gives T_r = T_f_bar
    "fppi-eq28-eq29-active": ("fppi-eq28", table_inputs(0.5, 5.0, 2.0), (2.0, 1e-12), (0.25, 1e-12)),
    "ppi-kappa1": ("ppi-kappa1", table_inputs(10.4, 6.8, 0.27), (10.4, 1e-12), (1.0, 1e-12)),
    # Table 2, process 3: A = 0.9, L_n = 8 -> T_r = 2.03
    "msp-eq43-table2-p3": ("msp-eq43", table_inputs(dead_time=8.0, area=0.9, integrating=True), (2.03, 0.005), None),
    # eq. 50 with delta_L = 0.2: T_r = L_n 0.4/0.8
    "msp-eq50": ("msp-eq50", table_inputs(dead_time=8.0, integrating=True), (4.0, 1e-12), None),
    "msp-tr-tn": ("msp-tr-tn", table_inputs(time_constant=2.5, dead_time=8.0, integrating=True), (2.5, 1e-12), None),
}


@pytest.mark.parametrize("case", SOURCE_ROWS)
def test_tr_rules_against_the_source(case):
    name, inputs, (tr, tr_tolerance), kappa = SOURCE_ROWS[case]
    controller = RULES[name].design(inputs)
    assert controller.tr == pytest.approx(tr, abs=tr_tolerance)
    if kappa is not None:
        assert controller.kappa == pytest.approx(kappa[0], abs=kappa[1])
        assert controller.tf == controller.tr  # T_f = T_r, section 4.3


@pytest.mark.parametrize("name, mu", MU_RULES.items())
def test_mu_rules_against_eq_3_11(name, mu):
    # SOPDT model of Gorez-Klan P1 as printed for tau = 0.33: theta = 0.37 (eq. 2-10)
    inputs = table_inputs(0.67, 0.33)
    t1, t2 = inputs.sopdt.time_constants
    controller = RULES[name].design(inputs)
    assert (controller.ti, controller.td) == (t1, t2)
    assert controller.kp == pytest.approx(t1 / (mu * inputs.sopdt.dead_time), rel=1e-14)


def test_eq43_refuses_a_model_error_beyond_its_bound():
    with pytest.raises(ValueError, match="eq. 43 has no positive T_r"):
        RULES["msp-eq43"].design(table_inputs(dead_time=1.0, area=1.5, integrating=True))


def test_rules_name_the_missing_input():
    with pytest.raises(ValueError, match="rule fppi-eq28 needs T_f_bar"):
        RULES["fppi-eq28"].design(table_inputs(10.4, 6.8))
    with pytest.raises(ValueError, match="rule msp-tr-tn needs T_n"):
        RULES["msp-tr-tn"].design(table_inputs(dead_time=8.0, integrating=True))


# --------------------------------------------------------------------------- RuleInputs.from_model
def test_from_fopdt_model_is_the_sopdt_model_with_no_second_lag():
    """A given FOPDT model is not re-fitted by moments (eq. 2-8 would give the SOPDT
    ``sopdt_from_moments(2.0, 10.0, 0.4)``, dead time 1.31 instead of 4)."""
    model = FOPDTModel(gain=2.0, time_constant=6.0, dead_time=4.0)
    inputs = RuleInputs.from_model(model)
    assert inputs.fopdt == model and inputs.model == model
    assert inputs.sopdt == SOPDTModel(gain=2.0, time_constants=(6.0, 0.0), dead_time=4.0)
    assert inputs.sopdt != sopdt_from_moments(2.0, 10.0, 0.4)


def test_from_sopdt_model_derives_the_moment_fopdt():
    model = SOPDTModel(gain=-1.5, time_constants=(3.0, 4.0), dead_time=2.0)
    inputs = RuleInputs.from_model(model)
    assert inputs.sopdt == model
    assert inputs.fopdt.time_constant == pytest.approx(5.0)  # T_a = sqrt(T1^2 + T2^2), eq. 2-6
    assert inputs.fopdt.residence_time == pytest.approx(9.0)  # T_ar = T1 + T2 + D2, eq. 2-5
    assert inputs.fopdt.gain == -1.5


def test_mismatch_time_of_the_exact_model_vanishes():
    model = FOPDTModel(gain=3.0, time_constant=10.0, dead_time=5.0)
    assert RuleInputs.from_model(model, model.plant()).mismatch_time < 1e-9


def test_mismatch_time_of_a_wrong_model_is_the_area_between_the_responses():
    # y - y_n for P = e^{-5s}/(10s+1) and the model e^{-6s}/(9s+1): both reach 1, the area is
    # int |y - y_n| dt; the signed integral is T_ar(model) - T_ar(plant) = 0 and the curves cross once
    plant = Plant.from_time_constants(1.0, [10.0], 5.0)
    model = FOPDTModel(gain=1.0, time_constant=9.0, dead_time=6.0)
    t = np.linspace(0, 400, 400_001)
    expected = np.trapezoid(np.abs(FOPDTModel(1.0, 10.0, 5.0).step_response(t) - model.step_response(t)), t)
    assert RuleInputs.from_model(model, plant).mismatch_time == pytest.approx(expected, rel=1e-4)


def test_pulse_area_of_the_exact_model_vanishes_and_integrating_lag_counts_in_l_n():
    exact = IntegratingModel(gain=0.5, dead_time=8.0)
    assert RuleInputs.from_model(exact, exact.plant()).pulse_area < 1e-9
    lagged = RuleInputs.from_model(IntegratingModel(gain=0.5, dead_time=5.0, time_constant=3.0))
    assert lagged.integrating_model == IntegratingModel(gain=0.5, dead_time=8.0)  # L_n = T_ar, eq. 2
    assert lagged.apparent_time_constant == 3.0


@pytest.mark.parametrize(
    "model, plant",
    [
        (FOPDTModel(1.0, 1.0, 1.0), Plant.from_time_constants(1.0, [1.0], 1.0, integrating=True)),
        (IntegratingModel(1.0, 1.0), Plant.from_time_constants(1.0, [1.0], 1.0)),
    ],
    ids=["fopdt-on-integrating", "integrating-on-stable"],
)
def test_from_model_refuses_a_model_of_the_other_kind(model, plant):
    with pytest.raises(ValueError, match="does not fit the plant"):
        RuleInputs.from_model(model, plant)


def test_rules_import_no_heavy_package():
    """gymnasium is loaded by ``envs/__init__.py`` (the registration); the learning packages never."""
    code = ("import sys, baselines.rules.registry, baselines.rules.tune, baselines.rules.mu\n"
            "print([m for m in ('torch', 'stable_baselines3') if m in sys.modules])")
    run = subprocess.run([sys.executable, "-c", code], check=False, capture_output=True, text=True, cwd=REPO, timeout=120)
    assert run.returncode == 0, run.stderr
    assert run.stdout.strip() == "[]"
