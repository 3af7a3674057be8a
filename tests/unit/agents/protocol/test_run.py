"""A tiny protocol (one regime, two seeds, a few plants, 30 training plants per fit) run, interrupted
after its choices on validation, resumed, and reported."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from tiny_protocol import write_rule, write_tiny_protocol

from agents.protocol.config import load_protocol
from agents.protocol.every_rule import write_every_rule
from agents.protocol.report import write_report
from agents.protocol.run import PER_PLANT, SUMMARY, run_protocol
from agents.protocol.streams import register_test_seed


@pytest.mark.slow
def test_a_tiny_protocol_runs_resumes_and_reports(tmp_path):
    path = write_tiny_protocol(tmp_path, wide=True, register=True)
    protocol = load_protocol(path)
    out = tmp_path / "out"
    assert run_protocol(protocol, out, validation_only=True) == ["pid-tiny"]
    regime = out / "pid-tiny"
    assert (regime / "selection.json").exists() and not (regime / PER_PLANT).exists()
    assert not (out / "work" / "pid-tiny" / "test").exists()  # no test plant scored yet
    assert run_protocol(protocol, out, resume=True) == ["pid-tiny"]
    first = (regime / PER_PLANT).read_bytes()
    fits = sorted((out / "work" / "runs").glob("*/s*/learned_rule.json"))
    assert len(fits) == 6  # three learners, two seeds
    stamps = [fit.stat().st_mtime_ns for fit in fits]

    # interrupted after the choices: the test stream is scored again from the evaluation's cache
    (regime / SUMMARY).unlink()
    (regime / PER_PLANT).unlink()
    with pytest.raises(ValueError, match="--resume"):
        run_protocol(protocol, out)
    assert run_protocol(protocol, out, resume=True) == ["pid-tiny"]
    assert (regime / PER_PLANT).read_bytes() == first
    assert [fit.stat().st_mtime_ns for fit in fits] == stamps  # no fit trained twice

    # another run folder given these fits (--fits) reads them back: nothing trained, the same results
    assert run_protocol(protocol, tmp_path / "again", validation_only=True, fits=out / "work" / "runs") == ["pid-tiny"]
    assert [fit.stat().st_mtime_ns for fit in fits] == stamps and not (tmp_path / "again" / "work" / "runs").exists()
    again = json.loads((tmp_path / "again" / "pid-tiny" / "selection.json").read_text())
    assert again["validation_mean_cost"] == json.loads((regime / "selection.json").read_text())["validation_mean_cost"]

    results = write_report(protocol, out)
    assert results["protocol_sha256"] == protocol.sha256 and results["complete"]
    entry = results["regimes"][0]
    assert entry["rule_chosen_on"] == "validation" and entry["test_plants"] == 6
    assert entry["benchmark"]["plants"] == 9 and entry["benchmark"]["pooled"] is False
    assert len(entry["comparisons"]) == 4
    for comparison in entry["comparisons"]:
        assert comparison["adjustment"] == "holm" and comparison["verdict"] in ("better", "tie", "worse")
        assert comparison["adjusted"]["low"] <= comparison["estimate"]["low"] <= comparison["estimate"]["high"]
    assert all(v["unit"] == "plant" for v in entry["violations"].values())
    selection = json.loads((regime / "selection.json").read_text())
    assert selection["chosen_on"] == "validation" and selection["validation_plants"] == 5
    assert (out / "results.md").read_text().count("\n| pid-tiny") == 4 and (out / "forest.png").exists()

    # every declared rule on the same test plants: the best rule as the run scored it, the primaries against each
    (table,) = write_every_rule(protocol, out)
    assert sorted(table["rules"]) == ["gorez-klan-mu-2", "simc-pi"] and table["test_plants"] == 6
    best = selection["chosen"]["best-rule"]
    summary = json.loads((regime / SUMMARY).read_text())
    assert table["rules"][best]["mean_cost"] == pytest.approx(summary["policies"]["best-rule"]["mean_cost"], rel=1e-6)
    fixed = next(c for c in entry["comparisons"] if c["roles"] == ["fixed", "best-rule"])
    assert table["rules"][best]["differences"]["fixed"]["mean"] == pytest.approx(fixed["estimate"]["mean"], rel=1e-5, abs=1e-6)
    assert "`gorez-klan-mu-2`" in (out / "every_rule.md").read_text()


PI_PROTOCOL = """name: tiny-pi
seeds: {{first: 0, count: 2}}
alpha: 0.05
streams:
  validation: {{entropy: 21, plants: 4, episode_seed: 50000000}}
  test: {{entropy: 22, plants: 5, episode_seed: 60000000}}
