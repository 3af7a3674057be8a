"""Training configuration: a typed, frozen schema and the rl-baselines3-zoo style YAML files.

A file in ``configs/`` holds one algorithm's settings keyed by environment id, with a ``default``
entry::

    default:                      # applies to every environment id
      algorithm: PPO
      env_id: DeadTime/PID-v0
      total_timesteps: 20000
      hyperparameters: {n_steps: 64, batch_size: 64}
    DeadTime/MSP-v0:              # merged over ``default`` when training on this id
      hyperparameters: {learning_rate: 0.001}

Precedence: the schema's defaults < the file's ``default`` entry < the entry of the environment id <
command-line overrides ``key=value`` (dotted keys reach into the mapping fields, e.g.
``hyperparameters.n_steps=32`` or ``env_kwargs.noise_std=0.02``; each value is parsed as YAML).
Mappings merge key by key; every other value replaces.  An unknown key anywhere is a ``ValueError``
that names it, with the closest known key if one is close: the top of a file holds only ``default``
and entries keyed by registered environment ids.  Files and override values are read within the
limits of :mod:`agents.files.reader` (nesting, aliases), the sizes within :mod:`agents.limits`.
Numbers in exponent form that YAML 1.1 reads as strings (``1e5``, ``3e-4``) are read as numbers in
the integer fields and the hyperparameters.
Hyperparameters and policy keyword arguments are checked against the stable-baselines3
constructors by :func:`validate` (which imports stable-baselines3, so it is called when training,
not when this module is imported).

A run directory's ``config.yaml`` holds one resolved config (the fields below at top level, no
``default``); :func:`load_config` reads both kinds of file.
"""

from __future__ import annotations

import dataclasses
import difflib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from agents.files.reader import load_yaml, load_yaml_file
from agents.limits import MAX_ENVS, MAX_EVAL_EPISODES, MAX_TIMESTEPS, require_at_most
from agents.training.dual_ascent import LagrangianSettings
from agents.training.hyperparameters import INTEGER_KEYS
from agents.training.learned_rule_config import LEARNED_RULE, LearnedRuleConfig, validate_learned_rule
from agents.training.selector_config import SELECTOR, SelectorConfig, validate_selector
from agents.training.schema import (
    check_env_kwargs,
    did_you_mean,
    frozen_mapping,
    parameters,
    plain_value,
    probe_environment,
    require_field,
    whole_number,
    whole_numbers,
    yaml_number,
)

__all__ = [
    "ALGORITHMS",
    "MAPPING_FIELDS",
    "TrainConfig",
    "apply_overrides",
    "load_config",
    "merge",
    "parse_override",
    "validate",
]

ALGORITHMS = ("A2C", "PPO", "SAC", "TD3", "MaskablePPO")
"""The algorithms a config can name (any case): stable-baselines3's four, and sb3-contrib's ``MaskablePPO``
for the agent mode's discrete action with its masks (``env_kwargs.discrete_action: true``)."""
_BY_UPPER = {name.upper(): name for name in ALGORITHMS}
OFF_POLICY = ("SAC", "TD3")
VEC_ENVS = ("dummy", "subproc", "native")
# Fields that hold open mappings (dotted override keys reach into them).
MAPPING_FIELDS = ("env_kwargs", "hyperparameters", "policy_kwargs")
# Constructor arguments that the config sets through its own fields, never through ``hyperparameters``.
_RESERVED = {
    "policy": "policy",
    "env": "env_id",
    "seed": "seed",
    "policy_kwargs": "policy_kwargs",
    "tensorboard_log": "the run directory",
    "verbose": "the command line",
    "device": "device",
    "_init_setup_model": "stable-baselines3",
    "replay_buffer_class": "stable-baselines3 (classes are not configurable from YAML)",
    "rollout_buffer_class": "stable-baselines3 (classes are not configurable from YAML)",
}


