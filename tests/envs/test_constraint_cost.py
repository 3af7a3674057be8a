"""The constraint cost of :class:`envs.tuning_env.ConstraintCost`: on every v3 structure and mode, every
step's info has ``constraint_cost`` in {0, 1}, 1 exactly on the final step of an episode whose design is
infeasible (or missing), cross-checked against the score's own violations; reward, observation and the
other keys are those of the unwrapped environment, bit for bit."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401
from envs.tuning_env import ConstraintCost, constraint_cost

IDS = ("DeadTime/PID-v3", "DeadTime/FPPI-v3", "DeadTime/MSP-v3", "DeadTime/PI-v3")


def _play(env: gym.Env, seed: int) -> list[tuple]:
    actions = np.random.default_rng(seed)
    observation, _ = env.reset(seed=seed)
    steps, done = [(observation.tolist(),)], False
    while not done:
        action = actions.uniform(-1.0, 1.0, env.action_space.shape).astype(np.float32)
        observation, reward, terminated, truncated, info = env.step(action)
        steps.append((observation.tolist(), reward, terminated, truncated, info))
        done = terminated or truncated
    return steps


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("mode", ["fixed", "agent"])
def test_the_key_is_the_violation_and_nothing_else_changes(env_id: str, mode: str) -> None:
    violated = 0
    for seed in range(6 if mode == "fixed" else 2):
        plain = _play(gym.make(env_id, experiments=mode), seed)
        wrapped = _play(ConstraintCost(gym.make(env_id, experiments=mode)), seed)
        assert len(plain) == len(wrapped)
        for before, after in zip(plain[1:], wrapped[1:]):
            assert before[:4] == after[:4]  # observation, reward, terminated, truncated
            info = dict(after[4])
            cost = info.pop("constraint_cost")
            assert cost in (0.0, 1.0) and isinstance(cost, float)
            assert info.keys() == before[4].keys()
            if not after[2]:
                assert cost == 0.0
            else:  # the score's violations (or no design at all) say the same
                score = info.get("score")
                expected = 1.0 if score is None else float(bool(score["violations"]))
                assert cost == expected
                violated += int(cost)
    assert violated <= 6


def test_constraint_cost_reads_feasible() -> None:
    assert constraint_cost({"feasible": True, "cost": 3.0}) == 0.0
    assert constraint_cost({"feasible": False, "cost": 23.0}) == 1.0
    assert constraint_cost({"experiment": "pulse"}) == 0.0
