"""Gymnasium environments: identify a plant with dead time, then choose one design parameter.

The only module of :mod:`envs` that imports Gymnasium.  The numerics are elsewhere: the
experiments and features in :mod:`envs.episode`, the designs in :mod:`envs.design`, the cost in
:mod:`envs.analysis.scoring`.  Ids are registered in :mod:`envs` (``DeadTime/PID-v0``, ``DeadTime/FPPI-v0``,
``DeadTime/MSP-v0``); see the docstrings of :class:`PIDEnv`, :class:`FPPIEnv` and :class:`MSPEnv`.
"""

from __future__ import annotations

import math
from dataclasses import fields, replace
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from envs.discrete_action import DiscreteLayout
from envs.base_design import (
    ACTIONS,
    DESIGN_FEATURES,
    base_parameter,
    design_features,
    residual_action,
    residual_parameter,
    robustness_action,
    robustness_parameter,
)
from envs.episode import (
    Evidence,
    IdentificationFailed,
    failed_start,
    feature_names,
    features,
    identification,
    run_experiment,
    start_fixed,
)
from envs.episode_options import AMPLITUDE_RANGE, EpisodeOptions
from envs.structures import Structure, structure as structure_named
from envs.systems.families import FAMILIES, check_family_config, sample_plant
from envs.systems.plants import Plant, as_plant
from envs.identification.procedure import Identification, ProcedureFailed
from envs.threads import single_threaded
from envs.analysis.scoring import FEASIBLE_CAP, VIOLATION_BAND, VIOLATION_COSTS, Constraints, CostWeights, Score, score
from envs.validation import require_number, require_real_array

# The kind of plant each family of :mod:`envs.systems.families` draws (True: integrating), checked when the
# environment is made; ``benchmark`` draws either, as its config says (a draw of the other kind is
# drawn again).
_FAMILY_KINDS: dict[str, bool] = {"stable": False, "fopdt": False, "sopdt": False, "lag-chain": False, "integrating": True}

__all__ = ["DeadTimeTuningEnv", "PIDEnv", "FPPIEnv", "MSPEnv", "PIEnv", "MODES", "AMPLITUDE_RANGE"]

MODES = ("fixed", "agent", "plan")
OBSERVATION_BOUND = 5.0
MAX_SAMPLING_ATTEMPTS = 10
"""Plants the fixed mode draws at most for an episode whose procedure identifies the design's model; with
``measured_observation`` (v3) the last one drawn is kept even if it fails, and the episode ends without a
design (``NO_DESIGN_COST``), else (v0-v2) the reset raises ``RuntimeError``."""
MAX_BUDGET = 100
"""The largest ``budget`` (agent mode's experiments per episode): far above any useful identification
(the procedure runs two), and an episode of an agent that never commits stays short."""
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


DIVERGED_RANGE = 5.0
"""``render()`` draws a diverging response until it leaves ``DIVERGED_RANGE`` times the first tenth
of its run (or the bounded responses' range, where there are any) and marks where it leaves."""


