"""Shared helpers of the environment tests."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest


def _play(env: gym.Env, seed: int, actions: list[np.ndarray], plant=None):
    """One episode with the given actions (the last one repeated): observations, rewards, final info."""
    options = None if plant is None else {"plant": plant}
    observations = [env.reset(seed=seed, options=options)[0]]
    rewards, k = [], 0
    while True:
        observation, reward, terminated, truncated, info = env.step(actions[min(k, len(actions) - 1)])
        observations.append(observation)
        rewards.append(reward)
        k += 1
        if terminated or truncated:
            return observations, rewards, info


@pytest.fixture
def play():
    """:func:`_play`: ``play(env, seed, actions, plant=None) -> (observations, rewards, info)``."""
    return _play
