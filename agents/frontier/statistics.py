"""Intervals that treat training seeds and plants as random: a (seeds x plants) matrix of paired differences.

A learner trained with ``k`` seeds is scored on ``n`` plants by each seed's model, so its paired
difference to another policy is a ``k x n`` matrix ``D``.  Seeds and plants are both samples: a
reader trains another model and meets other plants.  The crossed random-effects model
(McCullagh 2000, Bernoulli 6:285-301; Owen 2007, Ann. Appl. Statist. 1:1-29)::

    D[i, j] = mu + a_i + b_j + e_ij,   a ~ (0, var_seed), b ~ (0, var_plant), e ~ (0, var_residual)

gives ``Var(mean D) = var_seed/k + var_plant/n + var_residual/(k n)``; an interval conditional on the
seeds keeps only the last two terms.

* :func:`crossed_bootstrap`: the two-way (pigeonhole) bootstrap: seeds and plants resampled
  independently, per draw the mean of the resampled matrix; the percentile interval.  It counts the
  residual about twice and the seeds short by ``(k-1)/k`` (McCullagh 2000, section 3), and with ten
  seeds its percentile interval is too narrow where the variance between seeds dominates (measured by
  :func:`coverage`: 0.89 at ``sd_seed = sd_plant``; docs/frontier.md).
* :func:`crossed_variance`: the moment (two-way ANOVA) estimates of the three components, the
  standard error of the mean from them, and a Student-t interval with Satterthwaite's degrees of
  freedom (few seeds: ``k - 1`` is close).  The method's default, since ten seeds are few for a
  percentile interval.
* :func:`plant_interval`: one model's row (a shipped file): the paired t over the plants, the model fixed.
* :func:`coverage`: the share of intervals that hold the known mean on data simulated from the
  crossed model, with its binomial standard error (the check of the interval, docs/frontier.md).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import stats

__all__ = ["COVERAGE_SETTINGS", "CrossedInterval", "Coverage", "METHODS", "coverage", "coverage_table", "crossed_bootstrap", "crossed_interval",
           "crossed_p_value", "crossed_variance", "plant_interval", "plant_p_value", "seeds_or_plants_interval",
           "seeds_or_plants_p_value", "simulate_crossed", "variance_components"]


@dataclass(frozen=True)
class CrossedInterval:
    """The mean of a (seeds x plants) matrix and its interval; ``method`` names how it was made."""

    estimate: float
    low: float
    high: float
    standard_error: float
    method: str

    def to_dict(self) -> dict[str, float | str]:
        return {"estimate": self.estimate, "low": self.low, "high": self.high,
                "standard_error": self.standard_error, "method": self.method}


def _matrix(differences: np.ndarray) -> np.ndarray:
    d = np.asarray(differences, dtype=float)
    if d.ndim != 2 or d.shape[0] < 2 or d.shape[1] < 2:
        raise ValueError(f"differences must be a (seeds x plants) matrix with at least 2 of each, got shape {d.shape}")
    if not np.all(np.isfinite(d)):
        raise ValueError("differences must be finite")
    return d


def crossed_bootstrap(differences: np.ndarray, level: float = 0.95, resamples: int = 2000, seed: int = 0) -> CrossedInterval:
    """The two-way bootstrap over seeds and plants: percentile interval of the resampled means.

    A draw resamples the ``k`` seeds and the ``n`` plants with replacement, independently; its mean
    is ``w_s' D w_p / (k n)`` with ``w_s``, ``w_p`` the multinomial counts, so no resampled matrix
    is built.
    """
    d = _matrix(differences)
    k, n = d.shape
    rng = np.random.default_rng(seed)
    seeds = rng.multinomial(k, np.full(k, 1.0 / k), size=resamples).astype(float)
    plants = rng.multinomial(n, np.full(n, 1.0 / n), size=resamples).astype(float)
    means = np.einsum("bj,bj->b", seeds @ d, plants) / (k * n)
    tail = 50.0 * (1.0 - level)
    low, high = np.percentile(means, [tail, 100.0 - tail])
    return CrossedInterval(float(d.mean()), float(low), float(high), float(means.std(ddof=1)), "two-way bootstrap")


def variance_components(differences: np.ndarray) -> tuple[float, float, float]:
    """``(var_seed, var_plant, var_residual)``: the two-way ANOVA moment estimates (negative ones as 0)."""
    d = _matrix(differences)
    k, n = d.shape
    seed_means, plant_means, mean = d.mean(axis=1), d.mean(axis=0), d.mean()
    ms_seed = n * np.sum((seed_means - mean) ** 2) / (k - 1)
    ms_plant = k * np.sum((plant_means - mean) ** 2) / (n - 1)
    residual = d - seed_means[:, None] - plant_means[None, :] + mean
    ms_residual = np.sum(residual**2) / ((k - 1) * (n - 1))
    return max((ms_seed - ms_residual) / n, 0.0), max((ms_plant - ms_residual) / k, 0.0), float(ms_residual)


def _crossed_moments(d: np.ndarray) -> tuple[float, float, float]:
    """``(mean, SE, Satterthwaite degrees of freedom)`` of the matrix's mean under the crossed model."""
    k, n = d.shape
    var_seed, var_plant, var_residual = variance_components(d)
    ms = np.array([n * var_seed + var_residual, k * var_plant + var_residual, var_residual])
    df = np.array([k - 1, n - 1, (k - 1) * (n - 1)], dtype=float)
    signs = np.array([1.0, 1.0, -1.0])
    total = max(float(np.sum(signs * ms)), float(var_residual))  # at least the residual term's share
    terms = signs * ms
    dof = total**2 / max(float(np.sum(terms**2 / df)), 1e-300)
    return float(d.mean()), float(np.sqrt(total / (k * n))), max(float(dof), 1.0)


