"""Load a trained agent as a policy: ``load_policy(path).predict(observation)`` -> ``(action, None)``.

``path`` is a run directory of ``deadtime train`` or a model ``.zip``.  For a run directory the
agent is ``best_model.zip`` (lowest mean cost on the validation plants) when it exists, else
``model.zip``.  The algorithm is read from the ``config.yaml`` beside the model; without one, each
stable-baselines3 algorithm is tried in turn.  ``VecNormalize`` statistics saved beside the model
(``<stem>.vecnormalize.pkl``) are applied to the observations.  A checkpoint
(``<run>/checkpoints/model_<N>.zip``) takes its statistics from ``vecnormalize_<N>.pkl`` beside it
and its config from the run directory.

An agent trained with normalized observations is never played without its statistics: a model
saved by ``deadtime train`` records ``deadtime_vecnormalize`` in its ``data``, and a run's
``config.yaml`` says ``normalize``; either makes a missing statistics file an error that names it.
(A model saved elsewhere, without either, is loaded as it is.)  A damaged statistics file is an error
naming it too.

Loading an agent runs code from its folder: stable-baselines3 unpickles objects stored in the
model's ``.zip``, and the statistics are a pickle.  Load only agents from folders you trust.  Before
anything is unpickled, the model and its statistics are checked against the manifest written when
they were saved (``<stem>.manifest.json``, or a checkpoint's ``checkpoint_<N>.json``;
:mod:`agents.training.manifest`): a file damaged or replaced since is refused in one line naming it.
"""

from __future__ import annotations

import pickle
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.files.reader import parse_json
from agents.training.config import ALGORITHMS, TrainConfig, algorithm_class, load_config
from agents.training.manifest import verify_agent_files

__all__ = ["MODEL_FILES", "LoadedPolicy", "load_policy", "resolve_model_path"]


@dataclass(frozen=True)
class LoadedPolicy:
    """A trained agent.

    Attributes
    ----------
    name : str
        The run directory's name (or the model file's stem without a run directory).
    path : Path
        The model file.
    algorithm : str
        ``A2C``, ``PPO``, ``SAC``, ``TD3`` or ``MaskablePPO``.
    model : BaseAlgorithm
        The stable-baselines3 model.
    config : TrainConfig or None
        The run's resolved config (environment id and keyword arguments), if found.
    normalization : VecNormalize or None
        Observation statistics applied before the network.
    """

    name: str
    path: Path
    algorithm: str
    model: Any
    config: TrainConfig | None = None
    normalization: Any = None

    def predict(self, observation: np.ndarray, deterministic: bool = True,
                action_masks: np.ndarray | None = None) -> tuple[np.ndarray, None]:
        """``(action, None)`` for one observation (or a batch, first axis), as stable-baselines3's ``predict``;
        ``action_masks`` (the environment's, for a ``MaskablePPO`` agent) restrict it to the allowed actions."""
        observation = np.asarray(observation, dtype=np.float32)
        if self.normalization is not None:
            observation = self.normalization.normalize_obs(observation).astype(np.float32)
        if action_masks is not None and self.algorithm == "MaskablePPO":
            action, _ = self.model.predict(observation, deterministic=deterministic, action_masks=action_masks)
        else:
            action, _ = self.model.predict(observation, deterministic=deterministic)
        return action, None

    @property
    def env_id(self) -> str | None:
        """The environment id the agent was trained on, if known."""
        return None if self.config is None else self.config.env_id

    @property
    def env_kwargs(self) -> dict[str, Any]:
        """The keyword arguments of the environment the agent was trained on (empty if unknown)."""
        return {} if self.config is None else dict(self.config.env_kwargs)


MODEL_FILES = ("best_model.zip", "model.zip")
"""The model files of a training run directory, in the order :func:`resolve_model_path` takes them."""


def resolve_model_path(path: str | Path) -> Path:
    """The model file of a run directory (``best_model.zip``, else ``model.zip``) or of a ``.zip`` path."""
    path = Path(path)
    if path.is_dir():
        found = next((path / name for name in MODEL_FILES if (path / name).is_file()), None)
        if found is None:
            raise ValueError(f"{path} holds no best_model.zip or model.zip (is it a deadtime train run directory?)")
        path = found
    if not path.is_file() and path.with_suffix(".zip").is_file():
        path = path.with_suffix(".zip")
    if not path.is_file():
        raise ValueError(f"no trained agent at {path}")
    if not zipfile.is_zipfile(path):
        raise ValueError(f"{path} is not a stable-baselines3 model (.zip)")
    return path


