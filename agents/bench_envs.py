"""``deadtime bench``, part two: environment episodes per second and the environment's share of PPO.

Episodes are played with seeded random actions (``action_space.sample()``).  A rate is the number
of completed episodes (at least ``min_episodes``, over at least ``min_time``) divided by the time at
which the last one completed, measured after the
environments are built and reset once (start-up, worker processes and numba compilation are not
counted).  Vectorized environments hold ``n_envs`` copies: Gymnasium's ``SyncVectorEnv`` (with
same-step autoreset, as stable-baselines3 does), stable-baselines3's ``DummyVecEnv`` and
``SubprocVecEnv`` (one worker process per environment).

The PPO share: stable-baselines3 PPO with the hyperparameters of ``configs/ppo.yaml`` (``n_steps``
possibly reduced), each environment wrapped in a timer of ``reset`` and ``step``; the share is the
timed environment time over the wall time of ``PPO.learn`` for ``n_steps`` steps (one rollout and
one update).
"""

from __future__ import annotations

import functools
import time
from collections.abc import Callable
from typing import Any

import numpy as np

__all__ = ["episodes_per_s", "make_env", "ppo_env_share", "vector_episodes_per_s"]


def make_env(env_id: str, experiments: str, oracle: bool, wrapper: Callable | None = None):
    """A registered DeadTime environment (importable by worker processes)."""
    import gymnasium

    import envs  # noqa: F401  (registers the ids)

    env = gymnasium.make(env_id, experiments=experiments, oracle=oracle)
    return wrapper(env) if wrapper is not None else env


def episodes_per_s(
    env_id: str, experiments: str, oracle: bool, min_time: float, seed: int, min_episodes: int = 1
) -> float:
    """Episodes per second of one environment (see the module docstring)."""
    env = make_env(env_id, experiments, oracle)
    env.action_space.seed(seed)
    env.reset(seed=seed)
    episodes, last, start = 0, 0.0, time.perf_counter()
    while True:
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        if terminated or truncated:
            episodes += 1
            last = time.perf_counter() - start
            if last >= min_time and episodes >= min_episodes:
                break
            env.reset()
    env.close()
    return episodes / last


def _vector_env(kind: str, factory: Callable, n_envs: int):
    if kind == "sync":
        import gymnasium.vector

        return gymnasium.vector.SyncVectorEnv([factory] * n_envs, autoreset_mode=gymnasium.vector.AutoresetMode.SAME_STEP)
    from stable_baselines3.common.vec_env import DummyVecEnv, SubprocVecEnv

    if kind == "dummy":
        return DummyVecEnv([factory] * n_envs)
    if kind == "subproc":
        return SubprocVecEnv([factory] * n_envs)
    raise ValueError(f"kind must be sync, dummy or subproc; got {kind!r}")


def vector_episodes_per_s(
    kind: str, env_id: str, experiments: str, oracle: bool, n_envs: int, min_time: float, seed: int,
    min_episodes: int = 1,
) -> float:
    """Episodes per second of ``n_envs`` environments stepped together (see the module docstring)."""
    factory = functools.partial(make_env, env_id, experiments, oracle)
    vec = _vector_env(kind, factory, n_envs)
    space = vec.single_action_space if kind == "sync" else vec.action_space
    space.seed(seed)
    if kind == "sync":
        vec.reset(seed=seed)
    else:
        vec.seed(seed)
        vec.reset()
    episodes, last, start = 0, 0.0, time.perf_counter()
    try:
        while True:
            actions = np.stack([space.sample() for _ in range(n_envs)])
            if kind == "sync":
                _, _, terminated, truncated, _ = vec.step(actions)
                done = np.logical_or(terminated, truncated)
            else:
                _, _, done, _ = vec.step(actions)
            if np.any(done):
                episodes += int(np.sum(done))
                last = time.perf_counter() - start
                if last >= min_time and episodes >= min_episodes:
                    return episodes / last
    finally:
        vec.close()


class _Timer:
    """Accumulated wall time of the wrapped environments' ``reset`` and ``step``."""

    def __init__(self) -> None:
        self.seconds = 0.0
        self.steps = 0

    def wrap(self, env):
        import gymnasium

        timer = self

        class Timed(gymnasium.Wrapper):
            def reset(self, **kwargs: Any):
                start = time.perf_counter()
                try:
                    return self.env.reset(**kwargs)
                finally:
                    timer.seconds += time.perf_counter() - start

            def step(self, action):
                start = time.perf_counter()
                try:
                    return self.env.step(action)
                finally:
                    timer.seconds += time.perf_counter() - start
                    timer.steps += 1

        return Timed(env)


def ppo_env_share(env_id: str, n_steps: int, seed: int) -> dict[str, float]:
    """PPO (``configs/ppo.yaml`` settings, ``n_steps`` per rollout, one rollout): the env's share of ``learn``."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    torch.set_num_threads(1)
    timer = _Timer()
    vec = VecNormalize(DummyVecEnv([functools.partial(make_env, env_id, "fixed", False, timer.wrap)]))
    model = PPO(
        "MlpPolicy", vec, n_steps=n_steps, batch_size=min(64, n_steps), n_epochs=10, learning_rate=3e-4,
        gamma=0.99, clip_range=0.2, ent_coef=0.0, seed=seed, device="cpu", verbose=0,
        policy_kwargs={"net_arch": [64, 64], "activation_fn": torch.nn.Tanh, "log_std_init": -0.5},
    )  # fmt: skip
    timer.seconds, timer.steps = 0.0, 0
    start = time.perf_counter()
    model.learn(total_timesteps=n_steps)
    total = time.perf_counter() - start
    vec.close()
    return {
        "env_share_of_ppo_time": timer.seconds / total,
        "ppo_learn_seconds": total,
        "ppo_env_seconds": timer.seconds,
        "ppo_timesteps": timer.steps,
    }
