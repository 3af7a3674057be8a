"""The sequential agent: MaskablePPO on the agent mode's discrete action, trained, loaded and played
with the environment's masks."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401
from agents.cli import main
from agents.training.config import load_config
from envs.interface import tuning_env_of

SMALL = ["total_timesteps=128", "eval_freq=64", "n_eval_episodes=4", "checkpoint_freq=64", "progress_bar=false",
         "hyperparameters.n_steps=64", "hyperparameters.batch_size=32", "hyperparameters.n_epochs=2"]


@pytest.mark.parametrize("spelling", ["MaskablePPO", "maskableppo", "MASKABLEPPO"])
def test_the_config_names_maskableppo_in_any_case(spelling: str) -> None:
    config = load_config("configs/sequential.yaml", env_id="DeadTime/FPPI-v3", overrides=[f"algorithm={spelling}"])
    assert config.algorithm == "MaskablePPO" and config.env_kwargs["discrete_action"] is True
    assert config.run_name == "maskableppo-FPPI-v3-s0"


@pytest.mark.slow
def test_a_trained_sequential_agent_loads_and_plays_only_allowed_actions(tmp_path: Path) -> None:
    from agents.evaluation.run import agent_action
    from agents.training.policies import load_policy

    run = tmp_path / "seq"
    status = main(["train", "--config", "configs/sequential.yaml", "--env", "DeadTime/MSP-v3", "--out", str(run), *SMALL])
    assert status == 0 and (run / "model.zip").is_file()
    policy = load_policy(run)
    assert policy.algorithm == "MaskablePPO"
    env = tuning_env_of(gym.make("DeadTime/MSP-v3", experiments="agent", discrete_action=True, noise_std=0.1))
    for seed in range(5):
        observation, _ = env.reset(seed=seed)
        done = False
        while not done:
            masks = env.action_masks()
            action = agent_action(env, policy, observation)
            assert isinstance(action, int) and masks[action]
            observation, _, done, _, info = env.step(action)
        assert np.isfinite(info["cost"])
    from agents.studies.sequential_replay import replay

    table = replay([run], 4, tmp_path / "replay")
    assert "| seq | all | 4 |" in table and (tmp_path / "replay" / "replay.png").is_file()


def test_the_replay_table_groups_episodes_by_thirds_of_the_measured_noise() -> None:
    from agents.studies.sequential_replay import summarize

    quiet = {"actions": ["closed-loop-step@1", "open-loop-step@0.3", "commit@1", "design@0.2"], "sigma": 0.01,
             "cost": 2.0, "feasible": True}
    noisy = {"actions": ["closed-loop-step@3", "relay@1", "open-loop-step@3", "commit@3", "design@-0.4"], "sigma": 0.12,
             "cost": 5.0, "feasible": False}
    middle = {**quiet, "sigma": 0.05}
    rows = summarize([quiet, middle, noisy, quiet, middle, noisy])
    assert [row["episodes"] for row in rows] == [2, 2, 2, 6] and rows[-1]["noise"] == "all"
    assert rows[0]["experiments"] == 2 and rows[0]["second_amplitude"] == 0.3
    assert rows[2]["shares"] == pytest.approx({"closed-loop-step": 1 / 3, "open-loop-step": 1 / 3, "relay": 1 / 3})
    assert rows[-1]["design_level"] == pytest.approx((4 * 0.2 - 2 * 0.4) / 6) and rows[-1]["violating"] == pytest.approx(1 / 3)
