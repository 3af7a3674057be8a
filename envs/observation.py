"""What an agent observes of an episode: the features of its evidence, the design features, the design step.

Reads the arguments ``design_features`` and ``design_step`` (:class:`envs.env_config.EnvConfig`; the
design step is the plan mode's too).  The entries are those of the environments' Observation Space
(docs/environments/): :func:`envs.episode.features` of the evidence, then with ``design_features`` the
three of :func:`envs.base_design.design_features`, then with a design step its flag.
"""

from __future__ import annotations

import numpy as np

from envs.base_design import DESIGN_FEATURES, design_features
from envs.episode import Evidence, feature_names, features
from envs.tuning_episode import TuningEpisode

__all__ = ["OBSERVATION_BOUND", "ObservationLayout"]

OBSERVATION_BOUND = 5.0
"""The observation's entries are the features clipped to ``[-OBSERVATION_BOUND, OBSERVATION_BOUND]``."""


class ObservationLayout:
    """The observation of an episode whose empty evidence is ``evidence`` (its experiment types and options).

    Attributes
    ----------
    feature_names : tuple of str
        The names of the observation's entries, in order.
    experiment_names : tuple of str
        The episode's experiment types (:attr:`envs.episode.Evidence.experiments`).
    """

    def __init__(self, evidence: Evidence, budget: int, *, design_features: bool, design_step: bool) -> None:
        self.budget, self.design_features, self.design_step = budget, design_features, design_step
        self.experiment_names = evidence.experiments
        names = feature_names(evidence) + (DESIGN_FEATURES if design_features else ())
        self.feature_names = names + (("design_step",) if design_step else ())

    def values(self, episode: TuningEpisode) -> np.ndarray:
        """The features of the episode so far (float64, not clipped), in the order of :attr:`feature_names`."""
        values = features(episode.evidence, self.budget)
        if self.design_features:
            extra = design_features(episode.structure, episode.identification)  # zero in agent mode until the commit
            values = np.concatenate([values, list(extra.values())])
        if self.design_step:
            values = np.concatenate([values, [float(episode.design_pending)]])
        return values

    def observe(self, episode: TuningEpisode) -> tuple[np.ndarray, dict[str, float]]:
        """The observation (features clipped to the bounds, float32) and the features by name."""
        values = self.values(episode)
        observation = np.clip(values, -OBSERVATION_BOUND, OBSERVATION_BOUND).astype(np.float32)
        return observation, dict(zip(self.feature_names, values.tolist()))
