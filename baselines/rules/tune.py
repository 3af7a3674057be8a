"""``deadtime tune``: the controller a rule gives for a plant, and the analysis of its loop.

Without a model the rule's inputs come from the fixed procedure run noise-free on the plant
(:func:`envs.identification.procedure.identify`: closed-loop step, then open-loop step or pulse); with a model
(:meth:`baselines.rules.registry.RuleInputs.from_model`) the rule reads the model, and ``T_f_bar`` (eq. 22)
or ``A`` (eq. 46) are measured against it on the noise-free plant.  Without a plant the model is
the plant.  The analysis is that of ``deadtime analyze`` (:func:`envs.analysis.loop_analysis.analyze`) on the
plant.

:meth:`Tuning.problem` says what is wrong with the loop, if anything: unstable, or outside the
constraints of the environment of the rule's controller (``Ms <= 2`` and ``DM >= 0.2 L``; for the
MSP the delay margin only, as ``MSP-v0``); ``deadtime tune`` prints it on stderr and exits 3.  A
``T_r`` rule whose ``T_r`` falls below :data:`TR_FLOORS` times ``L_n`` is refused
(:class:`DegenerateTuning`, exit 3) before any analysis: eq. 28 and eq. 43 take ``T_r`` from the
model error (``T_f_bar``, ``A``), which an exact model makes zero (``T_r = 8.3e-7`` for
``2.5 e^{-4s}/(12 s + 1)``), and there the loop's frequency analysis degenerates.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from baselines.rules.registry import RULES, Rule, RuleInputs, get_rule
from envs.analysis.loop_analysis import LoopAnalysis, analyze
from envs.systems.controllers import Controller
from envs.identification.models import Model, model_from_dict
from envs.systems.plants import Plant, as_plant
from envs.identification.procedure import identify
from envs.structures import STRUCTURES
from envs.threads import single_threaded

__all__ = ["DegenerateTuning", "TR_FLOORS", "Tuning", "rule_inputs", "rule_list", "tune"]

TR_FLOORS: dict[str, float] = {"fppi": 0.08, "msp": 0.14}
"""The smallest ``T_r/L_n`` a ``T_r`` rule may give, per controller.

