"""The base rule of the residual action, and the design features of the observation.

The ``-v1`` environments (``action="residual"``, ``design_features=True``) start the agent at a
rule of the papers and show it what the identified models say about that rule's design.

Residual action
---------------
The action ``a`` in ``[-1, 1]`` is a log-correction of the base rule's relative parameter ``p_0``,
log-linear on each side from the range's aggressive end to ``p_0`` to its other end
(:data:`envs.structures.PARAMETER_RANGES` ``[p_min, p_max]``):

    ``p = p_0 (p_max/p_0)^a`` for ``a >= 0``,  ``p = p_0 (p_0/p_min)^a`` for ``a < 0``,

so that ``a = 0`` is the rule and ``a = +-1`` are the ends of the ``-v0`` range.  The base rules,
each the structure's own rule of its paper (:func:`base_parameter`):

=========  ==============================================================  =======================
structure  ``p_0``                                                         rule of ``baselines``
=========  ==============================================================  =======================
``pid``    ``mu = 2`` (Gorez-Klan section 3 table: the boundary between    ``gorez-klan-mu-2``
           "fast responses" ``1.3 < mu < 2`` and "over-damped" ``2 < mu``)
``fppi``   ``T_r/T_n`` of eq. 28/29 on ``T_f_bar + Delta L`` (eq. 34),     ``fppi-eq34``
           ``Delta L =`` :data:`FPPI_DEAD_TIME_ERROR` ``L_n``
``msp``    ``T_r/L_n = 2 delta_L/(1 - delta_L)`` (eq. 50),                  ``msp-eq50``
           ``delta_L =`` :data:`MSP_RELATIVE_DEAD_TIME_ERROR`
=========  ==============================================================  =======================

(Ingimundarson's eq. 28-29, 34 and 50; ``tests/unit/envs/test_base_design.py`` holds ``p_0`` equal
to the rule's relative parameter.)  Measured on 200 training plants of each ``-v0`` id (seeds
100000-100199, the oracle of ``baselines.oracle``): ``log10(oracle/p_0)`` has mean +0.07, sd 0.35,
5-95% [-0.12, +0.82] (PID); -0.66, 0.40, [-1.24, -0.07] (FPPI); -0.75, 0.33, [-1.22, -0.22] (MSP).
The tails are what a fixed band would miss: a first version with ``p_0 10^(1.5 a)`` left 2.5% of the
PID plants (oracle ``mu`` up to 142) and 2% of the FPPI plants (down to 2.3 decades below ``p_0``)
out of reach, and its ten PID agents violated the constraints on 5-9% of the validation plants
(v0's: 0%); hence the two-sided map to the ends of the range.

Robustness action
-----------------
With ``action="robustness"`` the action chooses a robustness target of the loop on the identified
model, and the design solves for the parameter (:func:`robustness_parameter`, the root find of
:mod:`envs.analysis.matching`, as the matched rules ``gorez-klan-msX``, ``fppi-msX``, ``msp-dmX`` of
``baselines``): ``Ms`` on a log scale over :data:`ROBUSTNESS_TARGETS` for the PID and the FPPI
(their loops checked on the SOPDT model), the delay margin in ``L_n`` for the MSP (on the
two-parameter model; its ``Ms`` is not monotone in ``T_r``).  ``a = +1`` is the most robust target.
A target the parameter range cannot meet gives the range's least aggressive end; one met even at
its aggressive end gives that end.  The inverse (:func:`robustness_action`, the action of a given
parameter, as the learned rule's labels need) is the target equal to the figure of that parameter's
own model loop: where the figure is monotone in the parameter, ``robustness_parameter`` of it gives
the parameter back; where it is not, the least aggressive parameter of the same figure.

Design features
---------------
Three numbers, appended to the observation (:data:`DESIGN_FEATURES`):

* ``log_base_parameter``: ``log10 p_0``;
* ``check_ms``, ``check_delay_margin``: ``Ms`` (clipped to ``[1, 5]``; 5 if unstable) and delay
  margin over the identified ``T_ar`` (clipped to ``[0, 5]``; 0 if unstable) of the base design's
  loop closed around the identification's *other* model (:func:`check_model`): the PID, designed on
  the SOPDT model, around the FOPDT model; the FPPI, designed on the FOPDT model, around the SOPDT
  model; the MSP, designed on the two-parameter model, around the integrator with the lag ``T_n``
  of the closed-loop step (``K_n e^{-(L_n - T_n) s}/(s (T_n s + 1))``, the same ``T_ar``).  The
  design's own model loop is fixed by ``p_0`` (Gorez-Klan eq. 3-12; the MSP's model loop depends on
  ``T_r/L_n`` only), so only a second model tells the agent how the design reacts to model error.
"""

