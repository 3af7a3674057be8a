"""Rewrite a model saved with pickles into the files that load as data (``deadtime convert-model``).

Loading a model never unpickles (:mod:`agents.training.model_files`, :mod:`agents.training.policies`).
Models saved in the older formats hold pickles: a learned rule's ``learned_rule.pkl``, a selector's
``selector.pkl``, an agent's ``<stem>.vecnormalize.pkl``.  :func:`convert` is the one place that
unpickles them, and only when told that the folder is trusted (``--trust``):

* a learned rule or a selector: the pickle is checked against its manifest (size, SHA-256, the
  scikit-learn that fitted it), unpickled, checked to be a model of its kind, written as
  ``learned_rule.skops`` / ``selector.skops`` with a new manifest (the fit's record kept), and removed
  (a selector's own learned design, ``RUN/learned``, with it);
* an agent (a run directory or a model ``.zip``; a run directory's ``best_model.zip`` and ``model.zip``
  both): its ``<stem>.vecnormalize.pkl`` is unpickled and its observation statistics written as
  ``<stem>.normalization.json``, the pickle removed, and the manifest written anew for the model and
  its statistics (a model without a manifest gets one: ``--trust`` vouches for it).  The model itself
  is kept as it is: its parameters are read as tensors only.  A model saved without its run's
  ``config.yaml`` (by stable-baselines3 directly) gets one written from the model as loaded (its
  algorithm, policy and ``policy_kwargs``) and the environment id given (``--env``).  The model is
  then loaded through the safe path (:func:`agents.training.policies.load_policy`) and must act bit
  for bit as stable-baselines3's own load of it on 64 observations drawn from its space, or the
  conversion is refused.

The fitted numbers are copied exactly: a converted model predicts bit for bit what the pickle did.
"""

from __future__ import annotations

import pickle
from pathlib import Path
from typing import Any

__all__ = ["convert"]

_BOOKKEEPING = ("format", "file", "size", "sha256")


def convert(path: str | Path, trust: bool, env_id: str | None = None) -> list[str]:
    """Convert the model at ``path``; returns one line per file written or removed.

    ``env_id`` is the environment of an agent saved without its run's ``config.yaml`` (by
    stable-baselines3 directly): the config is then written from the model itself.

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
    folder = path if path.is_dir() else path.parent
    if selector_policy.is_selector(path):
        lines = _convert_fitted(folder, selector_policy, "selector")
        from agents.training.selector_config import LEARNED

        own = folder / LEARNED  # the selector's own learned design, a learned-rule fit of its own
        if (own / learned_rule_policy.MANIFEST).is_file():
            lines += _convert_fitted(own, learned_rule_policy, "learned rule")
        return lines
    if learned_rule_policy.is_learned_rule(path):
        return _convert_fitted(folder, learned_rule_policy, "learned rule")
    return _convert_agent(path, env_id)


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


def _convert_agent(path: Path, env_id: str | None) -> list[str]:
    """Rewrite the statistics and the manifest of an agent's model(s)."""
    from agents.training.policies import MODEL_FILES, resolve_model_path

    if path.is_dir():
        models = [path / name for name in MODEL_FILES if (path / name).is_file()]
        if not models:
            raise ValueError(f"{path} holds no learned rule, selector, best_model.zip or model.zip")
    else:
        models = [resolve_model_path(path)]
    lines: list[str] = []
    for model_path in models:
        if model_path.parent.name == "checkpoints":
            raise ValueError(f"{model_path} is a checkpoint: convert its run's best_model.zip or model.zip")
        lines += _convert_zip(model_path, env_id)
    return lines


def _convert_zip(model_path: Path, env_id: str | None) -> list[str]:
    from agents.files.reader import DamagedFileError
    from agents.training.manifest import manifest_path, verify_agent_files, write_manifest
    from agents.training.normalization import write_normalization
    from agents.training.policies import statistics_paths

    statistics, pickled = statistics_paths(model_path)
    if manifest_path(model_path) is not None:
        try:
            verify_agent_files(model_path, pickled if pickled.is_file() else None)
        except DamagedFileError as error:
            raise ValueError(f"{error}; not converting it") from None
    model = _sb3_model(model_path)
    vecnormalize = None
    if pickled.is_file():
        vecnormalize = _unpickle(pickled)
        if not hasattr(vecnormalize, "obs_rms") or not hasattr(vecnormalize, "normalize_obs"):
            raise ValueError(f"{pickled} holds a {type(vecnormalize).__name__}, not VecNormalize statistics")
    lines: list[str] = []
    config_path = model_path.parent / "config.yaml"
    if not config_path.is_file():
        _write_config(config_path, model_path, model, env_id, vecnormalize is not None)
        lines.append(f"wrote {config_path}")
    if vecnormalize is not None:
        write_normalization(statistics, vecnormalize)
        lines.append(f"wrote {statistics}")
    write_manifest(model_path, [model_path, *([statistics] if statistics.is_file() else [])])
    lines.append(f"wrote {model_path.with_suffix('.manifest.json')}")
    _check_same_actions(model_path, model, vecnormalize)
    if pickled.is_file():
        pickled.unlink()
        lines.append(f"removed {pickled}")
    lines.append(f"{model_path} loads as data and acts as before")
    return lines


