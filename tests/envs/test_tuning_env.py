"""The Gymnasium environments: checkers, determinism, actions, reward = scored cost, invariance."""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import envs  # noqa: F401  (registers the ids)
from envs.analysis.loop_analysis import analyze
from envs.systems.plants import Plant
from envs.analysis.scoring import Constraints, score
from envs.tuning_env import FPPIEnv, MSPEnv, PIDEnv
from envs.interface import episode_of

REPO = Path(__file__).resolve().parents[2]
IDS = ["DeadTime/PID-v0", "DeadTime/FPPI-v0", "DeadTime/MSP-v0", "DeadTime/PID-v1", "DeadTime/FPPI-v1", "DeadTime/MSP-v1"]
MODES = ["fixed", "agent"]


def _episode(env: gym.Env, seed: int, actions: list[np.ndarray] | None = None):
    """Run one episode; return every observation, reward and the final info."""
    obs, info = env.reset(seed=seed)
    trace, rewards, k = [obs], [], 0
    while True:
        action = actions[k] if actions is not None and k < len(actions) else env.action_space.sample()
        obs, reward, terminated, truncated, info = env.step(action)
        trace.append(obs)
        rewards.append(reward)
        k += 1
        if terminated or truncated:
            return trace, rewards, info


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("mode", MODES)
def test_gymnasium_env_checker_passes(env_id, mode):
    env = gym.make(env_id, experiments=mode)
    gym_check_env(env.unwrapped, skip_render_check=True)


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("mode", MODES)
def test_stable_baselines3_env_checker_passes(env_id, mode):
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    sb3_check_env(gym.make(env_id, experiments=mode).unwrapped, warn=True)


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("mode", MODES)
def test_same_seed_same_episode_and_observations_in_space(env_id, mode):
    env = gym.make(env_id, experiments=mode)
    env.action_space.seed(3)
    actions = [env.action_space.sample() for _ in range(6)]
    first = _episode(env, 11, actions)
    second = _episode(env, 11, actions)
    for a, b in zip(first[0], second[0]):
        assert np.array_equal(a, b)
        assert env.observation_space.contains(a)
    assert first[1] == second[1]
    assert json.dumps(first[2], sort_keys=True) == json.dumps(second[2], sort_keys=True)
    assert _episode(env, 12, actions)[2]["plant"] != first[2]["plant"]


_CHILD = """
import json, sys, numpy as np, gymnasium as gym, envs
env = gym.make(sys.argv[1], experiments=sys.argv[2])
obs, info = env.reset(seed=5)
out = [obs.tolist()]
while True:
    obs, reward, terminated, truncated, info = env.step(np.full(env.action_space.shape, 0.3, dtype=np.float32))
    out.append([obs.tolist(), float(reward).hex(), info.get("cost", 0.0)])
    if terminated:
        break
print(json.dumps(out))
"""


@pytest.mark.parametrize("env_id, mode", [("DeadTime/PID-v0", "fixed"), ("DeadTime/MSP-v0", "agent")])
def test_same_seed_same_episode_across_processes(env_id, mode):
    environment = {**os.environ, "PYTHONPATH": str(REPO)}
    runs = [
        subprocess.run([sys.executable, "-c", _CHILD, env_id, mode], capture_output=True, text=True, env=environment, timeout=300, check=False)
        for _ in range(2)
    ]
    assert all(r.returncode == 0 for r in runs), runs[0].stderr
    assert runs[0].stdout == runs[1].stdout


@pytest.mark.parametrize("mode", MODES)
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_action_is_refused(mode, bad):
    env = PIDEnv(experiments=mode)
    env.reset(seed=0)
    action = np.zeros(env.action_space.shape, dtype=np.float32)
    action[-1] = bad
    with pytest.raises(ValueError, match="action must be finite"):
        env.step(action)


def test_wrong_action_shape_is_refused():
    env = PIDEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"action must have shape \(1,\)"):
        env.step(np.zeros(2, dtype=np.float32))


