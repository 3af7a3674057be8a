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
