"""``vec_env: native``: stable-baselines3's ``VecEnv`` over the native vector environment.

* The adapter gives what SB3's ``DummyVecEnv`` of ``Monitor``-wrapped single environments gives
  for the same seeds and actions: observations, rewards, dones, the final cost,
  ``terminal_observation`` and the ``episode`` record (bit for bit; ``t`` aside).
* A short PPO ``learn`` with ``n_envs: 4`` native; ``deadtime train`` with it, interrupted and
  resumed, gives exactly the uninterrupted agent (the slots' snapshots in the checkpoints).
* The config: ``vec_env: native`` with the agent mode, or with an id without a native vector
  environment, is refused in one line naming ``vec_env``.
"""

from __future__ import annotations

import functools
from pathlib import Path

import numpy as np
import pytest

from agents.cli import main
from agents.environments import make_env
from agents.training.config import load_config, validate
from agents.training.native_vec_env import NativeVecEnv, make_native_vec_env

ROOT = Path(__file__).resolve().parents[4]
PPO = ROOT / "configs" / "ppo.yaml"


def _monitored(env_id: str):
    from stable_baselines3.common.monitor import Monitor

    return Monitor(make_env(env_id))


@pytest.mark.parametrize("env_id", ["DeadTime/PID-v0", "DeadTime/MSP-v1"])
def test_adapter_steps_like_a_dummy_vec_env_of_single_envs(env_id):
    from stable_baselines3.common.vec_env import DummyVecEnv

    native = make_native_vec_env(env_id, 3)
    dummy = DummyVecEnv([functools.partial(_monitored, env_id)] * 3)
    assert isinstance(native, NativeVecEnv) and native.observation_space == dummy.observation_space
    for venv in (native, dummy):
        venv.seed(7)
    np.testing.assert_array_equal(native.reset(), dummy.reset())
    actions = np.random.default_rng(1).uniform(-1, 1, size=(4, 3, 1)).astype(np.float32)
    for action in actions:
        ours, theirs = native.step(action), dummy.step(action)
        for a, b in zip(ours[:3], theirs[:3]):
            np.testing.assert_array_equal(a, b)
        for mine, other in zip(ours[3], theirs[3]):
            assert mine["cost"] == other["cost"] and mine["TimeLimit.truncated"] == other["TimeLimit.truncated"]
            np.testing.assert_array_equal(mine["terminal_observation"], other["terminal_observation"])
            assert (mine["episode"]["r"], mine["episode"]["l"]) == (other["episode"]["r"], other["episode"]["l"])
    assert native.env_is_wrapped(type(dummy.envs[0])) == [True] * 3
    assert native.get_attr("structure", indices=[0]) == ["pid" if "PID" in env_id else "msp"]
    native.close()
    dummy.close()


def test_slot_snapshots_restore_the_episodes():
    venv = make_native_vec_env("DeadTime/FPPI-v0", 2)
    venv.seed(3)
    venv.reset()
    snapshots = venv.env_method("checkpoint_snapshot")
    action = np.zeros((2, 1), dtype=np.float32)
    first = venv.step(action)
    for index, snapshot in enumerate(snapshots):
        venv.env_method("checkpoint_restore", snapshot, indices=[index])
    again = venv.step(action)
    np.testing.assert_array_equal(first[0], again[0])
    np.testing.assert_array_equal(first[1], again[1])


def test_ppo_learns_with_four_native_envs():
    from agents.training.train import make_vec_env, new_model

    config = load_config(PPO, "DeadTime/PID-v0", ["n_envs=4", "vec_env=native", "hyperparameters.n_steps=8",
                                                  "hyperparameters.batch_size=16", "hyperparameters.n_epochs=1"])
    validate(config)
    venv = make_vec_env(config)
    assert isinstance(venv, NativeVecEnv)
    model = new_model(config, venv)
    model.learn(total_timesteps=64)
    assert model.num_timesteps == 64 and len(model.ep_info_buffer) == 64
    venv.close()


@pytest.mark.parametrize(("overrides", "message"), [
    (["vec_env=native", "env_kwargs.experiments=agent"], "vec_env: native runs the fixed mode only"),
    (["vec_env=threads"], "vec_env"),
])
def test_bad_native_configs_name_vec_env(overrides, message):
    with pytest.raises(ValueError, match=message):
        validate(load_config(PPO, "DeadTime/PID-v0", overrides))


def test_native_needs_a_vector_entry_point(tmp_path):
    path = tmp_path / "pendulum.yaml"
    path.write_text("default: {algorithm: PPO, env_id: Pendulum-v1, total_timesteps: 10, vec_env: native}\n")
    with pytest.raises(ValueError, match="vec_env: native needs"):
        validate(load_config(path))


@pytest.mark.slow
def test_native_training_resumes_exactly(tmp_path, sigint_at):
    """``deadtime train`` with ``vec_env: native``, SIGINT mid-run, ``--resume``: the uninterrupted agent."""
    import torch

    from agents.training.policies import load_policy
    from agents.training.train import train

    tiny = ["n_envs=4", "vec_env=native", "total_timesteps=96", "hyperparameters.n_steps=8",
            "hyperparameters.batch_size=16", "hyperparameters.n_epochs=2", "eval_freq=32", "n_eval_episodes=2",
            "checkpoint_freq=32", "progress_bar=false", "policy_kwargs.net_arch=[16, 16]"]
    whole = tmp_path / "whole"
    assert main(["train", "--config", str(PPO), "--out", str(whole), *tiny]) == 0

    run_dir = tmp_path / "part"
    result = train(load_config(PPO, "DeadTime/PID-v0", [*tiny, f"output_dir={run_dir}"]), callbacks=[sigint_at(52)])
    assert result.status == "interrupted"
    assert main(["train", "--out", str(run_dir), "--resume"]) == 0
    resumed, reference = (load_policy(d / "model.zip").model.policy.state_dict() for d in (run_dir, whole))
    assert all(torch.equal(resumed[key], reference[key]) for key in reference)
