"""Gymnasium environments: identify a plant with dead time, then choose one design parameter.

An environment is made of parts that read alone: its arguments (:class:`envs.env_config.EnvConfig`),
the episode (:class:`envs.tuning_episode.TuningEpisode`: plant, identification, design, score; the
experiments and features of :mod:`envs.episode`), the way of playing it (:mod:`envs.modes`: fixed,
plan, agent; :mod:`envs.discrete_action`), what is observed (:mod:`envs.observation`), where the plants
come from (:mod:`envs.plant_source`) and the image (:mod:`envs.rendering`).  This module joins them
under Gymnasium's ``Env``.  Ids are registered in :mod:`envs` (``DeadTime/PID-v0``, ``DeadTime/FPPI-v0``,
``DeadTime/MSP-v0``, ...); see the docstrings of :class:`PIDEnv`, :class:`FPPIEnv`, :class:`MSPEnv` and
:class:`PIEnv`.
"""

from __future__ import annotations

import inspect
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from envs.discrete_action import DiscreteLayout
from envs.design_map import DesignMap
from envs.env_cards import (
    FPPI_DESCRIPTION,
    MSP_DESCRIPTION,
    PI_DESCRIPTION,
    PI_VERSION_HISTORY,
    PID_DESCRIPTION,
    SHARED_DOC,
    VERSION_HISTORY,
)
from envs.env_config import EnvConfig
from envs.episode import Evidence
from envs.episode_options import AMPLITUDE_RANGE, EpisodeOptions
from envs.identification.procedure import Identification
from envs.modes import MAX_BUDGET, MODES, DiscreteAgentMode, mode_of
from envs.observation import OBSERVATION_BOUND, ObservationLayout
from envs.plant_source import PlantSource
from envs.rendering import render_episode
from envs.analysis.scoring import Constraints, Score
from envs.structures import Structure, structure as structure_named
from envs.systems.plants import Plant
from envs.threads import single_threaded
from envs.tuning_episode import NO_DESIGN_COST, TuningEpisode, scoring_of

__all__ = ["DeadTimeTuningEnv", "PIDEnv", "FPPIEnv", "MSPEnv", "PIEnv", "MODES", "AMPLITUDE_RANGE", "EnvConfig"]
__all__ += ["ConstraintCost", "constraint_cost"]
__all__ += ["MAX_BUDGET", "NO_DESIGN_COST", "OBSERVATION_BOUND"]  # (the names this module has always offered)

MAX_SAMPLING_ATTEMPTS = 10
"""Plants the fixed mode draws at most for an episode whose procedure identifies the design's model; with
``measured_observation`` (v3) the last one drawn is kept even if it fails, and the episode ends without a
design (``NO_DESIGN_COST``), else (v0-v2) the reset raises ``RuntimeError``."""


