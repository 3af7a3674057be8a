"""The learned rule through ``deadtime train`` and ``deadtime evaluate``.

A small fit (FPPI-v0, whose oracle is the cheapest: 12 training plants, 4 validation plants, two
model kinds, three margins) runs once, through the command line, with the fixed *test* plant set
made to raise: the fit never draws a test plant.  Then: the training, validation and test plants
it used are disjoint; the margin and kind come from the validation plants; the saved rule plays
exactly as the one that was chosen; an interrupted fit resumes from its cached oracle labels;
damaged files and bad configs get one line naming the file or the key.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from agents.cli import main
from envs.interface import episode_of

ROOT = Path(__file__).resolve().parents[4]
CONFIG = ROOT / "configs" / "learned_rule.yaml"
ENV = "DeadTime/FPPI-v0"
SMALL = ["training_plants=12", "validation_plants=4", "margins=[0.0, 0.1, 0.2]", "models=[ridge-quadratic, boosting]",
         "progress_bar=false"]
CHUNK = 5  # training plants per cached file in these tests (3 files: 5, 5, 2)


def _train(run_dir: Path, *extra: str, resume: bool = False) -> int:
    words = ["train", "--config", str(CONFIG), "--env", ENV, "--out", str(run_dir), *SMALL, *extra]
    return main(words + (["--resume"] if resume else []))


@pytest.fixture(scope="module")
def fitted(tmp_path_factory: pytest.TempPathFactory) -> dict:
    """The small fit, with ``plant_set(..., "test", ...)`` raising and the splits drawn recorded."""
    import envs.systems.plant_sets
    from agents.training import learned_rule

    real = envs.systems.plant_sets.plant_set
    splits: list[str] = []

    def no_test_plants(family, split, n, config=None):
        splits.append(split)
        if split == "test":
            raise AssertionError("the learned rule's fit drew a test plant")
        return real(family, split, n, config)

    run_dir = tmp_path_factory.mktemp("learned") / "run"
    with pytest.MonkeyPatch.context() as patch:
        patch.setattr(envs.systems.plant_sets, "plant_set", no_test_plants)
        patch.setattr(learned_rule, "CHUNK", CHUNK)
        assert _train(run_dir) == 0
    return {"run_dir": run_dir, "splits": splits}


def _records(run_dir: Path) -> list[dict]:
    return [record for path in sorted((run_dir / "dataset").glob("training-*.json")) for record in json.loads(path.read_text())["records"]]


def _key(plant: dict) -> str:
    return json.dumps(plant, sort_keys=True)


def test_the_fit_writes_the_rule_its_manifest_and_its_records(fitted: dict) -> None:
    run_dir = fitted["run_dir"]
    manifest = json.loads((run_dir / "learned_rule.json").read_text())
    assert (manifest["env_id"], manifest["training_plants"], manifest["validation_plants"]) == (ENV, 12, 4)
    assert manifest["kind"] in ("ridge-quadratic", "boosting") and manifest["margin"] in (0.0, 0.1, 0.2)
    assert manifest["direction"] == 1.0 and manifest["action_bounds"] == [-1.0, 1.0]
    costs = manifest["validation"]["mean_cost"]
    assert set(costs) == {"ridge-quadratic", "boosting"} and all(len(c) == 3 for c in costs.values())
    chosen = costs[manifest["kind"]][manifest["validation"]["margins"].index(manifest["margin"])]
    assert chosen == min(min(c) for c in costs.values())
    evaluations = json.loads((run_dir / "evaluations.json").read_text())
    assert evaluations[-1]["mean_cost"] == chosen == manifest["validation"]["chosen"]["mean_cost"]
    assert json.loads((run_dir / "run.json").read_text())["status"] == "finished"
    assert sorted(p.name for p in (run_dir / "dataset").iterdir()) == [f"training-{i:06d}.json" for i in (0, 5, 10)]
    records = _records(run_dir)
    assert [r["index"] for r in records] == list(range(12))
    assert all(-1.0 <= r["action"] <= 1.0 and r["oracle_cost"] > 0 for r in records)


def test_the_fit_draws_validation_plants_and_never_a_test_plant(fitted: dict) -> None:
    assert "validation" in fitted["splits"] and "test" not in fitted["splits"]


def test_training_validation_and_test_plants_are_disjoint(fitted: dict) -> None:
    from envs.systems.plant_sets import benchmark_set, plant_set

    run_dir = fitted["run_dir"]
    training = [_key(r["plant"]) for r in _records(run_dir)]
    validation = [_key(v["plant"]) for v in json.loads((run_dir / "validation_plants.json").read_text())]
    test = [_key(p.to_dict()) for p in plant_set("stable", "test", 200)] + [_key(p.to_dict()) for p in benchmark_set("fppi").values()]
    assert validation == [_key(p.to_dict()) for p in plant_set("stable", "validation", 4)]
    assert len(set(training)) == len(training) == 12
    assert not set(training) & set(validation)
    assert not set(training) & set(test)
    assert not set(validation) & set(test)


def test_each_seed_draws_other_training_plants(fitted: dict, tmp_path: Path) -> None:
    from agents.training.learned_rule import training_seed

    assert training_seed(1, 0) - training_seed(0, 0) >= 1_000_000
    from agents.environments import make_env

    env = make_env(ENV, {"experiments": "fixed"})
    other = []
    for k in range(3):
        env.reset(seed=training_seed(1, k))
        other.append(_key(episode_of(env).plant.to_dict()))
    assert not set(other) & {_key(r["plant"]) for r in _records(fitted["run_dir"])}


def test_the_saved_rule_replays_its_validation_and_round_trips(fitted: dict, tmp_path: Path) -> None:
    from agents.environments import make_env
    from agents.training.learned_rule_policy import load_learned_rule, save_learned_rule
    from agents.training.validation import validate_policy
    from envs.systems.plants import as_plant

    run_dir = fitted["run_dir"]
    policy = load_learned_rule(run_dir)
    assert policy.env_id == ENV and policy.env_kwargs == {"experiments": "fixed"}
    plants = [as_plant(v["plant"]) for v in json.loads((run_dir / "validation_plants.json").read_text())]
    result = validate_policy(lambda o: policy.predict(o)[0], make_env(ENV, policy.env_kwargs), len(plants), plants)
    assert result.mean_cost == json.loads((run_dir / "evaluations.json").read_text())[-1]["mean_cost"]

    observations = np.array([r["observation"] for r in _records(run_dir)], dtype=np.float32)
    save_learned_rule(tmp_path, policy.rule, {"env_id": ENV, "env_kwargs": {}})
    again = load_learned_rule(tmp_path / "learned_rule.json")
    np.testing.assert_array_equal(again.predict(observations)[0], policy.predict(observations)[0])
    for observation in observations[:3]:
        assert np.array_equal(again.predict(observation)[0], policy.rule.predict(observation))


def test_an_interrupted_fit_resumes_from_its_cached_labels(fitted: dict, tmp_path: Path, capsys, monkeypatch) -> None:
    from agents.training import learned_rule
    from agents.training.learned_rule_policy import load_learned_rule

    monkeypatch.setattr(learned_rule, "CHUNK", CHUNK)
    run_dir = tmp_path / "run"
    shutil.copytree(fitted["run_dir"], run_dir)
    for name in ("learned_rule.json", "learned_rule.skops", "run.json", "evaluations.json", "dataset/training-000005.json"):
        (run_dir / name).unlink()  # as if stopped while labelling the second file
    (run_dir / "dataset" / "training-000010.json").write_text("{garbage")
    capsys.readouterr()
    assert main(["train", "--out", str(run_dir), "--resume"]) == 0  # the config from the run itself
    captured = capsys.readouterr()
    assert "12 training plants (7 labelled by the oracle in this session" in captured.out
    assert "training-000010.json is not valid JSON" in captured.err
    assert _records(run_dir) == _records(fitted["run_dir"])
    observations = np.array([r["observation"] for r in _records(run_dir)])
    np.testing.assert_array_equal(load_learned_rule(run_dir).predict(observations)[0],
                                  load_learned_rule(fitted["run_dir"]).predict(observations)[0])
    assert main(["train", "--out", str(run_dir), "--resume"]) == 0
    assert "already holds this learned rule" in capsys.readouterr().out


def test_a_flipped_digit_in_the_label_cache_is_not_trusted(fitted: dict, tmp_path: Path, capsys, monkeypatch) -> None:
    """One digit of a cached action changed (-0.18 to -9.18, outside [-1, 1]): the checksum of its file
    no longer holds, so the file's plants are labelled again and the fit is the uninterrupted one's."""
    from agents.training import learned_rule

    monkeypatch.setattr(learned_rule, "CHUNK", CHUNK)
    run_dir = tmp_path / "run"
    shutil.copytree(fitted["run_dir"], run_dir)
    for name in ("learned_rule.json", "learned_rule.skops", "run.json", "evaluations.json"):
        (run_dir / name).unlink()
    path = run_dir / "dataset" / "training-000000.json"
    data = json.loads(path.read_text())
    data["records"][0]["action"] = -9.18
    path.write_text(json.dumps(data))
    capsys.readouterr()
    assert main(["train", "--out", str(run_dir), "--resume"]) == 0
    assert f"{path} is damaged: its records differ from their SHA-256; labelling its plants again" in capsys.readouterr().err
    assert _records(run_dir) == _records(fitted["run_dir"])


def test_a_violation_target_certifies_the_margin_on_resume_without_new_labels(fitted: dict, tmp_path: Path,
                                                                              capsys, monkeypatch) -> None:
    """The certificate is a choice on the validation plants only: a resume with a target reuses the labels.
    On 4 validation plants, two kinds each tested at 97.5%, 0 violations bound the rate by 60.2% and 1 by
    80.6%: a target of 0.7 certifies a kind's margins from the largest down while they have no violation,
    and 0.01 certifies none and says so."""
    from agents.training import learned_rule

    monkeypatch.setattr(learned_rule, "CHUNK", CHUNK)
    run_dir = tmp_path / "run"
    shutil.copytree(fitted["run_dir"], run_dir)
    capsys.readouterr()
    assert _train(run_dir, "violation_target=0.7", resume=True) == 0
    out = capsys.readouterr().out
    assert "(0 labelled by the oracle in this session" in out
    manifest = json.loads((run_dir / "learned_rule.json").read_text())
    certificate, violations = manifest["certification"], manifest["validation"]["violations"]
    assert certificate["plants"] == 4 and certificate["violation_target"] == 0.7
    for kind, counts in violations.items():  # margins [0, 0.1, 0.2]: certified from the largest while violation-free
        free = next((i for i in range(len(counts)) if all(c == 0 for c in counts[i:])), len(counts))
        assert certificate["certified_margins"][kind] == [0.0, 0.1, 0.2][free:]
    assert certificate["certified"] == any(certificate["certified_margins"].values())
    assert ("certified: violation rate <= 0.7" if certificate["certified"] else "NOT certified") in out
    assert _train(run_dir, "violation_target=0.01", resume=True) == 0
    out = capsys.readouterr().out
    assert "NOT certified: no margin of the list" in out
    assert json.loads((run_dir / "learned_rule.json").read_text())["certification"]["certified"] is False


def test_a_spread_margin_refits_on_resume_and_replays_its_validation(fitted: dict, tmp_path: Path, capsys, monkeypatch) -> None:
    """``margin_scale: spread`` is a choice after the labels: the resume reuses them, fits the two quantile
    trees, records the scale in the manifest, and the saved rule plays its validation cost exactly."""
    from agents.environments import make_env
    from agents.training import learned_rule
    from agents.training.learned_rule_policy import load_learned_rule
    from agents.training.validation import validate_policy
    from envs.systems.plants import as_plant

    monkeypatch.setattr(learned_rule, "CHUNK", CHUNK)
    run_dir = tmp_path / "run"
    shutil.copytree(fitted["run_dir"], run_dir)
    capsys.readouterr()
    assert _train(run_dir, "margin_scale=spread", resume=True) == 0
    assert "(0 labelled by the oracle in this session" in capsys.readouterr().out
    policy = load_learned_rule(run_dir)
    assert policy.manifest["margin_scale"] == "spread" and policy.rule.spread is not None
    observations = np.array([r["observation"] for r in _records(run_dir)])
    assert abs(float(np.mean(policy.rule.spread.scale(observations))) - 1.0) < 1e-12
    plants = [as_plant(v["plant"]) for v in json.loads((run_dir / "validation_plants.json").read_text())]
    result = validate_policy(lambda o: policy.predict(o)[0], make_env(ENV, policy.env_kwargs), len(plants), plants)
    assert result.mean_cost == json.loads((run_dir / "evaluations.json").read_text())[-1]["mean_cost"]
    assert _train(run_dir, "margin_scale=spread", resume=True) == 0
    assert "already holds this learned rule" in capsys.readouterr().out


def test_a_run_directory_is_not_fitted_twice_without_resume(fitted: dict, capsys) -> None:
    assert _train(fitted["run_dir"]) == 2
    assert "already holds a run; pass --resume" in capsys.readouterr().err


def test_resume_with_another_seed_is_refused(fitted: dict, capsys) -> None:
    assert _train(fitted["run_dir"], "seed=1", resume=True) == 2
    assert "the config differs from the saved one in seed" in capsys.readouterr().err


BAD = [
    ("training_plants=5", "training_plants must be an integer >= 10"),
    ("validation_plants=0", "validation_plants must be an integer >= 1"),
    ("margins=[-0.1, 0.1]", "margins must be a non-empty list of numbers >= 0"),
    ("margins=[]", "margins must be a non-empty list of numbers >= 0"),
    ("margins=[0.1, 0.1]", "margins must be a list without repeats"),
    ("models=[linear]", "models must be a non-empty list of model kinds"),
    ("seed=-1", "seed must be an integer >= 0"),
    ("bogus=1", "unknown config key 'bogus'"),
    ("hyperparameters.n_steps=3", "unknown config key 'hyperparameters'"),
    ("env_kwargs.experiments=agent", "env_kwargs: the learned rule needs a one-component action"),
    ("env_kwargs.noise_std=-1", "env_kwargs: refused by DeadTime/FPPI-v0: noise_std must be >= 0"),
    ("env_kwargs.nois_std=1", "unknown env_kwargs key 'nois_std'"),
    ("violation_target=1", "violation_target must be a number strictly between 0 and 1 or null"),
    ("violation_confidence=0", "violation_confidence must be a number strictly between 0 and 1"),
    ("quantile=1.5", "quantile must be a number strictly between 0 and 1"),
    ("margin_scale=wide", "margin_scale must be one of constant, spread"),
    ("labels=grid", "labels must be one of reference, fast"),
    ("margin_scale=spread; quantile=0.5", "quantile must be other than 0.5 with margin_scale: spread"),
]


@pytest.mark.parametrize(("override", "message"), BAD, ids=[o for o, _ in BAD])
def test_bad_config_values_get_one_line_naming_the_key(tmp_path: Path, capsys, override: str, message: str) -> None:
    run_dir = tmp_path / "run"
    assert _train(run_dir, *override.split("; ")) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"deadtime train: error: {message}"), lines
    assert not run_dir.exists()


def test_fast_labels_hold_the_oracle_and_the_feasibility_boundary(fitted: dict, tmp_path: Path) -> None:
    """``labels=fast`` labels the same plants with the fast search: the oracle's action within the oracle's
    tolerance of the reference labels (tests/unit/baselines/test_fast_search.py), and the boundary, the
    least conservative feasible parameter, on the aggressive side of the oracle's."""
    from baselines.fast_search import REFERENCE_ERROR

    run_dir = tmp_path / "run"
    assert _train(run_dir, "labels=fast", "training_plants=10") == 0
    fast, reference = _records(run_dir), _records(fitted["run_dir"])[:10]
    assert [r["seed"] for r in fast] == [r["seed"] for r in reference]
    for new, old in zip(fast, reference):
        assert new["observation"] == old["observation"] and new["plant"] == old["plant"]
        assert new["oracle_cost"] <= old["oracle_cost"] + REFERENCE_ERROR
        assert new["boundary_parameter"] <= new["oracle_parameter"] and -1 <= new["boundary_action"] <= new["action"]
    assert all("boundary_parameter" not in r for r in reference)  # the reference labels are as they were
    assert json.loads((run_dir / "run.json").read_text())["config"]["labels"] == "fast"


