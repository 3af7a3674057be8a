"""One tuning episode: the plant, its identification, the design and its score on the true plant.

:class:`TuningEpisode` is what every mode of :class:`envs.tuning_env.DeadTimeTuningEnv` plays on, and
what agents, rules and studies read of an episode (docs/environments/overview.md, "The episode"):
``env.unwrapped.episode`` (or :func:`envs.tuning_env.episode_of` through wrappers).  Free of Gymnasium;
the experiments and the identification are those of :mod:`envs.episode`, the designs those of
:mod:`envs.structures`, the cost that of :func:`envs.analysis.scoring.score`.

Reads the arguments ``constraints``, ``weights`` and ``violation_cost`` (:func:`scoring_of`), and through
its :class:`~envs.episode_options.EpisodeOptions` and :class:`~envs.design_map.DesignMap` those of the
experiments and of the action's coordinates.
"""

from __future__ import annotations

from dataclasses import fields, replace
from typing import Any

import numpy as np

from envs.analysis.scoring import FEASIBLE_CAP, VIOLATION_BAND, VIOLATION_COSTS, Constraints, CostWeights, Score, score
from envs.base_design import base_parameter
from envs.design_map import DesignMap
from envs.env_config import ScoringConfig
from envs.episode import Evidence, IdentificationFailed, failed_start, identification, run_experiment, start_fixed
from envs.episode_options import EpisodeOptions
from envs.identification.procedure import Identification, ProcedureFailed
from envs.structures import Structure, structure as structure_named
from envs.systems.plants import Plant

__all__ = ["NO_DESIGN_COST", "TuningEpisode", "scoring_of"]

NO_DESIGN_COST = FEASIBLE_CAP + 1 + VIOLATION_BAND
"""The cost of an episode that ends without a design (``measured_observation``: no closed-loop step
identified a usable gain and ``T_ar`` once the budget was spent): that of an unstable loop."""


def _dataclass_argument(value: Any, kind: type, name: str) -> Any:
    """A frozen dataclass argument given as an instance, a dict of its fields or None (defaults)."""
    if value is None:
        return kind()
    if isinstance(value, kind):
        return value
    if isinstance(value, dict):
        known = {f.name for f in fields(kind)}
        unknown = sorted(set(value) - known)
        if unknown:
            raise ValueError(f"{name}: unknown key {unknown[0]!r}; valid keys: {', '.join(sorted(known))}")
        return kind(**value)
    raise ValueError(f"{name} must be a {kind.__name__}, a dict or None, got {type(value).__name__}")


def scoring_of(structure: str, config: ScoringConfig) -> tuple[Constraints, CostWeights]:
    """The score's constraints and weights from the arguments ``constraints``, ``weights`` and
    ``violation_cost`` (None: the structure's constraints, the default weights); the environments score
    a zero-delay model by its residence time."""
    constraints, weights, violation_cost = config.constraints, config.weights, config.violation_cost
    if violation_cost not in VIOLATION_COSTS:
        raise ValueError(f"violation_cost must be one of {', '.join(VIOLATION_COSTS)}, got {violation_cost!r}")
    found = _dataclass_argument(constraints, Constraints, "constraints") if constraints is not None \
        else structure_named(structure).constraints
    if found.violation_cost != violation_cost:
        found = replace(found, violation_cost=violation_cost)
    if found.zero_delay is None:  # the environments' convention (envs.analysis.scoring)
        found = replace(found, zero_delay="residence-time")
    return found, _dataclass_argument(weights, CostWeights, "weights")