def test_out_of_range_actions_are_clipped():
    env = FPPIEnv()
    results = []
    for action in (1.0, 7.5, -1.0, -40.0):
        env.reset(seed=4)
        results.append(env.step(np.array([action], dtype=np.float32))[4]["parameter"])
    assert results[0] == results[1] == pytest.approx(env.parameter_range[1], rel=1e-12)
    assert results[2] == results[3] == pytest.approx(env.parameter_range[0], rel=1e-12)


def test_parameter_mapping_is_log_scale_and_inverts():
    env = PIDEnv()
    low, high = env.parameter_range
    assert env.parameter_from_action(0.0) == pytest.approx(math.sqrt(low * high), rel=1e-12)
    for parameter in (0.5, 2.0, 30.0):
        assert env.parameter_from_action(env.action_from_parameter(parameter)) == pytest.approx(parameter, rel=1e-12)


@pytest.mark.parametrize("cls", [PIDEnv, FPPIEnv, MSPEnv])
def test_fixed_mode_reward_is_minus_the_scored_cost(cls):
    """The reward equals -score(...) on the same plant and controller, and its IAE and margins are
    those of ``deadtime analyze`` (envs.analysis.loop_analysis.analyze)."""
    env = cls()
    env.reset(seed=21)
    _, reward, terminated, truncated, info = env.step(np.array([0.2], dtype=np.float32))
    assert terminated and not truncated
    plant = Plant.from_dict(info["plant"])
    controller = episode_of(env).design(info["parameter"])
    assert controller.to_dict() == info["controller"]
    expected = score(plant, controller, experiment_time=env.identification.experiment_time, constraints=env.constraints)
    assert reward == -expected.cost == -info["cost"]
    analysis = analyze(plant, controller).to_dict()
    assert analysis["ms"] == pytest.approx(info["score"]["ms"], rel=1e-12)
    assert analysis["delay_margin"] == pytest.approx(info["score"]["delay_margin"], rel=1e-12)
    if info["feasible"] and not info["score"]["iae_lower_bound"]:
        assert analysis["iae_load"] == pytest.approx(info["score"]["iae_load"], rel=1e-12)
        assert analysis["iae_setpoint"] == pytest.approx(info["score"]["iae_setpoint"], rel=1e-12)
    elif info["feasible"]:  # a capped design: the score stopped early, its IAE is a lower bound
        assert analysis["iae_load"] >= info["score"]["iae_load"] and analysis["iae_setpoint"] >= info["score"]["iae_setpoint"]


def test_info_carries_every_figure():
    env = PIDEnv()
    env.reset(seed=2)
    info = env.step(np.array([0.3], dtype=np.float32))[4]
    for key in ("cost", "feasible", "score", "plant", "model", "controller", "parameter", "experiment_time", "features"):
        assert key in info
    for key in ("ms", "gain_margin", "phase_margin_deg", "delay_margin", "relative_delay_margin", "iae_load", "iae_setpoint", "stable"):
        assert key in info["score"]
    assert info["model"]["type"] == "sopdt" and info["controller"]["type"] == "pid-series"


@pytest.mark.parametrize("kwargs, message", [
    ({"experiments": "both"}, "experiments must be one of fixed, agent"),
    ({"family": "sine"}, "unknown plant family 'sine'"),
    ({"constraints": {"max_sensitivty": 2.0}}, "constraints: unknown key 'max_sensitivty'"),
    ({"weights": {"load": -1.0}}, "weights.load"),
    ({"budget": 0}, "budget must be an integer from 1 to 100"),
    ({"noise_std": math.nan}, "noise_std"),
    ({"render_mode": "human"}, "render_mode must be None or 'rgb_array'"),
    ({"action": "ms"}, "action must be one of parameter, residual, robustness, got .ms."),
    ({"design_features": "yes"}, "design_features must be true or false"),
])  # fmt: skip
def test_bad_arguments_are_named(kwargs, message):
    with pytest.raises(ValueError, match=message):
        PIDEnv(**kwargs)


