"""A fitted scikit-learn model on disk: a pickle and its manifest, written and read back checked.

The learned rule (:mod:`agents.training.learned_rule_policy`) and the selector
(:mod:`agents.training.selector_policy`) write their model the same way: the pickle first, then a
JSON manifest with the pickle's size and SHA-256, the package versions and the fit's own record
(``env_id`` and ``env_kwargs`` among them), both atomically, so that the manifest's presence marks a
finished fit.  Read back, a model file whose size or checksum differs from its manifest's (damaged,
or replaced), an unreadable manifest, a pickle of another class, or one written by another
scikit-learn (a pickled model is only guaranteed to load, and predict the same, in the version that
wrote it) is refused in one line naming the file.
"""

from __future__ import annotations

import pickle
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from agents.files.reader import read_json
from agents.files.writer import atomic_write, file_digest, write_json

__all__ = ["FORMAT", "check_version", "load_model_file", "save_model_file"]

FORMAT = 1


def save_model_file(model_path: Path, manifest_path: Path, model: Any, manifest: Mapping[str, Any]) -> Path:
    """Write ``model`` pickled to ``model_path``, then ``manifest`` (with the file's size and checksum and
    the package versions) to ``manifest_path``, both atomically; returns the manifest's path."""
    from agents.runtime import versions

    written = atomic_write(model_path, lambda handle: pickle.dump(model, handle, protocol=pickle.HIGHEST_PROTOCOL))
    record = {"format": FORMAT, "file": model_path.name, "size": written.stat().st_size, "sha256": file_digest(written),
              "versions": versions(), **manifest}
    return write_json(manifest_path, record)


def load_model_file(manifest_path: Path, kind: str, expected: type) -> tuple[Any, Path, dict[str, Any]]:
    """``(model, model path, manifest)`` of the manifest at ``manifest_path`` (which must exist), the model
    an instance of ``expected``; ``kind`` names it in the messages (``"learned rule"``, ``"selector"``).

    Raises
    ------
    ValueError
        Naming the file (module docstring).
    """
    manifest = read_json(manifest_path, dict)
    try:
        model_path = manifest_path.with_name(manifest["file"])
        checksum = (int(manifest["size"]), str(manifest["sha256"]))
        str(manifest["env_id"]), dict(manifest["env_kwargs"])
    except (OSError, ValueError, KeyError, TypeError) as error:
        name = kind.replace(" ", "-")
        raise ValueError(f"{manifest_path} is damaged: not a {name} manifest ({error.__class__.__name__}: {error})") from None
    if not model_path.is_file() or (model_path.stat().st_size, file_digest(model_path)) != checksum:
        raise ValueError(f"{model_path} is damaged or missing: its size or SHA-256 differs from {manifest_path.name}'s")
    check_version(manifest, model_path)
    try:
        with model_path.open("rb") as handle:
            model = pickle.load(handle)  # noqa: S301  (the run's own file, checksummed by its manifest)
    except (pickle.UnpicklingError, EOFError, AttributeError, ImportError, ValueError, TypeError) as error:
        raise ValueError(f"{model_path} cannot be read ({error.__class__.__name__}: {error})") from None
    if not isinstance(model, expected):
        raise ValueError(f"{model_path} holds a {type(model).__name__}, not a {kind}")
    return model, model_path, manifest


def check_version(manifest: Mapping[str, Any], model_path: Path) -> None:
    """Refuse, naming ``model_path``, a model pickled by another scikit-learn than the installed one."""
    from importlib import metadata

    fitted = (manifest.get("versions") or {}).get("scikit-learn")
    installed = metadata.version("scikit-learn")
    if fitted != installed:
        raise ValueError(f"{model_path} was fitted with scikit-learn {fitted}, this is {installed}: "
                         "fit it again (deadtime train with its config.yaml)")
