"""``deadtime tune``: the controller a rule gives for a plant, and the analysis of its loop.

Without a model the rule's inputs come from the seeds' procedure run noise-free on the plant
(:func:`envs.procedure.identify`: closed-loop step, then open-loop step or pulse); with a model
(:meth:`baselines.rules.RuleInputs.from_model`) the rule reads the model, and ``T_f_bar`` (eq. 22)
or ``A`` (eq. 46) are measured against it on the noise-free plant.  The analysis is that of
``deadtime analyze`` (:func:`envs.analysis.analyze`) on the true plant.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from baselines.rules import RULES, Rule, RuleInputs, get_rule
from envs.analysis import LoopAnalysis, analyze
from envs.controllers import Controller
from envs.identification import Model
from envs.plants import Plant
from envs.procedure import identify
from envs.threads import single_threaded

__all__ = ["Tuning", "rule_inputs", "rule_list", "tune"]


@dataclass(frozen=True)
class Tuning:
    """A rule's controller for one plant and the analysis of the loop it closes.

    Attributes
    ----------
    rule : Rule
    inputs : RuleInputs
        What the rule read.
    controller : Controller
    analysis : LoopAnalysis
        :func:`envs.analysis.analyze` of the true plant with ``controller``.
    """

    rule: Rule
    inputs: RuleInputs
    controller: Controller
    analysis: LoopAnalysis

    @property
    def parameter(self) -> float | None:
        """The design parameter (``mu`` or ``T_r``) of the rules that go through :mod:`envs.design`."""
        return None if self.rule.parameter is None else float(self.rule.parameter(self.inputs))

    def to_dict(self) -> dict[str, Any]:
        """The JSON object of ``deadtime tune --json``; ``controller`` is ``deadtime analyze``'s JSON."""
        return {
            "rule": self.rule.name,
            "citation": self.rule.citation,
            "parameter": self.parameter,
            "controller": self.controller.to_dict(),
            "analysis": self.analysis.to_dict(),
            "inputs": self.inputs.to_dict(),
        }


def rule_inputs(plant: Plant, model: Model | None = None) -> RuleInputs:
    """The rule inputs for ``plant``: from ``model`` if given, else from the noise-free procedure."""
    if model is not None:
        return RuleInputs.from_model(model, plant)
    return RuleInputs.from_identification(identify(plant, np.random.default_rng(0)))


@single_threaded
def tune(rule: str, plant: Plant, model: Model | None = None) -> Tuning:
    """The controller of ``rule`` for ``plant`` (see the module docstring).

    Parameters
    ----------
    rule : str
        A name of :data:`baselines.rules.RULES`.
    plant : Plant
        The true plant.
    model : FOPDTModel, SOPDTModel or IntegratingModel, optional
        An identified model to use instead of running the experiments.

    Raises
    ------
    ValueError
        For an unknown rule, a rule for the other kind of plant, a model that does not fit the
        plant, or a rule undefined for these inputs (e.g. eq. 43 with ``A >= K_n L_n``).

    Examples
    --------
    >>> t = tune("gorez-klan-mu-2", Plant.from_time_constants(1.0, [2.0, 1.0], 1.0))
    >>> t.controller.to_dict()["type"], t.parameter, t.analysis.stable
    ('pid-series', 2.0, True)
    """
    chosen = get_rule(rule)
    if chosen.plants == "stable" and plant.integrating:
        raise ValueError(f"rule {chosen.name} is for self-regulating plants; the plant is integrating")
    if chosen.plants == "integrating" and not plant.integrating:
        raise ValueError(f"rule {chosen.name} is for integrating plants; the plant is self-regulating")
    inputs = rule_inputs(plant, model)
    controller = chosen.design(inputs)
    return Tuning(chosen, inputs, controller, analyze(plant, controller))


def rule_list() -> list[dict[str, str]]:
    """Name, controller, plants and citation of every rule (``deadtime tune --list``)."""
    return [
        {"name": r.name, "controller": r.controller, "plants": r.plants, "citation": r.citation}
        for r in RULES.values()
    ]
