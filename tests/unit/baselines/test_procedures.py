"""The experiment procedures of :mod:`baselines.procedures` on the v3 environments."""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401
from baselines.procedures import AmplitudeRule, PlanRule, amplitude_action, is_procedure, procedure
from envs.modes import experiment_amplitude
from envs.interface import episode_of, tuning_env_of


def _play(env, policy, seed):
    observation, _ = env.reset(seed=seed)
    steps, done = 0, False
    while not done:
        observation, reward, done, _, info = env.step(policy.predict(observation)[0])
        steps += 1
    return reward, info, steps


def test_amplitude_action_is_the_environments_inverse():
    env = tuning_env_of(gym.make("DeadTime/FPPI-v3", experiments="plan"))
    for amplitude in (0.1, 0.3, 1.0, 3.0):
        assert experiment_amplitude(amplitude_action(amplitude), env.options) == pytest.approx(amplitude, rel=1e-12)


def test_names():
    assert procedure("plan-0.3-3").name == "plan-0.3-3" and procedure("plan-1-1").first == 1.0
    assert is_procedure("amplitude-rule") and is_procedure("plan-best") and not is_procedure("plan-x")
    with pytest.raises(ValueError, match="outside"):
        procedure("plan-20-1")
    with pytest.raises(ValueError, match="unknown procedure"):
        procedure("plan-1")


@pytest.mark.parametrize("structure", ["PID", "FPPI", "MSP"])
def test_plan_1_1_designs_with_the_base_rule_after_the_fixed_procedure(structure):
    fixed = gym.make(f"DeadTime/{structure}-v3")
    plan = gym.make(f"DeadTime/{structure}-v3", **PlanRule(1, 1).env_kwargs)
    for seed in range(3):
        fixed.reset(seed=seed)
        _, expected, *_ = fixed.step(np.zeros(1, dtype=np.float32))
        reward, _, steps = _play(plan, PlanRule(1, 1), seed)
        assert steps == 2 and reward == expected


@pytest.mark.parametrize("structure, second", [("PID", "open-loop-step"), ("FPPI", "open-loop-step"), ("MSP", "pulse")])
@pytest.mark.parametrize("noise_std", [0.01, 0.1])
def test_the_amplitude_rule_steps_at_ten_noise_levels(structure, second, noise_std):
    """Closed-loop step at 1, the second experiment at 10 sigma (sigma estimated), commit, base rule."""
    env = gym.make(f"DeadTime/{structure}-v3", **AmplitudeRule().env_kwargs, noise_std=noise_std)
    rule = AmplitudeRule().bind(tuning_env_of(env).feature_names, tuning_env_of(env).experiment_names)
    observation, _ = env.reset(seed=0)
    infos, done = [], False
    while not done:
        observation, reward, done, _, info = env.step(rule.predict(observation)[0])
        infos.append(info)
    assert [i.get("experiment") for i in infos[:2]] == ["closed-loop-step", second]
    estimated = episode_of(env).evidence.noise_estimate
    assert estimated == pytest.approx(noise_std, rel=0.2)  # the estimate's spread is ~5% (tests/envs/test_v3.py)
    assert infos[0]["amplitude"] == pytest.approx(1.0)
    wanted = min(max(10 * estimated, 0.1), 3.0)  # within the range, cut to v3's limit 3
    assert infos[1]["amplitude"] == pytest.approx(wanted, rel=1e-6)  # through a float32 action: about 1e-7 relative
    assert infos[2]["identified"] and len(infos) == 4 and infos[3]["cost"] == -reward
    assert episode_of(env).evidence.runs == 2


def test_the_amplitude_rule_needs_its_observation():
    with pytest.raises(ValueError, match="design step"):
        AmplitudeRule().bind(("tau",), ("closed-loop-step", "open-loop-step"))
    with pytest.raises(RuntimeError, match="bind"):
        AmplitudeRule().predict(np.zeros(3))
