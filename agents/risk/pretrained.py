"""The shipped risk-conditioned learners, and their names ``learned-<structure>@<risk>``.

``agents/pretrained/learned-<structure>.skops`` holds the :class:`agents.risk.model.RiskLearner` of a
structure as data (skops's JSON schema and NumPy arrays; only the learner's class and the boosted
trees' type beyond skops's own trusted ones: :mod:`agents.training.model_files`), and
``learned-<structure>.json`` its manifest: the file's size and SHA-256, the package versions, the
config and commit it was fitted with, the choice made on the validation plants.  Loading checks the
file against its manifest and executes nothing from it.  ``deadtime pretrain`` writes them
(:mod:`agents.risk.train`).

A name ``learned-pid@0.01`` is the PID learner at risk ``r = 0.01`` (the share of plants on which its
design may violate a constraint), in ``deadtime evaluate --policies``, ``deadtime process`` and the
Python API (:func:`load_pretrained`); it plays the fixed mode of its structure's v3 environment.
Where the risk is below the share of plants with no feasible design in some band of the learner
(high noise), loading warns: there no design reaches it, the design is the most conservative one and
:meth:`PretrainedPolicy.reachable` is false; :meth:`PretrainedPolicy.floor` gives a plant's share.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["KIND", "PRETRAINED_DIR", "PretrainedPolicy", "is_pretrained_name", "load_pretrained", "model_paths", "parse_name"]

PRETRAINED_DIR = Path(__file__).resolve().parent.parent / "pretrained"
"""The folder of the shipped learners (package data)."""

KIND = "risk learner"
"""The model files' kind (:data:`agents.training.model_files.TRUSTED`)."""

_NAME = re.compile(r"learned-([a-z]+)@(.*)")


def model_paths(structure: str, folder: Path = PRETRAINED_DIR) -> tuple[Path, Path]:
    """``(model file, manifest)`` of a structure's learner in ``folder``."""
    stem = f"learned-{structure.lower()}"
    return folder / f"{stem}.skops", folder / f"{stem}.json"


def is_pretrained_name(text: str) -> bool:
    """Whether ``text`` is meant as a pretrained learner's name: ``learned-WORD@...``."""
    return _NAME.fullmatch(str(text).strip()) is not None


def parse_name(text: str, structure: str | None = None) -> tuple[str, float]:
    """``(structure, risk)`` of a name ``learned-<structure>@<risk>``; with ``structure``, that of the
    environment it must play.

    Raises
    ------
    ValueError
        One line: an unknown structure, a risk that is not a number in (0, 0.5), or a structure other than
        the environment's.
    """
    from agents.risk.labels import STRUCTURES

    match = _NAME.fullmatch(str(text).strip())
    if match is None:
        raise ValueError(f"{text!r} is not a pretrained learner's name: learned-<structure>@<risk>, e.g. learned-pid@0.01")
    own, risk_text = match.group(1).upper(), match.group(2)
    if own not in STRUCTURES:
        raise ValueError(f"{text!r}: unknown structure {match.group(1)!r}; the pretrained learners are "
                         f"{', '.join(f'learned-{s.lower()}' for s in STRUCTURES)}")
    try:
        risk = float(risk_text)
    except ValueError:
        risk = math.nan
    if not 0.0 < risk < 0.5:
        raise ValueError(f"{text!r}: the risk after '@' must be a number in (0, 0.5) (a share of plants, "
                         f"e.g. 0.01), got {risk_text!r}")
    if structure is not None and structure.upper() != own:
        raise ValueError(f"{text!r} designs the {own} structure; this environment's structure is {structure.upper()} "
                         f"(use learned-{structure.lower()}@{risk_text})")
    return own, risk


@dataclass(frozen=True)
class PretrainedPolicy:
    """A shipped learner at a risk, played like an agent: ``predict(observation)`` gives its design action.

    ``path`` identifies it in the evaluation's cache: the model file, its risk and the first digits of
    its SHA-256.
    """

    name: str
    risk: float
    learner: Any = field(repr=False)
    env_id: str
    env_kwargs: dict
    path: str
    manifest: dict = field(repr=False)

    @property
    def feature_ranges(self) -> dict[str, list[float]] | None:
        """The plant features' ranges over the training plants (the manifest's), for the out-of-distribution check."""
        return self.manifest.get("feature_ranges")

    def reachable(self, observation: Any) -> np.ndarray:
        """Per observation (a row, or rows), whether the learner reaches the policy's risk there."""
        return self.learner.reachable(observation, self.risk)

    def floor(self, observation: Any) -> np.ndarray:
        """Per observation, the share of its band's plants with no feasible design: no risk below it is reachable."""
        return self.learner.floor(observation)

    def predict(self, observation: Any, deterministic: bool = True) -> tuple[np.ndarray, None]:
        """``(action, None)`` for one observation (or a batch, first axis), as stable-baselines3's ``predict``."""
        rows = np.asarray(observation, dtype=np.float64)
        action = self.learner.design(rows, self.risk).astype(np.float32)
        return (action.reshape(-1, 1) if rows.ndim > 1 else action.reshape(1)), None


_LOADED: dict[tuple[str, str], tuple[Any, dict]] = {}


def load_learner(structure: str, folder: Path = PRETRAINED_DIR) -> tuple[Any, dict, Path]:
    """``(learner, manifest, model path)`` of a structure's learner in ``folder``, checked against its manifest.

    Raises
    ------
    ValueError
        Naming the file: missing, damaged or replaced, of a type outside the trusted list, or fitted with
        another scikit-learn.
    """
    from agents.risk.model import RiskLearner
    from agents.training.model_files import load_model_file

    model_path, manifest_path = model_paths(structure, folder)
    if not manifest_path.is_file():
        raise ValueError(f"{manifest_path} is missing: no pretrained {structure} learner (deadtime pretrain writes it)")
    key = (str(manifest_path), manifest_path.read_text())
    if key not in _LOADED:
        learner, _, manifest = load_model_file(manifest_path, KIND, RiskLearner)
        _LOADED[key] = (learner, manifest)
    learner, manifest = _LOADED[key]
    return learner, manifest, model_path


def load_pretrained(name: str, structure: str | None = None, folder: Path = PRETRAINED_DIR) -> PretrainedPolicy:
    """The policy of a name ``learned-<structure>@<risk>`` (:func:`parse_name`; ``structure``: the environment's).

    Raises
    ------
    ValueError
        One line: a bad name or risk (:func:`parse_name`), or a model file that cannot be loaded (:func:`load_learner`).
    """
    own, risk = parse_name(name, structure)
    learner, manifest, model_path = load_learner(own, folder)
    floors = learner.unreachable(risk)
    if floors:
        import warnings

        warnings.warn(f"{str(name).strip()}: the risk {risk:g} is below the share of plants with no feasible design in "
                      f"{len(floors)} of the learner's {len(learner.scores)} bands (up to {max(floors):.2%}, at high noise); "
                      "there the design is the most conservative one and the realized risk is that share", stacklevel=2)
    path = f"{model_path}@{risk:g}#{manifest['sha256'][:16]}"
    return PretrainedPolicy(str(name).strip(), risk, learner, str(manifest["env_id"]), dict(manifest["env_kwargs"]), path,
                            manifest)
