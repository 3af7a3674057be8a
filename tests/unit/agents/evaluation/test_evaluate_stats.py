"""The statistics of ``deadtime evaluate`` on synthetic numbers, against hand computation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from agents.evaluation.stats import bootstrap_indices, gap_closure, percentile_interval, summarize


def _summary(costs, oracle, best, violations=None, resamples=2000, seed=0):
    costs = {k: np.asarray(v, dtype=float) for k, v in costs.items()}
    n = len(oracle)
    violations = violations or {k: np.zeros(n) for k in costs}
    return {
        s.name: s
        for s in summarize(
            costs, violations, {k: np.zeros(n) for k in costs}, {k: np.full(n, 2.0) for k in costs},
            np.asarray(oracle, dtype=float), None if best is None else np.asarray(best, dtype=float),
            resamples=resamples, seed=seed,
        )
    }  # fmt: skip


@pytest.mark.parametrize(
    "best, policy, oracle, expected",
    [
        pytest.param(3.0, 2.5, 2.0, 0.5, id="half-way"),
        pytest.param(3.0, 3.0, 2.0, 0.0, id="best-rule-itself"),
        pytest.param(3.0, 2.0, 2.0, 1.0, id="oracle-itself"),
        pytest.param(3.0, 4.0, 2.0, -1.0, id="worse-than-best-rule"),
        pytest.param(3.0, 1.5, 2.0, 1.5, id="beats-the-oracle"),
    ],
)
def test_gap_closure_by_hand(best, policy, oracle, expected):
    assert gap_closure(best, policy, oracle) == pytest.approx(expected)


def test_gap_closure_undefined_without_gap():
    assert math.isnan(gap_closure(2.0, 1.0, 2.0))
    values = gap_closure(np.array([3.0, 2.0]), np.array([2.5, 1.0]), np.array([2.0, 2.0]))
    assert values[0] == pytest.approx(0.5) and math.isnan(values[1])


def test_point_figures_by_hand():
    oracle = [1.0, 2.0, 3.0, 4.0]
    best = [2.0, 3.0, 4.0, 5.0]  # mean 3.5
    policy = [1.0, 2.5, 3.0, 30.0]  # mean 9.125, median 2.75
    s = _summary({"p": policy, "b": best}, oracle, best, violations={"p": np.array([0, 0, 0, 1.0]), "b": np.zeros(4)})
    p = s["p"]
    assert p.mean_cost == pytest.approx(9.125)
    assert p.median_cost == pytest.approx(2.75)
    assert p.violation_rate == pytest.approx(0.25)
    assert p.regret == pytest.approx(9.125 - 2.5)
    assert p.gap_closure == pytest.approx((3.5 - 9.125) / (3.5 - 2.5))
    assert p.experiment_time == 2.0
    assert s["b"].gap_closure == 0.0


def test_paired_resampling_gives_exact_intervals_for_a_constant_shift():
    """A policy that is the oracle plus 0.5 everywhere has regret 0.5 on every paired resample,
    and the best rule (oracle + 1) gives gap closure 0.5 on every resample: degenerate intervals.
    Unpaired resampling would spread both."""
    rng = np.random.default_rng(7)
    oracle = rng.uniform(1, 5, 30)
    s = _summary({"p": oracle + 0.5, "b": oracle + 1.0}, oracle, oracle + 1.0)
    assert s["p"].ci95["regret"] == pytest.approx([0.5, 0.5])
    assert s["p"].ci95["gap_closure"] == pytest.approx([0.5, 0.5])
    assert s["b"].ci95["gap_closure"] == pytest.approx([0.0, 0.0])


def test_two_plant_bootstrap_by_hand():
    """Costs (0, 1): a resample's mean is 0, 1/2 or 1 with probabilities 1/4, 1/2, 1/4, so the
    95 % percentile interval is [0, 1] (with 2000 resamples each end has about 500 hits)."""
    s = _summary({"p": [0.0, 1.0]}, [0.0, 0.0], None)
    assert s["p"].ci95["mean_cost"] == [0.0, 1.0]
    assert math.isnan(s["p"].gap_closure) and all(math.isnan(v) for v in s["p"].ci95["gap_closure"])


def test_intervals_match_a_hand_written_bootstrap():
    rng = np.random.default_rng(3)
    oracle = rng.uniform(1, 2, 12)
    policy = oracle + rng.uniform(0, 1, 12)
    s = _summary({"p": policy}, oracle, oracle + 1, resamples=500, seed=11)["p"]
    draws = np.random.default_rng(11).integers(0, 12, size=(500, 12))
    means = np.array([policy[row].mean() for row in draws])
    medians = np.array([np.median(policy[row]) for row in draws])
    regrets = np.array([policy[row].mean() - oracle[row].mean() for row in draws])
    assert s.ci95["mean_cost"] == pytest.approx(list(np.percentile(means, [2.5, 97.5])))
    assert s.ci95["median_cost"] == pytest.approx(list(np.percentile(medians, [2.5, 97.5])))
    assert s.ci95["regret"] == pytest.approx(list(np.percentile(regrets, [2.5, 97.5])))
    lo, hi = s.ci95["mean_cost"]
    assert lo <= s.mean_cost <= hi


def test_same_seed_same_intervals_other_seed_other_intervals():
    rng = np.random.default_rng(5)
    oracle = rng.uniform(1, 3, 20)
    costs = {"p": oracle * rng.uniform(1, 2, 20)}
    a, b, c = (_summary(costs, oracle, None, seed=seed)["p"].ci95 for seed in (1, 1, 2))
    assert a == b and a != c


def test_bootstrap_indices_and_interval_edges():
    index = bootstrap_indices(5, 7, np.random.default_rng(0))
    assert index.shape == (7, 5) and index.min() >= 0 and index.max() <= 4
    with pytest.raises(ValueError, match="n must be > 0"):
        bootstrap_indices(0, 7, np.random.default_rng(0))
    assert all(math.isnan(v) for v in percentile_interval(np.array([np.nan, np.nan])))
    assert percentile_interval(np.array([1.0, np.nan, 1.0])) == [1.0, 1.0]


def test_to_dict_replaces_nan_by_none():
    s = _summary({"p": [1.0, 2.0]}, [1.0, 1.0], None)["p"].to_dict()
    assert s["gap_closure"] is None and s["ci95"]["gap_closure"] == [None, None]
    assert s["mean_cost"] == 1.5
