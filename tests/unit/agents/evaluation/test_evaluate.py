"""``deadtime evaluate`` end to end: a tiny run through the command line, its outputs, the cache,
an agent through the loading hook, bad input, and (slow) the oracle's line: with
``all-rules,oracle`` the oracle is ahead of every rule (by mean cost; of its own structure plant by plant), with no
violation."""

from __future__ import annotations

import csv
import json
import zipfile
from types import SimpleNamespace
from typing import ClassVar

import numpy as np
import pytest

from agents.cli import main
from agents.evaluation.policies import applicable_rules, own_rules
from envs.interface import episode_of

FAST_ENV = "DeadTime/FPPI-v0"  # its oracle is the cheapest of the three


def _evaluate(capsys, tmp_path, *extra: str) -> dict:
    code = main(["evaluate", "--env", FAST_ENV, "--n", "2", "--seed", "3", "--out", str(tmp_path), "--json", *extra])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    return json.loads(captured.out)


def _per_plant(tmp_path) -> dict[tuple[int, str], dict]:
    with (tmp_path / "per_plant.csv").open() as file:
        return {(int(row["index"]), row["policy"]): row for row in csv.DictReader(file)}


class _Constant:
    """Fixed mode: always action 0."""

    name = "constant"
    env_id = None
    env_kwargs: ClassVar[dict] = {}

    def predict(self, observation, deterministic=True):
        assert deterministic
        return np.zeros(1, dtype=np.float32), None


class _Explorer:
    """Agent mode: runs the first experiment, then commits to the middle of the parameter range."""

    name = "explorer"
    env_id = FAST_ENV
    env_kwargs: ClassVar[dict] = {"experiments": "agent"}

    def __init__(self, size: int) -> None:
        self.size, self.calls = size, 0

    def predict(self, observation, deterministic=True):
        self.calls += 1
        action = np.full(self.size, -1.0, dtype=np.float32)
        action[1 if self.calls % 2 else 0] = 1.0  # experiment 1, then commit (every episode: two steps)
        action[-2:] = 0.0
        return action, None


def _explorer_actions(size: int) -> list[np.ndarray]:
    agent = _Explorer(size)
    return [agent.predict(None)[0], agent.predict(None)[0]]


@pytest.fixture()
def fake_agents(monkeypatch, tmp_path):
    """A stand-in for ``agents.training.policies.load_policy``: ``constant.zip`` and ``explorer.zip``."""
    import gymnasium

    import agents.training.policies
    import envs  # noqa: F401  (registers the environments)

    size = gymnasium.make(FAST_ENV, experiments="agent").action_space.shape[0]
    loaded = []

    def load_policy(path):
        loaded.append(path)
        return _Constant() if "constant" in str(path) else _Explorer(size)

    monkeypatch.setattr(agents.training.policies, "load_policy", load_policy)
    paths = {}
    for name in ("constant", "explorer"):
        paths[name] = tmp_path / f"{name}.zip"
        with zipfile.ZipFile(paths[name], "w") as archive:  # a zip, so that resolve_model_path accepts it
            archive.writestr("data", "{}")
    return SimpleNamespace(paths=paths, loaded=loaded, size=size)


