"""The seeds-random intervals of a (seeds x plants) matrix: their standard error and coverage on the crossed model."""

import numpy as np
import pytest

from agents.frontier.statistics import COVERAGE_SETTINGS, coverage, crossed_bootstrap, crossed_interval, crossed_variance, simulate_crossed, variance_components

# (sd_seed, sd_plant, sd_residual): plants dominate, seeds as large as plants, no seed effect, residual dominates
SETTINGS = COVERAGE_SETTINGS
REPLICATES = 1000  # binomial SE of a coverage of 0.95: 0.0069; 0.93 is 2.9 SE below


@pytest.mark.parametrize("sd_seed, sd_plant, sd_residual", SETTINGS)
def test_crossed_variance_covers_the_mean_at_nominal_095(sd_seed, sd_plant, sd_residual):
    found = coverage(crossed_variance, replicates=REPLICATES, seeds=10, plants=200,
                     sd_seed=sd_seed, sd_plant=sd_plant, sd_residual=sd_residual)
    assert found.covered >= 0.93
    assert found.covered <= 0.95 + 3 * found.standard_error  # not wider than it needs to be


def test_standard_error_matches_the_spread_of_means_over_replicates():
    """Cross-check against an independent estimate: the empirical SD of the mean over simulated matrices."""
    rng = np.random.default_rng(1)
    replicates, truth = 1000, dict(sd_seed=0.5, sd_plant=1.0, sd_residual=0.7)
    means, variances = [], []
    for _ in range(replicates):
        d = simulate_crossed(rng, 10, 100, 0.0, **truth)
        means.append(d.mean())
        variances.append(crossed_variance(d).standard_error ** 2)
    exact = truth["sd_seed"] ** 2 / 10 + truth["sd_plant"] ** 2 / 100 + truth["sd_residual"] ** 2 / 1000
    # the SD of 1000 normal means is off by about 1/sqrt(2 * 1000) = 2.2%; the mean of the unbiased
    # variance estimates by its SD/sqrt(1000) (seed term on 9 degrees of freedom: 0.47 / 31 = 1.5%)
    assert np.var(means, ddof=1) == pytest.approx(exact, rel=3 * 2 * 0.022)
    assert np.mean(variances) == pytest.approx(exact, rel=3 * 0.015 + 0.01)


def test_variance_components_recover_the_model_on_a_large_matrix():
    d = simulate_crossed(np.random.default_rng(2), 400, 400, 1.0, 0.5, 1.0, 0.7)
    seed, plant, residual = variance_components(d)
    # sampling SD of each estimate: var * sqrt(2/399) = 7% relative
    assert seed == pytest.approx(0.25, rel=0.25) and plant == pytest.approx(1.0, rel=0.25)
    assert residual == pytest.approx(0.49, rel=0.02)


def test_bootstrap_agrees_with_the_variance_where_plants_dominate():
    d = simulate_crossed(np.random.default_rng(3), 10, 300, 0.0, 0.05, 1.0, 0.3)
    boot, var = crossed_bootstrap(d, resamples=4000), crossed_variance(d)
    assert boot.estimate == var.estimate == pytest.approx(d.mean())
    # the bootstrap SE of 4000 draws is off by 1.1%; its extra residual term adds < 1% here
    assert boot.standard_error == pytest.approx(var.standard_error, rel=0.1)


def test_bad_input_is_one_clear_error():
    with pytest.raises(ValueError, match="seeds x plants"):
        crossed_interval(np.zeros(5))
    with pytest.raises(ValueError, match="finite"):
        crossed_interval(np.array([[0.0, np.nan], [1.0, 2.0]]))
    with pytest.raises(ValueError, match="unknown interval method"):
        crossed_interval(np.zeros((2, 2)), method="jackknife")


def test_the_crossed_p_value_is_the_level_at_which_the_crossed_interval_touches_zero():
    """Cross-check of the p-value against the interval: at level ``1 - p`` one end of the interval is 0."""
    from agents.frontier.statistics import crossed_p_value, crossed_variance, simulate_crossed

    d = simulate_crossed(np.random.default_rng(3), 10, 200, 0.15, 0.3, 1.0, 0.5)
    p = crossed_p_value(d)
    assert 0 < p < 1
    held = crossed_variance(d, level=1.0 - p)
    assert min(abs(held.low), abs(held.high)) == pytest.approx(0.0, abs=1e-9)
