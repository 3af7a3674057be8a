"""``load_policy``: what it refuses, with a message naming the path (no torch needed for these)."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.policies import load_policy, resolve_model_path


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