def test_a_fit_recorded_before_the_labels_key_is_finished_on_resume(fitted: dict, tmp_path: Path, capsys) -> None:
    """A finished fit whose run.json has no ``labels`` (written before the key) was labelled by the
    reference search: resuming it with the default config fits nothing again."""
    run_dir = tmp_path / "run"
    shutil.copytree(fitted["run_dir"], run_dir)
    record = json.loads((run_dir / "run.json").read_text())
    del record["config"]["labels"]
    (run_dir / "run.json").write_text(json.dumps(record))
    capsys.readouterr()
    assert _train(run_dir, resume=True) == 0
    assert "already holds this learned rule (fit finished)" in capsys.readouterr().out


def test_the_repo_config_resolves_for_each_environment() -> None:
    from agents.training.config import load_config
    from agents.training.learned_rule_config import LearnedRuleConfig

    for env_id in ("DeadTime/PID-v0", "DeadTime/FPPI-v0", "DeadTime/MSP-v0"):
        config = load_config(CONFIG, env_id=env_id)
        assert isinstance(config, LearnedRuleConfig) and config.env_id == env_id
        assert config.run_name == f"learned-rule-{env_id.split('/')[1]}-s0"


def test_evaluate_plays_the_learned_rule_with_its_role(fitted: dict, tmp_path: Path, capsys) -> None:
    from agents.environments import make_env
    from agents.training.learned_rule_policy import load_learned_rule
    from envs.systems.plant_sets import plant_set

    out = tmp_path / "eval"
    code = main(["evaluate", "--env", ENV, "--policies", f"learned={fitted['run_dir']},fppi-eq34", "--n", "2", "--seed", "0",
                 "--no-benchmark", "--no-plots", "--resamples", "50", "--out", str(out), "--json"])
    captured = capsys.readouterr()
    assert code == 0, captured.err
    roles = {p["name"]: p["role"] for p in json.loads(captured.out)["policies"]}
    assert roles["learned"] == "learned rule"
    policy, env = load_learned_rule(fitted["run_dir"]), make_env(ENV, {"experiments": "fixed"})
    costs = []
    for i, plant in enumerate(plant_set("stable", "test", 2)):
        observation, _ = env.reset(seed=i, options={"plant": plant})
        costs.append(env.step(policy.predict(observation)[0])[4]["cost"])
    mean = next(p["mean_cost"] for p in json.loads(captured.out)["policies"] if p["name"] == "learned")
    assert mean == pytest.approx(float(np.mean(costs)), rel=1e-12)


