"""``deadtime protocol frontier-cost``: the CPU time of one frontier evaluation and its identification's share."""

from __future__ import annotations

import json

from in_process import error_line, run_deadtime


def test_the_frontier_cost_command_prints_the_cpu_seconds_of_each_step():
    status, out, _ = run_deadtime("protocol", "frontier-cost", "DeadTime/PID-v3", "--plants", "1")
    measured = json.loads(out)
    assert status == 0 and 0 < measured["identification_share_of_rule_evaluation"] <= 1
    assert "--plants must be at least 1" in error_line("protocol", "frontier-cost", "DeadTime/PID-v3", "--plants", "0")
