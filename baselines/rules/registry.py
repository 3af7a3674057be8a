"""One registry of every analytic rule: name -> :class:`Rule` (``deadtime tune``, ``deadtime evaluate``).

A rule is a plain function of the identified quantities (:class:`RuleInputs`) that returns a
controller.  Three kinds, all cited in :data:`RULES`:

* the PI/PID rules of the literature, adapted from :data:`baselines.rules.pid_registry.RULES` (their
  formulas are in :mod:`baselines.rules.pid`);
* the ``mu`` rules of the Gorez-Klan PID (:mod:`baselines.rules.mu`), designed by
  :func:`envs.design.pid_design`;
* the ``T_r`` rules of the FPPI and the MSP (:mod:`baselines.rules.dtc`), designed by
  :func:`envs.design.fppi_design` and :func:`envs.design.msp_design`;
* the robustness-matched rules (:mod:`baselines.rules.matched`, Grimholt and Skogestad 2018): ``mu``,
  ``T_r``, SIMC's ``tau_c`` or IMC's ``lambda`` chosen so that the loop on the identified model meets
  an ``Ms`` target (``gorez-klan-ms1.6``, ``fppi-ms1.6``, ``simc-pi-ms1.6``, ``imc-pid-ms1.6``) or a
  delay-margin target (``msp-dm0.5``); :data:`MATCHED` gives their root find's result.

The ``mu`` and ``T_r`` rules (matched ones included) go through the design maps of :mod:`envs.design`, so that a rule's
controller is exactly what the environments and the oracle produce for the same parameter;
:attr:`Rule.parameter` gives that parameter.

Which model each rule reads from :class:`RuleInputs`: FOPDT rules the ``fopdt`` model (eq. 11 of
Ingimundarson, or the given model), SOPDT rules and the ``mu`` rules the Gorez-Klan ``sopdt``
model (eq. 2-8; a given FOPDT model as the SOPDT model with ``T_2 = 0``), the ultimate-gain rules the exact ultimate point of ``model`` (the given model,
or the SOPDT model from identification), the MSP rules the two-parameter ``integrating_model``
(Ingimundarson eq. 2), and the PID rules that accept integrating plants ``model``.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from functools import lru_cache
from typing import Any, Literal

import numpy as np

from baselines.rules import dtc as dtc_rules
from baselines.rules import matched
from baselines.rules import mu as mu_rules
from baselines.rules import pid as pid_rules
from baselines.rules.pid_registry import RULES as PID_RULES
from baselines.rules.pid_registry import PIDFormula
from envs.systems.controllers import Controller
from envs.base_design import FPPI_DEAD_TIME_ERROR, MSP_RELATIVE_DEAD_TIME_ERROR  # the constants of fppi-eq34 and msp-eq50
from envs.design import MIN_RELATIVE_DEAD_TIME, fppi_design, msp_design, pid_design
from envs.structures import STRUCTURES
from envs.identification.models import FOPDTModel, IntegratingModel, Model, SOPDTModel
from envs.identification.moments import fopdt_from_moments
from envs.identification.open_loop_areas import mismatch_time
from envs.identification.open_loop_pulse import open_loop_pulse
from envs.identification.open_loop_step import open_loop_step
from envs.systems.plants import Plant
from envs.identification.procedure import PULSE_LENGTH, Identification, IdentifiedModels

__all__ = [
    "DM_TARGETS",
    "applicable_rules",
    "FPPI_DEAD_TIME_ERROR",
    "MATCHED",
    "MSP_RELATIVE_DEAD_TIME_ERROR",
    "MS_TARGETS",
    "RULES",
    "Rule",
    "RuleInputs",
    "get_rule",
]

ControllerKind = Literal["pid", "pid-series", "fppi", "msp"]
PlantKind = Literal["stable", "integrating", "both"]



@dataclass(frozen=True)
class RuleInputs(IdentifiedModels):
    """The identified quantities every rule is a function of: the identified models
    (:class:`~envs.identification.procedure.IdentifiedModels`, whose fields it has) and two more.

    Attributes
    ----------
    model : FOPDTModel, SOPDTModel or IntegratingModel
        The model the ultimate-gain rules and the integrating PID rules use: the given model
        (:meth:`from_model`), else the SOPDT model (stable) or the two-parameter model.
    apparent_time_constant : float
        ``T_n`` of the dynamics additional to the integrator (``msp-tr-tn``): the given model's
        ``time_constant``, or the closed-loop ``T_a`` (Gorez-Klan appendix B on the integrated
        input); nan if unknown.

    ``mismatch_time`` (``T_f_bar``, eq. 22) and ``pulse_area`` (``A``, eq. 46) are nan where unknown;
    ``fopdt`` and ``sopdt`` None if integrating, ``integrating_model`` (``L_n = T_ar``) None if stable.
    """

    model: Model = field(kw_only=True)
    apparent_time_constant: float = field(default=math.nan, kw_only=True)

    @classmethod
    def from_identification(cls, identification: Identification) -> RuleInputs:
        """The quantities of :func:`envs.identification.procedure.identify` (the fixed procedure)."""
        i = identification
        model = i.integrating_model if i.integrating else i.sopdt
        if model is None:
            raise ValueError("the identification produced no model")
        return cls(
            **{f.name: getattr(i, f.name) for f in fields(IdentifiedModels)},
            model=model,
            apparent_time_constant=i.closed_loop.apparent_time_constant if i.integrating else math.nan,
        )

    @classmethod
    def from_model(cls, model: Model, plant: Plant | None = None) -> RuleInputs:
        """The quantities of a given model, with ``T_f_bar``/``A`` measured on the true ``plant``.

        A rule reads the given model in the form it was written for: a FOPDT model is the SOPDT
        model with ``T_2 = 0`` (Gorez-Klan eq. 2-2; Skogestad 2003 and Haalman 1965 give the PI as
        that case of their PID), so the SOPDT rules and the ``mu`` rules use its own ``T_1`` and
        dead time, not the moment-fitted SOPDT of eq. 2-8 (which moves the dead time of
        ``2.5 e^{-4s}/(12s + 1)`` to 1.23 and closes unstable loops on the model itself).  From an
        SOPDT model the FOPDT model follows by its moments (``T_ar = T_1 + T_2 + D_2``,
        ``T_a = sqrt(T_1^2 + T_2^2)``, eq. 2-5, 2-6).  With ``plant``, the mismatch time of eq. 22
        (open-loop step to steady state) or the pulse area of eq. 46 (pulse of ``L_n/3``, as
        :func:`envs.identification.procedure.identify`) is computed against the model on the noise-free plant.

        Raises
        ------
        ValueError
            If the model's kind (stable or integrating) differs from the plant's.
        """
        if plant is not None and isinstance(model, IntegratingModel) != plant.integrating:
            kind = "integrating" if isinstance(model, IntegratingModel) else model.to_dict()["type"]
            plant_kind = "integrating" if plant.integrating else "self-regulating"
            raise ValueError(f"model.type {kind} does not fit the plant, which is {plant_kind}")
        if isinstance(model, IntegratingModel):
            two_parameter = IntegratingModel(gain=model.gain, dead_time=model.residence_time)
            return cls(
                integrating=True, gain=model.gain, residence_time=model.residence_time, fopdt=None, sopdt=None,
                integrating_model=two_parameter, model=model, mismatch_time=math.nan,
                pulse_area=_pulse_area(plant, two_parameter) if plant is not None else math.nan,
                apparent_time_constant=model.time_constant if model.time_constant is not None else math.nan,
            )
        if isinstance(model, FOPDTModel):
            fopdt = model
            # the FOPDT model in the SOPDT form (Gorez-Klan eq. 2-2 with T_2 = 0), not re-fitted by moments
            sopdt = SOPDTModel(model.gain, (model.time_constant, 0.0), model.dead_time)
        elif isinstance(model, SOPDTModel):
            t1, t2 = model.time_constants
            sopdt = model
            fopdt = fopdt_from_moments(model.gain, model.residence_time, math.hypot(t1, t2))
        else:
            raise TypeError(f"model must be a FOPDTModel, SOPDTModel or IntegratingModel, got {type(model).__name__}")
        return cls(
            integrating=False, gain=model.gain, residence_time=model.residence_time, fopdt=fopdt, sopdt=sopdt,
            integrating_model=None, model=model, pulse_area=math.nan,
            mismatch_time=_mismatch_time(plant, fopdt) if plant is not None else math.nan,
        )

    def to_dict(self) -> dict[str, Any]:
        """JSON form (``null`` for absent models and unknown numbers)."""

        def number(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        def as_dict(m: Model | None) -> dict[str, Any] | None:
            return None if m is None else m.to_dict()

        return {
            "integrating": self.integrating,
            "gain": self.gain,
            "residence_time": self.residence_time,
            "fopdt": as_dict(self.fopdt),
            "sopdt": as_dict(self.sopdt),
            "integrating_model": as_dict(self.integrating_model),
            "mismatch_time": number(self.mismatch_time),
            "pulse_area": number(self.pulse_area),
            "apparent_time_constant": number(self.apparent_time_constant),
        }


def _mismatch_time(plant: Plant, model: FOPDTModel) -> float:
    """``T_f_bar`` of eq. 22: the noise-free unit open-loop step of ``plant`` against ``model``."""
    height = 1.0 / abs(model.gain)
    step = open_loop_step(plant, np.random.default_rng(0), height, model.residence_time, model.gain)
    if not step.settled:
        return math.nan
    return mismatch_time(step.timepts, step.output / height, model)


def _pulse_area(plant: Plant, model: IntegratingModel) -> float:
    """``A`` of eq. 46: the noise-free pulse response of ``plant`` against the two-parameter ``model``."""
    if model.dead_time <= 0:
        return math.nan
    pulse = open_loop_pulse(
        plant, np.random.default_rng(0), 1.0 / abs(model.gain), PULSE_LENGTH * model.dead_time, model.gain, model.dead_time
    )
    return pulse.area


@dataclass(frozen=True)
class Rule:
    """One analytic rule.

    Attributes
    ----------
    name : str
        Kebab-case registry key: the rule, then the controller (``zn-step-pi``, ``fppi-eq28``).
    citation : str
        Paper, equation and table.
    controller : {"pid", "pid-series", "fppi", "msp"}
        The controller JSON type the rule returns.
    plants : {"stable", "integrating", "both"}
        The plants (and models) the rule applies to.
    design : callable
        ``RuleInputs -> Controller``.
    parameter : callable or None
        ``RuleInputs -> float``: the design parameter (``mu``, or ``T_r``) of the rules that go
        through :mod:`envs.design`, matched ones included; None for the full PI/PID rules (for the
        matched SIMC and IMC rules :data:`MATCHED` gives ``tau_c`` or ``lambda``).
    """

    name: str
    citation: str
    controller: ControllerKind
    plants: PlantKind
    design: Callable[[RuleInputs], Controller]
    parameter: Callable[[RuleInputs], float] | None = None

    def __call__(self, inputs: RuleInputs) -> Controller:
        """``self.design(inputs)``."""
        return self.design(inputs)

    def relative_parameter(self, inputs: RuleInputs) -> float | None:
        """:attr:`parameter` made dimensionless as the agent's and the oracle's (:func:`envs.structures.relative_scale`):
        ``mu``, ``T_r/T_n`` (FOPDT model) or ``T_r/L_n`` (two-parameter model); None for the full PI/PID rules."""
        if self.parameter is None:
            return None
        structure = next(s for s in STRUCTURES.values() if s.controller == self.controller)
        return self.parameter(inputs) / structure.scale(structure.model_of(inputs))


def _rule(
    name: str,
    citation: str,
    controller: ControllerKind,
    plants: PlantKind,
    design: Callable[[RuleInputs], Controller],
    parameter: Callable[[RuleInputs], float] | None = None,
) -> Rule:
    """A :class:`Rule` whose ``design`` refuses inputs of the wrong plant kind, naming the rule."""

    def checked(inputs: RuleInputs) -> Controller:
        if plants == "stable" and inputs.integrating:
            raise ValueError(f"rule {name} is for self-regulating plants; the plant is integrating")
        if plants == "integrating" and not inputs.integrating:
            raise ValueError(f"rule {name} is for integrating plants; the plant is self-regulating")
        return design(inputs)

    return Rule(name, citation, controller, plants, checked, parameter)


def _needs(value: Any, what: str, rule: str) -> Any:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        raise ValueError(f"rule {rule} needs {what}, which is unknown here")
    return value


# --------------------------------------------------------------------------- PI/PID of the literature
def _pid_rule(spec: PIDFormula) -> Rule:
    def model(inputs: RuleInputs) -> Model:
        if inputs.integrating:
            return inputs.model
        if spec.model == "ultimate":
            return inputs.model
        return _needs(inputs.fopdt if spec.model == "fopdt" else inputs.sopdt, f"a {spec.model.upper()} model", spec.name)

    return _rule(
        name=spec.name,
        citation=spec.citation,
        controller="pid" if spec.form == "ideal" else "pid-series",
        plants="both" if spec.integrating else "stable",
        design=lambda inputs: spec.design(model(inputs)),
    )


# --------------------------------------------------------------------------- mu rules (Gorez-Klan PID)
_GK = "Gorez & Klan, Simple models for process control, eq. 3-11 (PID)"


def _mu_rule(name: str, mu: float, source: str) -> Rule:
    def design(inputs: RuleInputs) -> Controller:
        return pid_design(_needs(inputs.sopdt, "the SOPDT model", name), mu)

    return _rule(name, f"{_GK}; mu = {mu:.6g} from {source}", "pid-series", "stable", design, lambda inputs: mu)


def _mu_rules() -> list[Rule]:
    table = [_mu_rule(f"gorez-klan-mu-{m:g}", mu_rules.mu_table(m), "section 3 table") for m in mu_rules.MU_TABLE]
    return table + [
        _mu_rule("gorez-klan-pm-60", mu_rules.mu_for_phase_margin(60.0), "eq. 3-14 (phase margin 60 deg on the model loop)"),
        _mu_rule("gorez-klan-gm-3", mu_rules.mu_for_gain_margin(3.0), "eq. 3-13 (gain margin 3 on the model loop)"),
    ]


# --------------------------------------------------------------------------- T_r rules (FPPI, MSP)
_IN = "Ingimundarson, Robust tuning procedures of dead-time compensating controllers"


def _fppi_rule(name: str, tr: Callable[[RuleInputs], float], citation: str) -> Rule:
    def design(inputs: RuleInputs) -> Controller:
        return fppi_design(_needs(inputs.fopdt, "the FOPDT model", name), tr(inputs))

    return _rule(name, citation, "fppi", "stable", design, tr)


def _msp_rule(name: str, tr: Callable[[RuleInputs], float], citation: str) -> Rule:
    def design(inputs: RuleInputs) -> Controller:
        return msp_design(_needs(inputs.integrating_model, "the two-parameter model", name), tr(inputs))

    return _rule(name, citation, "msp", "integrating", design, tr)


def _fppi_eq28(inputs: RuleInputs) -> float:
    fopdt = _needs(inputs.fopdt, "the FOPDT model", "fppi-eq28")
    return dtc_rules.fppi_time_constant(fopdt.time_constant, _needs(inputs.mismatch_time, "T_f_bar (eq. 22)", "fppi-eq28"))


def _fppi_eq34(inputs: RuleInputs) -> float:
    fopdt = _needs(inputs.fopdt, "the FOPDT model", "fppi-eq34")
    bound = _needs(inputs.mismatch_time, "T_f_bar (eq. 22)", "fppi-eq34") + FPPI_DEAD_TIME_ERROR * fopdt.dead_time
    return dtc_rules.fppi_time_constant(fopdt.time_constant, bound)


def _ppi_kappa1(inputs: RuleInputs) -> float:
    return _needs(inputs.fopdt, "the FOPDT model", "ppi-kappa1").time_constant


def _msp_eq43(inputs: RuleInputs) -> float:
    model = _needs(inputs.integrating_model, "the two-parameter model", "msp-eq43")
    return dtc_rules.msp_time_constant(model.gain, model.dead_time, _needs(inputs.pulse_area, "A (eq. 46)", "msp-eq43"))


def _msp_eq50(inputs: RuleInputs) -> float:
    model = _needs(inputs.integrating_model, "the two-parameter model", "msp-eq50")
    return dtc_rules.msp_eq50(model.gain, model.dead_time, MSP_RELATIVE_DEAD_TIME_ERROR).tr


def _msp_tr_tn(inputs: RuleInputs) -> float:
    t_n = _needs(inputs.apparent_time_constant, "T_n of the dynamics additional to the integrator", "msp-tr-tn")
    if not t_n > 0:
        raise ValueError(f"rule msp-tr-tn needs T_n > 0 (the dynamics additional to the integrator), got {t_n!r}")
    return t_n


def _dtc_rules() -> list[Rule]:
    return [
        _fppi_rule("fppi-eq28", _fppi_eq28, f"{_IN}, eq. 28 and 29 (T_r = max(sqrt(T_f_bar T_n), T_f_bar)), T_f = T_r, Table 1"),
        _fppi_rule(
            "fppi-eq34", _fppi_eq34,
            f"{_IN}, eq. 34 (as derived: kappa = sqrt(T_n/(T_f_bar + Delta L)); the printed form is inverted), "
            f"Delta L = {FPPI_DEAD_TIME_ERROR:g} L_n, section 4.2",
        ),
        _fppi_rule("ppi-kappa1", _ppi_kappa1, f"Hagglund 1996, Control Eng. Practice 4:749-756 (kappa = 1, T_r = T_n); {_IN}, eq. 15"),
        _msp_rule("msp-eq43", _msp_eq43, f"{_IN}, eq. 43 with beta = A (eq. 46), section 5.1, Table 2"),
        _msp_rule("msp-eq50", _msp_eq50, f"{_IN}, eq. 50 (T_r/L_n = 2 delta_L/(1 - delta_L)), delta_L = {MSP_RELATIVE_DEAD_TIME_ERROR:g}"),
        _msp_rule(
            "msp-tr-tn", _msp_tr_tn,
            f"Matausek & Micic 1996, IEEE TAC 41 (T_r = T_n); {_IN}, section 5.3; T_n = closed-loop T_a of the "
            "dynamics additional to the integrator (Gorez-Klan appendix B) or the given model's time_constant",
        ),
    ]


# --------------------------------------------------------------------------- robustness-matched rules
MS_TARGETS: tuple[float, ...] = (1.4, 1.6, 1.8)
"""``Ms`` targets of the matched rules: 1.4 (robust), 1.6 (Grimholt and Skogestad's typical choice, about
SIMC's ``tau_c = theta``), 1.8 (tight; the environments allow 2)."""

DM_TARGETS: tuple[float, ...] = (0.3, 0.5, 0.7)
"""Delay-margin targets of the matched MSP rules, in ``L_n`` (``MSP-v0`` requires ``0.2 L``)."""

_GS = "Grimholt & Skogestad 2018, J. Process Control 70:36-46 (free parameter for a robustness target on the model loop)"

MATCHED: dict[str, Callable[[RuleInputs], matched.MatchedParameter]] = {}
"""The root find of every matched rule by name: ``RuleInputs -> MatchedParameter`` (the parameter,
the figure reached on the model loop, the bracket).  Cached per inputs object."""


def _matched_rule(
    name: str,
    citation: str,
    controller: ControllerKind,
    plants: PlantKind,
    design_model: Callable[[RuleInputs], Model],
    design: Callable[[Model, float], Controller],
    figure: matched.Figure,
    target: float,
    bracket: Callable[[RuleInputs, Model], tuple[float, float]],
    has_parameter: bool,
) -> Rule:
    """A rule whose parameter makes the loop ``design(model, p)`` on ``inputs.model`` meet ``target``."""

    @lru_cache(maxsize=16)
    def solve(inputs: RuleInputs) -> matched.MatchedParameter:
        model = design_model(inputs)
        scale = model.dead_time if figure == "delay_margin" else 1.0
        return matched.match_parameter(
            lambda p: design(model, p), inputs.model.plant(), figure, target, bracket(inputs, model), scale=scale, name=name
        )

    def build(inputs: RuleInputs) -> Controller:
        return design(design_model(inputs), solve(inputs).parameter)

    MATCHED[name] = solve
    parameter = (lambda inputs: solve(inputs).parameter) if has_parameter else None
    return _rule(name, citation, controller, plants, build, parameter)


def _matched_rules() -> list[Rule]:
    def sopdt(name: str) -> Callable[[RuleInputs], Model]:
        return lambda inputs: _needs(inputs.sopdt, "the SOPDT model", name)

    def fopdt(name: str) -> Callable[[RuleInputs], Model]:
        return lambda inputs: _needs(inputs.fopdt, "the FOPDT model", name)

    def fopdt_or_integrating(name: str) -> Callable[[RuleInputs], Model]:
        return lambda inputs: inputs.model if inputs.integrating else _needs(inputs.fopdt, "the FOPDT model", name)

    def two_parameter(name: str) -> Callable[[RuleInputs], Model]:
        return lambda inputs: _needs(inputs.integrating_model, "the two-parameter model", name)

    def residence(low: float, high: float) -> Callable[[RuleInputs, Model], tuple[float, float]]:
        return lambda inputs, model: (low * inputs.residence_time, high * inputs.residence_time)

    rules = []
    for t in MS_TARGETS:
        name = f"gorez-klan-ms{t:g}"
        rules.append(_matched_rule(
            name, f"{_GK}; mu for Ms = {t:g} on the model loop, mu in [0.3, 300]; {_GS}", "pid-series", "stable",
            sopdt(name), pid_design, "ms", t, lambda inputs, model: (0.3, 300.0), True,
        ))
    for t in MS_TARGETS:
        name = f"fppi-ms{t:g}"
        rules.append(_matched_rule(
            name, f"{_IN}, eq. 14-15, T_f = T_r (section 4.3); T_r for Ms = {t:g} on the model loop, "
            f"T_r in [{matched.FPPI_TR_FLOOR:g} max(L_n, 0.01 T_ar), 100 T_ar]; {_GS}", "fppi", "stable",
            fopdt(name), fppi_design, "ms", t,
            lambda inputs, model: (matched.FPPI_TR_FLOOR * max(model.dead_time, MIN_RELATIVE_DEAD_TIME * inputs.residence_time),
                                   100.0 * inputs.residence_time), True,
        ))
    for t in DM_TARGETS:
        name = f"msp-dm{t:g}"
        rules.append(_matched_rule(
            name, f"{_IN}, eq. 36-38; T_r for delay margin = {t:g} L_n on the model loop (delay margin: section 3), "
            f"T_r in [{matched.MSP_TR_FLOOR:g}, 100] L_n; {_GS}", "msp", "integrating",
            two_parameter(name), msp_design, "delay_margin", t,
            lambda inputs, model: (matched.MSP_TR_FLOOR * model.dead_time, 100.0 * model.dead_time), True,
        ))
    for t in MS_TARGETS:
        name = f"simc-pi-ms{t:g}"
        rules.append(_matched_rule(
            name, f"{_GS}, SIMC PI (Skogestad 2003, J. Process Control 13:291-309) with tau_c for Ms = {t:g} "
            "on the model loop, tau_c in [0.001, 100] T_ar", "pid", "both",
            fopdt_or_integrating(name), pid_rules.simc_pi, "ms", t, residence(1e-3, 100.0), False,
        ))
    for t in MS_TARGETS:
        name = f"imc-pid-ms{t:g}"
        rules.append(_matched_rule(
            name, f"Rivera, Morari & Skogestad 1986, Ind. Eng. Chem. Process Des. Dev. 25:252-265, Table II (PID); lambda for Ms = {t:g} on the model loop, lambda in "
            f"[0.001, 100] T_ar, as {_GS}", "pid", "stable",
            fopdt(name), pid_rules.imc_pid, "ms", t, residence(1e-3, 100.0), False,
        ))
    return rules


RULES: dict[str, Rule] = {
    rule.name: rule for rule in [*map(_pid_rule, PID_RULES.values()), *_mu_rules(), *_dtc_rules(), *_matched_rules()]
}
"""Every rule by name; see :class:`Rule`."""


def get_rule(name: str) -> Rule:
    """The rule called ``name``, or the member ``RULE@S`` of a rule's family (:mod:`baselines.rules.family`);
    an unknown name is a ValueError that says where the names are."""
    if isinstance(name, str) and "@" in name and name not in RULES:
        from baselines.rules.family import rule_at, split_member_name

        base, knob = split_member_name(name)
        return rule_at(get_rule(base), knob)
    try:
        return RULES[name]
    except (KeyError, TypeError):  # TypeError: a name that cannot be a key (a list)
        close = difflib.get_close_matches(str(name), list(RULES), n=1)
        hint = f" (did you mean {close[0]!r}?)" if close else ""
        raise ValueError(f"unknown rule {name!r}{hint}; `deadtime tune --list` names the {len(RULES)} rules") from None


def applicable_rules(structure: str) -> list[str]:
    """Names of the rules for the plants of an environment of ``structure`` (``all-rules`` of ``deadtime
    evaluate``): every PI/PID rule and those of the structure's own controller, among the rules for its
    plant kind (self-regulating or integrating; ``both`` counts for either)."""
    from envs.structures import STRUCTURES

    kind = STRUCTURES[structure]
    classes = {"pid", "pid-series", kind.controller}
    return [name for name, rule in RULES.items() if rule.plants in (kind.plant_kind, "both") and rule.controller in classes]
