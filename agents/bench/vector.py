"""``deadtime bench``, the vector part: the native vector environment against its floor, and PPO with it.

Three measurements, all of fixed-mode episodes with seeded random actions:

* :func:`episode_floor`: the compiled-arithmetic floor of one episode (:mod:`agents.bench.floor`),
  of the single environment (``gymnasium.make``) or of the native vector environment
  (:mod:`envs.vector_env`) with ``n_envs`` slots: the same episodes (seeds) are played once
  untimed, so that every kernel is compiled, then with the compiled calls timed; with
  ``library=True`` the lower bound of a bit-identical episode (the library calls too).
* :func:`native_episodes_per_s`: episodes per second of ``gymnasium.make_vec(id, n)``, counted as
  in :mod:`agents.bench.episodes` (after one reset; at least ``min_time`` and ``min_episodes``).
* :func:`ppo_throughput`: the samples per second of PPO's ``learn`` (``configs/ppo.yaml``, one
  rollout of ``n_steps`` per environment and its update) with ``n_envs`` slots of the native
  vector environment (``vec_env: native``), and the share of it spent inside the environment
  (its ``reset`` and ``step_wait``).
"""

from __future__ import annotations

import contextlib
import time
from typing import Any

import numpy as np

__all__ = ["episode_floor", "native_episodes_per_s", "ppo_throughput"]


def _play(env_id: str, n_envs: int | None, episodes: int, seed: int, timing: Any = None) -> int:
    """Fixed-mode episodes of the single (``n_envs`` None) or the native vector environment, seeded
    ``seed`` (actions too), after a first reset outside ``timing`` (a context manager): each timed
    episode is a step and the reset that follows it.  Returns the number of timed episodes
    (``episodes`` rounded up to whole batches)."""
    import gymnasium

    from agents.environments import make_env

    single = n_envs is None
    env = make_env(env_id, {"experiments": "fixed"}) if single else gymnasium.make_vec(env_id, num_envs=n_envs, experiments="fixed")
    env.action_space.seed(seed)
    env.reset(seed=seed)
    rounds = episodes if single else -(-episodes // n_envs)
    with timing if timing is not None else contextlib.nullcontext():
        for _ in range(rounds):
            env.step(env.action_space.sample())
            if single:
                env.reset()
    env.close()
    return rounds * (1 if single else n_envs)


def episode_floor(env_id: str, n_envs: int | None, episodes: int, seed: int, library: bool = False,
                  warm: bool = False) -> dict[str, Any]:
    """Seconds of compiled calls per episode (and calls per episode, the five costliest kernels); with
    ``library`` the library calls a bit-identical batch would keep are counted too
    (:func:`~agents.bench.floor.compiled_calls_timed`); ``warm``: the kernels are compiled already
    (else these episodes are played once untimed first)."""
    from agents.bench.floor import CompiledTime, compiled_calls_timed

    if not warm:
        _play(env_id, n_envs, episodes, seed)  # compile every kernel these episodes need
    record = CompiledTime()
    played = _play(env_id, n_envs, episodes, seed, compiled_calls_timed(record, library))
    top = sorted(record.by_name.items(), key=lambda item: -item[1])[:5]
    return {"seconds": record.seconds / played, "calls": record.calls / played,
            "top": {name: seconds / played for name, seconds in top}}


def native_episodes_per_s(env_id: str, n_envs: int, min_time: float, seed: int, min_episodes: int = 1) -> float:
    """Episodes per second of the native vector environment with ``n_envs`` slots."""
    import gymnasium

    vec = gymnasium.make_vec(env_id, num_envs=n_envs, experiments="fixed")
    vec.action_space.seed(seed)
    vec.reset(seed=seed)
    episodes, start = 0, time.perf_counter()
    while True:
        vec.step(vec.action_space.sample())
        episodes += n_envs
        elapsed = time.perf_counter() - start
        if elapsed >= min_time and episodes >= min_episodes:
            vec.close()
            return episodes / elapsed


def ppo_throughput(config_file: str, env_id: str, n_envs: int, n_steps: int) -> dict[str, float]:
    """PPO's samples per second of ``learn`` and the environment's share, ``n_envs`` native slots."""
    import torch
    from stable_baselines3.common.vec_env import VecNormalize

    from agents.bench.episodes import EnvTimer
    from agents.training.config import load_config
    from agents.training.native_vec_env import make_native_vec_env
    from agents.training.train import new_model

    torch.set_num_threads(1)
    config = load_config(config_file, env_id, [f"n_envs={n_envs}", "vec_env=native", "device=cpu",
                                               f"hyperparameters.n_steps={n_steps}"])
    timer = EnvTimer()
    vec = timer.wrap_vec(make_native_vec_env(env_id, n_envs, dict(config.env_kwargs)))
    if config.normalize:
        vec = VecNormalize(vec, norm_obs=True, norm_reward=config.normalize_reward)
    model = new_model(config, vec)
    samples = n_steps * n_envs
    timer.seconds = 0.0
    start = time.perf_counter()
    model.learn(total_timesteps=samples)
    total = time.perf_counter() - start
    vec.close()
    return {"samples_per_s": model.num_timesteps / total, "share": timer.seconds / total,
            "learn_seconds": total, "timesteps": model.num_timesteps}
