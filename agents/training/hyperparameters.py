"""The values of the stable-baselines3 hyperparameters and policy arguments, checked before training.

Each constraint is the one stable-baselines3 2.x itself needs (read off its constructors and
``_setup_model``, where it asserts, or fails later with a ``TypeError`` deep inside training, or
silently trains something else): e.g. PPO asserts ``batch_size > 1`` and ``n_steps * n_envs > 1``
when it normalizes advantages; ``train_freq`` counts steps or episodes, episodes only with one
environment; SAC's ``ent_coef`` is a positive number, ``auto`` or ``auto_<initial value>``.  A
violation is a ``ValueError`` naming the key, the rule and the value.  Constructors' own errors for
anything left over are reported by the caller (``agents.training.train``) before anything is written.

``learning_rate`` (and PPO's ``clip_range``) is a positive number, or from YAML the linear schedule
``{linear: [start, end]}`` (stable-baselines3's ``LinearSchedule`` from ``start`` at the first step to
``end`` at the last); a Python callable is accepted from the Python API.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from numbers import Real
from typing import Any

from agents.limits import MAX_BUFFER_SIZE, MAX_LAYER_WIDTH, MAX_LAYERS, require_at_most

__all__ = ["check_hyperparameters", "check_policy_kwargs", "schedule"]

Check = Callable[[Any], bool]


def _integer(low: int) -> tuple[Check, str]:
    return (lambda v: isinstance(v, int) and not isinstance(v, bool) and v >= low), f"an integer >= {low}"


def _number(low: float = -math.inf, high: float = math.inf, open_low: bool = False) -> tuple[Check, str]:
    def check(value: Any) -> bool:
        if not isinstance(value, Real) or isinstance(value, bool) or not math.isfinite(value):
            return False
        return (value > low if open_low else value >= low) and value <= high

    bounds = ("> " if open_low else ">= ") + f"{low:g}" if math.isfinite(low) else ""
    if math.isfinite(high):
        bounds = f"in {'(' if open_low else '['}{low:g}, {high:g}]"
    return check, f"a number {bounds}".rstrip()


def _boolean() -> tuple[Check, str]:
    return (lambda v: isinstance(v, bool)), "true or false"


def _optional(rule: tuple[Check, str]) -> tuple[Check, str]:
    return (lambda v: v is None or rule[0](v)), f"null or {rule[1]}"


def _is_schedule(value: Any) -> bool:
    if callable(value):
        return True
    if isinstance(value, Mapping):
        pair = value.get("linear")
        return (set(value) == {"linear"} and isinstance(pair, list | tuple) and len(pair) == 2
                and all(_number(0.0)[0](v) for v in pair) and pair[0] > 0)
    return _number(0.0, open_low=True)[0](value)


SCHEDULE = (_is_schedule, "a positive number or {linear: [start > 0, end >= 0]}")
PROBABILITY = _number(0.0, 1.0)
# Shared by every algorithm, then each algorithm's own.
COMMON: dict[str, tuple[Check, str]] = {
    "learning_rate": SCHEDULE, "gamma": PROBABILITY, "use_sde": _boolean(), "sde_sample_freq": _integer(-1),
    "stats_window_size": _integer(1),
}
ON_POLICY = {"n_steps": _integer(1), "gae_lambda": PROBABILITY, "ent_coef": _number(0.0), "vf_coef": _number(0.0),
             "max_grad_norm": _number(0.0, open_low=True), "normalize_advantage": _boolean()}
OFF_POLICY = {"buffer_size": _integer(1), "learning_starts": _integer(0), "batch_size": _integer(1),
              "tau": _number(0.0, 1.0, open_low=True), "gradient_steps": (lambda v: _integer(1)[0](v) or v == -1,
                                                                          "an integer >= 1, or -1"),
              "optimize_memory_usage": _boolean(), "n_steps": _integer(1)}
INTEGER_KEYS = frozenset({"sde_sample_freq", "stats_window_size", "n_steps", "buffer_size", "learning_starts", "batch_size",
                          "gradient_steps", "n_epochs", "target_update_interval", "policy_delay"})
"""The hyperparameters that are counts: written ``1e3`` or ``3E4`` (a float), a whole number is read as the integer."""

RULES: dict[str, dict[str, tuple[Check, str]]] = {
    "PPO": {**COMMON, **ON_POLICY, "batch_size": _integer(1), "n_epochs": _integer(1), "clip_range": SCHEDULE,
            "clip_range_vf": _optional(_number(0.0, open_low=True)), "target_kl": _optional(_number(0.0, open_low=True))},
    "A2C": {**COMMON, **ON_POLICY, "rms_prop_eps": _number(0.0, open_low=True), "use_rms_prop": _boolean()},
    "SAC": {**COMMON, **OFF_POLICY, "target_update_interval": _integer(1), "use_sde_at_warmup": _boolean(),
            "ent_coef": (lambda v: _number(0.0, open_low=True)[0](v) or _auto(v), "a positive number, auto or auto_<x > 0>"),
            "target_entropy": (lambda v: v == "auto" or _number()[0](v), "auto or a number")},
    "TD3": {**COMMON, **OFF_POLICY, "policy_delay": _integer(1), "target_policy_noise": _number(0.0),
            "target_noise_clip": _number(0.0)},
}
RULES["MaskablePPO"] = RULES["PPO"]  # sb3-contrib's PPO with action masks: PPO's hyperparameters
# Constructor arguments that take classes or objects, which a YAML file cannot give.
NOT_FROM_CONFIG = ("rollout_buffer_class", "rollout_buffer_kwargs", "replay_buffer_class", "replay_buffer_kwargs")


def _auto(value: Any) -> bool:
    if not isinstance(value, str) or not value.startswith("auto"):
        return False
    if value == "auto":
        return True
    try:
        return value.startswith("auto_") and float(value[5:]) > 0
    except ValueError:
        return False


def schedule(value: Any) -> Any:
    """A ``learning_rate``/``clip_range`` value as stable-baselines3 takes it (``{linear: [a, b]}`` as a schedule)."""
    if isinstance(value, Mapping):
        from stable_baselines3.common.utils import LinearSchedule

        start, end = value["linear"]
        return LinearSchedule(float(start), float(end), 1.0)
    return value


def check_hyperparameters(algorithm: str, hyperparameters: Mapping[str, Any], n_envs: int) -> None:
    """Check the values of an algorithm's hyperparameters (the keys are checked by ``agents.training.config``).

    Raises
    ------
    ValueError
        Naming the first key whose value stable-baselines3 would refuse or misread.
    """
    rules = RULES[algorithm]
    for key, value in hyperparameters.items():
        if key in NOT_FROM_CONFIG:
            raise ValueError(f"hyperparameters.{key} cannot be set from a config (it takes a Python class)")
        if key in rules and not rules[key][0](value):
            raise ValueError(f"hyperparameters.{key} must be {rules[key][1]}, got {value!r}")
    for key in ("buffer_size", "batch_size"):
        if key in hyperparameters:
            require_at_most(hyperparameters[key], MAX_BUFFER_SIZE, f"hyperparameters.{key}")
    if isinstance(hyperparameters.get("n_steps"), int):  # the rollout buffer holds n_steps * n_envs transitions
        require_at_most(hyperparameters["n_steps"] * n_envs, MAX_BUFFER_SIZE, "hyperparameters.n_steps * n_envs")
    if "train_freq" in hyperparameters:
        _check_train_freq(hyperparameters["train_freq"], n_envs)
    if "action_noise" in hyperparameters:
        _check_action_noise(hyperparameters["action_noise"])
    if algorithm in ("PPO", "MaskablePPO"):
        _check_ppo(hyperparameters, n_envs)


def _check_ppo(hyperparameters: Mapping[str, Any], n_envs: int) -> None:
    """PPO's assertions: with advantage normalization, ``batch_size > 1`` and ``n_steps * n_envs > 1``."""
    if not hyperparameters.get("normalize_advantage", True):
        return
    batch_size, n_steps = hyperparameters.get("batch_size", 64), hyperparameters.get("n_steps", 2048)
    if batch_size < 2:
        raise ValueError(f"hyperparameters.batch_size must be > 1 for PPO with normalize_advantage (the advantages "
                         f"of one sample cannot be normalized), got {batch_size!r}")
    if n_steps * n_envs < 2:
        raise ValueError(f"hyperparameters.n_steps * n_envs must be > 1 for PPO with normalize_advantage, "
                         f"got {n_steps} * {n_envs}")


