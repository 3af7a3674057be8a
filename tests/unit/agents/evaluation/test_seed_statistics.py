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
    seed_statistics,
    stratified_interval,
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


def test_one_seed_has_a_zero_width_interval() -> None:
    costs = np.array([[1.0, 2.0, 3.0]])
    assert stratified_interval(costs, lambda c: c.mean(axis=(-2, -1))) == [2.0, 2.0]


def test_resampling_is_within_plants() -> None:
    """Seeds are drawn within each plant: a plant whose seeds agree adds no spread."""
    costs = np.array([[1.0, 5.0], [1.0, 5.0], [1.0, 5.0]])
    assert stratified_interval(costs, lambda c: c.mean(axis=(-2, -1))) == pytest.approx([3.0, 3.0])


def test_interval_of_the_mean_covers_at_its_level() -> None:
    """Coverage of the true mean over 400 independent studies (10 seeds x 5 plants, normal costs).

    The percentile bootstrap's variance of a mean of ``n`` draws is ``(n - 1)/n`` of the true one, so
    with 10 seeds per stratum the interval is ``sqrt(0.9)`` too narrow and covers about 93.7%
    (``2 Phi(1.96 sqrt(0.9)) - 1``), not 95%.  Over 400 studies the coverage's standard error is
    1.2%: the bounds are more than three of them away.
    """
    rng = np.random.default_rng(1)
    covered = 0
    trials = 400
    for trial in range(trials):
        costs = rng.normal(3.0, 1.0, (10, 5))
        low, high = stratified_interval(costs, lambda c: c.mean(axis=(-2, -1)), resamples=999, seed=trial)
        covered += low <= 3.0 <= high
    expected = math.erf(1.96 * math.sqrt(0.9) / math.sqrt(2))
    assert expected == pytest.approx(0.937, abs=1e-3)
    assert abs(covered / trials - expected) < 3.5 * math.sqrt(expected * (1 - expected) / trials)


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
