"""The agent mode's discrete action: an experiment at an amplitude level, a commit, or a design level.

``discrete_action=True`` (agent mode with a design step, v2-v3) replaces the agent mode's ``Box``
action by ``Discrete(N)``, for learners that choose among actions (sb3-contrib's ``MaskablePPO``).
Every index means what one ``Box`` action means, so an episode of discrete actions is the episode of
the equivalent ``Box`` actions, the amplitudes and design levels taken exactly:

=====================================  =====================================================================
index                                  meaning
=====================================  =====================================================================
``0 .. L-1``                           commit: the identification is completed (the fixed procedure's
                                       missing experiments at amplitude level ``l``) and shown
``L + t L + l``, ``t < n``             run experiment type ``t`` (:attr:`experiment_names`) at level ``l``
``L + n L + p``, ``p < P``             the design step's parameter: the residual action
                                       :data:`DESIGN_LEVELS` ``[p]`` (0: the base rule)
=====================================  =====================================================================

with ``L`` the :data:`AMPLITUDE_LEVELS` and ``n`` the experiment types.  :func:`action_masks` says which
indices mean something in the episode's state: in the design step only the design levels; before it,
the commits, and the experiments while the budget lasts; amplitude levels above the amplitude limit
(cut to it, they repeat the limit's level) are masked.  An index the mask excludes still acts, as its
``Box`` action does: an experiment beyond the budget commits, a design level before the design step
commits at amplitude 1 (cut to the limit), any other index in the design step designs at the base rule.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
import numpy as np

__all__ = ["AMPLITUDE_LEVELS", "DESIGN_LEVELS", "DiscreteAction", "DiscreteLayout"]

AMPLITUDE_LEVELS: tuple[float, ...] = (0.1, 0.3, 1.0, 3.0, 10.0)
"""The experiment amplitudes of the discrete action (relative to a unit output change): the plans'
grid and the range's top, about a factor 3 apart over :data:`envs.episode_options.AMPLITUDE_RANGE`."""
DESIGN_LEVELS: tuple[float, ...] = tuple(round(-1.0 + 0.1 * k, 1) for k in range(21))
"""The design step's residual actions: -1 to 1 in steps of 0.1 (0 is the structure's base rule; the
residual scale of :func:`envs.base_design.residual_parameter`)."""


@dataclass(frozen=True)
class DiscreteAction:
    """What one index means: ``kind`` is ``"commit"``, an experiment type or ``"design"``; ``value``
    the amplitude (commit, experiment) or the residual action (design)."""

    kind: str
    value: float

    @property
    def name(self) -> str:
        return f"{self.kind}@{self.value:g}"


@dataclass(frozen=True)
class DiscreteLayout:
    """The indices of the discrete action of an environment with these experiment types (their meanings
    made once: :meth:`meaning` runs at every step)."""

    experiment_names: tuple[str, ...]

    @cached_property
    def actions(self) -> tuple[DiscreteAction, ...]:
        commits = [DiscreteAction("commit", a) for a in AMPLITUDE_LEVELS]
        runs = [DiscreteAction(kind, a) for kind in self.experiment_names for a in AMPLITUDE_LEVELS]
        designs = [DiscreteAction("design", p) for p in DESIGN_LEVELS]
        return tuple(commits + runs + designs)

    @property
    def size(self) -> int:
        return len(self.actions)

    def meaning(self, index: int) -> DiscreteAction:
        return self.actions[index]

    def masks(self, *, design_pending: bool, budget_left: bool, amplitude_limit: float) -> np.ndarray:
        """Which indices mean something in this state (module docstring)."""
        levels = np.array([k == 0 or a <= amplitude_limit for k, a in enumerate(AMPLITUDE_LEVELS)])
        designs = np.full(len(DESIGN_LEVELS), design_pending)
        runs = np.tile(levels & (budget_left and not design_pending), len(self.experiment_names))
        return np.concatenate([levels & (not design_pending), runs, designs])

