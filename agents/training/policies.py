"""Load a trained agent as a policy: ``load_policy(path).predict(observation)`` -> ``(action, None)``.

``path`` is a run directory of ``deadtime train`` or a model ``.zip``.  For a run directory the
agent is ``best_model.zip`` (lowest mean cost on the validation plants) when it exists, else
``model.zip``; either is checked the same way.  A checkpoint (``<run>/checkpoints/model_<N>.zip``)
takes its config from the run directory.

Loading executes nothing from the agent's folder: nothing in it is unpickled.

* The files are checked against the manifest written when they were saved (``<stem>.manifest.json``,
  or a checkpoint's ``checkpoint_<N>.json``; :mod:`agents.training.manifest`): a model without one,
  or a file damaged or replaced since, is refused in one line naming it.
* The algorithm is rebuilt from the run's ``config.yaml`` (algorithm, policy, ``policy_kwargs``,
  hyperparameters) on its environment's spaces, and the network's parameters are read from the
  zip's ``policy.pth`` as tensors only (``torch.load(..., weights_only=True)``); the zip's ``data``
  entry is read as JSON, never deserialized.  A model without its run's config is refused: what
  the rebuild needs cannot be verified.
* An agent trained with normalized observations (a run's ``config.yaml`` says ``normalize``, or the
  model's ``data`` records ``deadtime_vecnormalize``) is played with its statistics,
  ``<stem>.normalization.json`` (a checkpoint's ``normalization_<N>.json``; JSON numbers,
  :mod:`agents.training.normalization`), and never without them.  A run saved with the statistics
  pickled (``<stem>.vecnormalize.pkl``) only is refused with the command that converts it,
  ``deadtime convert-model RUN --trust`` (:mod:`agents.training.convert`).
"""

from __future__ import annotations

import dataclasses
import io
import zipfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.files.reader import parse_json
from agents.training.config import TrainConfig, load_config
from agents.training.manifest import verify_agent_files
from agents.training.normalization import Normalization, read_normalization

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
    normalization : Normalization or None
        Observation statistics applied before the network.
    """

    name: str
    path: Path
    algorithm: str
    model: Any
    config: TrainConfig | None = None
    normalization: Normalization | None = None

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


MAX_PARAMETER_BYTES = 1 << 30
"""The most bytes a model's ``policy.pth`` may unpack to."""

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


def _data(model_path: Path) -> dict[str, Any]:
    """The zip's ``data`` entry read as JSON (the serialized objects in it stay text).

    Raises
    ------
    ValueError
        If it is missing or not JSON (naming the file).
    """
    try:
        with zipfile.ZipFile(model_path) as archive:
            text = archive.read("data").decode()
        return parse_json(text, f"{model_path}: data", dict)
    except (KeyError, ValueError, OSError, zipfile.BadZipFile, UnicodeDecodeError) as error:
        raise ValueError(f"{model_path} is not a stable-baselines3 model saved as data: its 'data' entry is missing "
                         f"or not JSON ({error.__class__.__name__})") from None


def _parameters(model_path: Path, device: str) -> dict[str, Any]:
    """The policy's parameters, ``policy.pth`` read as tensors only.

    Raises
    ------
    ValueError
        If the zip holds no ``policy.pth`` or it holds anything but tensors (naming the file).
    """
    import pickle

    import torch

    try:
        with zipfile.ZipFile(model_path) as archive:
            if archive.getinfo("policy.pth").file_size > MAX_PARAMETER_BYTES:
                raise ValueError(f"more than {MAX_PARAMETER_BYTES} bytes unpacked")
            content = archive.read("policy.pth")
        state = torch.load(io.BytesIO(content), map_location=device, weights_only=True)
    except (KeyError, OSError, ValueError, zipfile.BadZipFile, pickle.UnpicklingError, RuntimeError, EOFError) as error:
        reason = str(error).splitlines()[0] if str(error) else error.__class__.__name__
        raise ValueError(f"{model_path}: its policy.pth is missing or holds more than tensors; refusing it ({reason})") from None
    if not isinstance(state, dict) or not all(isinstance(value, torch.Tensor) for value in state.values()):
        raise ValueError(f"{model_path}: its policy.pth is not a mapping of names to tensors")
    return state


def statistics_paths(model_path: Path) -> tuple[Path, Path]:
    """``(statistics, pickled statistics)`` of a model: ``<stem>.normalization.json`` and
    ``<stem>.vecnormalize.pkl``, or for a checkpoint ``model_<N>.zip`` ``normalization_<N>.json`` and
    ``vecnormalize_<N>.pkl`` beside it."""
    prefix, _, steps = model_path.stem.rpartition("_")
    if prefix == "model" and steps.isdigit() and model_path.parent.name == "checkpoints":
        return model_path.with_name(f"normalization_{steps}.json"), model_path.with_name(f"vecnormalize_{steps}.pkl")
    return model_path.with_suffix(".normalization.json"), model_path.with_suffix(".vecnormalize.pkl")