At the floor the controller's loop around its own exact model has a delay margin of ``0.2 L_n``
(the environments' default constraint; delay margin as Ingimundarson section 3): measured
``T_r/L_n = 0.0790`` for the FPPI (closed loop ``e^{-L_n s}/(T_r s + 1)``, eq. 15, any ``T_n``)
and ``0.1394`` for the MSP (eq. 47), rounded up.  Below it no plant, not even the model itself, is
held with that margin: such a ``T_r`` only comes from a model error of zero (eq. 28, eq. 43 on an
exact model), i.e. a degenerate input, not from a design (test: ``test_tr_floors_are_the_exact_model_delay_margin``).
"""

LOOP_CONSTRAINTS: dict[str, tuple[float | None, float]] = {"pid": (2.0, 0.2), "pid-series": (2.0, 0.2), "fppi": (2.0, 0.2), "msp": (None, 0.2)}
"""``(max Ms, min DM/L)`` that :meth:`Tuning.problem` checks per controller: the default
constraints of ``PID-v0``, ``FPPI-v0`` and ``MSP-v0`` (:mod:`envs.tuning_env`, docs/scoring.md)."""


class DegenerateTuning(ValueError):
    """A rule's design parameter below :data:`TR_FLOORS` (``deadtime tune`` exits 3)."""

    exit_status = 3


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
        :func:`envs.analysis.loop_analysis.analyze` of the true plant with ``controller``.
    plant : Plant or None
        The plant of the analysis (the given plant, or the model).
    """

    rule: Rule
    inputs: RuleInputs
    controller: Controller
    analysis: LoopAnalysis
    plant: Plant | None = None

    @property
    def parameter(self) -> float | None:
        """The design parameter (``mu`` or ``T_r``) of the rules that go through :mod:`envs.design`."""
        return None if self.rule.parameter is None else float(self.rule.parameter(self.inputs))

    def problem(self) -> str | None:
        """What is wrong with the loop on :attr:`plant` (one line), or None.

        Unstable (with the number of closed-loop poles in the right half plane, or "infinitely
        many" when ``|L(i w)| >= 1`` as ``w -> inf``), or outside :data:`LOOP_CONSTRAINTS`.
        """
        m = self.analysis.margins
        if not m.stable:
            poles = "infinitely many" if m.unstable_poles < 0 else str(m.unstable_poles)
            return f"{self.rule.name} gives an unstable loop on the plant ({poles} closed-loop poles in the right half plane)"
        max_ms, min_relative_dm = LOOP_CONSTRAINTS[self.rule.controller]
        broken = []
        if max_ms is not None and m.ms > max_ms:
            broken.append(f"Ms = {m.ms:.4g} > {max_ms:g}")
        dead_time = 0.0 if self.plant is None else self.plant.dead_time
        if dead_time > 0 and m.delay_margin < min_relative_dm * dead_time:
            broken.append(f"delay margin = {m.delay_margin / dead_time:.4g} L < {min_relative_dm:g} L")
        if broken:
            return f"{self.rule.name} gives a loop outside the constraints on the plant: {', '.join(broken)}"
        return None

    def to_dict(self) -> dict[str, Any]:
        """The JSON object of ``deadtime tune --json``; ``controller`` is ``deadtime analyze``'s JSON."""
        return {
            "rule": self.rule.name,
            "citation": self.rule.citation,
            "parameter": self.parameter,
            "controller": self.controller.to_dict(),
            "analysis": self.analysis.to_dict(),
            "inputs": self.inputs.to_dict(),
            "plant": None if self.plant is None else self.plant.to_dict(),
            "problem": self.problem(),
        }


def rule_inputs(plant: Plant, model: Model | None = None) -> RuleInputs:
    """The rule inputs for ``plant``: from ``model`` if given, else from the noise-free procedure."""
    if model is not None:
        return RuleInputs.from_model(model, plant)
    return RuleInputs.from_identification(identify(plant, np.random.default_rng(0)))


@single_threaded
def tune(rule: str, plant: Any = None, model: Model | dict | None = None) -> Tuning:
    """The controller of ``rule`` for ``plant`` (see the module docstring).

    Parameters
    ----------
    rule : str
        A name of :data:`baselines.rules.registry.RULES`.
    plant : Plant, dict, control.TransferFunction or (TransferFunction, dead_time), optional
        The true plant (any form :func:`envs.systems.plants.as_plant` takes); default: the model.
    model : FOPDTModel, SOPDTModel, IntegratingModel or its dict, optional
        An identified model to use instead of running the experiments.

    Raises
    ------
    ValueError
        For an unknown rule, a rule for the other kind of plant, neither plant nor model, a model
        that does not fit the plant, or a rule undefined for these inputs (e.g. eq. 43 with
        ``A >= K_n L_n``).
    DegenerateTuning
        For a ``T_r`` below :data:`TR_FLOORS` times ``L_n``.

    Examples
    --------
    >>> t = tune("gorez-klan-mu-2", Plant.from_time_constants(1.0, [2.0, 1.0], 1.0))
    >>> t.controller.to_dict()["type"], t.parameter, t.analysis.stable
    ('pid-series', 2.0, True)
    >>> t = tune("simc-pi", model={"type": "fopdt", "gain": 2.5, "time_constant": 12, "dead_time": 4})
    >>> t.controller.kp, t.controller.ti, t.problem()
    (0.6, 12.0, None)
    """
    chosen = get_rule(rule)
    if isinstance(model, dict):
        model = model_from_dict(model)
    if plant is None:
        if model is None:
            raise ValueError("tune needs a plant or a model (the model is then the plant)")
        plant = model.plant()
    plant = as_plant(plant)
    if chosen.plants == "stable" and plant.integrating:
        raise ValueError(f"rule {chosen.name} is for self-regulating plants; the plant is integrating")
    if chosen.plants == "integrating" and not plant.integrating:
        raise ValueError(f"rule {chosen.name} is for integrating plants; the plant is self-regulating")
    inputs = rule_inputs(plant, model)
    _refuse_degenerate(chosen, inputs)
    controller = chosen.design(inputs)
    return Tuning(chosen, inputs, controller, analyze(plant, controller), plant)


def _refuse_degenerate(rule: Rule, inputs: RuleInputs) -> None:
    """Raise :class:`DegenerateTuning` if ``rule``'s ``T_r`` is below its floor (:data:`TR_FLOORS`)."""
    if rule.parameter is None or rule.controller not in TR_FLOORS:
        return
    structure = next(s for s in STRUCTURES.values() if s.controller == rule.controller)
    model = structure.model_of(inputs)
    if model is None or not model.dead_time > 0:
        return
    tr, floor = float(rule.parameter(inputs)), TR_FLOORS[rule.controller]
    if tr < floor * model.dead_time:
        cause = f"A = {inputs.pulse_area:.3g}" if structure.integrating else f"T_f_bar = {inputs.mismatch_time:.3g}"
        raise DegenerateTuning(
            f"{rule.name} gives T_r = {tr:.3g} = {tr / model.dead_time:.3g} L_n, below the floor {floor:g} L_n: the model "
            f"error ({cause}) is about zero, as for an exact model, and below the floor even the model's own loop has DM < 0.2 L_n"
        )


def rule_list() -> list[dict[str, str]]:
    """Name, controller, plants and citation of every rule (``deadtime tune --list``)."""
    return [
        {"name": r.name, "controller": r.controller, "plants": r.plants, "citation": r.citation}
        for r in RULES.values()
    ]
