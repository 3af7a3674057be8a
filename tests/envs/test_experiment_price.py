"""Experiments with a price and disturbances: the arguments ``weights.production``,
``amplitude_limit`` and ``disturbances`` of the environments.

Their defaults are the v0 environments bit for bit (tests/regression; here also given explicitly).
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (registers the ids)
from envs.analysis.scoring import CostWeights, score
from envs.identification.open_loop_step import open_loop_step
from envs.identification.procedure import experiment_deviation
from envs.systems.plants import Plant
from envs.interface import episode_of, tuning_env_of

IDS = ["DeadTime/PID-v0", "DeadTime/FPPI-v0", "DeadTime/MSP-v0"]
DEFAULTS = {"weights": {"production": 0.0}, "amplitude_limit": None, "disturbances": {}}


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("mode", ["fixed", "agent"])
def test_the_defaults_given_explicitly_are_v0(env_id, mode, play):
    default, explicit = gym.make(env_id, experiments=mode), gym.make(env_id, experiments=mode, **DEFAULTS)
    actions = list(np.random.default_rng(2).uniform(-1, 1, (6, *default.action_space.shape)).astype(np.float32))
    for seed in range(2):
        first, second = play(default, seed, actions), play(explicit, seed, actions)
        assert all(np.array_equal(a, b) for a, b in zip(first[0], second[0]))
        assert first[1] == second[1] and first[2] == second[2]


def test_deviation_of_an_open_loop_step_is_the_analytic_integral():
    """``D = int |y| dt`` of a noise-free FOPDT step ``a (1 - e^{-(t - L)/T})``: ``a (t_f - L - T (1 -
    e^{-(t_f - L)/T}))``; the trapezoidal rule at ``T_ar/200`` is second order (measured 1.2e-7 relative)."""
    gain, lag, dead_time, amplitude = 2.0, 6.0, 3.0, 0.7
    plant = Plant(num=(gain,), den=(lag, 1.0), dead_time=dead_time)
    result = open_loop_step(plant, np.random.default_rng(0), amplitude / gain, plant.residence_time, gain)
    end = result.timepts[-1] - dead_time
    exact = amplitude * (end - lag * (1.0 - math.exp(-end / lag)))
    assert experiment_deviation(result) == pytest.approx(exact, rel=2e-6)


def test_production_is_priced_in_the_cost(play):
    """``cost = v0 cost + w_prod D_exp/T_ar`` (feasible, uncapped design), ``D_exp`` the sum of the
    experiments' deviations, reported in ``info`` in units of the true ``T_ar``."""
    plant = Plant.from_time_constants(1.5, (6.0, 2.0), 3.0)
    action = [np.array([0.3], dtype=np.float32)]
    free = gym.make("DeadTime/FPPI-v0")
    priced = gym.make("DeadTime/FPPI-v0", weights={"production": 0.5})
    _, _, base = play(free, 0, action, plant)
    _, rewards, info = play(priced, 0, action, plant)
    evidence = episode_of(priced).evidence
    deviation = sum(experiment_deviation(r) for r in evidence.results.values())
    assert "experiment_deviation" not in base
    assert info["experiment_deviation"] == pytest.approx(deviation / plant.residence_time, rel=1e-12)
    assert base["feasible"] and info["cost"] < 20
    assert info["cost"] == pytest.approx(base["cost"] + 0.5 * deviation / plant.residence_time, rel=1e-12)
    assert rewards[-1] == -info["cost"]
    assert info["score"]["experiment_cost"] == pytest.approx(base["score"]["experiment_cost"] + 0.5 * info["experiment_deviation"])


def test_score_prices_the_deviation_only_with_a_weight():
    plant = Plant(num=(1.0,), den=(5.0, 1.0), dead_time=2.0)
    from envs.systems.controllers import PID

    controller = PID(kp=1.0, ti=5.0)
    plain = score(plant, controller, experiment_time=10.0)
    ignored = score(plant, controller, experiment_time=10.0, experiment_deviation=math.inf)  # weight 0: left out
    priced = score(plant, controller, experiment_time=10.0, experiment_deviation=14.0, weights=CostWeights(production=0.25))
    assert plain.cost == ignored.cost
    assert priced.cost == pytest.approx(plain.cost + 0.25 * 14.0 / plant.residence_time, rel=1e-12)


def test_amplitude_limit_cuts_the_agents_amplitude_and_the_seeds():
    env = gym.make("DeadTime/FPPI-v0", experiments="agent", amplitude_limit=0.5, noise_std=0.02)
    env.reset(seed=0)
    action = np.full(env.action_space.shape, -1.0, dtype=np.float32)
    action[1], action[-2] = 1.0, 1.0  # a closed-loop step at the largest amplitude, 10
    _, _, _, _, info = env.step(action)
    assert info["amplitude"] == 0.5
    assert episode_of(env).evidence.closed_loop.amplitude == 0.5
    assert info["features"]["log_noise_ratio"] == pytest.approx(math.log10(0.02 / 0.5))
    fixed = gym.make("DeadTime/FPPI-v0", amplitude_limit=0.25)
    fixed.reset(seed=0)
    found = episode_of(fixed).identification
    assert found.closed_loop.amplitude == 0.25
    assert found.open_loop.height == pytest.approx(0.25 / found.gain)


