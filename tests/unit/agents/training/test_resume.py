"""Resuming ``deadtime train`` gives exactly the uninterrupted run (slow).

A training process is stopped at an arbitrary step by SIGINT (a checkpoint at the next rollout
boundary, then exit 130), SIGTERM, or SIGKILL (no warning: the last periodic checkpoint), resumed
with ``--resume``, and compared with an uninterrupted run of the same config: the policy's
``state_dict`` must be equal tensor for tensor and ``evaluations.json`` equal number for number.
SAC (off-policy, replay buffer; the configured algorithm) and PPO (on-policy: checkpoints only at
rollout boundaries) on Gymnasium's ``Pendulum-v1`` (microsecond steps) with normalized observations
and rewards; SAC once more on ``DeadTime/PID-v0``.  Damaged checkpoint and model files are named in
one line with exit status 2, and a damaged newest checkpoint falls back on the previous one, which
resumes exactly too.
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

from agents.cli import main

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[4]
CONFIG = """
default:
  env_id: Pendulum-v1
  total_timesteps: 1000
  seed: 4
  normalize: true
  normalize_reward: true
  n_eval_episodes: 2
  eval_freq: 128
  checkpoint_freq: 64
  progress_bar: false
  policy_kwargs: {net_arch: [16, 16]}
