"""The statistics over seeds (:mod:`agents.evaluation.seed_statistics`) against values computed by hand."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents.evaluation.seed_statistics import (
    iqm,
    optimality_gap,
    performance_profile,
    probability_of_improvement,
    paired_difference,
    seed_statistics,
    bootstrap_interval,
)


def test_iqm_is_the_mean_of_the_middle_half() -> None:
    assert iqm(np.arange(1.0, 9.0)) == 4.5  # drops 1, 2 and 7, 8: mean of 3..6
    assert iqm(np.array([[1.0, 2.0], [3.0, 100.0]])) == 2.5  # over every (seed, plant): mean of 2, 3


def test_optimality_gap_counts_only_the_shortfall() -> None:
    assert optimality_gap(np.array([1.0, 0.5, 1.2, 0.8])) == pytest.approx((0.0 + 0.5 + 0.0 + 0.2) / 4)


def test_probability_of_improvement_counts_ties_as_half() -> None:
    costs = np.array([[1.0, 3.0], [2.0, 2.0]])  # two seeds, two plants
    assert probability_of_improvement(costs, np.array([2.0, 2.0])) == (1 + 0 + 0.5 + 0.5) / 4
    assert probability_of_improvement(costs, np.array([10.0, 10.0])) == 1.0


def test_performance_profile_is_the_fraction_at_or_above_tau() -> None:
    profile = performance_profile(np.array([0.2, 0.5, 0.9, 1.0]), np.array([0.0, 0.5, 1.0, 1.1]))
    assert profile.tolist() == [1.0, 0.75, 0.25, 0.0]


def _mean(costs: np.ndarray, plants: np.ndarray) -> np.ndarray:
    return costs.mean(axis=(-2, -1))


def test_seeds_are_resampled_whole() -> None:
    """A seed that is better on every plant stays better on every plant: the interval is the spread between the seeds.

    Two seeds of means 1 and 3: a resample's mean is 1, 2 or 3 with probabilities 1/4, 1/2, 1/4.
    """
    costs = np.array([[1.0, 1.0, 1.0], [3.0, 3.0, 3.0]])
    assert bootstrap_interval(costs, _mean) == [1.0, 3.0]


def test_plants_are_resampled_whole_and_paired() -> None:
    """Seeds that agree leave the plants' spread; a rule indexed by the same plants is paired."""
    costs = np.array([[1.0, 5.0], [1.0, 5.0], [1.0, 5.0]])
    assert bootstrap_interval(costs, _mean) == [1.0, 5.0]
    rule = np.array([1.0, 5.0])  # the same costs as the agent's on every plant: the difference is 0
    assert bootstrap_interval(costs, lambda c, p: (c - rule[p][:, None, :]).mean(axis=(-2, -1))) == [0.0, 0.0]


def test_interval_of_the_mean_covers_at_its_level() -> None:
    """Coverage of the population mean over 400 simulated studies (10 seeds x 20 plants).

    Costs ``3 + a_seed + b_plant + e`` (standard deviations 0.5, 1 and 0.3): the seeds and the plants
    are both random, so an interval of the mean must cover both (module docstring).  The percentile
    bootstrap's variance is ``(n - 1)/n`` of the true one per factor (too narrow by about 4% here)
    and it counts the interaction term twice (too wide by about as much): measured 0.9475 over these
    400 studies.  The coverage's standard error over 400 studies is 1.1%: the bounds are 3.5 of
    them around the nominal 95%.
    """
    rng = np.random.default_rng(1)
    covered, trials = 0, 400
    for trial in range(trials):
        costs = 3.0 + rng.normal(0, 0.5, (10, 1)) + rng.normal(0, 1.0, (1, 20)) + rng.normal(0, 0.3, (10, 20))
        low, high = bootstrap_interval(costs, _mean, resamples=999, seed=trial)
        covered += low <= 3.0 <= high
    tolerance = 3.5 * math.sqrt(0.95 * 0.05 / trials)
    assert abs(covered / trials - 0.95) < tolerance


def test_stratifying_by_plant_would_be_too_narrow() -> None:
    """Why seeds are resampled whole: with a seed effect, resampling seeds within plants (independently
    per plant) shrinks the spread of the mean by about the number of plants, and the interval with it."""
    rng = np.random.default_rng(2)
    costs = 3.0 + rng.normal(0, 0.5, (10, 1)) + rng.normal(0, 0.1, (10, 50))  # one plant-independent seed effect
    whole = np.diff(bootstrap_interval(costs, _mean))[0]
    rows = rng.integers(0, 10, (2000, 10, 50))  # seeds drawn per plant
    within = np.diff(np.quantile(np.take_along_axis(costs[None], rows, axis=1).mean(axis=(1, 2)), [0.025, 0.975]))[0]
    assert within < whole / 3


def test_seed_statistics_of_a_small_study() -> None:
    costs = np.array([[2.0, 4.0, 30.0], [2.0, 5.0, 6.0]])  # 2 seeds x 3 plants; one violation
    oracle = np.array([1.0, 4.0, 5.0])
    rules = {"good": np.array([3.0, 4.0, 6.0]), "bad": np.array([25.0, 25.0, 25.0])}
    result = seed_statistics(costs, oracle, rules, "good", resamples=200)
    assert (result.seeds, result.plants) == (2, 3)
    assert result.mean_cost == pytest.approx(49.0 / 6)
    assert result.iqm_cost == pytest.approx((2.0 + 4.0 + 5.0 + 6.0) / 4)  # 2, 2, 4, 5, 6, 30 less one each side
    assert result.per_seed_mean_cost == pytest.approx([12.0, 13.0 / 3])
    assert result.violation_rate == pytest.approx(1 / 6)
    assert result.prob_improvement == {"good": pytest.approx((1 + 0.5 + 0 + 1 + 0 + 0.5) / 6), "bad": 5 / 6}
    assert result.diff_to_best_rule[0] == pytest.approx(np.mean(costs - rules["good"]))
    low, high = result.diff_to_best_rule[1:]
    assert low <= result.diff_to_best_rule[0] <= high
    normalized = oracle / costs
    assert result.optimality_gap == pytest.approx(np.mean(1 - normalized))
    for name, (low, high) in result.ci95.items():
        assert low <= high, name


def test_paired_difference_against_a_loop_over_resamples() -> None:
    """The vectorized resampling equals a plain loop drawing the same indices (plants shared by the
    two policies, each one's seeds on its own), and a rule (one row) against itself is exactly 0."""
    rng = np.random.default_rng(4)
    first, second = rng.gamma(2.0, 1.0, (5, 7)), rng.gamma(2.0, 1.2, (3, 7))
    estimate, low, high = paired_difference(first, second, resamples=300, seed=9)
    draws = np.random.default_rng(9)
    columns = draws.integers(0, 7, (300, 7))
    rows_first, rows_second = draws.integers(0, 5, (300, 5)), draws.integers(0, 3, (300, 3))
    loop = [first[np.ix_(rows_first[k], columns[k])].mean() - second[np.ix_(rows_second[k], columns[k])].mean()
            for k in range(300)]
    assert estimate == pytest.approx(first.mean() - second.mean(), rel=1e-12)
    assert [low, high] == pytest.approx(list(np.quantile(loop, [0.025, 0.975])), rel=1e-12)
    rule = rng.gamma(2.0, 1.0, (1, 7))
    assert paired_difference(rule, rule, resamples=50) == [0.0, 0.0, 0.0]
    with pytest.raises(ValueError, match="same plants"):
        paired_difference(first, second[:, :6])
