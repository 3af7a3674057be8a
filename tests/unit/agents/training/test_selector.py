"""The selector (:mod:`agents.training.selector`): its config, its choice rule, the fixed-sequence choice of the
threshold, and a small fit played by ``deadtime evaluate`` (each plant's cost is its chosen candidate's)."""

from __future__ import annotations

import csv
import io
import json
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import numpy as np
import pytest

from agents.cli import main
from agents.training.selector import threshold_table
from agents.training.selector_config import SelectorConfig
from agents.training.selector_policy import Selector, choose

REPO = Path(__file__).resolve().parents[4]
CONFIG = REPO / "configs" / "selector.yaml"


def run(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        status = main(list(args))
    return status, out.getvalue(), err.getvalue()


def test_the_choice_is_the_cheapest_candidate_predicted_safe_else_the_safest():
    p = np.array([[0.01, 0.3, 0.02], [0.5, 0.4, 0.6], [0.05, 0.05, 0.2]])
    c = np.array([[3.0, 1.0, 2.0], [1.0, 2.0, 3.0], [2.0, 2.0, 1.0]])
    assert choose(p, c, 0.1).tolist() == [2, 1, 0]  # cheapest among p <= 0.1; none: least p; a tie: the first
    assert choose(p, c, 1.0).tolist() == [1, 0, 2]


def _selector(p: np.ndarray, c: np.ndarray) -> Selector:
    """A selector whose models return the columns of ``p`` and ``c`` row by row (observation = row index)."""

    class Column:
        def __init__(self, values, probability):
            self.values, self.classes_ = values, [False, True]
            self.probability = probability

        def predict_proba(self, rows):
            chosen = self.values[rows[:, 0].astype(int)]
            return np.column_stack([1 - chosen, chosen])

        def predict(self, rows):
            return self.values[rows[:, 0].astype(int)]

    k = p.shape[1]
    return Selector(tuple(f"c{i}" for i in range(k)), tuple(f"c{i}" for i in range(k)), {},
                    tuple(Column(p[:, i], True) for i in range(k)), tuple(Column(c[:, i], False) for i in range(k)))


def test_the_threshold_is_chosen_by_fixed_sequence_testing():
    """Thresholds tested in order; the sequence stops at the first one not certified, even if a later one would be."""
    plants = 400
    rng = np.random.default_rng(0)
    p = np.column_stack([np.zeros(plants), rng.uniform(0, 1, plants)])  # candidate 0 always safe, 1 risky
    c = np.column_stack([np.full(plants, 5.0), np.full(plants, 1.0)])
    feasible = np.column_stack([np.ones(plants, bool), p[:, 1] < 0.3])  # candidate 1 violates where p >= 0.3
    data = {"observation": np.arange(plants, dtype=float)[:, None], "cost": np.where(feasible, c, 26.0), "feasible": feasible}
    rows, index = threshold_table(_selector(p, c), data, (0.1, 0.2, 0.5, 0.25), target=0.01, confidence=0.95)
    assert [row["violating_plants"] for row in rows] == [0, 0, rows[2]["violating_plants"], 0]
    assert rows[2]["violating_plants"] > 0
    assert [row["certified"] for row in rows] == [True, True, False, False]  # 0.25 comes after a failure
    assert rows[index]["threshold"] == 0.2 and rows[index]["mean_cost"] < rows[0]["mean_cost"]
    assert sum(rows[index]["shares"].values()) == pytest.approx(1.0)
    _, cheapest = threshold_table(_selector(p, c), data, (0.1, 0.2, 0.5, 0.25), target=None, confidence=0.95)
    assert rows[cheapest]["threshold"] == 0.25  # without a target: the least mean cost (0.5 pays violations)


@pytest.mark.parametrize(("override", "message"), [
    ("candidates=[simc-pi]", "candidates must be a list of non-empty strings (at least 2)"),
    ("candidates=[simc-pi, simc-pi]", "candidates must be distinct names"),
    ("candidates=[simc-pi, fppi-eq34]", "candidates: 'fppi-eq34' is not a rule of DeadTime/PID-v3"),
    ("thresholds=[0.1, 1.5]", "thresholds must be a non-empty list of distinct numbers in [0, 1]"),
    ("env_kwargs.experiments=agent", "env_kwargs must be the fixed mode"),
    ("violation_target=1", "violation_target must be a number strictly between 0 and 1 or null"),
])
def test_bad_selector_configs_get_one_line(tmp_path, override, message):
    status, _, err = run("train", "--config", str(CONFIG), "--env", "DeadTime/PID-v3", "--out", str(tmp_path / "run"), override)
    assert status == 2 and err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "run").exists()


def test_a_small_selector_is_fitted_played_and_read_back(tmp_path):
    run_dir, evaluation = tmp_path / "selector", tmp_path / "eval"
    small = ["training_plants=60", "validation_plants=40", "progress_bar=false",
             'learned_overrides=["training_plants=30", "validation_plants=20"]']
    status, out, err = run("train", "--config", str(CONFIG), "--env", "DeadTime/PID-v3", "--out", str(run_dir), *small)
    assert status == 0, err
    assert f"deadtime evaluate --policies selector={run_dir}" in out
    manifest = json.loads((run_dir / "selector.json").read_text())
    assert manifest["candidates"] == ["simc-pi", "amigo-pid", "learned"]
    assert [row["threshold"] for row in manifest["validation"]] == list(SelectorConfig("selector", "x", candidates=("a", "b")).thresholds)
    assert manifest["threshold"] in [row["threshold"] for row in manifest["validation"]]

    status, out, err = run("evaluate", "--env", "DeadTime/PID-v3", "--policies",
                           f"selector={run_dir},simc-pi,amigo-pid,learned={run_dir / 'learned'}", "--n", "6", "--seed", "0",
                           "--out", str(evaluation), "--no-plots")
    assert status == 0, err
    rows = list(csv.DictReader((evaluation / "per_plant.csv").open()))
    by_plant: dict[str, dict[str, dict]] = {}
    for row in rows:
        by_plant.setdefault(row["index"], {})[row["policy"]] = row
    for policies in by_plant.values():  # the selector plays its choice, bit for bit
        chosen = policies["selector"]
        assert chosen["choice"] in ("simc-pi", "amigo-pid", "learned")
        assert chosen["cost"] == policies[chosen["choice"]]["cost"]
        assert all(row["choice"] == "" for name, row in policies.items() if name != "selector")
    results = json.loads((evaluation / "results.json").read_text())
    assert sum(results["choices"]["selector"].values()) == pytest.approx(1.0)
    assert next(p for p in results["policies"] if p["name"] == "selector")["role"] == "selector"

    status, out, _ = run("train", "--config", str(CONFIG), "--env", "DeadTime/PID-v3", "--out", str(run_dir), "--resume", *small)
    assert status == 0 and "already holds this selector" in out
    status, out, err = run("evaluate", "--env", "DeadTime/PID-v3", "--policies", str(run_dir), "--n", "2", "--json",
                           "--no-plots", "--out", str(tmp_path / "e2"))
    assert status == 0, err
    assert [p["name"] for p in json.loads(out)["policies"] if p["role"] == "selector"] == ["selector"]  # unnamed: its folder's name
    with (run_dir / "selector.skops").open("ab") as handle:
        handle.write(b"x")
    status, _, err = run("evaluate", "--env", "DeadTime/PID-v3", "--policies", f"selector={run_dir}", "--n", "2",
                         "--out", str(tmp_path / "e3"))
    assert status == 2 and "selector.skops is damaged or missing" in err