selection:
  violation_target: 0.5
  confidence: 0.95
  rules: [amigo-pi]
comparisons: [[fixed, best-rule], [fixed, base-rule]]
regimes:
  - name: pi-tiny
    env: DeadTime/PI-v3
    env_kwargs: {{noise_std: 0.01}}
    fixed:
      - {{label: tiny-fixed, config: {rule}, overrides: ["env_id=DeadTime/PI-v3"]}}
"""


@pytest.mark.slow
def test_the_base_rule_is_compared_where_declared_and_scored_though_not_among_the_rules(tmp_path):
    """``base-rule`` is the structure's own rule (on the PI: ``simc-pi``), fixed in advance, not chosen."""
    path = tmp_path / "tiny-pi.yaml"
    path.write_text(PI_PROTOCOL.format(rule=write_rule(tmp_path)))
    protocol = load_protocol(path)
    register_test_seed(protocol.test.entropy, protocol.path, protocol.sha256, path.with_name("test_seeds.json"))
    out = tmp_path / "out"
    assert run_protocol(protocol, out) == ["pi-tiny"]
    selection = json.loads((out / "pi-tiny" / "selection.json").read_text())
    assert selection["chosen"]["best-rule"] == "amigo-pi" and selection["chosen"]["base-rule"] == "simc-pi"
    entry = write_report(protocol, out)["regimes"][0]
    assert [(c["first"], c["second"]) for c in entry["comparisons"]] == [("tiny-fixed", "amigo-pi"), ("tiny-fixed", "simc-pi")]


SEQ_PROTOCOL = """name: tiny-seq
seeds: {{first: 0, count: 2}}
alpha: 0.05
streams:
  validation: {{entropy: 31, plants: 4, episode_seed: 50000000}}
  test: {{entropy: 32, plants: 5, episode_seed: 60000000}}
selection:
  violation_target: 0.5
  confidence: 0.95
  rules: [simc-pi]
  plans: [plan-1-1]
  fixed_procedure: plan-1-1
comparisons: [[seq, best-rule], [seq, plan], [seq, fixed-procedure]]
regimes:
  - name: msp-tiny
    env: DeadTime/MSP-v3
    env_kwargs: {{noise_std: 0.1}}
    plan:
      - {{label: tiny-plan, config: {rule}, overrides: ["env_id=DeadTime/MSP-v3", "env_kwargs.plan=[3, 0.1]"]}}
    seq:
      - {{label: tiny-seq, config: configs/sequential.yaml, overrides: [total_timesteps=64, eval_freq=64, n_eval_episodes=2,
           checkpoint_freq=64, progress_bar=false, hyperparameters.n_steps=32, hyperparameters.batch_size=16,
           hyperparameters.n_epochs=1]}}
"""


@pytest.mark.slow
def test_a_sequential_primary_is_trained_chosen_and_compared_with_the_plan_primary(tmp_path):
    """As protocol v4 declares it: a sequential and a plan-mode primary, no fixed-mode candidate."""
    path = tmp_path / "tiny-seq.yaml"
    path.write_text(SEQ_PROTOCOL.format(rule=write_rule(tmp_path)))
    protocol = load_protocol(path)
    assert [learner.label for learner in protocol.regimes[0].seq] == ["tiny-seq"]
    register_test_seed(protocol.test.entropy, protocol.path, protocol.sha256, path.with_name("test_seeds.json"))
    out = tmp_path / "out"
    assert run_protocol(protocol, out) == ["msp-tiny"]
    selection = json.loads((out / "msp-tiny" / "selection.json").read_text())
    assert selection["chosen"]["seq"] == "tiny-seq" and selection["candidates"]["seq"][0]["plants"] == 4
    results = write_report(protocol, out)
    assert results["complete"] and results["comparisons_declared"] == 3
    pairs = [(c["roles"][0], c["roles"][1], c["second"]) for c in results["regimes"][0]["comparisons"]]
    assert pairs[1] == ("seq", "plan", "tiny-plan") and pairs[2] == ("seq", "fixed-procedure", "plan-1-1")
    assert (out / "forest.png").is_file() and "tiny-seq" in (out / "results.md").read_text()
