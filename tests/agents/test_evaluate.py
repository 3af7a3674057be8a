"""``deadtime evaluate`` end to end: a tiny run through the command line, its outputs, the cache,
an agent through the loading hook, bad input, and (slow) the issue's must-show line: with
``all-rules,oracle`` the oracle is ahead of every rule of the environment's own structure, with no
violation."""

from __future__ import annotations

import csv
import json
import zipfile
from types import SimpleNamespace

import numpy as np
import pytest

from agents.cli import main
from agents.evaluation_policies import own_rules

FAST_ENV = "DeadTime/FPPI-v0"  # its oracle is the cheapest of the three


def _evaluate(capsys, tmp_path, *extra: str) -> dict:
    code = main(["evaluate", "--env", FAST_ENV, "--n", "2", "--seed", "3", "--out", str(tmp_path), "--json", *extra])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    return json.loads(captured.out)


def _per_plant(tmp_path) -> dict[tuple[int, str], dict]:
    with (tmp_path / "per_plant.csv").open() as file:
        return {(int(row["index"]), row["policy"]): row for row in csv.DictReader(file)}


@pytest.fixture()
def constant_agent(monkeypatch, tmp_path):
    """A stand-in for ``agents.policies.load_policy``: an agent that always plays action 0."""
    import agents.policies

    class Constant:
        name = "constant"
        env_id = None
        env_kwargs: dict = {}

        def predict(self, observation, deterministic=True):
            assert deterministic
            return np.zeros(1, dtype=np.float32), None

    loaded = []
    monkeypatch.setattr(agents.policies, "load_policy", lambda path: loaded.append(path) or Constant())
    path = tmp_path / "agent.zip"
    with zipfile.ZipFile(path, "w") as archive:  # a zip, so that resolve_model_path accepts it
        archive.writestr("data", "{}")
    return SimpleNamespace(path=path, loaded=loaded)


def test_tiny_run_writes_every_output_and_scores_the_agent_like_the_env(capsys, tmp_path, constant_agent):
    import gymnasium

    out = tmp_path / "out"
    result = _evaluate(capsys, out, "--policies", f"ppi-kappa1,simc-pi,oracle,const={constant_agent.path}", "--no-benchmark")
    assert constant_agent.loaded == [str(constant_agent.path)]
    assert (result["env"], result["n"], result["seed"]) == (FAST_ENV, 2, 3)
    names = {p["name"]: p for p in result["policies"]}
    best = result["best_rule"]
    assert best in own_rules("fppi")
    assert {"ppi-kappa1", "simc-pi", "oracle", "const", best} == set(names)
    assert names["const"]["role"] == "agent" and names["oracle"]["role"] == "oracle"
    assert [p["mean_cost"] for p in result["policies"]] == sorted(p["mean_cost"] for p in result["policies"])
    for p in result["policies"]:
        assert {"mean_cost", "median_cost", "violation_rate", "experiment_time", "regret", "gap_closure", "ci95"} <= set(p)
        assert set(p["ci95"]) == {"mean_cost", "median_cost", "violation_rate", "regret", "gap_closure"}
        lo, hi = p["ci95"]["mean_cost"]
        assert lo <= p["mean_cost"] <= hi
    assert names["oracle"]["regret"] == 0 and names["oracle"]["gap_closure"] == pytest.approx(1.0)
    assert names[best]["gap_closure"] == 0
    for name in ("results.md", "results.csv", "results.json", "per_plant.csv", "costs.png", "cache.jsonl"):
        assert (out / name).is_file(), name
    assert len(list(out.glob("responses_*.png"))) >= 1 and len(list(out.glob("nyquist_*.png"))) >= 1
    assert json.loads((out / "results.json").read_text()) == result
    table = (out / "results.md").read_text()
    assert "| **oracle** | oracle |" in table and "| **const** | agent |" in table

    # The oracle is the optimum of the structure's parameter: no rule of the structure beats it on a plant.
    rows = _per_plant(out)
    for index in range(2):
        oracle = float(rows[(index, "oracle")]["cost"])
        for rule in own_rules("fppi"):
            assert oracle <= float(rows[(index, rule)]["cost"]) + 1e-9, (index, rule)

    # The agent is scored exactly as its episode in the environment: same plant, seed and action.
    from envs.plant_sets import plant_set

    env = gymnasium.make(FAST_ENV)
    for index, plant in enumerate(plant_set("stable", "test", 2)):
        env.reset(seed=3 + index, options={"plant": plant})
        _, reward, terminated, _, info = env.step(np.zeros(1, dtype=np.float32))
        assert terminated
        assert float(rows[(index, "const")]["cost"]) == pytest.approx(-reward, rel=1e-12)
        # the rules are scored on the same identification as the agent
        assert float(rows[(index, "oracle")]["experiment_time"]) == pytest.approx(info["experiment_time"])


