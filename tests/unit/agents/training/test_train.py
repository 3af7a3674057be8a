"""Training end to end (slow): the command line, determinism, and resuming an interrupted run.

One test trains on ``DeadTime/PID-v0`` (fixed mode) and evaluates the agent on validation plants;
the mechanics (artefacts, determinism, checkpoints and resume, every algorithm) are the same for any
environment and are tested on Gymnasium's ``Pendulum-v1``, whose steps cost microseconds instead of
the tenths of a second of an identification experiment.  The runs are tiny (tens to a few hundred
steps); no test looks at the wall-clock time.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from agents.cli import main
from agents.training.config import load_config

pytestmark = pytest.mark.slow


CONFIG = """
default:
  env_id: Pendulum-v1
  total_timesteps: 192
  seed: 5
  normalize: true
  n_eval_episodes: 3
  eval_freq: 64
  checkpoint_freq: 64
  progress_bar: false
  policy_kwargs: {net_arch: [16, 16]}
"""
HYPERPARAMETERS = {
    "ppo": "{n_steps: 32, batch_size: 32, n_epochs: 2}",
    "a2c": "{n_steps: 8}",
    "sac": "{learning_starts: 32, buffer_size: 1000, batch_size: 32}",
    "td3": "{learning_starts: 32, buffer_size: 1000, batch_size: 32, action_noise: {type: normal, sigma: 0.2}}",
}


def _config(tmp_path: Path, algorithm: str) -> Path:
    path = tmp_path / f"{algorithm}.yaml"
    path.write_text(CONFIG + f"  hyperparameters: {HYPERPARAMETERS[algorithm]}\n")
    return path


def _parameters(run_dir: Path, name: str = "model.zip") -> list[np.ndarray]:
    from agents.training.policies import load_policy

    policy = load_policy(run_dir / name)
    return [p.detach().numpy().copy() for p in policy.model.policy.parameters()]


def _episode_costs(run_dir: Path, n: int = 3) -> list[float]:
    """The loaded agent's costs on a few episodes (seeds 0..n-1) of its training environment."""
    from agents.training.callbacks import validate_policy, validation_plants
    from agents.training.policies import load_policy
    from agents.environments import make_env

    policy = load_policy(run_dir)
    env = make_env(policy.env_id, policy.env_kwargs)
    plants = validation_plants(env, n)
    result = validate_policy(lambda o: policy.predict(o)[0], env, n, plants)
    return list(result.costs)


def test_deadtime_agent_trains_from_the_command_line_deterministically(tmp_path: Path) -> None:
    """A tiny PPO agent on DeadTime/PID-v0, twice with one seed: same agent, same validation costs."""
    config = Path(__file__).resolve().parents[4] / "configs" / "ppo.yaml"
    tiny = ["total_timesteps=32", "hyperparameters.n_steps=16", "hyperparameters.batch_size=16",
            "hyperparameters.n_epochs=2", "eval_freq=16", "n_eval_episodes=2", "checkpoint_freq=16",
            "progress_bar=false", "seed=3"]
    runs = [tmp_path / "a", tmp_path / "b"]
    for run_dir in runs:
        assert main(["train", "--config", str(config), "--env", "DeadTime/PID-v0", "--out", str(run_dir), *tiny]) == 0
    evaluations = [json.loads((run_dir / "evaluations.json").read_text()) for run_dir in runs]
    assert evaluations[0] == evaluations[1]
    assert [e["num_timesteps"] for e in evaluations[0]] == [16, 32]
    assert all(e["violation_rate"] is not None for e in evaluations[0])  # the environment's own cost and feasibility
    first, second = (_parameters(run_dir) for run_dir in runs)
    assert all(np.array_equal(a, b) for a, b in zip(first, second))

    from agents.training.policies import load_policy

    policy = load_policy(runs[0])
    assert (policy.algorithm, policy.env_id, policy.env_kwargs) == ("PPO", "DeadTime/PID-v0", {"experiments": "fixed"})
    costs = _episode_costs(runs[0], 2)
    assert costs == _episode_costs(runs[1], 2) and all(np.isfinite(costs))

    # deadtime evaluate with the agents beside a rule and the oracle: identical numbers for both runs
    results = []
    for run_dir in runs:
        out = tmp_path / f"eval-{run_dir.name}"
        assert main(["evaluate", "--env", "DeadTime/PID-v0", "--policies", f"agent={run_dir},gorez-klan-mu-3",
                     "--n", "2", "--seed", "0", "--out", str(out), "--no-benchmark", "--no-plots"]) == 0
        results.append(json.loads((out / "results.json").read_text()))
    agents = [next(p for p in r["policies"] if p["name"] == "agent") for r in results]
    assert agents[0] == agents[1] and np.isfinite(agents[0]["mean_cost"])