@pytest.mark.parametrize("disturbances", [{"drift": 0.005}, {"load": 0.2}])
def test_disturbances_change_the_identification_not_the_white_noise(disturbances):
    plant = Plant.from_time_constants(1.5, (6.0, 2.0), 3.0)
    clean, disturbed = gym.make("DeadTime/FPPI-v0"), gym.make("DeadTime/FPPI-v0", disturbances=disturbances)
    clean.reset(seed=5, options={"plant": plant})
    disturbed.reset(seed=5, options={"plant": plant})
    a, b = episode_of(clean).identification, episode_of(disturbed).identification
    assert a.gain != b.gain
    first = min(a.closed_loop.output.size, b.closed_loop.output.size)
    # the true outputs start alike (same white noise, the disturbance grows from 0 or starts later)
    assert np.allclose(a.closed_loop.true_output[:20], b.closed_loop.true_output[:20], atol=1e-2)
    assert first > 20


@pytest.mark.parametrize(
    "env_id, kwargs, message",
    [
        ("DeadTime/FPPI-v0", {"weights": {"production": -0.1}}, "weights.production must be >= 0"),
        ("DeadTime/FPPI-v0", {"weights": {"experiment": -0.1}}, "weights.experiment must be >= 0"),
        ("DeadTime/FPPI-v0", {"amplitude_limit": -1.0}, "amplitude_limit must be > 0"),
        ("DeadTime/PID-v0", {"amplitude_limit": 0}, "amplitude_limit must be > 0"),
        ("DeadTime/PID-v0", {"disturbances": {"wind": 0.1}}, "disturbances: unknown kind 'wind'"),
        ("DeadTime/PID-v0", {"disturbances": {"drift": -0.1}}, r"disturbances\['drift'\] must be >= 0"),
        ("DeadTime/MSP-v0", {"disturbances": {"load": 0.1}}, r"disturbances\['load'\] needs self-regulating plants"),
    ],
)
def test_bad_arguments_raise_one_value_error_naming_them(env_id, kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make(env_id, **kwargs)


@pytest.mark.parametrize("structure", ["PID", "FPPI", "MSP"])
def test_v2_is_v1_with_production_priced(structure, play):
    """Same seed and action: v2's fixed-mode episode identifies as v1's and its cost is v1's plus
    ``0.05 D_exp/T_ar`` (v2's production weight); its agent-mode amplitudes stop at 3."""
    v1, v2 = gym.make(f"DeadTime/{structure}-v1"), gym.make(f"DeadTime/{structure}-v2")
    assert episode_of(v2).weights == CostWeights(production=0.05)
    assert episode_of(v2).options.amplitude_limit == 3.0
    action = [np.array([0.2], dtype=np.float32)]
    for seed in range(3):
        first, _, info1 = play(v1, seed, action)
        second, _, info2 = play(v2, seed, action)
        assert np.array_equal(first[0], second[0])
        assert info1["controller"] == info2["controller"]
        if info1["feasible"]:
            assert info2["cost"] == pytest.approx(info1["cost"] + 0.05 * info2["experiment_deviation"], rel=1e-12)
    agent = gym.make(f"DeadTime/{structure}-v2", experiments="agent")
    agent.reset(seed=0)
    step = np.full(agent.action_space.shape, -1.0, dtype=np.float32)
    step[1], step[-2] = 1.0, 1.0  # the first experiment at the largest amplitude asked for (10)
    assert agent.step(step)[4]["amplitude"] == 3.0


def agent_action(size: int, choice: int, amplitude: float, design: float) -> np.ndarray:
    action = np.full(size, -1.0, dtype=np.float32)
    action[choice], action[-2], action[-1] = 1.0, amplitude, design
    return action


@pytest.mark.parametrize("structure", ["PID", "FPPI", "MSP"])
def test_v2_agent_mode_designs_in_a_step_of_its_own(structure):
    """v2 agent mode: the commit runs the fixed procedure's missing experiments at the commit's amplitude (cut to
    3) and shows them (reward 0, ``design_step`` 1, design features set); the next step designs
    from its last component, as the fixed mode would on that identification."""
    from gymnasium.utils.env_checker import check_env

    env = gym.make(f"DeadTime/{structure}-v2", experiments="agent")
    check_env(env.unwrapped, skip_render_check=True)
    size = env.action_space.shape[0]
    assert tuning_env_of(env).feature_names[-1] == "design_step"
    observation, _ = env.reset(seed=1)
    assert observation[-1] == 0.0
    observation, reward, terminated, _, info = env.step(agent_action(size, 0, 0.0, -1.0))  # commit at amplitude 1
    evidence = episode_of(env).evidence
    assert (reward, terminated, observation[-1]) == (0.0, False, 1.0)
    assert info["amplitude"] == pytest.approx(1.0) and evidence.noise_ratio == pytest.approx(0.01)
    runs = 2 if structure == "FPPI" else 1  # the FPPI's design needs the open-loop step too
    assert evidence.runs == runs and info["features"]["log_base_parameter"] != 0.0
    design = 0.5  # exact in float32, the action's type
    expected = episode_of(env).score_controller(episode_of(env).design(episode_of(env).parameter_from_action(design))).cost
    _, reward, terminated, _, info = env.step(agent_action(size, 1, 0.0, design))  # its choice is ignored now
    assert terminated and reward == -info["cost"] and info["cost"] == pytest.approx(expected, rel=1e-12)
    assert episode_of(env).evidence.runs == runs
    env.reset(seed=1)
    env.step(agent_action(size, 0, 1.0, 0.0))  # amplitude 10, cut to 3
    assert episode_of(env).evidence.noise_ratio == pytest.approx(0.01 / 3.0)


def test_v1_agent_mode_still_designs_at_the_commit():
    env = gym.make("DeadTime/FPPI-v1", experiments="agent")
    env.reset(seed=1)
    _, _, terminated, _, info = env.step(agent_action(env.action_space.shape[0], 0, 1.0, 0.0))
    assert terminated and episode_of(env).evidence.noise_ratio == pytest.approx(0.01)
    assert "design_step" not in tuning_env_of(env).feature_names
