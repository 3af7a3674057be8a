"""The ways of playing a tuning episode: the fixed, plan and agent modes, and the agent mode with a
discrete action and masks (its layout: :mod:`envs.discrete_action`).

A mode reads the arguments ``experiments``, ``budget``, ``excursion_limit``, ``plan`` and
``design_step`` (:class:`envs.env_config.EnvConfig`): it starts an episode on a plant (the fixed mode
runs its procedure) and turns each action into experiments, the identification and the design on the
episode core (:class:`envs.tuning_episode.TuningEpisode`).  Every step returns Gymnasium's
``(observation, reward, terminated, truncated, info)``; the environment
(:class:`envs.tuning_env.DeadTimeTuningEnv`) passes itself as ``env``: its ``episode``, ``np_random``,
``action_space``, ``layout`` (:class:`envs.observation.ObservationLayout`), and the two methods a
subclass may change, ``parameter_from_action`` and ``observation_and_features``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from envs.discrete_action import DiscreteLayout
from envs.env_config import ModeConfig
from envs.episode import IdentificationFailed
from envs.episode_options import AMPLITUDE_RANGE, EpisodeOptions
from envs.identification.procedure import ProcedureFailed
from envs.systems.plants import Plant
from envs.tuning_episode import NO_DESIGN_COST
from envs.validation import require_number, require_real_array

__all__ = ["MODES", "MAX_BUDGET", "Mode", "FixedMode", "PlanMode", "AgentMode", "DiscreteAgentMode", "mode_of",
           "checked_budget", "checked_plan", "experiment_amplitude"]

MODES = ("fixed", "agent", "plan")
MAX_BUDGET = 100
"""The largest ``budget`` (agent mode's experiments per episode): far above any useful identification
(the procedure runs two), and an episode of an agent that never commits stays short."""

Step = tuple[np.ndarray, float, bool, bool, dict]


def checked_budget(budget: Any) -> int:
    """``budget`` as an integer from 1 to :data:`MAX_BUDGET`, or a ``ValueError`` naming it."""
    if isinstance(budget, bool) or not isinstance(budget, (int, float, np.integer, np.floating)) \
            or not math.isfinite(budget) or int(budget) != budget or not 1 <= budget <= MAX_BUDGET:
        raise ValueError(f"budget must be an integer from 1 to {MAX_BUDGET}, got {budget!r}")
    return int(budget)


def checked_plan(plan: Any, experiments: str) -> tuple[float, float] | None:
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


def experiment_amplitude(amplitude_action: float, options: EpisodeOptions) -> float:
    """The experiment amplitude of an action's component in [-1, 1]: log scale over
    :data:`~envs.episode_options.AMPLITUDE_RANGE`, cut to the options' amplitude limit."""
    low, high = (math.log10(v) for v in AMPLITUDE_RANGE)
    return options.limited(10.0 ** (low + 0.5 * (amplitude_action + 1.0) * (high - low)))


def _require_flag(value: Any, name: str) -> bool:
    if not isinstance(value, bool):
        raise ValueError(f"{name} must be true or false, got {value!r}")
    return value


def mode_of(config: ModeConfig, experiment_names: tuple[str, ...]) -> Mode:
    """The way of playing ``config`` names (its values checked, each bad one a ``ValueError`` naming it);
    ``experiment_names`` are the agent mode's experiment types."""
    if config.experiments not in MODES:
        raise ValueError(f"experiments must be one of {', '.join(MODES)}, got {config.experiments!r}")
    _require_flag(config.design_step, "design_step")
    plan = checked_plan(config.plan, config.experiments)
    budget = checked_budget(config.budget)
    excursion_limit = require_number(config.excursion_limit, "excursion_limit", positive=True)
    if config.experiments == "fixed":
        mode: Mode = FixedMode(budget, excursion_limit, plan)
    elif config.experiments == "plan":
        mode = PlanMode(budget, excursion_limit)
    else:
        mode = AgentMode(budget, excursion_limit, config.design_step)
    if not _require_flag(config.discrete_action, "discrete_action"):
        return mode
    if mode.name != "agent" or not mode.design_step:
        raise ValueError("discrete_action needs experiments='agent' with design_step=True (the v2-v3 agent mode), "
                         f"got experiments={config.experiments!r}")
    return DiscreteAgentMode(budget, excursion_limit, experiment_names)


class Mode:
    """What every mode shares: the outcomes of a step (an experiment, the identification, the design).

    Attributes
    ----------
    name : str
        ``"fixed"``, ``"plan"`` or ``"agent"``.
    budget : int
        Experiments per episode (agent mode; the observation's counts are over it in every mode).
    excursion_limit : float
        The output limit that stops an experiment the mode runs.
    """

    name = "fixed"
    design_step = False

    def __init__(self, budget: int, excursion_limit: float) -> None:
        self.budget, self.excursion_limit = budget, excursion_limit

    def size(self, experiment_names: tuple[str, ...]) -> int:
        """The number of components of the ``Box`` action."""
        return 1

    def start(self, env: Any, plant: Plant, given: bool) -> None:
        """Begin an episode on ``plant`` (``given``: a plant that is not drawn again if it fails)."""
        env.episode.start(plant)

    def step(self, env: Any, action: Any) -> Step:
        raise NotImplementedError

    def checked_action(self, env: Any, action: Any) -> np.ndarray:
        """The action as float64 of the action space's shape (a number for a one-component action),
        clipped to [-1, 1]; a boolean, complex or non-numeric array, or another shape, is a ``ValueError``."""
        raw = require_real_array(action, "action")
        shape = env.action_space.shape
        if raw.shape != shape and not (shape == (1,) and raw.shape == ()):
            raise ValueError(f"action must have shape {shape}, got {raw.shape}")
        return np.clip(raw.reshape(shape), -1.0, 1.0)

    # ------------------------------------------------------------------ outcomes
    @staticmethod
    def amplitude(env: Any, amplitude_action: float) -> float:
        return experiment_amplitude(amplitude_action, env.episode.options)

    def experiment(self, env: Any, kind: str, amplitude: float) -> Step:
        env.episode.run(kind, amplitude, env.np_random, self.excursion_limit)
        observation, named = env.observation_and_features()
        return observation, 0.0, False, False, {"experiment": kind, "amplitude": amplitude, "features": named}

    def identify(self, env: Any, amplitude: float) -> Step:
        """Complete the identification at ``amplitude`` and show it; the next step designs."""
        try:
            env.episode.identify(env.np_random, amplitude=amplitude)
        except IdentificationFailed as failure:
            return self.failed(env, failure, amplitude)
        env.episode.design_pending = True
        observation, named = env.observation_and_features()
        return observation, 0.0, False, False, {"identified": True, "amplitude": amplitude, "features": named}

    def failed(self, env: Any, failure: IdentificationFailed, amplitude: float | None) -> Step:
        """``measured_observation``: a commit whose identification failed is a failed experiment (charged,
        shown in ``failed_experiments``); the episode goes on while the budget lasts, and else ends
        without a design at :data:`NO_DESIGN_COST`.  Otherwise the failure raises, as in v0-v2."""
        if not env.episode.options.measured:
            raise failure
        env.episode.keep_failed(failure)
        observation, named = env.observation_and_features()
        info = {"identified": False, "amplitude": amplitude, "features": named}
        if env.episode.evidence.runs < self.budget:
            return observation, 0.0, False, False, info
        return self.no_design(env, info)

    def no_design(self, env: Any, info: dict) -> Step:
        """End the episode without a design, at :data:`NO_DESIGN_COST`."""
        episode = env.episode
        episode.done = True
        observation, named = env.observation_and_features()
        info = {**info, **episode.no_design_info(), "features": named, **episode.production_info()}
        return observation, -NO_DESIGN_COST, True, False, info

    def design(self, env: Any, parameter_action: float) -> Step:
        """End the episode with the design of ``parameter_action`` on the identification."""
        episode = env.episode
        relative = env.parameter_from_action(parameter_action)
        controller, result = episode.commit(relative)
        observation, named = env.observation_and_features()
        info = {**episode.final_info(result, relative, controller), "features": named, **episode.production_info()}
        return observation, -float(result.cost), True, False, info


class FixedMode(Mode):
    """``experiments="fixed"``: the fixed procedure (or a ``plan``'s two amplitudes) at the start, one design step."""

    def __init__(self, budget: int, excursion_limit: float, plan: tuple[float, float] | None = None) -> None:
        super().__init__(budget, excursion_limit)
        self.plan = plan

    def start(self, env: Any, plant: Plant, given: bool) -> None:
        episode = env.episode
        episode.start(plant)
        try:
            if self.plan is not None:
                episode.run_plan(*(episode.options.limited(a) for a in self.plan), env.np_random, self.excursion_limit)
            else:
                episode.run_fixed_procedure(env.np_random)
        except (ProcedureFailed, IdentificationFailed) as failure:
            if not (given and episode.options.measured):
                raise
            episode.fail_procedure(failure)

    def step(self, env: Any, action: Any) -> Step:
        action = self.checked_action(env, action)
        if env.episode.identification is None:  # the procedure failed on a given plant
            return self.no_design(env, {"identified": False})
        return self.design(env, action[-1])


class PlanMode(Mode):
    """``experiments="plan"``: the first step runs the fixed procedure's two experiments at its
    amplitudes and shows the identification, the second designs."""

    name = "plan"
    design_step = True

    def size(self, experiment_names: tuple[str, ...]) -> int:
        return 3

    def step(self, env: Any, action: Any) -> Step:
        action = self.checked_action(env, action)
        if env.episode.design_pending:
            return self.design(env, action[-1])
        first, second = self.amplitude(env, float(action[0])), self.amplitude(env, float(action[1]))
        try:
            env.episode.run_plan(first, second, env.np_random, self.excursion_limit)
        except IdentificationFailed as failure:
            if not env.episode.options.measured:
                raise
            env.episode.keep_failed(failure)
            return self.no_design(env, {"identified": False, "amplitudes": (first, second)})
        env.episode.design_pending = True
        observation, named = env.observation_and_features()
        return observation, 0.0, False, False, {"identified": True, "amplitudes": (first, second), "features": named}


class AgentMode(Mode):
    """``experiments="agent"``: experiments chosen one step at a time, then the commit (with
    ``design_step``: the commit shows the identification and a step of its own designs)."""

    name = "agent"

    def __init__(self, budget: int, excursion_limit: float, design_step: bool = False) -> None:
        super().__init__(budget, excursion_limit)
        self.design_step = design_step

    def size(self, experiment_names: tuple[str, ...]) -> int:
        return len(experiment_names) + 3

    def step(self, env: Any, action: Any) -> Step:
        action = self.checked_action(env, action)
        episode = env.episode
        if not episode.design_pending:
            names = env.layout.experiment_names
            choice = int(np.argmax(action[: len(names) + 1]))
            if choice > 0 and episode.evidence.runs < self.budget:
                return self.experiment(env, names[choice - 1], self.amplitude(env, action[-2]))
            if self.design_step:
                return self.identify(env, self.amplitude(env, action[-2]))
        return self.commit(env, action[-1])

    def commit(self, env: Any, parameter_action: float) -> Step:
        """The design, after the identification the commit completes (without a design step)."""
        if not env.episode.design_pending:
            try:
                env.episode.identify(env.np_random)
            except IdentificationFailed as failure:
                return self.failed(env, failure, None)
        return self.design(env, parameter_action)


class DiscreteAgentMode(AgentMode):
    """``discrete_action=True``: the agent mode with a design step, its action an index of a
    :class:`~envs.discrete_action.DiscreteLayout` (:mod:`envs.discrete_action`)."""

    def __init__(self, budget: int, excursion_limit: float, experiment_names: tuple[str, ...]) -> None:
        super().__init__(budget, excursion_limit, design_step=True)
        self.layout = DiscreteLayout(experiment_names)

    def checked_index(self, action: Any) -> int:
        """The discrete action as an index; anything but one integer in range is a ``ValueError`` naming it."""
        raw = np.asarray(action)
        size = self.layout.size
        if raw.shape not in ((), (1,)) or raw.dtype.kind not in "iu" or not 0 <= int(raw.reshape(-1)[0]) < size:
            raise ValueError(f"action must be one integer index from 0 to {size - 1}, got {action!r}")
        return int(raw.reshape(-1)[0])

    def step(self, env: Any, action: Any) -> tuple[np.ndarray, float, bool, bool, dict]:
        """The step of the index's meaning."""
        meaning = self.layout.meaning(self.checked_index(action))
        episode = env.episode
        amplitude = episode.options.limited(1.0 if meaning.kind == "design" else meaning.value)
        if episode.design_pending:
            result = self.commit(env, meaning.value if meaning.kind == "design" else 0.0)
        elif meaning.kind in ("commit", "design") or episode.evidence.runs >= self.budget:
            result = self.identify(env, amplitude)
        else:
            result = self.experiment(env, meaning.kind, amplitude)
        observation, reward, terminated, truncated, info = result
        return observation, reward, terminated, truncated, {**info, "action": meaning.name}

    def masks(self, episode: Any) -> np.ndarray:
        """Which indices mean something in ``episode``'s state (sb3-contrib's ``MaskablePPO`` reads them)."""
        budget_left = episode.evidence is None or episode.evidence.runs < self.budget
        return self.layout.masks(design_pending=episode.design_pending, budget_left=budget_left,
                                 amplitude_limit=episode.options.amplitude_limit)