@dataclass(frozen=True)
class TrainConfig:
    """Everything a training run depends on.

    Attributes
    ----------
    algorithm : str
        One of ``A2C``, ``PPO``, ``SAC``, ``TD3`` (stable-baselines3) or ``MaskablePPO`` (sb3-contrib; any case).
    env_id : str
        A registered Gymnasium id, e.g. ``DeadTime/PID-v0``.
    total_timesteps : int
        Environment steps over all vectorized environments (one step = one episode in fixed mode).
    seed : int
        The one training seed: ``set_random_seed(seed)``; vectorized environment ``i`` gets ``seed + i``.
    n_envs, vec_env : int, str
        Number of training environments and their vectorization: ``dummy`` or ``subproc`` (SB3's, over
        ``Monitor``-wrapped single environments), or ``native`` (the id's native vector environment,
        :mod:`envs.vector_env`, through :mod:`agents.training.native_vec_env`: the same episodes,
        fixed mode only, the per-episode Python of N single environments saved).
    normalize, normalize_reward : bool
        Wrap the training environments in ``VecNormalize`` (observations; rewards too if
        ``normalize_reward``).  The statistics are saved beside every model.
    env_kwargs : mapping
        Keyword arguments of ``gymnasium.make`` (e.g. ``experiments``, ``family``, ``noise_std``, ``budget``).
    policy, policy_kwargs : str, mapping
        The policy alias and its keyword arguments (``net_arch``; ``activation_fn`` and
        ``optimizer_class`` by name: ``tanh``, ``relu``, ``elu``, ``leaky_relu``, ``gelu``, ``silu``;
        ``adam``, ``adamw``, ``rmsprop``, ``sgd``).
    hyperparameters : mapping
        Keyword arguments of the algorithm's constructor.  ``action_noise`` is given as
        ``{type: normal | ornstein-uhlenbeck, sigma: s}``; ``train_freq`` as an int or ``[n, step|episode]``.
    eval_freq : int
        Environment steps between two evaluations on the validation plant set (0: only at the end).
    n_eval_episodes : int
        Number of validation plants (one episode each).
    eval_family : str or None
        Family of the validation plant set; default the environment's family.
    checkpoint_freq : int
        Environment steps between two checkpoints (0: none).
    output_dir : str or None
        Run directory; default ``runs/<algorithm>-<env name>-s<seed>``.
    device : str
        Torch device (``cpu``).
    torch_threads : int
        ``torch.set_num_threads`` of the training process.
    progress_bar : bool
        Show a tqdm progress bar.
    lagrangian : mapping or None
        Train against a limit on the violation rate (SAC, TD3): ``{risk: r, multiplier_lr, initial,
        window}`` (:class:`agents.training.dual_ascent.LagrangianSettings`; docs/lagrangian.md).
    """

    algorithm: str
    env_id: str
    total_timesteps: int
    seed: int = 0
    n_envs: int = 1
    vec_env: str = "dummy"
    normalize: bool = False
    normalize_reward: bool = False
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    policy: str = "MlpPolicy"
    policy_kwargs: Mapping[str, Any] = field(default_factory=dict)
    hyperparameters: Mapping[str, Any] = field(default_factory=dict)
    eval_freq: int = 0
    n_eval_episodes: int = 16
    eval_family: str | None = None
    checkpoint_freq: int = 0
    output_dir: str | None = None
    device: str = "cpu"
    torch_threads: int = 1
    progress_bar: bool = True
    lagrangian: Mapping[str, Any] | None = None

    def __post_init__(self) -> None:
        if not isinstance(self.algorithm, str) or self.algorithm.upper() not in _BY_UPPER:
            raise ValueError(f"algorithm must be one of {', '.join(ALGORITHMS)} (or learned-rule), got {self.algorithm!r}")
        object.__setattr__(self, "algorithm", _BY_UPPER[self.algorithm.upper()])
        for name in ("env_id", "policy", "device"):
            value = getattr(self, name)
            require_field(isinstance(value, str) and bool(value), name, "a non-empty string", value)
        for name, low in (("total_timesteps", 1), ("seed", 0), ("n_envs", 1), ("eval_freq", 0),
                          ("n_eval_episodes", 1), ("checkpoint_freq", 0), ("torch_threads", 1)):
            value = yaml_number(getattr(self, name))
            if isinstance(value, float) and value.is_integer():  # YAML reads 1.0e5 as a float
                value = int(value)
                object.__setattr__(self, name, value)
            require_field(isinstance(value, int) and not isinstance(value, bool) and value >= low, name, f"an integer >= {low}", value)
        require_at_most(self.total_timesteps, MAX_TIMESTEPS, "total_timesteps")
        require_at_most(self.n_envs, MAX_ENVS, "n_envs")
        require_at_most(self.n_eval_episodes, MAX_EVAL_EPISODES, "n_eval_episodes")
        for name in ("normalize", "normalize_reward", "progress_bar"):
            require_field(isinstance(getattr(self, name), bool), name, "true or false", getattr(self, name))
        require_field(self.vec_env in VEC_ENVS, "vec_env", " or ".join(VEC_ENVS), self.vec_env)
        for name in ("eval_family", "output_dir"):
            value = getattr(self, name)
            require_field(value is None or (isinstance(value, str) and value), name, "a non-empty string or null", value)
        for name in MAPPING_FIELDS:
            value = getattr(self, name)
            require_field(isinstance(value, Mapping), name, "a mapping", value)
            for key in value:
                require_field(isinstance(key, str), f"{name} key", "a string", key)
            if name == "hyperparameters":
                value = {key: yaml_number(item) for key, item in value.items()}
                value = {key: whole_number(item) if key in INTEGER_KEYS else item for key, item in value.items()}
            if name == "policy_kwargs" and "net_arch" in value:
                value = {**value, "net_arch": whole_numbers(value["net_arch"])}
            object.__setattr__(self, name, frozen_mapping(value))
        if self.lagrangian is not None:
            LagrangianSettings.from_mapping(self.lagrangian)
            require_field(self.algorithm in OFF_POLICY, "algorithm", f"one of {', '.join(OFF_POLICY)} with lagrangian "
                          "(its replay buffer recombines reward and cost)", self.algorithm)
            object.__setattr__(self, "lagrangian", frozen_mapping(dict(self.lagrangian)))

    @property
    def lagrangian_settings(self) -> LagrangianSettings | None:
        """The ``lagrangian`` settings, or None."""
        return None if self.lagrangian is None else LagrangianSettings.from_mapping(self.lagrangian)

    @property
    def off_policy(self) -> bool:
        """True for the algorithms with a replay buffer (SAC, TD3)."""
        return self.algorithm in OFF_POLICY

    @property
    def run_name(self) -> str:
        """``<algorithm>-<env name>-s<seed>``, e.g. ``ppo-PID-v0-s0``."""
        return f"{self.algorithm.lower()}-{self.env_id.rsplit('/', 1)[-1]}-s{self.seed}"

    def to_dict(self) -> dict[str, Any]:
        """Plain values (for YAML and JSON), in field order."""
        return {f.name: plain_value(getattr(self, f.name)) for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "config") -> TrainConfig:
        """Build from a mapping of field names; unknown or missing keys are errors naming them."""
        if not isinstance(data, Mapping):
            raise ValueError(f"{where} must be a mapping of config keys, got {type(data).__name__}")  # noqa: TRY004
        known = [f.name for f in dataclasses.fields(cls)]
        for key in data:
            if key not in known:
                raise ValueError(f"unknown config key {key!r} in {where}{did_you_mean(key, known)} (known keys: {', '.join(known)})")
        missing = [f.name for f in dataclasses.fields(cls)
                   if f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING and f.name not in data]
        if missing:
            raise ValueError(f"{where} is missing the required key(s) {', '.join(missing)}")
        return cls(**data)


