"""The transfer study: per condition each policy's mean over emulator seeds, its rank among the non-oracles,
and the transfer gap, measured minus predicted."""

from __future__ import annotations

import pytest

from agents.studies.transfer import _summary, markdown, transfer


def _row(condition, seed, policy, cost, predicted, role="rule", run=None, feasible=True, note=None):
    return {"condition": condition, "seed": seed, "policy": policy, "run": run or policy, "role": role, "cost": cost,
            "feasible": feasible, "predicted": predicted, "note": note}


def test_the_summary_ranks_the_non_oracles_and_measures_the_gap():
    rows = []
    for seed, shift in ((0, 0.0), (1, 0.2)):
        rows += [_row("c", seed, "rule-a", 1.0 + shift, 0.9 + shift), _row("c", seed, "rule-b", 2.0 + shift, 2.0),
                 _row("c", seed, "oracle", 0.5, 0.5, role="oracle"),
                 _row("c", seed, "g", 1.5 + shift, 1.0, role="agent", run="g#0", note="out of distribution: tau"),
                 _row("c", seed, "g", 1.7 + shift, 1.2, role="agent", run="g#1", feasible=False)]
    summary = {e["policy"]: e for e in _summary(rows, ["g"])}
    assert summary["g"]["mean_cost"] == pytest.approx(1.7) and summary["g"]["rank"] == 2 and summary["g"]["ranked"] == 3
    assert summary["g"]["transfer_gap"] == pytest.approx(0.6) and summary["g"]["infeasible"] == pytest.approx(0.5)
    assert summary["g"]["out_of_distribution"] == 2 and summary["g"]["designs"] == 4
    assert "rank" not in summary["oracle"] and summary["rule-a"]["rank"] == 1
    table = markdown(list(summary.values()), ["g"])
    assert "| c | `rule-a` 1.1 | 1.7 [" in table and "2 of 3, +0.6, +0.6, 50%, 2 of 4 | 0.5 | - |" in table


def test_one_emulator_seed_is_refused():
    with pytest.raises(ValueError, match="--seeds must be at least 2"):
        transfer({}, 1, None)


@pytest.mark.slow
def test_the_study_runs_a_condition_with_a_rule_only_group(tmp_path):
    from envs.process.tclab_conditions import CONDITIONS

    chosen = tuple(c for c in CONDITIONS if c.name == "no quantization")
    table = transfer({}, 2, tmp_path, conditions=chosen)
    assert table.count("\n| no quantization |") == 1 and (tmp_path / "transfer.png").is_file()
    assert table.splitlines()[1] == "|---|---|---|---|"  # condition, best rule, the two oracles


@pytest.mark.slow
def test_a_shipped_learner_is_a_group_by_its_name_and_reads_the_nominal_emulator_in_distribution(tmp_path):
    from envs.process.tclab_conditions import CONDITIONS

    transfer({"learned-fppi@0.01": ["learned-fppi@0.01"]}, 2, tmp_path, conditions=CONDITIONS[:1])
    import gzip
    import json

    summary = json.loads(gzip.decompress((tmp_path / "transfer.json.gz").read_bytes()))["summary"]
    (entry,) = [e for e in summary if e["policy"] == "learned-fppi@0.01"]
    assert entry["role"] == "learner" and entry["designs"] == 2 and entry["rank"] <= entry["ranked"]
    assert entry["out_of_distribution"] == 0
