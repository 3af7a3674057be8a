"""The comparison table of the shipped learners at matched risk, from ``deadtime frontier``'s results."""

from in_process import error_line, run_deadtime

from agents.risk.report import matched_lines


def _result():
    rows = [{"family": family, "kind": kind, "knob": knob, "mean_cost": cost, "risk": risk}
            for family, kind, knob, cost, risk in [("learned-pid@0.01", "learned rule", 0.0, 4.0, 0.004),
                                                   ("learned-pid@0.05", "learned rule", 0.0, 3.5, 0.03),
                                                   ("amigo-pid", "rule", 0.0, 5.0, 0.09), ("amigo-pid", "rule", 1.0, 7.0, 0.04),
                                                   ("sac", "agent", 0.0, 4.5, 0.02), ("sac", "agent", 1.0, 6.0, 0.0)]]
    return {"env_id": "DeadTime/PID-v3", "env_kwargs": {}, "risk_levels": [0.01, 0.05], "rows": rows,
            "chosen": {"amigo-pid": {"1%": None, "5%": 1.0}, "sac": {"1%": 1.0, "5%": 0.0},
                       "learned-pid@0.01": {"1%": 0.0, "5%": 0.0}, "learned-pid@0.05": {"1%": None, "5%": 0.0}},
            "best": {"1%": {"rule": None}, "5%": {"rule": {"family": "amigo-pid", "knob": 1.0, "mean_cost": 7.0, "risk": 0.04}}},
            "oracle": {"mean_cost": 2.5}}


def test_each_level_shows_the_learner_at_its_risk_the_best_rule_and_the_other_learners():
    lines = matched_lines([_result()])
    assert lines[2] == "| DeadTime/PID-v3 {} | 1% | 4.000 (0.40%) | cannot reach | sac (s = 1): 6.000 (0.00%) | 2.500 |"
    assert lines[3] == ("| DeadTime/PID-v3 {} | 5% | 3.500 (3.00%) | amigo-pid (s = 1): 7.000 (4.00%) | "
                        "sac (s = 0): 4.500 (2.00%) | 2.500 |")


def test_the_command_writes_the_table_and_refuses_a_folder_without_results(tmp_path):
    import json

    (tmp_path / "runs" / "pid").mkdir(parents=True)
    (tmp_path / "runs" / "pid" / "frontier.json").write_text(json.dumps(_result()))
    status, out, _ = run_deadtime("pretrain", "--report", "--frontiers", str(tmp_path / "runs"), "--out", str(tmp_path / "out"))
    assert status == 0 and "| 5% | 3.500 (3.00%)" in (tmp_path / "out" / "comparison.md").read_text()
    assert "no frontier.json" in error_line("pretrain", "--report", "--frontiers", str(tmp_path / "out"), "--out", str(tmp_path / "x"))


def test_the_misses_expected_of_an_exactly_calibrated_learner_are_the_binomials():
    import numpy as np

    from agents.risk.calibration import expected_misses, outside_probability

    # against a simulation of the check: shares of n plants violating with probability r
    rng = np.random.default_rng(0)
    for n, r in ((2000, 0.005), (2000, 0.05), (300, 0.01)):
        shares = rng.binomial(n, r, size=200000) / n
        simulated = float(np.mean((shares < 0.5 * r) | (shares > 1.5 * r)))
        assert abs(outside_probability(n, r) - simulated) <= 4 * (simulated * (1 - simulated) / 200000) ** 0.5 + 1e-4
    assert 0.07 < outside_probability(2000, 0.005) < 0.085  # about one cell in thirteen at r = 0.5%
    assert expected_misses([(2000, 0.005), (2000, 0.005)]) == 2 * outside_probability(2000, 0.005)


def test_a_cell_most_of_whose_plants_are_unreachable_says_its_floor():
    from agents.risk.report import _count_line, _verdict

    unreachable = {"plants": 2000, "realized": 0.0165, "unreachable": 0.8, "floor": 0.031}
    assert _verdict(unreachable, 0.005) == "unreachable: floor 0.0310"
    assert _verdict({"plants": 2000, "realized": 0.006}, 0.005) == "yes"
    assert _verdict({"plants": 2000, "realized": 0.0005, "unreachable": 0.0}, 0.005) == "NO"
    line = _count_line({"MSP": {"regimes": {"priced-10": {"0.005": unreachable, "0.05": {"plants": 2000, "realized": 0.05}}}}})
    assert line.startswith("1 of 2 cells within [0.5 r, 1.5 r], 0 outside, 1 unreachable")


def test_the_calibration_interval_is_wilsons_score_interval():
    import math

    from scipy.stats import norm

    from agents.risk.calibration import wilson

    # Wilson's closed form with the exact normal quantile; the two differ by the rounding of a few operations
    z = norm.ppf(0.975)
    for k, n in ((0, 2000), (14, 2000), (71, 2000), (3, 7), (300, 300)):
        p = k / n
        centre = (p + z * z / (2 * n)) / (1 + z * z / n)
        half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
        low, high = wilson(k, n)
        assert abs(low - max(0.0, centre - half)) < 1e-12 and abs(high - min(1.0, centre + half)) < 1e-12
    assert all(math.isnan(v) for v in wilson(0, 0))
