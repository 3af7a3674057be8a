"""``evaluate`` from Python: policy callables and objects with ``predict`` beside the policy strings,
the table returned, and nothing written without an output directory."""

from __future__ import annotations

import numpy as np
import pytest

import agents
from agents.evaluation.evaluate import evaluate
from agents.evaluation.policies import CallablePolicy, split_policies

ENV = "DeadTime/PID-v3"
SMALL = {"n": 2, "seed": 1, "benchmark": False, "resamples": 20}


class _Half:
    """A stand-in for a stable-baselines3 model: ``predict`` gives the middle of the action range."""

    def predict(self, observation, deterministic=True):
        assert deterministic
        return np.zeros(1, dtype=np.float32), None


def _rows(result: dict) -> dict[str, dict]:
    return {row["name"]: row for row in result["policies"]}


def test_a_lambda_beside_rules_returns_the_table_and_writes_nothing(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    seen = []

    def record(observation):
        seen.append(observation)
        return [0.0]

    result = evaluate(ENV, ["simc-pi,oracle", {"mine": record}, lambda observation: np.full(1, 0.5), _Half()], **SMALL)
    rows = _rows(result)
    assert {"mine", "policy-2", "policy-3", "simc-pi", "oracle", result["best_rule"]} <= set(rows)
    assert rows["mine"]["role"] == rows["policy-2"]["role"] == "agent" and rows["simc-pi"]["role"] == "rule"
    assert rows["mine"]["n"] == 2 and np.isfinite(rows["mine"]["mean_cost"]) and rows["oracle"]["regret"] == 0
    assert len(seen) == 2 and all(isinstance(observation, np.ndarray) for observation in seen)  # one step per plant
    assert list(tmp_path.rglob("*")) == []


def test_the_zero_action_policy_is_the_same_whatever_its_form(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    result = evaluate(ENV, {"function": lambda observation: [0.0], "model": _Half()}, **SMALL)
    rows = _rows(result)
    assert rows["function"]["mean_cost"] == rows["model"]["mean_cost"]
    assert agents.evaluate is evaluate
    assert list(tmp_path.rglob("*")) == []


def test_with_an_output_directory_the_files_are_written_but_python_policies_not_cached(tmp_path):
    out = tmp_path / "out"
    evaluate(ENV, ["oracle", CallablePolicy("zero", lambda observation: [0.0])], out=out, plots=False, **SMALL)
    assert {path.name for path in out.iterdir()} >= {"results.json", "results.md", "per_plant.csv", "cache.jsonl"}
    assert "agent|" not in (out / "cache.jsonl").read_text()


@pytest.mark.parametrize(
    "policies, message",
    [
        ([3], r"policies\[0\] must be a policy name .*; got int"),
        ([], "policies must be a non-empty string or list"),
        ({"": lambda observation: [0.0]}, "a policy's name must be a non-empty string"),
        ({"a,b": lambda observation: [0.0]}, "without commas"),
        ([{"x": lambda observation: [0.0]}, {"x": _Half()}], "policy name 'x' is given twice"),
        ({"x": "simc-pi"}, r"policies\[0\] must be .*; got str"),
    ],
)
def test_bad_python_policies_are_named(policies, message):
    with pytest.raises(ValueError, match=message):
        split_policies(policies)


def test_a_python_policy_may_not_take_a_rules_name(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    with pytest.raises(ValueError, match="policy name 'oracle' is taken"):
        evaluate(ENV, {"oracle": lambda observation: [0.0]}, **SMALL)
    with pytest.raises(ValueError, match=r"unknown policy 'oracl' \(did you mean 'oracle'\?\)"):
        evaluate(ENV, "oracl", **SMALL)
    assert list(tmp_path.rglob("*")) == []


def test_strings_pass_through_unchanged():
    assert split_policies("all-rules,oracle") == ("all-rules,oracle", {})
    text, python = split_policies(["all-rules", "oracle", _Half()])
    assert text == "all-rules,oracle" and list(python) == ["policy-2"]