# ----------------------------------------------------------------------------------- merging
def merge(base: Mapping[str, Any], update: Mapping[str, Any]) -> dict[str, Any]:
    """``base`` updated by ``update``: mappings merge key by key, every other value replaces."""
    merged = dict(base)
    for key, value in update.items():
        if isinstance(value, Mapping) and isinstance(merged.get(key), Mapping):
            merged[key] = merge(merged[key], value)
        else:
            merged[key] = value
    return merged


def parse_override(text: str) -> tuple[list[str], Any]:
    """``"hyperparameters.n_steps=32"`` -> ``(["hyperparameters", "n_steps"], 32)`` (the value read as YAML,
    :func:`agents.files.reader.load_yaml`)."""
    key, sep, raw = text.partition("=")
    path = key.strip().split(".")
    if not sep or not all(path):
        raise ValueError(f"override {text!r} must be key=value (dotted keys for nesting, e.g. hyperparameters.n_steps=32)")
    value = load_yaml(raw, f"the value of override {key.strip()!r}") if raw.strip() else None
    return path, value


def apply_overrides(data: Mapping[str, Any], overrides: Sequence[str], schema: type = TrainConfig) -> dict[str, Any]:
    """Apply ``key=value`` overrides to a config mapping; unknown top-level keys (of the dataclass
    ``schema``) are errors naming them."""
    known = [f.name for f in dataclasses.fields(schema)]
    mappings = [name for name in (*MAPPING_FIELDS, "lagrangian") if name in known]
    result = dict(data)
    for text in overrides:
        path, value = parse_override(text)
        if path[0] not in known:
            raise ValueError(f"unknown config key {path[0]!r} in override {text!r} (known keys: {', '.join(known)})")
        if len(path) > 1 and path[0] not in mappings:
            raise ValueError(f"override {text!r}: {path[0]!r} is not a mapping (dotted keys reach into {', '.join(mappings)})")
        nested: Any = value
        for key in reversed(path[1:]):
            nested = {key: nested}
        if len(path) > 1:
            result = merge(result, {path[0]: nested})
        else:
            result[path[0]] = value
    return result


