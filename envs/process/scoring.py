"""The cost of a controller on a process: its tests on the process, its robustness on the model.

The environments score a design on the TRUE plant (:mod:`envs.analysis.scoring`).  On a process the
truth is the process itself for performance, but its frequency response is unknown: robustness is
judged on the identified model, as the robustness-matched rules do
(:mod:`baselines.rules.matched`).  With ``K_n``, ``T_ar`` identified (the closed-loop step),
``Delta r`` the set-point step and ``Delta d`` the load step:

* ``J_setpoint = IAE_setpoint/(|Delta r| T_ar)``: the environments' ``IAE_setpoint/T_ar`` per unit step;
* ``J_load = IAE_load/(|K_d Delta d| T_ar)``: the environments' ``IAE_load/(|K| T_ar)`` per unit load
  at the plant input, ``K_d`` the process's ``load_gain`` (the static effect of the load on the
  output; the identified ``K_n`` if the process does not give it, the load entering at the input).
  On the TCLab the load is heater 2, ``K_d = 0.050 degC/%`` (a twelfth of heater 1's 0.60);
* robustness: ``Ms``, the delay margin and the other figures of
  :func:`envs.analysis.loop_analysis.plant_margins` for the loop of the controller with the
  identified SOPDT model (Gorez-Klan eq. 2-8, the model of the ``mu`` rules and of the matched
  rules), judged by :class:`~envs.analysis.scoring.Constraints` (default ``Ms <= 2`` and a delay
  margin of ``0.2`` times the model's dead time, the environments' defaults).

``cost = w_load J_load + w_setpoint J_setpoint`` capped at ``FEASIBLE_CAP`` when the constraints hold
on the model, else ``FEASIBLE_CAP + 1 + grade`` (the environments' grading); a test stopped by a
measurement that is not a number is graded as an unstable loop.  No experiment cost: every policy
reads the same experiments.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from envs.analysis.loop_analysis import plant_margins
from envs.analysis.robustness import Margins
from envs.analysis.scoring import FEASIBLE_CAP, UNSTABLE_GRADE, Constraints, CostWeights, constraint_violations, violation_cost
from envs.process.performance import ProcessPerformance, RunProtocol, closed_loop_performance
from envs.process.procedure import ProcessIdentification
from envs.process.protocol import Process
from envs.systems.controllers import Controller
from envs.systems.plants import Plant

__all__ = ["ProcessScore", "process_score", "model_plant"]


@dataclass(frozen=True)
class ProcessScore:
    """One controller on one process.

    Attributes
    ----------
    cost : float
        See the module docstring.
    feasible : bool
        The constraints hold on the model loop and neither test stopped.
    violations : dict of str to float
        The relative violations on the model loop (``"stability"`` if unstable there), and
        ``"stopped"`` if a test stopped.
    margins : Margins
        The robustness of the loop on the identified model.
    relative_delay_margin : float
        The model loop's delay margin over the model's dead time.
    performance : ProcessPerformance or None
        The tests on the process (None if they were skipped for an infeasible design).
    setpoint_cost, load_cost : float
    """

    cost: float
    feasible: bool
    violations: dict[str, float]
    margins: Margins
    relative_delay_margin: float
    performance: ProcessPerformance | None
    setpoint_cost: float
    load_cost: float


def model_plant(found: ProcessIdentification) -> Plant:
    """The identified SOPDT model as a plant (the model of the robustness figures)."""
    return found.identification.sopdt.plant()


def process_score(
    process: Process,
    controller: Controller,
    found: ProcessIdentification,
    protocol: RunProtocol,
    *,
    constraints: Constraints = Constraints(),
    weights: CostWeights = CostWeights(),
    test_infeasible: bool = True,
) -> ProcessScore:
    """The :class:`ProcessScore` of ``controller`` (see the module docstring).

    ``test_infeasible=False`` skips the process tests of a design infeasible on the model (its cost
    does not depend on them), as the oracle's search does.
    """
    model = model_plant(found)
    margins = plant_margins(model, controller)
    reference = model.dead_time if model.dead_time > 0 else model.residence_time
    relative_dm = margins.delay_margin / reference
    violations = constraint_violations(margins, relative_dm, constraints)
    performance = None
    if test_infeasible or not violations:
        performance = closed_loop_performance(process, controller, protocol)
    identification = found.identification
    scale = identification.residence_time
    setpoint_cost = load_cost = math.nan
    if performance is not None:
        setpoint_cost = weights.setpoint * performance.iae_setpoint / (abs(protocol.setpoint_step) * scale)
        load_gain = identification.gain if found.load_gain is None else found.load_gain
        load_cost = weights.load * performance.iae_load / (abs(load_gain * protocol.load_step) * scale)
        if performance.stopped:
            violations = {**violations, "stopped": UNSTABLE_GRADE}
    if violations:
        cost = violation_cost(violations, margins.stable and "stopped" not in violations, constraints.violation_cost)
    else:
        cost = min(setpoint_cost + load_cost, FEASIBLE_CAP)
    return ProcessScore(float(cost), not violations, violations, margins, relative_dm, performance, setpoint_cost, load_cost)
