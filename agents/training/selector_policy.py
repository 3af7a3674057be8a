"""A fitted selector on disk, and played as a policy: ``load_selector(path).choose(observation)``.

A selector's fit (:mod:`agents.training.selector`) writes into its run directory

* ``selector.skops``: the :class:`Selector` (per candidate a classifier of "violates" and a regression
  of the cost where it does not, the threshold, and the learned designs among the candidates) as data:
  skops's JSON schema and NumPy arrays (:mod:`agents.training.model_files`);
* ``selector.json``: its manifest, written after the model: the environment id and keyword arguments,
  the candidates, the threshold and the validation table that chose it, the size and SHA-256 of the
  model file and the package versions.

:func:`load_selector` takes the run directory, the manifest or the model file, executes nothing from
them, and refuses in one line a model file whose size or checksum differs from the manifest's, one
that names a type outside the trusted list, one fitted by another scikit-learn, or a pickled
``selector.pkl`` (converted by ``deadtime convert-model``).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from agents.training.model_files import load_model_file, save_model_file

__all__ = ["MANIFEST", "MODEL_FILE", "PICKLE_FILE", "Selector", "SelectorPolicy", "is_selector", "load_selector", "save_selector"]

MODEL_FILE = "selector.skops"
PICKLE_FILE = "selector.pkl"
"""The pickled model of older fits: never loaded, only converted (:mod:`agents.training.convert`)."""
MANIFEST = "selector.json"


@dataclass(frozen=True)
class Selector:
    """The per-plant choice among candidate designs.

    For an observation, each candidate ``k`` has a predicted probability of violating ``p_k`` and a
    predicted cost ``c_k`` (where it does not violate).  The choice is the candidate of least ``c_k``
    among those with ``p_k <= threshold`` (ties: the first in order); where none is, the one of least
    ``p_k``.

    Attributes
    ----------
    names : tuple of str
        The candidates' names, in order.
    rules : tuple of str or None
        Per candidate, the rule's name, or None for a learned design.
    learned : dict of str to baselines.learned_rule.LearnedRule
        The learned designs by name.
    violation_models, cost_models : tuple
        Per candidate a fitted scikit-learn model, or a number where the training plants admit none
        (one class only; fewer than :data:`agents.training.selector.MIN_FEASIBLE` feasible plants).
    threshold : float
    """

    names: tuple[str, ...]
    rules: tuple[str | None, ...]
    learned: Mapping[str, Any] = field(repr=False)
    violation_models: tuple[Any, ...] = field(repr=False)
    cost_models: tuple[Any, ...] = field(repr=False)
    threshold: float = 0.1

    def predictions(self, observations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(p, c)``, each ``(plants, candidates)``: the predicted probability of violating and cost."""
        rows = np.atleast_2d(np.asarray(observations, dtype=float))
        p = np.column_stack([_predict(model, rows, probability=True) for model in self.violation_models])
        c = np.column_stack([_predict(model, rows, probability=False) for model in self.cost_models])
        return p, c

    def choices(self, observations: np.ndarray, threshold: float | None = None) -> np.ndarray:
        """The index of the chosen candidate per row of ``observations`` (at ``threshold``, default the fitted one)."""
        p, c = self.predictions(observations)
        return choose(p, c, self.threshold if threshold is None else threshold)

    def choose(self, observation: np.ndarray) -> str:
        """The chosen candidate's name for one observation."""
        return self.names[int(self.choices(observation)[0])]


def choose(p: np.ndarray, c: np.ndarray, threshold: float) -> np.ndarray:
    """Per row, the index of least ``c`` among the columns with ``p <= threshold``, else of least ``p``."""
    allowed = p <= threshold
    costs = np.where(allowed, c, np.inf)
    return np.where(allowed.any(axis=1), np.argmin(costs, axis=1), np.argmin(p, axis=1))


def _predict(model: Any, rows: np.ndarray, probability: bool) -> np.ndarray:
    if isinstance(model, int | float):
        return np.full(len(rows), float(model))
    if probability:
        return model.predict_proba(rows)[:, list(model.classes_).index(True)]
    return model.predict(rows)


@dataclass(frozen=True)
class SelectorPolicy:
    """A fitted selector, played by ``deadtime evaluate`` (:func:`agents.evaluation.run.selector_result`)."""

    name: str
    path: Path
    selector: Selector = field(repr=False)
    env_id: str
    env_kwargs: Mapping[str, Any]
    manifest: Mapping[str, Any] = field(repr=False)

    def choose(self, observation: np.ndarray) -> str:
        return self.selector.choose(observation)

    def rule_of(self, choice: str) -> str | None:
        """The rule's name of the candidate ``choice``, or None for a learned design."""
        return self.selector.rules[self.selector.names.index(choice)]

    def action(self, choice: str, observation: np.ndarray) -> np.ndarray:
        """The action of the learned design ``choice``."""
        return self.selector.learned[choice].predict(observation)


def save_selector(run_dir: Path, selector: Selector, manifest: Mapping[str, Any]) -> Path:
    """Write ``selector.skops`` then its manifest, both atomically (:func:`agents.training.model_files.save_model_file`);
    returns the manifest's path."""
    return save_model_file(run_dir / MODEL_FILE, run_dir / MANIFEST, selector, manifest)


def is_selector(path: str | Path) -> bool:
    """Whether ``path`` names a selector: its manifest or model file, or a run directory holding one."""
    path = Path(path)
    return path.name in (MANIFEST, MODEL_FILE, PICKLE_FILE) or (path.is_dir() and (path / MANIFEST).is_file())


def load_selector(path: str | Path) -> SelectorPolicy:
    """The selector of a run directory, manifest or model file.

    Raises
    ------
    ValueError
        Naming the file: no manifest, an unreadable one, a model file that differs from it, a pickle,
        a type outside the trusted list, a scikit-learn other than the fitting one, or a model file
        that holds no selector.
    """
    path = Path(path)
    manifest_path = path / MANIFEST if path.is_dir() else path.with_name(MANIFEST)
    if not manifest_path.is_file():
        raise ValueError(f"{manifest_path} is missing: no finished selector at {path}")
    selector, model_path, manifest = load_model_file(manifest_path, "selector", Selector)
    return SelectorPolicy(manifest_path.parent.name, model_path, selector, str(manifest["env_id"]), dict(manifest["env_kwargs"]),
                          manifest)