def test_rerun_is_served_from_the_cache(capsys, tmp_path, monkeypatch):
    first = _evaluate(capsys, tmp_path, "--policies", "ppi-kappa1,oracle", "--no-benchmark", "--no-plots")
    import baselines.oracle

    def no_search(*args, **kwargs):
        raise AssertionError("the oracle ran again")

    monkeypatch.setattr(baselines.oracle, "oracle", no_search)
    second = _evaluate(capsys, tmp_path, "--policies", "ppi-kappa1,oracle", "--no-benchmark", "--no-plots")
    first.pop("wall_time_s"), second.pop("wall_time_s")
    assert first == second
    # without --json: a plain table on stdout, the progress bar and the paths on stderr
    assert main(["evaluate", "--env", FAST_ENV, "--n", "2", "--seed", "3", "--out", str(tmp_path),
                 "--policies", "ppi-kappa1,oracle", "--no-benchmark", "--no-plots"]) == 0  # fmt: skip
    captured = capsys.readouterr()
    assert captured.out.splitlines()[0].startswith(f"{FAST_ENV}: 2 plants, seed 3, best rule ")
    assert any(line.split()[:2] == ["oracle", "oracle"] for line in captured.out.splitlines())
    assert "results.md" in captured.err


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--env", "DeadTime/Nope-v0", "--policies", "oracle"], "unknown environment 'DeadTime/Nope-v0'"),
        (["--env", FAST_ENV, "--policies", "oracle,no-such-rule"], "unknown rule 'no-such-rule'"),
        (["--env", FAST_ENV, "--policies", "oracle", "--n", "0"], "--n must be a positive integer, got 0"),
        (["--env", FAST_ENV, "--policies", "oracle", "--resamples", "0"], "--resamples must be positive"),
        (["--env", FAST_ENV, "--policies", "runs/none/model.zip"], "runs/none/model.zip"),
        (["--env", FAST_ENV, "--policies", "a=README.md"], "README.md is not a stable-baselines3 model"),
    ],
    ids=["env", "rule", "n", "resamples", "agent-missing", "agent-unreadable"],
)
def test_bad_input_is_one_line_and_exit_2(capsys, tmp_path, argv, message):
    code = main(["evaluate", *argv, "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and message in err and "Traceback" not in err


@pytest.mark.slow
@pytest.mark.parametrize("env_id, structure", [("DeadTime/PID-v0", "pid"), ("DeadTime/FPPI-v0", "fppi"), ("DeadTime/MSP-v0", "msp")])
def test_oracle_is_ahead_of_every_rule_of_its_structure_without_violations(capsys, tmp_path, env_id, structure):
    """The must-show line of issue 4, on the random test set and the seeds' benchmark batch."""
    code = main(["evaluate", "--env", env_id, "--policies", "all-rules,oracle", "--n", "3", "--seed", "0",
                 "--out", str(tmp_path), "--json", "--no-plots"])  # fmt: skip
    captured = capsys.readouterr()
    assert code == 0, captured.err
    result = json.loads(captured.out)
    names = {p["name"]: p for p in result["policies"]}
    oracle = names["oracle"]
    assert oracle["violation_rate"] == 0
    for rule in own_rules(structure):
        assert oracle["mean_cost"] < names[rule]["mean_cost"], rule
    rows = _per_plant(tmp_path)
    for index in range(result["plants"]):
        for rule in own_rules(structure):
            assert float(rows[(index, "oracle")]["cost"]) <= float(rows[(index, rule)]["cost"]) + 1e-9, (index, rule)


def test_episode_seeds_do_not_depend_on_n():
    from agents.evaluate import BENCHMARK_SEED_OFFSET, _episode_seeds

    small = [("test", "a", None), ("test", "b", None), ("benchmark", "P1", None), ("benchmark", "P2", None)]
    large = small[:2] + [("test", "c", None)] + small[2:]
    assert _episode_seeds(small, 5) == [5, 6, 5 + BENCHMARK_SEED_OFFSET, 6 + BENCHMARK_SEED_OFFSET]
    assert _episode_seeds(large, 5) == [5, 6, 7, 5 + BENCHMARK_SEED_OFFSET, 6 + BENCHMARK_SEED_OFFSET]