from __future__ import annotations

import math

from envs.analysis.loop_analysis import plant_margins
from envs.analysis.matching import loop_figure, match_parameter
from envs.design import FPPI_DEAD_TIME_ERROR, MSP_RELATIVE_DEAD_TIME_ERROR, PID_BASE_MU, fppi_time_constant
from envs.identification.procedure import Identification
from envs.structures import PARAMETER_RANGES, STRUCTURES
from envs.validation import require_number

__all__ = [
    "ACTIONS",
    "DESIGN_FEATURES",
    "FPPI_DEAD_TIME_ERROR",
    "MSP_RELATIVE_DEAD_TIME_ERROR",
    "PID_BASE_MU",
    "base_parameter",
    "check_model",
    "design_features",
    "fppi_time_constant",
    "residual_parameter",
    "residual_action",
    "robustness_action",
    "robustness_parameter",
    "robustness_target",
]

ACTIONS = ("parameter", "residual", "robustness")
"""The action coordinates of the environments: the relative parameter over its range (``-v0``), the
residual around the base rule (``-v1``), or the robustness target on the model."""

ROBUSTNESS_TARGETS: dict[str, tuple[str, float, float]] = {name: s.robustness for name, s in STRUCTURES.items()}
"""``(figure, target at a = -1, target at a = +1)`` of the robustness action (log scale between),
:attr:`envs.structures.Structure.robustness`.  ``Ms`` from 1.2 (the matched rules' most robust is
1.4) to 2.4 (beyond the constraint's 2, since the model's ``Ms`` is not the plant's); the delay
margin from 0.1 to 1.5 ``L_n`` (the MSP's approaches about 2 ``L_n`` as ``T_r`` grows)."""

DESIGN_FEATURES: tuple[str, ...] = ("log_base_parameter", "check_ms", "check_delay_margin")
"""Names of :func:`design_features`, in order."""

FIGURE_CLIP = 5.0


def _clip_to_range(structure: str, relative: float) -> float:
    low, high = PARAMETER_RANGES[structure]
    return min(max(relative, low), high)


def base_parameter(structure: str, identification: Identification) -> float:
    """``p_0``, the base rule's relative parameter (module docstring), clipped to the structure's range.

    The FPPI's eq. 34 needs ``T_n > 0`` and ``T_f_bar + Delta L > 0``; where the identification
    gives neither (a model without dead time or mismatch), ``p_0`` is the range's aggressive end,
    where ``fppi-eq34`` refuses the plant.  A mismatch area that was not measured (agent mode: the
    design reads a PRBS's least-squares model and no open-loop step ran, or the step did not
    settle) counts as 0, so that eq. 34 keeps its assumed dead-time error ``Delta L``; before
    this, such an episode's base was the aggressive end and its loop was unstable at ``a = 0``.
    """
    return _clip_to_range(structure, STRUCTURES[structure].base(identification))


def residual_parameter(structure: str, base: float, action: float) -> float:
    """``p_0 (p_max/p_0)^a`` (``a >= 0``) or ``p_0 (p_0/p_min)^a`` (``a < 0``), ``a`` clipped to ``[-1, 1]``."""
    low, high = PARAMETER_RANGES[structure]
    base = _clip_to_range(structure, base)
    a = min(max(float(action), -1.0), 1.0)
    return _clip_to_range(structure, base * (high / base if a >= 0 else base / low) ** a)