class DeadTimeTuningEnv(gym.Env):
    """Base class of the tuning environments; see :class:`PIDEnv` for the full documentation.

    Subclasses set :attr:`structure`, a name of :data:`envs.structures.STRUCTURES`; :attr:`integrating`,
    :attr:`default_family` and :meth:`default_constraints` are the structure's.  The arguments are those
    of :class:`envs.env_config.EnvConfig`, given as keywords (as ``gymnasium.make`` passes them) or as
    ``config`` (the keywords then replace its values).

    The public parts: :attr:`episode` (:class:`envs.tuning_episode.TuningEpisode`, the plant, the
    identification, the design map and the score), :attr:`config`, :attr:`interaction` (the mode,
    :mod:`envs.modes`), :attr:`layout` (the observation, :class:`envs.observation.ObservationLayout`) and
    :attr:`plants` (:class:`envs.plant_source.PlantSource`).
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 1}
    structure: str = "pid"
    integrating: bool = False
    default_family: str = "stable"
    config_class = EnvConfig

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        kind = structure_named(cls.structure)
        cls.integrating, cls.default_family = kind.integrating, kind.family

    def __init__(self, config: EnvConfig | None = None, **kwargs: Any) -> None:
        # (its signature, for inspect and the docs: every argument of EnvConfig by keyword; below the class)
        config = EnvConfig.from_arguments(type(self).__name__, kwargs, config)
        design_map = DesignMap(self.structure, config.design.action)
        if not isinstance(config.design.design_features, bool):
            raise ValueError(f"design_features must be true or false, got {config.design.design_features!r}")
        scoring = scoring_of(self.structure, config.scoring)
        if config.render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {config.render_mode!r}")
        self.config, self.render_mode, self.mode = config, config.render_mode, config.mode.experiments
        family = self.default_family if config.plants.family is None else config.plants.family
        self.plants = PlantSource(type(self).__name__, self.integrating, family, config.plants.family_config)
        options = EpisodeOptions.from_config(self.structure, config.experiments, production=scoring[1].production > 0)
        self.episode = TuningEpisode(self.structure, options, scoring, design_map)
        evidence = Evidence.empty(self.integrating, options)
        self.interaction = mode_of(config.mode, evidence.experiments)
        self.layout = ObservationLayout(evidence, self.interaction.budget, design_features=config.design.design_features,
                                        design_step=self.interaction.design_step)
        if isinstance(self.interaction, DiscreteAgentMode):
            self.action_space = spaces.Discrete(self.interaction.layout.size)
        else:
            self.action_space = spaces.Box(-1.0, 1.0, shape=(self.interaction.size(evidence.experiments),), dtype=np.float32)
        bound = OBSERVATION_BOUND
        self.observation_space = spaces.Box(-bound, bound, shape=(len(self.layout.feature_names),), dtype=np.float32)

    # ------------------------------------------------------------------ the parts' figures
    @property
    def kind(self) -> Structure:
        """The controller structure (:mod:`envs.structures`) named by :attr:`structure`."""
        return structure_named(self.structure)

    @classmethod
    def default_constraints(cls) -> Constraints:
        """The structure's default constraints (:attr:`envs.structures.Structure.constraints`; docs/scoring.md)."""
        return structure_named(cls.structure).constraints

    family = property(lambda self: self.plants.family, doc="The plant family (:attr:`plants`).")
    family_config = property(lambda self: self.plants.family_config, doc="The family's config (:attr:`plants`).")
    options = property(lambda self: self.episode.options, doc="The episode's experiment settings (:class:`envs.episode_options.EpisodeOptions`).")
    noise_std = property(lambda self: self.episode.options.noise_std, doc="The experiments' measurement noise (``noise_std``).")
    constraints = property(lambda self: self.episode.constraints, doc="The score's constraints (:attr:`episode`).")
    weights = property(lambda self: self.episode.weights, doc="The cost's weights (:attr:`episode`).")
    action_coordinates = property(lambda self: self.episode.design_map.coordinates, doc="The ``action`` argument.")
    parameter_range = property(lambda self: self.episode.design_map.parameter_range, doc="The relative parameter's range.")
    budget = property(lambda self: self.interaction.budget, doc="Experiments per episode (agent mode).")
    excursion_limit = property(lambda self: self.interaction.excursion_limit, doc="The output limit that stops an experiment.")
    plan = property(lambda self: getattr(self.interaction, "plan", None), doc="The fixed mode's two amplitudes, or None.")
    design_features = property(lambda self: self.layout.design_features, doc="The observation ends with the design features.")
    design_step = property(lambda self: self.layout.design_step, doc="A step of its own designs (plan mode; agent mode with ``design_step``).")
    feature_names = property(lambda self: self.layout.feature_names, doc="The names of the observation's entries.")
    experiment_names = property(lambda self: self.layout.experiment_names, doc="The agent mode's experiment types.")

    @property
    def discrete(self) -> DiscreteLayout | None:
        """The discrete action's layout (``discrete_action=True``), or None."""
        return self.interaction.layout if isinstance(self.interaction, DiscreteAgentMode) else None

    # ------------------------------------------------------------------ the episode's state
    plant = property(lambda self: self.episode.plant, lambda self, value: setattr(self.episode, "plant", value),
                     doc="The true plant of the episode (:attr:`envs.tuning_episode.TuningEpisode.plant`).")
    identification = property(lambda self: self.episode.identification,
                              lambda self, value: setattr(self.episode, "identification", value),
                              doc="What the experiments identified (:attr:`envs.tuning_episode.TuningEpisode.identification`).")
    evidence = property(lambda self: self.episode.evidence, lambda self, value: setattr(self.episode, "evidence", value),
                        doc="The experiments so far (:attr:`envs.tuning_episode.TuningEpisode.evidence`).")

    # ------------------------------------------------------------------ design and score (the episode's)
    def base_parameter(self) -> float:
        """The residual action's base (:meth:`envs.tuning_episode.TuningEpisode.base_parameter`)."""
        return self.episode.base_parameter()

    def parameter_from_action(self, action: float) -> float:
        """The relative parameter (``mu``, ``T_r/T_n``, ``T_r/L_n`` or ``tau_c/theta``) of an action in
        [-1, 1] (:meth:`envs.design_map.DesignMap.parameter_from_action`); every design of a step reads it."""
        return self.episode.parameter_from_action(action)

    def action_from_parameter(self, parameter: float) -> float:
        """Inverse of :meth:`parameter_from_action` (:meth:`envs.design_map.DesignMap.action_from_parameter`)."""
        return self.episode.action_from_parameter(parameter)

    def model(self) -> Any:
        """The identified model the design reads (SOPDT, FOPDT or integrating)."""
        return self.episode.model()

    def design(self, relative: float) -> Any:
        """The controller for the relative parameter ``relative`` and the current identification."""
        return self.episode.design(relative)

    def score_controller(self, controller: Any) -> Score:
        """The cost of any ``controller`` on the true plant, with this episode's experiment time."""
        return self.episode.score_controller(controller)

    def score_action(self, parameter_action: float) -> tuple[float, Any, Score]:
        """What committing ``parameter_action`` would give, ``(relative parameter, controller, score)``,
        the episode left as it is (a selector scores several designs on one identification)."""
        relative = self.parameter_from_action(parameter_action)
        controller, result = self.episode.score_parameter(relative)
        return relative, controller, result

    def commit_design(self, parameter_action: float) -> tuple[float, Any, Score]:
        """End the episode with the design of ``parameter_action`` (a number in [-1, 1]) on the current
        identification: ``(relative parameter, controller, score)``.  Step's work in the fixed mode
        before its observation and info; the native vector environment commits with it."""
        relative = self.parameter_from_action(parameter_action)
        controller, result = self.episode.commit(relative)
        return relative, controller, result

    # ------------------------------------------------------------------ episode
    @single_threaded
    def reset(self, *, seed: int | None = None, options: dict | None = None) -> tuple[np.ndarray, dict]:
        """Start an episode: draw a plant (or take ``options["plant"]``) and, in the fixed mode, identify it.

        Options
        -------
        plant : Plant, dict, control.TransferFunction or (TransferFunction, dead_time)
            Use this plant instead of drawing one (any form :func:`envs.systems.plants.as_plant` takes).
        """
        if seed is not None and (isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)) or seed < 0):
            raise ValueError(f"seed must be an integer >= 0 or None, got {seed!r}")
        super().reset(seed=seed)
        options = {} if options is None else dict(options)
        unknown = sorted(set(options) - {"plant"})
        if unknown:
            raise ValueError(f"reset options: unknown key {unknown[0]!r}; valid keys: plant")
        self.new_episode(options.get("plant"))
        observation, named = self.observation_and_features()
        return observation, {"plant": self.plant.to_dict(), "features": named}

    def new_episode(self, given: Any = None) -> None:
        """Reset's work before its observation, with the generator as it is: draw a plant (or take
        ``given``, as ``options["plant"]``) and, in the fixed mode, identify it.  The native vector
        environment (:mod:`envs.vector_env`) starts its episodes with it."""
        plant = self.plants.given(given) if given is not None else None
        for attempt in range(MAX_SAMPLING_ATTEMPTS):
            if given is None:
                plant = self.plants.draw(self.np_random)
            try:  # the last draw is kept as a given plant is (measured_observation: an episode without a design)
                self.plants.check_kind(plant)
                self.interaction.start(self, plant, given is not None or attempt == MAX_SAMPLING_ATTEMPTS - 1)
                break
            except ValueError:
                if given is not None:
                    raise
        else:
            raise RuntimeError(f"no plant of family {self.family!r} could be identified in {MAX_SAMPLING_ATTEMPTS} draws")
        self.episode.done, self.episode.controller = False, None

    @single_threaded
    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict]:
        """Run an experiment (agent mode) or commit the design; see the class docstring."""
        if self.episode.done:
            raise RuntimeError("step() called on a finished episode; call reset() first")
        return self.interaction.step(self, action)

    def action_masks(self) -> np.ndarray:
        """``discrete_action=True``: which indices mean something now (sb3-contrib's ``MaskablePPO``
        reads it; :meth:`envs.discrete_action.DiscreteLayout.masks`)."""
        if not isinstance(self.interaction, DiscreteAgentMode):
            raise RuntimeError("action_masks() needs discrete_action=True")
        return self.interaction.masks(self.episode)

    def observe(self, identification: Identification, evidence: Evidence) -> np.ndarray:
        """The observation of experiments run elsewhere (a real process: ``agents.evaluation.process_policies``):
        ``identification`` and ``evidence`` become the episode's, with no plant to score a design on (the
        episode is over for :meth:`step`); in plan mode the design step is the one pending."""
        self.episode.observe(identification, evidence, design_pending=self.mode == "plan")
        return self.observation_and_features()[0]

    def render(self) -> np.ndarray | None:
        """``render_mode="rgb_array"``: an image of the experiments so far and, once the design is
        committed, of its loop on the true plant (:func:`envs.rendering.render_episode`)."""
        if self.render_mode != "rgb_array" or self.episode.evidence is None:
            return None
        return render_episode(self.episode)

    # ------------------------------------------------------------------ observation
    def feature_values(self) -> np.ndarray:
        """The features of the episode so far (float64, not clipped), in the order of :attr:`feature_names`."""
        return self.layout.values(self.episode)

    def observation_and_features(self) -> tuple[np.ndarray, dict[str, float]]:
        """The observation (features clipped to the bounds, float32) and the features by name."""
        return self.layout.observe(self.episode)



