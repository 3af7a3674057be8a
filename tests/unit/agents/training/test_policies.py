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


def test_a_checkpoint_takes_the_statistics_and_config_of_its_run(tmp_path: Path, agent_saver) -> None:
    """``<run>/checkpoints/model_<N>.zip`` pairs with ``normalization_<N>.json``, its checkpoint's manifest
    and ``<run>/config.yaml``."""
    import json
    import shutil

    from agents.files.writer import file_digest

    run, _, _ = agent_saver(tmp_path / "run")
    checkpoints = run / "checkpoints"
    checkpoints.mkdir()
    shutil.copy(run / "model.zip", checkpoints / "model_64.zip")
    shutil.copy(run / "model.normalization.json", checkpoints / "normalization_64.json")
    files = {name: {"bytes": (checkpoints / name).stat().st_size, "sha256": file_digest(checkpoints / name)}
             for name in ("model_64.zip", "normalization_64.json")}
    (checkpoints / "checkpoint_64.json").write_text(json.dumps({"num_timesteps": 64, "model": "model_64.zip", "files": files}))
    loaded = load_policy(checkpoints / "model_64.zip")
    assert loaded.normalization is not None
    assert loaded.algorithm == "PPO" and loaded.config is not None and loaded.name == "run"


def test_an_older_checkpoints_pickled_statistics_are_refused_naming_the_runs_models(tmp_path: Path, agent_saver) -> None:
    import json
    import shutil

    from agents.files.writer import file_digest

    run, _, _ = agent_saver(tmp_path / "run", legacy=True)
    checkpoints = run / "checkpoints"
    checkpoints.mkdir()
    shutil.copy(run / "model.zip", checkpoints / "model_64.zip")
    shutil.copy(run / "model.vecnormalize.pkl", checkpoints / "vecnormalize_64.pkl")
    files = {name: {"bytes": (checkpoints / name).stat().st_size, "sha256": file_digest(checkpoints / name)}
             for name in ("model_64.zip", "vecnormalize_64.pkl")}
    (checkpoints / "checkpoint_64.json").write_text(json.dumps({"num_timesteps": 64, "model": "model_64.zip", "files": files}))
    with pytest.raises(ValueError, match=f"vecnormalize_64.pkl is a pickle, which is not loaded .*convert-model {run} --trust"):
        load_policy(checkpoints / "model_64.zip")
