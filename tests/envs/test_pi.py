"""``DeadTime/PI-v3``: SIMC PI with the agent choosing ``tau_c/theta``.

Both environment checkers in every mode; action 0 (the residual action's base) designs the rule
``simc-pi``'s controller bit for bit, on the same identification; the design is the one SIMC
formula that ``simc-pi`` uses; the oracle's optimum lies inside the parameter range.
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import envs  # noqa: F401  (registers the ids)
from baselines.rules.registry import RuleInputs, get_rule
from envs.design import pi_design, simc_pi_gains
from envs.identification.models import FOPDTModel
from envs.structures import STRUCTURES
from envs.interface import episode_of, tuning_env_of

ENV_ID = "DeadTime/PI-v3"
MODES = ("fixed", "plan", "agent")


@pytest.mark.parametrize("mode", MODES)
def test_gymnasium_env_checker_passes(mode):
    gym_check_env(gym.make(ENV_ID, experiments=mode).unwrapped, skip_render_check=True)


@pytest.mark.parametrize("mode", MODES)
def test_stable_baselines3_env_checker_passes(mode):
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    sb3_check_env(gym.make(ENV_ID, experiments=mode).unwrapped, warn=True)


def test_action_zero_is_simc_pi_bit_for_bit():
    """On every plant whose FOPDT model has a dead time (``simc-pi`` refuses the others: about 3% of
    the plants, lead plants whose step shows none; 3 of these 12) of the first twelve seeds."""
    env = gym.make(ENV_ID)
    compared = 0
    for seed in range(12):
        env.reset(seed=seed)
        identification = episode_of(env).identification
        if not identification.fopdt.dead_time > 0:
            continue
        rule = get_rule("simc-pi")(RuleInputs.from_identification(identification))
        _, reward, terminated, _, info = env.step(np.zeros(1, dtype=np.float32))
        assert terminated and info["parameter"] == 1.0
        assert info["controller"] == rule.to_dict()
        assert reward == -episode_of(env).score_controller(rule).cost
        compared += 1
    assert compared >= 8


def test_the_design_is_the_simc_formula():
    """``K_c = tau_1/(k (tau_c + theta))``, ``tau_I = min(tau_1, 4 (tau_c + theta))`` (Skogestad 2003)."""
    model = FOPDTModel(2.0, 10.0, 1.0)
    for tau_c, kp, ti in ((1.0, 10.0 / (2.0 * 2.0), 8.0), (0.5, 10.0 / (2.0 * 1.5), 6.0), (4.0, 10.0 / (2.0 * 5.0), 10.0)):
        controller = pi_design(model, tau_c)
        assert (controller.kp, controller.ti, controller.td) == (kp, ti, 0.0)
        assert simc_pi_gains(2.0, 10.0, 1.0, tau_c) == (kp, ti)


def test_a_model_without_dead_time_has_the_floored_theta():
    """``theta`` floored at 0.01 ``T_ar`` (as the Gorez-Klan PID's ``D_2``), where ``simc-pi`` refuses."""
    model = FOPDTModel(1.0, 5.0, 0.0)
    pi = STRUCTURES["pi"]
    assert pi.scale(model) == 0.05
    controller = pi.relative_design(model, 1.0)  # tau_c = theta = 0.05
    assert (controller.kp, controller.ti) == (5.0 / (1.0 * (0.05 + 0.05)), 4.0 * (0.05 + 0.05))
    with pytest.raises(ValueError):
        get_rule("simc-pi")(RuleInputs(False, 1.0, 5.0, model, None, None, 0.0, float("nan"), model=model))


def test_oracle_optimum_inside_the_range():
    """On the first training plants (seeds 100000-100003) the oracle's ``tau_c/theta`` searched over a
    wider range lies inside the environment's (the measured quantiles are in the class docstring)."""
    from baselines.oracle import oracle

    env = tuning_env_of(gym.make(ENV_ID))
    low, high = env.parameter_range
    for seed in range(100000, 100004):
        env.reset(seed=seed)
        best = oracle(env.plant, env.identification, "pi", constraints=env.constraints, weights=env.weights,
                      parameter_range=(low / 10, high * 10))
        assert low < best.relative_parameter < high
