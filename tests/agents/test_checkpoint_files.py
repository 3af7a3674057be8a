"""Atomic files of ``deadtime train``: a failed write leaves the previous file whole."""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.callbacks import atomic_write, latest_checkpoint, write_json


def test_atomic_write_replaces_or_leaves_the_old_file(tmp_path: Path) -> None:
    path = tmp_path / "sub" / "model.zip"
    atomic_write(path, lambda handle: handle.write(b"first"))
    assert path.read_bytes() == b"first"

    def broken(handle) -> None:
        handle.write(b"half")
        raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        atomic_write(path, broken)
    assert path.read_bytes() == b"first"
    assert sorted(p.name for p in path.parent.iterdir()) == ["model.zip"]  # no temporary left
    atomic_write(path, lambda handle: handle.write(b"second"))
    assert path.read_bytes() == b"second"


def test_latest_checkpoint_paths(tmp_path: Path) -> None:
    assert latest_checkpoint(tmp_path) is None
    write_json(tmp_path / "checkpoints" / "latest.json",
               {"num_timesteps": 64, "model": "model_64.zip", "replay_buffer": None, "vecnormalize": "vecnormalize_64.pkl"})
    checkpoint = latest_checkpoint(tmp_path)
    assert checkpoint is not None and checkpoint["num_timesteps"] == 64
    assert checkpoint["model"] == str(tmp_path / "checkpoints" / "model_64.zip")
    assert checkpoint["replay_buffer"] is None
    assert checkpoint["vecnormalize"] == str(tmp_path / "checkpoints" / "vecnormalize_64.pkl")
