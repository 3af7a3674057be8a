"""stable-baselines3's ``VecEnv`` over a native vector environment (``vec_env: native``).

``deadtime train`` with ``n_envs: N`` and ``vec_env: native`` steps the id's native vector
environment (:mod:`envs.vector_env`, built by ``gymnasium.make_vec``) instead of N wrapped single
environments in a ``DummyVecEnv``.  The adapter translates:

* seeds: ``VecEnv.seed(seed)`` gives environment ``i`` the seed ``seed + i`` (SB3's rule and the
  training config's), passed to the vector environment's reset as a list;
* autoreset: the vector environment resets in the same step (``AutoresetMode.SAME_STEP``), which is
  what SB3 expects: the observation returned after a done is the new episode's first, and the
  final one is ``infos[i]["terminal_observation"]``;
* infos: each environment's dict holds the final figures (``cost``, ``feasible``, ``parameter``,
  ``experiment_time``), ``terminal_observation``, ``TimeLimit.truncated`` (as ``DummyVecEnv`` sets
  it) and ``episode`` (``r``, ``l``, ``t``) as a ``Monitor`` would write it, so the run's episode
  statistics are the same as with ``dummy``; :meth:`NativeVecEnv.env_is_wrapped` answers True for
  ``Monitor`` for that reason;
* checkpoints: ``env_method("checkpoint_snapshot")`` and ``env_method("checkpoint_restore", ...)``
  save and restore a slot whole (its generator, episode in progress and observation, and the
  monitor's counters), as :class:`agents.training.checkpoints.SnapshotWrapper` does for one
  environment; any other method or attribute is the slot's single environment's.
"""

from __future__ import annotations

import pickle
import time
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv

__all__ = ["NativeVecEnv", "make_native_vec_env"]


def make_native_vec_env(env_id: str, n_envs: int, env_kwargs: dict[str, Any] | None = None) -> NativeVecEnv:
    """``n_envs`` environments of ``env_id`` in its native vector environment, as an SB3 ``VecEnv``."""
    import gymnasium

    from agents.environments import require_registered

    require_registered(env_id)
    if gymnasium.spec(env_id).vector_entry_point is None:
        raise ValueError(f"vec_env: {env_id} has no native vector environment (vector_entry_point); use dummy or subproc")
    vector = gymnasium.make_vec(env_id, num_envs=n_envs, vectorization_mode="vector_entry_point", **dict(env_kwargs or {}))
    return NativeVecEnv(vector)


class NativeVecEnv(VecEnv):
    """An SB3 ``VecEnv`` of a same-step-autoreset Gymnasium vector environment (module docstring)."""

    def __init__(self, vector: Any) -> None:
        from gymnasium.vector import AutoresetMode

        if vector.metadata.get("autoreset_mode") is not AutoresetMode.SAME_STEP:
            raise ValueError("NativeVecEnv needs a vector environment with same-step autoreset")
        self.vector = vector
        self.base = vector.unwrapped  # the vector environment under its wrappers (its slots, their states)
        super().__init__(vector.num_envs, vector.single_observation_space, vector.single_action_space)
        self._actions: np.ndarray | None = None
        self._returns = np.zeros(self.num_envs)
        self._lengths = np.zeros(self.num_envs, dtype=int)
        self._started = time.time()

    # ------------------------------------------------------------------ stepping
    def reset(self) -> np.ndarray:
        seeds = None if all(s is None for s in self._seeds) else list(self._seeds)
        observations, _ = self.vector.reset(seed=seeds, options=self._options[0] or None)
        self._returns[:], self._lengths[:] = 0.0, 0
        self._reset_seeds()
        self._reset_options()
        return observations

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, list[dict]]:
        observations, rewards, terminated, truncated, infos = self.vector.step(self._actions)
        dones = terminated | truncated
        self._returns += rewards
        self._lengths += 1
        final, ended = infos.get("final_info", {}), infos.get("_final_obs", np.zeros(self.num_envs, dtype=bool))
        per_env: list[dict] = [{} for _ in range(self.num_envs)]
        for i in np.flatnonzero(dones):
            info = per_env[i]
            for key, values in final.items():
                if not key.startswith("_") and final.get(f"_{key}", ended)[i]:
                    info[key] = values[i].item()
            info["terminal_observation"] = infos["final_obs"][i] if ended[i] else observations[i]
            info["TimeLimit.truncated"] = bool(truncated[i] and not terminated[i])
            info["episode"] = {"r": round(float(self._returns[i]), 6), "l": int(self._lengths[i]),
                               "t": round(time.time() - self._started, 6)}
            self._returns[i], self._lengths[i] = 0.0, 0
        return observations, rewards.astype(np.float32), dones, per_env

    def close(self) -> None:
        self.vector.close()

    # ------------------------------------------------------------------ slots
    def _indices(self, indices: None | int | Iterable[int]) -> list[int]:
        if indices is None:
            return list(range(self.num_envs))
        return [indices] if isinstance(indices, int) else list(indices)

    def checkpoint_snapshot(self, index: int) -> bytes:
        """Slot ``index`` pickled whole, with its monitor counters."""
        return pickle.dumps((self.base.slot_state(index), float(self._returns[index]), int(self._lengths[index])))

    def checkpoint_restore(self, index: int, snapshot: bytes) -> None:
        """Put back a :meth:`checkpoint_snapshot` into slot ``index``."""
        state, self._returns[index], self._lengths[index] = pickle.loads(snapshot)  # noqa: S301  (our own checkpoint)
        self.base.set_slot_state(index, state)

    def env_method(self, method_name: str, *method_args: Any, indices: None | int | Iterable[int] = None,
                   **method_kwargs: Any) -> list[Any]:
        if method_name == "checkpoint_snapshot":
            return [self.checkpoint_snapshot(i) for i in self._indices(indices)]
        if method_name == "checkpoint_restore":
            return [self.checkpoint_restore(i, *method_args) for i in self._indices(indices)]
        envs = self.base.envs
        return [getattr(envs[i], method_name)(*method_args, **method_kwargs) for i in self._indices(indices)]

    def get_attr(self, attr_name: str, indices: None | int | Iterable[int] = None) -> list[Any]:
        envs = self.base.envs
        return [getattr(envs[i], attr_name) for i in self._indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: None | int | Iterable[int] = None) -> None:
        envs = self.base.envs
        for i in self._indices(indices):
            setattr(envs[i], attr_name, value)

    def env_is_wrapped(self, wrapper_class: type, indices: None | int | Iterable[int] = None) -> list[bool]:
        from stable_baselines3.common.monitor import Monitor

        return [wrapper_class is Monitor for _ in self._indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        return [None for _ in range(self.num_envs)]
