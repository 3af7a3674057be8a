"""A fitted scikit-learn model on disk as data: a skops file and its manifest, written and read back checked.

The learned rule (:mod:`agents.training.learned_rule_policy`) and the selector
(:mod:`agents.training.selector_policy`) write their model the same way: the model in skops's format
(``skops.io``: a zip of a JSON schema and NumPy arrays, no pickle), then a JSON manifest with the
file's size and SHA-256, the package versions and the fit's own record (``env_id`` and
``env_kwargs`` among them), both atomically, so that the manifest's presence marks a finished fit.

Loading executes nothing from the file.  skops builds only the types it is allowed to: its own list
of scikit-learn, NumPy and SciPy types, and the few of :data:`TRUSTED` named here per kind of model
(the project's classes and the boosted trees' ``TreePredictor``); a file that names any other type is
refused in one line naming the type, before anything is built.  Read back, a model file whose size or
checksum differs from its manifest's (damaged, or replaced), an unreadable manifest, a file of another
class, or one written by another scikit-learn (the same estimators predict the same only in the
version that fitted them) is refused in one line naming the file.  A pickled model (``.pkl``, the
format of older fits) is never loaded: the message names ``deadtime convert-model``, which rewrites it
(:mod:`agents.training.convert`).
"""

from __future__ import annotations

import io
import zipfile
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from agents.files.reader import read_json
from agents.files.writer import atomic_write, file_digest, write_json

__all__ = ["FORMAT", "SUFFIX", "TRUSTED", "check_version", "load_model_file", "read_manifest", "save_model_file"]

FORMAT = 2
"""The manifest's format: 2 names a skops file (1, a pickle, is only read by the conversion)."""

SUFFIX = ".skops"

MAX_UNPACKED = 1 << 30
"""The most bytes a model file may unpack to (a fitted model of this project is a few megabytes)."""

_TREES = "sklearn.ensemble._hist_gradient_boosting.predictor.TreePredictor"
TRUSTED: dict[str, tuple[str, ...]] = {
    "learned rule": ("baselines.learned_rule.LearnedRule", "baselines.learned_rule.Spread", _TREES),
    "selector": ("agents.training.selector_policy.Selector", "baselines.learned_rule.LearnedRule",
                 "baselines.learned_rule.Spread", _TREES),
    "risk learner": ("agents.risk.model.RiskLearner", _TREES),
}
"""Per kind of model, the types beyond skops's own trusted ones that its file may name."""


def save_model_file(model_path: Path, manifest_path: Path, model: Any, manifest: Mapping[str, Any]) -> Path:
    """Write ``model`` in skops's format to ``model_path``, then ``manifest`` (with the file's size and
    checksum and the package versions) to ``manifest_path``, both atomically; returns the manifest's path."""
    import skops.io

    from agents.runtime import versions

    data = skops.io.dumps(model, compression=zipfile.ZIP_DEFLATED)
    written = atomic_write(model_path, lambda handle: handle.write(data))
    record = {"format": FORMAT, "file": model_path.name, "size": written.stat().st_size, "sha256": file_digest(written),
              "versions": versions(), **manifest}
    return write_json(manifest_path, record)


def read_manifest(manifest_path: Path, kind: str) -> tuple[dict[str, Any], Path]:
    """``(manifest, model path)`` of the manifest at ``manifest_path``, the model file checked against it.

    Raises
    ------
    ValueError
        For a manifest that is not one of ``kind``, or a model file missing or differing from it.
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
    return manifest, model_path


def load_model_file(manifest_path: Path, kind: str, expected: type) -> tuple[Any, Path, dict[str, Any]]:
    """``(model, model path, manifest)`` of the manifest at ``manifest_path`` (which must exist), the model
    an instance of ``expected``; ``kind`` names it in the messages and chooses its :data:`TRUSTED` types.

    Raises
    ------
    ValueError
        Naming the file (module docstring).
    """
    manifest, model_path = read_manifest(manifest_path, kind)
    if model_path.suffix != SUFFIX:
        raise ValueError(f"{model_path} is a pickle, which is not loaded (it could run code): if you trust its folder, "
                         f"convert it with deadtime convert-model {manifest_path.parent} --trust")
    check_version(manifest, model_path)
    model = _load_skops(model_path, TRUSTED[kind])
    if not isinstance(model, expected):
        raise ValueError(f"{model_path} holds a {type(model).__name__}, not a {kind}")
    return model, model_path, manifest


def _load_skops(model_path: Path, trusted: tuple[str, ...]) -> Any:
    """The object of a skops file, if it names no type beyond skops's own trusted ones and ``trusted``."""
    import skops.io

    data = model_path.read_bytes()
    try:
        with zipfile.ZipFile(io.BytesIO(data)) as archive:
            unpacked = sum(info.file_size for info in archive.infolist())
        if unpacked > MAX_UNPACKED:
            raise ValueError(f"{unpacked} bytes unpacked, more than {MAX_UNPACKED}")
        untrusted = skops.io.get_untrusted_types(data=data)
    except Exception as error:  # noqa: BLE001  (a damaged or foreign file fails in many ways; nothing is built yet)
        raise ValueError(f"{model_path} cannot be read as a skops file ({error.__class__.__name__}: {error})") from None
    refused = sorted(set(untrusted) - set(trusted))
    if refused:
        raise ValueError(f"{model_path} names types that are not trusted ({', '.join(refused)}): refusing to load it")
    try:
        return skops.io.loads(data, trusted=untrusted)
    except Exception as error:  # noqa: BLE001  (only trusted types are built; their errors name the file)
        raise ValueError(f"{model_path} cannot be read as a skops file ({error.__class__.__name__}: {error})") from None


def check_version(manifest: Mapping[str, Any], model_path: Path) -> None:
    """Refuse, naming ``model_path``, a model fitted with another scikit-learn than the installed one."""
    from importlib import metadata

    fitted = (manifest.get("versions") or {}).get("scikit-learn")
    installed = metadata.version("scikit-learn")
    if fitted != installed:
        raise ValueError(f"{model_path} was fitted with scikit-learn {fitted}, this is {installed}: "
                         "fit it again (deadtime train with its config.yaml)")