def _check_train_freq(value: Any, n_envs: int) -> None:
    frequency, unit = (value, "step") if not isinstance(value, list | tuple) else (tuple(value) + (None,))[:2]
    valid = (_integer(1)[0](frequency) and unit in ("step", "episode")
             and (not isinstance(value, list | tuple) or len(value) == 2))
    if not valid:
        raise ValueError(f"hyperparameters.train_freq must be an integer >= 1 or [n >= 1, step | episode], got {value!r}")
    if unit == "episode" and n_envs > 1:
        raise ValueError(f"hyperparameters.train_freq in episodes needs n_envs = 1 (stable-baselines3), got n_envs = {n_envs}")


def _check_action_noise(noise: Any) -> None:
    kinds = ("normal", "ornstein-uhlenbeck")
    if (not isinstance(noise, Mapping) or set(noise) != {"type", "sigma"} or noise["type"] not in kinds
            or not _number(0.0)[0](noise["sigma"])):
        raise ValueError(f"hyperparameters.action_noise must be null or {{type: normal | ornstein-uhlenbeck, "
                         f"sigma: s >= 0}}, got {noise!r}")


def check_policy_kwargs(policy_kwargs: Mapping[str, Any]) -> None:
    """Check the values of the policy arguments a config sets most (``net_arch``, ``n_critics``, flags).

    Raises
    ------
    ValueError
        Naming the first key with a value the policy cannot be built from.
    """
    net_arch = policy_kwargs.get("net_arch")
    if net_arch is not None and not _is_layers(net_arch):
        if not (isinstance(net_arch, Mapping) and net_arch and all(_is_layers(v) for v in net_arch.values())
                and set(net_arch) <= {"pi", "vf", "qf"}):
            raise ValueError(f"policy_kwargs.net_arch must be a list of layer sizes >= 1 or {{pi: [...], vf|qf: [...]}}, "
                             f"got {net_arch!r}")
    if net_arch is not None:
        _check_network_size(net_arch)
    rules = {"n_critics": _integer(1), "log_std_init": _number(), "ortho_init": _boolean(),
             "share_features_extractor": _boolean(), "normalize_images": _boolean(), "squash_output": _boolean(),
             "use_expln": _boolean(), "full_std": _boolean(), "optimizer_kwargs": ((lambda v: isinstance(v, Mapping)), "a mapping")}
    for key, (check, what) in rules.items():
        if key in policy_kwargs and not check(policy_kwargs[key]):
            raise ValueError(f"policy_kwargs.{key} must be {what}, got {policy_kwargs[key]!r}")


def _check_network_size(net_arch: Any) -> None:
    """At most :data:`agents.limits.MAX_LAYERS` hidden layers of at most :data:`agents.limits.MAX_LAYER_WIDTH` units."""
    for layers in net_arch.values() if isinstance(net_arch, Mapping) else [net_arch]:
        require_at_most(len(layers), MAX_LAYERS, "the number of hidden layers of policy_kwargs.net_arch")
        require_at_most(max(layers, default=0), MAX_LAYER_WIDTH, "a layer of policy_kwargs.net_arch")


def _is_layers(value: Any) -> bool:
    return isinstance(value, list | tuple) and all(_integer(1)[0](v) for v in value)
