"""The residual action's base rule and the design features (envs.base_design, the -v1 ids)."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (registers the ids)
from baselines.rules.registry import RuleInputs, get_rule
from envs.analysis.robustness import loop_margins
from envs.simulation.loops import loop_response
from envs.base_design import (
    DESIGN_FEATURES,
    base_parameter,
    check_model,
    design_features,
    residual_action,
    residual_parameter,
)
from envs.structures import PARAMETER_RANGES, design, relative_scale
from envs.interface import tuning_env_of

BASE_RULES = {"pid": "gorez-klan-mu-2", "fppi": "fppi-eq34", "msp": "msp-eq50"}
V1 = {"pid": "DeadTime/PID-v1", "fppi": "DeadTime/FPPI-v1", "msp": "DeadTime/MSP-v1"}


@pytest.mark.parametrize("structure", list(V1))
def test_base_parameter_is_the_base_rule_and_action_zero_plays_it(structure):
    """p_0 equals the rule's relative parameter (baselines), and action 0 scores the rule's controller."""
    env = tuning_env_of(gym.make(V1[structure]))
    for seed in range(12):
        env.reset(seed=seed)
        inputs = RuleInputs.from_identification(env.identification)
        rule = get_rule(BASE_RULES[structure])
        assert base_parameter(structure, env.identification) == pytest.approx(rule.relative_parameter(inputs), rel=1e-12)
        info = env.step(np.zeros(1, dtype=np.float32))[4]
        assert info["cost"] == pytest.approx(float(env.score_controller(rule(inputs)).cost), rel=1e-12)


@pytest.mark.parametrize("structure", list(V1))
@pytest.mark.parametrize("base_at", [0.1, 0.5, 0.9])
def test_residual_reaches_the_range_ends_and_inverts(structure, base_at):
    low, high = PARAMETER_RANGES[structure]
    base = low * (high / low) ** base_at
    assert residual_parameter(structure, base, 0.0) == pytest.approx(base, rel=1e-14)
    assert residual_parameter(structure, base, -1.0) == pytest.approx(low, rel=1e-12)
    assert residual_parameter(structure, base, 1.0) == pytest.approx(high, rel=1e-12)
    parameters = [residual_parameter(structure, base, a) for a in np.linspace(-1.0, 1.0, 41)]
    assert parameters == sorted(parameters)
    for a, p in zip(np.linspace(-1.0, 1.0, 41), parameters):
        assert residual_action(structure, base, p) == pytest.approx(a, abs=1e-12)
    assert residual_parameter(structure, base, 5.0) == residual_parameter(structure, base, 1.0)


@pytest.mark.parametrize("structure", list(V1))
def test_design_features_agree_with_the_reference_margins(structure):
    """check_ms and check_delay_margin: the compiled margins against the python reference (loop_margins)."""
    env = tuning_env_of(gym.make(V1[structure]))
    for seed in range(6):
        obs, info = env.reset(seed=seed)
        found = env.identification
        model = {"pid": found.sopdt, "fppi": found.fopdt, "msp": found.integrating_model}[structure]
        base = base_parameter(structure, found)
        controller = design(structure, model, base * relative_scale(structure, model))
        plant = check_model(structure, found).plant()
        reference = loop_margins(lambda w: loop_response(plant, controller, w), integrators=int(plant.integrating) + controller.integrators,
                                 time_scale=plant.step_time_scale())
        named = info["features"]
        assert list(named)[-3:] == list(DESIGN_FEATURES)
        assert named["log_base_parameter"] == pytest.approx(math.log10(base), rel=1e-12)
        if reference.stable:
            assert named["check_ms"] == pytest.approx(min(max(reference.ms, 1.0), 5.0), rel=1e-3)
            dm = reference.delay_margin / found.residence_time
            assert named["check_delay_margin"] == pytest.approx(min(dm, 5.0), rel=1e-3)


@pytest.mark.parametrize("structure", list(V1))
def test_v1_sees_the_v0_episode(structure):
    """Same seed: v1's observation starts with v0's, and v0's action on the same parameter costs the same."""
    v0, v1 = tuning_env_of(gym.make(V1[structure].replace("v1", "v0"))), tuning_env_of(gym.make(V1[structure]))
    for seed in range(4):
        o0, _ = v0.reset(seed=seed)
        o1, _ = v1.reset(seed=seed)
        assert np.array_equal(o0, o1[: len(o0)])
        a1 = 0.3
        parameter = v1.parameter_from_action(a1)
        c1 = v1.step(np.array([a1], dtype=np.float32))[4]["cost"]
        c0 = v0.step(np.array([v0.action_from_parameter(parameter)], dtype=np.float32))[4]["cost"]
        assert c0 == pytest.approx(c1, rel=1e-6)


def test_design_features_are_zero_without_an_identification():
    assert design_features("pid", None) == dict.fromkeys(DESIGN_FEATURES, 0.0)
    env = tuning_env_of(gym.make("DeadTime/PID-v1", experiments="agent"))
    _, info = env.reset(seed=0)
    assert [info["features"][k] for k in DESIGN_FEATURES] == [0.0, 0.0, 0.0]
    with pytest.raises(RuntimeError, match="the action.s coordinates need the identification"):
        env.base_parameter()


def _action_for(structure: str, target: float) -> float:
    from envs.base_design import ROBUSTNESS_TARGETS

    _, aggressive, robust = ROBUSTNESS_TARGETS[structure]
    return 2.0 * math.log(target / aggressive) / math.log(robust / aggressive) - 1.0