def test_a_damaged_model_file_is_named(fitted: dict, tmp_path: Path, capsys) -> None:
    run_dir = tmp_path / "run"
    shutil.copytree(fitted["run_dir"], run_dir)
    with (run_dir / "learned_rule.skops").open("ab") as file:
        file.write(b"x")
    code = main(["evaluate", "--env", ENV, "--policies", f"learned={run_dir}", "--n", "1", "--no-benchmark", "--no-plots",
                 "--out", str(tmp_path / "eval")])
    lines = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(lines) == 1, lines
    assert f"{run_dir / 'learned_rule.skops'} is damaged or missing" in lines[0]


@pytest.mark.slow
@pytest.mark.parametrize("how, status, word", [("SIGINT", 130, "interrupted"), ("SIGTERM", 143, "terminated")])
def test_sigint_or_sigterm_keeps_the_labels_written_and_resume_labels_only_the_rest(tmp_path: Path, how: str, status: int, word: str) -> None:
    """A fit interrupted by SIGINT (SIGTERM) while labelling exits 130 (143) with one line saying how many
    labels are kept and how to continue; the continued fit labels only the others."""
    import os
    import re
    import signal
    import subprocess
    import sys
    import time

    run_dir = tmp_path / "run"
    environment = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    command = [sys.executable, "-m", "agents.cli", "train", "--config", str(CONFIG), "--env", ENV, "--out", str(run_dir),
               "training_plants=400", "validation_plants=2", "margins=[0.1]", "models=[ridge-quadratic]", "progress_bar=false"]
    process = subprocess.Popen(command, cwd=ROOT, env=environment, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300
    while not (run_dir / "dataset" / "training-000000.json").exists() and time.monotonic() < deadline:
        time.sleep(0.05)
    process.send_signal(getattr(signal, how))
    _, err = process.communicate(timeout=300)
    assert process.returncode == status, err[-2000:]
    found = re.search(rf"{word}; (\d+) labelled training plants are kept in .*; continue with: deadtime train --out "
                      rf"{re.escape(str(run_dir))} --resume", err)
    assert found, err[-2000:]
    kept = int(found.group(1))
    assert 50 <= kept < 400
    done = subprocess.run([sys.executable, "-m", "agents.cli", "train", "--out", str(run_dir), "--resume"], cwd=ROOT,
                          env=environment, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    assert f"400 training plants ({400 - kept} labelled by the oracle in this session" in done.stdout


def _flipped_env(**kwargs):
    """A stand-in for a new environment version: FPPI-v0 with the action coordinate reversed (the
    parameter falls as the action grows) and one more observation entry."""
    from gymnasium import spaces

    from envs.tuning_env import FPPIEnv

    class Flipped(FPPIEnv):
        def __init__(self, **kwargs) -> None:
            super().__init__(**kwargs)
            self.observation_space = spaces.Box(-5.0, 5.0, (self.observation_space.shape[0] + 1,), np.float32)

        def parameter_from_action(self, action: float) -> float:
            return super().parameter_from_action(-float(action))

        def action_from_parameter(self, parameter: float) -> float:
            return -super().action_from_parameter(parameter)

        def observation_and_features(self):
            observation, named = super().observation_and_features()
            return np.append(observation, np.float32(0.5)), named

    return Flipped(**kwargs)


def test_another_action_coordinate_and_observation_are_learned_generically(tmp_path: Path, capsys) -> None:
    """Only the environment's interface is used: a reversed action gets its margin the other way."""
    import gymnasium

    from agents.training.learned_rule_policy import load_learned_rule

    gymnasium.register(id="Test/FlippedFPPI-v0", entry_point=_flipped_env)
    try:
        run_dir = tmp_path / "run"
        code = main(["train", "--config", str(CONFIG), "--env", "Test/FlippedFPPI-v0", "--out", str(run_dir), *SMALL,
                     "training_plants=10", "models=[ridge-quadratic]"])
        assert code == 0, capsys.readouterr().err
        size = gymnasium.make(ENV).observation_space.shape[0] + 1
        manifest = json.loads((run_dir / "learned_rule.json").read_text())
        assert (manifest["direction"], manifest["observation_size"]) == (-1.0, size)
        records = _records(run_dir)
        assert all(r["direction"] == -1.0 and len(r["observation"]) == size and r["observation"][-1] == 0.5 for r in records)
        policy = load_learned_rule(run_dir)
        observations = np.array([r["observation"] for r in records])
        shifted = np.clip(policy.rule.regression(observations) - manifest["margin"], -1, 1).astype(np.float32)
        np.testing.assert_array_equal(policy.predict(observations)[0][:, 0], shifted)
    finally:
        del gymnasium.registry["Test/FlippedFPPI-v0"]
