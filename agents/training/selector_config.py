"""The config of a selector: ``algorithm: selector`` (``configs/selector.yaml``).

A selector chooses, per plant, one of several candidate designs from the observation
(:mod:`agents.training.selector`).  Read by :func:`agents.training.config.load_config` like the other
configs (the same zoo-style file, precedence and ``key=value`` overrides); a file whose resolved
``algorithm`` is ``selector`` gives a :class:`SelectorConfig`, which ``deadtime train`` fits with
:func:`agents.training.selector.fit`.  An unknown key, or a value of the wrong type or range, is a
``ValueError`` that names the key.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from agents.limits import MAX_EVAL_EPISODES
from agents.training.learned_rule_config import MAX_TRAINING_PLANTS
from agents.training.schema import config_from_dict, frozen_mapping, plain_value, require_field, set_integer_fields, yaml_number

__all__ = ["LEARNED", "SELECTOR", "SelectorConfig", "validate_selector"]

SELECTOR = "selector"
"""The ``algorithm`` value of a selector config."""

LEARNED = "learned"
"""The candidate that names the selector's own learned design (fitted in ``RUN/learned`` from
``learned_config`` with ``learned_overrides``, on the selector's environment and seed)."""

DEFAULT_THRESHOLDS = (0.0, 0.0001, 0.0002, 0.0005, 0.001, 0.002, 0.005, 0.01, 0.02, 0.05, 0.1, 0.2, 0.5)
"""The largest predicted probabilities of violating that a candidate may have to be chosen, tried in
this order on the validation plants (fixed-sequence testing, :mod:`agents.training.selector`); 0
gives every plant the candidate least likely to violate."""


