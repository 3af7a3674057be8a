"""Checkpoint files of ``deadtime train``: atomic writes, manifests with checksums, the fallback.

These tests build checkpoints by hand (no torch): the manifests are those that
:func:`agents.training.checkpoints.save_checkpoint` writes; the end-to-end tests are in ``test_resume.py``.
"""

from __future__ import annotations

from pathlib import Path

import pytest

from agents.training.checkpoints import DamagedFileError, _check_modules, find_checkpoint, read_manifest
from agents.files.writer import atomic_write, file_digest, write_json


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


def _checkpoint(run_dir: Path, steps: int, latest: bool = True) -> Path:
    """A checkpoint of ``steps`` steps as ``save_checkpoint`` writes it (file contents are stand-ins)."""
    directory = run_dir / "checkpoints"
    manifest = {"format": 2, "num_timesteps": steps, "periodic_checkpoint": steps, "files": {},
                "evaluations": [{"num_timesteps": steps, "mean_cost": 1.0}]}
    for role, suffix in (("model", "zip"), ("replay_buffer", "pkl"), ("vecnormalize", "pkl"), ("state", "pkl")):
        path = atomic_write(directory / f"{role}_{steps}.{suffix}", lambda handle: handle.write(bytes(range(256)) * 8))
        manifest[role] = path.name
        manifest["files"][path.name] = {"bytes": path.stat().st_size, "sha256": file_digest(path)}
    write_json(directory / f"checkpoint_{steps}.json", manifest)
    if latest:
        write_json(directory / "latest.json", manifest)
    return directory


def test_the_newest_intact_checkpoint_is_found(tmp_path: Path) -> None:
    assert find_checkpoint(tmp_path) == (None, None)
    _checkpoint(tmp_path, 64)
    directory = _checkpoint(tmp_path, 128)
    checkpoint, note = find_checkpoint(tmp_path)
    assert checkpoint is not None and checkpoint.num_timesteps == 128 and note is None
    assert checkpoint.path("model") == directory / "model_128.zip"
    assert checkpoint.evaluations == ({"num_timesteps": 128, "mean_cost": 1.0},)


def test_a_truncated_file_falls_back_to_the_previous_checkpoint(tmp_path: Path) -> None:
    _checkpoint(tmp_path, 64)
    directory = _checkpoint(tmp_path, 128)
    buffer = directory / "replay_buffer_128.pkl"
    buffer.write_bytes(buffer.read_bytes()[:100])
    checkpoint, note = find_checkpoint(tmp_path)
    assert checkpoint is not None and checkpoint.num_timesteps == 64
    assert note == (f"{buffer} is damaged: 100 bytes, 2048 when saved (truncated?); "
                    "resuming from checkpoint_64.json (64 steps) instead")


def test_a_changed_file_is_recognized_by_its_checksum(tmp_path: Path) -> None:
    directory = _checkpoint(tmp_path, 64)
    state = directory / "state_64.pkl"
    state.write_bytes(bytes(2048))
    with pytest.raises(DamagedFileError, match=f"^{state} is damaged: its SHA-256 differs.*no intact checkpoint"):
        find_checkpoint(tmp_path)


def test_a_garbage_index_is_named_and_the_manifest_used(tmp_path: Path) -> None:
    directory = _checkpoint(tmp_path, 64)
    (directory / "latest.json").write_text("garbage{")
    checkpoint, note = find_checkpoint(tmp_path)
    assert checkpoint is not None and checkpoint.num_timesteps == 64
    assert note.startswith(f"{directory / 'latest.json'} is damaged: not valid JSON (")
    assert note.endswith("resuming from checkpoint_64.json (64 steps) instead")
    with pytest.raises(DamagedFileError, match="not valid JSON"):
        read_manifest(directory / "latest.json")
    (directory / "latest.json").write_text('{"num_timesteps": "many"}')
    with pytest.raises(DamagedFileError, match="latest.json is damaged: not a checkpoint manifest"):
        read_manifest(directory / "latest.json")


def test_a_missing_file_is_named_as_it_is(tmp_path: Path) -> None:
    directory = _checkpoint(tmp_path, 64)
    (directory / "model_64.zip").unlink()
    with pytest.raises(DamagedFileError) as caught:
        find_checkpoint(tmp_path)
    assert str(caught.value).startswith(f"{directory / 'model_64.zip'} is missing (named by latest.json)")
    assert ".zip.zip" not in str(caught.value)


def test_a_checkpoint_of_the_old_module_paths_is_refused_in_one_line():
    """A snapshot that names an old module path, ``envs.scoring`` (now ``envs.analysis.scoring``)."""
    with pytest.raises(ValueError, match=r"module 'envs\.scoring'.*moved since"):
        _check_modules(b"cenvs.scoring\nScore\n.")
