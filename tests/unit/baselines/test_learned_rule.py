"""The learned rule's numerics (:mod:`baselines.learned_rule`): the regressions, the margin and its
direction, clipping, the choice of model and margin, bad input."""

from __future__ import annotations

from statistics import NormalDist

import numpy as np
import pytest

from baselines.learned_rule import (MODEL_KINDS, QUANTILE, SPREAD_FLOOR, LearnedRule, Validated, fit_regression, fit_spread, select,
                                    violation_bound)


def _data(n: int = 400, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    observations = rng.uniform(-1, 1, (n, 3))
    actions = 0.5 * observations[:, 0] - 0.3 * observations[:, 1] ** 2 + 0.05 * rng.standard_normal(n)
    return observations, actions


@pytest.mark.parametrize("kind", MODEL_KINDS)
def test_each_kind_learns_a_smooth_map(kind: str) -> None:
    observations, actions = _data()
    fresh, truth = _data(200, seed=1)
    model = fit_regression(kind, observations, actions)
    error = model.predict(fresh) - truth
    # the noise has sd 0.05; the quantile fit sits above the mean by z(QUANTILE) sd (0.064 for 0.9).
    # Measured on four draws of these data: mean errors within 0.013 of that, sd of the errors 0.05-0.075.
    bias = NormalDist().inv_cdf(QUANTILE) * 0.05 if kind == "quantile-boosting" else 0.0
    assert abs(float(np.mean(error)) - bias) < 0.03
    assert float(np.sqrt(np.mean((error - error.mean()) ** 2))) < 0.1


def test_the_quantile_fit_is_above_the_mean_fit() -> None:
    observations, actions = _data()
    mean = fit_regression("boosting", observations, actions).predict(observations)
    upper = fit_regression("quantile-boosting", observations, actions).predict(observations)
    assert float(np.mean(upper > mean)) > 0.8


def _rule(margin: float = 0.0, direction: float = 1.0) -> LearnedRule:
    observations, actions = _data()
    return LearnedRule("ridge-quadratic", fit_regression("ridge-quadratic", observations, actions), margin, direction,
                       -1.0, 1.0, 3)


def test_the_margin_shifts_towards_the_conservative_side_and_is_clipped() -> None:
    observations, _ = _data(50, seed=2)
    base = _rule().regression(observations)
    for direction in (1.0, -1.0):
        shifted = _rule(0.2, direction).predict(observations)
        assert shifted.shape == (50, 1) and shifted.dtype == np.float32
        expected = np.clip(base + 0.2 * direction, -1, 1).astype(np.float32)
        np.testing.assert_array_equal(shifted[:, 0], expected)
    assert np.all(_rule(5.0).predict(observations) == 1.0)
    one = _rule(0.1).predict(observations[0])
    assert one.shape == (1,) and one[0] == _rule(0.1).predict(observations)[0, 0]


def _heteroscedastic(n: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Actions whose noise sd grows with the first feature: 0.01 at -1 to 0.21 at +1."""
    rng = np.random.default_rng(seed)
    observations = rng.uniform(-1, 1, (n, 3))
    sd = 0.11 + 0.1 * observations[:, 0]
    return observations, 0.3 * observations[:, 1] + sd * rng.standard_normal(n), sd


def test_the_spread_scale_follows_the_noise_and_averages_one_on_the_training_plants() -> None:
    observations, actions, sd = _heteroscedastic(2000, 0)
    spread = fit_spread(observations, actions)
    scale = spread.scale(observations)
    # the mean width on the training plants is the divisor: the mean scale is 1 up to rounding
    assert abs(float(np.mean(scale)) - 1.0) < 1e-12 and np.all(spread.width(observations) >= SPREAD_FLOOR)
    # the true band is 2 z(0.9) sd = 2.56 sd; the fitted width's rank correlation with it is what the
    # scale carries (measured 0.93-0.96 on six draws of these data)
    fresh, _, fresh_sd = _heteroscedastic(500, 1)
    from scipy.stats import spearmanr

    assert spearmanr(spread.width(fresh), fresh_sd).statistic > 0.8
    # the mean width against the true band's: trees on 2000 noisy points shrink it by 9-14% (six draws)
    assert abs(float(np.mean(spread.width(fresh))) / float(np.mean(2 * NormalDist().inv_cdf(QUANTILE) * fresh_sd)) - 1) < 0.3


def test_a_spread_margin_is_the_constant_margin_times_the_scale() -> None:
    observations, actions, _ = _heteroscedastic(600, 0)
    spread = fit_spread(observations, actions)
    model = fit_regression("quantile-boosting", observations, actions)
    constant = LearnedRule("quantile-boosting", model, 0.3, -1.0, -5.0, 5.0, 3)
    scaled = LearnedRule("quantile-boosting", model, 0.3, -1.0, -5.0, 5.0, 3, spread)
    assert constant.margin_scale == "constant" and scaled.margin_scale == "spread"
    assert scaled.with_margin(0.1).spread is spread
    expected = (constant.regression(observations) - 0.3 * spread.scale(observations)).astype(np.float32)
    np.testing.assert_array_equal(scaled.predict(observations)[:, 0], expected)
    assert scaled.with_margin(0.0).predict(observations[:5]).tolist() == constant.with_margin(0.0).predict(observations[:5]).tolist()


@pytest.mark.parametrize(
    ("observation", "message"),
    [(np.zeros(4), "observation must have 3 entries"), (np.array([0.0, np.nan, 0.0]), "observation must be finite")],
)
def test_a_wrong_observation_is_refused(observation: np.ndarray, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        _rule().predict(observation)


def test_select_takes_the_lowest_validation_cost_and_ties_go_to_the_larger_margin() -> None:
    rules = [_rule(), LearnedRule("boosting", _rule().model, 0.0, 1.0, -1.0, 1.0, 3)]
    seen = []

    def cost(rule: LearnedRule) -> Validated:
        seen.append((rule.kind, rule.margin))
        return Validated({("ridge-quadratic", 0.1): 1.0, ("boosting", 0.2): 1.0}.get((rule.kind, rule.margin), 2.0), 3, 100)

    selection = select(rules, [0.0, 0.1, 0.2], cost)
    assert (selection.rule.kind, selection.rule.margin) == ("boosting", 0.2)
    assert len(seen) == 6 and selection.costs["ridge-quadratic"] == (2.0, 1.0, 2.0)
    assert selection.is_certified is None and selection.violations["boosting"] == (3, 3, 3)


def _validated(costs: dict[float, float], violations: dict[float, int], plants: int = 500):
    return lambda rule: Validated(costs[rule.margin], violations[rule.margin], plants)


def test_a_violation_target_restricts_the_choice_to_the_certified_margins() -> None:
    """500 plants at 95%: 0 or 1 violation certifies 1% (bounds 0.6% and 0.94%), 2 does not (1.25%)."""
    margins = [0.0, 0.1, 0.2, 0.3]
    costs = {0.0: 1.0, 0.1: 1.1, 0.2: 1.2, 0.3: 1.3}
    violations = {0.0: 9, 0.1: 2, 0.2: 1, 0.3: 0}
    free = select([_rule()], margins, _validated(costs, violations))
    assert free.rule.margin == 0.0 and free.is_certified is None
    held = select([_rule()], margins, _validated(costs, violations), violation_target=0.01)
    assert held.rule.margin == 0.2 and held.is_certified
    assert held.certified["ridge-quadratic"] == (False, False, True, True)


def test_fixed_sequence_testing_stops_at_the_first_margin_that_fails() -> None:
    """A cheap small margin with no violations below a failing one is not certified: the sequence from the
    largest margin down stopped at the failure (testing it anyway would spend the error budget twice)."""
    margins = [0.0, 0.1, 0.2]
    costs, violations = {0.0: 1.0, 0.1: 2.0, 0.2: 3.0}, {0.0: 0, 0.1: 5, 0.2: 0}
    held = select([_rule()], margins, _validated(costs, violations), violation_target=0.01)
    assert held.rule.margin == 0.2 and held.certified["ridge-quadratic"] == (False, False, True)


def test_without_a_certified_margin_the_fewest_violations_are_chosen_and_said_so() -> None:
    margins = [0.0, 0.1, 0.2]
    costs, violations = {0.0: 1.0, 0.1: 2.0, 0.2: 1.5}, {0.0: 9, 0.1: 4, 0.2: 4}
    held = select([_rule()], margins, _validated(costs, violations), violation_target=0.01)
    assert (held.rule.margin, held.is_certified) == (0.2, False)


def test_bonferroni_over_kinds_needs_more_plants() -> None:
    """One violation-free kind on 300 plants certifies 1% at 95% (bound 0.994%); two kinds test each at
    97.5%, where 0 of 300 bounds the rate by 1.22% only."""
    costs, violations = {0.0: 1.0}, {0.0: 0}
    one = select([_rule()], [0.0], _validated(costs, violations, 300), violation_target=0.01)
    two = select([_rule(), LearnedRule("boosting", _rule().model, 0.0, 1.0, -1.0, 1.0, 3)], [0.0],
                 _validated(costs, violations, 300), violation_target=0.01)
    assert one.is_certified and not two.is_certified


@pytest.mark.parametrize("plants", [1, 7, 60, 300, 500, 1000])
@pytest.mark.parametrize("confidence", [0.9, 0.95, 0.99])
def test_the_clopper_pearson_bound_is_the_exact_binomial_test(plants: int, confidence: float) -> None:
    """Independent check of :func:`violation_bound` (the beta quantile) against scipy's exact binomial test:
    the bound ``u`` has ``P(Binomial(n, u) <= k) = 1 - confidence``, so the one-sided test of ``p >= r``
    rejects at level ``1 - confidence`` exactly for the rates ``r`` above ``u``.  The beta quantile is
    accurate to ~1e-12 here, so rates 1e-6 apart on either side of it decide the test correctly."""
    from scipy.stats import binom, binomtest

    for violations in sorted({0, 1, plants // 3, plants - 1} - {plants}):
        bound = violation_bound(violations, plants, confidence)
        assert binom.cdf(violations, plants, bound) == pytest.approx(1 - confidence, rel=1e-7)
        for rate, rejected in ((bound + 1e-6, True), (bound - 1e-6, False)):
            if 0 < rate < 1:
                p_value = binomtest(violations, plants, rate, alternative="less").pvalue
                assert (p_value <= 1 - confidence) == rejected
    assert violation_bound(plants, plants, confidence) == 1.0
    assert violation_bound(0, plants, confidence) == pytest.approx(1 - (1 - confidence) ** (1 / plants), rel=1e-10)


def test_the_certificate_holds_on_simulated_validation_sets() -> None:
    """The promise itself, simulated: rules whose true violation rates fall with the margin; on 2000 draws
    of 500 validation plants, the chosen rule's true rate exceeds 1% in at most 5% of draws (binomial
    sampling error of that share over 2000 draws: sd 0.5%, so the bound is 5% + 3 sd)."""
    rng = np.random.default_rng(0)
    margins = np.linspace(0, 0.5, 11)
    true_rates = 0.04 * np.exp(-8 * margins)  # 4% at no margin, below 1% from 0.2 on
    failures, rule = 0, _rule()
    for _ in range(2000):
        counts = dict(zip(margins.tolist(), rng.binomial(500, true_rates).tolist()))
        costs = {m: 1.0 + m for m in margins.tolist()}
        chosen = select([rule], margins.tolist(), _validated(costs, counts), violation_target=0.01)
        failures += bool(true_rates[margins.tolist().index(chosen.rule.margin)] > 0.01) and bool(chosen.is_certified)
    assert failures / 2000 <= 0.05 + 3 * np.sqrt(0.05 * 0.95 / 2000)


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda: fit_regression("linear", *_data()), "model kind must be one of"),
        (lambda: fit_regression("boosting", np.zeros(3), np.zeros(3)), "observations must be"),
        (lambda: fit_regression("boosting", np.zeros((1, 3)), np.zeros(1)), "at least 2 training plants"),
        (lambda: fit_regression("boosting", np.full((4, 3), np.inf), np.zeros(4)), "must be finite"),
        (lambda: _rule(-0.1), "margin must be"),
        (lambda: _rule(0.0, 0.5), "direction must be"),
        (lambda: select([_rule()], [-0.1], lambda r: Validated(0.0, 0, 1)), "margins must be"),
        (lambda: select([_rule(), _rule()], [0.0], lambda r: Validated(0.0, 0, 1)), "distinct"),
        (lambda: select([_rule()], [0.0], lambda r: Validated(0.0, 0, 1), violation_target=1.0), "violation_target must"),
        (lambda: select([_rule()], [0.0], lambda r: Validated(0.0, 0, 1), confidence=0.0), "confidence must"),
        (lambda: select([_rule()], [0.0, 0.1], lambda r: Validated(0.0, 0, 1 + int(10 * r.margin))), "same number"),
        (lambda: violation_bound(3, 2, 0.95), "violations and plants"),
        (lambda: fit_regression("quantile-boosting", *_data(), quantile=1.0), "quantile must"),
        (lambda: fit_spread(*_data(), quantile=0.5), "quantile other than 0.5"),
    ],
    ids=["kind", "shape", "too-few", "non-finite", "negative-margin", "direction", "select-margin", "select-kinds",
         "target", "confidence", "plants", "bound-counts", "quantile", "spread-quantile"],
)
def test_bad_input_is_a_value_error(call, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        call()
