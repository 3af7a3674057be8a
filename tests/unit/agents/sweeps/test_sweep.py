"""``deadtime sweep`` (:mod:`agents.commands.sweep`): bad input, the smoke sweep end to end, and resume.

The end-to-end tests run ``configs/sweeps/smoke.yaml`` (2 seeds of SAC on PID-v3, 300 steps each) on a
local Ray instance in a subprocess, as a user would; they are slow (about a minute each on 2 cores).
"""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from in_process import run_deadtime as run
from ray_cluster import driver_environment

from agents.sweeps.config import load_sweep

REPO = Path(__file__).resolve().parents[4]
SMOKE = REPO / "configs" / "sweeps" / "smoke.yaml"


def _sweep_file(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "sweep.yaml"
    path.write_text(text)
    return path


GOOD = f"""
trials:
  - config: {REPO / 'configs' / 'sac.yaml'}
    envs: [DeadTime/PID-v0]
    seeds: {{first: 3, count: 2}}
"""


def test_a_sweep_file_resolves_every_trial(tmp_path: Path) -> None:
    sweep = load_sweep(_sweep_file(tmp_path, GOOD))
    assert sweep.name == "sweep"
    assert [t.name for t in sweep.trials()] == ["sac-PID-v0-s3", "sac-PID-v0-s4"]
    config = sweep.trials()[1].train_config(tmp_path / "run")
    assert (config.seed, config.env_id, config.output_dir) == (4, "DeadTime/PID-v0", str(tmp_path / "run"))


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (GOOD + "bogus: 1\n", "unknown key 'bogus' in "),
        (GOOD.replace("seeds: {first: 3, count: 2}", "seeds: []"), "trials[0].seeds must be a non-empty list"),
        (GOOD.replace("count: 2", "count: 0"), "trials[0].seeds.count must be an integer >= 1"),
        (GOOD.replace(str(REPO / "configs" / "sac.yaml"), "configs/sac.yml"), "trials[0].config: no such file"),
        (GOOD.replace(str(REPO / "configs" / "sac.yaml"), "[configs/sac.yaml]"), "trials[0].config: no such file"),
        (GOOD + "evaluation: {n: 0}\n", "evaluation.n must be an integer >= 1"),
        (GOOD + "evaluation: {policis: [oracle]}\n", "unknown key 'policis' in evaluation"),
        (GOOD.replace("envs: [DeadTime/PID-v0]", "envs: [DeadTime/PID-v0]\n    overrides: [hyperparameters.batch_sise=3]"),
         "trial sac-PID-v0-s3:"),
        ("trials: []\n", "trials must be a non-empty list"),
    ],
    ids=["unknown-key", "empty-seeds", "zero-count", "config-typo", "config-not-a-path", "n-zero",
         "unknown-evaluation-key", "bad-override", "no-trials"],
)
def test_bad_sweep_files_get_one_line_and_exit_2(tmp_path: Path, text: str, message: str) -> None:
    path = _sweep_file(tmp_path, text)
    status, out, err = run("sweep", "--config", str(path), "--out", str(tmp_path / "out"))
    assert status == 2
    assert out == ""
    assert err.count("\n") == 1 and message in err, err
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("label", ["..", ".", "", "a/b", "a\\\\b", "-x", " x", "a\\tb", "x" * 201])
def test_a_label_that_is_not_a_plain_file_name_is_one_line_and_exit_2(tmp_path: Path, label: str) -> None:
    """A trial group's label names its trials' run folders (``LABEL-ENV-sSEED``): a plain file name only
    (agents/files/names.py), refused before anything is written."""
    path = _sweep_file(tmp_path, GOOD.replace("  - config:", f'  - label: "{label}"\n    config:'))
    status, out, err = run("sweep", "--config", str(path), "--out", str(tmp_path / "out"))
    assert (status, out) == (2, "")
    assert err.count("\n") == 1 and "trials[0].label must be a plain file name" in err, err
    assert not (tmp_path / "out").exists()


def test_missing_sweep_file(tmp_path: Path) -> None:
    status, _, err = run("sweep", "--config", str(tmp_path / "none.yaml"), "--out", str(tmp_path / "out"))
    assert (status, err.strip()) == (2, f"deadtime sweep: error: --config {tmp_path / 'none.yaml'}: no such file")


@pytest.mark.parametrize("address", ["127.0.0.1:1", "nohost"])
def test_unreachable_address_is_refused_at_once_and_leaves_nothing(tmp_path: Path, address: str) -> None:
    status, _, err = run("sweep", "--config", str(SMOKE), "--out", str(tmp_path / "out"), "--address", address)
    assert status == 2
    assert err.count("\n") == 1 and f"--address {address}:" in err, err
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------------------ end to end
def _sweep_command(out: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "agents.cli", "sweep", "--config", str(SMOKE), "--out", str(out), *extra]