def crossed_variance(differences: np.ndarray, level: float = 0.95) -> CrossedInterval:
    """The crossed random-effects interval: mean +- t * SE.

    ``SE^2 = (MS_seed + MS_plant - MS_residual)/(k n)``, the unbiased estimate of
    ``var_seed/k + var_plant/n + var_residual/(k n)`` from the ANOVA mean squares; the t quantile has
    Satterthwaite's degrees of freedom for that combination (Satterthwaite 1946, Biometrics Bull. 2:110-114).
    """
    mean, se, dof = _crossed_moments(_matrix(differences))
    half = stats.t.ppf(0.5 + level / 2.0, dof) * se
    return CrossedInterval(mean, mean - half, mean + half, se, "crossed random effects (t, Satterthwaite)")


def crossed_p_value(differences: np.ndarray) -> float:
    """The two-sided p-value of a zero mean by :func:`crossed_variance`'s t (the interval at level ``1 - alpha``
    excludes 0 exactly when this is below ``alpha``)."""
    mean, se, dof = _crossed_moments(_matrix(differences))
    if se == 0.0:
        return 1.0 if mean == 0.0 else 0.0
    return float(2.0 * stats.t.sf(abs(mean) / se, dof))


def _plant_moments(differences: np.ndarray) -> tuple[float, float, int]:
    d = np.asarray(differences, dtype=float)
    if d.ndim != 2 or d.shape[0] != 1 or d.shape[1] < 2 or not np.all(np.isfinite(d)):
        raise ValueError(f"differences must be one finite row of at least 2 plants, got shape {d.shape}")
    return float(d.mean()), float(d.std(ddof=1) / np.sqrt(d.shape[1])), d.shape[1] - 1


def plant_interval(differences: np.ndarray, level: float = 0.95) -> CrossedInterval:
    """The paired t interval of one model's (1 x plants) differences: plants random, the model fixed (a shipped
    file is one model: a user of it meets other plants, not another model)."""
    mean, se, dof = _plant_moments(differences)
    half = stats.t.ppf(0.5 + level / 2.0, dof) * se
    return CrossedInterval(mean, mean - half, mean + half, se, "paired t, plants random (one model)")


def plant_p_value(differences: np.ndarray) -> float:
    """The two-sided p-value of a zero mean by :func:`plant_interval`'s t."""
    mean, se, dof = _plant_moments(differences)
    if se == 0.0:
        return 1.0 if mean == 0.0 else 0.0
    return float(2.0 * stats.t.sf(abs(mean) / se, dof))


def seeds_or_plants_interval(differences: np.ndarray, level: float = 0.95) -> CrossedInterval:
    """:func:`crossed_variance` for several seeds, :func:`plant_interval` for one model."""
    return plant_interval(differences, level) if np.shape(differences)[0] == 1 else crossed_variance(differences, level)


