"""``deadtime frontier`` on a learned rule of two seeds, loaded by a glob: one family, risk per seed and union."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from agents.cli import main

ROOT = Path(__file__).resolve().parents[4]
CONFIG = ROOT / "configs" / "learned_rule.yaml"
ENV = "DeadTime/FPPI-v0"
SMALL = ["training_plants=12", "validation_plants=4", "margins=[0.0, 0.1]", "models=[ridge-quadratic]", "progress_bar=false"]


@pytest.mark.slow
def test_frontier_of_a_learned_rule_of_two_seeds(tmp_path: Path) -> None:
    for seed in (0, 1):
        words = ["train", "--config", str(CONFIG), "--env", ENV, "--out", str(tmp_path / f"lr-seed{seed}"), *SMALL, f"seed={seed}"]
        assert main(words) == 0
    out = tmp_path / "frontier"
    assert main(["frontier", "--env", ENV, "--policies", f"fppi-eq34,lr={tmp_path}/lr-seed*", "--knobs=-0.5,0.5",
                 "--n", "5", "--out", str(out), "--no-plots"]) == 0
    result = json.loads((out / "frontier.json").read_text())
    learned = [row for row in result["rows"] if row["family"] == "lr"]
    assert [row["knob"] for row in learned] == [-0.5, 0.0, 0.5]
    assert all(row["seeds"] == 2 and row["kind"] == "learned rule" for row in learned)
    assert all(row["risk"] <= row["risk_union"] <= min(1.0, 2 * row["risk"]) + 1e-12 for row in learned)
    # a rerun is served from the cache: the same table
    assert main(["frontier", "--env", ENV, "--policies", f"fppi-eq34,lr={tmp_path}/lr-seed*", "--knobs=-0.5,0.5",
                 "--n", "5", "--out", str(out), "--no-plots"]) == 0
    assert json.loads((out / "frontier.json").read_text())["rows"] == result["rows"]