def test_tiny_run_writes_every_output_and_scores_the_agents_like_the_env(capsys, tmp_path, fake_agents):
    import gymnasium

    import envs  # noqa: F401  (registers the environments)

    out = tmp_path / "out"
    agents = f"const={fake_agents.paths['constant']},{fake_agents.paths['explorer']}"
    result = _evaluate(capsys, out, "--policies", f"ppi-kappa1,simc-pi,oracle,{agents}", "--no-benchmark")
    assert fake_agents.loaded == [str(fake_agents.paths["constant"]), str(fake_agents.paths["explorer"])]
    assert (result["env"], result["n"], result["seed"]) == (FAST_ENV, 2, 3)
    names = {p["name"]: p for p in result["policies"]}
    best = result["best_rule"]
    assert best in own_rules("fppi")
    assert {"ppi-kappa1", "simc-pi", "oracle", "const", "explorer", best} == set(names)
    assert names["const"]["role"] == names["explorer"]["role"] == "agent" and names["oracle"]["role"] == "oracle"
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
    assert "| **oracle** | oracle |" in table and "| **const** | agent |" in table and "| **explorer** | agent |" in table

    # The oracle is the optimum of the structure's parameter: no rule of the structure beats it on a plant.
    rows = _per_plant(out)
    for index in range(2):
        oracle = float(rows[(index, "oracle")]["cost"])
        for rule in own_rules("fppi"):
            assert oracle <= float(rows[(index, rule)]["cost"]) + 1e-9, (index, rule)

    # The agents are scored exactly as their episodes in the environment: same plant, seed and actions.
    from envs.systems.plant_sets import plant_set

    fixed, agent_mode = gymnasium.make(FAST_ENV), gymnasium.make(FAST_ENV, experiments="agent")
    for index, plant in enumerate(plant_set("stable", "test", 2)):
        fixed.reset(seed=3 + index, options={"plant": plant})
        _, reward, terminated, _, info = fixed.step(np.zeros(1, dtype=np.float32))
        assert terminated
        assert float(rows[(index, "const")]["cost"]) == pytest.approx(-reward, rel=1e-12)
        # the rules are scored on the same identification as the agent
        assert float(rows[(index, "oracle")]["experiment_time"]) == pytest.approx(info["experiment_time"])
        agent_mode.reset(seed=3 + index, options={"plant": plant})
        first, last = _explorer_actions(fake_agents.size)
        assert agent_mode.step(first)[2] is False
        _, reward, terminated, _, info = agent_mode.step(last)
        assert terminated
        assert float(rows[(index, "explorer")]["cost"]) == pytest.approx(-reward, rel=1e-12)
        assert float(rows[(index, "explorer")]["experiment_time"]) == pytest.approx(info["experiment_time"])


def test_rerun_is_served_from_the_cache_and_workers_agree(capsys, tmp_path, monkeypatch):
    first = _evaluate(capsys, tmp_path, "--policies", "ppi-kappa1,oracle", "--no-benchmark", "--no-plots")
    parallel = _evaluate(capsys, tmp_path / "parallel", "--policies", "ppi-kappa1,oracle", "--no-benchmark", "--no-plots",
                         "--workers", "2")  # fmt: skip
    parallel.pop("wall_time_s")
    assert parallel == {k: v for k, v in first.items() if k != "wall_time_s"}  # same episodes in other processes
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
    assert captured.out.splitlines()[0].startswith(f"{FAST_ENV}: 2 plants, seed 3, paper rule ")
    assert any(line.split()[:2] == ["oracle", "oracle"] for line in captured.out.splitlines())
    assert "results.md" in captured.err


