"""Rewrite a model saved with pickles into the files that load as data (``deadtime convert-model``).

Loading a model never unpickles (:mod:`agents.training.model_files`, :mod:`agents.training.policies`).
Models saved in the older formats hold pickles: a learned rule's ``learned_rule.pkl``, a selector's
``selector.pkl``, an agent's ``<stem>.vecnormalize.pkl``.  :func:`convert` is the one place that
unpickles them, and only when told that the folder is trusted (``--trust``):

* a learned rule or a selector: the pickle is checked against its manifest (size, SHA-256, the
  scikit-learn that fitted it), unpickled, checked to be a model of its kind, written as
  ``learned_rule.skops`` / ``selector.skops`` with a new manifest (the fit's record kept), and removed;
* an agent (a run directory or a model ``.zip``; a run directory's ``best_model.zip`` and ``model.zip``
  both): its ``<stem>.vecnormalize.pkl`` is unpickled and its observation statistics written as
  ``<stem>.normalization.json``, the pickle removed, and the manifest written anew for the model and
  its statistics (a model without a manifest gets one: ``--trust`` vouches for it).  The model itself
  is kept as it is: its parameters are read as tensors only.  It is then loaded through the safe path
  (:func:`agents.training.policies.load_policy`) to check that it plays.

The fitted numbers are copied exactly: a converted model predicts bit for bit what the pickle did.
"""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

__all__ = ["convert"]

_BOOKKEEPING = ("format", "file", "size", "sha256")


def convert(path: str | Path, trust: bool) -> list[str]:
    """Convert the model at ``path``; returns one line per file written or removed.

    Raises
    ------
    ValueError
        Without ``trust``, or for a path that holds no model or a model that cannot be converted
        (naming the file).
    """
    from agents.training import learned_rule_policy, selector_policy

    path = Path(path)
    if not path.exists():
        raise ValueError(f"no model at {path}")
    if not trust:
        raise ValueError(f"converting {path} unpickles its files, which can run any code: pass --trust only if you trust "
                         "whoever could write its folder")
    for module, kind in ((selector_policy, "selector"), (learned_rule_policy, "learned rule")):
        checks = module.is_selector if kind == "selector" else module.is_learned_rule
        if checks(path):
            folder = path if path.is_dir() else path.parent
            return _convert_fitted(folder, module, kind)
    return _convert_agent(path)


def _convert_fitted(folder: Path, module: Any, kind: str) -> list[str]:
    """Rewrite a learned rule's or a selector's pickle as a skops file."""
    from agents.training.model_files import check_version, read_manifest, save_model_file

    manifest_path = folder / module.MANIFEST
    if not manifest_path.is_file():
        raise ValueError(f"{manifest_path} is missing: no finished {kind} at {folder}")
    manifest, model_path = read_manifest(manifest_path, kind)
    if model_path.name != module.PICKLE_FILE:
        return [f"{model_path}: already data, nothing to convert"]
    check_version(manifest, model_path)
    model = _unpickle(model_path)
    expected = module.Selector if kind == "selector" else _learned_rule_class()
    if not isinstance(model, expected):
        raise ValueError(f"{model_path} holds a {type(model).__name__}, not a {kind}")
    record = {key: value for key, value in manifest.items() if key not in _BOOKKEEPING}
    save_model_file(folder / module.MODEL_FILE, manifest_path, model, record)
    model_path.unlink()
    return [f"wrote {folder / module.MODEL_FILE} and {manifest_path.name}", f"removed {model_path}"]


def _learned_rule_class() -> type:
    from baselines.learned_rule import LearnedRule

    return LearnedRule


def _unpickle(path: Path) -> Any:
    try:
        with path.open("rb") as handle:
            return pickle.load(handle)  # noqa: S301  (the one trusted conversion: --trust)
    except Exception as error:  # noqa: BLE001  (a damaged pickle fails in many ways)
        raise ValueError(f"{path} cannot be unpickled ({error.__class__.__name__}: {error})") from None


def _convert_agent(path: Path) -> list[str]:
    """Rewrite the statistics and the manifest of an agent's model(s)."""
    from agents.training.policies import MODEL_FILES, load_policy, resolve_model_path

    if path.is_dir():
        models = [path / name for name in MODEL_FILES if (path / name).is_file()]
        if not models:
            raise ValueError(f"{path} holds no learned rule, selector, best_model.zip or model.zip")
    else:
        models = [resolve_model_path(path)]
    lines: list[str] = []
    for model_path in models:
        lines += _convert_zip(model_path)
        load_policy(model_path)
        lines.append(f"{model_path} loads as data")
    return lines


def _convert_zip(model_path: Path) -> list[str]:
    from agents.files.reader import DamagedFileError
    from agents.training.manifest import manifest_path, verify_agent_files, write_manifest
    from agents.training.normalization import write_normalization
    from agents.training.policies import statistics_paths

    statistics, pickled = statistics_paths(model_path)
    if model_path.parent.name == "checkpoints":
        raise ValueError(f"{model_path} is a checkpoint: convert its run's best_model.zip or model.zip")
    lines: list[str] = []
    if manifest_path(model_path) is not None:
        try:
            verify_agent_files(model_path, pickled if pickled.is_file() else None)
        except DamagedFileError as error:
            raise ValueError(f"{error}; not converting it") from None
    if pickled.is_file() and not statistics.is_file():
        vecnormalize = _unpickle(pickled)
        if not hasattr(vecnormalize, "obs_rms"):
            raise ValueError(f"{pickled} holds a {type(vecnormalize).__name__}, not VecNormalize statistics")
        write_normalization(statistics, vecnormalize)
        lines.append(f"wrote {statistics}")
    write_manifest(model_path, [model_path, *([statistics] if statistics.is_file() else [])])
    lines.append(f"wrote {model_path.with_suffix('.manifest.json')}")
    if pickled.is_file():
        pickled.unlink()
        lines.append(f"removed {pickled}")
    return lines