def test_reset_with_a_given_plant_and_wrong_kind_refused():
    env = MSPEnv()
    plant = Plant((1.0,), (10.0, 1.0, 0.0), 2.0)
    obs, info = env.reset(seed=0, options={"plant": plant.to_dict()})
    assert Plant.from_dict(info["plant"]) == plant
    with pytest.raises(ValueError, match="must be an integrating plant"):
        env.reset(seed=0, options={"plant": Plant((1.0,), (10.0, 1.0), 2.0)})
    with pytest.raises(ValueError, match="unknown key 'plants'"):
        env.reset(seed=0, options={"plants": plant})


def test_msp_default_constraints_are_the_delay_margin_only():
    environments = "residence-time"  # the environments' judgement of a plant without dead time (envs.analysis.scoring)
    assert MSPEnv().constraints == Constraints(max_sensitivity=None, min_relative_delay_margin=0.2, zero_delay=environments)
    assert PIDEnv().constraints == Constraints(zero_delay=environments)


def _scaled(plant: Plant, gain: float, time: float) -> Plant:
    """``gain * G(time s) e^{-L time s}``: the same plant in other units."""
    num = gain * np.asarray(plant.num) * time ** np.arange(len(plant.num))[::-1]
    den = np.asarray(plant.den) * time ** np.arange(len(plant.den))[::-1]
    return Plant(tuple(num), tuple(den), plant.dead_time * time)


@pytest.mark.parametrize("cls", [PIDEnv, FPPIEnv, MSPEnv])
@pytest.mark.parametrize("gain, time", [(-3.0, 0.01), (250.0, 40.0)])
def test_episode_is_invariant_to_gain_and_time_scale(cls, gain, time):
    """Same seed, the plant in other units: same observation, same reward (noise is relative)."""
    env = cls()
    env.reset(seed=8)
    plant = env.plant
    results = []
    for candidate in (plant, _scaled(plant, gain, time)):
        obs, _ = env.reset(seed=8, options={"plant": candidate})
        _, reward, *_ = env.step(np.array([0.1], dtype=np.float32))
        results.append((obs, reward))
    np.testing.assert_allclose(results[0][0], results[1][0], rtol=1e-6, atol=1e-6)
    assert results[1][1] == pytest.approx(results[0][1], rel=1e-6)


class TestAgentMode:
    def test_first_experiment_is_always_the_closed_loop_step(self):
        env = PIDEnv(experiments="agent")
        env.reset(seed=0)
        action = np.array([-1, -1, 1, -1, -1, 0, 0], dtype=np.float32)  # open-loop step first
        obs, reward, terminated, _, info = env.step(action)
        assert not terminated and reward == 0.0
        assert env.evidence.counts == (1, 0, 0, 0)
        env.step(action)
        assert env.evidence.counts == (1, 1, 0, 0)

    def test_budget_forces_the_commit(self):
        env = MSPEnv(experiments="agent", budget=2)
        env.reset(seed=0)
        action = np.array([-1, 1, -1, -1, 0, 0], dtype=np.float32)  # closed-loop step, again and again
        assert not env.step(action)[2]
        assert not env.step(action)[2]
        _, reward, terminated, _, info = env.step(action)
        assert terminated and reward == -info["cost"]
        assert env.evidence.runs == 2

    def test_commit_runs_the_missing_experiments(self):
        env = FPPIEnv(experiments="agent")
        env.reset(seed=0)
        commit = np.array([1, -1, -1, -1, -1, 0, 0], dtype=np.float32)
        info = env.step(commit)[4]
        assert env.evidence.counts == (1, 1, 0, 0)  # closed-loop step, then the open-loop step for T_n
        assert info["model"]["type"] == "fopdt"
        assert info["experiment_time"] > 0

    def test_large_amplitude_is_stopped_at_the_excursion_limit(self):
        env = PIDEnv(experiments="agent", excursion_limit=2.0)
        env.reset(seed=0)
        env.step(np.array([-1, 1, -1, -1, -1, -1, 0], dtype=np.float32))  # closed-loop step, amplitude 0.1
        env.step(np.array([-1, -1, 1, -1, -1, 1, 0], dtype=np.float32))  # open-loop step, amplitude 10
        assert env.evidence.aborted == 1 and "open-loop-step" not in env.evidence.results