def residual_action(structure: str, base: float, parameter: float) -> float:
    """The inverse of :func:`residual_parameter` (clipped to ``[-1, 1]``)."""
    low, high = PARAMETER_RANGES[structure]
    base = _clip_to_range(structure, base)
    parameter = _clip_to_range(structure, require_number(parameter, "parameter", positive=True))
    end = high if parameter >= base else low
    if end == base:
        return 0.0
    return min(max(math.log(parameter / base) / abs(math.log(end / base)), -1.0), 1.0)


def robustness_target(structure: str, action: float) -> float:
    """The target of the robustness action ``a`` (clipped to ``[-1, 1]``): ``Ms``, or delay margin in ``L_n``."""
    _, aggressive, robust = ROBUSTNESS_TARGETS[structure]
    a = min(max(float(action), -1.0), 1.0)
    return aggressive * (robust / aggressive) ** ((a + 1.0) / 2.0)


def _robustness_loop(structure: str, identification: Identification):
    """``(design model, model the loop is closed around, scale of the relative parameter, figure's unit)``:
    the loop is closed around the SOPDT model, or the two-parameter model where the plants integrate."""
    found = STRUCTURES[structure]
    model = found.model_of(identification)
    loop_model = identification.integrating_model if found.integrating else identification.sopdt
    unit = model.dead_time if found.robustness[0] == "delay_margin" else 1.0
    return model, loop_model, found.scale(model), unit


def robustness_parameter(structure: str, identification: Identification, action: float) -> float:
    """The relative parameter whose loop on the identified model meets :func:`robustness_target`."""
    figure = ROBUSTNESS_TARGETS[structure][0]
    model, loop_model, scale, unit = _robustness_loop(structure, identification)
    low, high = PARAMETER_RANGES[structure]
    try:
        found = match_parameter(
            lambda p: STRUCTURES[structure].design(model, p), loop_model.plant(), figure, robustness_target(structure, action),
            (low * scale, high * scale), scale=unit,
        )
    except ValueError:  # missed even at the least aggressive end: the most robust design there is
        return high
    return _clip_to_range(structure, found.parameter / scale)


def robustness_action(structure: str, identification: Identification, parameter: float) -> float:
    """The robustness action whose target is the figure of ``parameter``'s model loop, clipped to ``[-1, 1]``.

    ``a = 2 log(figure/aggressive)/log(robust/aggressive) - 1``, the inverse of
    :func:`robustness_target`; an unstable model loop (``Ms`` infinite, delay margin 0) is the
    aggressive end ``-1``.
    """
    figure, aggressive, robust = ROBUSTNESS_TARGETS[structure]
    model, loop_model, scale, unit = _robustness_loop(structure, identification)
    relative = _clip_to_range(structure, require_number(parameter, "parameter", positive=True))
    value = loop_figure(loop_model.plant(), STRUCTURES[structure].design(model, relative * scale), figure, unit)
    if not (math.isfinite(value) and value > 0):
        return -1.0
    return min(max(2.0 * math.log(value / aggressive) / math.log(robust / aggressive) - 1.0, -1.0), 1.0)


def check_model(structure: str, identification: Identification):
    """The model the base design is checked on (module docstring), or None where it is unknown."""
    return STRUCTURES[structure].check(identification)


def design_features(structure: str, identification: Identification | None) -> dict[str, float]:
    """:data:`DESIGN_FEATURES` of the identification (all 0 without one)."""
    if identification is None:
        return dict.fromkeys(DESIGN_FEATURES, 0.0)
    base = base_parameter(structure, identification)
    found = STRUCTURES[structure]
    model = found.model_of(identification)
    checked = found.check(identification)
    out = {"log_base_parameter": math.log10(base), "check_ms": 0.0, "check_delay_margin": 0.0}
    if checked is None:
        return out
    margins = plant_margins(checked.plant(), found.relative_design(model, base))
    if not margins.stable:
        return {**out, "check_ms": FIGURE_CLIP}
    ms = float(margins.ms) if math.isfinite(margins.ms) else FIGURE_CLIP
    margin = float(margins.delay_margin) / identification.residence_time
    out["check_ms"] = min(max(ms, 1.0), FIGURE_CLIP)
    out["check_delay_margin"] = min(max(margin, 0.0), FIGURE_CLIP) if math.isfinite(margin) else FIGURE_CLIP
    return out
