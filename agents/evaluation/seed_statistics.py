"""Statistics of a policy trained with many seeds, as Agarwal et al. (2021) recommend.

R. Agarwal, M. Schwarzer, P. S. Castro, A. Courville, M. G. Bellemare, "Deep reinforcement learning
at the edge of the statistical precipice", NeurIPS 2021 (the ``rliable`` library; archived, so the
figures are computed here with ``scipy.stats``).  The data of one environment are the costs
``C[s, p]`` of the policy trained with seed ``s`` on held-out plant ``p`` (every seed on the same
plants, with the same episode seeds), and the deterministic costs ``o[p]`` of the oracle and
``r[p]`` of each rule on those plants.  Lower cost is better.

* **IQM**: the interquartile mean of all ``C[s, p]``, the mean of the middle 50% (section 4.3):
  ``scipy.stats.trim_mean(C, 0.25, axis=None)``; robust to the outlying runs that a mean is not,
  and less wasteful than a median.
* **Bootstrap intervals, two-way.**  Agarwal et al.'s stratified bootstrap (section 4.2) resamples
  the runs of each task independently, because there each run is trained and scored on one task.
  Here one training run (a seed) is one policy scored on every plant, so its costs on the plants are
  not independent: a good seed is good on most plants.  Resampling seeds within each plant would
  break that correlation and give intervals several times too narrow (measured on the study of
  docs/results_history.md: 0.03 wide against a spread of 0.23 between the per-seed means on
  ``FPPI-v0``).  So a resample draws the seeds (whole rows) and, independently, the plants (whole
  columns) with replacement, the same plants for every policy (paired): the interval covers both the
  seed-to-seed variation of training and the variation of the held-out plants, i.e. a claim about
  the plant distribution and not only the 59 plants drawn.  Percentile intervals (rliable's
  default), each environment on its own (the environments are the strata).
* **Normalized score** ``oracle_cost/cost`` per (seed, plant): 1 for the oracle, towards 0 for bad
  designs (a violating design costs at least 21).  Its IQM and its **optimality gap**
  ``mean(max(1 - score, 0))`` (section 4.3, with the target 1 = the oracle).
* **Probability of improvement** over a rule (section 4.4): ``P(C[s, p] < r[p])`` over the seeds,
  ties counting one half (the Mann-Whitney statistic), averaged over the plants.  Above 0.5, the
  agent is more likely than not to beat the rule on a plant.
* **Paired difference** to a rule: ``mean_{s,p}(C[s, p] - r[p])``, negative when the agent is better;
  between two trained policies (:func:`paired_difference`), ``mean(C_1) - mean(C_2)``, the plants
  resampled together and each policy's seeds on their own (two sets of training runs, not pairs).
* **Performance profile** (section 4.1): the fraction of runs whose normalized score is at least
  ``tau``, for ``tau`` in ``[0, 1]``; the area under it is the mean normalized score.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from scipy import stats

__all__ = [
    "VIOLATION_COST",
    "RESAMPLES",
    "SeedStatistics",
    "iqm",
    "optimality_gap",
    "paired_difference",
    "performance_profile",
    "probability_of_improvement",
    "seed_statistics",
    "bootstrap_interval",
]

RESAMPLES = 2000
VIOLATION_COST = 21.0
"""The least cost of a design that violates a constraint: the scoring charges ``FEASIBLE_CAP + 1 +
grade`` (:mod:`envs.analysis.scoring`; ``tests/unit/agents/evaluation/test_evaluate_policies.py``
checks the two agree), and every feasible cost is at most ``FEASIBLE_CAP``."""


def iqm(values: np.ndarray) -> float:
    """Interquartile mean of every value (the mean of the middle 50%)."""
    return float(stats.trim_mean(np.asarray(values, dtype=float), 0.25, axis=None))


def optimality_gap(normalized: np.ndarray) -> float:
    """``mean(max(1 - normalized, 0))``: how far the runs fall short of the oracle, on average."""
    return float(np.mean(np.maximum(1.0 - np.asarray(normalized, dtype=float), 0.0)))


def probability_of_improvement(costs: np.ndarray, rule: np.ndarray) -> float:
    """``P(cost < rule cost)`` per plant over the seeds (ties one half), averaged over the plants."""
    costs, rule = _matrix(costs), np.asarray(rule, dtype=float)
    wins = (costs < rule).astype(float) + 0.5 * (costs == rule)
    return float(wins.mean())


def performance_profile(normalized: np.ndarray, taus: np.ndarray) -> np.ndarray:
    """Fraction of the runs (every seed and plant) whose normalized score is at least each ``tau``."""
    values = np.asarray(normalized, dtype=float).ravel()
    return np.array([float(np.mean(values >= tau)) for tau in np.asarray(taus, dtype=float)])


def _matrix(costs: np.ndarray) -> np.ndarray:
    costs = np.asarray(costs, dtype=float)
    if costs.ndim != 2 or costs.shape[0] < 1 or costs.shape[1] < 1:
        raise ValueError(f"costs must be a (seeds, plants) matrix, got shape {costs.shape}")
    return costs


def bootstrap_interval(
    costs: np.ndarray,
    statistic: Callable[[np.ndarray, np.ndarray], np.ndarray],
    *,
    level: float = 0.95,
    resamples: int = RESAMPLES,
    seed: int = 0,
) -> list[float]:
    """Percentile interval of ``statistic`` under the two-way bootstrap (module docstring).

    Parameters
    ----------
    costs : (seeds, plants) array
    statistic : function of the resampled costs ``(resamples, seeds, plants)`` and the resampled
        plant indices ``(resamples, plants)`` (to index the rules' and the oracle's costs, paired),
        returning one value per resample.
    level, resamples, seed : the interval's coverage, the number of resamples and the seed of the
        resampling (a fixed seed makes the interval reproducible).
    """
    costs = _matrix(costs)
    seeds, plants = costs.shape
    rng = np.random.default_rng(seed)
    seed_rows = rng.integers(0, seeds, (resamples, seeds))
    plant_columns = rng.integers(0, plants, (resamples, plants))
    values = statistic(costs[seed_rows[:, :, None], plant_columns[:, None, :]], plant_columns)
    low, high = np.quantile(values, [(1 - level) / 2, (1 + level) / 2])
    return [float(low), float(high)]


def paired_difference(
    first: np.ndarray, second: np.ndarray, *, level: float = 0.95, resamples: int = RESAMPLES, seed: int = 0
) -> list[float]:
    """``[mean(first) - mean(second), lo, hi]`` of two policies' costs on the same plants.

    ``first`` and ``second`` are ``(seeds, plants)`` matrices (a rule or the oracle: one row).  A
    resample draws the plants once for both (paired) and each matrix's seeds on their own, with
    replacement: the seeds of two training configs are independent runs, not pairs.
    """
    first, second = _matrix(first), _matrix(second)
    if first.shape[1] != second.shape[1]:
        raise ValueError(f"the two policies must be scored on the same plants, got {first.shape[1]} and {second.shape[1]}")
    rng = np.random.default_rng(seed)
    plants = first.shape[1]
    columns = rng.integers(0, plants, (resamples, plants))

    def resampled_means(costs: np.ndarray) -> np.ndarray:
        rows = rng.integers(0, costs.shape[0], (resamples, costs.shape[0]))
        return costs[rows[:, :, None], columns[:, None, :]].mean(axis=(-2, -1))

    differences = resampled_means(first) - resampled_means(second)
    low, high = np.quantile(differences, [(1 - level) / 2, (1 + level) / 2])
    return [float(first.mean() - second.mean()), float(low), float(high)]


@dataclass(frozen=True)
class SeedStatistics:
    """The figures of one policy over seeds and plants (module docstring); intervals are ``[lo, hi]``."""

    seeds: int
    plants: int
    mean_cost: float
    iqm_cost: float
    ci95: dict[str, list[float]]
    per_seed_mean_cost: list[float]
    violation_rate: float
    normalized_iqm: float
    optimality_gap: float
    prob_improvement: dict[str, float]
    diff_to_best_rule: list[float]  # [estimate, lo, hi]


def _trimmed(values: np.ndarray) -> np.ndarray:
    flat = values.reshape(*values.shape[:-2], -1)
    return stats.trim_mean(flat, 0.25, axis=-1)


def seed_statistics(
    costs: np.ndarray,
    oracle: np.ndarray,
    rules: Mapping[str, np.ndarray],
    best_rule: str,
    *,
    violation_threshold: float = VIOLATION_COST,
    resamples: int = RESAMPLES,
    seed: int = 0,
) -> SeedStatistics:
    """Every figure of :class:`SeedStatistics` for costs ``(seeds, plants)`` against the oracle and rules.

    ``violation_threshold`` is the cost from which a design violates a constraint
    (:data:`VIOLATION_COST`).
    """
    costs, oracle = _matrix(costs), np.asarray(oracle, dtype=float)
    best = np.asarray(rules[best_rule], dtype=float)
    normalized = oracle / costs

    def interval(statistic: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> list[float]:
        return bootstrap_interval(costs, statistic, resamples=resamples, seed=seed)

    difference = float(np.mean(costs - best))
    return SeedStatistics(
        seeds=costs.shape[0],
        plants=costs.shape[1],
        mean_cost=float(costs.mean()),
        iqm_cost=iqm(costs),
        ci95={
            "mean_cost": interval(lambda c, p: c.mean(axis=(-2, -1))),
            "iqm_cost": interval(lambda c, p: _trimmed(c)),
            "normalized_iqm": interval(lambda c, p: _trimmed(oracle[p][:, None, :] / c)),
        },
        per_seed_mean_cost=[float(v) for v in costs.mean(axis=1)],
        violation_rate=float(np.mean(costs >= violation_threshold)),
        normalized_iqm=iqm(normalized),
        optimality_gap=optimality_gap(normalized),
        prob_improvement={name: probability_of_improvement(costs, np.asarray(r, dtype=float)) for name, r in rules.items()},
        diff_to_best_rule=[difference, *interval(lambda c, p: (c - best[p][:, None, :]).mean(axis=(-2, -1)))],
    )
