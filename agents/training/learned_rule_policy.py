"""A fitted learned rule on disk, and played as a policy: ``load_learned_rule(path).predict(observation)``.

A learned-rule fit (:mod:`agents.training.learned_rule`) writes into its run directory

* ``learned_rule.skops``: the :class:`baselines.learned_rule.LearnedRule` (the fitted scikit-learn
  regression, its margin, direction and action bounds) as data: skops's JSON schema and NumPy arrays
  (:mod:`agents.training.model_files`);
* ``learned_rule.json``: its manifest, written after the model, so that its presence marks a
  finished fit: the environment id and keyword arguments, the model kind and margin, the size and
  SHA-256 of the model file, the package versions, and the validation costs that chose the rule.

:func:`load_learned_rule` takes the run directory, the manifest or the model file, and executes
nothing from them.  A model file whose size or checksum differs from its manifest's (damaged, or
replaced), one that names a type outside the trusted list, an unreadable manifest, a scikit-learn
other than the one that fitted it, or a pickled ``learned_rule.pkl`` (converted by ``deadtime
convert-model``) is refused in one line naming the file.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from agents.training.model_files import load_model_file, save_model_file

__all__ = ["MANIFEST", "MODEL_FILE", "PICKLE_FILE", "LearnedRulePolicy", "is_learned_rule", "load_learned_rule", "save_learned_rule"]

MODEL_FILE = "learned_rule.skops"
PICKLE_FILE = "learned_rule.pkl"
"""The pickled model of older fits: never loaded, only converted (:mod:`agents.training.convert`)."""
MANIFEST = "learned_rule.json"


@dataclass(frozen=True)
class LearnedRulePolicy:
    """A fitted learned rule, played like a trained agent by ``deadtime evaluate``.

    Attributes
    ----------
    name : str
        The run directory's name.
    path : Path
        The model file.
    rule : baselines.learned_rule.LearnedRule
    env_id : str
        The environment the rule was fitted on.
    env_kwargs : dict
        Its keyword arguments.
    manifest : dict
        The manifest as read.
    """

    name: str
    path: Path
    rule: Any = field(repr=False)
    env_id: str
    env_kwargs: Mapping[str, Any]
    manifest: Mapping[str, Any] = field(repr=False)

    def predict(self, observation: np.ndarray, deterministic: bool = True) -> tuple[np.ndarray, None]:
        """``(action, None)`` for one observation (or a batch, first axis), as stable-baselines3's ``predict``."""
        return self.rule.predict(observation), None


def save_learned_rule(run_dir: Path, rule: Any, manifest: Mapping[str, Any]) -> Path:
    """Write ``learned_rule.skops`` then its manifest (``manifest`` plus the file's size and checksum),
    both atomically (:func:`agents.training.model_files.save_model_file`); returns the manifest's path."""
    return save_model_file(run_dir / MODEL_FILE, run_dir / MANIFEST, rule, manifest)


def is_learned_rule(path: str | Path) -> bool:
    """Whether ``path`` names a learned rule: its manifest or model file, or a run directory that holds
    one or whose ``config.yaml`` is a learned-rule config (a fit that has not finished)."""
    path = Path(path)
    if path.name in (MANIFEST, MODEL_FILE, PICKLE_FILE):
        return True
    if not path.is_dir():
        return False
    if (path / MANIFEST).is_file():
        return True
    from agents.files.reader import load_yaml_file

    try:
        config = load_yaml_file(path / "config.yaml")
    except (OSError, ValueError):
        return False
    return isinstance(config, dict) and str(config.get("algorithm", "")).lower() == "learned-rule"


def _manifest_path(path: Path) -> Path:
    if path.is_dir():
        return path / MANIFEST
    return path.with_name(MANIFEST) if path.name in (MODEL_FILE, PICKLE_FILE) else path


def load_learned_rule(path: str | Path) -> LearnedRulePolicy:
    """The learned rule of a run directory, manifest or model file.

    Raises
    ------
    ValueError
        Naming the file: no manifest (the fit has not finished), an unreadable manifest, a model
        file that differs from the manifest's size or checksum, a pickle, a type outside the trusted
        list, a scikit-learn version other than the fitting one, or a model file that holds no learned
        rule.
    """
    from baselines.learned_rule import LearnedRule

    manifest_path = _manifest_path(Path(path))
    if not manifest_path.is_file():
        raise ValueError(f"{manifest_path} is missing: no finished learned-rule fit at {path} "
                         "(finish it with deadtime train --out DIR --resume)")
    rule, model_path, manifest = load_model_file(manifest_path, "learned rule", LearnedRule)
    env_id, env_kwargs = str(manifest["env_id"]), dict(manifest["env_kwargs"])
    return LearnedRulePolicy(manifest_path.parent.name, model_path, rule, env_id, env_kwargs, manifest)
