"""The arguments as one EnvConfig, and the episode's public interface through the wrappers."""

from __future__ import annotations

import inspect

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401  (registers the ids)
from envs.env_config import ARGUMENTS, EnvConfig, ModeConfig
from envs.interface import episode_of, tuning_env_of
from envs.tuning_env import PIDEnv


def test_every_keyword_fills_its_group_and_reads_back():
    config = EnvConfig.from_arguments("PIDEnv", {"budget": 6, "action": "residual", "noise_std": 0.05,
                                                 "violation_cost": "bounded", "family": "fopdt", "render_mode": "rgb_array"})
    assert config.mode.budget == 6 and config.design.action == "residual" and config.experiments.noise_std == 0.05
    assert config.scoring.violation_cost == "bounded" and config.plants.family == "fopdt"
    assert [config[name] for name in ("budget", "action", "render_mode")] == [6, "residual", "rgb_array"]
    assert tuple(EnvConfig.defaults()) == ARGUMENTS and EnvConfig.defaults()["experiments"] == "fixed"


def test_an_unknown_keyword_is_one_type_error_naming_it():
    with pytest.raises(TypeError, match=r"^PIDEnv.__init__\(\) got an unexpected keyword argument 'nois_std'$"):
        PIDEnv(nois_std=0.1)
    with pytest.raises(TypeError, match="unexpected keyword argument 'noise'"):
        gym.make("DeadTime/PID-v3", noise=0.1)


def test_a_config_and_keywords_make_the_same_environment_as_the_keywords():
    given = PIDEnv(EnvConfig(mode=ModeConfig(experiments="agent", budget=3)), noise_std=0.05)
    made = PIDEnv(experiments="agent", budget=3, noise_std=0.05)
    assert given.config == made.config and given.budget == made.budget == 3 and given.noise_std == 0.05
    first = given.reset(seed=4)[0]
    assert np.array_equal(first, made.reset(seed=4)[0])


def test_the_signature_names_every_argument():
    parameters = inspect.signature(PIDEnv.__init__).parameters
    assert [name for name in parameters if name not in ("self", "config")] == list(ARGUMENTS)
    assert parameters["budget"].default == 4


def test_the_episode_scores_a_parameter_as_the_step_does():
    env = gym.make("DeadTime/FPPI-v3")
    env.reset(seed=5)
    episode = episode_of(env)
    assert tuning_env_of(env).episode is episode and episode.identification is not None
    relative = episode.parameter_from_action(0.3)
    assert episode.action_from_parameter(relative) == pytest.approx(0.3, abs=1e-12)
    controller, expected = episode.score_parameter(relative)
    assert episode.score_action(0.3)[2].cost == expected.cost == episode.score_controller(controller).cost
    info = env.step(np.array([0.3], dtype=np.float32))[4]
    assert info["parameter"] == episode.parameter_from_action(np.float32(0.3))
    assert episode.committed == (info["parameter"], info["cost"])
