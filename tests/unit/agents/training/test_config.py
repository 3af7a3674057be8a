"""Training configs: the zoo-style files, precedence, overrides, and unknown keys named."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from agents.training.config import (
    apply_overrides,
    load_config,
    merge,
    parse_override,
    validate,
)

ROOT = Path(__file__).resolve().parents[4]
ZOO = """
default:
  algorithm: PPO
  env_id: Pendulum-v1
  total_timesteps: 1000
  seed: 1
  hyperparameters: {n_steps: 64, batch_size: 32}
  policy_kwargs: {net_arch: [16, 16]}
  env_kwargs: {g: 9.0}
Pendulum-v1:
  total_timesteps: 2000
  hyperparameters: {n_steps: 128}
MountainCarContinuous-v0:
  seed: 7
"""


@pytest.fixture
def zoo(tmp_path: Path) -> Path:
    path = tmp_path / "ppo.yaml"
    path.write_text(ZOO)
    return path


def test_default_then_env_entry_then_overrides(zoo: Path) -> None:
    config = load_config(zoo)
    assert config.algorithm == "PPO" and config.env_id == "Pendulum-v1"
    assert config.total_timesteps == 2000  # the env entry over the default
    assert dict(config.hyperparameters) == {"n_steps": 128, "batch_size": 32}  # mappings merge key by key
    assert dict(config.env_kwargs) == {"g": 9.0}
    config = load_config(zoo, overrides=["total_timesteps=3000", "hyperparameters.batch_size=16",
                                         "policy_kwargs.net_arch=[8, 8]", "env_kwargs.g=null"])
    assert config.total_timesteps == 3000
    assert dict(config.hyperparameters) == {"n_steps": 128, "batch_size": 16}
    assert config.policy_kwargs["net_arch"] == [8, 8]
    assert config.env_kwargs["g"] is None


def test_env_selects_its_entry_or_the_default(zoo: Path) -> None:
    config = load_config(zoo, env_id="MountainCarContinuous-v0")
    assert (config.env_id, config.seed, config.total_timesteps) == ("MountainCarContinuous-v0", 7, 1000)
    config = load_config(zoo, env_id="CartPole-v1")  # no entry: the default alone
    assert (config.env_id, config.seed) == ("CartPole-v1", 1)
    assert load_config(zoo, overrides=["env_id=MountainCarContinuous-v0"]).seed == 7


def test_algorithm_from_the_file_name(tmp_path: Path) -> None:
    path = tmp_path / "sac.yaml"
    path.write_text("default: {env_id: Pendulum-v1, total_timesteps: 10}\n")
    assert load_config(path).algorithm == "SAC"


@pytest.mark.parametrize(
    ("text", "overrides", "named"),
    [
        ("default: {algorithm: PPO, env_id: Pendulum-v1, total_timesteps: 10, learning_rate: 0.1}", [], "learning_rate"),
        ("default: {algorithm: PPO, env_id: Pendulum-v1, total_timesteps: 10}\nPendulum-v1: {n_step: 3}", [], "n_step"),
        ("default: {algorithm: PPO, env_id: Pendulum-v1, total_timesteps: 10}", ["sed=3"], "sed"),
        ("default: {algorithm: PPO, env_id: Pendulum-v1, total_timesteps: 10}", ["seed.x=3"], "seed"),
        ("default: {algorithm: PPO, env_id: Pendulum-v1}", [], "total_timesteps"),
        ("default: {algorithm: DQN, env_id: Pendulum-v1, total_timesteps: 10}", [], "DQN"),
        ("default: {algorithm: PPO, env_id: Pendulum-v1, total_timesteps: 0}", [], "total_timesteps"),
        ("default: {algorithm: PPO, env_id: Pendulum-v1, total_timesteps: 10, vec_env: threads}", [], "vec_env"),
        ("default: {algorithm: PPO, env_id: Pendulum-v1, total_timesteps: 10, seed: true}", [], "seed"),
        ("default: {algorithm: PPO, env_id: Pendulum-v1, total_timesteps: 10, hyperparameters: 3}", [], "hyperparameters"),
        ("default: {algorithm: PPO, total_timesteps: 10}", [], "env"),
        ("default: {algorithm: PPO, env_id: Pendulum-v1, total_timesteps: 10}", ["seed"], "key=value"),
    ],
)
def test_bad_configs_name_the_key(tmp_path: Path, text: str, overrides: list[str], named: str) -> None:
    path = tmp_path / "config.yaml"
    path.write_text(text)
    with pytest.raises(ValueError, match=named):
        load_config(path, overrides=overrides)


def test_override_values_are_yaml() -> None:
    assert parse_override("a.b=[1, 2]") == (["a", "b"], [1, 2])
    assert parse_override("x=1.0e-3") == (["x"], 1e-3)
    assert parse_override("x=true") == (["x"], True)
    assert parse_override("x=") == (["x"], None)
    assert parse_override("x=relu") == (["x"], "relu")
    assert merge({"a": {"b": 1, "c": 2}, "d": [1]}, {"a": {"b": 3}, "d": [2]}) == {"a": {"b": 3, "c": 2}, "d": [2]}
    assert apply_overrides({"hyperparameters": {"n_steps": 1}}, ["hyperparameters.gamma=0.5"]) == {
        "hyperparameters": {"n_steps": 1, "gamma": 0.5}}


def test_integral_floats_are_integers_and_config_is_frozen(zoo: Path) -> None:
    config = load_config(zoo, overrides=["total_timesteps=2.0e3"])
    assert config.total_timesteps == 2000 and isinstance(config.total_timesteps, int)
    with pytest.raises(AttributeError):
        config.seed = 3  # type: ignore[misc]
    with pytest.raises(TypeError):
        config.hyperparameters["n_steps"] = 3  # type: ignore[index]


def test_resolved_config_round_trips(zoo: Path, tmp_path: Path) -> None:
    config = load_config(zoo, overrides=["hyperparameters.gamma=0.5"])
    saved = tmp_path / "run" / "config.yaml"
    saved.parent.mkdir()
    saved.write_text("# a comment\n" + yaml.safe_dump(config.to_dict(), sort_keys=False))
    assert load_config(saved) == config
    assert load_config(saved, overrides=["total_timesteps=5"]).total_timesteps == 5


@pytest.mark.parametrize(
    ("override", "named"),
    [
        ("hyperparameters.n_step=3", "n_step"),
        ("hyperparameters.seed=3", "seed"),
        ("hyperparameters.buffer_size=100", "buffer_size"),  # SAC's, not PPO's
        ("policy_kwargs.net_arc=[3]", "net_arc"),
        ("env_kwargs.gravity=3.0", "gravity"),
        ("policy=CnnPolicyX", "CnnPolicyX"),
        ("env_id=NoSuchEnv-v0", "NoSuchEnv-v0"),
    ],
)
def test_validate_checks_the_constructors(zoo: Path, override: str, named: str) -> None:
    with pytest.raises(ValueError, match=named):
        validate(load_config(zoo, overrides=[override]))


ACCEPTED = [
    (["hyperparameters.gamma=0.5", "policy_kwargs.activation_fn=tanh"],
     lambda model: model.gamma == 0.5 and model.policy.activation_fn.__name__ == "Tanh"),
    (["algorithm=SAC", "hyperparameters={buffer_size: 100}"],
     lambda model: type(model).__name__ == "SAC" and model.buffer_size == 100 and model.replay_buffer.buffer_size == 100),
]


@pytest.mark.parametrize(("overrides", "taken"), ACCEPTED, ids=[" ".join(o) for o, _ in ACCEPTED])
def test_validate_accepts_known_keys_and_the_model_takes_them(zoo: Path, overrides: list[str], taken) -> None:
    """What ``validate`` accepts, the constructor accepts too, and the value reaches the model."""
    from agents.training.train import make_vec_env, new_model

    config = load_config(zoo, overrides=overrides)
    validate(config)  # raises on a refused key
    venv = make_vec_env(config)
    try:
        assert taken(new_model(config, venv))
    finally:
        venv.close()


def _deadtime_registered() -> bool:
    import gymnasium

    import envs  # noqa: F401

    return "DeadTime/PID-v0" in gymnasium.registry


@pytest.mark.parametrize("name", ["ppo", "sac", "td3", "a2c"])
def test_repo_configs_load_and_validate(name: str) -> None:
    path = ROOT / "configs" / f"{name}.yaml"
    data = yaml.safe_load(path.read_text())
    env_ids = [key for key in data if key != "default"]
    assert {"DeadTime/PID-v0", "DeadTime/FPPI-v0", "DeadTime/MSP-v0"} <= set(env_ids)
    for env_id in env_ids:
        config = load_config(path, env_id=env_id)
        assert config.algorithm == name.upper()
        if not _deadtime_registered():  # the hyperparameters at least, on a stand-in environment
            validate(dataclasses.replace(config, env_id="Pendulum-v1", env_kwargs={}))
            pytest.skip("the DeadTime environments are not registered yet")
        validate(config)


def test_cli_parsing_does_not_import_torch() -> None:
    code = ("import sys, agents.cli; agents.cli._parser(); "
            "assert 'torch' not in sys.modules and 'stable_baselines3' not in sys.modules, 'heavy import'")
    subprocess.run([sys.executable, "-c", code], cwd=ROOT, check=True, env={"PYTHONPATH": str(ROOT), "PATH": ""})


def test_exponent_numbers_that_yaml_reads_as_strings(zoo: Path) -> None:
    config = load_config(zoo, overrides=["total_timesteps=1e4", "hyperparameters.learning_rate=3e-4",
                                         "hyperparameters.ent_coef=auto"])
    assert config.total_timesteps == 10_000
    assert config.hyperparameters["learning_rate"] == 3e-4 and config.hyperparameters["ent_coef"] == "auto"


# ----------------------------------------------------------------------------------- values refused before any write
BAD_VALUES = [
    ("PPO", "env_kwargs.experiments=bogus", "env_kwargs: refused by DeadTime/PID-v0: experiments must be one of"),
    ("PPO", "hyperparameters.learning_rate=fast", "hyperparameters.learning_rate must be a positive number"),
    ("PPO", "hyperparameters.learning_rate=-1", "hyperparameters.learning_rate must be a positive number"),
    ("PPO", "hyperparameters.batch_size=0", "hyperparameters.batch_size must be an integer >= 1, got 0"),
    ("PPO", "hyperparameters.batch_size=1", "hyperparameters.batch_size must be > 1 for PPO with normalize_advantage"),
    ("PPO", "hyperparameters.n_steps=1", "hyperparameters.n_steps * n_envs must be > 1 for PPO"),
    ("PPO", "hyperparameters.gamma=1.5", "hyperparameters.gamma must be a number in [0, 1], got 1.5"),
    ("PPO", "hyperparameters.clip_range=0", "hyperparameters.clip_range must be a positive number"),
    ("PPO", "hyperparameters.n_epochs=2.5", "hyperparameters.n_epochs must be an integer >= 1"),
    ("SAC", "hyperparameters.buffer_size=0", "hyperparameters.buffer_size must be an integer >= 1"),
    ("SAC", "hyperparameters.train_freq=[1, hour]", "hyperparameters.train_freq must be an integer >= 1 or [n >= 1, step | episode]"),
    ("SAC", "hyperparameters.ent_coef=auto_0", "hyperparameters.ent_coef must be a positive number, auto or auto_<x > 0>"),
    ("SAC", "hyperparameters.tau=0", "hyperparameters.tau must be a number in (0, 1]"),
    ("SAC", "hyperparameters.gradient_steps=0", "hyperparameters.gradient_steps must be an integer >= 1, or -1"),
    ("SAC", "hyperparameters.replay_buffer_class=x", "hyperparameters.replay_buffer_class is not allowed here"),
    ("SAC", "policy_kwargs.net_arch=[64, -1]", "policy_kwargs.net_arch must be a list of layer sizes >= 1"),
    ("SAC", "eval_family=nonsense", "eval_family: refused by the validation plant set: unknown plant family 'nonsense'"),
]


@pytest.mark.parametrize(("algorithm", "override", "message"), BAD_VALUES, ids=[o for _, o, _ in BAD_VALUES])
def test_bad_values_are_named_and_leave_no_run_directory(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                         algorithm: str, override: str, message: str) -> None:
    """One line naming the key, exit 2, no run directory: the corrected command then runs as a new run."""
    from agents.cli import main

    run_dir = tmp_path / "run"
    config = ROOT / "configs" / f"{algorithm.lower()}.yaml"
    assert main(["train", "--config", str(config), "--out", str(run_dir), override]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(f"deadtime train: error: {message}"), lines
    assert not run_dir.exists()


def test_a_linear_learning_rate_schedule_is_taken() -> None:
    from stable_baselines3.common.utils import LinearSchedule

    from agents.training.hyperparameters import check_hyperparameters, schedule

    check_hyperparameters("SAC", {"learning_rate": {"linear": [1e-3, 0.0]}}, 1)
    rate = schedule({"linear": [1e-3, 0.0]})
    assert isinstance(rate, LinearSchedule) and rate(1.0) == 1e-3 and rate(0.0) == 0.0
    with pytest.raises(ValueError, match="learning_rate"):
        check_hyperparameters("SAC", {"learning_rate": {"linear": [0.0, 1.0]}}, 1)
    with pytest.raises(ValueError, match="train_freq in episodes needs n_envs = 1"):
        check_hyperparameters("TD3", {"train_freq": [1, "episode"]}, 2)
