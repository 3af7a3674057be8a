"""The stable-baselines3 configs of the v3 environments (``configs/v5/``): each resolves and validates in
every structure, in the fixed-mode default regime and, with its plan-mode overrides, in the 10%-noise
production-priced regime, as a protocol's learner resolves it (:meth:`agents.sweeps.config.Trial.train_config`)."""

from __future__ import annotations

from pathlib import Path

import pytest
import yaml

from agents.sweeps.config import Trial
from agents.training.config import TrainConfig, validate

ROOT = Path(__file__).resolve().parents[4]
ENVS = ("DeadTime/PID-v3", "DeadTime/FPPI-v3", "DeadTime/MSP-v3", "DeadTime/PI-v3")
NOISY_PRICED = {"noise_std": 0.1, "weights": {"production": 0.05}}
# The plan mode's overrides, as the configs' header comments and docs/sb3_candidates.md give them.
PLAN = {
    "sac": ["env_kwargs.experiments=plan", "total_timesteps=6000", "hyperparameters.learning_starts=512"],
    "td3": ["env_kwargs.experiments=plan", "total_timesteps=6000", "hyperparameters.learning_starts=512"],
    "ppo": ["env_kwargs.experiments=plan", "vec_env=dummy", "n_envs=1", "hyperparameters.n_steps=256",
            "total_timesteps=60000"],
}


@pytest.mark.parametrize("name", sorted(PLAN))
def test_every_v3_structure_has_an_entry(name: str) -> None:
    data = yaml.safe_load((ROOT / "configs" / "v5" / f"{name}.yaml").read_text())
    assert set(data) == {"default", *ENVS}
    assert data["default"]["algorithm"] == name.upper()


@pytest.mark.parametrize("env_id", ENVS)
@pytest.mark.parametrize("name", sorted(PLAN))
@pytest.mark.parametrize("plan", [False, True], ids=["fixed-default", "plan-noise10-production"])
def test_v5_configs_resolve_and_validate_in_both_regimes(name: str, env_id: str, plan: bool, tmp_path: Path) -> None:
    overrides = PLAN[name] if plan else []
    env_kwargs = NOISY_PRICED if plan else {}
    trial = Trial(name, env_id, 3, str(ROOT / "configs" / "v5" / f"{name}.yaml"), tuple(overrides), env_kwargs)
    config = trial.train_config(tmp_path / "run")
    assert isinstance(config, TrainConfig)
    assert config.algorithm == name.upper() and config.env_id == env_id and config.seed == 3
    assert dict(config.env_kwargs) == {"experiments": "plan" if plan else "fixed", **env_kwargs}
    validate(config)
    assert not (tmp_path / "run").exists()


SB3_REGIMES = """  - name: pid-default
    env: DeadTime/PID-v3
    env_kwargs: {{}}
    fixed: [{{label: sac, config: {config}, overrides: {tiny}}}]
  - name: pid-noise10-production
    env: DeadTime/PID-v3
    env_kwargs: {{noise_std: 0.1, weights: {{production: 0.05}}}}
    plan: [{{label: sac-plan, config: {config}, overrides: {plan}}}]
"""
TINY = ["total_timesteps=300", "hyperparameters.learning_starts=100", "eval_freq=0", "n_eval_episodes=5", "checkpoint_freq=0"]


@pytest.mark.slow
def test_sac_trains_in_a_protocol_in_both_regimes(tmp_path: Path) -> None:
    """SAC of configs/v5/sac.yaml as the fixed candidate of the default regime and, with its plan-mode
    overrides, the plan candidate of the noisy priced one: two seeds each, trained, chosen and tested."""
    from tiny_protocol import write_tiny_protocol

    from agents.protocol.config import load_protocol
    from agents.protocol.run import run_protocol

    regimes = SB3_REGIMES.format(config=ROOT / "configs" / "v5" / "sac.yaml", tiny=TINY, plan=[*PLAN["sac"], *TINY])
    path = write_tiny_protocol(tmp_path, plants=(30, 4, 5), comparisons="[[fixed, best-rule], [plan, best-rule]]",
                               regimes_text=regimes, register=True)
    assert run_protocol(load_protocol(path), tmp_path / "out") == ["pid-default", "pid-noise10-production"]
    runs = sorted((tmp_path / "out" / "work" / "runs").glob("*/s*/run.json"))
    assert [run.parent.name for run in runs] == ["s0", "s1", "s0", "s1"]
    from agents.files.reader import read_json

    assert read_json(tmp_path / "out" / "pid-default" / "selection.json", dict)["chosen"]["fixed"] == "sac"
    assert read_json(tmp_path / "out" / "pid-noise10-production" / "selection.json", dict)["chosen"]["plan"] == "sac-plan"