def test_vector_environments_run_one_step_episodes():
    vector = gym.make_vec("DeadTime/PID-v0", num_envs=2, vectorization_mode="sync")
    obs, _ = vector.reset(seed=0)
    assert obs.shape == (2, 15)
    _, reward, terminated, truncated, _ = vector.step(np.zeros((2, 1), dtype=np.float32))
    assert terminated.all() and not truncated.any() and np.all(reward < 0)


@pytest.mark.slow
@pytest.mark.parametrize("vec", ["dummy", "subproc"])
def test_stable_baselines3_vector_environments(vec):
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    cls = DummyVecEnv if vec == "dummy" else SubprocVecEnv
    # "envs:" makes gymnasium import envs (the registration) first, also in spawned workers.
    venv = make_vec_env("envs:DeadTime/FPPI-v0", n_envs=2, seed=0, vec_env_cls=cls)
    try:
        venv.reset()
        for _ in range(2):
            _, reward, done, info = venv.step(np.zeros((2, 1), dtype=np.float32))
            assert done.all() and all("cost" in i for i in info)
            assert np.allclose(reward, [-i["cost"] for i in info])
    finally:
        venv.close()


def test_rgb_array_rendering():
    env = gym.make("DeadTime/MSP-v0", render_mode="rgb_array")
    env.reset(seed=0)
    before = env.render()
    env.step(np.array([0.0], dtype=np.float32))
    after = env.render()
    assert before.dtype == np.uint8 and before.shape == after.shape == (512, 512, 3)
    assert not np.array_equal(before, after)  # the loop's responses are drawn after the commit
    assert PIDEnv().render() is None


@pytest.mark.parametrize(
    "given",
    [
        Plant.from_time_constants(2.5, [12.0], 4.0),
        {"num": [2.5], "den": [12.0, 1.0], "delay": 4.0},
        "transfer-function-and-delay",
    ],
    ids=["plant", "dict", "transfer-function-and-delay"],
)
def test_reset_takes_a_plant_in_every_form(given):
    import control

    if given == "transfer-function-and-delay":
        given = (control.tf([2.5], [12.0, 1.0]), 4.0)
    env = gym.make("DeadTime/PID-v0")
    _, info = env.reset(seed=0, options={"plant": given})
    assert Plant.from_dict(info["plant"]) == Plant.from_time_constants(2.5, [12.0], 4.0)


def test_reset_names_the_forms_of_a_plant():
    env = gym.make("DeadTime/PID-v0")
    with pytest.raises(ValueError) as error:
        env.reset(seed=0, options={"plant": [2.5, 12.0]})
    assert str(error.value) == (
        "reset options: plant must be a Plant, a JSON object with num, den, delay, a control.TransferFunction "
        "or a (TransferFunction, delay) pair; got list"
    )


def test_a_family_of_the_wrong_kind_is_named_when_the_env_is_made():
    """A family of the other kind of plant is refused by ``gym.make``, naming the family and the
    kinds, rather than at reset after draws of plants none of which the structure can identify."""
    with pytest.raises(ValueError) as error:
        gym.make("DeadTime/PID-v0", family="integrating")
    assert str(error.value) == (
        "family 'integrating' draws integrating plants; PIDEnv takes self-regulating plants "
        "(families: stable, fopdt, sopdt, lag-chain, benchmark)"
    )
    with pytest.raises(ValueError, match="family 'fopdt' draws self-regulating plants; MSPEnv takes integrating plants"):
        gym.make("DeadTime/MSP-v0", family="fopdt")