"""
HYPERPARAMETERS = {
    "SAC": "{learning_starts: 32, buffer_size: 2000, batch_size: 32}",
    "PPO": "{n_steps: 32, batch_size: 32, n_epochs: 2}",
}


def _config(directory: Path, algorithm: str) -> Path:
    path = directory / f"{algorithm.lower()}.yaml"
    path.write_text(CONFIG + f"  algorithm: {algorithm}\n  hyperparameters: {HYPERPARAMETERS[algorithm]}\n")
    return path


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """One uninterrupted run per algorithm, the reference of every resumed run."""
    directory = tmp_path_factory.mktemp("uninterrupted")
    runs = {}
    for algorithm in HYPERPARAMETERS:
        runs[algorithm] = directory / algorithm
        assert main(["train", "--config", str(_config(directory, algorithm)), "--out", str(runs[algorithm])]) == 0
    return runs


def _state_dict(run_dir: Path) -> dict[str, Any]:
    from agents.training.policies import load_policy

    return load_policy(run_dir / "model.zip").model.policy.state_dict()


def _assert_same_run(run_dir: Path, reference: Path) -> None:
    import torch

    resumed, whole = _state_dict(run_dir), _state_dict(reference)
    assert resumed.keys() == whole.keys()
    assert all(torch.equal(resumed[key], whole[key]) for key in whole)
    assert json.loads((run_dir / "evaluations.json").read_text()) == json.loads((reference / "evaluations.json").read_text())


def _train_process(config: Path, run_dir: Path) -> subprocess.Popen[str]:
    environment = {**os.environ, "OPENBLAS_NUM_THREADS": "1"}
    return subprocess.Popen([sys.executable, "-m", "agents.cli", "train", "--config", str(config), "--out", str(run_dir)],
                            cwd=ROOT, env=environment, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def _wait_for_checkpoint(process: subprocess.Popen[str], run_dir: Path, timeout: float = 120.0) -> None:
    deadline = time.monotonic() + timeout
    while not list((run_dir / "checkpoints").glob("checkpoint_*.json")):
        assert process.poll() is None, f"training ended before its first checkpoint: {process.stderr.read()}"
        assert time.monotonic() < deadline, "no checkpoint"
        time.sleep(0.005)


@pytest.mark.parametrize("how", ["SIGINT", "SIGKILL"])
@pytest.mark.parametrize("algorithm", ["SAC", "PPO"])
def test_a_killed_run_resumes_exactly(tmp_path: Path, uninterrupted: dict[str, Path], algorithm: str, how: str) -> None:
    run_dir = tmp_path / "run"
    process = _train_process(_config(tmp_path, algorithm), run_dir)
    _wait_for_checkpoint(process, run_dir)
    os.killpg(process.pid, getattr(signal, how))  # the whole process group, as Ctrl-C in a terminal
    _, stderr = process.communicate(timeout=120)
    if how == "SIGINT":
        assert process.returncode == 130
        last = stderr.strip().splitlines()[-1]
        assert last.startswith("deadtime train: stopped by SIGINT; checkpoint of ")
        assert last.endswith(f"continue exactly with: deadtime train --out {run_dir} --resume")
        assert "Traceback" not in stderr
    else:
        assert process.returncode == -signal.SIGKILL
    from agents.training.checkpoints import find_checkpoint

    checkpoint, note = find_checkpoint(run_dir)  # a kill may fall between checkpoint_N.json and latest.json
    steps = checkpoint.num_timesteps
    assert 0 < steps < 1000 and note is None
    if algorithm == "PPO":
        assert steps % 32 == 0  # a rollout boundary

    assert main(["train", "--out", str(run_dir), "--resume"]) == 0
    assert json.loads((run_dir / "run.json").read_text())["segments"][-1]["from_timesteps"] == steps
    _assert_same_run(run_dir, uninterrupted[algorithm])


class _Stopped(Exception):
    """What stops a run from outside at a step (as Ray Tune stops a sweep's trial)."""


def test_a_run_stopped_before_its_first_checkpoint_starts_again_and_ends_as_the_uninterrupted_run(
        tmp_path: Path, uninterrupted: dict[str, Path], capsys: Any) -> None:
    """Stopped at step 40 of SAC, before its first checkpoint (64): ``run.json`` records the steps and no
    checkpoint, and ``--resume`` starts again from step 0, says so in one line, and ends bit for bit as the
    uninterrupted run.  A run that did write checkpoints and lost them is refused instead
    (tests/unit/agents/test_files.py)."""
    from stable_baselines3.common.callbacks import BaseCallback

    from agents.training.config import load_config
    from agents.training.train import train

    class StopAt(BaseCallback):
        def _on_step(self) -> bool:
            if self.model.num_timesteps >= 40:
                raise _Stopped
            return True

    run_dir = tmp_path / "run"
    config = load_config(_config(tmp_path, "SAC"), overrides=[f"output_dir={run_dir}"])
    with pytest.raises(_Stopped):
        train(config, resume=True, callbacks=[StopAt()])
    record = json.loads((run_dir / "run.json").read_text())
    assert (record["status"], record["num_timesteps"], record["checkpointed"]) == ("interrupted", 40, False)
    assert not list((run_dir / "checkpoints").glob("checkpoint_*.json"))
    capsys.readouterr()
    assert main(["train", "--out", str(run_dir), "--resume"]) == 0
    assert (f"deadtime train: {run_dir} was stopped after 40 steps, before its first checkpoint: it starts again "
            "from step 0") in capsys.readouterr().err
    assert json.loads((run_dir / "run.json").read_text())["segments"][-1]["from_timesteps"] == 0
    _assert_same_run(run_dir, uninterrupted["SAC"])


def test_sigterm_checkpoints_at_the_next_boundary_and_resumes_exactly(tmp_path: Path, uninterrupted: dict[str, Path],
                                                                      capsys: Any) -> None:
    """In process: SIGTERM at step 70 of PPO (rollouts of 32) stops at 96 with a checkpoint there."""
    from stable_baselines3.common.callbacks import BaseCallback

    from agents.training.config import load_config
    from agents.training.train import train

    class Terminate(BaseCallback):
        def _on_step(self) -> bool:
            if self.model.num_timesteps == 70:
                os.kill(os.getpid(), signal.SIGTERM)
            return True

    run_dir = tmp_path / "run"
    config = load_config(_config(tmp_path, "PPO"), overrides=[f"output_dir={run_dir}"])
    result = train(config, callbacks=[Terminate()])
    assert (result.status, result.num_timesteps, result.stopped_by) == ("interrupted", 96, signal.SIGTERM)
    assert "SIGTERM received; writing a checkpoint at the end of the current rollout" in capsys.readouterr().err
    assert json.loads((run_dir / "checkpoints" / "latest.json").read_text())["num_timesteps"] == 96
    assert not (run_dir / "model.zip").exists()
    assert main(["train", "--out", str(run_dir), "--resume"]) == 0
    _assert_same_run(run_dir, uninterrupted["PPO"])


def _interrupted(tmp_path: Path, algorithm: str, at: int = 300) -> Path:
    """A run stopped without warning at step ``at`` (checkpoints at 256 and 192 kept)."""
    from stable_baselines3.common.callbacks import BaseCallback

    from agents.training.config import load_config
    from agents.training.train import train

    class Crash(BaseCallback):
        def _on_step(self) -> bool:
            if self.model.num_timesteps >= at:
                raise KeyboardInterrupt
            return True

    run_dir = tmp_path / "run"
    with pytest.raises(KeyboardInterrupt):
        train(load_config(_config(tmp_path, algorithm), overrides=[f"output_dir={run_dir}"]), callbacks=[Crash()])
    return run_dir


def _error_line(capsys: Any) -> str:
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1, lines
    return lines[0]


def test_a_damaged_latest_checkpoint_falls_back_and_still_resumes_exactly(tmp_path: Path, uninterrupted: dict[str, Path],
                                                                           capsys: Any) -> None:
    run_dir = _interrupted(tmp_path, "SAC")
    buffer = run_dir / "checkpoints" / "replay_buffer_256.pkl"
    buffer.write_bytes(buffer.read_bytes()[:1000])
    capsys.readouterr()
    assert main(["train", "--out", str(run_dir), "--resume"]) == 0
    notes = [line for line in capsys.readouterr().err.splitlines() if line.startswith("deadtime train:")]
    assert len(notes) == 1
    assert notes[0].startswith(f"deadtime train: {buffer} is damaged: 1000 bytes, ")
    assert notes[0].endswith("resuming from checkpoint_192.json (192 steps) instead")
    _assert_same_run(run_dir, uninterrupted["SAC"])


@pytest.mark.parametrize("damage", ["truncated buffer", "garbage index", "missing model"])
def test_damaged_checkpoints_are_named_in_one_line(tmp_path: Path, capsys: Any, damage: str) -> None:
    run_dir = _interrupted(tmp_path, "SAC", at=100)  # a single checkpoint, at 64: nothing to fall back on
    directory = run_dir / "checkpoints"
    if damage == "truncated buffer":
        (directory / "replay_buffer_64.pkl").write_bytes((directory / "replay_buffer_64.pkl").read_bytes()[:500])
        expected = f"{directory / 'replay_buffer_64.pkl'} is damaged: 500 bytes, "
    elif damage == "missing model":
        (directory / "model_64.zip").unlink()
        expected = f"{directory / 'model_64.zip'} is missing (named by latest.json)"
    else:
        (directory / "latest.json").write_text("\x00garbage")
        (directory / "checkpoint_64.json").write_text("{")
        expected = f"{directory / 'latest.json'} is damaged: not valid JSON ("
    capsys.readouterr()
    assert main(["train", "--out", str(run_dir), "--resume"]) == 2
    line = _error_line(capsys)
    assert line.startswith(f"deadtime train: error: {expected}"), line
    assert ".zip.zip" not in line and line.endswith("no intact checkpoint to resume from (start a new run in another --out)")


def test_an_agent_is_loaded_with_its_statistics_or_refused(tmp_path: Path, uninterrupted: dict[str, Path]) -> None:
    """A model copied with its manifest and its run's config but without ``model.normalization.json``, or
    with it truncated."""
    from agents.training.policies import load_policy

    copy = tmp_path / "copy"
    copy.mkdir()
    for name in ("model.zip", "model.manifest.json", "config.yaml"):
        shutil.copy(uninterrupted["SAC"] / name, copy / name)
    with pytest.raises(ValueError, match=f"^{copy / 'model.normalization.json'} is missing: model.zip was trained on normalized"):
        load_policy(copy / "model.zip")
    statistics = (uninterrupted["SAC"] / "model.normalization.json").read_bytes()
    (copy / "model.normalization.json").write_bytes(statistics[: len(statistics) // 2])
    with pytest.raises(ValueError, match=f"^{copy / 'model.normalization.json'} differs from the file recorded in"):
        load_policy(copy / "model.zip")
    (copy / "model.normalization.json").write_bytes(statistics)
    assert load_policy(copy / "model.zip").normalization is not None


def test_sac_on_the_deadtime_environment_resumes_exactly(tmp_path: Path, capsys: Any, sigint_at) -> None:
    """The configured algorithm on DeadTime/PID-v0 (fixed mode): SIGINT at step 13: a rollout is one step, so the checkpoint is at 13."""
    from agents.training.config import load_config
    from agents.training.train import train

    tiny = ["total_timesteps=30", "hyperparameters.learning_starts=8", "hyperparameters.batch_size=8",
            "hyperparameters.gradient_steps=2", "eval_freq=10", "n_eval_episodes=2", "checkpoint_freq=10",
            "progress_bar=false", "policy_kwargs.net_arch=[16, 16]"]
    config_path = ROOT / "configs" / "sac.yaml"
    whole = tmp_path / "whole"
    assert main(["train", "--config", str(config_path), "--out", str(whole), *tiny]) == 0

    run_dir = tmp_path / "part"
    result = train(load_config(config_path, env_id="DeadTime/PID-v0", overrides=[*tiny, f"output_dir={run_dir}"]),
                   callbacks=[sigint_at(13)])
    assert (result.status, result.num_timesteps) == ("interrupted", 13)
    assert main(["train", "--out", str(run_dir), "--resume"]) == 0
    _assert_same_run(run_dir, whole)

    # deadtime evaluate refuses the agent without its statistics, or with them damaged: one line, exit 2
    copy = tmp_path / "copy"
    copy.mkdir()
    for name in ("model.zip", "model.manifest.json", "config.yaml"):
        shutil.copy(whole / name, copy / name)
    evaluate = ["evaluate", "--env", "DeadTime/PID-v0", "--policies", f"agent={copy / 'model.zip'}", "--n", "1",
                "--out", str(tmp_path / "eval"), "--no-benchmark", "--no-plots"]
    capsys.readouterr()
    assert main(evaluate) == 2
    assert _error_line(capsys) == (f"deadtime evaluate: error: {copy / 'model.normalization.json'} is missing: model.zip "
                                   "was trained on normalized observations and cannot be played without its statistics "
                                   "(copy them beside the model as model.normalization.json)")
    (copy / "model.normalization.json").write_bytes((whole / "model.normalization.json").read_bytes()[:300])
    assert main(evaluate) == 2
    assert _error_line(capsys).startswith(f"deadtime evaluate: error: {copy / 'model.normalization.json'} differs from ")
