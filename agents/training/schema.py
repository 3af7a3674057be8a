"""What the two training-config schemas share: reading their values, and checking their environment.

:class:`agents.training.config.TrainConfig` (a stable-baselines3 agent) and
:class:`agents.training.learned_rule_config.LearnedRuleConfig` (the learned rule) are both frozen
dataclasses read from the same zoo-style files: their fields are checked with :func:`require_field`,
numbers in exponent form read with :func:`yaml_number`, mappings frozen with :func:`frozen_mapping`,
and a misspelled key named with :func:`did_you_mean`.  Both name a registered environment and its
keyword arguments, checked by :func:`check_env_kwargs` (the keys, against the environment's
signature) and :func:`probe_environment` (the values, by one reset); an error of building anything
from a config is reported in one line by :func:`refused_as`.
"""

from __future__ import annotations

import difflib
import inspect
import re
from collections.abc import Callable, Mapping, Sequence
from types import MappingProxyType
from typing import Any

__all__ = ["check_env_kwargs", "config_from_dict", "did_you_mean", "frozen_mapping", "integer_field", "mapping_field", "parameters",
           "plain_value", "probe_environment", "refused_as", "require_field", "set_integer_fields", "whole_number", "whole_numbers",
           "yaml_number"]


def frozen_mapping(mapping: Mapping[str, Any]) -> Mapping[str, Any]:
    """A read-only copy of ``mapping`` (the mapping fields of a frozen config)."""
    return MappingProxyType(dict(mapping))

_EXPONENT_NUMBER = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)[eE][-+]?\d+")


def whole_number(value: Any) -> Any:
    """A float that is a whole number (``1e3`` read as ``1000.0``) as the integer; any other value unchanged."""
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value


