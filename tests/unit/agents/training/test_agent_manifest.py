"""The manifest of a saved agent (agents.training.manifest): written by ``save_model``, checked by
``load_policy`` before anything of the folder is unpickled."""

from __future__ import annotations

import json
import pickle
import shutil
from pathlib import Path

import pytest

from agents.cli import main


@pytest.fixture(scope="module")
def saved(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A tiny PPO with ``VecNormalize`` statistics, saved as ``deadtime train`` saves its models."""
    import gymnasium
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    import envs  # noqa: F401  (registers the ids)
    from agents.training.callbacks import save_model

    directory = tmp_path_factory.mktemp("agent")
    venv = VecNormalize(DummyVecEnv([lambda: gymnasium.make("DeadTime/FPPI-v0")]))
    model = PPO("MlpPolicy", venv, n_steps=8, batch_size=8, device="cpu", policy_kwargs={"net_arch": [4]})
    model.deadtime_vecnormalize = True
    save_model(model, directory / "model.zip", venv)
    return directory


def _copy(saved: Path, tmp_path: Path) -> Path:
    copy = tmp_path / "agent"
    shutil.copytree(saved, copy)
    return copy


def test_save_model_records_the_model_and_its_statistics(saved: Path) -> None:
    from agents.files.writer import file_digest
    from agents.training.policies import load_policy

    manifest = json.loads((saved / "model.manifest.json").read_text())
    assert manifest["files"] == {name: {"bytes": (saved / name).stat().st_size, "sha256": file_digest(saved / name)}
                                 for name in ("model.zip", "model.vecnormalize.pkl")}
    assert load_policy(saved / "model.zip").normalization is not None


def _replaced_statistics(copy: Path) -> str:
    with (copy / "model.vecnormalize.pkl").open("wb") as handle:
        pickle.dump({"not": "the saved statistics"}, handle)
    return "model.vecnormalize.pkl differs from the file recorded in"


def _appended_model(copy: Path) -> str:
    with (copy / "model.zip").open("ab") as handle:
        handle.write(b"\0")
    return "model.zip differs from the file recorded in"


def _garbage_manifest(copy: Path) -> str:
    (copy / "model.manifest.json").write_text("{")
    return "model.manifest.json is damaged: not valid JSON"


def _statistics_beside_a_model_without_them(copy: Path) -> str:
    manifest = json.loads((copy / "model.manifest.json").read_text())
    del manifest["files"]["model.vecnormalize.pkl"]
    (copy / "model.manifest.json").write_text(json.dumps(manifest))
    return "model.vecnormalize.pkl is not recorded in"


DAMAGES = [_replaced_statistics, _appended_model, _garbage_manifest, _statistics_beside_a_model_without_them]


@pytest.mark.parametrize("damage", DAMAGES, ids=lambda f: f.__name__.strip("_"))
def test_a_file_that_differs_from_its_manifest_is_refused_before_unpickling(saved: Path, tmp_path: Path, capsys,
                                                                          monkeypatch, damage) -> None:
    copy = _copy(saved, tmp_path)
    message = damage(copy)

    def no_unpickling(*args, **kwargs):
        raise AssertionError("a file was unpickled")

    monkeypatch.setattr(pickle, "load", no_unpickling)
    status = main(["evaluate", "--env", "DeadTime/FPPI-v0", "--policies", f"agent={copy}", "--n", "1",
                   "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert status == 2
    assert err.count("\n") == 1 and message in err and str(copy) in err, err
    assert not (tmp_path / "out").exists()


def test_a_checkpoint_model_is_checked_against_its_checkpoint_manifest(saved: Path, tmp_path: Path) -> None:
    from agents.files.writer import file_digest
    from agents.training.policies import load_policy

    checkpoints = tmp_path / "run" / "checkpoints"
    checkpoints.mkdir(parents=True)
    shutil.copy(saved / "model.zip", checkpoints / "model_64.zip")
    shutil.copy(saved / "model.vecnormalize.pkl", checkpoints / "vecnormalize_64.pkl")
    files = {name: {"bytes": (checkpoints / name).stat().st_size, "sha256": file_digest(checkpoints / name)}
             for name in ("model_64.zip", "vecnormalize_64.pkl")}
    (checkpoints / "checkpoint_64.json").write_text(json.dumps({"num_timesteps": 64, "model": "model_64.zip", "files": files}))
    assert load_policy(checkpoints / "model_64.zip").normalization is not None
    _replaced = checkpoints / "vecnormalize_64.pkl"
    _replaced.write_bytes(_replaced.read_bytes() + b"\0")
    with pytest.raises(ValueError, match="vecnormalize_64.pkl differs from the file recorded in .*checkpoint_64.json"):
        load_policy(checkpoints / "model_64.zip")
