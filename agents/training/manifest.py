"""The manifest of a saved agent: its files with their sizes and SHA-256, checked before they are read.

:func:`agents.training.callbacks.save_model` writes ``<stem>.manifest.json`` after the model and its
statistics (``{"format": 1, "files": {NAME: {"bytes", "sha256"}}}``), and :func:`verify_agent_files`
checks the files against it before they are read, so that a file damaged or replaced since it was
saved, or not saved with the model, is refused in one line naming it.  A checkpoint's model
(``checkpoints/model_<N>.zip``) is checked against its checkpoint's own manifest,
``checkpoint_<N>.json`` (:mod:`agents.training.checkpoints`).  A model without a manifest is refused.
A manifest guards against damage and mix-ups, not against whoever can write the folder (they can
rewrite the manifest too); that reading an agent executes nothing from its folder is
:mod:`agents.training.policies`'s part.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from agents.files.reader import DamagedFileError, read_record
from agents.files.writer import file_digest, write_json

__all__ = ["manifest_path", "verify_agent_files", "write_manifest"]

FORMAT = 1


def manifest_path(model_path: Path) -> Path | None:
    """The manifest that records ``model_path``: ``<stem>.manifest.json``, or for a checkpoint's
    ``model_<N>.zip`` its ``checkpoint_<N>.json``; None if there is none."""
    candidates = [model_path.with_suffix(".manifest.json")]
    prefix, _, steps = model_path.stem.rpartition("_")
    if prefix == "model" and steps.isdigit():
        candidates.append(model_path.with_name(f"checkpoint_{steps}.json"))
    return next((c for c in candidates if c.is_file()), None)


def write_manifest(model_path: Path, files: list[Path]) -> Path:
    """Record ``files`` (the model and its statistics) in ``<stem>.manifest.json``, atomically."""
    record = {"format": FORMAT, "files": {path.name: {"bytes": path.stat().st_size, "sha256": file_digest(path)}
                                          for path in files}}
    return write_json(model_path.with_suffix(".manifest.json"), record)


def _recorded(manifest: Path) -> dict[str, Any]:
    data = read_record(manifest, dict)
    files = data.get("files")
    if not isinstance(files, dict) or not all(isinstance(v, dict) and {"bytes", "sha256"} <= set(v) for v in files.values()):
        raise DamagedFileError(f"{manifest} is damaged: not a manifest of files with their bytes and sha256")
    return files


def verify_agent_files(model_path: Path, statistics_path: Path | None) -> None:
    """Check the model and its statistics against their manifest.

    Raises
    ------
    DamagedFileError
        If there is no manifest, it is unreadable, or a file is not recorded in it or differs from the
        record (size or SHA-256), naming the file.
    """
    manifest = manifest_path(model_path)
    if manifest is None:
        raise DamagedFileError(f"{model_path} has no manifest ({model_path.with_suffix('.manifest.json').name}): its files "
                               "cannot be verified; refusing to load it (if you trust its folder: "
                               f"deadtime convert-model {model_path} --trust)")
    recorded = _recorded(manifest)
    for path in (model_path, statistics_path):
        if path is None:
            continue
        expected = recorded.get(path.name)
        if expected is None:
            raise DamagedFileError(f"{path} is not recorded in {manifest} (it was not saved with the model); "
                                   "refusing to load it")
        size = path.stat().st_size
        if size != expected["bytes"] or file_digest(path) != expected["sha256"]:
            raise DamagedFileError(f"{path} differs from the file recorded in {manifest} ({size} bytes, "
                                   f"{expected['bytes']} when saved, or another SHA-256): damaged or replaced; "
                                   "refusing to load it")
