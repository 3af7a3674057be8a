"""The protocol's statistics: plant-clustered violation bounds, paired mean differences, Holm.

The plant is the unit of evidence.  A learner trained with ``S`` seeds is scored on every plant by
each seed's model; its per-plant cost is the mean over the seeds, and a plant counts as violating
when the design violates the constraints on it in any seed.  Seeds share their plants, so pooling
the ``S x n`` episodes as independent would count one hard plant ``S`` times.

* :func:`clopper_pearson`: the exact two-sided interval of a binomial proportion (Clopper and
  Pearson, Biometrika 26, 1934), from the beta quantiles; the rate of violating plants and its
  interval, on validation (the certificate of the selection rule) and on test alike.
* :func:`paired_difference`: the mean over plants of the paired per-plant difference, with the
  Student-t interval of that mean.  The interval is conditional on the trained models (the seeds
  are fixed, the plants are the sample): it speaks of these ten fits on the plant distribution, not
  of the distribution of training runs.  ``deadtime protocol coverage`` checks its coverage by
  simulation on the committed per-plant data (:mod:`agents.protocol.coverage`).
* :func:`holm`: Holm's step-down adjustment of the comparisons' p-values (Holm, Scand. J. Statist.
  6, 1979), and per comparison the level of a *Holm-consistent* interval: the ``j``-th smallest
  p-value's hypothesis, if rejected at step ``j``, gets the level ``1 - alpha/(m - j + 1)``; every
  hypothesis not rejected gets ``1 - alpha/(m - r)`` with ``r`` the number rejected.  Each interval
  excludes 0 exactly when Holm rejects (the verdict read from the interval is Holm's decision).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import stats

__all__ = ["Difference", "Violations", "clopper_pearson", "holm", "paired_difference", "plant_means",
           "plant_violations", "t_interval", "verdict"]


def clopper_pearson(successes: int, trials: int, level: float = 0.95) -> tuple[float, float]:
    """The exact (Clopper-Pearson) two-sided interval of a binomial proportion.

    Parameters
    ----------
    successes, trials : int
        ``0 <= successes <= trials``, ``trials >= 1``.
    level : float
        The confidence level (each tail ``(1 - level)/2``).

    Returns
    -------
    (float, float)
        ``(low, high)``: the ``alpha/2`` quantile of Beta(k, n-k+1) (0 if k = 0) and the ``1 - alpha/2``
        quantile of Beta(k+1, n-k) (1 if k = n).
    """
    if trials < 1 or not 0 <= successes <= trials:
        raise ValueError(f"successes must be within [0, trials] and trials >= 1, got {successes} of {trials}")
    alpha = 1.0 - level
    low = 0.0 if successes == 0 else float(stats.beta.ppf(alpha / 2, successes, trials - successes + 1))
    high = 1.0 if successes == trials else float(stats.beta.ppf(1 - alpha / 2, successes + 1, trials - successes))
    return low, high


@dataclass(frozen=True)
class Violations:
    """The share of plants where a design violates (in any seed), with its exact interval."""

    plants: int
    violating: int
    rate: float
    interval: tuple[float, float]

    def to_dict(self) -> dict[str, object]:
        return {"rate": self.rate, "interval": list(self.interval), "unit": "plant", "plants": self.plants,
                "violating_plants": self.violating}


def plant_violations(feasible: np.ndarray, level: float = 0.95) -> Violations:
    """Violations with the plant as the unit: ``feasible`` is ``(seeds, plants)`` (or ``(plants,)``)
    booleans; a plant violates if any seed's design is infeasible on it."""
    matrix = np.atleast_2d(np.asarray(feasible, dtype=bool))
    violating = int(np.sum(~matrix.all(axis=0)))
    plants = matrix.shape[1]
    return Violations(plants, violating, violating / plants, clopper_pearson(violating, plants, level))


def plant_means(costs: np.ndarray) -> np.ndarray:
    """A learner's per-plant cost: the mean over seeds of ``(seeds, plants)`` costs (a 1-D array as is)."""
    matrix = np.atleast_2d(np.asarray(costs, dtype=float))
    return matrix.mean(axis=0)