def load_config(path: str | Path, env_id: str | None = None, overrides: Sequence[str] = ()) -> TrainConfig:
    """Resolve a training config from a YAML file, an environment id and ``key=value`` overrides.

    A config whose resolved ``algorithm`` is ``learned-rule`` is returned as an
    :class:`agents.training.learned_rule_config.LearnedRuleConfig` (its own keys, checked the same way).

    Parameters
    ----------
    path : str or Path
        A zoo-style file (``default`` plus entries keyed by environment id), or a run's resolved
        ``config.yaml`` (the fields at top level).
    env_id : str, optional
        The environment to train on; default the ``env_id`` override, else the file's ``env_id``.
    overrides : sequence of str
        ``key=value`` strings applied last.

    Raises
    ------
    ValueError
        On an unreadable file, an unknown key (named), or an invalid value (named).
    """
    path = Path(path)
    data = load_yaml_file(path)
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise ValueError(f"{path} must hold a mapping, got {type(data).__name__}")  # noqa: TRY004
    if "default" not in data and "algorithm" in data:  # a run's resolved config.yaml
        resolved = dict(data)
    else:
        default = data.get("default") or {}
        if not isinstance(default, Mapping):
            raise ValueError(f"{path}: 'default' must be a mapping")
        _check_top_level(data, path)
        chosen = env_id or _override_value(overrides, "env_id") or default.get("env_id")
        if chosen is None:
            raise ValueError(f"no environment id: pass --env or set env_id in the 'default' entry of {path}")
        entry = data.get(chosen) or {}
        if not isinstance(entry, Mapping):
            raise ValueError(f"{path}: the entry {chosen!r} must be a mapping")
        if "env_id" in entry:
            raise ValueError(f"{path}: the entry {chosen!r} must not set env_id (it is the entry's key)")
        resolved = merge(default, entry)
        resolved["env_id"] = chosen
        if "algorithm" not in resolved and path.stem.upper() in _BY_UPPER:
            resolved["algorithm"] = _BY_UPPER[path.stem.upper()]
    schema = _schema(_override_value(overrides, "algorithm") or resolved.get("algorithm"))
    resolved = apply_overrides(resolved, overrides, schema)
    if env_id is not None:
        resolved["env_id"] = env_id
    return schema.from_dict(resolved, where=str(path))


def _check_top_level(data: Mapping[str, Any], path: Path) -> None:
    """The top of a zoo-style file holds ``default`` and entries keyed by registered environment ids;
    anything else (a misspelled id, a config key that belongs under ``default``) is refused, named."""
    import gymnasium

    import envs  # noqa: F401  (registers the DeadTime ids)

    fields = list(dict.fromkeys(f.name for schema in (TrainConfig, LearnedRuleConfig, SelectorConfig) for f in dataclasses.fields(schema)))
    for key in data:
        if key == "default" or (isinstance(key, str) and key in gymnasium.registry):
            continue
        if key in fields:
            raise ValueError(f"unknown config key {key!r} at the top of {path} (put it under 'default')")
        close = difflib.get_close_matches(str(key), fields, n=1)
        hint = f" (did you mean {close[0]!r}, under 'default'?)" if close else did_you_mean(
            key, ["default", *sorted(k for k in gymnasium.registry if k.startswith("DeadTime/"))])
        raise ValueError(f"unknown config key {key!r} at the top of {path}{hint}: the top holds 'default' and "
                         "entries keyed by registered environment ids")


