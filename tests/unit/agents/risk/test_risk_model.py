"""The risk-conditioned design: the conformal quantile, its coverage on data of known law, the names."""

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
