"""Training against a risk limit (agents.training.dual_ascent, agents.training.lagrangian).

* The multiplier on synthetic violation streams: it rises while the rate is above the risk, falls
  back to exactly 0 once it is below, and each step is the dual ascent's formula, recomputed by hand.
* The settings: bad keys and values named in one line.
* The wrapper and the replay buffer: ``reward - lambda * cost``, the buffer with the current lambda
  at each sampling (and the plain samples at lambda 0), checked against the stored arrays.
* A short training run through ``deadtime train``'s config machinery: the multiplier recorded, the
  model loadable by the package's loader (slow).
"""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401
from agents.training.dual_ascent import DualAscent, LagrangianSettings


def _stream(rate: float, count: int, seed: int) -> np.ndarray:
    return (np.random.default_rng(seed).random(count) < rate).astype(float)


def test_multiplier_rises_above_the_risk_and_returns_to_zero_below() -> None:
    settings = LagrangianSettings(risk=0.01, multiplier_lr=1.0, window=100)
    dual = DualAscent(settings)
    trace = [dual.observe(cost) for cost in _stream(0.10, 2000, 0)]
    assert trace[settings.window - 2] == 0.0 and trace[-1] > 100  # about (0.10 - 0.01) per episode: 171
    assert all(b >= a for a, b in zip(trace[500::100], trace[600::100]))
    # no violation any more: once the window holds only these, the multiplier falls 0.01 a step to 0, and stays
    high = trace[-1] + settings.multiplier_lr * settings.window
    trace = [dual.observe(0.0) for _ in range(settings.window + int(high / settings.risk) + 100)]
    after = trace[settings.window - 1:]
    assert all(b <= a for a, b in zip(after, after[1:]))
    assert after[-1] == 0.0 and trace.index(0.0) < len(trace) - 100
    assert dual.history[-1][0] == dual.episodes - dual.episodes % settings.window


def test_each_update_is_the_projected_dual_step() -> None:
    settings = LagrangianSettings(risk=0.05, multiplier_lr=0.3, initial=0.2, window=7)
    dual, costs = DualAscent(settings), _stream(0.2, 300, 2)
    expected = settings.initial
    for k, cost in enumerate(costs):
        dual.observe(cost)
        if k + 1 >= settings.window:
            rate = costs[k + 1 - settings.window: k + 1].mean()
            expected = max(0.0, expected + settings.multiplier_lr * (rate - settings.risk))
        assert dual.multiplier == pytest.approx(expected, rel=1e-12, abs=1e-12)


def test_a_rate_at_the_risk_leaves_the_multiplier_near_its_start() -> None:
    dual = DualAscent(LagrangianSettings(risk=0.5, multiplier_lr=0.1, initial=5.0, window=2))
    for cost in [1.0, 0.0] * 500:  # every window's mean is exactly the risk
        dual.observe(cost)
    assert dual.multiplier == 5.0


@pytest.mark.parametrize(("value", "message"), [
    ({}, "lagrangian.risk is required"),
    ({"risk": 0.0}, "lagrangian.risk must be a number in (0, 1)"),
    ({"risk": 0.01, "windw": 10}, "did you mean 'window'"),
    ({"risk": 0.01, "window": 0}, "lagrangian.window must be an integer >= 1"),
    ({"risk": 0.01, "initial": -1}, "lagrangian.initial must be a number >= 0"),
    ({"risk": 0.01, "multiplier_lr": "fast"}, "lagrangian.multiplier_lr must be a number"),
    ([0.01], "lagrangian must be a mapping"),
])
def test_bad_settings_are_named(value: object, message: str) -> None:
    with pytest.raises(ValueError, match=None) as raised:
        LagrangianSettings.from_mapping(value)
    assert message in str(raised.value)


def test_settings_read_yaml_numbers() -> None:
    settings = LagrangianSettings.from_mapping({"risk": "1e-2", "window": 1e3, "multiplier_lr": 2})
    assert settings == LagrangianSettings(risk=0.01, multiplier_lr=2.0, initial=0.0, window=1000)


