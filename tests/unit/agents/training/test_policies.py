"""``load_policy``: what it refuses, with a message naming the path (no torch needed for these)."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.training.policies import load_policy, resolve_model_path


def test_missing_and_unreadable_agents_are_named(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="no trained agent"):
        resolve_model_path(tmp_path / "nothing.zip")
    with pytest.raises(ValueError, match="best_model.zip or model.zip"):
        resolve_model_path(tmp_path)
    (tmp_path / "model.zip").write_text("not a zip")
    with pytest.raises(ValueError, match="not a stable-baselines3 model"):
        load_policy(tmp_path)


def test_run_directory_prefers_the_best_model(tmp_path: Path) -> None:
    import zipfile

    for name in ("model.zip", "best_model.zip"):
        with zipfile.ZipFile(tmp_path / name, "w") as archive:
            archive.writestr("data", "{}")
    assert resolve_model_path(tmp_path) == tmp_path / "best_model.zip"
    assert resolve_model_path(tmp_path / "model") == tmp_path / "model.zip"


def test_a_checkpoint_takes_the_statistics_and_config_of_its_run(tmp_path: Path) -> None:
    """``<run>/checkpoints/model_<N>.zip`` pairs with ``vecnormalize_<N>.pkl`` and ``<run>/config.yaml``."""
    import pickle
    import shutil

    import gymnasium
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    import envs  # noqa: F401  (registers the ids)

    checkpoints = tmp_path / "run" / "checkpoints"
    checkpoints.mkdir(parents=True)
    venv = VecNormalize(DummyVecEnv([lambda: gymnasium.make("DeadTime/PID-v0")]))
    PPO("MlpPolicy", venv, n_steps=8, batch_size=8, device="cpu").save(checkpoints / "model_64.zip")
    with (checkpoints / "vecnormalize_64.pkl").open("wb") as handle:
        pickle.dump(venv, handle)
    shutil.copy(Path(__file__).resolve().parents[4] / "configs" / "ppo.yaml", tmp_path / "run" / "config.yaml")
    loaded = load_policy(checkpoints / "model_64.zip")
    assert loaded.normalization is not None and not loaded.normalization.training
    assert loaded.algorithm == "PPO" and loaded.config is not None and loaded.name == "run"