def _schema(algorithm: Any) -> type:
    """:class:`TrainConfig`, or for ``algorithm: learned-rule`` the learned rule's config, for ``algorithm:
    selector`` the selector's."""
    name = algorithm.lower() if isinstance(algorithm, str) else None
    return {LEARNED_RULE: LearnedRuleConfig, SELECTOR: SelectorConfig}.get(name, TrainConfig)


def _override_value(overrides: Sequence[str], key: str) -> Any:
    value = None
    for text in overrides:
        path, parsed = parse_override(text)
        if path == [key]:
            value = parsed
    return value


# ----------------------------------------------------------------------------------- validation
def validate(config: TrainConfig) -> None:
    """Check ``hyperparameters``, ``policy``, ``policy_kwargs`` and ``env_kwargs`` against the constructors:
    the keys, then the values (:mod:`agents.training.hyperparameters`).

    Imports stable-baselines3 (hence torch) and the environment's module.  The values of
    ``env_kwargs`` are checked by the environment itself: one is made and reset with the training
    seed (and ``deadtime train`` builds them all before anything is written).

    A learned-rule config (:class:`agents.training.learned_rule_config.LearnedRuleConfig`) has no
    stable-baselines3 keys: it is checked by
    :func:`agents.training.learned_rule_config.validate_learned_rule`.

    Raises
    ------
    ValueError
        Naming the first unknown key or invalid value.
    """
    if isinstance(config, LearnedRuleConfig):
        validate_learned_rule(config)
        return
    if isinstance(config, SelectorConfig):
        validate_selector(config)
        return
    algorithm = algorithm_class(config.algorithm)
    accepted, _ = parameters(algorithm.__init__)
    for key in config.hyperparameters:
        if key in _RESERVED:
            raise ValueError(f"hyperparameters.{key} is not allowed here (it is set by {_RESERVED[key]})")
        if key not in accepted:
            raise ValueError(f"unknown hyperparameter {key!r} for {config.algorithm} "
                             f"(known: {', '.join(sorted(accepted - set(_RESERVED) - {'self'}))})")
    if config.policy not in algorithm.policy_aliases:
        raise ValueError(f"unknown policy {config.policy!r} for {config.algorithm} (known: {', '.join(algorithm.policy_aliases)})")
    policy_class = algorithm.policy_aliases[config.policy]
    accepted, open_ended = parameters(policy_class.__init__)
    accepted -= {"self", "observation_space", "action_space", "lr_schedule"}
    for key in config.policy_kwargs:
        if key not in accepted and not open_ended:
            raise ValueError(f"unknown policy_kwargs key {key!r} for {config.algorithm} {config.policy} "
                             f"(known: {', '.join(sorted(accepted))})")
    from agents.training.hyperparameters import check_hyperparameters, check_policy_kwargs

    check_hyperparameters(config.algorithm, config.hyperparameters, config.n_envs)
    check_policy_kwargs(config.policy_kwargs)
    _validate_device(config.device)
    check_env_kwargs(config)
    _validate_native(config)
    probe_environment(config)


def _validate_device(device: str) -> None:
    """``auto`` (stable-baselines3's choice) or a device torch can name (``cpu``, ``cuda``, ``cuda:1``)."""
    import torch

    if device == "auto":
        return
    try:
        torch.device(device)
    except (RuntimeError, TypeError, ValueError):
        raise ValueError(f"device must be auto or a torch device such as cpu, cuda or cuda:0, got {device!r}") from None


def _validate_native(config: TrainConfig) -> None:
    """``vec_env: native`` needs an id with a native vector environment, in the fixed mode."""
    if config.vec_env != "native":
        return
    import gymnasium

    if gymnasium.spec(config.env_id).vector_entry_point is None:
        raise ValueError(f"vec_env: native needs an environment with a native vector environment "
                         f"(vector_entry_point); {config.env_id} has none (use dummy or subproc)")
    mode = config.env_kwargs.get("experiments", "fixed")
    if mode != "fixed":
        raise ValueError(f"vec_env: native runs the fixed mode only, but env_kwargs.experiments is {mode!r} "
                         "(use dummy or subproc)")


def algorithm_class(name: str) -> type:
    """The class of an algorithm of :data:`ALGORITHMS` (imports stable-baselines3, or sb3-contrib)."""
    if name == "MaskablePPO":
        from sb3_contrib import MaskablePPO

        return MaskablePPO
    import stable_baselines3

    return getattr(stable_baselines3, name)
