"""Aggregate statistics of ``deadtime evaluate``: per-policy figures and paired bootstrap intervals.

Every policy is scored on the same plants, so the plants are the unit of resampling: one
bootstrap resample draws plant indices with replacement and every policy's figures are computed
on those same plants (paired resampling).  The intervals are percentile intervals (2.5 % and
97.5 % quantiles over the resamples).

Definitions, for per-plant costs ``c_p`` of a policy, ``o_p`` of the oracle and ``b_p`` of the best
rule (the rule of lowest mean cost, chosen once on the full sample and kept fixed in the resamples):

* regret ``= mean_p (c_p - o_p)``;
* gap closure ``= (mean b - mean c)/(mean b - mean o)``: 0 for the best rule, 1 for the oracle,
  negative for a policy worse than the best rule; a ratio of means (a per-plant ratio is undefined
  wherever the best rule is optimal, and unstable near it); ``nan`` if ``mean b == mean o``.

Only numpy: the module holds no policy, environment or plotting logic.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = [
    "BOOTSTRAP_RESAMPLES",
    "PolicyStats",
    "bootstrap_indices",
    "gap_closure",
    "percentile_interval",
    "summarize",
]

BOOTSTRAP_RESAMPLES = 2000
INTERVAL_FIELDS = ("mean_cost", "median_cost", "violation_rate", "regret", "gap_closure")


@dataclass(frozen=True)
class PolicyStats:
    """The figures of one policy over a set of plants (see the module docstring).

    ``ci95`` maps each of ``mean_cost``, ``median_cost``, ``violation_rate``, ``regret`` and
    ``gap_closure`` to its percentile interval ``[lo, hi]`` (``nan`` where undefined).
    """

    name: str
    n: int
    mean_cost: float
    median_cost: float
    violation_rate: float
    failure_rate: float
    experiment_time: float
    regret: float
    gap_closure: float
    ci95: dict[str, list[float]] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready (``None`` for ``nan``)."""

        def clean(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        out: dict[str, Any] = {"name": self.name, "n": self.n}
        for key in ("mean_cost", "median_cost", "violation_rate", "failure_rate", "experiment_time", "regret", "gap_closure"):
            out[key] = clean(getattr(self, key))
        out["ci95"] = {key: [clean(lo), clean(hi)] for key, (lo, hi) in self.ci95.items()}
        return out


def bootstrap_indices(n: int, resamples: int, rng: np.random.Generator) -> np.ndarray:
    """``(resamples, n)`` plant indices drawn with replacement (one row per resample)."""
    if n <= 0:
        raise ValueError(f"n must be > 0, got {n!r}")
    if resamples <= 0:
        raise ValueError(f"resamples must be > 0, got {resamples!r}")
    return rng.integers(0, n, size=(resamples, n))


def gap_closure(best_rule: np.ndarray | float, policy: np.ndarray | float, oracle: np.ndarray | float) -> np.ndarray | float:
    """``(best_rule - policy)/(best_rule - oracle)`` of mean costs, elementwise; ``nan`` where the gap is 0."""
    best_rule, policy, oracle = (np.asarray(x, dtype=float) for x in (best_rule, policy, oracle))
    gap = best_rule - oracle
    with np.errstate(divide="ignore", invalid="ignore"):
        result = np.where(gap != 0, (best_rule - policy) / np.where(gap != 0, gap, 1.0), np.nan)
    return float(result) if result.ndim == 0 else result


def percentile_interval(values: np.ndarray, level: float = 0.95) -> list[float]:
    """The percentile interval of bootstrap replicates, ignoring ``nan`` (``[nan, nan]`` if all are)."""
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    if values.size == 0:
        return [math.nan, math.nan]
    tail = 100 * (1 - level) / 2
    lo, hi = np.percentile(values, [tail, 100 - tail])
    return [float(lo), float(hi)]


def summarize(
    costs: dict[str, np.ndarray],
    violations: dict[str, np.ndarray],
    failures: dict[str, np.ndarray],
    experiment_times: dict[str, np.ndarray],
    oracle: np.ndarray,
    best_rule: np.ndarray | None,
    *,
    resamples: int = BOOTSTRAP_RESAMPLES,
    seed: int = 0,
) -> list[PolicyStats]:
    """The figures of every policy in ``costs`` with paired bootstrap intervals.

    Parameters
    ----------
    costs, violations, failures, experiment_times : dict of str to ndarray, shape (n,)
        Per-plant cost, constraint violation (bool), rule failure (bool) and experiment time of
        each policy, over the same ``n`` plants in the same order.
    oracle : ndarray, shape (n,)
        Per-plant oracle cost (the reference of regret and gap closure).
    best_rule : ndarray, shape (n,), or None
        Per-plant cost of the best rule; None leaves the gap closure undefined (``nan``).
    resamples : int
        Number of bootstrap resamples.
    seed : int
        Seed of the resampling (``numpy.random.default_rng(seed)``); the same seed gives the same
        intervals.

    Returns
    -------
    list of PolicyStats
        In the order of ``costs``.
    """
    oracle = np.asarray(oracle, dtype=float)
    n = oracle.size
    index = bootstrap_indices(n, resamples, np.random.default_rng(seed))
    oracle_means = oracle[index].mean(axis=1)
    best_means = None if best_rule is None else np.asarray(best_rule, dtype=float)[index].mean(axis=1)
    out = []
    for name, cost in costs.items():
        cost = np.asarray(cost, dtype=float)
        if cost.shape != (n,):
            raise ValueError(f"costs of {name!r} must have shape ({n},), got {cost.shape}")
        violated = np.asarray(violations[name], dtype=float)
        means = cost[index].mean(axis=1)
        replicates = {
            "mean_cost": means,
            "median_cost": np.median(cost[index], axis=1),
            "violation_rate": violated[index].mean(axis=1),
            "regret": means - oracle_means,
            "gap_closure": np.full(resamples, np.nan) if best_means is None else gap_closure(best_means, means, oracle_means),
        }
        mean = float(cost.mean())
        out.append(
            PolicyStats(
                name=name,
                n=n,
                mean_cost=mean,
                median_cost=float(np.median(cost)),
                violation_rate=float(violated.mean()),
                failure_rate=float(np.asarray(failures[name], dtype=float).mean()),
                experiment_time=float(np.mean(experiment_times[name])),
                regret=mean - float(oracle.mean()),
                gap_closure=math.nan if best_rule is None else float(gap_closure(float(np.mean(best_rule)), mean, float(oracle.mean()))),
                ci95={key: percentile_interval(replicates[key]) for key in INTERVAL_FIELDS},
            )
        )
    return out