def seeds_or_plants_p_value(differences: np.ndarray) -> float:
    """:func:`crossed_p_value` for several seeds, :func:`plant_p_value` for one model."""
    return plant_p_value(differences) if np.shape(differences)[0] == 1 else crossed_p_value(differences)


METHODS: dict[str, Callable[..., CrossedInterval]] = {"variance": crossed_variance, "bootstrap": crossed_bootstrap}
"""The interval methods by name; ``variance`` is the default."""


def crossed_interval(differences: np.ndarray, level: float = 0.95, method: str = "variance") -> CrossedInterval:
    """The mean of the (seeds x plants) matrix ``differences`` and its interval, seeds and plants random.

    Raises
    ------
    ValueError
        For an unknown method, or a matrix with fewer than 2 seeds or 2 plants or a value not finite.
    """
    if method not in METHODS:
        raise ValueError(f"unknown interval method {method!r}; choose one of {', '.join(METHODS)}")
    return METHODS[method](differences, level=level)


def simulate_crossed(rng: np.random.Generator, seeds: int, plants: int, mean: float,
                     sd_seed: float, sd_plant: float, sd_residual: float) -> np.ndarray:  # fmt: skip
    """One (seeds x plants) matrix of the crossed model with normal effects."""
    a = rng.normal(0.0, sd_seed, size=(seeds, 1))
    b = rng.normal(0.0, sd_plant, size=(1, plants))
    return mean + a + b + rng.normal(0.0, sd_residual, size=(seeds, plants))


@dataclass(frozen=True)
class Coverage:
    """The share of ``replicates`` intervals that held the true mean, and its binomial standard error."""

    covered: float
    standard_error: float
    replicates: int
    mean_width: float


def coverage(interval: Callable[[np.ndarray], CrossedInterval], *, replicates: int = 400, seeds: int = 10,
             plants: int = 200, sd_seed: float = 0.3, sd_plant: float = 1.0, sd_residual: float = 0.5,
             mean: float = 0.2, seed: int = 0) -> Coverage:  # fmt: skip
    """Coverage of ``interval`` on ``replicates`` matrices simulated by :func:`simulate_crossed`."""
    rng = np.random.default_rng(seed)
    hits, widths = 0, []
    for _ in range(replicates):
        found = interval(simulate_crossed(rng, seeds, plants, mean, sd_seed, sd_plant, sd_residual))
        hits += bool(found.low <= mean <= found.high)
        widths.append(found.high - found.low)
    share = hits / replicates
    return Coverage(share, float(np.sqrt(share * (1.0 - share) / replicates)), replicates, float(np.mean(widths)))


COVERAGE_SETTINGS: tuple[tuple[float, float, float], ...] = ((0.3, 1.0, 0.5), (1.0, 1.0, 0.5), (0.0, 1.0, 1.0), (0.1, 0.5, 2.0))
"""``(sd_seed, sd_plant, sd_residual)`` of the coverage check: plants dominate, seeds as large as plants, no
seed effect, the residual dominates (10 seeds, 200 plants, mean 0.2)."""


def coverage_table(replicates: int = 1000, resamples: int = 500) -> str:
    """The coverage of both methods at nominal 0.95 in each of :data:`COVERAGE_SETTINGS`, as Markdown
    (``python -m agents.frontier.statistics``; docs/frontier.md)."""
    lines = ["| sd_seed | sd_plant | sd_residual | crossed variance | two-way bootstrap |", "|---:|---:|---:|---:|---:|"]
    methods = (crossed_variance, lambda d: crossed_bootstrap(d, resamples=resamples))
    for sd_seed, sd_plant, sd_residual in COVERAGE_SETTINGS:
        found = [coverage(method, replicates=replicates, sd_seed=sd_seed, sd_plant=sd_plant, sd_residual=sd_residual)
                 for method in methods]
        cells = " | ".join(f"{c.covered:.3f} +- {c.standard_error:.3f}" for c in found)
        lines.append(f"| {sd_seed:g} | {sd_plant:g} | {sd_residual:g} | {cells} |")
    return "\n".join(lines)


if __name__ == "__main__":
    print(coverage_table())