def _statistics_file(model_path: Path, required: bool) -> Path | None:
    """The statistics file to load, or None if the model is played without.

    Raises
    ------
    ValueError
        If they are required but missing, or saved as a pickle only (naming the file and the conversion).
    """
    statistics, pickled = statistics_paths(model_path)
    if not required:
        return None
    if statistics.is_file():
        return statistics
    if pickled.is_file() and model_path.parent.name == "checkpoints":
        raise ValueError(f"{pickled} is a pickle, which is not loaded (it could run code): play the run's model.zip or "
                         f"best_model.zip instead (deadtime convert-model {model_path.parent.parent} --trust converts them)")
    if pickled.is_file():
        raise ValueError(f"{pickled} is a pickle, which is not loaded (it could run code): if you trust its folder, "
                         f"convert it with deadtime convert-model {model_path} --trust")
    raise ValueError(f"{statistics} is missing: {model_path.name} was trained on normalized observations and cannot "
                     f"be played without its statistics (copy them beside the model as {statistics.name})")


def _run_config(model_path: Path) -> tuple[Path, TrainConfig]:
    """``(run directory, config)`` of a model.

    Raises
    ------
    ValueError
        If the run's ``config.yaml`` is missing (the agent cannot be rebuilt) or not a config of an agent.
    """
    run_dir = model_path.parent.parent if model_path.parent.name == "checkpoints" else model_path.parent
    config_path = run_dir / "config.yaml"
    if not config_path.is_file():
        raise ValueError(f"{config_path} is missing: {model_path.name} is rebuilt from its run's config and cannot be "
                         "loaded without it (keep the model in its deadtime train run directory; for a model saved "
                         f"elsewhere, from a folder you trust: deadtime convert-model {model_path} --trust --env ID)")
    config = load_config(config_path)
    if not isinstance(config, TrainConfig):
        raise ValueError(f"{config_path} is not the config of a stable-baselines3 agent (algorithm {config.algorithm!r}), "
                         f"so {model_path.name} cannot be rebuilt from it")
    return run_dir, config


def _rebuilt(config: TrainConfig, model_path: Path, device: str) -> Any:
    """The algorithm of ``config`` on its environment's spaces, with the parameters of ``model_path``."""
    from stable_baselines3.common.vec_env import DummyVecEnv

    from agents.environments import make_env
    from agents.training.schema import refused_as
    from agents.training.train import new_model

    parameters = _parameters(model_path, device)
    venv = refused_as("env_kwargs", config.env_id,
                      lambda: DummyVecEnv([lambda: make_env(config.env_id, dict(config.env_kwargs))]))
    model = refused_as("hyperparameters or policy_kwargs", config.algorithm,
                       lambda: new_model(dataclasses.replace(config, device=device), venv))
    try:
        model.policy.load_state_dict(parameters)
    except RuntimeError as error:
        raise ValueError(f"{model_path}'s parameters do not fit the {config.algorithm} of its run's config.yaml "
                         f"({str(error).splitlines()[0]})") from None
    model.policy.set_training_mode(False)
    return model


def load_policy(path: str | Path, device: str = "cpu") -> LoadedPolicy:
    """Load a saved agent from a run directory or a model ``.zip``, with its normalization statistics.

    Nothing of the agent's folder is unpickled (the module docstring says how it is read).

    Raises
    ------
    ValueError
        If there is no model at ``path``, it has no manifest or its files differ from it, its run's
        config is missing, its parameters are not tensors or do not fit the config's algorithm, or its
        statistics are required (the model or the run's config says so) but missing, pickled or damaged.
    """
    model_path = resolve_model_path(path)  # a missing or unreadable file is named before torch is imported
    verify_agent_files(model_path, None)  # the model against its manifest, before anything in it is read
    run_dir, config = _run_config(model_path)
    data = _data(model_path)
    required = data.get("deadtime_vecnormalize") is True or config.normalize
    statistics = _statistics_file(model_path, required)
    if statistics is not None:
        verify_agent_files(model_path, statistics)
    normalization = None if statistics is None else read_normalization(statistics)
    model = _rebuilt(config, model_path, device)
    steps = data.get("num_timesteps")
    model.num_timesteps = steps if isinstance(steps, int) and not isinstance(steps, bool) else 0  # as trained (a plain number)
    return LoadedPolicy(name=run_dir.name, path=model_path, algorithm=config.algorithm, model=model, config=config,
                        normalization=normalization)
