"""The agent mode's discrete action: each index is one Box action, and the masks say which mean something."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import envs  # noqa: F401
from baselines.procedures import amplitude_action
from envs.discrete_action import AMPLITUDE_LEVELS, DESIGN_LEVELS
from envs.interface import tuning_env_of

STRUCTURES = ["PID", "FPPI", "MSP", "PI"]


def box_action(env, index: int) -> np.ndarray:
    """The Box action of the same meaning (amplitude through its log-scale component)."""
    meaning = env.discrete.meaning(index)
    names = env.experiment_names
    action = np.full(len(names) + 3, -1.0)
    action[-1] = 0.0
    if meaning.kind == "design":
        action[-1] = meaning.value
        action[0] = 1.0
        action[-2] = 0.0
    else:
        action[0 if meaning.kind == "commit" else 1 + names.index(meaning.kind)] = 1.0
        action[-2] = amplitude_action(meaning.value)
    return action


@pytest.mark.parametrize("structure", STRUCTURES)
def test_discrete_episodes_are_the_box_episodes_of_the_same_actions(structure: str) -> None:
    rng = np.random.default_rng(0)
    for episode in range(6):
        discrete = tuning_env_of(gym.make(f"DeadTime/{structure}-v3", experiments="agent", discrete_action=True, noise_std=0.05))
        box = tuning_env_of(gym.make(f"DeadTime/{structure}-v3", experiments="agent", noise_std=0.05))
        first, _ = discrete.reset(seed=episode)
        second, _ = box.reset(seed=episode)
        assert np.array_equal(first, second)
        done = False
        while not done:
            allowed = np.flatnonzero(discrete.action_masks())
            index = int(rng.choice(allowed))
            first, reward, done, _, info = discrete.step(index)
            second, reward_box, done_box, _, info_box = box.step(box_action(discrete, index))
            # amplitudes agree to the log scale's rounding; every amplitude level below the limit is exact
            assert info["action"] == discrete.discrete.meaning(index).name
            np.testing.assert_allclose(first, second, rtol=1e-9, atol=1e-12)
            assert reward == pytest.approx(reward_box, rel=1e-9, abs=1e-12) and done == done_box


def test_the_masks_follow_the_phase_the_budget_and_the_amplitude_limit() -> None:
    env = tuning_env_of(gym.make("DeadTime/PID-v3", experiments="agent", discrete_action=True, budget=1))
    env.reset(seed=0)
    levels, n = len(AMPLITUDE_LEVELS), len(env.experiment_names)
    masks = env.action_masks()
    assert masks.shape == (env.action_space.n,) and env.action_space.n == levels * (1 + n) + len(DESIGN_LEVELS)
    allowed_levels = [a <= 3.0 for a in AMPLITUDE_LEVELS]  # the v3 amplitude limit
    assert list(masks[:levels]) == allowed_levels and list(masks[levels:2 * levels]) == allowed_levels
    assert not masks[levels * (1 + n):].any()
    env.step(levels + AMPLITUDE_LEVELS.index(1.0))  # a closed-loop step at 1: the budget of one is spent
    masks = env.action_masks()
    assert list(masks[:levels]) == allowed_levels and not masks[levels:].any()
    _, _, done, _, info = env.step(AMPLITUDE_LEVELS.index(1.0))  # commit
    assert not done and info["identified"]
    masks = env.action_masks()
    assert not masks[: levels * (1 + n)].any() and masks[levels * (1 + n):].all()
    _, reward, done, _, info = env.step(levels * (1 + n) + DESIGN_LEVELS.index(0.0))
    assert done and info["parameter"] == pytest.approx(env.base_parameter())


def test_a_masked_index_acts_as_its_box_action() -> None:
    env = tuning_env_of(gym.make("DeadTime/FPPI-v3", experiments="agent", discrete_action=True))
    env.reset(seed=3)
    levels, n = len(AMPLITUDE_LEVELS), len(env.experiment_names)
    _, _, done, _, info = env.step(levels * (1 + n))  # a design level before the design step: commit at 1
    assert not done and info["identified"] and info["amplitude"] == 1.0
    _, _, done, _, info = env.step(levels)  # an experiment in the design step: the base rule's design
    assert done and info["parameter"] == pytest.approx(env.base_parameter())


@pytest.mark.parametrize("action", [-1, 41, 1.0, True, np.array([1, 2]), "3"])
def test_a_bad_index_is_one_line(action) -> None:
    env = tuning_env_of(gym.make("DeadTime/PID-v3", experiments="agent", discrete_action=True))
    env.reset(seed=0)
    with pytest.raises(ValueError, match="action must be one integer index from 0 to 40"):
        env.step(action)


@pytest.mark.parametrize("kwargs, message", [
    ({"experiments": "fixed", "discrete_action": True}, "discrete_action needs experiments='agent'"),
    ({"experiments": "agent", "discrete_action": "yes"}, "discrete_action must be true or false"),
])
def test_a_bad_argument_is_one_line(kwargs, message) -> None:
    with pytest.raises(ValueError, match=message):
        gym.make("DeadTime/PID-v3", **kwargs)


def test_box_environments_have_no_masks_and_the_discrete_one_passes_the_checker() -> None:
    with pytest.raises(RuntimeError, match="needs discrete_action=True"):
        tuning_env_of(gym.make("DeadTime/PID-v3", experiments="agent")).action_masks()
    check_env(gym.make("DeadTime/MSP-v3", experiments="agent", discrete_action=True).unwrapped, skip_render_check=True)
