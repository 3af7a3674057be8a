"""What agents, rules and studies read of a tuning environment, through any wrappers.

``gymnasium.make`` wraps an environment (order enforcing, the passive checker, ``TimeLimit``); what lies
under the wrappers is reached once, as Gymnasium's ``Env.unwrapped`` does, by these two functions:

* :func:`episode_of`: the episode in progress (:class:`envs.tuning_episode.TuningEpisode`): the true
  ``plant``, the ``identification`` and ``evidence`` of its experiments, ``model()`` (the identified model
  the design reads), the design map (``parameter_from_action``, ``action_from_parameter``,
  ``base_parameter()``), ``design(relative)``, and the score on the true plant (``score_controller``,
  ``score_parameter``, ``score_action``), with its ``constraints``, ``weights`` and ``options``;
* :func:`tuning_env_of`: the environment (:class:`envs.tuning_env.DeadTimeTuningEnv`): its ``config``
  (:class:`envs.env_config.EnvConfig`), ``structure``, ``family``, ``plan``, ``budget``, the observation's
  ``feature_names`` and ``feature_values()``, the agent mode's ``experiment_names``, ``discrete`` (the
  discrete action's layout) and ``observe(identification, evidence)`` for experiments run elsewhere.

docs/environments/overview.md, "The episode's interface", lists them.  Nothing here imports Gymnasium.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from envs.tuning_env import DeadTimeTuningEnv
    from envs.tuning_episode import TuningEpisode

__all__ = ["episode_of", "tuning_env_of"]


def tuning_env_of(env: Any) -> DeadTimeTuningEnv:
    """The tuning environment under ``env``'s wrappers (``env`` itself if it has none)."""
    return env.unwrapped


def episode_of(env: Any) -> TuningEpisode:
    """The episode of the tuning environment under ``env``'s wrappers."""
    return env.unwrapped.episode
