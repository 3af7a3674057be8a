"""Every rule a one-parameter family by its risk knob ``s``: the shipped rule at ``s = 0``, more conservative for ``s > 0``.

The knob is the one a control engineer turns, on a log scale:

* a rule with a design parameter through the design maps of :mod:`envs.design` (the Gorez-Klan ``mu``
  rules, eq. 3-11; Ingimundarson's FPPI and MSP ``T_r`` rules, eq. 14-15 and 36-38, Hagglund's
  ``ppi-kappa1``; the robustness-matched ``mu`` and ``T_r`` of ``gorez-klan-ms*``, ``fppi-ms*``,
  ``msp-dm*``): that parameter times ``exp(s)``.  A larger ``mu`` is a smaller gain
  (``K_p = T_1/(mu K L)``, Gorez-Klan eq. 3-11); a larger ``T_r`` a slower closed loop and a larger
  delay margin (Ingimundarson section 3).  For a matched rule the knob scales the matched parameter,
  not its target;
* SIMC (``simc-pi``, ``simc-pid``, ``isimc-pi``): ``tau_c = theta exp(s)`` (Skogestad 2003: a larger
  ``tau_c`` is a slower, more robust loop; ``tau_c = theta`` is his tight default); IMC
  (``imc-pi``, ``imc-pid``): ``lambda`` times ``exp(s)`` (Rivera, Morari and Skogestad 1986);
* every other rule (AMIGO, Ziegler-Nichols, Cohen-Coon and the classic PI/PID rules, and the matched
  SIMC/IMC rules): the detuning of its gain, ``K_p exp(-s)`` with its integral and derivative times
  kept.  At fixed ``T_i`` and ``T_d`` the phase crossover does not move, so the gain margin is
  multiplied by ``exp(s)`` (Marlin, Process Control, ch. 10, the gain margin as the way to add
  conservatism to Ziegler-Nichols; Astrom and Hagglund, Advanced PID Control, ch. 6-7, detuning).

A family member is named ``RULE@S`` (``amigo-pid@0.5``, ``gorez-klan-mu-2@-0.25``) and is a
:class:`~baselines.rules.registry.Rule` like any other (:func:`baselines.rules.registry.get_rule`
resolves the name), so that ``deadtime tune`` and the evaluation score it as they score the rule.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

from baselines.rules import pid as pid_rules
from envs.identification.models import IntegratingModel, SOPDTModel
from envs.structures import STRUCTURES

__all__ = ["KNOB_LIMIT", "knob_kind", "member_name", "rule_at", "split_member_name"]

KNOB_LIMIT = 5.0
"""``|s|`` at most this: ``exp(5) = 148``, beyond any parameter range of :mod:`envs.structures`."""


def _simc_dead_time(model) -> float:
    """SIMC's effective dead time ``theta`` of the rule's model (the half rule of Skogestad 2003)."""
    if isinstance(model, SOPDTModel):
        model = pid_rules.half_rule(model)
    if isinstance(model, IntegratingModel):
        return model.dead_time + (model.time_constant or 0.0) / 2.0
    return model.dead_time


def _imc_dead_time(model) -> float:
    """The dead time IMC's default ``lambda`` is a multiple of (an integrating model's reaction curve's)."""
    if isinstance(model, IntegratingModel):
        return pid_rules.reaction_curve(model, "imc_pi").dead_time
    return model.dead_time


_TIME_CONSTANT_RULES: dict[str, tuple[Callable, Callable]] = {
    # name: (the rule's function of (model, time constant), the default time constant of the model)
    "simc-pi": (pid_rules.simc_pi, _simc_dead_time),
    "simc-pid": (pid_rules.simc_pid, lambda model: model.dead_time),
    "isimc-pi": (pid_rules.isimc_pi, _simc_dead_time),
    "imc-pi": (pid_rules.imc_pi, lambda model: pid_rules.IMC_PI_LAMBDA * _imc_dead_time(model)),
    "imc-pid": (pid_rules.imc_pid, lambda model: pid_rules.IMC_PID_LAMBDA * model.dead_time),
}


def member_name(rule: str, knob: float) -> str:
    """``RULE@S``, with ``S`` printed as short as it reads back exactly (``repr``)."""
    return f"{rule}@{float(knob)!r}"


def split_member_name(name: str) -> tuple[str, float]:
    """``(rule, s)`` of ``RULE@S``.

    Raises
    ------
    ValueError
        If ``S`` is not a finite number with ``|S| <= KNOB_LIMIT``.
    """
    rule, _, text = name.rpartition("@")
    try:
        knob = float(text)
    except ValueError:
        raise ValueError(f"the knob of {name!r} must be a number after '@', got {text!r}") from None
    if not (math.isfinite(knob) and abs(knob) <= KNOB_LIMIT):
        raise ValueError(f"the knob of {name!r} must be a finite number from -{KNOB_LIMIT:g} to {KNOB_LIMIT:g}, got {text!r}")
    return rule, knob


def knob_kind(rule) -> str:
    """What the knob of ``rule`` (a :class:`~baselines.rules.registry.Rule`) scales: ``"parameter"``,
    ``"time constant"`` or ``"gain"`` (module docstring)."""
    if rule.parameter is not None:
        return "parameter"
    return "time constant" if rule.name in _TIME_CONSTANT_RULES else "gain"


def rule_at(rule, knob: float):
    """The member ``knob`` of ``rule``'s family: ``rule`` (a :class:`~baselines.rules.registry.Rule`) with the
    name :func:`member_name` and the design at ``knob`` (the rule's own design at ``knob = 0``, bit for bit)."""
    factor = math.exp(float(knob))
    kind = knob_kind(rule)
    if kind == "parameter":
        structure = next(s for s in STRUCTURES.values() if s.controller == rule.controller)

        def parameter(inputs):
            return rule.parameter(inputs) * factor

        def design(inputs):
            reference = rule(inputs)  # the rule's own checks (plant kind, model)
            if knob == 0:
                return reference
            return structure.design(structure.model_of(inputs), parameter(inputs))
    elif kind == "time constant":
        function, default = _TIME_CONSTANT_RULES[rule.name]
        parameter = None

        def design(inputs):
            reference = rule(inputs)  # the rule's own checks (plant kind, model) and the model it reads
            if knob == 0:
                return reference
            model = _rule_model(rule.name, inputs)
            return function(model, default(model) * factor)
    else:
        parameter = None

        def design(inputs):
            controller = rule(inputs)
            return controller if knob == 0 else replace(controller, kp=controller.kp / factor)

    citation = f"{rule.citation}; family member s = {float(knob):g} ({kind} knob, baselines.rules.family)"
    return replace(rule, name=member_name(rule.name, knob), citation=citation, design=design, parameter=parameter)


def _rule_model(name: str, inputs):
    """The model the PI/PID rule ``name`` reads from ``inputs`` (:func:`baselines.rules.registry._pid_rule`)."""
    if inputs.integrating:
        return inputs.model
    return inputs.sopdt if name == "simc-pid" else inputs.fopdt