@pytest.mark.parametrize("structure, rule, target", [("pid", "gorez-klan-ms1.6", 1.6), ("msp", "msp-dm0.5", 0.5)])
def test_robustness_action_is_the_matched_rule(structure, rule, target):
    """The robustness action at a rule's target gives the matched rule's parameter (same root find, same bracket)."""
    env = tuning_env_of(gym.make(V1[structure], action="robustness"))
    a = _action_for(structure, target)
    for seed in range(5):
        env.reset(seed=seed)
        inputs = RuleInputs.from_identification(env.identification)
        assert env.parameter_from_action(a) == pytest.approx(get_rule(rule).relative_parameter(inputs), rel=1e-9)


def test_robustness_action_meets_its_target_on_the_model():
    """FPPI (its bracket is the action's range, not fppi-msX's): Ms on the SOPDT model loop = target to 1e-3,
    unless the parameter is at an end of the range; a more robust target never gives a more aggressive design."""
    from envs.analysis.matching import loop_figure

    env = tuning_env_of(gym.make("DeadTime/FPPI-v1", action="robustness"))
    low, high = PARAMETER_RANGES["fppi"]
    for seed in range(5):
        env.reset(seed=seed)
        found = env.identification
        parameters = []
        for target in (2.0, 1.6, 1.3):
            p = env.parameter_from_action(_action_for("fppi", target))
            parameters.append(p)
            if low < p < high:
                controller = design("fppi", found.fopdt, p * found.fopdt.time_constant)
                assert loop_figure(found.sopdt.plant(), controller, "ms") == pytest.approx(target, abs=1e-3)
        assert parameters == sorted(parameters)


@pytest.mark.parametrize("structure", list(V1))
def test_robustness_action_inverts_the_robustness_parameter(structure):
    """action_from_parameter(p) is the target of p's own model-loop figure: the parameter it gives back has
    that figure (to the root find's 1e-12 in log p, so 1e-6 relative is loose) and is the least aggressive
    such parameter (>= p); a parameter whose model loop is unstable is the aggressive end -1."""
    from envs.analysis.matching import loop_figure
    from envs.base_design import ROBUSTNESS_TARGETS, _robustness_loop

    env = tuning_env_of(gym.make(V1[structure], action="robustness"))
    name = structure
    figure = ROBUSTNESS_TARGETS[name][0]
    low, high = PARAMETER_RANGES[name]
    checked = 0
    for seed in range(4):
        env.reset(seed=seed)
        model, loop_model, scale, unit = _robustness_loop(name, env.identification)

        def value(p):
            return loop_figure(loop_model.plant(), design(name, model, p * scale), figure, unit)

        for p in np.geomspace(low, high, 9)[1:-1]:
            a = env.action_from_parameter(p)
            assert -1.0 <= a <= 1.0
            if not math.isfinite(value(p)) or value(p) == 0:
                assert a == -1.0
            elif -1.0 < a < 1.0:
                back = env.parameter_from_action(a)
                assert back >= p * (1 - 1e-9)
                if low < back < high:
                    assert value(back) == pytest.approx(value(p), rel=1e-6)
                    checked += 1
    assert checked >= 8


@pytest.mark.parametrize("structure", list(V1))
def test_env_checkers_pass_with_the_robustness_action(structure):
    from gymnasium.utils.env_checker import check_env

    check_env(gym.make(V1[structure], action="robustness").unwrapped, skip_render_check=True)


def test_an_unmeasured_mismatch_area_counts_as_zero_in_the_fppi_base():
    """Agent mode with only a PRBS fitted: no open-loop step measured ``T_f_bar`` (nan).  The base is
    eq. 34 with ``T_f_bar = 0`` (the assumed dead-time error alone), not the range's aggressive end."""
    from dataclasses import replace

    from envs.base_design import FPPI_DEAD_TIME_ERROR, fppi_time_constant

    env = tuning_env_of(gym.make(V1["fppi"]))
    env.reset(seed=0)
    found = env.identification
    unmeasured, zero = replace(found, mismatch_time=math.nan), replace(found, mismatch_time=0.0)
    fopdt = found.fopdt
    expected = fppi_time_constant(fopdt.time_constant, FPPI_DEAD_TIME_ERROR * fopdt.dead_time) / fopdt.time_constant
    assert base_parameter("fppi", unmeasured) == base_parameter("fppi", zero) == pytest.approx(expected, rel=1e-12)
    assert base_parameter("fppi", unmeasured) > PARAMETER_RANGES["fppi"][0]


def test_a_prbs_only_agent_episode_designs_a_stable_loop_at_action_zero():
    """FPPI-v2 in agent mode, a PRBS then the commit at ``a = 0``: the loop is stable on these plants
    (before the base read an unmeasured ``T_f_bar`` as 0 it was the aggressive end: 26, unstable).
    Without the mismatch area eq. 34 is aggressive (Ms 2-5 on some of them): robustness is the agent's
    to buy, with a residual or an open-loop step."""
    env = gym.make("DeadTime/FPPI-v2", experiments="agent", identification="least-squares")
    names = tuning_env_of(env).experiment_names
    for seed in range(3):
        env.reset(seed=seed)
        for kind in ("closed-loop-step", "prbs"):
            action = np.full(env.action_space.shape, -1.0, dtype=np.float32)
            action[names.index(kind) + 1], action[-2], action[-1] = 1.0, 0.0, 0.0
            env.step(action)
        commit = np.full(env.action_space.shape, -1.0, dtype=np.float32)
        commit[0], commit[-1] = 1.0, 0.0
        env.step(commit)  # v2: the commit shows the identification, the next step designs
        info = env.step(commit)[4]
        assert info["score"]["stable"], info["cost"]