def test_config_key_needs_an_off_policy_algorithm_and_overrides_reach_it(tmp_path: Path) -> None:
    from agents.training.config import TrainConfig, load_config

    with pytest.raises(ValueError, match="lagrangian"):
        TrainConfig(algorithm="PPO", env_id="DeadTime/PID-v3", total_timesteps=10, lagrangian={"risk": 0.01})
    config = load_config(Path(__file__).resolve().parents[4] / "configs" / "sac_lagrangian.yaml",
                         overrides=["lagrangian.risk=0.02", "seed=3"])
    assert config.lagrangian_settings.risk == 0.02 and config.seed == 3
    assert dict(TrainConfig.from_dict(config.to_dict()).lagrangian) == dict(config.lagrangian)


def test_wrapper_penalizes_the_violation_only() -> None:
    from agents.training.lagrangian import LagrangianReward

    plain = gym.make("DeadTime/PID-v3")
    wrapped = LagrangianReward(gym.make("DeadTime/PID-v3"), multiplier=7.5)
    seen = set()
    for seed in range(6):
        for action in (-1.0, 1.0):  # the boldest design violates on most plants, the most cautious on few
            plain.reset(seed=seed)
            wrapped.reset(seed=seed)
            _, reward, *_, info = plain.step(np.array([action], dtype=np.float32))
            _, penalized, *_, winfo = wrapped.step(np.array([action], dtype=np.float32))
            violated = not info["feasible"]
            seen.add(violated)
            assert winfo["reward"] == reward and winfo["constraint_cost"] == float(violated)
            assert penalized == reward - 7.5 * violated
    assert seen == {True, False}
    wrapped.set_multiplier(0.0)
    wrapped.reset(seed=0)
    plain.reset(seed=0)
    assert wrapped.step(np.array([-1.0], dtype=np.float32))[1] == plain.step(np.array([-1.0], dtype=np.float32))[1]


def test_buffer_samples_the_current_multiplier() -> None:
    from gymnasium import spaces

    from agents.training.lagrangian import CostReplayBuffer

    buffer = CostReplayBuffer(128, spaces.Box(-1, 1, (2,), np.float32), spaces.Box(-1, 1, (1,), np.float32), n_envs=2)
    rng = np.random.default_rng(0)
    for _ in range(40):
        rewards = -rng.uniform(1, 25, 2).astype(np.float32)
        infos = [{"feasible": bool(f)} for f in rng.random(2) < 0.7]
        buffer.add(rng.random((2, 2)), rng.random((2, 2)), rng.random((2, 1)), rewards, np.ones(2), infos)
    assert set(np.unique(buffer.costs[:40])) == {0.0, 1.0}
    stored = buffer.rewards.copy()
    inds = np.arange(40)
    np.random.seed(1)  # noqa: NPY002  (SB3's buffers draw the environment index from it)
    plain = buffer._get_samples(inds)  # noqa: SLF001
    np.random.seed(1)  # noqa: NPY002
    envs_drawn = np.random.randint(0, 2, size=40)  # noqa: NPY002
    assert np.array_equal(plain.rewards.numpy().ravel(), stored[inds, envs_drawn])
    buffer.dual = DualAscent(LagrangianSettings(risk=0.01, initial=3.0))
    np.random.seed(1)  # noqa: NPY002
    penalized = buffer._get_samples(inds)  # noqa: SLF001
    expected = stored[inds, envs_drawn] - np.float32(3.0) * buffer.costs[inds, envs_drawn]
    assert np.array_equal(penalized.rewards.numpy().ravel(), expected)
    assert np.array_equal(buffer.rewards, stored)  # the stored rewards stay the environment's


@pytest.mark.slow
def test_short_lagrangian_run_records_the_multiplier_and_loads(tmp_path: Path) -> None:
    from agents.cli import main
    from agents.files.reader import read_json
    from agents.training.policies import load_policy

    run = tmp_path / "run"
    status = main(["train", "--config", "configs/sac_lagrangian.yaml", "--out", str(run), "total_timesteps=300",
                   "hyperparameters.learning_starts=64", "hyperparameters.gradient_steps=1", "eval_freq=0",
                   "n_eval_episodes=4", "checkpoint_freq=0", "progress_bar=false",
                   "lagrangian={risk: 0.01, multiplier_lr: 1.0, window: 50}"])
    assert status == 0
    record = read_json(run / "lagrangian.json", dict)
    assert record["episodes"] == 300 - 64 and record["multiplier"] >= 0.0
    assert record["history"][-1]["multiplier"] == record["multiplier"]
    policy = load_policy(run / "model.zip")
    action, _ = policy.predict(np.zeros(policy.model.observation_space.shape, dtype=np.float32))
    assert action.shape == (1,)
