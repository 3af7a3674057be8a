"""The choice of the conformal bands: a band holds enough calibration plants for its realized risk, then validation decides."""

import numpy as np

from agents.risk.model import conformal_quantile
from agents.risk.train import ERROR_NOISE, MISS, RISKS, choose, least_band


def test_the_least_band_bounds_the_realized_risks_deviation_by_a_quarter_of_the_risk():
    r, n = min(RISKS), least_band()
    assert n == 3184
    assert r * (1 - r) / n <= r**2 / 16 < r * (1 - r) / (n - 1)


def test_the_least_band_agrees_with_the_realized_risks_of_simulated_calibrations():
    """Independent check: uniform scores, so a quantile q violates on a new plant with probability exactly 1 - q."""
    r, n, draws = min(RISKS), least_band(), 2000
    rng = np.random.default_rng(7)
    realized = np.array([1.0 - conformal_quantile(np.sort(rng.uniform(size=n)), r) for _ in range(draws)])
    # the realized risk is Beta(l, n + 1 - l), l = floor((n + 1) r): its exact mean and standard deviation
    l = np.floor((n + 1) * r)
    mean, sd = l / (n + 1), np.sqrt(l * (n + 1 - l) / ((n + 1) ** 2 * (n + 2)))
    assert abs(realized.mean() - mean) < 4 * sd / np.sqrt(draws)
    assert abs(realized.std() / sd - 1) < 4 / np.sqrt(2 * draws)  # the relative standard error of a standard deviation
    assert sd <= r / 4
    inside = np.mean((realized >= 0.5 * r) & (realized <= 1.5 * r))
    assert inside > 0.9  # about 95% (two standard deviations), the Beta's skew and the simulation's noise aside


def _row(miss=0.0, error=1.0):
    return {"miss": miss, "error": error}


def test_a_candidate_with_a_band_below_the_least_is_not_tried_even_when_best_on_validation():
    candidates = {("boosting", 8, True): _row(error=1.0), ("boosting", 4, False): _row(error=1.0 + ERROR_NOISE / 2),
                  ("boosting", 1, False): _row(error=1.1)}
    smallest = {("boosting", 8, True): 600, ("boosting", 4, False): 3750, ("boosting", 1, False): 15000}
    assert choose(candidates, smallest) == ("boosting", 4, False)
    # with every band large enough, the finest the validation cannot tell from the best
    assert choose(candidates, dict.fromkeys(candidates, 10**5)) == ("boosting", 8, True)


def test_the_miss_and_the_error_still_decide_among_the_candidates_tried():
    candidates = {("boosting", 4, False): _row(miss=MISS + 1), ("boosting", 2, True): _row(error=2.0),
                  ("boosting", 1, False): _row(error=1.0)}
    smallest = {("boosting", 4, False): 4000, ("boosting", 2, True): 4000, ("boosting", 1, False): 16000}
    assert choose(candidates, smallest) == ("boosting", 1, False)


def test_with_no_candidate_large_enough_the_largest_smallest_band_is_tried():
    candidates = {("boosting", 2, False): _row(), ("boosting", 1, True): _row(), ("boosting", 1, False): _row(error=5.0)}
    smallest = {("boosting", 2, False): 30, ("boosting", 1, True): 20, ("boosting", 1, False): 60}
    assert choose(candidates, smallest) == ("boosting", 1, False)
    assert choose(candidates, smallest, least=25) == ("boosting", 2, False)
