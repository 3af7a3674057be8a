"""The manifest of a saved agent (agents.training.manifest): written by ``save_model``, checked by
``load_policy`` before anything of the folder is read."""

from __future__ import annotations

import json
import pickle
import shutil
from pathlib import Path

import pytest

from agents.cli import main


def _copy(saved: Path, tmp_path: Path) -> Path:
    copy = tmp_path / "agent"
    shutil.copytree(saved, copy)
    return copy


def test_save_model_records_the_model_and_its_statistics(tiny_agent) -> None:
    from agents.files.writer import file_digest
    from agents.training.policies import load_policy

    saved = tiny_agent[0]
    manifest = json.loads((saved / "model.manifest.json").read_text())
    assert manifest["files"] == {name: {"bytes": (saved / name).stat().st_size, "sha256": file_digest(saved / name)}
                                 for name in ("model.zip", "model.normalization.json")}
    assert not (saved / "model.vecnormalize.pkl").exists()
    assert load_policy(saved / "model.zip").normalization is not None


def _replaced_statistics(copy: Path) -> str:
    (copy / "model.normalization.json").write_text(json.dumps({"not": "the saved statistics"}))
    return "model.normalization.json differs from the file recorded in"


def _appended_model(copy: Path) -> str:
    with (copy / "model.zip").open("ab") as handle:
        handle.write(b"\0")
    return "model.zip differs from the file recorded in"


def _garbage_manifest(copy: Path) -> str:
    (copy / "model.manifest.json").write_text("{")
    return "model.manifest.json is damaged: not valid JSON"


def _statistics_not_recorded(copy: Path) -> str:
    manifest = json.loads((copy / "model.manifest.json").read_text())
    del manifest["files"]["model.normalization.json"]
    (copy / "model.manifest.json").write_text(json.dumps(manifest))
    return "model.normalization.json is not recorded in"


def _deleted_manifest(copy: Path) -> str:
    (copy / "model.manifest.json").unlink()
    return "model.zip has no manifest (model.manifest.json): its files cannot be verified"


DAMAGES = [_replaced_statistics, _appended_model, _garbage_manifest, _statistics_not_recorded, _deleted_manifest]


@pytest.mark.parametrize("damage", DAMAGES, ids=lambda f: f.__name__.strip("_"))
def test_a_file_that_differs_from_its_manifest_is_refused(tiny_agent, tmp_path: Path, capsys, monkeypatch, damage) -> None:
    copy = _copy(tiny_agent[0], tmp_path)
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


def test_a_checkpoint_model_is_checked_against_its_checkpoint_manifest(tiny_agent, tmp_path: Path) -> None:
    from agents.files.writer import file_digest
    from agents.training.policies import load_policy

    saved = tiny_agent[0]
    run = _copy(saved, tmp_path)
    checkpoints = run / "checkpoints"
    checkpoints.mkdir()
    shutil.copy(saved / "model.zip", checkpoints / "model_64.zip")
    shutil.copy(saved / "model.normalization.json", checkpoints / "normalization_64.json")
    files = {name: {"bytes": (checkpoints / name).stat().st_size, "sha256": file_digest(checkpoints / name)}
             for name in ("model_64.zip", "normalization_64.json")}
    (checkpoints / "checkpoint_64.json").write_text(json.dumps({"num_timesteps": 64, "model": "model_64.zip", "files": files}))
    assert load_policy(checkpoints / "model_64.zip").normalization is not None
    replaced = checkpoints / "normalization_64.json"
    replaced.write_bytes(replaced.read_bytes() + b" ")
    with pytest.raises(ValueError, match="normalization_64.json differs from the file recorded in .*checkpoint_64.json"):
        load_policy(checkpoints / "model_64.zip")
