"""The arguments of a tuning environment, as one typed object.

``gymnasium.make("DeadTime/PID-v3", budget=6)`` fills an :class:`EnvConfig` from its keyword arguments
(the registered ones of the id first: :mod:`envs`).  The arguments come in groups, one per part of the
environment that reads them:

====================  ====================================================  =================================================
group                 arguments                                             read by
====================  ====================================================  =================================================
:class:`ModeConfig`   ``experiments``, ``budget``, ``excursion_limit``,      :func:`envs.modes.mode_of` (fixed, plan, agent,
                      ``plan``, ``design_step``, ``discrete_action``        discrete agent)
:class:`PlantConfig`  ``family``, ``family_config``                          :class:`envs.plant_source.PlantSource`
:class:`ExperimentConfig`  ``noise_std``, ``identification``,               :class:`envs.episode_options.EpisodeOptions` (the
                      ``amplitude_limit``, ``disturbances``,                experiments and the identification)
                      ``measured_observation``, ``experiment_set``,
                      ``quantization``
:class:`ScoringConfig`  ``constraints``, ``weights``, ``violation_cost``     :func:`envs.tuning_episode.scoring_of`
:class:`DesignConfig`  ``action``, ``design_features``                       :class:`envs.design_map.DesignMap`,
                                                                            :class:`envs.observation.ObservationLayout`
(the config itself)   ``render_mode``                                       :class:`envs.tuning_env.DeadTimeTuningEnv`
====================  ====================================================  =================================================

The eight arguments that tell the versions apart are ``action``, ``design_features``, ``weights``,
``amplitude_limit``, ``design_step``, ``violation_cost``, ``measured_observation`` and
``experiment_set`` (:mod:`envs` registers them); the meaning of each is in the environments'
Arguments table (docs/environments/).  A bad value raises one ``ValueError`` naming the argument when
the environment is made; an unknown argument a ``TypeError`` naming it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from typing import Any, Mapping

from envs.analysis.scoring import Constraints, CostWeights

__all__ = ["EnvConfig", "ModeConfig", "PlantConfig", "ExperimentConfig", "ScoringConfig", "DesignConfig", "ARGUMENTS"]


@dataclass(frozen=True)
class ModeConfig:
    """How the episode is played (:mod:`envs.modes`).

    Attributes
    ----------
    experiments : {"fixed", "agent", "plan"}
        The fixed procedure then one design step; experiments chosen one step at a time; or the fixed
        procedure's two amplitudes in one step, then the design.
    budget : int
        Agent mode: experiments per episode (1 to 100); the observation's counts are over it.
    excursion_limit : float
        Agent and plan modes: the output limit that stops an experiment.
    plan : sequence of two floats or None
        Fixed mode: the amplitudes of the fixed procedure's two experiments.
    design_step : bool
        Agent mode: the commit shows the identification and a step of its own designs (v2-v3: True).
    discrete_action : bool
        Agent mode with ``design_step``: a ``Discrete`` action with ``action_masks()``.
    """

    experiments: str = "fixed"
    budget: int = 4
    excursion_limit: float = 5.0
    plan: Any = None
    design_step: bool = False
    discrete_action: bool = False


@dataclass(frozen=True)
class PlantConfig:
    """Where the plants come from (:class:`envs.plant_source.PlantSource`).

    Attributes
    ----------
    family : str or None
        The plant family (:mod:`envs.systems.families`); None: the structure's own.
    family_config : object
        The family's config dataclass (its parameter ranges), a dict of its fields, or None.
    """

    family: str | None = None
    family_config: object = None


@dataclass(frozen=True)
class ExperimentConfig:
    """How the experiments run and identify (:class:`envs.episode_options.EpisodeOptions`).

    Attributes
    ----------
    noise_std : float
        White measurement noise of every experiment, relative to a unit output change.
    identification : {"seeds", "least-squares"}
        The papers' formulas, or least-squares fits of the open-loop records.
    amplitude_limit : float or None
        The largest experiment amplitude (v2-v3: 3); None: none.
    disturbances : dict or None
        ``{kind: level}`` beyond the white noise (``"drift"``, ``"load"``).
    measured_observation : bool
        The observation made of the records only (v3: True).
    experiment_set : {"all", "design"}
        Agent mode's experiment types: all of the plant's kind, or those the design reads (v3: ``"design"``).
    quantization : float
        The sensor's resolution, in the units of ``noise_std``: every measured output is floored to a
        multiple of it, as the TCLab's sensor does (0: none).
    """

    noise_std: float = 0.01
    identification: str = "seeds"
    amplitude_limit: float | None = None
    disturbances: dict | None = None
    measured_observation: bool = False
    experiment_set: str = "all"
    quantization: float = 0.0


@dataclass(frozen=True)
class ScoringConfig:
    """How a design is scored on the true plant (:func:`envs.tuning_episode.scoring_of`).

    Attributes
    ----------
    constraints : Constraints, dict or None
        The robustness constraints; None: the structure's own.
    weights : CostWeights, dict or None
        The cost's weights; None: ``CostWeights()`` (v2-v3: a production weight of 0.05).
    violation_cost : {"graded", "bounded"}
        How a design that violates the constraints is charged (v3: ``"bounded"``).
    """

    constraints: Constraints | dict | None = None
    weights: CostWeights | dict | None = None
    violation_cost: str = "graded"


@dataclass(frozen=True)
class DesignConfig:
    """The design's action and what the observation shows of the base design.

    Attributes
    ----------
    action : {"parameter", "residual", "robustness"}
        The design parameter's coordinate (:class:`envs.design_map.DesignMap`; v1-v3: ``"residual"``).
    design_features : bool
        Append the base design's three features to the observation (:class:`envs.observation.ObservationLayout`;
        v1-v3: True).
    """

    action: str = "parameter"
    design_features: bool = False


_GROUPS = {"mode": ModeConfig, "plants": PlantConfig, "experiments": ExperimentConfig, "scoring": ScoringConfig,
           "design": DesignConfig}
_GROUP_OF: dict[str, str] = {f.name: group for group, kind in _GROUPS.items() for f in fields(kind)}


@dataclass(frozen=True)
class EnvConfig:
    """Every argument of a tuning environment in its group, defaults those of the ``-v0`` ids
    (module docstring); ``config["budget"]`` reads one argument by its keyword."""

    mode: ModeConfig = field(default_factory=ModeConfig)
    plants: PlantConfig = field(default_factory=PlantConfig)
    experiments: ExperimentConfig = field(default_factory=ExperimentConfig)
    scoring: ScoringConfig = field(default_factory=ScoringConfig)
    design: DesignConfig = field(default_factory=DesignConfig)
    render_mode: str | None = None

    def __getitem__(self, name: str) -> Any:
        if name == "render_mode":
            return self.render_mode
        return getattr(getattr(self, _GROUP_OF[name]), name)

    @classmethod
    def from_arguments(cls, owner: str, arguments: Mapping[str, Any], base: EnvConfig | None = None) -> EnvConfig:
        """``base`` (default: the defaults) with the keyword ``arguments`` in place of its values; an
        unknown one is a ``TypeError`` naming it, worded as Python words an unexpected keyword argument
        of ``owner``'s constructor."""
        unknown = sorted(set(arguments) - set(ARGUMENTS))
        if unknown:
            raise TypeError(f"{owner}.__init__() got an unexpected keyword argument {unknown[0]!r}")
        if base is not None and not isinstance(base, cls):
            raise TypeError(f"{owner}.__init__(): config must be an {cls.__name__} or None, got {type(base).__name__}")
        config = cls() if base is None else base
        changes: dict[str, Any] = {}
        for group in _GROUPS:
            given = {name: value for name, value in arguments.items() if _GROUP_OF.get(name) == group}
            if given:
                changes[group] = replace(getattr(config, group), **given)
        if "render_mode" in arguments:
            changes["render_mode"] = arguments["render_mode"]
        return replace(config, **changes)

    @classmethod
    def defaults(cls) -> dict[str, Any]:
        """Every argument's default, by keyword (in the order of :data:`ARGUMENTS`)."""
        config = cls()
        return {name: config[name] for name in ARGUMENTS}


ARGUMENTS: tuple[str, ...] = (
    "experiments", "family", "family_config", "noise_std", "constraints", "weights", "budget", "excursion_limit",
    "render_mode", "action", "design_features", "identification", "amplitude_limit", "disturbances", "design_step",
    "violation_cost", "measured_observation", "experiment_set", "plan", "discrete_action", "quantization",
)  # fmt: skip
"""The keyword arguments of every tuning environment (in the order of the environments' Arguments table)."""
assert set(ARGUMENTS) == {*_GROUP_OF, "render_mode"}
