"""The arguments of a tuning environment, as one typed object.

``gymnasium.make("DeadTime/PID-v3", budget=6)`` fills an :class:`EnvConfig` from its keyword arguments
(the registered ones of the id first: :mod:`envs`); the environment hands each field to the part that
reads it:

==========================================================  ==============================================
fields                                                      read by
==========================================================  ==============================================
``family``, ``family_config``                               :class:`envs.plant_source.PlantSource`
``noise_std``, ``identification``, ``amplitude_limit``,     :class:`envs.episode_options.EpisodeOptions`
``disturbances``, ``measured_observation``,                 (the experiments and the identification)
``experiment_set``
``constraints``, ``weights``, ``violation_cost``            :func:`envs.tuning_episode.scoring_of` (the score)
``action``                                                  :class:`envs.design_map.DesignMap`
``design_features``, ``design_step``                        :class:`envs.observation.ObservationLayout`
``experiments``, ``budget``, ``excursion_limit``, ``plan``,  :func:`envs.modes.mode_of` (the ways of
``design_step``, ``discrete_action``                        interacting: fixed, plan, agent, discrete)
``render_mode``                                             :class:`envs.tuning_env.DeadTimeTuningEnv`
==========================================================  ==============================================

The eight fields that tell the versions apart are ``action``, ``design_features``, ``weights``,
``amplitude_limit``, ``design_step``, ``violation_cost``, ``measured_observation`` and
``experiment_set`` (:mod:`envs` registers them); the meaning of each field is in the environments'
Arguments table (docs/environments/).  A bad value raises one ``ValueError`` naming the argument when
the environment is made; an unknown argument a ``TypeError`` naming it.
"""

from __future__ import annotations

from dataclasses import dataclass, fields, replace
from typing import Any, Mapping

from envs.analysis.scoring import Constraints, CostWeights

__all__ = ["EnvConfig", "ARGUMENTS"]


@dataclass(frozen=True)
class EnvConfig:
    """Every argument of a tuning environment, defaults those of the ``-v0`` ids.

    Attributes
    ----------
    experiments : {"fixed", "agent", "plan"}
        The mode: the fixed procedure then one design step; experiments chosen one step at a time
        (budget ``budget``); or the fixed procedure's two amplitudes, then the design.
    family : str or None
        The plant family (:mod:`envs.systems.families`); None: the structure's own.
    family_config : object
        The family's config dataclass (its parameter ranges), a dict of its fields, or None.
    noise_std : float
        White measurement noise of every experiment, relative to a unit output change.
    constraints : Constraints, dict or None
        The robustness constraints of the score; None: the structure's own.
    weights : CostWeights, dict or None
        The cost's weights; None: ``CostWeights()``.
    budget : int
        Agent mode: experiments per episode (1 to 100).
    excursion_limit : float
        Agent and plan mode: the output limit that stops an experiment.
    render_mode : {None, "rgb_array"}
        ``"rgb_array"``: ``render()`` draws the experiments and the loop.
    action : {"parameter", "residual", "robustness"}
        The design parameter's coordinate (v1-v3: ``"residual"``).
    design_features : bool
        Append the base design's three features to the observation (v1-v3: True).
    identification : {"seeds", "least-squares"}
        The papers' formulas, or least-squares fits of the open-loop records.
    amplitude_limit : float or None
        The largest experiment amplitude (v2-v3: 3); None: none.
    disturbances : dict or None
        ``{kind: level}`` beyond the white noise (``"drift"``, ``"load"``).
    design_step : bool
        Agent mode: the commit shows the identification and a step of its own designs (v2-v3: True).
    violation_cost : {"graded", "bounded"}
        How a design that violates the constraints is charged (v3: ``"bounded"``).
    measured_observation : bool
        The observation made of the records only (v3: True).
    experiment_set : {"all", "design"}
        Agent mode's experiment types: all of the plant's kind, or those the design reads (v3: ``"design"``).
    plan : sequence of two floats or None
        Fixed mode: the amplitudes of the fixed procedure's two experiments.
    discrete_action : bool
        Agent mode with ``design_step``: a ``Discrete`` action with ``action_masks()``.
    """

    experiments: str = "fixed"
    family: str | None = None
    family_config: object = None
    noise_std: float = 0.01
    constraints: Constraints | dict | None = None
    weights: CostWeights | dict | None = None
    budget: int = 4
    excursion_limit: float = 5.0
    render_mode: str | None = None
    action: str = "parameter"
    design_features: bool = False
    identification: str = "seeds"
    amplitude_limit: float | None = None
    disturbances: dict | None = None
    design_step: bool = False
    violation_cost: str = "graded"
    measured_observation: bool = False
    experiment_set: str = "all"
    plan: Any = None
    discrete_action: bool = False

    @classmethod
    def from_arguments(cls, owner: str, arguments: Mapping[str, Any], base: EnvConfig | None = None) -> EnvConfig:
        """``base`` (default: the defaults) with the keyword ``arguments`` in place of its fields; an unknown
        one is a ``TypeError`` naming it, worded as Python words an unexpected keyword argument of
        ``owner``'s constructor."""
        unknown = sorted(set(arguments) - set(ARGUMENTS))
        if unknown:
            raise TypeError(f"{owner}.__init__() got an unexpected keyword argument {unknown[0]!r}")
        if base is not None and not isinstance(base, cls):
            raise TypeError(f"{owner}.__init__(): config must be an {cls.__name__} or None, got {type(base).__name__}")
        return replace(base, **arguments) if base is not None else cls(**arguments)


ARGUMENTS: tuple[str, ...] = tuple(f.name for f in fields(EnvConfig))
"""The keyword arguments of every tuning environment, in the order of :class:`EnvConfig`."""
