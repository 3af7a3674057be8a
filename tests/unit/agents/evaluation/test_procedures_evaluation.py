"""The procedures of :mod:`baselines.procedures` as rows of ``deadtime evaluate``: ``plan-1-1`` is the
structure's base rule after the fixed procedure, plant by plant; ``plan-best`` is chosen on validation
plants and named in ``results.json``; ``amplitude-rule`` plays its own episodes."""

from __future__ import annotations

import csv
import json

from agents.cli import main


def _costs(folder) -> dict[tuple[int, str], float]:
    with (folder / "per_plant.csv").open() as file:
        return {(int(row["index"]), row["policy"]): float(row["cost"]) for row in csv.DictReader(file)}


def test_procedures_are_rows_of_evaluate(capsys, tmp_path):
    code = main(["evaluate", "--env", "DeadTime/FPPI-v3", "--policies", "plan-1-1,plan-best,amplitude-rule,fppi-eq34,oracle",
                 "--n", "3", "--seed", "0", "--no-benchmark", "--no-plots", "--out", str(tmp_path),
                 "--env-kwargs", '{"noise_std": 0.1}'])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    assert "plan-best on DeadTime/FPPI-v3: plan-" in captured.err
    results = json.loads((tmp_path / "results.json").read_text())
    roles = {p["name"]: p["role"] for p in results["policies"]}
    assert roles["plan-1-1"] == roles["amplitude-rule"] == roles["plan-best"] == "procedure"
    assert results["chosen_plan"].startswith("plan-")
    costs = _costs(tmp_path)
    for index in range(3):
        assert costs[(index, "plan-1-1")] == costs[(index, "fppi-eq34")]  # the base rule, bit for bit


def test_a_bad_procedure_is_one_line(capsys, tmp_path):
    code = main(["evaluate", "--env", "DeadTime/FPPI-v3", "--policies", "plan-30-1", "--n", "1", "--out", str(tmp_path / "x")])
    assert code == 2 and "amplitude 30 outside" in capsys.readouterr().err
