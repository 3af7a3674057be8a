"""Training against a risk limit: the Lagrangian reward, its replay buffer and the multiplier's callback.

A config with ``lagrangian: {risk: r, multiplier_lr: ..., initial: ..., window: ...}``
(:class:`agents.training.dual_ascent.LagrangianSettings`) trains its agent on ``reward - lambda * cost``,
``cost`` the violation (``info["constraint_cost"]``, :class:`envs.tuning_env.ConstraintCost`) and
``lambda`` the multiplier that :class:`MultiplierCallback` moves by dual ascent towards a violation rate
of ``r`` (:mod:`agents.training.dual_ascent`).

Off-policy (SAC, TD3), a transition stays in the replay buffer while ``lambda`` moves.  Storing the
penalized reward would train on the multipliers of the past; :class:`CostReplayBuffer` stores the
reward and the cost apart and combines them with the current ``lambda`` each time it samples, so every
gradient step sees the Lagrangian of the current multiplier (with ``lambda = 0`` the samples are the
plain ones, bit for bit).  The buffer also holds the multiplier's state (:class:`DualAscent`), so that a
checkpoint, which saves the buffer, resumes the multiplier with it.

:class:`LagrangianReward` is the same reward as a Gymnasium wrapper, for an on-policy algorithm trained
from Python (its reward is used once, at the multiplier of its step).

Imports stable-baselines3 (and torch).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
from stable_baselines3.common.buffers import ReplayBuffer
from stable_baselines3.common.callbacks import BaseCallback

from agents.training.dual_ascent import DualAscent, LagrangianSettings
from envs.tuning_env import constraint_cost

__all__ = ["CostReplayBuffer", "LagrangianReward", "MultiplierCallback", "cost_of", "lagrangian_reward"]

HISTORY_FILE = "lagrangian.json"
"""The run directory's record of the multiplier: its settings, final value and history."""


def cost_of(info: dict) -> float:
    """The constraint cost of a step's info: ``info["constraint_cost"]`` if present, else read from ``feasible``."""
    return float(info["constraint_cost"]) if "constraint_cost" in info else constraint_cost(info)


def lagrangian_reward(reward: Any, cost: Any, multiplier: float) -> Any:
    """``reward - multiplier * cost`` (numbers or arrays)."""
    return reward - multiplier * cost


class LagrangianReward(gym.Wrapper):
    """The reward replaced by ``reward - multiplier * cost``; ``info["reward"]`` keeps the environment's,
    ``info["constraint_cost"]`` the cost.  Set :attr:`multiplier` (or call :meth:`set_multiplier`,
    e.g. through a vector environment's ``env_method``) as the multiplier moves."""

    def __init__(self, env: gym.Env, multiplier: float = 0.0) -> None:
        super().__init__(env)
        self.multiplier = float(multiplier)

    def set_multiplier(self, value: float) -> None:
        self.multiplier = float(value)

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        observation, reward, terminated, truncated, info = self.env.step(action)
        cost = cost_of(info)
        info = {**info, "reward": reward, "constraint_cost": cost}
        return observation, float(lagrangian_reward(reward, cost, self.multiplier)), terminated, truncated, info


class CostReplayBuffer(ReplayBuffer):
    """A replay buffer that stores each transition's constraint cost beside its reward and samples
    ``reward - lambda * cost`` with the current multiplier (:attr:`dual`'s, set by :class:`MultiplierCallback`)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.costs = np.zeros((self.buffer_size, self.n_envs), dtype=np.float32)
        self.dual: DualAscent | None = None

    @property
    def multiplier(self) -> float:
        return 0.0 if self.dual is None else self.dual.multiplier

    def add(self, obs: Any, next_obs: Any, action: Any, reward: Any, done: Any, infos: list[dict[str, Any]]) -> None:
        self.costs[self.pos] = np.array([cost_of(info) for info in infos], dtype=np.float32)
        super().add(obs, next_obs, action, reward, done, infos)

    def _get_samples(self, batch_inds: np.ndarray, env: Any = None) -> Any:
        stored = self.rewards
        self.rewards = lagrangian_reward(stored, self.costs, np.float32(self.multiplier))
        try:
            return super()._get_samples(batch_inds, env)
        finally:
            self.rewards = stored


class MultiplierCallback(BaseCallback):
    """Dual ascent on the training episodes' constraint costs; logs ``lagrangian/multiplier`` and
    ``lagrangian/violation_rate`` (the window's mean cost) and writes ``lagrangian.json`` in the run
    directory at the end of training.

    Episodes before the algorithm's ``learning_starts`` (uniformly random actions) are not counted: they
    say nothing of the policy's violations.  The state lives on the model's :class:`CostReplayBuffer`
    (created there on a fresh run, restored with it from a checkpoint).
    """

    def __init__(self, settings: LagrangianSettings, run_dir: Path | None = None) -> None:
        super().__init__()
        self.settings, self.run_dir = settings, run_dir

    @property
    def dual(self) -> DualAscent:
        buffer = self.model.replay_buffer
        if not isinstance(buffer, CostReplayBuffer):
            raise TypeError("the Lagrangian callback needs the model's replay buffer to be a CostReplayBuffer")
        if buffer.dual is None:
            buffer.dual = DualAscent(self.settings)
        return buffer.dual

    def _on_training_start(self) -> None:
        _ = self.dual

    def _on_step(self) -> bool:
        if self.num_timesteps <= getattr(self.model, "learning_starts", 0):
            return True
        dual = self.dual
        for info, done in zip(self.locals["infos"], self.locals["dones"]):
            if done:
                dual.observe(cost_of(info))
        self.logger.record("lagrangian/multiplier", dual.multiplier)
        self.logger.record("lagrangian/violation_rate", dual.rate)
        return True

    def _on_training_end(self) -> None:
        if self.run_dir is None:
            return
        from agents.files.writer import write_json

        dual = self.dual
        dual.record()
        write_json(self.run_dir / HISTORY_FILE, {
            "settings": {"risk": self.settings.risk, "multiplier_lr": self.settings.multiplier_lr,
                         "initial": self.settings.initial, "window": self.settings.window},
            "episodes": dual.episodes, "multiplier": dual.multiplier, "violation_rate": _number(dual.rate),
            "history": [{"episodes": e, "multiplier": m, "violation_rate": _number(r)} for e, m, r in dual.history],
        })


def _number(value: float) -> float | None:
    return value if value == value else None
