"""Experiment procedures without learning: a fixed plan of amplitudes, and Marlin's amplitude rule.

They choose the experiments of an episode (the environments' ``"plan"`` and ``"agent"`` modes) and
design with the structure's base rule (the residual action 0: ``gorez-klan-mu-2``, ``fppi-eq34``,
``msp-eq50``; :mod:`envs.base_design`), so that against the fixed procedure (the papers' experiments
at amplitude 1 and the same rule) they measure what choosing the experiments is worth by itself.
Each plays like a trained agent: ``predict(observation) -> (action, None)``, with ``env_kwargs`` the
interface it needs (:func:`procedure`).

* :class:`PlanRule`, ``plan-A1-A2``: every plant gets the closed-loop step at amplitude ``A1`` and
  the open-loop step (or pulse) at ``A2``.  ``plan-1-1`` is the fixed procedure.
* :class:`AmplitudeRule`, ``amplitude-rule``: the closed-loop step at amplitude 1, then the second
  experiment at the smallest amplitude whose signal-to-noise ratio is :data:`SIGNAL_TO_NOISE`, with
  the noise level estimated from the first record (the observation's ``log_noise_ratio``): Marlin's
  guideline for the process reaction curve, "the signal-to-noise ratio should be at least 5", the
  noise being "the variation experienced by the output variable when all measured inputs are
  constant" (Marlin, Process Control, section 6.3, experimental design; his example: an output that
  varies by +-1 needs a change of at least 5).  The variation is read as the band of
  :data:`NOISE_BAND` standard deviations either side (95% of the samples of white Gaussian noise), so
  the amplitude is ``SIGNAL_TO_NOISE * NOISE_BAND * sigma = 10 sigma``, within the action's range.

Only numpy here: the policies read the observation by the feature names of the environment they
play (:meth:`AmplitudeRule.bind`).
"""

from __future__ import annotations

import math
import re

import numpy as np

from envs.episode_options import AMPLITUDE_RANGE

__all__ = ["AMPLITUDE_RANGE", "BEST_PLAN", "NOISE_BAND", "SIGNAL_TO_NOISE", "AmplitudeRule", "PlanRule", "amplitude_action",
           "is_procedure", "procedure"]

SIGNAL_TO_NOISE = 5.0
"""Marlin's least signal-to-noise ratio of a step test (section 6.3)."""
NOISE_BAND = 2.0
"""Half-width of the noise's band of variation, in standard deviations (95% of Gaussian samples)."""

_PLAN = re.compile(r"^plan-(?P<first>[0-9.]+(?:e-?[0-9]+)?)-(?P<second>[0-9.]+(?:e-?[0-9]+)?)$")
_BASE_RULE = 0.0  # the residual action of the structure's base rule
_PROCEDURE_KWARGS = {"action": "residual", "design_features": True}


def amplitude_action(amplitude: float) -> float:
    """The action component of an amplitude (log scale over :data:`AMPLITUDE_RANGE`), clipped to [-1, 1]."""
    low, high = (math.log10(v) for v in AMPLITUDE_RANGE)
    return float(np.clip(2.0 * (math.log10(amplitude) - low) / (high - low) - 1.0, -1.0, 1.0))


class PlanRule:
    """The same plan for every plant: the closed-loop step at ``first``, the open-loop step (or pulse)
    at ``second``, then the base rule's design (``experiments="plan"``)."""

    def __init__(self, first: float, second: float) -> None:
        for name, value in (("first", first), ("second", second)):
            if not (isinstance(value, (int, float)) and math.isfinite(value) and value > 0):
                raise ValueError(f"plan amplitude {name} must be a positive number, got {value!r}")
        self.first, self.second = float(first), float(second)
        self.name = f"plan-{self.first:g}-{self.second:g}"
        self.env_kwargs = {"experiments": "plan", **_PROCEDURE_KWARGS}
        self._action = np.array([amplitude_action(self.first), amplitude_action(self.second), _BASE_RULE], dtype=np.float32)

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        """The plan's action: its amplitudes (read on the first step) and the base rule (on the second)."""
        return self._action.copy(), None