def t_interval(values: np.ndarray, level: float = 0.95) -> tuple[float, float, float, float]:
    """``(mean, low, high, p)``: the Student-t interval of the mean of ``values`` and the two-sided
    p-value of mean zero (a constant sample has a zero-width interval and p 0 or 1)."""
    values = np.asarray(values, dtype=float)
    n = values.size
    if n < 2:
        raise ValueError(f"an interval needs at least 2 plants, got {n}")
    mean = float(values.mean())
    error = float(values.std(ddof=1)) / np.sqrt(n)
    if error == 0.0:
        return mean, mean, mean, 1.0 if mean == 0.0 else 0.0
    half = float(stats.t.ppf(0.5 + level / 2, n - 1)) * error
    p = float(2 * stats.t.sf(abs(mean) / error, n - 1))
    return mean, mean - half, mean + half, p


@dataclass(frozen=True)
class Difference:
    """The paired difference ``first - second`` over plants (negative: the first is cheaper)."""

    first: str
    second: str
    differences: np.ndarray
    second_mean: float
    mean: float
    low: float
    high: float
    p_value: float

    @property
    def percent_of_second(self) -> float:
        """The difference in percent of the second's mean cost."""
        return 100.0 * self.mean / self.second_mean

    @property
    def share_better(self) -> float:
        """The share of plants where the first is strictly cheaper."""
        return float(np.mean(self.differences < 0))

    def interval(self, level: float) -> tuple[float, float]:
        """The t interval of the mean difference at ``level`` (e.g. a Holm-consistent level)."""
        _, low, high, _ = t_interval(self.differences, level)
        return low, high


def paired_difference(first: str, second: str, first_costs: np.ndarray, second_costs: np.ndarray,
                      level: float = 0.95) -> Difference:
    """The paired difference of two policies' per-plant costs (each ``(seeds, plants)`` or ``(plants,)``;
    a learner's seeds are averaged per plant first, :func:`plant_means`)."""
    a, b = plant_means(first_costs), plant_means(second_costs)
    if a.shape != b.shape:
        raise ValueError(f"{first} and {second} are scored on different plants ({a.size} and {b.size})")
    for name, costs in ((first, a), (second, b)):
        bad = int(np.sum(~np.isfinite(costs)))
        if bad:
            raise ValueError(f"{name} has a cost that is not a finite number (NaN or infinite) on {bad} plant(s): "
                             "no comparison is read from it")
    differences = a - b
    mean, low, high, p = t_interval(differences, level)
    return Difference(first, second, differences, float(b.mean()), mean, low, high, p)


def holm(p_values: list[float] | np.ndarray, alpha: float = 0.05) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Holm's step-down procedure over ``m`` p-values.

    Returns
    -------
    (adjusted, rejected, levels) : arrays of length m
        Holm-adjusted p-values (``max_{i<=j} min(1, (m - i + 1) p_(i))`` in sorted order), whether each
        hypothesis is rejected at ``alpha`` (adjusted p <= alpha), and each comparison's Holm-consistent
        interval level (module docstring).
    """
    p = np.asarray(p_values, dtype=float)
    m = p.size
    order = np.argsort(p, kind="stable")
    scaled = np.minimum(1.0, (m - np.arange(m)) * p[order])
    adjusted_sorted = np.maximum.accumulate(scaled)
    adjusted = np.empty(m)
    adjusted[order] = adjusted_sorted
    rejected = adjusted <= alpha
    rejections = int(rejected.sum())
    levels = np.empty(m)
    for step, index in enumerate(order):
        divisor = m - step if rejected[index] else m - rejections
        levels[index] = 1.0 - alpha / divisor
    return adjusted, rejected, levels


def verdict(low: float, high: float) -> str:
    """``better`` when the adjusted interval of ``first - second`` lies below 0, ``worse`` above, else ``tie``
    (an interval of a bound that is not a number has no verdict: a ``ValueError``)."""
    if np.isnan(low) or np.isnan(high):
        raise ValueError(f"an interval [{low}, {high}] has no verdict")
    if high < 0:
        return "better"
    if low > 0:
        return "worse"
    return "tie"
