"""The cost of committing at once at amplitude ``A`` in ``FPPI-v2``'s agent mode (the table of
docs/environments/overview.md, v2): the fixed procedure's two steps at ``A``, then the base rule's design (action 0), on
the first 60 validation plants, episode seed = plant index.

    deadtime study commit-amplitude
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np

import envs  # noqa: F401  (registers the ids)
from envs.systems.plant_sets import plant_set
from envs.tuning_env import AMPLITUDE_RANGE


def amplitude_action(amplitude: float) -> float:
    low, high = (math.log10(v) for v in AMPLITUDE_RANGE)
    return 2.0 * (math.log10(amplitude) - low) / (high - low) - 1.0


def mean_cost(noise: float, production: float, amplitude: float, plants: list) -> float:
    env = gym.make("DeadTime/FPPI-v2", experiments="agent", noise_std=noise, weights={"production": production})
    costs = []
    for index, plant in enumerate(plants):
        env.reset(seed=index, options={"plant": plant})
        action = np.full(env.action_space.shape, -1.0, dtype=np.float32)
        action[0], action[-2], action[-1] = 1.0, amplitude_action(amplitude), 0.0
        env.step(action)  # the commit: the fixed procedure's steps at the amplitude
        costs.append(env.step(action)[4]["cost"])  # the design at the base rule
    return float(np.mean(costs))


def commit_amplitude() -> None:
    """Print the mean cost of committing at amplitude 0.3, 1 and 3 in each noise and price regime."""
    plants = plant_set("stable", "validation", 60)
    for noise in (0.01, 0.1):
        for production in (0.0, 0.05):
            row = [f"{mean_cost(noise, production, a, plants):.3f}" for a in (0.3, 1.0, 3.0)]
            print(f"noise {noise:.0%}, production {production}: A = 0.3, 1, 3: {', '.join(row)}")
