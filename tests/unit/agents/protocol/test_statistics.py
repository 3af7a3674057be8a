"""The protocol's statistics against independent computations: scipy's exact binomial interval and
one-sample t-test, a brute-force Holm, and the coverage of the t interval by simulation."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy import stats

from agents.protocol.coverage import t_coverage
from agents.protocol.statistics import (clopper_pearson, holm, paired_difference, plant_violations, t_interval,
                                        verdict)


@pytest.mark.parametrize("k, n", [(0, 50), (1, 50), (7, 2000), (0, 4000), (50, 50), (13, 97)])
def test_clopper_pearson_is_scipys_exact_interval(k, n):
    expected = stats.binomtest(k, n).proportion_ci(confidence_level=0.95, method="exact")
    low, high = clopper_pearson(k, n)
    assert low == pytest.approx(expected.low, abs=1e-12)
    assert high == pytest.approx(expected.high, abs=1e-12)


def test_zero_of_fifty_plants_bounds_the_rate_at_seven_percent():
    # the honest bound the test sets of 50 plants allowed: 1 - 0.025 ** (1 / 50)
    assert clopper_pearson(0, 50)[1] == pytest.approx(1 - 0.025 ** (1 / 50), rel=1e-12)
    assert clopper_pearson(0, 50)[1] == pytest.approx(0.0711, abs=1e-4)


def test_a_plant_violating_in_any_seed_counts_once():
    feasible = np.ones((10, 20), dtype=bool)
    feasible[:, 3] = False  # one plant, every seed
    feasible[4, 7] = False  # another, one seed
    violations = plant_violations(feasible)
    assert (violations.violating, violations.plants, violations.rate) == (2, 20, 0.1)
    assert violations.interval == clopper_pearson(2, 20)
    assert violations.to_dict()["unit"] == "plant"


def test_t_interval_is_scipys_one_sample_t_test():
    rng = np.random.default_rng(1)
    values = rng.standard_t(3, size=300) + 0.1
    mean, low, high, p = t_interval(values)
    test = stats.ttest_1samp(values, 0.0)
    interval = test.confidence_interval(0.95)
    assert (low, high) == pytest.approx((interval.low, interval.high), rel=1e-12)
    assert p == pytest.approx(test.pvalue, rel=1e-10)
    assert mean == pytest.approx(values.mean())


def test_paired_difference_averages_a_learners_seeds_per_plant():
    learner = np.array([[1.0, 2.0, 6.0], [3.0, 2.0, 2.0]])  # 2 seeds x 3 plants -> means 2, 2, 4
    rule = np.array([3.0, 2.0, 3.0])
    d = paired_difference("learner", "rule", learner, rule)
    assert d.differences == pytest.approx([-1.0, 0.0, 1.0])
    assert d.mean == pytest.approx(0.0)
    assert d.share_better == pytest.approx(1 / 3)
    assert d.percent_of_second == pytest.approx(0.0)


def _holm_brute_force(p, alpha):
    """Holm's procedure written out: reject the sorted hypotheses while p_(j) <= alpha/(m - j + 1)."""
    m = len(p)
    rejected = [False] * m
    for step, index in enumerate(sorted(range(m), key=lambda i: p[i])):
        if p[index] <= alpha / (m - step):
            rejected[index] = True
        else:
            break
    return rejected


@pytest.mark.parametrize("seed", range(20))
def test_holm_rejects_what_the_brute_force_rejects(seed):
    rng = np.random.default_rng(seed)
    m = int(rng.integers(1, 12))
    p = np.concatenate([rng.uniform(0, 0.02, m // 2), rng.uniform(0, 1, m - m // 2)])
    adjusted, rejected, _ = holm(p, 0.05)
    assert list(rejected) == _holm_brute_force(list(p), 0.05)
    for i in np.flatnonzero(adjusted < 1):  # the adjusted p-value: the least alpha at which Holm rejects i
        assert _holm_brute_force(list(p), adjusted[i] * (1 + 1e-9))[i]
        assert not _holm_brute_force(list(p), adjusted[i] * (1 - 1e-9))[i]


def test_holm_consistent_intervals_exclude_zero_exactly_when_holm_rejects():
    rng = np.random.default_rng(7)
    samples = [rng.normal(shift, 1.0, 400) for shift in (0.0, 0.05, 0.1, 0.15, 0.2, 0.3, -0.25, 0.01)]
    p = [t_interval(s)[3] for s in samples]
    _, rejected, levels = holm(p, 0.05)
    for sample, reject, level in zip(samples, rejected, levels):
        _, low, high, _ = t_interval(sample, level)
        assert (verdict(low, high) != "tie") == reject
    assert 0 < rejected.sum() < len(samples)  # both kinds occur


def test_verdict_reads_the_interval():
    assert [verdict(-2, -0.1), verdict(-1, 1), verdict(0.2, 3)] == ["better", "tie", "worse"]


def test_t_interval_covers_a_skewed_population_at_the_nominal_level():
    # a population like the committed differences: mostly small, a few plants with a large violation cost
    rng = np.random.default_rng(3)
    population = np.concatenate([rng.normal(-0.3, 0.5, 48), [21.0, -18.0]])
    replicates = 2000
    c = t_coverage(population, 2000, replicates, 0.95, np.random.default_rng(4))
    error = np.sqrt(0.95 * 0.05 / replicates)
    assert abs(c - 0.95) < 4 * error
