"""The config of a learned-rule fit: ``algorithm: learned-rule`` (``configs/learned_rule.yaml``).

Read by :func:`agents.training.config.load_config` like the configs of stable-baselines3 agents (the
same zoo-style file, precedence and ``key=value`` overrides); a file whose resolved ``algorithm`` is
``learned-rule`` gives a :class:`LearnedRuleConfig`, which ``deadtime train`` fits with
:mod:`agents.training.learned_rule` instead of training an agent.  An unknown key, or a value of the
wrong type or range, is a ``ValueError`` that names the key; :func:`validate_learned_rule` checks the
environment it names.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from agents.limits import MAX_EVAL_EPISODES
from agents.training.schema import (
    check_env_kwargs,
    config_from_dict,
    frozen_mapping,
    plain_value,
    probe_environment,
    refused_as,
    require_field,
    set_integer_fields,
    yaml_number,
)
from baselines.learned_rule import MARGIN_SCALES, QUANTILE

__all__ = ["LABEL_SEARCHES", "LEARNED_RULE", "LearnedRuleConfig", "MAX_TRAINING_PLANTS", "check_environment", "validate_learned_rule"]

LEARNED_RULE = "learned-rule"
"""The ``algorithm`` value of a learned-rule config."""

MAX_TRAINING_PLANTS = 1_000_000
"""The most training plants of one fit (the stride of the training seeds, :mod:`agents.training.learned_rule`)."""

LABEL_SEARCHES = ("reference", "fast")
"""The oracle searches that label the training plants (:data:`baselines.oracle.SEARCHES`)."""

DEFAULT_MARGINS = tuple(round(0.025 * i, 3) for i in range(21))
"""0 to 0.5 action units in steps of 0.025."""


@dataclass(frozen=True)
class LearnedRuleConfig:
    """Everything a learned-rule fit depends on.

    Attributes
    ----------
    algorithm : str
        ``learned-rule``.
    env_id : str
        A registered Gymnasium id whose action has one component (a fixed-mode ``DeadTime`` id).
    seed : int
        Selects the training plants (:mod:`agents.training.learned_rule`): each seed draws others.
    env_kwargs : mapping
        Keyword arguments of ``gymnasium.make``.
    training_plants : int
        Plants drawn by the environment's generator, each labelled by the oracle (10 to
        :data:`MAX_TRAINING_PLANTS`).
    validation_plants : int
        Plants of the fixed validation set on which the model kind and the margin are chosen.
    margins : sequence of float
        The safety margins to try (action units, >= 0, distinct).
    margin_scale : str
        ``constant`` (the margin as it is) or ``spread`` (scaled per plant by the width of the
        ``quantile``/``1 - quantile`` band of two quantile trees, mean 1 over the training plants;
        :mod:`baselines.learned_rule`, "Margin scales").
    models : sequence of str
        The model kinds to try (:data:`baselines.learned_rule.MODEL_KINDS`, distinct).
    quantile : float
        The quantile that ``quantile-boosting`` estimates (0 < q < 1; default
        :data:`baselines.learned_rule.QUANTILE`).
    violation_target : float or None
        If set (0 < alpha < 1), the kind and margin are chosen only among those whose violation rate on
        new plants is certified to be at most this, with ``violation_confidence``, from the validation
        plants (:func:`baselines.learned_rule.select`, "Certified margins"); null chooses by mean
        validation cost alone.
    violation_confidence : float
        The probability (0 < c < 1) over the draw of the validation plants with which the certified
        rate holds.
    labels : str
        The oracle's search that labels the training plants: ``reference`` (the grid, Brent and probes
        of :mod:`baselines.oracle`; every committed fit) or ``fast`` (:mod:`baselines.fast_search`:
        the same optimum within the oracle's tolerance, several times quicker, and each record also
        holds the feasibility boundary; docs/performance.md, "Labels").
    output_dir : str or None
        Run directory; default ``runs/learned-rule-<env name>-s<seed>``.
    progress_bar : bool
        Show a tqdm progress bar over the training plants.
    """

    algorithm: str
    env_id: str
    seed: int = 0
    env_kwargs: Mapping[str, Any] = field(default_factory=dict)
    training_plants: int = 1000
    validation_plants: int = 500
    margins: tuple[float, ...] = DEFAULT_MARGINS
    margin_scale: str = "constant"
    models: tuple[str, ...] = ("boosting", "quantile-boosting")
    quantile: float = QUANTILE
    violation_target: float | None = None
    violation_confidence: float = 0.95
    labels: str = "reference"
    output_dir: str | None = None
    progress_bar: bool = True

    def __post_init__(self) -> None:
        require_field(isinstance(self.algorithm, str) and self.algorithm.lower() == LEARNED_RULE, "algorithm", repr(LEARNED_RULE),
                 self.algorithm)
        object.__setattr__(self, "algorithm", LEARNED_RULE)
        require_field(isinstance(self.env_id, str) and bool(self.env_id), "env_id", "a non-empty string", self.env_id)
        set_integer_fields(self, (("seed", 0, math.inf), ("training_plants", 10, MAX_TRAINING_PLANTS),
                                 ("validation_plants", 1, MAX_EVAL_EPISODES)))
        require_field(isinstance(self.env_kwargs, Mapping) and all(isinstance(k, str) for k in self.env_kwargs),
                 "env_kwargs", "a mapping with string keys", self.env_kwargs)
        object.__setattr__(self, "env_kwargs", frozen_mapping(self.env_kwargs))
        object.__setattr__(self, "margins", _margins(self.margins))
        require_field(self.margin_scale in MARGIN_SCALES, "margin_scale", f"one of {', '.join(MARGIN_SCALES)}", self.margin_scale)
        object.__setattr__(self, "models", _models(self.models))
        for name, optional in (("quantile", False), ("violation_target", True), ("violation_confidence", False)):
            object.__setattr__(self, name, _fraction(name, getattr(self, name), optional))
        require_field(self.margin_scale == "constant" or self.quantile != 0.5, "quantile",
                      "other than 0.5 with margin_scale: spread (the band between quantile and 1 - quantile)", self.quantile)
        require_field(self.labels in LABEL_SEARCHES, "labels", f"one of {', '.join(LABEL_SEARCHES)}", self.labels)
        require_field(self.output_dir is None or (isinstance(self.output_dir, str) and bool(self.output_dir)), "output_dir",
                 "a non-empty string or null", self.output_dir)
        require_field(isinstance(self.progress_bar, bool), "progress_bar", "true or false", self.progress_bar)

    @property
    def run_name(self) -> str:
        """``learned-rule-<env name>-s<seed>``, e.g. ``learned-rule-PID-v0-s0``."""
        return f"{LEARNED_RULE}-{self.env_id.rsplit('/', 1)[-1]}-s{self.seed}"

    def to_dict(self) -> dict[str, Any]:
        """Plain values (for YAML and JSON), in field order."""
        return {f.name: plain_value(getattr(self, f.name)) for f in dataclasses.fields(self)}

    @classmethod
    def from_dict(cls, data: Mapping[str, Any], where: str = "config") -> LearnedRuleConfig:
        """Build from a mapping of field names; unknown or missing keys are errors naming them."""
        return config_from_dict(cls, data, where, ("algorithm", "env_id"), LEARNED_RULE)


def _fraction(name: str, value: Any, optional: bool) -> float | None:
    """A number strictly between 0 and 1 (or None where ``optional``), as a float."""
    value = yaml_number(value)
    if optional and value is None:
        return None
    ok = isinstance(value, int | float) and not isinstance(value, bool) and 0 < value < 1
    require_field(ok, name, "a number strictly between 0 and 1" + (" or null" if optional else ""), value)
    return float(value)


def _margins(value: Any) -> tuple[float, ...]:
    items = value if isinstance(value, list | tuple) else None
    require_field(bool(items), "margins", "a non-empty list of numbers >= 0", value)
    margins = tuple(yaml_number(item) for item in items)
    require_field(all(isinstance(m, int | float) and not isinstance(m, bool) and math.isfinite(m) and m >= 0 for m in margins),
             "margins", "a non-empty list of numbers >= 0", value)
    require_field(len(set(margins)) == len(margins), "margins", "a list without repeats", value)
    return tuple(float(m) for m in margins)


def _models(value: Any) -> tuple[str, ...]:
    from baselines.learned_rule import MODEL_KINDS

    items = [value] if isinstance(value, str) else value
    what = f"a non-empty list of model kinds ({', '.join(MODEL_KINDS)})"
    require_field(isinstance(items, list | tuple) and bool(items) and all(item in MODEL_KINDS for item in items), "models", what, value)
    require_field(len(set(items)) == len(items), "models", "a list without repeats", value)
    return tuple(items)


def check_environment(config: LearnedRuleConfig) -> Any:
    """The environment of ``config``, made; refused in one line if its action has more than one component."""
    from agents.environments import make_env
    from envs.interface import tuning_env_of

    env = refused_as("env_kwargs", config.env_id, lambda: make_env(config.env_id, config.env_kwargs))
    shape = tuple(getattr(env.action_space, "shape", None) or ())
    mappings = all(hasattr(tuning_env_of(env), name) for name in ("action_from_parameter", "parameter_from_action"))
    if shape != (1,) or not mappings:
        env.close()
        raise ValueError(f"env_kwargs: the learned rule needs a one-component action (fixed mode) and the environment's "
                         f"action_from_parameter and parameter_from_action; {config.env_id} with env_kwargs "
                         f"{dict(config.env_kwargs)} has an action of shape {shape}")
    return env


def validate_learned_rule(config: LearnedRuleConfig) -> None:
    """Check the environment of ``config``: ``env_kwargs``' keys, an action of one component
    (:func:`check_environment`) and ``env_kwargs``' values (a reset of that environment with the seed).

    Raises
    ------
    ValueError
        Naming the first unknown key or invalid value.
    """
    check_env_kwargs(config)
    env = check_environment(config)
    try:
        probe_environment(config, env)
    finally:
        env.close()