def _agent_costs(path: Path) -> list[str]:
    with path.open(newline="") as file:
        return [row["cost"] for row in csv.DictReader(file) if row["policy"] == "agent"]


@pytest.fixture(scope="module")
def smoke(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("sweep") / "smoke"
    subprocess.run(_sweep_command(out, "--json"), cwd=REPO, env=driver_environment(), check=True, capture_output=True, timeout=900)
    return out


@pytest.mark.slow
def test_smoke_sweep_equals_the_runs_done_one_by_one(smoke: Path, tmp_path: Path) -> None:
    summary = json.loads((smoke / "summary.json").read_text())
    for name in ("summary.md", "summary.csv", "learning_curves.png", "performance_profiles.png"):
        assert (smoke / name).is_file(), name
    sweep = load_sweep(SMOKE)
    trial = sweep.trials()[0]
    run_dir, evaluation = tmp_path / "run", tmp_path / "eval"
    overrides = [*trial.overrides, f"seed={trial.seed}"]
    done = subprocess.run([sys.executable, "-m", "agents.cli", "train", "--config", trial.config_path, "--env", trial.env_id,
                           "--out", str(run_dir), *overrides], cwd=REPO, env=driver_environment(), capture_output=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    e = sweep.evaluation
    done = subprocess.run([sys.executable, "-m", "agents.cli", "evaluate", "--env", trial.env_id, "--policies", f"agent={run_dir}",
                           "--n", str(e.n), "--seed", str(e.seed), "--out", str(evaluation), "--no-plots"],
                          cwd=REPO, env=driver_environment(), capture_output=True, timeout=600)
    assert done.returncode == 0, done.stderr[-2000:]
    one_by_one = _agent_costs(evaluation / "per_plant.csv")
    assert one_by_one == _agent_costs(smoke / "eval" / "PID-v3" / trial.name / "per_plant.csv")
    agent = next(p for p in summary["envs"][0]["policies"] if p["kind"] == "agent")
    assert agent["seeds"] == 2
    assert agent["per_seed_mean_cost"][0] == pytest.approx(sum(map(float, one_by_one)) / len(one_by_one), rel=1e-12)
    assert (run_dir / "evaluations.json").read_text() == (smoke / "runs" / trial.name / "evaluations.json").read_text()


@pytest.mark.slow
@pytest.mark.parametrize("how", [signal.SIGKILL, signal.SIGINT, signal.SIGTERM], ids=["SIGKILL", "Ctrl-C", "SIGTERM"])
def test_a_killed_sweep_resumes_to_the_same_summary(smoke: Path, tmp_path: Path, how: signal.Signals) -> None:
    """SIGKILL of the driver and the local Ray instance it started, Ctrl-C (SIGINT to the process
    group, as a terminal sends it), or SIGTERM to the driver (as a scheduler ends a job): exit status
    130 or 143, one line saying how to resume, no summary."""
    out = tmp_path / "killed"
    driver = subprocess.Popen(_sweep_command(out), cwd=REPO, env=driver_environment(), stdout=subprocess.DEVNULL,
                              stderr=subprocess.PIPE, text=True, start_new_session=True)
    deadline = time.monotonic() + 600
    while not list(out.glob("runs/*/checkpoints/latest.json")) and time.monotonic() < deadline and driver.poll() is None:
        time.sleep(0.2)
    if how == signal.SIGTERM:
        os.kill(driver.pid, how)
    else:
        os.killpg(driver.pid, how)
    _, err = driver.communicate(timeout=300)
    if how != signal.SIGKILL:
        assert driver.returncode == 128 + how, err[-2000:]
        assert err.rstrip().splitlines()[-1] == (
            f"deadtime sweep: {'interrupted' if how == signal.SIGINT else 'terminated'}; no summary written, the trials' "
            f"checkpoints and the evaluations' caches are kept; continue with: deadtime sweep --config {SMOKE} --out {out} --resume")
        assert "Tuner.restore" not in err and "Traceback" not in err
    assert not any(out.glob("summary.*"))
    (session,) = json.loads((out / "sessions.json").read_text())  # on record, with the time it spent
    assert session["status"] == ("running" if how == signal.SIGKILL else "interrupted") and session["wall_time_s"] >= 0
    done = subprocess.run(_sweep_command(out, "--resume", "--json"), cwd=REPO, env=driver_environment(), capture_output=True,
                          text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    assert not json.loads(done.stdout)["failed"]  # a trial stopped before its first checkpoint starts again
    sessions = json.loads(done.stdout)["sessions"]
    assert [s["status"] for s in sessions] == ["interrupted", "finished"]
    assert json.loads(done.stdout)["wall_time_s"] == pytest.approx(sum(s["wall_time_s"] for s in sessions), abs=0.05)
    assert "Failed to fetch metrics" not in done.stderr  # trials not started are not failures
    expected, resumed = (json.loads((d / "summary.json").read_text()) for d in (smoke, out))
    assert resumed["envs"] == expected["envs"]
    assert resumed["learning_curves"] == expected["learning_curves"]


def test_without_ray_the_command_names_the_extra(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError, as where it is not installed
    monkeypatch.delitem(sys.modules, "agents.sweeps.run", raising=False)
    status, _, err = run("sweep", "--config", str(SMOKE), "--out", str(tmp_path / "out"))
    assert (status, err) == (2, "deadtime sweep: error: deadtime sweep needs Ray Tune: pip install -e '.[sweep]'\n")
    assert not (tmp_path / "out").exists()


@pytest.mark.slow
def test_a_failing_trial_is_reported_by_name_and_the_others_summarized(tmp_path: Path) -> None:
    """A trial that fails when it runs (here its validation plant set, which only the trial builds) fails
    after its retry; the sweep goes on and summarizes the trial that worked.  (An environment argument
    the environment refuses is refused before any trial starts: tests/unit/agents/test_hostile_input.py.)"""
    quick = ("[total_timesteps=200, eval_freq=100, n_eval_episodes=4, checkpoint_freq=100, "
             "hyperparameters.learning_starts=100, hyperparameters.gradient_steps=1")
    path = _sweep_file(tmp_path, f"""
trials:
  - {{label: bad, config: {REPO / 'configs' / 'sac.yaml'}, envs: [DeadTime/PID-v0], seeds: [0],
     overrides: {quick}, eval_family=nonsense]}}
  - {{label: good, config: {REPO / 'configs' / 'sac.yaml'}, envs: [DeadTime/PID-v0], seeds: [0], overrides: {quick}]}}
evaluation: {{policies: [all-rules, oracle], n: 3, resamples: 100}}
failure: {{max_failures: 1}}
""")
    done = subprocess.run([sys.executable, "-m", "agents.cli", "sweep", "--config", str(path), "--out", str(tmp_path / "out"),
                           "--json"], cwd=REPO, env=driver_environment(), capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    summary = json.loads(done.stdout)
    assert list(summary["failed"]) == ["bad-PID-v0-s0"]
    assert summary["failed"]["bad-PID-v0-s0"].startswith("ValueError: eval_family: refused by the validation plant set: "
                                                         "unknown plant family 'nonsense'")
    assert [p["name"] for p in summary["envs"][0]["policies"] if p["kind"] == "agent"] == ["good"]
    assert "trial bad-PID-v0-s0 failed: ValueError: eval_family: refused" in done.stderr


@pytest.mark.parametrize("path", sorted((REPO / "configs" / "sweeps").glob("*.yaml")), ids=lambda p: p.name)
def test_every_committed_sweep_file_is_valid(path: Path) -> None:
    """The studies behind docs/results.md and docs/results_history.md load and validate (each training config resolved, with its seeds)."""
    sweep = load_sweep(path)
    assert sweep.trials()


@pytest.mark.slow
def test_a_sweep_of_learned_rules_fits_one_per_seed_and_summarizes_them_as_learned_rules(tmp_path: Path) -> None:
    """``configs/learned_rule.yaml`` as a trial group: each seed fits its own rule on its own training
    plants, the evaluations play them, and the summary's role says what they are; a procedure of the
    evaluation is a row of its own kind, not a rule."""
    path = _sweep_file(tmp_path, f"""
trials:
  - label: learned
    config: {REPO / 'configs' / 'learned_rule.yaml'}
    overrides: [training_plants=12, validation_plants=3, "margins=[0.0, 0.2]", "models=[ridge-quadratic]",
                progress_bar=false]
    envs: [DeadTime/FPPI-v0]
    seeds: [0, 1]
evaluation: {{policies: [fppi-eq34, plan-1-1, oracle], n: 2, resamples: 100}}
""")
    done = subprocess.run([sys.executable, "-m", "agents.cli", "sweep", "--config", str(path), "--out", str(tmp_path / "out"),
                           "--json"], cwd=REPO, env=driver_environment(), capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    summary = json.loads(done.stdout)
    assert summary["failed"] == {}
    procedure = next(p for p in summary["envs"][0]["policies"] if p["name"] == "plan-1-1")
    assert procedure["kind"] == "procedure" and summary["envs"][0]["best_rule"] == "fppi-eq34"  # a procedure is no rule
    learned = next(p for p in summary["envs"][0]["policies"] if p["name"] == "learned")
    assert (learned["kind"], learned["seeds"], len(learned["per_seed_mean_cost"])) == ("learned-rule", 2, 2)
    assert "| learned | learned rule | 2 |" in (tmp_path / "out" / "summary.md").read_text()
    plants = [{json.dumps(record["plant"], sort_keys=True)
               for chunk in sorted((tmp_path / "out" / "runs" / f"learned-FPPI-v0-s{seed}" / "dataset").glob("*.json"))
               for record in json.loads(chunk.read_text())["records"]} for seed in (0, 1)]
    assert len(plants[0]) == len(plants[1]) == 12 and not plants[0] & plants[1]


def test_a_sweeps_env_kwargs_go_to_every_trial_over_its_config(tmp_path: Path) -> None:
    """``env_kwargs`` of a sweep file, the study's regime: merged over each trial config's own (the
    mode stays the config's), and kept by the trial's plain form (Ray's trial config)."""
    from agents.sweeps.config import Trial

    text = GOOD.replace("trials:", "env_kwargs: {noise_std: 0.1, weights: {production: 0.0}}\ntrials:")
    sweep = load_sweep(_sweep_file(tmp_path, text))
    assert sweep.env_kwargs == {"noise_std": 0.1, "weights": {"production": 0.0}}
    trial = sweep.trials()[0]
    config = trial.train_config(tmp_path / "run")
    assert dict(config.env_kwargs) == {"experiments": "fixed", "noise_std": 0.1, "weights": {"production": 0.0}}
    assert Trial.from_dict(trial.to_dict()) == trial


@pytest.mark.parametrize("value", ["{experiments: agent}", "[1]", "{noise: 0.1}"], ids=["mode", "not-a-mapping", "unknown"])
def test_bad_env_kwargs_of_a_sweep_are_one_line_and_exit_2(tmp_path: Path, value: str) -> None:
    path = _sweep_file(tmp_path, GOOD.replace("trials:", f"env_kwargs: {value}\ntrials:"))
    status, out, err = run("sweep", "--config", str(path), "--out", str(tmp_path / "out"))
    assert status == 2 and out == ""
    assert err.count("\n") == 1 and ("env_kwargs" in err or "noise" in err), err
    assert not (tmp_path / "out").exists()


# ------------------------------------------------------------------------------ a real cluster
@pytest.mark.slow
def test_a_sweep_on_a_ray_start_cluster_by_address_equals_the_local_run(smoke: Path, tmp_path: Path,
                                                                       ray_start_cluster: tuple[str, dict[str, str]]) -> None:
    """``ray start`` turns on token authentication; ``--address`` works with it, and the cluster gives
    the local run's summary."""
    address, environment = ray_start_cluster
    out = tmp_path / "on-cluster"
    done = subprocess.run(_sweep_command(out, "--address", address, "--json"), cwd=REPO, env=environment,
                          capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, done.stderr[-2000:]
    assert "InvalidAuthToken" not in done.stderr and "gcs_client" not in done.stderr
    expected, remote = (json.loads((d / "summary.json").read_text()) for d in (smoke, out))
    assert remote["envs"] == expected["envs"]
    assert remote["learning_curves"] == expected["learning_curves"]
    assert (out / "summary.csv").read_text() == (smoke / "summary.csv").read_text()
    assert remote["sessions"][0]["cpus"] == 2


@pytest.mark.slow
def test_a_committed_sweep_is_compressed_and_recomputes_its_summary(smoke: Path, tmp_path: Path) -> None:
    """``deadtime study commit``: the copy keeps no model and no sweep file, its tables are compressed, and its
    summary is the sweep's and is recomputed from the copy, byte for byte."""
    from agents.compressed import read_json, read_text
    from agents.sweeps.summary import summary_texts

    target = tmp_path / "results" / "smoke"
    status, _, err = run("study", "commit", str(smoke), str(target))
    assert status == 0, err
    files = {path.relative_to(target).as_posix() for path in target.rglob("*") if path.is_file()}
    assert not any(name.endswith((".zip", ".pkl", ".yaml", ".csv")) for name in files), files
    assert {"summary.md", "summary.csv.gz", "summary.json.gz", "sessions.json"} <= files
    assert read_text(target / "summary.md") == (smoke / "summary.md").read_text()
    sweep = load_sweep(SMOKE)
    committed = read_json(target / "summary.json")
    texts = summary_texts(sweep, sweep.trials(), target, committed["failed"], read_json(target / "sessions.json"))
    assert texts == {name: read_text(target / name) for name in texts}
