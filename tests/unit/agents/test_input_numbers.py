"""Numbers as researchers write them (``1e-3``, ``3E4``) in every numeric field, and the documented upper
bounds (:mod:`agents.limits`) on every count that sizes a run: one line naming the field, exit 2."""

from __future__ import annotations

import io
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from agents.cli import main
from agents.training.config import load_config

REPO = Path(__file__).resolve().parents[3]
SAC = REPO / "configs" / "sac.yaml"


def run(*args: str) -> tuple[int, str]:
    err = io.StringIO()
    with redirect_stdout(io.StringIO()), redirect_stderr(err):
        status = main(list(args))
    return status, err.getvalue()


def test_exponent_numbers_in_every_field() -> None:
    config = load_config(SAC, env_id="DeadTime/PID-v3", overrides=[
        "env_kwargs.noise_std=1e-3", "policy_kwargs.net_arch=[1e2, 64]", "hyperparameters.learning_rate=3E-4",
        "hyperparameters.batch_size=1.28e2", "hyperparameters.buffer_size=1e5", "total_timesteps=3E4"])
    assert config.env_kwargs["noise_std"] == 1e-3 and isinstance(config.env_kwargs["noise_std"], float)
    assert list(config.policy_kwargs["net_arch"]) == [100, 64] and all(type(v) is int for v in config.policy_kwargs["net_arch"])
    assert config.hyperparameters["learning_rate"] == 3e-4
    assert (config.hyperparameters["batch_size"], config.hyperparameters["buffer_size"], config.total_timesteps) == (128, 100_000, 30_000)
    assert all(type(v) is int for v in (config.hyperparameters["batch_size"], config.hyperparameters["buffer_size"],
                                        config.total_timesteps))


@pytest.mark.parametrize(("args", "line"), [
    (("train", "--config", str(SAC), "--env", "DeadTime/PID-v3", "total_timesteps=1e15"),
     "deadtime train: error: total_timesteps must be at most 100000000 (the documented limit, agents/limits.py), "
     "got 1000000000000000"),
    (("evaluate", "--env", "DeadTime/PID-v3", "--policies", "oracle", "--workers", "1024"),
     "deadtime evaluate: error: --workers must be at most 64 (the documented limit, agents/limits.py), got 1024"),
    (("bench", "--pade-order", "1000"),
     "deadtime bench: error: --pade-order must be at most 14 (the documented limit, agents/limits.py), got 1000"),
    (("bench", "--reference-samples", "1000000000"),
     "deadtime bench: error: --reference-samples must be at most 10000 (the documented limit, agents/limits.py), "
     "got 1000000000"),
], ids=["total_timesteps", "workers", "pade-order", "reference-samples"])
def test_a_count_above_its_documented_limit_is_one_line(tmp_path: Path, args: tuple[str, ...], line: str) -> None:
    out = tmp_path / "out"
    status, err = run(*args, *(["--out", str(out)] if args[0] in ("train", "evaluate") else []))
    assert (status, err) == (2, line + "\n")
    assert not out.exists()
