"""``deadtime bench``, part two: environment episodes per second and the environment's share of PPO.

Episodes are played with seeded random actions (``action_space.sample()``).  A rate is the number
of completed episodes (at least ``min_episodes``, over at least ``min_time``) divided by the time at
which the last one completed, measured after the
environments are built and reset once (start-up, worker processes and numba compilation are not
counted).  Vectorized environments hold ``n_envs`` copies: Gymnasium's ``SyncVectorEnv`` (with
same-step autoreset, as stable-baselines3 does), stable-baselines3's ``DummyVecEnv`` and
``SubprocVecEnv`` (one worker process per environment).

The training shares: the agent of a config file (``configs/ppo.yaml``: PPO, one rollout of
``n_steps`` and its update; ``configs/sac.yaml``: SAC, the demo's agent, some steps after its
``learning_starts``), one environment wrapped in a timer of ``reset`` and ``step``; the share is
the timed environment time over the wall time of ``learn``.
"""

from __future__ import annotations

import contextlib
import functools
import time
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np

__all__ = ["EnvTimer", "episodes_per_s", "make_env", "training_env_share", "vector_episodes_per_s"]


def make_env(env_id: str, experiments: str, oracle: bool, wrapper: Callable | None = None):
    """A registered DeadTime environment (importable by worker processes); ``oracle``: with the
    oracle's cost in the final ``info`` (:class:`~agents.evaluation.oracle_info.OracleInfo`)."""
    from agents.environments import make_env as make

    env = make(env_id, {"experiments": experiments}, oracle=oracle)
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


class EnvTimer:
    """Accumulated wall time of the wrapped environments' ``reset`` and ``step`` (a Gymnasium
    environment, :meth:`wrap`) or ``reset`` and ``step_wait`` (an SB3 ``VecEnv``, :meth:`wrap_vec`)."""

    def __init__(self) -> None:
        self.seconds = 0.0
        self.steps = 0

    @contextlib.contextmanager
    def timing(self) -> Iterator[None]:
        """Add the wall time of the block to :attr:`seconds`."""
        start = time.perf_counter()
        try:
            yield
        finally:
            self.seconds += time.perf_counter() - start

    def wrap(self, env):
        import gymnasium

        timer = self

        class Timed(gymnasium.Wrapper):
            def reset(self, **kwargs: Any):
                with timer.timing():
                    return self.env.reset(**kwargs)

            def step(self, action):
                timer.steps += 1
                with timer.timing():
                    return self.env.step(action)

        return Timed(env)

    def wrap_vec(self, venv):
        from stable_baselines3.common.vec_env import VecEnvWrapper

        timer = self

        class Timed(VecEnvWrapper):
            def reset(self):
                with timer.timing():
                    return self.venv.reset()

            def step_wait(self):
                with timer.timing():
                    return self.venv.step_wait()

        return Timed(venv)


def training_env_share(config_file: str, env_id: str, steps: int, overrides: tuple[str, ...] = (),
                       warmup_steps: int = 0) -> dict[str, float]:
    """The environment's share of ``learn`` for the agent of ``config_file`` (see the module docstring).

    The model is that of ``deadtime train --config config_file --env env_id`` with ``overrides``
    (one environment, ``VecNormalize`` as configured); ``warmup_steps`` are learned first and not
    timed (an off-policy algorithm's ``learning_starts`` of random actions without updates).
    """
    import torch
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    from agents.training.config import load_config
    from agents.training.train import new_model

    torch.set_num_threads(1)
    config = load_config(config_file, env_id, ["n_envs=1", "vec_env=dummy", "device=cpu", *overrides])
    timer = EnvTimer()
    vec = DummyVecEnv([functools.partial(make_env, env_id, "fixed", False, timer.wrap)])
    if config.normalize:
        vec = VecNormalize(vec, norm_obs=True, norm_reward=config.normalize_reward)
    model = new_model(config, vec)
    if warmup_steps:
        model.learn(total_timesteps=warmup_steps)
    timer.seconds, timer.steps = 0.0, 0
    start = time.perf_counter()
    model.learn(total_timesteps=steps, reset_num_timesteps=not warmup_steps)
    total = time.perf_counter() - start
    vec.close()
    return {"share": timer.seconds / total, "learn_seconds": total, "env_seconds": timer.seconds, "timesteps": timer.steps}
