"""Shared test helpers of the training tests."""

from __future__ import annotations

import os
import signal

import pytest


@pytest.fixture
def sigint_at():
    """A callback class: ``sigint_at(step)`` sends SIGINT to this process (as Ctrl-C would) when the
    model reaches ``step`` timesteps."""
    from stable_baselines3.common.callbacks import BaseCallback

    class SigintAt(BaseCallback):
        def __init__(self, step: int) -> None:
            super().__init__()
            self.step = step

        def _on_step(self) -> bool:
            if self.model.num_timesteps == self.step:
                os.kill(os.getpid(), signal.SIGINT)
            return True

    return SigintAt


def save_tiny_agent(directory, *, legacy: bool = False, env_id: str = "DeadTime/FPPI-v0", steps: int = 16):
    """A tiny PPO on normalized observations, trained ``steps`` steps and saved in ``directory`` with its
    run's ``config.yaml``, as ``deadtime train`` saves its models; ``legacy``: as older runs did (the
    statistics pickled in ``model.vecnormalize.pkl`` and recorded in the manifest).  Returns
    ``(directory, model, vecnormalize)``."""
    import pickle
    from pathlib import Path

    import yaml
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from agents.environments import make_env
    from agents.files.writer import atomic_write
    from agents.training.callbacks import save_model
    from agents.training.config import TrainConfig
    from agents.training.manifest import write_manifest
    from agents.training.train import new_model

    directory = Path(directory)
    directory.mkdir(parents=True, exist_ok=True)
    config = TrainConfig(algorithm="PPO", env_id=env_id, total_timesteps=steps, normalize=True,
                         policy_kwargs={"net_arch": [4]}, hyperparameters={"n_steps": 8, "batch_size": 8})
    (directory / "config.yaml").write_text(yaml.safe_dump(config.to_dict(), sort_keys=False))
    venv = VecNormalize(DummyVecEnv([lambda: make_env(env_id, {})]))
    model = new_model(config, venv)
    model.deadtime_vecnormalize = True
    model.learn(steps)
    if legacy:
        path = atomic_write(directory / "model.zip", model.save)
        statistics = atomic_write(directory / "model.vecnormalize.pkl", lambda handle: pickle.dump(venv, handle))
        write_manifest(path, [path, statistics])
    else:
        save_model(model, directory / "model.zip", venv)
    return directory, model, venv


@pytest.fixture(scope="module")
def tiny_agent(tmp_path_factory: pytest.TempPathFactory):
    """``save_tiny_agent`` in a fresh folder, once per module."""
    return save_tiny_agent(tmp_path_factory.mktemp("agent") / "run")


@pytest.fixture
def agent_saver():
    """:func:`save_tiny_agent`, to save one in a test's own folder."""
    return save_tiny_agent
