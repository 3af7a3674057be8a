"""The design map: from an action in [-1, 1] to the structure's relative design parameter, and back.

Reads the argument ``action`` (:class:`envs.env_config.EnvConfig`): ``"parameter"``, a log scale over
the structure's range (:attr:`envs.structures.Structure.parameter_range`); ``"residual"``, around the
base rule's parameter of the episode's identification; ``"robustness"``, the robustness target of the
loop on the identified model (:mod:`envs.base_design`).
"""

from __future__ import annotations

import math
from typing import Protocol

import numpy as np

from envs.base_design import (
    ACTIONS,
    residual_action,
    residual_parameter,
    robustness_action,
    robustness_parameter,
)
from envs.identification.procedure import Identification
from envs.structures import structure as structure_named
from envs.validation import require_number

__all__ = ["DesignMap"]


class Identified(Protocol):
    """What the map reads of an episode (:class:`envs.tuning_episode.TuningEpisode`)."""

    def identified(self) -> Identification: ...

    def base_parameter(self) -> float: ...


class DesignMap:
    """The action coordinate ``coordinates`` (one of :data:`envs.base_design.ACTIONS`) of ``structure``."""

    def __init__(self, structure: str, coordinates: str = "parameter") -> None:
        if coordinates not in ACTIONS:
            raise ValueError(f"action must be one of {', '.join(ACTIONS)}, got {coordinates!r}")
        self.structure, self.coordinates = structure, coordinates
        self.parameter_range = structure_named(structure).parameter_range

    def parameter_from_action(self, action: float, episode: Identified) -> float:
        """The relative parameter (``mu``, ``T_r/T_n`` or ``T_r/L_n``) of an action in [-1, 1] (clipped to
        it) on ``episode``'s identification."""
        if isinstance(action, float):  # a number (as step() passes it): numpy.clip's value without its call
            a = min(max(float(action), -1.0), 1.0)
        else:
            a = float(np.clip(action, -1.0, 1.0))
        if self.coordinates == "residual":
            return residual_parameter(self.structure, episode.base_parameter(), a)
        if self.coordinates == "robustness":
            return robustness_parameter(self.structure, episode.identified(), a)
        low, high = (math.log(v) for v in self.parameter_range)
        return math.exp(low + 0.5 * (a + 1.0) * (high - low))

    def action_from_parameter(self, parameter: float, episode: Identified) -> float:
        """Inverse of :meth:`parameter_from_action` (clipped to [-1, 1]); for the robustness action, the
        target equal to the parameter's own model-loop figure (:func:`envs.base_design.robustness_action`)."""
        if self.coordinates == "robustness":
            return robustness_action(self.structure, episode.identified(), parameter)
        if self.coordinates == "residual":
            return residual_action(self.structure, episode.base_parameter(), parameter)
        low, high = (math.log(v) for v in self.parameter_range)
        parameter = require_number(parameter, "parameter", positive=True)
        return float(np.clip(2.0 * (math.log(parameter) - low) / (high - low) - 1.0, -1.0, 1.0))
