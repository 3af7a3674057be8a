"""The risk-conditioned design: the conformal quantile, its coverage on data of known law, the names."""

import dataclasses
import math

import numpy as np
import pytest

from agents.risk.model import conformal_quantile, fit_learner
from agents.risk.pretrained import is_pretrained_name, parse_name


def test_conformal_quantile_is_numpys_inverted_cdf_at_the_finite_sample_level():
    scores = np.sort(np.random.default_rng(0).normal(size=199))
    for risk in (0.005, 0.01, 0.05, 0.2):
        level = math.ceil(200 * (1 - risk)) / 199
        expected = np.quantile(scores, level, method="inverted_cdf") if level <= 1 else math.inf
        assert conformal_quantile(scores, risk) == expected
    assert conformal_quantile(scores[:10], 0.05) == math.inf  # ceil(11 * 0.95) = 11 > 10


def _synthetic(n, seed):
    """A boundary of known law: b = x0 + (0.05 + 0.2 x1) e, e standard normal; x1 plays the noise feature."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(size=(n, 2))
    boundary = x[:, 0] + (0.05 + 0.2 * x[:, 1]) * rng.normal(size=n)
    boundary[rng.uniform(size=n) < 0.002] = np.nan  # no feasible design
    return {"observation": x, "action": np.nan_to_num(boundary, nan=1.0) + 0.05, "boundary": boundary}


@pytest.mark.parametrize("bands", [1, 3])
def test_the_design_violates_on_a_share_r_of_new_plants(bands):
    train = _synthetic(3000, 1)
    learner = fit_learner(train, "boosting", 0, shares=(0.5, 0.2, 0.3), bands=bands, noise_feature=1, low=-5.0, high=5.0)
    calibration = min(len(s) for s in learner.scores)
    fresh = _synthetic(20000, 2)
    previous = -np.inf
    for risk in (0.1, 0.05, 0.02):
        design = learner.design(fresh["observation"], risk)
        share = float(np.mean(design < np.where(np.isfinite(fresh["boundary"]), fresh["boundary"], np.inf)))
        # the conformal coverage given the calibration split is Beta-distributed about 1 - r with a standard
        # deviation sqrt(r(1-r)/n_cal); the fresh plants add their binomial error
        tolerance = 4 * math.sqrt(risk * (1 - risk) / calibration) + 3 * math.sqrt(risk * (1 - risk) / len(design))
        assert abs(share - risk) <= tolerance, (risk, share, tolerance)
        assert np.all(design >= learner.action_model.predict(fresh["observation"]) - 1e-12)
        assert np.mean(design) >= previous  # a smaller risk is a more conservative design
        previous = np.mean(design)


def test_a_fit_is_deterministic_given_its_seed():
    train = _synthetic(600, 3)
    rows = _synthetic(50, 4)["observation"]
    first, second = (fit_learner(train, "boosting", 7, noise_feature=1, low=-5.0, high=5.0) for _ in range(2))
    assert np.array_equal(first.design(rows, 0.05), second.design(rows, 0.05))


def test_names_of_the_pretrained_learners():
    assert parse_name("learned-pid@0.01") == ("PID", 0.01)
    assert parse_name(" learned-msp@0.2 ", "msp") == ("MSP", 0.2)
    assert is_pretrained_name("learned-foo@x") and not is_pretrained_name("amigo-pid@0.5")


@pytest.mark.parametrize("name, structure, words", [
    ("learned-pid@0.5", None, "(0, 0.5)"), ("learned-pid@0", None, "(0, 0.5)"), ("learned-pid@abc", None, "'abc'"),
    ("learned-pid@nan", None, "(0, 0.5)"), ("learned-xyz@0.01", None, "unknown structure 'xyz'"),
    ("learned-pid@0.01", "fppi", "this environment's structure is FPPI"),
])
def test_a_bad_name_is_one_line(name, structure, words):
    with pytest.raises(ValueError) as raised:
        parse_name(name, structure)
    assert words in str(raised.value) and "\n" not in str(raised.value)


def test_the_evaluation_parses_a_pretrained_name_and_refuses_a_bad_one():
    from agents.evaluation.policies import parse_policies

    specs = parse_policies("learned-pid@0.01,simc-pi", "pid")
    assert [(s.name, s.kind) for s in specs] == [("learned-pid@0.01", "learned-rule"), ("simc-pi", "rule")]
    with pytest.raises(ValueError, match="unknown structure 'pdi'"):
        parse_policies("learned-pdi@0.01", "pid")


def test_the_command_line_says_a_bad_risk_in_one_line():
    from in_process import error_line

    assert "(0, 0.5)" in error_line("evaluate", "--env", "DeadTime/PID-v3", "--policies", "learned-pid@0.9", "--n", "1",
                                    "--out", "never-written")


def _adjusted_level_quantile(feasible, risk, n):
    """The feasible plants' own conformal quantile at the adjusted level ``(r - p0) / (1 - p0)``, ``p0 = n0 / n``
    (numpy's inverted-cdf quantile at the finite-sample level), or inf where that level is not positive."""
    m = len(feasible)
    p0 = (n - m) / n
    level = (risk - p0) / (1 - p0)
    if level <= 0:
        return math.inf
    rank = math.ceil((m + 1) * (1 - level))
    return math.inf if rank > m else float(np.quantile(feasible, rank / m, method="inverted_cdf"))


@pytest.mark.parametrize("seed", range(5))
def test_the_quantile_with_no_design_plants_is_the_adjusted_level_within_a_rank(seed):
    rng = np.random.default_rng(seed)
    n0 = int(rng.integers(0, 12))
    feasible = np.sort(rng.normal(size=400 - n0))
    with_inf = np.concatenate([feasible, np.full(n0, np.inf)])
    for risk in (0.005, 0.01, 0.02, 0.05, 0.1):
        ours = conformal_quantile(feasible, risk, n0)
        assert ours == conformal_quantile(with_inf, risk)  # the n0 plants scored +inf among n
        adjusted = _adjusted_level_quantile(feasible, risk, 400)
        # the adjusted level's rank is ours or one more (rounding n+1 against m+1): never bolder
        assert ours <= adjusted
        assert adjusted == ours or adjusted == feasible[np.searchsorted(feasible, ours) + 1]
        assert math.isinf(ours) == (math.ceil(401 * (1 - risk)) > 400 - n0)


def test_the_guarantee_with_an_infeasible_share_by_simulation():
    """Scores N(0, 1), a share p0 of plants with no feasible design: the design's exact violation probability
    given the calibration split, p0 + (1 - p0)(1 - Phi(q)), averaged over many splits, is the conformal level
    1 - k/(n + 1) where reachable; where not (r below about p0), the floor p0 is what the learner reports."""
    from scipy.stats import norm

    rng, n, p0, trials = np.random.default_rng(11), 300, 0.02, 4000
    for risk in (0.03, 0.05, 0.1):
        rank = math.ceil((n + 1) * (1 - risk))
        violation, reached = [], 0
        for _ in range(trials):
            no_design = rng.uniform(size=n) < p0
            q = conformal_quantile(np.sort(rng.normal(size=n - no_design.sum())), risk, int(no_design.sum()))
            reached += math.isfinite(q)
            violation.append(p0 + (1 - p0) * norm.sf(q))
        exact = 1 - rank / (n + 1)
        # the mean of bounded draws: its standard error from the draws themselves
        assert abs(np.mean(violation) - exact) <= 4 * np.std(violation) / math.sqrt(trials) + 1e-12, (risk, np.mean(violation))
        assert exact <= risk
        if risk == 0.1:  # unreachable only beyond 29 of 300 plants with no design
            assert reached == trials
    # below the floor: unreachable in (nearly) every split, the design the most conservative
    assert math.isinf(conformal_quantile(np.sort(rng.normal(size=290)), 0.01, 10))


def _banded(n, seed):
    """Two bands of the noise feature x1: above 0.5 a share 0.04 of plants has no feasible design, below none."""
    data = _synthetic(n, seed)
    rng = np.random.default_rng(seed + 100)
    x1 = data["observation"][:, 1]
    data["boundary"] = np.where(np.isnan(data["boundary"]), data["observation"][:, 0], data["boundary"])
    data["boundary"][(x1 > 0.5) & (rng.uniform(size=n) < 0.04)] = np.nan
    return data


def test_a_band_of_unreachable_risk_leaves_the_other_calibrated_and_says_so():
    learner = fit_learner(_banded(6000, 5), "boosting", 0, shares=(0.4, 0.2, 0.4), bands=2, noise_feature=1, low=-5.0, high=5.0)
    fresh = _banded(40000, 6)
    rows, low_noise = fresh["observation"], fresh["observation"][:, 1] <= learner.band_edges[0]
    floor = learner.floor(rows)
    assert np.all(floor[low_noise] == 0) and np.all(np.abs(floor[~low_noise] - 0.04) < 0.015)
    risk = 0.01
    reachable = learner.reachable(rows, risk)
    assert np.all(reachable[low_noise]) and not np.any(reachable[~low_noise])
    design = learner.design(rows, risk)
    assert np.all(design[~low_noise] == learner.high)
    boundary = np.where(np.isfinite(fresh["boundary"]), fresh["boundary"], np.inf)
    share = float(np.mean(design[low_noise] < boundary[low_noise]))
    calibration = len(learner.scores[0])
    assert abs(share - risk) <= 4 * math.sqrt(risk * (1 - risk) / calibration) + 3 * math.sqrt(risk / low_noise.sum())


def test_a_learner_of_the_former_scores_with_inf_gives_the_same_quantiles():
    learner = fit_learner(_banded(3000, 7), "boosting", 0, bands=2, noise_feature=1, low=-5.0, high=5.0)
    rows = _banded(200, 8)["observation"]
    former = dataclasses.replace(learner, scores=[np.concatenate([s, np.full(k, np.inf)]) for s, k in
                                                  zip(learner.scores, learner.no_design)], no_design=[])
    for risk in (0.005, 0.02, 0.1):
        assert np.array_equal(former.quantiles(rows, risk), learner.quantiles(rows, risk))
        assert np.array_equal(former.floor(rows), learner.floor(rows))


def _quantized(n, seed):
    """A quarter of the plants 'quantized': seen in a third feature, their boundary's residual of another law (Student's
    t with 2 degrees of freedom) of the same median absolute value as the others' (normal): a scale cannot tell them apart."""
    rng = np.random.default_rng(seed)
    x = rng.uniform(size=(n, 3))
    quantized = rng.uniform(size=n) < 0.25
    x[:, 2] = np.where(quantized, 0.8, 0.2) + 0.1 * rng.normal(size=n)
    heavy = rng.standard_t(2, size=n) * 0.6745 / 0.8165  # the medians of |N(0, 1)| and |t_2|
    boundary = x[:, 0] + 0.1 * np.where(quantized, heavy, rng.normal(size=n))
    return {"observation": x, "action": boundary - 1.0, "boundary": boundary, "quantization": quantized * 0.1}


def test_a_band_of_its_own_calibrates_the_unquantized_plants_apart_from_the_quantized():
    train, fresh = _quantized(24000, 9), _quantized(40000, 10)
    plain = fresh["quantization"] == 0
    risk = 0.01
    shares = {}
    for apart in (False, True):
        learner = fit_learner(train, "boosting", 0, shares=(0.4, 0.2, 0.4), noise_feature=1, low=-5.0, high=5.0,
                              quantized_band=apart)
        violates = learner.design(fresh["observation"], risk) < fresh["boundary"]
        shares[apart] = (float(violates[plain].mean()), float(violates[~plain].mean()))
    calibration = 0.25 * 0.4 * 24000  # the quantized band's calibration plants, the fewer
    tolerance = 4 * math.sqrt(risk * (1 - risk) / calibration) + 3 * math.sqrt(risk / (~plain).sum())
    assert all(abs(share - risk) <= tolerance for share in shares[True]), shares
    # one band for both: the shared quantile is bold for the heavy tail, conservative for the others
    assert shares[False][1] > risk + tolerance and shares[False][0] < 0.5 * risk, shares


def test_the_unreachable_bands_are_those_whose_floor_is_above_the_risk():
    learner = fit_learner(_banded(6000, 5), "boosting", 0, shares=(0.4, 0.2, 0.4), bands=2, noise_feature=1, low=-5.0, high=5.0)
    assert learner.unreachable(0.1) == [] and learner.unreachable(0.01) == [learner.no_design[1] / (len(learner.scores[1]) + learner.no_design[1])]


def test_a_band_whose_quantile_is_minus_inf_reaches_its_risk():
    # every calibration plant's predicted optimum already feasible: scores -inf, the quantile -inf, the design f_a
    learner = fit_learner(_synthetic(600, 3), "boosting", 0, noise_feature=1, low=-5.0, high=5.0)
    learner = dataclasses.replace(learner, scores=[np.full(200, -np.inf)], no_design=[0])
    rows = _synthetic(20, 4)["observation"]
    assert np.all(learner.reachable(rows, 0.05)) and learner.unreachable(0.05) == []
    assert np.array_equal(learner.design(rows, 0.05), np.clip(learner.action_model.predict(rows), -5.0, 5.0))
