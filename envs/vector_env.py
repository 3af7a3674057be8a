"""The native vector environments of the fixed mode: N plants reset and stepped per call.

Gymnasium's answer to a per-episode Python overhead is a native vector environment, registered as
the id's ``vector_entry_point`` (as :class:`gymnasium.envs.classic_control.cartpole.CartPoleVectorEnv`
is): ``gymnasium.make_vec("DeadTime/PID-v0", num_envs=32)`` builds a :class:`PIDVectorEnv`.  It lives
beside its single environments (:mod:`envs.tuning_env`), and is the one other module of
:mod:`envs` that imports Gymnasium.

What it does per call, and why it gives the same episodes
--------------------------------------------------------
Each of the ``N`` slots is a plain, unwrapped instance of the single environment class: its
arguments are validated once, and it holds the slot's generator (``np_random``) and episode.  A
reset of the batch runs, slot by slot, exactly the single environment's reset work
(:meth:`~envs.tuning_env.DeadTimeTuningEnv.new_episode`: the plant draw and the fixed procedure,
whose experiments, identification and scoring are the compiled calls of :mod:`envs.simulation`,
:mod:`envs.identification` and :mod:`envs.analysis`); a step validates, clips and maps the N actions
as one array and commits every slot's design
(:meth:`~envs.tuning_env.DeadTimeTuningEnv.commit_design`).  What it leaves out is the single
environment's per-episode Python around those calls: Gymnasium's wrappers and checks, the
thread-limit scope of every call (once per batch here: :mod:`envs.threads`), the observation built
and clipped one plant at a time, and the ``info`` dicts of the plant, model, controller and score.
The observation rows are the same numbers clipped as one array, so slot ``i`` reset with seed
``s`` and given action ``a`` returns bit for bit the observation, reward, termination and cost of
``gymnasium.make(id)`` reset with seed ``s`` and given ``a``; the next episodes continue the slot's
generator as a single environment's ``reset()`` without a seed does (``tests/envs/test_vector_env.py``).

Autoreset: same step
--------------------
A fixed-mode episode is one step: every step terminates every slot.  With Gymnasium's default
``NEXT_STEP`` autoreset every other call would be a reset whose actions are ignored, and half of
an agent's transitions would be dummies; so this environment resets in the same step
(``AutoresetMode.SAME_STEP``, ``metadata["autoreset_mode"]``), as stable-baselines3 expects: ``step``
returns the next episodes' first observations, and the episodes that ended in ``infos["final_obs"]``
(an object array of the final observations, ``infos["_final_obs"]`` its mask) and
``infos["final_info"]`` (``cost``, ``feasible``, ``parameter``, ``experiment_time``, with a
``production`` weight ``experiment_deviation``: arrays over the slots, each with its ``_`` mask).

Only the fixed mode: an agent-mode episode has a different length per slot and most of its time in
experiments chosen one step at a time; ``gymnasium.make_vec(id, n, vectorization_mode="sync")``
vectorizes it.  Rendering is the single environment's.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from envs.threads import single_threaded
from envs.validation import require_real_array
from envs.tuning_env import NO_DESIGN_COST, OBSERVATION_BOUND, DeadTimeTuningEnv, FPPIEnv, MSPEnv, PIDEnv, PIEnv

__all__ = ["DeadTimeVectorEnv", "PIDVectorEnv", "FPPIVectorEnv", "MSPVectorEnv"]

FINAL_INFO = ("cost", "feasible", "parameter", "experiment_time")
"""The keys of ``infos["final_info"]`` (and ``experiment_deviation`` with a production weight)."""


class DeadTimeVectorEnv(VectorEnv):
    """``num_envs`` fixed-mode episodes of :attr:`single_class` per call (module docstring).

    Parameters
    ----------
    num_envs : int
        Number of slots (plants per call), >= 1.
    **kwargs
        The single environment's arguments (:class:`~envs.tuning_env.PIDEnv`); ``experiments`` must
        be ``"fixed"`` and ``render_mode`` None.
    """

    metadata = {"autoreset_mode": AutoresetMode.SAME_STEP, "render_modes": []}
    single_class: type[DeadTimeTuningEnv] = PIDEnv

    def __init__(self, num_envs: int = 1, **kwargs: Any) -> None:
        if isinstance(num_envs, bool) or not isinstance(num_envs, (int, np.integer)) or num_envs < 1:
            raise ValueError(f"num_envs must be an integer >= 1, got {num_envs!r}")
        if kwargs.get("experiments", "fixed") != "fixed":
            raise ValueError(f"experiments: the native vector environment runs the fixed mode only, got "
                             f"{kwargs['experiments']!r} (vectorize the agent mode with vectorization_mode='sync')")
        if kwargs.get("render_mode") is not None:
            raise ValueError("render_mode: the native vector environment does not render; use gymnasium.make")
        kwargs.pop("max_episode_steps", None)  # gymnasium.make_vec passes the spec's (None: episodes are one step)
        self.num_envs = int(num_envs)
        self.envs = [self.single_class(**kwargs) for _ in range(self.num_envs)]
        first = self.envs[0]
        self.single_observation_space = first.observation_space
        self.single_action_space = first.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.render_mode = None
        self._final_keys = FINAL_INFO + (("experiment_deviation",) if first.weights.production else ())
        self._observations: np.ndarray | None = None  # of the episodes in progress

    # ------------------------------------------------------------------ episodes
    @single_threaded
    def reset(self, *, seed: int | list[int | None] | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        """Start an episode in every slot; ``seed`` an int (slot ``i`` gets ``seed + i``), a list of
        one seed (or None) per slot, or None (each slot's generator continues)."""
        if options:
            raise ValueError(f"reset options: the native vector environment takes none, got {sorted(options)}")
        for env, slot_seed in zip(self.envs, self._slot_seeds(seed)):
            if slot_seed is not None:
                env._np_random, env._np_random_seed = seeding.np_random(slot_seed)  # noqa: SLF001  (Env.reset's seeding)
            env.new_episode()
        self._observations = self._observe()
        return self._observations.copy(), {}

    def _slot_seeds(self, seed: int | list[int | None] | None) -> list[int | None]:
        if seed is None:
            return [None] * self.num_envs
        if isinstance(seed, bool) or not isinstance(seed, int | np.integer | list | tuple):
            raise ValueError(f"seed must be None, an integer >= 0 or a list of one per slot, got {seed!r}")
        if isinstance(seed, (int, np.integer)) and not isinstance(seed, bool):
            return [int(seed) + i for i in range(self.num_envs)]
        seeds = list(seed)
        if len(seeds) != self.num_envs:
            raise ValueError(f"seed: a list needs one seed per slot ({self.num_envs}), got {len(seeds)}")
        return seeds

    @single_threaded
    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict]:
        """Commit every slot's design, then start the slots' next episodes (same-step autoreset)."""
        if self._observations is None:
            raise RuntimeError("step() called before reset()")
        parameters = self._parameter_actions(actions)
        final = {key: np.empty(self.num_envs, dtype=bool if key == "feasible" else np.float64) for key in self._final_keys}
        for i, env in enumerate(self.envs):
            if env.identification is None:  # a v3 start whose ten draws identified nothing: no design
                final["cost"][i], final["feasible"][i], final["parameter"][i] = NO_DESIGN_COST, False, np.nan
            else:
                relative, _, result = env.commit_design(parameters[i])
                final["cost"][i], final["feasible"][i], final["parameter"][i] = result.cost, result.feasible, relative
            final["experiment_time"][i] = env.evidence.experiment_time / env.plant.residence_time
            if "experiment_deviation" in final:
                final["experiment_deviation"][i] = env.evidence.experiment_deviation / env.plant.residence_time
            env.new_episode()
        rewards = -final["cost"]
        done = np.ones(self.num_envs, dtype=bool)
        final_obs = np.empty(self.num_envs, dtype=object)
        final_obs[:] = list(self._observations)  # the final observation of a fixed-mode episode is its first
        final_info = {**final, **{f"_{key}": done.copy() for key in final}}
        infos = {"final_obs": final_obs, "_final_obs": done.copy(), "final_info": final_info, "_final_info": done.copy()}
        self._observations = self._observe()
        return self._observations.copy(), rewards, done, np.zeros(self.num_envs, dtype=bool), infos

    def _parameter_actions(self, actions: Any) -> np.ndarray:
        """The actions' design parameter coordinates, validated and clipped as one array."""
        values = require_real_array(actions, "actions")  # booleans, complex numbers and text refused; finite
        if values.shape not in ((self.num_envs, 1), (self.num_envs,)):
            raise ValueError(f"actions must have shape {self.action_space.shape}, got {values.shape}")
        return np.clip(values.reshape(self.num_envs), -1.0, 1.0)

    def _observe(self) -> np.ndarray:
        """The slots' observations: their features clipped to the bounds as one array, float32."""
        values = np.stack([env.feature_values() for env in self.envs])
        return np.clip(values, -OBSERVATION_BOUND, OBSERVATION_BOUND).astype(np.float32)

    # ------------------------------------------------------------------ slots
    def slot_state(self, index: int) -> tuple[DeadTimeTuningEnv, np.ndarray | None]:
        """Slot ``index``'s environment (generator and episode in progress) and observation, for a checkpoint."""
        return self.envs[index], None if self._observations is None else self._observations[index].copy()

    def set_slot_state(self, index: int, state: tuple[DeadTimeTuningEnv, np.ndarray | None]) -> None:
        """Put back a :meth:`slot_state` (the other slots must hold episodes too before :meth:`step`)."""
        env, observation = state
        self.envs[index] = env
        if observation is not None:
            if self._observations is None:
                self._observations = np.zeros(self.observation_space.shape, dtype=np.float32)
            self._observations[index] = observation


class PIDVectorEnv(DeadTimeVectorEnv):
    """:class:`~envs.tuning_env.PIDEnv`, fixed mode, ``num_envs`` plants per call (module docstring)."""

    single_class = PIDEnv


class FPPIVectorEnv(DeadTimeVectorEnv):
    """:class:`~envs.tuning_env.FPPIEnv`, fixed mode, ``num_envs`` plants per call (module docstring)."""

    single_class = FPPIEnv


class MSPVectorEnv(DeadTimeVectorEnv):
    """:class:`~envs.tuning_env.MSPEnv`, fixed mode, ``num_envs`` plants per call (module docstring)."""

    single_class = MSPEnv


class PIVectorEnv(DeadTimeVectorEnv):
    """:class:`~envs.tuning_env.PIEnv`, fixed mode, ``num_envs`` plants per call (module docstring)."""

    single_class = PIEnv
