"""Episodes that once raised or grew without bound return a result: an identification without the
design's model, an experiment longer than the sample cap, a least-squares search without a budget."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils import seeding

import envs  # noqa: F401
from envs.episode import IdentificationFailed, start_fixed
from envs.identification.prbs_experiment import open_loop_prbs
from envs.simulation.delay_systems import MAX_RUN_SAMPLES
from envs.systems.families import sample_plant
from envs.systems.plants import Plant
from envs.tuning_env import NO_DESIGN_COST
from envs.interface import episode_of, tuning_env_of

DRIFT = {"drift": 0.1}


# ----------------------------------------------------------------------------- no model for the design
def test_a_fixed_start_without_the_design_model_is_a_failed_identification():
    """FPPI-v3's first plant of seed 2 under a drift of 0.1: the open-loop step never settles, so there
    is no FOPDT model; the start raises the one-line failure the environment handles, not an AttributeError."""
    env = gym.make("DeadTime/FPPI-v3", disturbances=DRIFT)
    rng = seeding.np_random(2)[0]
    plant = sample_plant("stable", rng)
    with pytest.raises(IdentificationFailed, match="no fopdt model") as failure:
        start_fixed(plant, rng, episode_of(env).options, "fppi")
    assert failure.value.evidence.aborted == 1 and failure.value.evidence.closed_loop is not None


@pytest.mark.parametrize("version", ["v0", "v1", "v3"])
def test_the_fixed_mode_draws_another_plant_when_the_design_has_no_model(version):
    env = gym.make(f"DeadTime/FPPI-{version}", disturbances=DRIFT)
    env.reset(seed=2)
    assert episode_of(env).identification.fopdt is not None
    _, reward, terminated, _, info = env.step(np.zeros(1, dtype=np.float32))
    assert terminated and np.isfinite(reward) and "score" in info


def test_the_plan_mode_without_the_design_model_ends_without_a_design_in_v3_and_raises_one_line_before():
    env = gym.make("DeadTime/FPPI-v3", experiments="plan", disturbances=DRIFT)
    env.reset(seed=2)
    _, reward, terminated, _, info = env.step(np.zeros(3, dtype=np.float32))
    assert terminated and reward == -NO_DESIGN_COST and info["identified"] is False
    assert info["features"]["failed_experiments"] > 0
    v0 = gym.make("DeadTime/FPPI-v0", experiments="plan", disturbances=DRIFT)
    v0.reset(seed=2)
    with pytest.raises(ValueError, match="no fopdt model"):  # v0-v2: a failed identification raises
        v0.step(np.zeros(3, dtype=np.float32))


# ----------------------------------------------------------------------------- the sample cap
def _choose(env, kind: str) -> np.ndarray:
    action = np.full(env.action_space.shape, -1.0, dtype=np.float32)
    action[1 + tuning_env_of(env).experiment_names.index(kind)], action[-2] = 1.0, 1.0
    return action


def test_a_ramp_longer_than_the_sample_cap_stops_there_as_a_failed_experiment():
    """Under a load the closed-loop step identifies a ``T_ar`` far above the plant's: the ramp over that
    ``T_ar`` (483 million samples, 19 GB) stops at ``MAX_RUN_SAMPLES``, charged and counted as failed."""
    env = gym.make("DeadTime/PID-v1", experiments="agent", amplitude_limit=2e-6, disturbances={"load": 4.06})
    env.reset(seed=545583)
    for kind in ("open-loop-step", "closed-loop-step"):
        env.step(_choose(env, kind))
    before = episode_of(env).evidence
    assert before.closed_loop.residence_time / episode_of(env).plant.residence_time > 1e5
    env.step(_choose(env, "open-loop-ramp"))
    after = episode_of(env).evidence
    assert after.aborted == before.aborted + 1 and "open-loop-ramp" not in after.results
    dt = episode_of(env).plant.step_time_scale() / 200
    assert after.experiment_time - before.experiment_time == pytest.approx((MAX_RUN_SAMPLES - 1) * dt)


def test_a_prbs_longer_than_the_sample_cap_stops_there_without_a_fit():
    plant = Plant.from_dict({"num": [1.0], "den": [10.0, 1.0], "delay": 2.0})
    result = open_loop_prbs(plant, np.random.default_rng(0), 1.0, 1e4 * plant.residence_time, noise_std=0.01)
    assert result.timepts.size == MAX_RUN_SAMPLES and result.aborted and result.fit is None
    whole = open_loop_prbs(plant, np.random.default_rng(0), 1.0, plant.residence_time, noise_std=0.01)
    assert whole.timepts.size == 15 * 67 and not whole.aborted and whole.fit is not None  # clock ceil(200/3)


# ----------------------------------------------------------------------------- the least-squares budget
@pytest.mark.slow
def test_the_least_squares_search_of_a_step_that_never_settled_keeps_its_budget(monkeypatch):
    """Under a load the fixed procedure's open-loop step runs to the sample cap unsettled; its search
    took 232 s one fit per dead time.  Within the budget: a few seconds, and a result."""
    from envs.identification import least_squares

    fitted = []
    original = least_squares.instrumental_variables
    monkeypatch.setattr(least_squares, "instrumental_variables",
                        lambda *args, **kwargs: fitted.append(1) or original(*args, **kwargs))
    env = gym.make("DeadTime/FPPI-v3", identification="least-squares", amplitude_limit=0.0234,
                   disturbances={"load": 49.35}, action="robustness")
    env.reset(seed=38484)
    assert len(fitted) <= least_squares.MAX_FITS + 2
    _, reward, terminated, _, _ = env.step(np.zeros(1, dtype=np.float32))
    assert terminated and np.isfinite(reward)


def test_a_fixed_start_that_fails_on_every_draw_ends_without_a_design_in_v3():
    """Ten drawn plants whose procedure identifies nothing (a drift of 0.2 against an amplitude of 2e-4):
    v3 keeps the tenth and ends the episode without a design; v0-v2 raise one line."""
    settings = {"noise_std": 0.0216, "amplitude_limit": 2.03e-4, "disturbances": {"drift": 0.197}}
    env = gym.make("DeadTime/FPPI-v3", **settings)
    _, info = env.reset(seed=4)
    assert episode_of(env).identification is None and info["features"]["failed_experiments"] > 0
    _, reward, terminated, _, info = env.step(np.zeros(1, dtype=np.float32))
    assert terminated and reward == -NO_DESIGN_COST and info["identified"] is False
    with pytest.raises(RuntimeError, match="10 draws"):
        gym.make("DeadTime/FPPI-v2", **settings).reset(seed=4)
    vector = gym.make_vec("DeadTime/FPPI-v3", num_envs=2, vectorization_mode="vector_entry_point", **settings)
    vector.reset(seed=4)
    _, rewards, terminated, _, infos = vector.step(np.zeros((2, 1), dtype=np.float32))
    assert rewards[0] == -NO_DESIGN_COST and terminated.all() and not infos["final_info"]["feasible"][0]