DeadTimeTuningEnv.__init__.__signature__ = inspect.Signature([
    inspect.Parameter("self", inspect.Parameter.POSITIONAL_OR_KEYWORD),
    inspect.Parameter("config", inspect.Parameter.POSITIONAL_OR_KEYWORD, default=None),
    *(inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, default=value) for name, value in EnvConfig.defaults().items()),
])

class PIDEnv(DeadTimeTuningEnv):
    __doc__ = PID_DESCRIPTION + SHARED_DOC + VERSION_HISTORY
    structure = "pid"


class FPPIEnv(DeadTimeTuningEnv):
    __doc__ = FPPI_DESCRIPTION + SHARED_DOC + VERSION_HISTORY
    structure = "fppi"


class MSPEnv(DeadTimeTuningEnv):
    __doc__ = MSP_DESCRIPTION + SHARED_DOC + VERSION_HISTORY
    structure = "msp"


class PIEnv(DeadTimeTuningEnv):
    __doc__ = PI_DESCRIPTION + SHARED_DOC + PI_VERSION_HISTORY
    structure = "pi"


def constraint_cost(info: dict) -> float:
    """The step's constraint cost: 1.0 when the step ends the episode with a design that violates the
    constraints on the true plant, or with no design (``info["feasible"]`` False), else 0.0 (a feasible
    design, or a step that does not end the episode: its info has no ``feasible``)."""
    return 0.0 if info.get("feasible", True) else 1.0


class ConstraintCost(gym.Wrapper):
    """Adds ``info["constraint_cost"]`` (:func:`constraint_cost`, 0.0 or 1.0) to every step's info, the
    violation as a constraint signal the way the safe-RL benchmarks expose it (Ray, Achiam and Amodei
    2019, Safety Gym; Safety-Gymnasium): reward, observation and every other key unchanged.  The
    environment's own ``info["cost"]`` is the design's cost, the negative reward, hence the other name."""

    def step(self, action: Any) -> tuple[Any, float, bool, bool, dict]:
        observation, reward, terminated, truncated, info = self.env.step(action)
        return observation, reward, terminated, truncated, {**info, "constraint_cost": constraint_cost(info)}
