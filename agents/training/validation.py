"""Validation of a policy on the fixed validation plants, as ``deadtime train`` runs it.

:func:`validate_policy` runs one deterministic episode per plant of the validation set
``envs.systems.plant_sets.plant_set(family, "validation", n)`` (never a test set), resetting with
``options={"plant": p}`` and the seed ``VALIDATION_SEED + k`` (3_000_000 + k) for plant ``k``.  Used by
the stable-baselines3 callbacks (:mod:`agents.training.callbacks`) and by the learned rule's choice
of its model and margin (:mod:`agents.training.learned_rule`); numpy only, so the learned rule's
fit does not load torch.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

__all__ = ["VALIDATION_SEED", "ValidationResult", "action_masks", "validate_policy", "validation_plants"]

# Reset seed of validation plant k is VALIDATION_SEED + k: disjoint from the training environments
# (seed + i) and from deadtime evaluate's (seed + i, seed + 1_000_000 + j).
VALIDATION_SEED = 3_000_000


@dataclass(frozen=True)
class ValidationResult:
    """Deterministic-policy costs on the validation episodes."""

    num_timesteps: int
    mean_cost: float
    median_cost: float
    violation_rate: float | None
    costs: tuple[float, ...]

    def to_dict(self) -> dict[str, Any]:
        data = asdict(self)
        data["costs"] = list(self.costs)
        return data


def validation_plants(env: Any, n: int, family: str | None = None) -> list[Any] | None:
    """The validation plants of a ``DeadTime`` environment (None for other environments).

    ``family`` defaults to the environment's own (its ``family`` if it has one, else
    ``integrating`` for the MSP structure and ``stable`` otherwise).
    """
    from envs.interface import tuning_env_of

    unwrapped = tuning_env_of(env)
    if not hasattr(unwrapped, "structure"):
        return None
    from envs.structures import STRUCTURES
    from envs.systems.plant_sets import plant_set

    if family is None:
        family = getattr(unwrapped, "family", None)
    if family is None:
        family = STRUCTURES[unwrapped.structure].family
    return list(plant_set(family, "validation", n))


def action_masks(env: Any) -> np.ndarray | None:
    """The environment's action masks now (the agent mode's discrete action, :mod:`envs.discrete_action`), or None."""
    from envs.interface import tuning_env_of

    unwrapped = tuning_env_of(env)
    return unwrapped.action_masks() if getattr(unwrapped, "discrete", None) is not None else None


def validate_policy(
    predict: Callable[[np.ndarray], np.ndarray],
    env: Any,
    n_episodes: int,
    plants: Sequence[Any] | None = None,
    num_timesteps: int = 0,
) -> ValidationResult:
    """Run one episode per validation plant (or per seed) with deterministic actions.

    The cost of an episode is ``info["cost"]`` of its last step when the environment reports one,
    else minus the episode's return.
    """
    costs, feasible = [], []
    for k in range(n_episodes if plants is None else len(plants)):
        options = None if plants is None else {"plant": plants[k]}
        observation, info = env.reset(seed=VALIDATION_SEED + k, options=options)
        total, done = 0.0, False
        while not done:
            observation, reward, terminated, truncated, info = env.step(predict(observation))
            total += float(reward)
            done = terminated or truncated
        costs.append(float(info["cost"]) if "cost" in info else -total)
        if "feasible" in info:
            feasible.append(bool(info["feasible"]))
    values = np.asarray(costs)
    return ValidationResult(
        num_timesteps=int(num_timesteps),
        mean_cost=float(values.mean()),
        median_cost=float(np.median(values)),
        violation_rate=None if not feasible else 1.0 - float(np.mean(feasible)),
        costs=tuple(costs),
    )
