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


@pytest.mark.slow
def test_frontier_of_a_stable_baselines3_agent_of_two_seeds(tmp_path: Path) -> None:
    """A tiny PPO agent (two seeds) on PID-v0: its family by the shifted action, one curve of two seeds."""
    tiny = ["total_timesteps=32", "hyperparameters.n_steps=16", "hyperparameters.batch_size=16", "hyperparameters.n_epochs=2",
            "eval_freq=0", "checkpoint_freq=0", "progress_bar=false"]
    for seed in (0, 1):
        assert main(["train", "--config", str(ROOT / "configs" / "ppo.yaml"), "--env", "DeadTime/PID-v0",
                     "--out", str(tmp_path / f"ppo-seed{seed}"), *tiny, f"seed={seed}"]) == 0
    out = tmp_path / "frontier"
    assert main(["frontier", "--env", "DeadTime/PID-v0", "--policies", f"ppo={tmp_path}/ppo-seed*", "--knobs=-1,1",
                 "--n", "4", "--out", str(out), "--no-plots"]) == 0
    rows = json.loads((out / "frontier.json").read_text())["rows"]
    assert [(row["knob"], row["seeds"], row["kind"]) for row in rows] == [(-1.0, 2, "agent"), (0.0, 2, "agent"), (1.0, 2, "agent")]
    assert all(row["risk"] <= row["risk_union"] for row in rows)


def test_a_shipped_learner_is_a_family_by_its_name_and_a_smaller_risk_is_never_bolder(tmp_path: Path) -> None:
    from agents.frontier.frontier import frontier
    from agents.frontier.policies import parse_families

    families = parse_families("learned-pid@0.01,bold=learned-pid@0.2")
    assert [(f.name, f.kind, len(f.members)) for f in families] == [("learned-pid@0.01", "learned rule", 1), ("bold", "learned rule", 1)]
    result = frontier("DeadTime/PID-v3", families, (0.0, 1.0), n=3, seed=0, out=tmp_path)
    rows = {(row["family"], row["knob"]): row for row in result["rows"]}
    assert rows[("learned-pid@0.01", 0.0)]["risk"] <= rows[("bold", 0.0)]["risk"]
    with pytest.raises(ValueError, match=r"in \(0, 0.5\)"):
        parse_families("learned-pid@0.7")


def test_all_rules_are_the_structures_rules_once_each() -> None:
    from agents.evaluation.policies import applicable_rules
    from agents.frontier.policies import parse_families

    names = [family.name for family in parse_families("amigo-pid,all-rules", "pid")]
    assert sorted(names) == sorted(applicable_rules("pid")) and names[0] == "amigo-pid"
    with pytest.raises(ValueError, match="all-rules needs the environment's structure"):
        parse_families("all-rules")