def _algorithm(model_path: Path) -> str:
    """The algorithm of a model zip, from its ``data``'s policy class and attributes (read as JSON)."""
    import zipfile

    from agents.files.reader import parse_json

    try:
        with zipfile.ZipFile(model_path) as archive:
            data = parse_json(archive.read("data").decode(), f"{model_path}: data", dict)
    except (KeyError, ValueError, OSError, zipfile.BadZipFile, UnicodeDecodeError):
        raise ValueError(f"{model_path} is not a stable-baselines3 model: its 'data' entry is missing or not JSON") from None
    module = str((data.get("policy_class") or {}).get("__module__", ""))
    guess = next((name for name in ("SAC", "TD3") if f".{name.lower()}." in module), None)
    if guess is None and ".maskable." in module:
        guess = "MaskablePPO"
    return guess or ("PPO" if "clip_range" in data else "A2C")


def _sb3_model(model_path: Path) -> Any:
    """The model loaded by stable-baselines3 itself (it unpickles: trusted)."""
    from agents.training.config import algorithm_class

    algorithm = _algorithm(model_path)
    try:
        model = algorithm_class(algorithm).load(model_path, device="cpu")
    except Exception as error:  # noqa: BLE001  (a foreign zip fails in many ways)
        raise ValueError(f"{model_path} could not be loaded by {algorithm} ({error.__class__.__name__}: {error})") from None
    model.deadtime_algorithm = algorithm
    return model


def _write_config(config_path: Path, model_path: Path, model: Any, env_id: str | None, normalize: bool) -> None:
    """The run config of a model saved without one: its algorithm, policy and ``policy_kwargs`` as loaded."""
    import yaml

    from agents.files.writer import write_text
    from agents.training.config import TrainConfig, algorithm_class
    from agents.training.train import _ACTIVATIONS, _OPTIMIZERS

    if env_id is None:
        raise ValueError(f"{config_path} is missing: pass --env ID, the environment {model_path.name} was trained on, "
                         "to write it")
    algorithm = model.deadtime_algorithm
    aliases = algorithm_class(algorithm).policy_aliases
    policy = next((name for name, cls in aliases.items() if cls is type(model.policy)), None)
    if policy is None:
        raise ValueError(f"{model_path}: its policy {type(model.policy).__name__} is not one of {', '.join(aliases)}")
    names = {"activation_fn": {v: k for k, v in _ACTIVATIONS.items()}, "optimizer_class": {v: k for k, v in _OPTIMIZERS.items()}}
    policy_kwargs = {}
    for key, value in dict(model.policy_kwargs).items():
        if key == "use_sde":
            continue
        if key in names:
            if getattr(value, "__name__", None) not in names[key]:
                raise ValueError(f"{model_path}: policy_kwargs.{key} {value!r} cannot be written in a config")
            value = names[key][value.__name__]
        policy_kwargs[key] = value
    hyperparameters: dict[str, Any] = {"use_sde": True} if getattr(model, "use_sde", False) else {}
    if hasattr(model, "buffer_size"):
        hyperparameters["buffer_size"] = int(model.buffer_size)  # the rebuilt model's buffer, as small as saved
    config = TrainConfig(algorithm=algorithm, env_id=env_id, total_timesteps=max(int(model.num_timesteps), 1),
                         seed=int(model.seed or 0), normalize=normalize, policy=policy, policy_kwargs=policy_kwargs,
                         hyperparameters=hyperparameters, progress_bar=False)
    try:
        text = yaml.safe_dump(config.to_dict(), sort_keys=False)
    except yaml.YAMLError as error:
        raise ValueError(f"{model_path}: its policy_kwargs cannot be written in a config ({error})") from None
    write_text(config_path, text)


def _check_same_actions(model_path: Path, model: Any, vecnormalize: Any) -> None:
    """Refuse a conversion whose model, loaded as data, does not act bit for bit as stable-baselines3's."""
    import numpy as np

    from agents.training.policies import load_policy

    loaded = load_policy(model_path)
    space = model.observation_space
    space.seed(0)
    observations = np.stack([space.sample() for _ in range(64)]).astype(np.float32)
    observations = np.nan_to_num(observations, posinf=1e6, neginf=-1e6)
    expected = model.predict(observations if vecnormalize is None else vecnormalize.normalize_obs(observations),
                             deterministic=True)[0]
    if not np.array_equal(loaded.predict(observations)[0], expected):
        raise ValueError(f"{model_path}, rebuilt from {model_path.parent / 'config.yaml'}, does not act as the model "
                         "stable-baselines3 loads: not converted")
