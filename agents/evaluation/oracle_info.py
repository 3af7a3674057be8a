"""The oracle's figures in the final ``info`` of a DeadTime environment.

The environments (``envs``) know nothing of the baselines; this wrapper, in the layer that owns
both, runs :func:`baselines.oracle.oracle` on the episode's true plant and identification when the
design is committed, with the environment's own constraints and weights, and adds its cost and
relative parameter (``mu``, ``T_r/T_n`` or ``T_r/L_n``) to that step's ``info``.  It costs 10-16 ms
per episode (a log grid, then bounded Brent; measured by the learned rule's fits on 1000 training
plants), about ten episodes' worth.

Examples
--------
>>> import gymnasium as gym
>>> import numpy as np
>>> import envs  # registers the ids
>>> from agents.evaluation.oracle_info import OracleInfo
>>> env = OracleInfo(gym.make("DeadTime/PID-v0"))
>>> _ = env.reset(seed=1)
>>> info = env.step(np.array([0.0], dtype=np.float32))[4]
>>> info["oracle_cost"] <= info["cost"] + 1e-9
True
"""

from __future__ import annotations

from typing import Any

import gymnasium

__all__ = ["OracleInfo", "oracle_info"]


def oracle_info(env: Any, search: str = "reference") -> dict[str, float | None]:
    """``oracle_cost`` and ``oracle_parameter`` of the episode ``env`` (:func:`envs.interface.episode_of`, or
    the unwrapped environment, which offers the same ``plant``, ``identification``, ``structure``,
    ``constraints`` and ``weights``), after the design is committed, by the oracle's ``search``
    (:data:`baselines.oracle.SEARCHES`); the fast search adds ``boundary_parameter``, the least
    conservative feasible relative parameter (None where none is feasible)."""
    from baselines.oracle import oracle

    best = oracle(env.plant, env.identification, env.structure, constraints=env.constraints, weights=env.weights,
                  search=search)
    found: dict[str, float | None] = {"oracle_cost": float(best.cost), "oracle_parameter": float(best.relative_parameter)}
    if search == "fast":
        found["boundary_parameter"] = best.feasibility_boundary
    return found


class OracleInfo(gymnasium.Wrapper):
    """Adds ``oracle_cost`` and ``oracle_parameter`` to the ``info`` of the step that ends an episode."""

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict[str, Any]]:
        observation, reward, terminated, truncated, info = self.env.step(action)
        if terminated:
            from envs.interface import episode_of

            info = {**info, **oracle_info(episode_of(self.env))}
        return observation, reward, terminated, truncated, info