class AmplitudeRule:
    """Marlin's amplitude rule in the sequential agent mode (module docstring): closed-loop step at 1,
    the second experiment at ``10 sigma``, commit, base rule."""

    name = "amplitude-rule"

    def __init__(self, first: float = 1.0) -> None:
        self.first = float(first)
        self.env_kwargs = {"experiments": "agent", "design_step": True, **_PROCEDURE_KWARGS}
        self._layout: dict | None = None

    def bind(self, feature_names: tuple[str, ...], experiment_names: tuple[str, ...]) -> AmplitudeRule:
        """Read observations of an environment with these feature and experiment names."""
        second = "pulse" if "pulse" in experiment_names else "open-loop-step"
        missing = [n for n in ("log_noise_ratio", "count_closed-loop-step", f"count_{second}", "design_step") if n not in feature_names]
        if missing:
            raise ValueError(f"amplitude-rule needs an agent-mode environment with a design step; the observation has no {missing[0]!r}")
        index = {name: i for i, name in enumerate(feature_names)}
        self._layout = {
            "noise": index["log_noise_ratio"], "first": index["count_closed-loop-step"], "second": index[f"count_{second}"],
            "design": index["design_step"], "choices": len(experiment_names) + 1,
            "first_choice": 1 + experiment_names.index("closed-loop-step"), "second_choice": 1 + experiment_names.index(second),
        }
        return self

    def second_amplitude(self, log_noise_ratio: float) -> float:
        """``SIGNAL_TO_NOISE NOISE_BAND sigma``, ``sigma`` from the first step's noise ratio ``sigma/first``."""
        sigma = 10.0 ** float(log_noise_ratio) * self.first
        return SIGNAL_TO_NOISE * NOISE_BAND * sigma

    def predict(self, observation, state=None, episode_start=None, deterministic: bool = True):
        """The next action of the procedure, read off the observation's counts and design flag."""
        if self._layout is None:
            raise RuntimeError("amplitude-rule: bind() it to the environment's feature names first")
        layout, observation = self._layout, np.asarray(observation, dtype=np.float64).reshape(-1)
        action = np.full(layout["choices"] + 2, -1.0, dtype=np.float32)
        action[-1] = _BASE_RULE
        if observation[layout["first"]] == 0:
            action[layout["first_choice"]], action[-2] = 1.0, amplitude_action(self.first)
        elif observation[layout["second"]] == 0:
            amplitude = self.second_amplitude(observation[layout["noise"]])
            action[layout["second_choice"]], action[-2] = 1.0, amplitude_action(amplitude)
        else:
            action[0], action[-2] = 1.0, amplitude_action(self.first)  # commit (nothing missing: no run)
        return action, None


BEST_PLAN = "plan-best"
"""The name of the plan chosen on validation plants (``agents.evaluation.plan_search``)."""


def is_procedure(name: str) -> bool:
    """Whether ``name`` names a procedure (``plan-A1-A2``, ``plan-best`` or ``amplitude-rule``)."""
    return name in (AmplitudeRule.name, BEST_PLAN) or _PLAN.match(name) is not None


def procedure(name: str) -> PlanRule | AmplitudeRule:
    """The procedure of a name (:func:`is_procedure`).

    Raises
    ------
    ValueError
        For a name of neither form, or plan amplitudes outside :data:`AMPLITUDE_RANGE`.
    """
    if name == AmplitudeRule.name:
        return AmplitudeRule()
    if name == BEST_PLAN:
        return PlanRule(1.0, 1.0)  # a placeholder of the interface: the evaluation chooses the plan
    found = _PLAN.match(name)
    if found is None:
        raise ValueError(f"unknown procedure {name!r}; procedures: plan-A1-A2 (e.g. plan-1-1), amplitude-rule")
    first, second = float(found["first"]), float(found["second"])
    low, high = AMPLITUDE_RANGE
    for value in (first, second):
        if not low <= value <= high:
            raise ValueError(f"procedure {name!r}: amplitude {value:g} outside [{low:g}, {high:g}]")
    return PlanRule(first, second)
