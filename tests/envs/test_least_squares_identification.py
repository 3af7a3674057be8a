"""The environments' least-squares identification: ``identification="least-squares"``.

Behind the argument only: without it every episode is the v0 episode (tests/regression), and with
``identification="seeds"`` given explicitly too (below).
"""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env as gym_check_env

import envs  # noqa: F401  (registers the ids)
from envs.episode import FEATURES, LEAST_SQUARES_FEATURES, STABLE_EXPERIMENTS
from envs.identification.prbs_experiment import fit_record
from envs.systems.plants import Plant
from envs.interface import episode_of, tuning_env_of

IDS = ["DeadTime/PID-v0", "DeadTime/FPPI-v0"]
LS = {"identification": "least-squares"}


def _choose(env: gym.Env, experiment: str | None, parameter: float = 0.0, amplitude: float = 0.0) -> np.ndarray:
    """The agent-mode action that runs ``experiment`` (None: commit)."""
    names = tuning_env_of(env).experiment_names
    action = np.full(env.action_space.shape, -1.0, dtype=np.float32)
    action[0 if experiment is None else 1 + names.index(experiment)] = 1.0
    action[-2], action[-1] = amplitude, parameter
    return action


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("mode", ["fixed", "agent"])
def test_spaces_and_checker(env_id, mode):
    env = gym.make(env_id, experiments=mode, **LS)
    assert tuning_env_of(env).experiment_names == (*STABLE_EXPERIMENTS, "prbs")
    names = tuning_env_of(env).feature_names
    assert names[: len(FEATURES) + 3] == (*FEATURES, *LEAST_SQUARES_FEATURES)
    assert env.observation_space.shape == (len(FEATURES) + 3 + len(STABLE_EXPERIMENTS) + 2,)
    assert env.action_space.shape == ((1,) if mode == "fixed" else (len(STABLE_EXPERIMENTS) + 4,))
    gym_check_env(env.unwrapped, skip_render_check=True)


@pytest.mark.parametrize("env_id", IDS)
@pytest.mark.parametrize("mode", ["fixed", "agent"])
def test_seeds_given_explicitly_is_the_default(env_id, mode, play):
    default, explicit = gym.make(env_id, experiments=mode), gym.make(env_id, experiments=mode, identification="seeds")
    actions = list(np.random.default_rng(1).uniform(-1, 1, (6, *default.action_space.shape)).astype(np.float32))
    for seed in range(3):
        first, second = play(default, seed, actions), play(explicit, seed, actions)
        assert all(np.array_equal(a, b) for a, b in zip(first[0], second[0])) and first[1] == second[1]


def test_fixed_fppi_designs_from_the_fit_of_the_seeds_step(play):
    """Same experiments as the fixed procedure (same seed, same records), then the step's record fitted."""
    plant = Plant(num=(2.5,), den=(12.0, 1.0), dead_time=4.0)
    seeds, fitted = gym.make("DeadTime/FPPI-v0"), gym.make("DeadTime/FPPI-v0", **LS)
    seeds.reset(seed=3, options={"plant": plant})
    fitted.reset(seed=3, options={"plant": plant})
    step = episode_of(seeds).evidence.results["open-loop-step"]
    assert np.array_equal(step.output, episode_of(fitted).evidence.results["open-loop-step"].output)
    expected = fit_record(step, episode_of(seeds).identification.residence_time, 1).model
    model = episode_of(fitted).model()
    assert model == expected
    assert model.gain == pytest.approx(2.5, rel=0.01)
    assert model.time_constant == pytest.approx(12.0, rel=0.02) and model.dead_time == pytest.approx(4.0, rel=0.02)
    assert episode_of(fitted).evidence.fit.experiment == "open-loop-step"
    _, _, info = play(fitted, 3, [np.zeros(1, dtype=np.float32)], plant)
    assert info["model"] == expected.to_dict()


def test_agent_prbs_replaces_the_open_loop_step(play):
    """A PRBS (after the closed-loop step) gives the FPPI its FOPDT model: committing runs no step."""
    env = gym.make("DeadTime/FPPI-v0", experiments="agent", **LS)
    plant = Plant.from_time_constants(1.7, (6.0, 2.0), 3.0)
    actions = [_choose(env, "closed-loop-step"), _choose(env, "prbs"), _choose(env, None)]
    _, rewards, info = play(env, 0, actions, plant)
    evidence = episode_of(env).evidence
    assert dict(zip(evidence.experiments, evidence.counts)) == {
        "closed-loop-step": 1, "open-loop-step": 0, "open-loop-ramp": 0, "relay": 0, "prbs": 1}
    assert evidence.fit.experiment == "prbs" and info["model"] == evidence.fit.fit.model.to_dict()
    named = info["features"]
    assert named["ls_dead_time"] > 0 and named["ls_time_constant"] > 0 and named["log_ls_residual"] < -1
    assert rewards[-1] == -info["cost"]


def test_pid_reads_an_sopdt_fit():
    env = gym.make("DeadTime/PID-v0", **LS)
    plant = Plant.from_time_constants(1.5, (8.0, 3.0), 2.0)
    env.reset(seed=0, options={"plant": plant})
    model = episode_of(env).model()
    assert episode_of(env).evidence.fit is not None and model == episode_of(env).evidence.fit.fit.model
    assert model.gain == pytest.approx(1.5, rel=0.02)
    assert sum(model.time_constants) + model.dead_time == pytest.approx(13.0, rel=0.05)


@pytest.mark.parametrize(
    "env_id, kwargs, message",
    [
        ("DeadTime/MSP-v0", LS, "needs self-regulating plants"),
        ("DeadTime/FPPI-v0", {"identification": "moments"}, "identification must be one of seeds, least-squares"),
    ],
)
def test_refused(env_id, kwargs, message):
    with pytest.raises(ValueError, match=message):
        gym.make(env_id, **kwargs)


@pytest.mark.parametrize("order", [("prbs", "open-loop-step"), ("open-loop-step", "prbs")], ids=["step-last", "prbs-last"])
def test_agent_chooses_the_identification_by_its_latest_experiment(order, play):
    """Agent mode: the design reads the model of the latest experiment that gives one, the PRBS's by
    least squares or the step's by the papers' area method (eq. 11)."""
    env = gym.make("DeadTime/FPPI-v0", experiments="agent", **LS)
    plant = Plant.from_time_constants(1.7, (6.0, 2.0), 3.0)
    actions = [_choose(env, "closed-loop-step"), *(_choose(env, kind) for kind in order), _choose(env, None)]
    _, _, info = play(env, 1, actions, plant)
    evidence = episode_of(env).evidence
    if order[-1] == "prbs":
        assert info["model"] == evidence.fit.fit.model.to_dict()
    else:
        assert evidence.fit is None and info["model"] == evidence.results["open-loop-step"].model.to_dict()
