"""The controller structures: what each one identifies, designs and is judged against, in one place.

A :class:`Structure` is everything the environments, the rules, the oracle and the evaluation need
to know about a controller structure: the identified model its design reads, the design map, the
design parameter with its range and unit, the base rule of the residual action, the plants it is
for, its default constraints and the experiments its design reads.  :data:`STRUCTURES` registers
them by name and :func:`structure` looks one up; code elsewhere asks the structure rather than
comparing its name.

=========  =========  ===================  =====================  ==============  ===============
name       model      design               relative parameter     base rule       plants
=========  =========  ===================  =====================  ==============  ===============
``pid``    SOPDT      Gorez-Klan PID       ``mu``                 ``gorez-klan-   self-regulating
                      (eq. 3-11)                                  mu-2``
``fppi``   FOPDT      Hagglund's FPPI      ``T_r/T_n``            ``fppi-eq34``   self-regulating
                      (Ingimundarson 4)
``msp``    integ.     modified Smith       ``T_r/L_n``            ``msp-eq50``    integrating
                      predictor (sec. 5)
=========  =========  ===================  =====================  ==============  ===============

The relative parameter is the design parameter over the structure's unit (:meth:`Structure.scale`),
searched on a log scale over :attr:`Structure.parameter_range` (measured: :data:`PARAMETER_RANGES`).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from envs.analysis.scoring import Constraints
from envs.design import (
    FPPI_DEAD_TIME_ERROR,
    MSP_RELATIVE_DEAD_TIME_ERROR,
    PID_BASE_MU,
    fppi_design,
    fppi_time_constant,
    msp_design,
    pi_dead_time,
    pi_design,
    pid_design,
)
from envs.identification.models import IntegratingModel

__all__ = ["PARAMETER_RANGES", "STRUCTURES", "Structure", "design", "relative_scale", "structure"]


@dataclass(frozen=True)
class Structure:
    """One controller structure (module docstring).

    Attributes
    ----------
    name : str
        Registry key and the ``structure`` of the environments (``"pid"``).
    title : str
        The environment id's name (``"PID"`` of ``DeadTime/PID-v0``).
    controller : str
        The type of controller its design returns (:func:`envs.systems.controllers.controller_from_dict`).
    model : {"sopdt", "fopdt", "integrating_model"}
        The identified model the design reads: the field of
        :class:`~envs.identification.procedure.Identification` (and of the rules' inputs and the
        oracle's exact models) that holds it.
    integrating : bool
        Whether its plants (and model) integrate.
    family : str
        The default plant family of its environments (:mod:`envs.systems.families`).
    symbol : str
        The relative parameter's symbol (``"mu"``, ``"T_r/T_n"``).
    parameter_range : (float, float)
        Range of the relative parameter (log scale).
    design_function : callable
        ``(model, parameter) -> controller``, with the absolute parameter.
    unit : callable
        ``model -> float``, the unit of the relative parameter.
    base_rule : str
        The rule of ``baselines`` whose relative parameter is the residual action's ``p_0``.
    base : callable
        ``Identification -> float``, that rule's relative parameter (before the clip to the range).
    check : callable
        ``Identification -> model or None``, the model the base design is checked on
        (:func:`envs.base_design.check_model`).
    robustness : (str, float, float)
        ``(figure, target at a = -1, target at a = +1)`` of the robustness action.
    design_experiments : tuple of str
        The agent mode's experiment types with ``experiment_set="design"``.
    least_squares_order : int or None
        The order of the least-squares model its design reads (1 FOPDT, 2 SOPDT); None where the
        plants integrate and no least-squares fit applies.
    constraints : Constraints
        The default constraints of its environments (docs/scoring.md).
    """

    name: str
    title: str
    controller: str
    model: str
    integrating: bool
    family: str
    symbol: str
    parameter_range: tuple[float, float]
    design_function: Callable[[Any, float], Any]
    unit: Callable[[Any], float]
    base_rule: str
    base: Callable[[Any], float]
    check: Callable[[Any], Any]
    robustness: tuple[str, float, float]
    design_experiments: tuple[str, ...]
    least_squares_order: int | None
    constraints: Constraints = Constraints()

    @property
    def plant_kind(self) -> str:
        """``"integrating"`` or ``"stable"``: the plants of its rules and benchmark set."""
        return "integrating" if self.integrating else "stable"

    def model_of(self, identified: Any) -> Any:
        """The model the design reads, from an identification, the rules' inputs or exact models."""
        return getattr(identified, self.model)

    def scale(self, model: Any) -> float:
        """The unit of the relative parameter for ``model``."""
        return self.unit(model)

    def design(self, model: Any, parameter: float) -> Any:
        """The controller designed from ``model`` with the (absolute) ``parameter``."""
        return self.design_function(model, parameter)

    def relative_design(self, model: Any, relative: float) -> Any:
        """The controller of the relative parameter ``relative``."""
        return self.design(model, relative * self.scale(model))


def _fppi_base(identification) -> float:
    """``T_r/T_n`` of eq. 28/29 on ``T_f_bar + Delta L`` (eq. 34); 0 (the range's aggressive end once
    clipped) where the identification gives no ``T_n > 0`` or no positive bound; an unmeasured
    mismatch area counts as 0 (:func:`envs.base_design.base_parameter`)."""
    fopdt = identification.fopdt
    mismatch = identification.mismatch_time if math.isfinite(identification.mismatch_time) else 0.0
    bound = mismatch + FPPI_DEAD_TIME_ERROR * fopdt.dead_time
    if not (fopdt.time_constant > 0 and bound > 0):
        return 0.0
    return fppi_time_constant(fopdt.time_constant, bound) / fopdt.time_constant


def _msp_check(identification):
    """The integrator with the closed-loop step's lag ``T_n``: ``K_n e^{-(L_n - T_n) s}/(s (T_n s + 1))``."""
    model = identification.integrating_model
    lag = identification.closed_loop.apparent_time_constant
    if math.isfinite(lag) and 0.0 < lag < model.dead_time:
        return IntegratingModel(model.gain, model.dead_time - lag, lag)
    return model


_STABLE_EXPERIMENTS = ("closed-loop-step", "open-loop-step")

STRUCTURES: dict[str, Structure] = {
    s.name: s
    for s in (
        Structure(
            name="pid", title="PID", controller="pid-series", model="sopdt", integrating=False, family="stable",
            symbol="mu", parameter_range=(0.3, 300.0), design_function=pid_design, unit=lambda model: 1.0,
            base_rule="gorez-klan-mu-2", base=lambda identification: PID_BASE_MU, check=lambda i: i.fopdt,
            robustness=("ms", 2.4, 1.2), design_experiments=(*_STABLE_EXPERIMENTS, "relay"), least_squares_order=2,
        ),
        Structure(
            name="fppi", title="FPPI", controller="fppi", model="fopdt", integrating=False, family="stable",
            symbol="T_r/T_n", parameter_range=(0.001, 10.0), design_function=fppi_design,
            unit=lambda model: model.time_constant, base_rule="fppi-eq34", base=_fppi_base, check=lambda i: i.sopdt,
            robustness=("ms", 2.4, 1.2), design_experiments=_STABLE_EXPERIMENTS, least_squares_order=1,
        ),
        Structure(
            name="msp", title="MSP", controller="msp", model="integrating_model", integrating=True,
            family="integrating", symbol="T_r/L_n", parameter_range=(0.01, 30.0), design_function=msp_design,
            unit=lambda model: model.dead_time, base_rule="msp-eq50",
            base=lambda identification: 2.0 * MSP_RELATIVE_DEAD_TIME_ERROR / (1.0 - MSP_RELATIVE_DEAD_TIME_ERROR),
            check=_msp_check, robustness=("delay_margin", 0.1, 1.5), design_experiments=("closed-loop-step", "pulse"),
            least_squares_order=None, constraints=Constraints(max_sensitivity=None, min_relative_delay_margin=0.2),
        ),
        Structure(
            name="pi", title="PI", controller="pid", model="fopdt", integrating=False, family="stable",
            symbol="tau_c/theta", parameter_range=(0.03, 300.0), design_function=pi_design, unit=pi_dead_time,
            base_rule="simc-pi", base=lambda identification: 1.0, check=lambda i: i.sopdt,
            robustness=("ms", 2.4, 1.2), design_experiments=_STABLE_EXPERIMENTS, least_squares_order=1,
        ),
    )
}
"""Every structure by name."""

PARAMETER_RANGES: dict[str, tuple[float, float]] = {s.name: s.parameter_range for s in STRUCTURES.values()}
"""Range of the relative design parameter of each structure (log scale).

* ``"pid"``: ``mu`` (Gorez-Klan eq. 3-11), dimensionless.
* ``"fppi"``: ``T_r/T_n``, ``T_n`` the model's time constant (``kappa = T_n/T_r``).
* ``"msp"``: ``T_r/L_n``, ``L_n`` the model's dead time.

Measured with a wider search (``mu`` in [0.3, 300], ``T_r/T_n`` in [0.003, 100], ``T_r/L_n`` in
[0.005, 100]) on the 17 benchmark plants and 40 random plants of each family
(``sample_plants(family, 50, 0)[:40]``), noise-free identification, default constraints: every
plant had a feasible design, with optima ``mu`` in [0.45, 105.5], ``T_r/T_n`` in [0.0053, 4.9]
and ``T_r/L_n`` in [0.064, 3.0].  ``mu`` must reach about 30 on Ingimundarson's stable P6
(``0.5/(s+1) + 0.05/(s+0.1)``, lead: the PID is unstable up to ``mu`` = 13 and breaks
``Ms <= 2`` up to 28.5) and 105 on lag-chain plant 28 (strong lead, ``D_2 = 0.007 T_ar``: ``mu``
scales with ``1/D_2``).  The ranges leave a factor of 2 or more beyond every optimum found.  The
MSP's optimum under ``Ms <= 2`` is ``T_r/L_n`` of about 2.3 (the MSP loop has ``Ms`` of
2.2-2.4 for ``T_r/L_n <= 1``, Ingimundarson eq. 47).  These are the ranges open to the agent (``mu``
reaching well beyond 8).
"""


def structure(name: str) -> Structure:
    """The registered structure ``name``; a ``ValueError`` naming the valid ones otherwise."""
    found = STRUCTURES.get(name) if isinstance(name, str) else None
    if found is None:
        raise ValueError(f"unknown structure {name!r}; valid: {', '.join(STRUCTURES)}")
    return found


def relative_scale(name: str, model: Any) -> float:
    """The unit of the relative parameter of structure ``name``: 1 (PID), ``T_n`` (FPPI), ``L_n`` (MSP)."""
    return structure(name).scale(model)


def design(name: str, model: Any, parameter: float) -> Any:
    """The controller of structure ``name`` designed from ``model`` with ``parameter`` (``mu`` or ``T_r``)."""
    return structure(name).design(model, parameter)