class TuningEpisode:
    """The state of one episode of ``structure`` and what can be done with it.

    Attributes
    ----------
    plant : Plant or None
        The true plant (None before the first start, and after :meth:`observe`).
    identification : Identification or None
        What the experiments identified, once the design can read it (fixed mode: from the start; agent
        and plan modes: once committed); None if it failed.
    evidence : Evidence or None
        The experiments run so far (:class:`envs.episode.Evidence`).
    design_pending : bool
        The next step designs (plan mode, agent mode with ``design_step``).
    controller : controller or None
        The committed design, once the episode ends with one.
    done : bool
        The episode is over.
    """

    def __init__(self, structure: str, options: EpisodeOptions, scoring: tuple[Constraints, CostWeights],
                 design_map: DesignMap) -> None:  # fmt: skip
        self.structure, self.options, self.design_map = structure, options, design_map
        self.constraints, self.weights = scoring
        self._base: float | None = None
        self.plant: Plant | None = None
        self.identification: Identification | None = None
        self.evidence: Evidence | None = None
        self.design_pending, self.done = False, True
        self.controller: Any = None
        self.committed: tuple[float, float] | None = None  # (relative parameter, cost) of the committed design

    @property
    def identification(self) -> Identification | None:
        return self._identification

    @identification.setter
    def identification(self, found: Identification | None) -> None:
        self._identification, self._base = found, None  # the base rule's parameter is of this identification

    @property
    def kind(self) -> Structure:
        """The controller structure (:mod:`envs.structures`)."""
        return structure_named(self.structure)

    @property
    def integrating(self) -> bool:
        return self.kind.integrating

    # ------------------------------------------------------------------ experiments
    def start(self, plant: Plant) -> None:
        """Begin on ``plant`` with no experiment run."""
        self.plant, self._base, self.design_pending = plant, None, False  # (a new plant: the base again)
        self.identification, self.evidence = None, Evidence.empty(self.integrating, self.options)

    def run_fixed_procedure(self, rng: np.random.Generator) -> None:
        """The fixed procedure (:func:`envs.episode.start_fixed`) on the plant; raises as it does."""
        self.identification, self.evidence = start_fixed(self.plant, rng, self.options, self.structure)

    def fail_procedure(self, failure: ProcedureFailed | IdentificationFailed) -> None:
        """The fixed procedure failed with ``failure``: keep its runs, charged, with no identification."""
        self.identification = None
        if isinstance(failure, ProcedureFailed):
            self.evidence = failed_start(failure, self.integrating, self.options)
        else:
            self.evidence = failure.evidence

    def run(self, kind: str, amplitude: float, rng: np.random.Generator, excursion_limit: float) -> None:
        """Run experiment ``kind`` at ``amplitude`` on the true plant (:func:`envs.episode.run_experiment`)."""
        self.evidence = run_experiment(self.evidence, kind, self.plant, rng, amplitude, excursion_limit)

    def identify(self, rng: np.random.Generator, amplitude: float | None = None) -> None:
        """Complete the identification the design reads (:func:`envs.episode.identification`); raises
        :class:`envs.episode.IdentificationFailed`, whose ``evidence`` :meth:`keep_failed` keeps."""
        self.identification, self.evidence = identification(self.evidence, self.structure, self.plant, rng, amplitude=amplitude)

    def keep_failed(self, failure: IdentificationFailed) -> None:
        """Keep the runs of a failed identification (charged, the failure counted)."""
        self.evidence = failure.evidence

    def run_plan(self, first: float, second: float, rng: np.random.Generator, excursion_limit: float) -> None:
        """The fixed procedure's two experiments at amplitudes ``first`` (closed-loop step) and ``second``
        (open-loop step, or pulse), then the identification (raises :class:`envs.episode.IdentificationFailed`)."""
        self.run("closed-loop-step", first, rng, excursion_limit)
        if self.evidence.closed_loop is not None:
            self.run("pulse" if self.integrating else "open-loop-step", second, rng, excursion_limit)
        self.identify(rng, amplitude=first)

    def observe(self, identification: Identification, evidence: Evidence, design_pending: bool) -> None:
        """Take experiments run elsewhere (a real process) as the episode's, with no plant to score on."""
        self.plant, self.identification, self.evidence = None, identification, evidence
        self.design_pending, self.done = design_pending, True

    # ------------------------------------------------------------------ design
    def identified(self) -> Identification:
        """The identification, or a ``RuntimeError`` before it exists."""
        if self.identification is None:
            raise RuntimeError("the action's coordinates need the identification: in agent mode it exists once the design is committed")
        return self.identification

    def base_parameter(self) -> float:
        """The residual action's base: the relative parameter of the structure's base rule for this
        episode's identification (:func:`envs.base_design.base_parameter`)."""
        if self._base is None:
            self._base = base_parameter(self.structure, self.identified())
        return self._base

    def parameter_from_action(self, action: float) -> float:
        """The relative parameter of an action in [-1, 1] (:meth:`envs.design_map.DesignMap.parameter_from_action`)."""
        return self.design_map.parameter_from_action(action, self)

    def action_from_parameter(self, parameter: float) -> float:
        """The action of a relative parameter (:meth:`envs.design_map.DesignMap.action_from_parameter`)."""
        return self.design_map.action_from_parameter(parameter, self)

    def model(self) -> Any:
        """The identified model the design reads (SOPDT, FOPDT or integrating)."""
        return self.kind.model_of(self.identification)

    def design(self, relative: float) -> Any:
        """The controller for the relative parameter ``relative`` and the current identification."""
        return self.kind.relative_design(self.model(), relative)

    # ------------------------------------------------------------------ score
    def score_controller(self, controller: Any) -> Score:
        """The cost of any ``controller`` on the true plant, with this episode's experiment time."""
        if self.plant is None or self.evidence is None:
            raise RuntimeError("score_controller() needs an episode; call reset() first")
        return score(
            self.plant, controller, experiment_time=self.evidence.experiment_time,
            experiment_deviation=self.evidence.experiment_deviation, constraints=self.constraints, weights=self.weights,
        )  # fmt: skip

    def score_parameter(self, relative: float) -> tuple[Any, Score]:
        """The controller of the relative parameter ``relative`` and its score on the true plant."""
        controller = self.design(relative)
        return controller, self.score_controller(controller)

    def score_action(self, parameter_action: float) -> tuple[float, Any, Score]:
        """What committing ``parameter_action`` would give, ``(relative parameter, controller, score)``,
        the episode left as it is (a selector scores several designs on one identification)."""
        relative = self.parameter_from_action(parameter_action)
        controller, result = self.score_parameter(relative)
        return relative, controller, result

    def commit(self, relative: float) -> tuple[Any, Score]:
        """End the episode with the design of the relative parameter ``relative``: ``(controller, score)``."""
        controller, result = self.score_parameter(relative)
        self.controller, self.committed, self.done = controller, (relative, float(result.cost)), True
        return controller, result

    # ------------------------------------------------------------------ info
    def final_info(self, result: Score, relative: float, controller: Any) -> dict:
        """The final step's info of a design (the class docstring of :class:`envs.tuning_env.PIDEnv`, Info)."""
        return {
            "cost": float(result.cost),
            "feasible": bool(result.feasible),
            "score": result.to_dict(),
            "plant": self.plant.to_dict(),
            "model": self.model().to_dict(),
            "controller": controller.to_dict(),
            "parameter": relative,
            "experiment_time": self.evidence.experiment_time / self.plant.residence_time,
        }

    def no_design_info(self) -> dict:
        """The final step's info of an episode that ends without a design."""
        return {"cost": NO_DESIGN_COST, "feasible": False, "plant": self.plant.to_dict(),
                "experiment_time": self.evidence.experiment_time / self.plant.residence_time}

    def production_info(self) -> dict:
        """``experiment_deviation`` (``D_exp`` in true ``T_ar``) when production has a price (v0 info otherwise)."""
        if not self.weights.production:
            return {}
        return {"experiment_deviation": self.evidence.experiment_deviation / self.plant.residence_time}
