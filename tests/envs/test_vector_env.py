"""The native vector environments (:mod:`envs.vector_env`).

* Bit-identical episodes: slot ``i`` of ``gymnasium.make_vec(id, N)`` reset with seed ``s + i``
  gives, over several same-step autoresets, exactly the observations, rewards, terminations and
  costs of ``gymnasium.make(id)`` reset once with ``s + i`` and then reset without a seed, given the
  same actions (every structure, v0, v1 and v2 ids).
* The checks Gymnasium 1.4 has for a vector environment: spaces batched from the single spaces,
  observations inside them, the ``autoreset_mode`` metadata, determinism under a seed, returned
  arrays not reused (1.4 has no ``check_env`` for vector environments; these are its single-env
  checks stated for the batch).
* Refusals: agent mode, bad action shapes and values, bad seeds.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

import envs  # noqa: F401  (registers the ids)
from envs.vector_env import DeadTimeVectorEnv

IDS = [f"DeadTime/{s}-v{v}" for v in (0, 1, 2) for s in ("PID", "FPPI", "MSP")]
N, ROUNDS, SEED = 3, 3, 11


def _actions(rounds: int, n: int, seed: int = 0) -> np.ndarray:
    """Actions in and beyond [-1, 1] (the clip is part of what must agree)."""
    return np.random.default_rng(seed).uniform(-1.3, 1.3, size=(rounds, n, 1)).astype(np.float32)


@pytest.mark.parametrize("env_id", IDS)
def test_vector_env_gives_the_episodes_of_single_envs_bit_for_bit(env_id):
    actions = _actions(ROUNDS, N)
    vec = gym.make_vec(env_id, num_envs=N)
    assert isinstance(vec.unwrapped, DeadTimeVectorEnv)
    observations, _ = vec.reset(seed=SEED)
    vector = {"obs": [observations], "reward": [], "terminated": [], "cost": [], "final_obs": []}
    for k in range(ROUNDS):
        observations, rewards, terminated, truncated, infos = vec.step(actions[k])
        assert not truncated.any()
        vector["obs"].append(observations)
        vector["reward"].append(rewards)
        vector["terminated"].append(terminated)
        vector["cost"].append(infos["final_info"]["cost"])
        vector["final_obs"].append(np.stack(infos["final_obs"]))
    for i in range(N):
        env = gym.make(env_id)
        first, _ = env.reset(seed=SEED + i)
        np.testing.assert_array_equal(vector["obs"][0][i], first)
        for k in range(ROUNDS):
            final, reward, terminated, _, info = env.step(actions[k][i])
            assert reward == vector["reward"][k][i] and info["cost"] == vector["cost"][k][i]
            assert terminated == vector["terminated"][k][i]
            np.testing.assert_array_equal(vector["final_obs"][k][i], final)
            np.testing.assert_array_equal(vector["obs"][k + 1][i], env.reset()[0])
    vec.close()


@pytest.mark.parametrize("env_id", ["DeadTime/PID-v0", "DeadTime/MSP-v1", "DeadTime/FPPI-v2"])
def test_vector_checks(env_id):
    vec = gym.make_vec(env_id, num_envs=4)
    single = gym.make(env_id)
    assert vec.metadata["autoreset_mode"] is AutoresetMode.SAME_STEP
    assert vec.single_observation_space == single.observation_space
    assert vec.single_action_space == single.action_space
    assert vec.observation_space.shape == (4, *single.observation_space.shape)
    assert vec.action_space.shape == (4, *single.action_space.shape)
    first, info = vec.reset(seed=3)
    assert isinstance(info, dict) and first in vec.observation_space
    vec.action_space.seed(0)
    action = vec.action_space.sample()
    observations, rewards, terminated, truncated, infos = vec.step(action)
    assert observations in vec.observation_space and observations is not first
    assert rewards.shape == terminated.shape == truncated.shape == (4,)
    assert rewards.dtype == np.float64 and terminated.dtype == truncated.dtype == np.bool_
    assert set(infos["final_info"]) >= {"cost", "_cost", "feasible", "parameter", "experiment_time"}
    assert all(infos["_final_obs"]) and all(o in vec.single_observation_space for o in infos["final_obs"])
    again = gym.make_vec(env_id, num_envs=4)
    np.testing.assert_array_equal(again.reset(seed=3)[0], first)
    np.testing.assert_array_equal(again.step(action)[1], rewards)
    other = again.reset(seed=4)[0]
    assert not np.array_equal(other, first)


def test_seed_list_and_unseeded_reset_continue_each_slot():
    vec = gym.make_vec("DeadTime/PID-v0", num_envs=2)
    by_list, _ = vec.reset(seed=[5, 9])
    env = gym.make("DeadTime/PID-v0")
    np.testing.assert_array_equal(by_list[1], env.reset(seed=9)[0])
    np.testing.assert_array_equal(vec.reset()[0][1], env.reset()[0])


def test_agent_mode_and_render_are_refused():
    with pytest.raises(ValueError, match="experiments: the native vector environment runs the fixed mode only"):
        gym.make_vec("DeadTime/PID-v0", num_envs=2, experiments="agent")
    with pytest.raises(ValueError, match="render_mode"):
        gym.make_vec("DeadTime/PID-v0", num_envs=2, render_mode="rgb_array")
    with pytest.raises(ValueError, match="num_envs"):
        DeadTimeVectorEnv(num_envs=0)


@pytest.mark.parametrize("bad, message", [
    (np.zeros((3, 1)), "shape"), (np.array([[0.0], [np.nan]]), "finite"),
])
def test_bad_actions_and_seeds_are_refused(bad, message):
    vec = gym.make_vec("DeadTime/PID-v0", num_envs=2)
    with pytest.raises(RuntimeError, match="before reset"):
        vec.step(np.zeros((2, 1)))
    vec.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        vec.step(bad)
    with pytest.raises(ValueError, match="one seed per slot"):
        vec.reset(seed=[1, 2, 3])
