"""Bad input to the kept ``deadtime study`` subcommands: one line, exit status 2, nothing written."""

from __future__ import annotations

from pathlib import Path

import pytest
from in_process import error_line


@pytest.mark.parametrize("source", ["missing", "empty"])
def test_commit_refuses_a_folder_that_is_not_a_finished_sweep_and_creates_no_target(tmp_path: Path, source: str) -> None:
    (tmp_path / "empty").mkdir()
    target = tmp_path / "results" / "sweep"
    line = error_line("study", "commit", str(tmp_path / source), str(target))
    assert "is not a finished sweep's folder: it holds no sweep.yaml, sessions.json, summary.json" in line
    assert not (tmp_path / "results").exists()


@pytest.mark.parametrize("plants", ["0", "-3"])
def test_sequential_replay_refuses_no_plants_before_loading_an_agent(tmp_path: Path, plants: str) -> None:
    line = error_line("study", "sequential-replay", str(tmp_path), "--plants", plants, "--out", str(tmp_path / "out"))
    assert f"--plants must be a whole number of at least 1, got {plants}" in line
    assert not (tmp_path / "out").exists()