@pytest.mark.parametrize(
    "argv, message",
    [
        (["--env", "DeadTime/Nope-v0", "--policies", "oracle"], "unknown environment 'DeadTime/Nope-v0'"),
        (["--env", FAST_ENV, "--policies", "oracle,no-such-rule"], "unknown rule 'no-such-rule'"),
        (["--env", FAST_ENV, "--policies", "oracle", "--n", "0"], "--n must be an integer >= 1, got 0"),
        (["--env", FAST_ENV, "--policies", "oracle", "--resamples", "0"], "--resamples must be an integer >= 1, got 0"),
        (["--env", FAST_ENV, "--policies", "oracle", "--workers", "0"], "--workers must be an integer >= 1, got 0"),
        (["--env", FAST_ENV, "--policies", "runs/none/model.zip"], "runs/none/model.zip"),
        (["--env", FAST_ENV, "--policies", "a=README.md"], "README.md is not a stable-baselines3 model"),
    ],
    ids=["env", "rule", "n", "resamples", "workers", "agent-missing", "agent-unreadable"],
)
def test_bad_input_is_one_line_and_exit_2(capsys, tmp_path, argv, message):
    code = main(["evaluate", *argv, "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and message in err and "Traceback" not in err


@pytest.mark.slow
@pytest.mark.parametrize("env_id, structure", [("DeadTime/PID-v0", "pid"), ("DeadTime/FPPI-v0", "fppi"), ("DeadTime/MSP-v0", "msp")])
def test_oracle_is_ahead_of_every_rule_of_its_structure_without_violations(capsys, tmp_path, env_id, structure):
    """The oracle's mean cost is below every rule's, without violations, on the random test set and the
    papers' benchmark batch."""
    code = main(["evaluate", "--env", env_id, "--policies", "all-rules,oracle", "--n", "3", "--seed", "0",
                 "--out", str(tmp_path), "--json", "--no-plots"])  # fmt: skip
    captured = capsys.readouterr()
    assert code == 0, captured.err
    result = json.loads(captured.out)
    names = {p["name"]: p for p in result["policies"]}
    oracle = names["oracle"]
    assert oracle["violation_rate"] == 0
    for rule in applicable_rules(structure):
        assert oracle["mean_cost"] < names[rule]["mean_cost"], rule
    rows = _per_plant(tmp_path)
    for index in range(result["plants"]):
        for rule in own_rules(structure):
            assert float(rows[(index, "oracle")]["cost"]) <= float(rows[(index, rule)]["cost"]) + 1e-9, (index, rule)


def test_episode_seeds_do_not_depend_on_n():
    from agents.evaluation.evaluate import BENCHMARK_SEED_OFFSET, _episode_seeds

    small = [("test", "a", None), ("test", "b", None), ("benchmark", "P1", None), ("benchmark", "P2", None)]
    large = small[:2] + [("test", "c", None)] + small[2:]
    assert _episode_seeds(small, 5) == [5, 6, 5 + BENCHMARK_SEED_OFFSET, 6 + BENCHMARK_SEED_OFFSET]
    assert _episode_seeds(large, 5) == [5, 6, 7, 5 + BENCHMARK_SEED_OFFSET, 6 + BENCHMARK_SEED_OFFSET]


# ------------------------------------------------------------------ the user's plants, messages
USER_PLANTS = [{"num": [2.5], "den": [12.0, 1.0], "delay": 4.0}, {"num": [1.0], "den": [2.0, 3.0, 1.0], "delay": 1.0}]


def test_plants_file_is_the_test_set_and_no_plots_says_so(capsys, tmp_path):
    """``--plants FILE`` replaces the random test set (labels ``user-<i>``); the first stderr line
    comes before any plant is drawn or scored (a progress line within a second); ``--no-plots``
    names only what it wrote."""
    plants = tmp_path / "plants.json"
    plants.write_text(json.dumps(USER_PLANTS))
    out = tmp_path / "out"
    code = main(["evaluate", "--env", "DeadTime/PID-v0", "--policies", "simc-pi", "--plants", str(plants),
                 "--no-benchmark", "--no-plots", "--resamples", "50", "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 0, err
    assert err.splitlines()[0] == f"evaluate DeadTime/PID-v0: 2 given plants into {out}"
    assert err.splitlines()[-1] == f"wrote {out / 'results.md'} (and .csv, .json, per_plant.csv)"
    assert {row["plant"] for row in _per_plant(out).values()} == {"user-0", "user-1"}
    assert not list(out.glob("*.png"))
    assert json.loads((out / "results.json").read_text())["n"] == 2  # the plants given, not --n's default


@pytest.mark.parametrize(
    "plants, line",
    [
        ("plants.json", "deadtime evaluate: error: --plants: no such file 'plants.json' (nor is it JSON)"),
        ('{"num": [1]}', "deadtime evaluate: error: --plants must be a non-empty JSON list of plants, got dict"),
        ('[{"num": [1], "den": [1, 0], "delay": 1}]',
         "deadtime evaluate: error: --plants[0] must be a self-regulating plant for this environment"),
        ('[{"num": [1], "den": [10, 1], "delay": 5}, {"num": [1], "den": [-10, 1], "delay": 5}]',
         "deadtime evaluate: error: --plants[1]: plant.den has an unstable pole at s=0.1: the plant must be stable or "
         "integrating"),
        ('[{"num": [1], "den": [10, 1]}]', "deadtime evaluate: error: --plants[0]: plant is missing key 'delay'"),
    ],
    ids=["missing-file", "not-a-list", "wrong-kind", "unstable-second", "missing-key"],
)
def test_bad_plants_are_one_line_and_exit_2(capsys, tmp_path, plants, line):
    code = main(["evaluate", "--env", "DeadTime/PID-v0", "--policies", "simc-pi", "--plants", plants, "--out", str(tmp_path)])
    assert (code, capsys.readouterr().err) == (2, line + "\n")


def test_a_family_of_the_wrong_kind_is_one_line_and_exit_2(capsys, tmp_path):
    code = main(["evaluate", "--env", "DeadTime/PID-v0", "--policies", "simc-pi", "--family", "integrating", "--out", str(tmp_path)])
    assert (code, capsys.readouterr().err) == (2, (
        "deadtime evaluate: error: family 'integrating' draws integrating plants; PIDEnv takes self-regulating plants "
        "(families: stable, fopdt, sopdt, lag-chain, benchmark)\n"))


def test_version(capsys):
    from importlib.metadata import version

    with pytest.raises(SystemExit) as done:
        main(["--version"])
    assert done.value.code == 0 and capsys.readouterr().out == f"deadtime {version('deadtime-gym')}\n"


@pytest.mark.parametrize(
    "regime, message",
    [
        ('{"experiments": "agent"}', "--env-kwargs: 'experiments' is not an evaluation's choice"),
        ('{"noise": 0.1}', "unexpected keyword argument 'noise'"),
        ('{"noise_std": -1}', "noise_std"),
        ('[1]', "--env-kwargs must be a JSON object"),
        ("{noise_std: 0.1}", "--env-kwargs is not valid JSON"),
    ],
    ids=["experiments", "unknown-argument", "bad-value", "not-an-object", "not-json"],
)
def test_bad_env_kwargs_are_one_line_and_exit_2(capsys, tmp_path, regime, message):
    code = main(["evaluate", "--env", FAST_ENV, "--policies", "oracle", "--env-kwargs", regime, "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert code == 2
    assert err.count("\n") == 1 and message in err and "Traceback" not in err, err


def test_env_kwargs_set_the_regime_of_every_policy(capsys, tmp_path, fake_agents):
    """``--env-kwargs``: the rules play the environment made with them, the agents are scored in them
    over their own arguments, the cache keeps regimes apart, and results.json records them."""
    import gymnasium

    regime = {"noise_std": 0.1, "weights": {"production": 0.05}}
    policies = f"fppi-eq34,constant={fake_agents.paths['constant']}"
    plain = _evaluate(capsys, tmp_path / "plain", "--policies", policies, "--no-plots")
    rows = {}
    for name in ("first", "again"):  # the second run shares the first's cache: served from it, equal
        found = _evaluate(capsys, tmp_path / "regime", "--policies", policies, "--no-plots", "--env-kwargs", json.dumps(regime))
        rows[name] = _per_plant(tmp_path / "regime")
    assert found["env_kwargs"] == regime and "env_kwargs" not in plain
    assert rows["first"] == rows["again"]
    default = _per_plant(tmp_path / "plain")
    env = gymnasium.make(FAST_ENV, **regime)
    for index in range(2):
        plant = rows["first"][(index, "constant")]
        assert float(plant["cost"]) != float(default[(index, "constant")]["cost"])
        env.reset(seed=3 + index, options={"plant": _test_plant(index)})
        cost = env.step(np.zeros(1, dtype=np.float32))[4]["cost"]
        assert float(plant["cost"]) == pytest.approx(cost, rel=1e-12)
        env.reset(seed=3 + index, options={"plant": _test_plant(index)})
        rule = episode_of(env).score_controller(_rule_controller(env, "fppi-eq34")).cost
        assert float(rows["first"][(index, "fppi-eq34")]["cost"]) == pytest.approx(rule, rel=1e-12)


def _test_plant(index: int):
    """Test plant ``index`` of the evaluation's set."""
    from envs.systems.plant_sets import plant_set

    return plant_set("stable", "test", index + 1)[index]


def _rule_controller(env, name: str):
    from baselines.rules.registry import RuleInputs, get_rule

    return get_rule(name).design(RuleInputs.from_identification(episode_of(env).identification))