def _draw_bounded(axes: Any, curves: list[tuple[np.ndarray, np.ndarray, str, str, bool]]) -> None:
    """Draw ``(time, values, style, label, diverged)`` curves; the axis follows the bounded ones."""
    bounded = [values for _, values, *_, diverged in curves if not diverged]
    if bounded:
        low, high = min(float(np.nanmin(v)) for v in bounded), max(float(np.nanmax(v)) for v in bounded)
    else:
        start = np.concatenate([values[: max(1, len(values) // 10)] for _, values, *_ in curves])
        reach = DIVERGED_RANGE * max(float(np.nanmax(np.abs(start))), 1e-12)
        low, high = -reach, reach
    margin = 0.05 * (high - low or 1.0)
    low, high = low - margin, high + margin
    for time, values, style, label, diverged in curves:
        if not diverged:
            axes.plot(time, values, style, lw=1.0, label=label)
            continue
        outside = np.flatnonzero(~((values >= low) & (values <= high)))
        end = int(outside[0]) if outside.size else len(values)
        line, = axes.plot(time[:end], values[:end], style, lw=1.0, label=f"{label} (diverged)")
        if end < len(values):
            axes.plot(time[end - 1 if end else 0], np.clip(values[end - 1 if end else 0], low, high), "x",
                      color=line.get_color(), ms=8)
    axes.set_ylim(low, high)


class DeadTimeTuningEnv(gym.Env):
    """Base class of the tuning environments; see :class:`PIDEnv` for the full documentation.

    Subclasses set :attr:`structure`, a name of :data:`envs.structures.STRUCTURES`; :attr:`integrating`,
    :attr:`default_family` and :meth:`default_constraints` are the structure's.
    """

    metadata = {"render_modes": ["rgb_array"], "render_fps": 1}
    structure: str = "pid"
    integrating: bool = False
    default_family: str = "stable"

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        kind = structure_named(cls.structure)
        cls.integrating, cls.default_family = kind.integrating, kind.family

    def __init__(
        self,
        experiments: str = "fixed",
        family: str | None = None,
        family_config: object = None,
        noise_std: float = 0.01,
        constraints: Constraints | dict | None = None,
        weights: CostWeights | dict | None = None,
        budget: int = 4,
        excursion_limit: float = 5.0,
        render_mode: str | None = None,
        action: str = "parameter",
        design_features: bool = False,
        identification: str = "seeds",
        amplitude_limit: float | None = None,
        disturbances: dict | None = None,
        design_step: bool = False,
        violation_cost: str = "graded",
        measured_observation: bool = False,
        experiment_set: str = "all",
        plan: Any = None,
        discrete_action: bool = False,
    ) -> None:
        if experiments not in MODES:
            raise ValueError(f"experiments must be one of {', '.join(MODES)}, got {experiments!r}")
        if action not in ACTIONS:
            raise ValueError(f"action must be one of {', '.join(ACTIONS)}, got {action!r}")
        if not isinstance(design_features, bool):
            raise ValueError(f"design_features must be true or false, got {design_features!r}")
        if not isinstance(design_step, bool):
            raise ValueError(f"design_step must be true or false, got {design_step!r}")
        if not isinstance(measured_observation, bool):
            raise ValueError(f"measured_observation must be true or false, got {measured_observation!r}")
        self.plan = self._plan_argument(plan, experiments)
        if violation_cost not in VIOLATION_COSTS:
            raise ValueError(f"violation_cost must be one of {', '.join(VIOLATION_COSTS)}, got {violation_cost!r}")
        self.action_coordinates = action
        self.design_features = design_features
        if render_mode not in (None, *self.metadata["render_modes"]):
            raise ValueError(f"render_mode must be None or 'rgb_array', got {render_mode!r}")
        self.mode = experiments
        self.family = self.default_family if family is None else family
        if self.family not in FAMILIES:
            raise ValueError(f"unknown plant family {self.family!r}; valid families: {', '.join(FAMILIES)}")
        if self.family in _FAMILY_KINDS and _FAMILY_KINDS[self.family] != self.integrating:
            raise ValueError(self._wrong_family_kind(_FAMILY_KINDS[self.family]))
        self.family_config = check_family_config(self.family, family_config)
        noise_std = require_number(noise_std, "noise_std", nonnegative=True)
        self.constraints = _dataclass_argument(constraints, Constraints, "constraints") if constraints is not None else self.default_constraints()
        if self.constraints.violation_cost != violation_cost:
            self.constraints = replace(self.constraints, violation_cost=violation_cost)
        if self.constraints.zero_delay is None:  # the environments' convention (envs.analysis.scoring)
            self.constraints = replace(self.constraints, zero_delay="residence-time")
        self.weights = _dataclass_argument(weights, CostWeights, "weights")
        if isinstance(budget, bool) or not isinstance(budget, (int, float, np.integer, np.floating)) \
                or not math.isfinite(budget) or int(budget) != budget or not 1 <= budget <= MAX_BUDGET:
            raise ValueError(f"budget must be an integer from 1 to {MAX_BUDGET}, got {budget!r}")
        self.budget = int(budget)
        self.excursion_limit = require_number(excursion_limit, "excursion_limit", positive=True)
        self.options = EpisodeOptions.for_structure(
            self.structure, noise_std=noise_std, identification=identification, amplitude_limit=amplitude_limit, disturbances=disturbances,
            production=self.weights.production > 0, measured=measured_observation, experiment_set=experiment_set,
        )  # fmt: skip
        self.render_mode = render_mode
        self._controller = None
        self.parameter_range = self.kind.parameter_range
        evidence = Evidence.empty(self.integrating, self.options)
        self.experiment_names = evidence.experiments
        self.design_step = (design_step and self.mode == "agent") or self.mode == "plan"
        self.feature_names = feature_names(evidence) + (DESIGN_FEATURES if design_features else ())
        self.feature_names += ("design_step",) if self.design_step else ()
        self._design_pending = False
        size = {"fixed": 1, "agent": len(self.experiment_names) + 3, "plan": 3}[self.mode]
        self.action_space = spaces.Box(-1.0, 1.0, shape=(size,), dtype=np.float32)
        self.discrete = self._discrete_argument(discrete_action)
        if self.discrete is not None:
            self.action_space = spaces.Discrete(self.discrete.size)
        bound = OBSERVATION_BOUND
        self.observation_space = spaces.Box(-bound, bound, shape=(len(self.feature_names),), dtype=np.float32)
        self.plant: Plant | None = None
        self.identification: Identification | None = None
        self.evidence: Evidence | None = None
        self._base: float | None = None
        self._done = True

    # ------------------------------------------------------------------ configuration
    def _plan_argument(self, plan: Any, experiments: str) -> tuple[float, float] | None:
        """``plan``: None, or two amplitudes in :data:`AMPLITUDE_RANGE` for the fixed mode (cut to the
        amplitude limit when run, as the plan mode's)."""
        if plan is None:
            return None
        if experiments != "fixed":
            raise ValueError(f"plan sets the fixed mode's experiments; experiments={experiments!r} chooses its own")
        if isinstance(plan, (str, bytes)) or not hasattr(plan, "__len__") or len(plan) != 2:
            raise ValueError(f"plan must be two amplitudes [closed-loop step, second experiment], got {plan!r}")
        low, high = AMPLITUDE_RANGE
        amplitudes = tuple(require_number(a, "plan amplitude", positive=True) for a in plan)
        if not all(low <= a <= high for a in amplitudes):
            raise ValueError(f"plan amplitudes must lie in [{low:g}, {high:g}], got {list(plan)!r}")
        return amplitudes

    def _discrete_argument(self, discrete_action: Any) -> DiscreteLayout | None:
        """``discrete_action``: the layout of the agent mode's discrete action (:mod:`envs.discrete_action`), or None."""
        if not isinstance(discrete_action, bool):
            raise ValueError(f"discrete_action must be true or false, got {discrete_action!r}")
        if not discrete_action:
            return None
        if self.mode != "agent" or not self.design_step:
            raise ValueError("discrete_action needs experiments='agent' with design_step=True (the v2-v3 agent mode), "
                             f"got experiments={self.mode!r}")
        return DiscreteLayout(self.experiment_names)

    @property
    def noise_std(self) -> float:
        """The measurement noise of the experiments (the ``noise_std`` argument, :attr:`options`)."""
        return self.options.noise_std

    @property
    def kind(self) -> Structure:
        """The controller structure (:mod:`envs.structures`) named by :attr:`structure`."""
        return structure_named(self.structure)

    @classmethod
    def default_constraints(cls) -> Constraints:
        """The structure's default constraints (:attr:`envs.structures.Structure.constraints`; docs/scoring.md)."""
        return structure_named(cls.structure).constraints

    def base_parameter(self) -> float:
        """The residual action's base: the relative parameter of the structure's base rule for this
        episode's identification (:func:`envs.base_design.base_parameter`)."""
        if self._base is None:
            self._base = base_parameter(self.structure, self._identified())
        return self._base

    def _identified(self) -> Identification:
        if self.identification is None:
            raise RuntimeError("the action's coordinates need the identification: in agent mode it exists once the design is committed")
        return self.identification

    def parameter_from_action(self, action: float) -> float:
        """The relative parameter (``mu``, ``T_r/T_n`` or ``T_r/L_n``) of an action in [-1, 1]: log scale
        over the range (``action="parameter"``), or the residual around :meth:`base_parameter`."""
        if isinstance(action, float):  # a number (as step() passes it): numpy.clip's value without its call
            a = min(max(float(action), -1.0), 1.0)
        else:
            a = float(np.clip(action, -1.0, 1.0))
        if self.action_coordinates == "residual":
            return residual_parameter(self.structure, self.base_parameter(), a)
        if self.action_coordinates == "robustness":
            return robustness_parameter(self.structure, self._identified(), a)
        low, high = (math.log(v) for v in self.parameter_range)
        return math.exp(low + 0.5 * (a + 1.0) * (high - low))

    def action_from_parameter(self, parameter: float) -> float:
        """Inverse of :meth:`parameter_from_action` (clipped to [-1, 1]); for the robustness action, the
        target equal to the parameter's own model-loop figure (:func:`envs.base_design.robustness_action`)."""
        if self.action_coordinates == "robustness":
            return robustness_action(self.structure, self._identified(), parameter)
        if self.action_coordinates == "residual":
            return residual_action(self.structure, self.base_parameter(), parameter)
        low, high = (math.log(v) for v in self.parameter_range)
        parameter = require_number(parameter, "parameter", positive=True)
        return float(np.clip(2.0 * (math.log(parameter) - low) / (high - low) - 1.0, -1.0, 1.0))

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
        observation, named = self._observation_and_features()
        return observation, {"plant": self.plant.to_dict(), "features": named}

    def new_episode(self, given: Any = None) -> None:
        """Reset's work before its observation, with the generator as it is: draw a plant (or take
        ``given``, as ``options["plant"]``) and, in the fixed mode, identify it.  The native vector
        environment (:mod:`envs.vector_env`) starts its episodes with it."""
        self.plant = self._given_plant(given) if given is not None else None
        for attempt in range(MAX_SAMPLING_ATTEMPTS):
            plant = self.plant if given is not None else sample_plant(self.family, self.np_random, self.family_config)
            try:  # the last draw is kept as a given plant is (measured_observation: an episode without a design)
                self._start(plant, given is not None or attempt == MAX_SAMPLING_ATTEMPTS - 1)
                break
            except ValueError:
                if given is not None:
                    raise
        else:
            raise RuntimeError(f"no plant of family {self.family!r} could be identified in {MAX_SAMPLING_ATTEMPTS} draws")
        self._done = False
        self._controller = None

    def _wrong_family_kind(self, integrating: bool) -> str:
        """The one line for a family (or a draw of it) of the other kind of plant than this environment's."""
        kinds = ("self-regulating", "integrating")
        fitting = [f for f, kind in _FAMILY_KINDS.items() if kind == self.integrating] + ["benchmark"]
        return (f"family {self.family!r} draws {kinds[integrating]} plants; {type(self).__name__} takes "
                f"{kinds[self.integrating]} plants (families: {', '.join(fitting)})")

    def _given_plant(self, plant: Any) -> Plant:
        plant = as_plant(plant, "reset options: plant")
        if plant.integrating != self.integrating:
            kind = "an integrating" if self.integrating else "a self-regulating"
            raise ValueError(f"reset options: plant must be {kind} plant for {type(self).__name__}")
        return plant

    def _start(self, plant: Plant, given: bool = False) -> None:
        """Start on ``plant``.  A drawn plant whose procedure fails, or identifies no model for the design
        (fixed mode), raises, and is drawn again; a given one, with ``measured_observation``, starts an episode that can only end without a
        design (:meth:`_no_design`), its failed steps charged and observed."""
        if plant.integrating != self.integrating:
            raise ValueError(f"family {self.family!r} drew a plant of the wrong kind for {type(self).__name__}")
        self.plant = plant
        self._base = None
        self._design_pending = False
        if self.mode == "fixed" and self.plan is not None:
            self.evidence = Evidence.empty(self.integrating, self.options)
            try:
                self._run_plan(*(self.options.limited(a) for a in self.plan))
            except IdentificationFailed as failure:
                if not (given and self.options.measured):
                    raise
                self.identification, self.evidence = None, failure.evidence
        elif self.mode == "fixed":
            try:
                self.identification, self.evidence = start_fixed(plant, self.np_random, self.options, self.structure)
            except ProcedureFailed as failure:
                if not (given and self.options.measured):
                    raise
                self.identification, self.evidence = None, failed_start(failure, self.integrating, self.options)
            except IdentificationFailed as failure:
                if not (given and self.options.measured):
                    raise
                self.identification, self.evidence = None, failure.evidence
        else:
            self.identification = None
            self.evidence = Evidence.empty(self.integrating, self.options)

    @single_threaded
    def step(self, action: np.ndarray) -> tuple[np.ndarray, float, bool, bool, dict]:
        """Run an experiment (agent mode) or commit the design; see the class docstring."""
        if self._done:
            raise RuntimeError("step() called on a finished episode; call reset() first")
        if self.discrete is not None:
            return self._discrete_step(action)
        action = self._checked_action(action)
        action = np.clip(action, -1.0, 1.0)
        if self.mode == "fixed" and self.identification is None:  # the procedure failed on a given plant
            return self._no_design({"identified": False})
        if self.mode == "plan" and not self._design_pending:
            return self._plan(float(action[0]), float(action[1]))
        if self.mode == "agent" and not self._design_pending:
            choice = int(np.argmax(action[: len(self.experiment_names) + 1]))
            if choice > 0 and self.evidence.runs < self.budget:
                return self._experiment(self.experiment_names[choice - 1], action[-2])
            if self.design_step:
                return self._identify(action[-2])
        return self._commit(action[-1])

    def _discrete_step(self, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        """``discrete_action=True``: the step of the index's meaning (:mod:`envs.discrete_action`)."""
        meaning = self.discrete.meaning(self._checked_index(action))
        amplitude = self.options.limited(1.0 if meaning.kind == "design" else meaning.value)
        if self._design_pending:
            result = self._commit(meaning.value if meaning.kind == "design" else 0.0)
        elif meaning.kind in ("commit", "design") or self.evidence.runs >= self.budget:
            result = self._identify_at(amplitude)
        else:
            result = self._experiment_at(meaning.kind, amplitude)
        observation, reward, terminated, truncated, info = result
        return observation, reward, terminated, truncated, {**info, "action": meaning.name}

    def _checked_index(self, action: Any) -> int:
        """The discrete action as an index; anything but one integer in range is a ``ValueError`` naming it."""
        raw = np.asarray(action)
        size = self.discrete.size
        if raw.shape not in ((), (1,)) or raw.dtype.kind not in "iu" or not 0 <= int(raw.reshape(-1)[0]) < size:
            raise ValueError(f"action must be one integer index from 0 to {size - 1}, got {action!r}")
        return int(raw.reshape(-1)[0])

    def action_masks(self) -> np.ndarray:
        """``discrete_action=True``: which indices mean something now (sb3-contrib's ``MaskablePPO``
        reads it; :meth:`envs.discrete_action.DiscreteLayout.masks`)."""
        if self.discrete is None:
            raise RuntimeError("action_masks() needs discrete_action=True")
        budget_left = self.evidence is None or self.evidence.runs < self.budget
        return self.discrete.masks(design_pending=self._design_pending, budget_left=budget_left,
                                   amplitude_limit=self.options.amplitude_limit)

    def _amplitude(self, amplitude_action: float) -> float:
        """The experiment amplitude of an action's component: log scale over AMPLITUDE_RANGE, cut to the limit."""
        low, high = (math.log10(v) for v in AMPLITUDE_RANGE)
        return self.options.limited(10.0 ** (low + 0.5 * (amplitude_action + 1.0) * (high - low)))

    def _identify(self, amplitude_action: float) -> tuple[np.ndarray, float, bool, bool, dict]:
        """``design_step=True``: the commit completes the identification (the fixed procedure's missing
        experiments at the commit's amplitude) and shows it; the next step designs."""
        return self._identify_at(self._amplitude(amplitude_action))

    def _identify_at(self, amplitude: float) -> tuple[np.ndarray, float, bool, bool, dict]:
        try:
            self.identification, self.evidence = identification(
                self.evidence, self.structure, self.plant, self.np_random, amplitude=amplitude
            )
        except IdentificationFailed as failure:
            return self._failed(failure, amplitude)
        self._design_pending = True
        observation, named = self._observation_and_features()
        return observation, 0.0, False, False, {"identified": True, "amplitude": amplitude, "features": named}

    def _checked_action(self, action: Any) -> np.ndarray:
        """The action as float64 of the action space's shape (a number for a one-component action);
        a boolean, complex or non-numeric array, or another shape, is a ``ValueError`` naming it."""
        raw = require_real_array(action, "action")
        shape = self.action_space.shape
        if raw.shape != shape and not (shape == (1,) and raw.shape == ()):
            raise ValueError(f"action must have shape {shape}, got {raw.shape}")
        return raw.reshape(shape)

    def _plan(self, first_action: float, second_action: float) -> tuple[np.ndarray, float, bool, bool, dict]:
        """``experiments="plan"``: the procedure's two experiments at the plan's amplitudes (the closed-loop
        step, then the open-loop step or the pulse), the identification completed and shown; the next
        step designs."""
        first, second = self._amplitude(first_action), self._amplitude(second_action)
        try:
            self._run_plan(first, second)
        except IdentificationFailed as failure:
            if not self.options.measured:
                raise
            self.evidence = failure.evidence
            return self._no_design({"identified": False, "amplitudes": (first, second)})
        self._design_pending = True
        observation, named = self._observation_and_features()
        return observation, 0.0, False, False, {"identified": True, "amplitudes": (first, second), "features": named}

    def _run_plan(self, first: float, second: float) -> None:
        """Run a plan on the episode's evidence and identify (raises :class:`IdentificationFailed`)."""
        evidence = run_experiment(self.evidence, "closed-loop-step", self.plant, self.np_random, first, self.excursion_limit)
        if evidence.closed_loop is not None:
            kind = "pulse" if self.integrating else "open-loop-step"
            evidence = run_experiment(evidence, kind, self.plant, self.np_random, second, self.excursion_limit)
        self.evidence = evidence
        self.identification, self.evidence = identification(
            self.evidence, self.structure, self.plant, self.np_random, amplitude=first
        )

    def _failed(self, failure: IdentificationFailed, amplitude: float | None) -> tuple[np.ndarray, float, bool, bool, dict]:
        """``measured_observation``: a commit whose identification failed is a failed experiment (charged,
        shown in ``failed_experiments``); the episode goes on while the budget lasts, and else ends
        without a design at :data:`NO_DESIGN_COST`.  Otherwise the failure raises, as in v0-v2."""
        if not self.options.measured:
            raise failure
        self.evidence = failure.evidence
        observation, named = self._observation_and_features()
        info = {"identified": False, "amplitude": amplitude, "features": named}
        if self.evidence.runs < self.budget:
            return observation, 0.0, False, False, info
        return self._no_design(info)

    def _no_design(self, info: dict) -> tuple[np.ndarray, float, bool, bool, dict]:
        """End the episode without a design, at :data:`NO_DESIGN_COST`."""
        self._done = True
        observation, named = self._observation_and_features()
        scale = self.plant.residence_time
        info = {**info, "cost": NO_DESIGN_COST, "feasible": False, "plant": self.plant.to_dict(),
                "experiment_time": self.evidence.experiment_time / scale, "features": named, **self._production_info()}
        return observation, -NO_DESIGN_COST, True, False, info

    def _experiment(self, kind: str, amplitude_action: float) -> tuple[np.ndarray, float, bool, bool, dict]:
        return self._experiment_at(kind, self._amplitude(amplitude_action))

    def _experiment_at(self, kind: str, amplitude: float) -> tuple[np.ndarray, float, bool, bool, dict]:
        self.evidence = run_experiment(self.evidence, kind, self.plant, self.np_random, amplitude, self.excursion_limit)
        observation, named = self._observation_and_features()
        info = {"experiment": kind, "amplitude": amplitude, "features": named}
        return observation, 0.0, False, False, info

    def _commit(self, parameter_action: float) -> tuple[np.ndarray, float, bool, bool, dict]:
        if self.mode == "agent" and not self._design_pending:  # (design_step: _identify has identified)
            try:
                self.identification, self.evidence = identification(self.evidence, self.structure, self.plant, self.np_random)
            except IdentificationFailed as failure:
                return self._failed(failure, None)
        relative, controller, result = self.commit_design(parameter_action)
        observation, named = self._observation_and_features()
        info = self._final_info(result, relative, controller, named)
        return observation, -float(result.cost), True, False, info

    def commit_design(self, parameter_action: float) -> tuple[float, Any, Score]:
        """End the episode with the design of ``parameter_action`` (a number in [-1, 1]) on the current
        identification: ``(relative parameter, controller, score)``.  Step's work in the fixed mode
        before its observation and info; the native vector environment commits with it."""
        relative, controller, result = self.score_action(parameter_action)
        self._controller = controller
        self._design = (relative, float(result.cost))
        self._done = True
        return relative, controller, result

    def observe(self, identification: Identification, evidence: Evidence) -> np.ndarray:
        """The observation of experiments run elsewhere (a real process: ``agents.evaluation.process_policies``):
        ``identification`` and ``evidence`` become the episode's, with no plant to score a design on (the
        episode is over for :meth:`step`); in plan mode the design step is the one pending."""
        self.plant, self.identification, self.evidence, self._base = None, identification, evidence, None
        self._design_pending, self._done = self.mode == "plan", True
        return self._observation_and_features()[0]

    # ------------------------------------------------------------------ scoring
    def score_action(self, parameter_action: float) -> tuple[float, Any, Score]:
        """What committing ``parameter_action`` would give, ``(relative parameter, controller, score)``,
        the episode left as it is (a selector scores several designs on one identification)."""
        relative = self.parameter_from_action(parameter_action)
        controller = self.design(relative)
        return relative, controller, self.score_controller(controller)

    def model(self):
        """The identified model the design reads (SOPDT, FOPDT or integrating)."""
        return self.kind.model_of(self.identification)

    def design(self, relative: float):
        """The controller for the relative parameter ``relative`` and the current identification."""
        return self.kind.relative_design(self.model(), relative)

    def score_controller(self, controller) -> Score:
        """The cost of any ``controller`` on the true plant, with this episode's experiment time."""
        if self.plant is None or self.evidence is None:
            raise RuntimeError("score_controller() needs an episode; call reset() first")
        return score(
            self.plant, controller, experiment_time=self.evidence.experiment_time,
            experiment_deviation=self.evidence.experiment_deviation, constraints=self.constraints, weights=self.weights,
        )  # fmt: skip

    def _final_info(self, result: Score, relative: float, controller, named: dict[str, float]) -> dict:
        return {
            "cost": float(result.cost),
            "feasible": bool(result.feasible),
            "score": result.to_dict(),
            "plant": self.plant.to_dict(),
            "model": self.model().to_dict(),
            "controller": controller.to_dict(),
            "parameter": relative,
            "experiment_time": self.evidence.experiment_time / self.plant.residence_time,
            "features": named,
            **self._production_info(),
        }

    def _production_info(self) -> dict:
        """``experiment_deviation`` (``D_exp`` in true ``T_ar``) when production has a price (v0 info otherwise)."""
        if not self.weights.production:
            return {}
        return {"experiment_deviation": self.evidence.experiment_deviation / self.plant.residence_time}

    # ------------------------------------------------------------------ rendering
    def render(self) -> np.ndarray | None:
        """``render_mode="rgb_array"``: an image of the experiments' measured outputs so far and,
        once the design is committed, the loop's set-point and load responses on the true plant:
        the output in one panel, the control signal in another, labelled with the design's parameter
        and cost, time in units of the true ``T_ar``.  A diverging response is drawn until it leaves
        the axes and marked; the axes follow the bounded ones."""
        if self.render_mode != "rgb_array" or self.evidence is None:
            return None
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure

        figure = Figure(figsize=(6.4, 6.4), dpi=80)
        canvas = FigureCanvasAgg(figure)
        experiments, output, control = figure.subplots(3, 1)
        scale = self.plant.residence_time
        for name, result in self.evidence.results.items():
            experiments.plot(result.timepts / scale, result.output, lw=0.8, label=name)
        experiments.set_title("experiments (measured output)", fontsize=9)
        if self.evidence.results:
            experiments.legend(fontsize=7)
        if self._controller is not None:
            self._plot_loop(output, control, scale)
        control.set_xlabel("t / T_ar", fontsize=8)
        figure.tight_layout()
        canvas.draw()
        return np.asarray(canvas.buffer_rgba())[..., :3].copy()

    def _plot_loop(self, output, control, scale: float) -> None:
        from envs.simulation.loops import closed_loop_response, simulation_step

        dt = simulation_step(self.plant, self._controller)
        steps = int(min(40.0 * scale / dt, 20_000))
        gain = abs(self.plant.gain) * (scale if self.integrating else 1.0)
        symbol = self.kind.symbol
        curves = {output: [], control: []}
        for label, kwargs, unit, style in (("set point", {"setpoint": 1.0}, 1.0, "-"), ("load / |K|", {"load": 1.0}, gain, "--")):
            response = closed_loop_response(self.plant, self._controller, steps, dt, **kwargs)
            time = response.timepts / scale
            curves[output].append((time, response.output / unit, style, label, response.diverged))
            curves[control].append((time, response.control * unit, style, label, response.diverged))
        for axes, drawn in curves.items():
            _draw_bounded(axes, drawn)
        output.set_title(f"designed loop on the true plant: {symbol} = {self._design[0]:.3g}, cost {self._design[1]:.3g}",
                         fontsize=9)
        output.set_ylabel("y", fontsize=8)
        control.set_ylabel("u (load: u |K|)", fontsize=8)
        output.legend(fontsize=7)

    # ------------------------------------------------------------------ observation
    def feature_values(self) -> np.ndarray:
        """The features of the episode so far (float64, not clipped), in the order of :attr:`feature_names`."""
        values = features(self.evidence, self.budget)
        if self.design_features:
            extra = design_features(self.structure, self.identification)  # zero in agent mode until the commit
            values = np.concatenate([values, list(extra.values())])
        if self.design_step:
            values = np.concatenate([values, [float(self._design_pending)]])
        return values

    def _observation_and_features(self) -> tuple[np.ndarray, dict[str, float]]:
        """The observation (features clipped to the bounds, float32) and the features by name."""
        values = self.feature_values()
        observation = np.clip(values, -OBSERVATION_BOUND, OBSERVATION_BOUND).astype(np.float32)
        return observation, dict(zip(self.feature_names, values.tolist()))


_SHARED_DOC = """
    ## Action Space
    ``experiments="fixed"``: ``Box(-1, 1, (1,), float32)``, the design parameter ``p`` in the
    coordinate of ``action``: ``"parameter"`` (v0), a log scale over ``[p_min, p_max]``,
    ``p = p_min (p_max/p_min)^((a + 1)/2)``; ``"residual"`` (v1-v3), around the base rule's ``p_0``
    (Description), ``p = p_0 (p_max/p_0)^a`` for ``a >= 0`` and ``p_0 (p_0/p_min)^a`` below, so that
    action 0 is the rule and ``+-1`` the ends of the range; ``"robustness"``, the robustness target of
    the loop on the model (Description), for which the parameter is solved (:mod:`envs.base_design`).

    ``experiments="agent"``: ``Box(-1, 1, (n + 3,), float32)`` with ``n`` the experiment types
    (stable plants: closed-loop step, open-loop step, open-loop ramp, relay, and with
    ``identification="least-squares"`` a PRBS; integrating plants: closed-loop step, pulse, relay;
    see :mod:`envs.episode`):

    | index     | meaning                                                                      |
    |-----------|------------------------------------------------------------------------------|
    | 0         | score of "commit the design"                                                 |
    | 1 .. n    | score of each experiment type; the largest of 0 .. n is the choice            |
    | n + 1     | amplitude ``a`` of the experiment, log scale over [0.1, 10] (unit output change) |
    | n + 2     | the design parameter, as in the fixed mode (read when committing)            |

    ``experiments="plan"``: ``Box(-1, 1, (3,), float32)``: the first step reads the amplitudes of the
    fixed procedure's two experiments (index 0: the closed-loop step, 1: the open-loop step, or the pulse for
    integrating plants; log scale over [0.1, 10] as above, cut to ``amplitude_limit``), runs both and
    shows the identification;
    the second step designs from index 2, as in the fixed mode.  A plan of amplitudes (1, 1) is the
    fixed mode's procedure, bit for bit.

    With ``experiment_set="design"`` (v3) the agent mode's ``n`` experiment types are those the
    structure's design or design features read (:data:`envs.episode_options.DESIGN_EXPERIMENTS`): PID
    closed-loop step, open-loop step, relay; FPPI closed-loop step, open-loop step; MSP closed-loop
    step, pulse.

    Actions outside [-1, 1] are clipped to it; a NaN or infinite action raises ``ValueError``.

    ``discrete_action=True`` (agent mode with ``design_step``, v2-v3): ``Discrete(5 (n + 1) + 21)``,
    for learners that choose among actions (sb3-contrib's ``MaskablePPO``), each index one ``Box``
    action of the same meaning (:mod:`envs.discrete_action`): indices 0-4 commit at amplitude 0.1, 0.3,
    1, 3 or 10; then five per experiment type (in the order of ``experiment_names``), the experiment at
    those amplitudes; then 21 design levels, the residual action -1, -0.9, ..., 1 (0: the base rule).
    ``action_masks()`` gives the indices that mean something now: in the design step the 21 design
    levels only; before it the commits, and the experiments while the budget lasts; amplitudes above
    ``amplitude_limit`` masked (v3: 10).  A masked index still acts as its ``Box`` action: an experiment
    beyond the budget commits, a design level before the design step commits at amplitude 1, a commit
    or experiment in the design step designs at the base rule.  The step's info names the index
    (``action``: ``"open-loop-step@3"``, ``"commit@1"``, ``"design@-0.2"``).  An index out of range, or
    not an integer, raises ``ValueError``.

    ## Observation Space
    ``Box(-5, 5, (10 + n + 1,), float32)``, every entry dimensionless (identified ``T_ar`` and
    ``K_n`` as units): the ten identified features of :data:`envs.episode.FEATURES` (``tau``,
    ``theta``, ``L_n/T_ar``, ``log10(T_f_bar/T_n)``, ``log10(A/(K_n L_n))``, noise-to-amplitude
    ratio, relay gain and period, ramp ``T_n/T_ar``, experiment time), 0 where not measured (with
    ``identification="least-squares"``, three more: :data:`envs.episode.LEAST_SQUARES_FEATURES`);
    then the number of runs of each experiment type over the budget, and the total runs over the budget;
    with ``measured_observation=True`` (v3) one more, ``failed_experiments``: the runs that gave nothing
    usable over the budget.  The noise-to-amplitude ratio is ``sigma/a`` of the closed-loop step, with
    ``sigma`` the configured ``noise_std`` (v0-v2) or, with ``measured_observation=True``, estimated from
    the step's record (:mod:`envs.episode`); the relay's hysteresis is ``3 sigma`` of the same ``sigma``.
    With ``design_features=True`` (v1-v3) the three design features follow, and with
    ``design_step=True`` in agent mode (v2-v3) and in plan mode, ``design_step``.  A feature whose
    experiment has not run (or failed) is 0, and the counts tell which ran.

    | feature | measured by | value |
    |---|---|---|
    | `tau` | `closed-loop-step` | normalized dead time ``1 - T_a/T_ar`` (Gorez & Klan eq. 2-7), from the moments of the closed-loop step's record |
    | `theta` | `closed-loop-step` | ``theta`` of the SOPDT model (Gorez & Klan eq. 2-10), from the same moments |
    | `dead_time_fraction` | `open-loop-step` | ``L_n/T_ar`` of the open-loop step's FOPDT model (Ingimundarson & Hagglund eq. 11) |
    | `log_mismatch` | `open-loop-step` | ``log10(T_f_bar/T_n)``, the mismatch area of the open-loop step (Ingimundarson & Hagglund eq. 22) |
    | `log_pulse_area` | `pulse` | ``log10(A/(K_n L_n))``, the area of the pulse experiment (Ingimundarson & Hagglund eq. 46; pulse ``a/(K_n tau_p)`` of length ``tau_p = L_n/3``) |
    | `log_noise_ratio` | `closed-loop-step` | ``log10(sigma/a)`` of the closed-loop step at amplitude ``a``; with ``measured_observation=True`` (v3) ``sigma`` is estimated from the step's record (the median absolute fourth difference over ``0.6745 sqrt(70)``, :func:`envs.identification.steady_state.noise_level`), in v0-v2 it is the configured ``noise_std`` |
    | `log_relay_gain` | `relay` | ``log10(K_u |K_n|)``, the ultimate gain of the relay experiment (hysteresis ``3 sigma``) |
    | `relay_period` | `relay` | ``P_u/T_ar``, the relay's period |
    | `ramp_time_constant` | `open-loop-ramp` | ``T_n/T_ar`` from an open-loop ramp (Ingimundarson & Hagglund eq. 12) |
    | `log_experiment_time` | - | ``log10(1 + t_exp/T_ar)``, the experiment time so far |
    | `count_<type>` | - | runs of each experiment type over the budget |
    | `budget_used` | - | all runs over the budget |
    | `failed_experiments` | - | ``measured_observation=True`` (v3): runs that gave nothing usable (stopped at the excursion limit, or a closed-loop step without a usable gain and ``T_ar``) over the budget |
    | `ls_time_constant` | `prbs` | ``identification="least-squares"``: the latest least-squares fit's time constant over ``T_ar`` |
    | `ls_dead_time` | `prbs` | ``identification="least-squares"``: that fit's dead time over ``T_ar`` |
    | `log_ls_residual` | `prbs` | ``identification="least-squares"``: ``log10`` of that fit's residual over the amplitude |
    | `log_base_parameter` | - | ``design_features=True`` (v1-v3): ``log10 p_0``, the base rule's parameter |
    | `check_ms` | - | ``design_features=True`` (v1-v3): ``Ms`` of the base design's loop closed around the *other* identified model (Description), clipped to [1, 5], 5 if unstable |
    | `check_delay_margin` | - | ``design_features=True`` (v1-v3): that loop's delay margin over ``T_ar``, clipped to [0, 5], 0 if unstable |
    | `design_step` | - | plan mode, and agent mode with ``design_step=True`` (v2-v3): 1 when the next step designs |

    ## Rewards
    ``r = -cost`` on the step that commits the design, 0 on experiment steps, where
    (:mod:`envs.analysis.scoring`) ``cost = w_load IAE_load/(|K| T_ar) + w_sp IAE_sp/T_ar + w_exp t_exp/T_ar
    + w_prod D_exp/T_ar`` (``D_exp = int |y| dt`` of the true output over the experiments; ``w_prod = 0``
    by default) on the TRUE plant (``K``, ``T_ar`` true; integrating plants: ``IAE_load/(|K_v| T_ar^2)``),
    capped at 20 when the loop meets the constraints.  A design that violates them costs, with ``g``
    the sum of its relative violations (:func:`envs.analysis.scoring.violation_cost`):
    ``violation_cost="graded"`` (v0-v2) ``21 + g``, an unstable loop 26; ``violation_cost="bounded"``
    (v3) ``21 + 5 g/(1 + g)``, an unstable loop 26, so that every violation costs more than every
    feasible design and no stable loop more than an unstable one.  The cost is the one of
    ``deadtime analyze`` and :func:`envs.analysis.scoring.score` for the same plant and controller.

    ## Starting State
    A plant drawn from ``family`` with ``self.np_random`` (or ``options["plant"]`` of ``reset``, any
    form :func:`envs.systems.plants.as_plant` takes).
    Fixed mode: the fixed procedure has run (:func:`envs.identification.procedure.identify`: closed-loop step,
    then open-loop step, or pulse for integrating plants, amplitude 1, noise ``noise_std``).
    Agent mode: nothing has run; the observation is zero.

    ## Episode End
    Termination: the design is committed (fixed mode: the first step; plan mode: the second; agent
    mode: the commit choice, or any step once ``budget`` experiments have run).  No truncation.  Committing with
    missing data runs the fixed procedure's missing experiments first (charged).  With ``design_step=True``
    (v2) a commit only completes the identification, at the commit action's amplitude, and returns
    it (reward 0, the observation's last entry ``design_step`` = 1, the design features filled in);
    the next step designs from its last component, whatever its choice, and ends the episode.
    With ``measured_observation=True`` (v3) a commit whose closed-loop step identifies no usable gain
    and ``T_ar`` is a failed experiment (charged, counted in ``failed_experiments``, reward 0, info
    ``identified=False``): the episode goes on while the budget lasts, else it terminates without a
    design at cost 26 (``NO_DESIGN_COST``, that of an unstable loop).  An identification without the
    model the design reads is a failed identification too (the FPPI's FOPDT model needs an open-loop
    step or ramp that settles, which a drift or a load can prevent; the experiment counts as failed):
    the fixed mode draws another plant, as when its closed-loop steps fail, up to 10 plants (a given
    plant, or the tenth drawn: with ``measured_observation=True`` an episode that ends without a design,
    else a ``ValueError`` or, after ten draws, a ``RuntimeError``); the
    plan and agent modes treat it as a commit that identifies nothing (v0-v2: a ``ValueError``).

    ## Arguments
    | argument          | default                     | meaning                                                  |
    |-------------------|-----------------------------|----------------------------------------------------------|
    | `experiments`     | `"fixed"`                   | `"fixed"`, `"agent"` or `"plan"` (Action Space)           |
    | `family`          | see class                   | plant family of :mod:`envs.systems.families`                     |
    | `family_config`   | `None`                      | the family's config dataclass (its parameter ranges)      |
    | `noise_std`       | `0.01`                      | measurement noise, relative to a unit output change       |
    | `constraints`     | see class                   | :class:`envs.analysis.scoring.Constraints` or a dict of its fields |
    | `weights`         | `CostWeights()` (1, 1, 0.01, 0) | :class:`envs.analysis.scoring.CostWeights` or a dict: `load`, `setpoint`, `experiment` (per `T_ar` of experiment), `production` (per unit of `D_exp/T_ar`) |
    | `budget`          | `4`                         | experiments per episode (agent mode)                      |
    | `excursion_limit` | `5.0`                       | output limit that stops an experiment (agent mode)        |
    | `render_mode`     | `None`                      | `"rgb_array"`: `render()` draws the experiments and the loop |
    | `action`          | `"parameter"` (v1: `"residual"`) | the design parameter's coordinate: `"parameter"`, log scale over the range; `"residual"`, log-linear from the range's ends to the base rule's ``p_0`` at 0; `"robustness"`, the ``Ms`` (delay margin for the MSP) of the loop on the model (:mod:`envs.base_design`) |
    | `design_features` | `False` (v1: `True`)        | append ``log10 p_0`` and the base design's ``Ms`` and delay margin on the other identified model (:mod:`envs.base_design`) |
    | `identification`  | `"seeds"`                   | `"least-squares"` (not the MSP): fixed mode designs from the least-squares fit (Marlin 6.4) of the fixed procedure's open-loop step; agent mode adds a PRBS fitted by least squares, and the latest model experiment decides (:mod:`envs.episode_options`) |
    | `amplitude_limit` | `None` (none)               | largest experiment amplitude (output units, > 0): agent amplitudes are cut to it, the fixed procedure's experiments run at `min(1, limit)` |
    | `design_step`     | `False` (v2: `True`)        | agent mode: the commit completes and shows the identification (at the commit's amplitude), and a separate last step designs (Episode End) |
    | `violation_cost`  | `"graded"` (v3: `"bounded"`) | how a violating design is charged (Rewards; :func:`envs.analysis.scoring.violation_cost`) |
    | `measured_observation` | `False` (v3: `True`)   | the noise level estimated from the records (never the configured `noise_std`), failed experiments observed, and a failed commit charged instead of raised (Observation Space, Episode End) |
    | `plan`            | `None`                      | fixed mode: run the closed-loop step and the second experiment at these two amplitudes, as the plan mode's first step does (None: the procedure at amplitude 1 of the earlier versions) |
    | `experiment_set`  | `"all"` (v3: `"design"`)    | the agent mode's experiment types: all of the plant's kind, or those the design reads (Action Space) |
    | `discrete_action` | `False`                     | agent mode with `design_step`: a `Discrete` action with `action_masks()` instead of the `Box` (Action Space; :mod:`envs.discrete_action`) |
    | `disturbances`    | `None` (none)               | `{kind: level}` beyond the white noise, kinds `"drift"` (random walk, `level` per `sqrt(T_ar)`) and, for self-regulating plants, `"load"` (unmeasured input step during the experiment, `level` of output) (:mod:`envs.identification.disturbances`) |

    ``identification="seeds"`` is the identification of the source papers (the method of moments and the
    papers' formulas).  A bad value raises one ``ValueError`` naming the argument.

    ## Info
    At reset: ``plant`` (dict), ``features``.  On the final step: ``cost``, ``feasible``, ``score``
    (every figure of :class:`envs.analysis.scoring.Score`), ``plant``, ``model`` (identified), ``controller``,
    ``parameter`` (relative), ``experiment_time`` (in true ``T_ar``), ``features``; with a
    ``production`` weight also ``experiment_deviation`` (``D_exp`` in true ``T_ar``).  The wrapper
    ``agents.evaluation.oracle_info.OracleInfo`` adds ``oracle_cost`` and ``oracle_parameter``.

"""

_VERSION_HISTORY = """
    ## Version History
    * v0: initial version.  The oracle's figures come from the wrapper ``OracleInfo`` (Info), not
      from an argument of the environment, so that ``envs`` imports nothing from ``baselines``.
    * v1: ``action="residual"`` and ``design_features=True``: the action is a bounded
      log-correction of the structure's base rule (``gorez-klan-mu-2``, ``fppi-eq34``, ``msp-eq50``;
      action 0 is the rule), and the observation ends with three design features.  Plants,
      experiments, dynamics and cost are v0's.
    * v2: v1 with a price on production: ``weights={"production": 0.05}`` (each unit of
      ``D_exp/T_ar``, the experiments' integrated output deviation, costs 0.05: the fixed procedure
      at amplitude 1 costs about 0.5 more than in v1) and ``amplitude_limit=3`` (agent-mode
      amplitudes above 3 are cut to 3).  The fixed mode runs v1's experiments (the same
      identifications); its cost adds the production term.  Agent mode has ``design_step=True``:
      the commit completes the identification at its own amplitude and the design is a step of its
      own, which sees the identification and the design features (in v1 the commit's design was
      chosen before the missing experiments ran, and its features were zero).  In agent mode the
      FPPI base rule reads an unmeasured mismatch area as 0 (:func:`envs.base_design.base_parameter`).
    * v3: v2 with ``violation_cost="bounded"`` (a violating design costs ``21 + 5 g/(1 + g)``, an
      unstable loop 26: bounded, and no stable loop above an unstable one; v2's ``21 + g`` reached the
      thousands near instability) and ``measured_observation=True`` (the noise ratio and the relay's
      hysteresis from the noise level estimated in the closed-loop step's record, not the configured
      one; the feature ``failed_experiments``; a commit that identifies nothing is a failed experiment,
      never an exception), and ``experiment_set="design"`` (agent mode offers only the experiments
      the structure's design reads).  Plants, the fixed mode's experiments and feasible costs are v2's (the
      relay's hysteresis follows the estimate).  The ``"plan"`` mode is new in every version.
    * Every version with ``design_step`` in agent mode (v2, v3): the option ``discrete_action=True``,
      a ``Discrete`` action with ``action_masks()`` whose indices are ``Box`` actions (Action Space);
      without it every episode is unchanged.
"""


class PIDEnv(DeadTimeTuningEnv):
    __doc__ = """Gorez-Klan PID on self-regulating plants with dead time: choose ``mu``.

    ## Description
    A self-regulating plant ``K G(s) e^{-Ls}`` is identified by experiments; the SOPDT model of the
    method of moments (Gorez-Klan eq. 2-8) gives the series PID ``T_i = T_1``, ``T_d = T_2``,
    ``K_i = 1/(mu K D_2)`` (eq. 3-11, derivative filter ``T_d/10``), and the agent chooses ``mu``
    over [0.3, 300] (log scale).  The loop is then closed around the TRUE plant and scored.  Model
    mismatch is the point: on an FOPDT plant the SOPDT model invents a second lag, and the table's
    ``mu`` of 1.3 to 3 (Gorez-Klan table 3-1) can break ``Ms <= 2``.  When the moments see no dead
    time (``D_2 = 0``, plants with a strong lead) eq. 3-11 is undefined; :func:`envs.design.pid_design`
    floors ``D_2`` at 1% of ``T_ar``, which changes no design whose model has a larger dead time.

    Default family ``"stable"``: FOPDT, SOPDT and lag-chain plants in equal shares
    (:mod:`envs.systems.families`; also ``fopdt``, ``sopdt``, ``lag-chain`` and ``benchmark``); the
    held-out validation and test sets are fixed (:mod:`envs.systems.plant_sets`).  Default
    constraints ``Ms <= 2``, delay margin ``>= 0.2 L``.

    The residual action's base rule is ``gorez-klan-mu-2`` (``p_0 = 2``); ``action="robustness"``
    chooses the target ``Ms`` of the loop on the model, from 2.4 to 1.2, and solves for ``mu``.  The
    design features check the PID, designed on the SOPDT model, on its loop around the FOPDT model.
""" + _SHARED_DOC + _VERSION_HISTORY
    structure = "pid"


class FPPIEnv(DeadTimeTuningEnv):
    __doc__ = """Hagglund's filtered predictive PI on self-regulating plants: choose ``T_r/T_n``.

    ## Description
    The FOPDT model ``K_n, T_n, L_n`` of the open-loop step (Ingimundarson eq. 11) gives the FPPI
    with ``T_i = T_n``, ``kappa = T_n/T_r`` and the robustness filter ``T_f = T_r``
    (Ingimundarson section 4); the agent chooses ``T_r/T_n`` over [0.001, 10] (log scale).  The
    mismatch area ``T_f_bar/T_n`` (eq. 22) is observed: it is what eq. 28-29 tune from, and what
    makes ``fppi-eq34`` hard to beat.

    Default family ``"stable"`` (also ``fopdt``, ``sopdt``, ``lag-chain`` and ``benchmark``); default
    constraints ``Ms <= 2``, delay margin ``>= 0.2 L``.

    The residual action's base rule is ``fppi-eq34`` (``p_0`` its ``T_r/T_n`` for the episode's
    identification); ``action="robustness"`` chooses the target ``Ms`` of the loop on the model, from
    2.4 to 1.2, and solves for ``T_r``.  The design features check the FPPI, designed on the FOPDT
    model, on its loop around the SOPDT model.
""" + _SHARED_DOC + _VERSION_HISTORY
    structure = "fppi"


class MSPEnv(DeadTimeTuningEnv):
    __doc__ = """Modified Smith predictor on integrating plants: choose ``T_r/L_n``.

    ## Description
    The two-parameter model ``K_n e^{-L_n s}/s`` of the closed-loop step gives the MSP with
    ``K_0 = 1/(2 L_n K_n)`` and ``K_r = 1/(K_n T_r)`` (Ingimundarson section 5, eq. 36-38); the
    agent chooses ``T_r/L_n`` over [0.01, 30] (log scale).  The pulse area ``A`` (eq. 46) is
    observed: it is what eq. 43 tunes from.

    Default family ``"integrating"``: plants with one integrator (:mod:`envs.systems.families`; also
    ``benchmark``); the held-out validation and test sets are fixed (:mod:`envs.systems.plant_sets`).
    Default constraints: delay margin ``>= 0.2 L`` only, no
    ``Ms`` bound.  The MSP's own loop (eq. 47) has ``Ms`` of 2.2 to 2.4 for ``T_r/L_n <= 1`` even
    with a perfect model, so ``Ms <= 2`` would rule out every tuning rule of the paper (eq. 43,
    eq. 50, ``T_r = T_n``) and push every design to ``T_r/L_n`` of about 2.3; the delay margin is
    the robustness measure of Ingimundarson's own analysis (eq. 40).

    The residual action's base rule is ``msp-eq50`` (``p_0`` its ``T_r/L_n`` for the episode's
    identification); ``action="robustness"`` chooses the target delay margin of the loop on the model,
    from 0.1 to 1.5 ``L_n``, and solves for ``T_r``.  The design features check the MSP, designed on
    the two-parameter model, on its loop around the integrator with the closed-loop step's lag,
    ``K_n e^{-(L_n - T_n) s}/(s (T_n s + 1))``.
""" + _SHARED_DOC + _VERSION_HISTORY
    structure = "msp"


class PIEnv(DeadTimeTuningEnv):
    __doc__ = """Skogestad's SIMC PI on self-regulating plants: choose ``tau_c/theta``.

    ## Description
    The FOPDT model ``K_n e^{-L_n s}/(T_n s + 1)`` of the open-loop step (Ingimundarson eq. 11)
    gives the SIMC PI ``K_c = T_n/(K_n (tau_c + theta))``, ``T_i = min(T_n, 4 (tau_c + theta))``
    (S. Skogestad, "Simple analytic rules for model reduction and PID controller tuning",
    J. Process Control 13 (2003) 291-309; :func:`envs.design.simc_pi_gains`, the formula of the rule
    ``simc-pi`` too), ``theta = L_n`` floored at ``0.01 T_ar`` (a model without dead time); the agent chooses the closed-loop
    time constant ``tau_c`` as ``tau_c/theta`` over [0.03, 300] (log scale).  SIMC's own rule
    ``tau_c = theta`` ("tight" tuning) is ``simc-pi``, the strongest rule on these plants and the
    residual action's base: action 0 designs ``simc-pi``'s controller, bit for bit.  The loop is then
    closed around the TRUE plant and scored.

    The range: on 200 training plants (seeds 100000-100199, fixed mode) the oracle's ``tau_c/theta``
    searched over [0.001, 1000] has quantiles 1% 0.146, 5% 0.329, 25% 0.511, 50% 0.657, 75% 0.682,
    95% 1.80, 99% 80.0
    and lies in [0.079, 104]; the top 2.5% are plants whose open-loop step shows no dead time
    (``theta`` is the floor, and ``tau_c`` of about ``T_ar``).  The range leaves a factor of 2.6
    below and 2.9 above.

    Only ``-v3`` is registered, with the other structures' ``-v3`` arguments (residual action and
    design features, production priced, amplitude limit 3, a design step, bounded violation cost,
    measured observation; agent mode's experiments: closed-loop step and open-loop step).  The
    design features check the base design on the SOPDT model (Gorez-Klan eq. 2-8).

    Default family ``"stable"``: FOPDT, SOPDT and lag-chain plants in equal shares, those of
    ``PID-v3`` (:mod:`envs.systems.families`; also ``fopdt``, ``sopdt``, ``lag-chain`` and
    ``benchmark``); the held-out validation and test sets are fixed (:mod:`envs.systems.plant_sets`).
    Default constraints ``Ms <= 2``, delay margin ``>= 0.2 L``.

    The residual action's base rule is ``simc-pi`` (``p_0 = tau_c/theta = 1``); ``action="robustness"``
    chooses the target ``Ms`` of the loop on the model, from 2.4 to 1.2, and solves for ``tau_c``.
""" + _SHARED_DOC + """
    ## Version History
    * v3: initial version: the structure ``pi`` (:mod:`envs.structures`) in the ``-v3`` regime of
      the other structures (Arguments).  Plants, experiments and cost are ``PID-v3``'s.
"""
    structure = "pi"