@dataclass(frozen=True)
class SelectorConfig:
    """Everything a selector's fit depends on.

    Attributes
    ----------
    algorithm : str
        ``selector``.
    env_id : str
        A ``DeadTime`` id in the fixed mode (``env_kwargs`` may set a ``plan``).
    seed : int
        Selects the training plants (those of a learned-rule fit of the same seed) and seeds the models.
    env_kwargs : mapping
        Keyword arguments of ``gymnasium.make``.
    candidates : sequence of str
        The designs to choose from, in order (the first is the default where the models cannot tell):
        rule names, ``learned`` (the selector's own learned design), or ``NAME=PATH``, a finished
        learned-rule fit (``{seed}`` in ``PATH`` is replaced by the seed).
    learned_config : str
        The learned-rule config of the ``learned`` candidate.
    learned_overrides : sequence of str
        Its ``key=value`` overrides (the environment, its arguments, the seed and the output folder
        are the selector's).
    training_plants : int
        Plants on which every candidate is scored, to train the models.
    validation_plants : int
        Plants of the fixed validation set on which the threshold is chosen.
    thresholds : sequence of float
        The thresholds to try (0 <= t <= 1, in the order of the fixed-sequence test).
    violation_target : float or None
        The certified share of violating plants (0 < alpha < 1); null chooses by validation cost alone.
    violation_confidence : float
        The confidence of the certificate (0 < c < 1).
    output_dir : str or None
        Run directory; default ``runs/selector-<env name>-s<seed>``.
    progress_bar : bool
        Show a progress bar over the plants.
    """

    algorithm: str
    env_id: str
    seed: int = 0
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    candidates: tuple[str, ...] = ()
    learned_config: str = "configs/learned_plan.yaml"
    learned_overrides: tuple[str, ...] = ()
    training_plants: int = 1000
    validation_plants: int = 500
    thresholds: tuple[float, ...] = DEFAULT_THRESHOLDS
    violation_target: float | None = 0.01
    violation_confidence: float = 0.95
    output_dir: str | None = None
    progress_bar: bool = True

    def __post_init__(self) -> None:
        require_field(isinstance(self.algorithm, str) and self.algorithm.lower() == SELECTOR, "algorithm", repr(SELECTOR),
                      self.algorithm)
        object.__setattr__(self, "algorithm", SELECTOR)
        require_field(isinstance(self.env_id, str) and bool(self.env_id), "env_id", "a non-empty string", self.env_id)
        set_integer_fields(self, (("seed", 0, math.inf), ("training_plants", 10, MAX_TRAINING_PLANTS // 2),
                                 ("validation_plants", 1, MAX_EVAL_EPISODES)))
        require_field(isinstance(self.env_kwargs, Mapping) and all(isinstance(k, str) for k in self.env_kwargs),
                      "env_kwargs", "a mapping with string keys", self.env_kwargs)
        require_field(self.env_kwargs.get("experiments", "fixed") == "fixed", "env_kwargs",
                      "the fixed mode (a plan of amplitudes may be set with plan: [A1, A2])", dict(self.env_kwargs))
        object.__setattr__(self, "env_kwargs", frozen_mapping(self.env_kwargs))
        object.__setattr__(self, "candidates", _strings("candidates", self.candidates, minimum=2))
        require_field(len({_name(c) for c in self.candidates}) == len(self.candidates), "candidates", "distinct names",
                      list(self.candidates))
        require_field(isinstance(self.learned_config, str) and bool(self.learned_config), "learned_config", "a path",
                      self.learned_config)
        object.__setattr__(self, "learned_overrides", _strings("learned_overrides", self.learned_overrides, minimum=0))
        thresholds = tuple(yaml_number(t) for t in (self.thresholds if isinstance(self.thresholds, list | tuple) else ()))
        require_field(bool(thresholds) and all(isinstance(t, int | float) and not isinstance(t, bool) and 0 <= t <= 1
                                               for t in thresholds) and len(set(thresholds)) == len(thresholds),
                      "thresholds", "a non-empty list of distinct numbers in [0, 1]", self.thresholds)
        object.__setattr__(self, "thresholds", tuple(float(t) for t in thresholds))
        for name, optional in (("violation_target", True), ("violation_confidence", False)):
            value = yaml_number(getattr(self, name))
            ok = (optional and value is None) or (isinstance(value, int | float) and not isinstance(value, bool) and 0 < value < 1)
            require_field(ok, name, "a number strictly between 0 and 1" + (" or null" if optional else ""), value)
            object.__setattr__(self, name, None if value is None else float(value))
        require_field(self.output_dir is None or (isinstance(self.output_dir, str) and bool(self.output_dir)), "output_dir",
                      "a non-empty string or null", self.output_dir)
        require_field(isinstance(self.progress_bar, bool), "progress_bar", "true or false", self.progress_bar)

    @property
    def run_name(self) -> str:
        """``selector-<env name>-s<seed>``, e.g. ``selector-PID-v3-s0``."""
        return f"{SELECTOR}-{self.env_id.rsplit('/', 1)[-1]}-s{self.seed}"

    def candidate_names(self) -> tuple[str, ...]:
        """The candidates' names as results show them (``NAME`` of ``NAME=PATH``)."""
        return tuple(_name(c) for c in self.candidates)

    def to_dict(self) -> dict[str, Any]:
        """Plain values (for YAML and JSON), in field order."""
        return {f.name: plain_value(getattr(self, f.name)) for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "config") -> SelectorConfig:
        """Build from a mapping of field names; unknown or missing keys are errors naming them."""
        return config_from_dict(cls, data, where, ("algorithm", "env_id", "candidates"), SELECTOR)


def _name(candidate: str) -> str:
    return candidate.split("=", 1)[0]


def _strings(name: str, value: Any, minimum: int) -> tuple[str, ...]:
    items = value if isinstance(value, list | tuple) else None
    what = "a list of non-empty strings" + (f" (at least {minimum})" if minimum else "")
    require_field(items is not None and len(items) >= minimum and all(isinstance(i, str) and i for i in items), name, what, value)
    return tuple(items)


def validate_selector(config: SelectorConfig) -> None:
    """Check the environment (the fixed mode, one reset with the seed) and that every rule candidate
    is a rule of its structure; raises ``ValueError`` naming what is wrong."""
    from agents.environments import make_env
    from agents.training.schema import check_env_kwargs, probe_environment, refused_as
    from baselines.rules.registry import applicable_rules
    from envs.interface import tuning_env_of

    check_env_kwargs(config)
    env = refused_as("env_kwargs", config.env_id, lambda: make_env(config.env_id, config.env_kwargs))
    try:
        probe_environment(config, env)
        rules = applicable_rules(tuning_env_of(env).structure)
    finally:
        env.close()
    for candidate in config.candidates:
        if candidate != LEARNED and "=" not in candidate and candidate not in rules:
            raise ValueError(f"candidates: {candidate!r} is not a rule of {config.env_id} (nor 'learned' or NAME=PATH)")