@pytest.mark.parametrize("algorithm", ["ppo", "sac", "td3", "a2c"])
def test_train_from_the_command_line_and_load(tmp_path: Path, algorithm: str, capsys: Any) -> None:
    run_dir = tmp_path / "run"
    assert main(["train", "--config", str(_config(tmp_path, algorithm)), "--out", str(run_dir), "seed=2"]) == 0
    printed = capsys.readouterr().out
    assert "seed: 2" in printed and "agent:" in printed  # the resolved config, then where the agent is
    for name in ("model.zip", "best_model.zip", "config.yaml", "run.json", "evaluations.json",
                 "model.normalization.json", "best_model.normalization.json"):
        assert (run_dir / name).is_file(), name
    assert any((run_dir / "tensorboard").rglob("events.out.tfevents.*"))
    record = json.loads((run_dir / "run.json").read_text())
    assert record["status"] == "finished" and record["num_timesteps"] == 192
    assert record["command"].startswith("deadtime train --config") and "torch" in record["versions"]
    saved = load_config(run_dir / "config.yaml")
    assert saved.seed == 2 and saved.algorithm == algorithm.upper()
    assert "# commit:" in (run_dir / "config.yaml").read_text()
    evaluations = json.loads((run_dir / "evaluations.json").read_text())
    assert [e["num_timesteps"] for e in evaluations] == [64, 128, 192]  # periodic, then the final model once
    checkpoints = json.loads((run_dir / "checkpoints" / "latest.json").read_text())
    if algorithm in ("sac", "td3"):
        assert (run_dir / "checkpoints" / checkpoints["replay_buffer"]).is_file()

    from agents.training.policies import load_policy
    from agents.environments import make_env

    policy = load_policy(run_dir)
    assert policy.algorithm == algorithm.upper() and policy.name == "run"
    assert policy.path.name == "best_model.zip"
    env = make_env(policy.env_id, policy.env_kwargs)
    observation, _ = env.reset(seed=0)
    action, _ = policy.predict(observation)
    assert env.action_space.contains(np.asarray(action, dtype=np.float32))
    assert all(np.isfinite(_episode_costs(run_dir)))


def test_existing_run_needs_resume(tmp_path: Path, capsys: Any) -> None:
    run_dir = tmp_path / "run"
    config = str(_config(tmp_path, "a2c"))
    assert main(["train", "--config", config, "--out", str(run_dir), "total_timesteps=16", "eval_freq=0"]) == 0
    assert main(["train", "--config", config, "--out", str(run_dir), "total_timesteps=16", "eval_freq=0"]) == 2
    assert "--resume" in capsys.readouterr().err
    assert main(["train", "--config", config, "--out", str(run_dir), "--resume", "total_timesteps=16", "seed=9"]) == 2
    assert "seed" in capsys.readouterr().err


def test_same_seed_same_agent(tmp_path: Path) -> None:
    config = str(_config(tmp_path, "ppo"))
    runs = [tmp_path / "a", tmp_path / "b", tmp_path / "c"]
    for run_dir, seed in zip(runs, (1, 1, 2)):
        assert main(["train", "--config", config, "--out", str(run_dir), f"seed={seed}"]) == 0
    first, second, other = (_parameters(run_dir) for run_dir in runs)
    assert all(np.array_equal(a, b) for a, b in zip(first, second))
    assert not all(np.array_equal(a, b) for a, b in zip(first, other))
    evaluations = [json.loads((run_dir / "evaluations.json").read_text()) for run_dir in runs[:2]]
    assert evaluations[0] == evaluations[1]
    assert _episode_costs(runs[0]) == _episode_costs(runs[1])


@pytest.mark.parametrize("algorithm", ["ppo", "sac"])
def test_interrupted_run_resumes_to_the_same_number_of_steps(tmp_path: Path, algorithm: str) -> None:
    from stable_baselines3.common.callbacks import BaseCallback

    from agents.training.train import train

    class Interrupt(BaseCallback):
        def _on_step(self) -> bool:
            if self.model.num_timesteps >= 150:
                raise KeyboardInterrupt
            return True

    path = _config(tmp_path, algorithm)
    uninterrupted = tmp_path / "whole"
    assert main(["train", "--config", str(path), "--out", str(uninterrupted)]) == 0
    run_dir = tmp_path / "part"
    config = load_config(path, overrides=[f"output_dir={run_dir}"])
    with pytest.raises(KeyboardInterrupt):
        train(config, callbacks=[Interrupt()])
    assert json.loads((run_dir / "run.json").read_text())["status"] == "interrupted"
    assert not (run_dir / "model.zip").exists()
    checkpoint = json.loads((run_dir / "checkpoints" / "latest.json").read_text())
    assert 0 < checkpoint["num_timesteps"] < 150

    assert main(["train", "--out", str(run_dir), "--resume"]) == 0  # the config comes from the run
    whole = json.loads((uninterrupted / "run.json").read_text())
    resumed = json.loads((run_dir / "run.json").read_text())
    assert resumed["status"] == "finished"
    assert resumed["num_timesteps"] == whole["num_timesteps"] == 192
    assert [s["from_timesteps"] for s in resumed["segments"]] == [0, checkpoint["num_timesteps"]]
    from agents.training.policies import load_policy

    assert load_policy(run_dir / "model.zip").model.num_timesteps == 192
    evaluations = json.loads((run_dir / "evaluations.json").read_text())
    steps = [e["num_timesteps"] for e in evaluations]
    assert steps == sorted(steps) and steps[-1] == 192

    assert main(["train", "--out", str(run_dir), "--resume"]) == 0  # finished: nothing to do
    assert len(json.loads((run_dir / "run.json").read_text())["segments"]) == 2
    assert main(["train", "--out", str(run_dir), "--resume", "total_timesteps=256"]) == 0  # extended
    assert json.loads((run_dir / "run.json").read_text())["num_timesteps"] == 256
    assert load_policy(run_dir / "model.zip").model.num_timesteps == 256