def whole_numbers(value: Any) -> Any:
    """:func:`whole_number` of every number in a list or mapping of lists (``net_arch: [1e3]``, ``{pi: [64]}``)."""
    if isinstance(value, Mapping):
        return {key: whole_numbers(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [whole_number(item) for item in value]
    return whole_number(value)


def yaml_number(value: Any) -> Any:
    """A number written in exponent form without a dot or sign (``1e5``, ``3e-4``), which YAML 1.1
    reads as a string, as a float; any other value unchanged."""
    if isinstance(value, str) and _EXPONENT_NUMBER.fullmatch(value.strip()):
        return float(value)
    return value


def mapping_field(value: Any, where: str, known: Sequence[str], required: Sequence[str] = ()) -> Mapping[str, Any]:
    """``value`` as a mapping of only the ``known`` keys and every ``required`` one, else one line naming ``where``."""
    if not isinstance(value, Mapping):
        raise ValueError(f"{where} must be a mapping, got {type(value).__name__}")
    unknown = [key for key in value if key not in known]
    if unknown:
        raise ValueError(f"unknown key {unknown[0]!r} in {where} (known keys: {', '.join(known)})")
    missing = [key for key in required if key not in value]
    if missing:
        raise ValueError(f"{where} needs {missing[0]!r}")
    return value


def integer_field(value: Any, where: str, minimum: int) -> int:
    """``value`` as an integer of at least ``minimum`` (not a bool), else one line naming ``where``."""
    if isinstance(value, bool) or not isinstance(value, int) or value < minimum:
        raise ValueError(f"{where} must be an integer >= {minimum}, got {value!r}")
    return value


def did_you_mean(key: Any, known: Sequence[str]) -> str:
    """``" (did you mean 'total_timesteps'?)"`` for the known name closest to a misspelled ``key``, or ``""``.

    >>> did_you_mean("total_timestep", ["seed", "total_timesteps"]), did_you_mean("xyz", ["seed"])
    (" (did you mean 'total_timesteps'?)", '')
    """
    close = difflib.get_close_matches(str(key), list(known), n=1)
    return f" (did you mean {close[0]!r}?)" if close else ""


def require_field(condition: bool, name: str, what: str, value: Any) -> None:
    if not condition:
        raise ValueError(f"{name} must be {what}, got {value!r}")


def plain_value(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {key: plain_value(item) for key, item in value.items()}
    if isinstance(value, tuple | list):
        return [plain_value(item) for item in value]
    return value

def parameters(function: Any) -> tuple[set[str], bool]:
    """Names a callable accepts, and whether it takes ``**kwargs``."""
    parameters = inspect.signature(function).parameters.values()
    names = {p.name for p in parameters if p.kind in (p.POSITIONAL_OR_KEYWORD, p.KEYWORD_ONLY)}
    return names, any(p.kind is p.VAR_KEYWORD for p in parameters)

def refused_as(key: str, refuser: str, build: Callable[[], Any]) -> Any:
    """``build()``, with an error it raises reported in one line as ``refuser`` refusing ``key``."""
    try:
        return build()
    except (ValueError, TypeError, KeyError, AssertionError, OverflowError) as error:
        raise ValueError(f"{key}: refused by {refuser}: {error or error.__class__.__name__}") from None

def check_env_kwargs(config: Any) -> None:
    """``env_id`` registered, and every key of ``env_kwargs`` one the environment's constructor (or
    ``gymnasium.make``) accepts; read from the signature, no environment is made."""
    import gymnasium

    from agents.environments import require_registered

    require_registered(config.env_id, "env_id")
    try:
        spec = gymnasium.spec(config.env_id)
    except (gymnasium.error.Error, ImportError) as error:  # "module:Id-v0" of a module that fails or registers no such id
        raise ValueError(f"env_id {config.env_id!r}: {error}") from None
    entry_point = spec.entry_point
    if isinstance(entry_point, str):
        from gymnasium.envs.registration import load_env_creator

        entry_point = load_env_creator(entry_point)
    target = entry_point.__init__ if inspect.isclass(entry_point) else entry_point
    accepted, open_ended = parameters(target)
    accepted |= {"max_episode_steps", "disable_env_checker", "autoreset", "apply_api_compatibility"}
    for key in config.env_kwargs:
        if key not in accepted and not open_ended:
            raise ValueError(f"unknown env_kwargs key {key!r} for {config.env_id} "
                             f"(known: {', '.join(sorted(accepted - {'self'}))})")

def probe_environment(config: Any, env: Any = None) -> None:
    """Reset one environment of ``config`` with its seed: ``env_kwargs`` values that only an episode
    uses (a family's config, a render mode) are refused here, before anything is written.  The
    environment is ``env`` if given (left open), else one made for the probe (closed)."""
    from agents.environments import make_env

    made = None
    try:
        if env is None:
            env = made = make_env(config.env_id, config.env_kwargs)
        env.reset(seed=config.seed)
    except (ValueError, TypeError, KeyError, AssertionError, OverflowError) as error:
        raise ValueError(f"env_kwargs: refused by {config.env_id}: {error or error.__class__.__name__}") from None
    finally:
        if made is not None:
            made.close()


def config_from_dict(schema: type, data: Mapping[str, Any], where: str, required: Sequence[str], algorithm: str) -> Any:
    """``schema(**data)`` of a config dataclass whose ``algorithm`` is ``algorithm``; an unknown key (with the
    closest known one) or a missing ``required`` one is a ``ValueError`` naming it and ``where``."""
    import dataclasses

    known = [f.name for f in dataclasses.fields(schema)]
    for key in data:
        if key not in known:
            raise ValueError(f"unknown config key {key!r} in {where}{did_you_mean(key, known)} (known keys of a {algorithm} "
                             f"config: {', '.join(known)})")
    missing = [name for name in required if name not in data]
    if missing:
        raise ValueError(f"{where} is missing the required key(s) {', '.join(missing)}")
    return schema(**data)


def set_integer_fields(config: Any, bounds: Sequence[tuple[str, float, float]]) -> None:
    """Check (and set, read as integers) the fields ``(name, low, high)`` of a frozen config: each an
    integer in ``[low, high]`` (``1e3`` read as 1000), else a ``ValueError`` naming it."""
    import math

    for name, low, high in bounds:
        value = yaml_number(getattr(config, name))
        if isinstance(value, float) and value.is_integer():
            value = int(value)
            object.__setattr__(config, name, value)
        what = f"an integer >= {low}" + ("" if high == math.inf else f" and <= {high}")
        require_field(isinstance(value, int) and not isinstance(value, bool) and low <= value <= high, name, what, value)