def _likely_algorithms(model_path: Path) -> list[str]:
    """Every algorithm, the likeliest first, from the saved policy class and attributes."""
    try:
        with zipfile.ZipFile(model_path) as archive:
            data = parse_json(archive.read("data").decode(), f"{model_path}: data", dict)
    except (KeyError, ValueError, OSError, zipfile.BadZipFile):
        return list(ALGORITHMS)
    module = str(data.get("policy_class", {}).get("__module__", ""))
    guess = next((name for name in ("SAC", "TD3") if f".{name.lower()}." in module), None)
    if guess is None and ".maskable." in module:
        guess = "MaskablePPO"
    if guess is None:
        guess = "PPO" if "clip_range" in data else "A2C"
    return [guess, *(name for name in ALGORITHMS if name != guess)]


def _statistics_path(model_path: Path) -> Path | None:
    """The ``VecNormalize`` statistics of a model: ``<stem>.vecnormalize.pkl``, or for a checkpoint
    ``model_<N>.zip`` the ``vecnormalize_<N>.pkl`` beside it; None if there are none."""
    candidates = [model_path.with_suffix(".vecnormalize.pkl")]
    prefix, _, steps = model_path.stem.rpartition("_")
    if prefix == "model" and steps.isdigit():
        candidates.append(model_path.with_name(f"vecnormalize_{steps}.pkl"))
    return next((c for c in candidates if c.is_file()), None)


def _saved_with_statistics(model_path: Path) -> bool:
    """Whether ``deadtime train`` saved the model with ``VecNormalize`` statistics (its ``data`` says so)."""
    try:
        with zipfile.ZipFile(model_path) as archive:
            data = parse_json(archive.read("data").decode(), f"{model_path}: data", dict)
    except (KeyError, ValueError, OSError, zipfile.BadZipFile):
        return False
    return data.get("deadtime_vecnormalize") is True


def _load_statistics(model_path: Path, required: bool) -> Any:
    """The model's ``VecNormalize`` statistics (not updated while playing), or None if it has none.

    Raises
    ------
    ValueError
        If they are required but missing, or cannot be read (naming the file).
    """
    statistics = _statistics_path(model_path)
    if statistics is None:
        if required:
            raise ValueError(f"{model_path.with_suffix('.vecnormalize.pkl')} is missing: {model_path.name} was trained on "
                             "normalized observations and cannot be played without its statistics "
                             "(copy them beside the model as <stem>.vecnormalize.pkl)")
        return None
    try:
        with statistics.open("rb") as handle:
            normalization = pickle.load(handle)  # noqa: S301  (the run's own file)
        normalization.training = False
        normalization.normalize_obs  # noqa: B018  (a VecNormalize, not some other pickle)
    except (pickle.UnpicklingError, EOFError, AttributeError, ValueError, TypeError, ImportError, IndexError, OSError) as error:
        raise ValueError(f"{statistics} is damaged: it is not readable VecNormalize statistics "
                         f"({error.__class__.__name__}: {error})") from None
    return normalization


def load_policy(path: str | Path, device: str = "cpu") -> LoadedPolicy:
    """Load a saved agent from a run directory or a model ``.zip``, with its normalization statistics.

    Loading runs pickled code from the model's folder (the module docstring says which files); they
    are first checked against the manifest written when they were saved.

    Raises
    ------
    ValueError
        If there is no model at ``path``, no stable-baselines3 algorithm can load it, its files differ
        from their manifest, or its statistics are required (the model or the run's config says so)
        but missing or damaged.
    """
    model_path = resolve_model_path(path)  # a missing or unreadable file is named before torch is imported
    run_dir = model_path.parent.parent if model_path.parent.name == "checkpoints" else model_path.parent
    config_path = run_dir / "config.yaml"
    config = load_config(config_path) if config_path.is_file() else None
    required = _saved_with_statistics(model_path) or (config is not None and config.normalize)
    verify_agent_files(model_path, _statistics_path(model_path))  # before anything of the folder is unpickled
    normalization = _load_statistics(model_path, required)
    candidates = [config.algorithm] if config is not None else _likely_algorithms(model_path)
    errors = []
    for algorithm in candidates:
        try:
            model = algorithm_class(algorithm).load(model_path, device=device)
        except Exception as error:  # noqa: BLE001  (each algorithm refuses the others' files its own way)
            errors.append(f"{algorithm}: {error.__class__.__name__}")
            continue
        break
    else:
        raise ValueError(f"{model_path} could not be loaded by {', '.join(candidates)} ({'; '.join(errors)})")
    name = run_dir.name if config is not None else model_path.stem
    return LoadedPolicy(name=name, path=model_path, algorithm=algorithm, model=model, config=config,
                        normalization=normalization)
