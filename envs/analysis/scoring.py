"""The episode cost of a design: dimensionless IAE under robustness constraints on the true plant.

For a controller designed from identified data, the loop is closed around the TRUE plant and
analysed exactly as ``deadtime analyze`` does (:func:`envs.analysis.loop_analysis.analyze`).  With ``K`` the true
static gain (velocity gain ``K_v`` for integrating plants) and ``T_ar`` the true residence time
(``L_n`` for integrating plants):

* ``J_load = IAE_load/(|K| T_ar)`` (stable) or ``IAE_load/(|K_v| T_ar^2)`` (integrating): a unit
  load step at the plant input moves the output by ``K`` per unit (``K_v t`` when integrating);
* ``J_setpoint = IAE_setpoint/T_ar``;
* ``J_experiment = experiment_time/T_ar``;
* ``J_production = D_exp/T_ar`` with ``D_exp = int |y - y_0| dt`` of the true output about its
  operating point over the experiments (output units; the experiments' amplitudes are relative to a
  unit change of the output, as the set-point step of ``J_setpoint``): the production the
  experiments disturb.

Both IAE terms are invariant to the plant's gain and time scale.  The feasible cost is
``c = w_load J_load + w_setpoint J_setpoint + w_experiment J_experiment + w_production J_production``
(the last two are the cost of the experiments, ``Score.experiment_cost``; ``w_production`` is 0 by
default, and the term is then left out), capped at
``FEASIBLE_CAP`` (a design that bad is useless anyway; the cap keeps the ordering below strict).
A design that violates a constraint costs more than every feasible design, by
:func:`violation_cost` of its grade ``g``: the sum of the relative violations ``Ms/Ms_max - 1``,
``1 - DM_rel/DM_min``, ``1 - GM/GM_min``, ``1 - PM/PM_min`` (each when positive) of a stable loop.
An unstable loop's margins are undefined and not graded.  Two maps (``Constraints.violation_cost``):

* ``"graded"`` (the environments' v0-v2): ``FEASIBLE_CAP + 1 + g``, and ``FEASIBLE_CAP + 1 +
  UNSTABLE_GRADE`` for an unstable loop.  Unbounded: a stable loop near instability (``Ms`` in the
  thousands) costs far more than an unstable one, and one such plant dominates a policy's mean.
* ``"bounded"`` (v3): ``FEASIBLE_CAP + 1 + VIOLATION_BAND g/(1 + g)`` for a stable loop, and the top
  of the band, ``FEASIBLE_CAP + 1 + VIOLATION_BAND``, for an unstable one.  Every violating design
  costs more than every feasible one, every unstable loop at least as much as every stable one, and
  the cost grows strictly with ``g`` (half the band at ``g = 1``, e.g. ``Ms = 4`` against ``Ms <= 2``).

The delay margin is relative to the true dead time ``L``.  A plant without dead time is judged in
one of two ways (``Constraints.zero_delay``):

* ``"limit"`` (:func:`score`'s default, and so the standalone oracle's and every caller's that does
  not choose): as the limit of small dead times, ``DM/L -> inf`` for a stable loop (``DM > 0``), so
  the delay margin constraint holds; ``L = 0`` and ``L = 1e-300`` cost the same.
* ``"residence-time"`` (the environments' convention, every version): ``DM/T_ar``, the true ``T_ar``
  standing in for the missing dead time.  The environments keep it so that no episode's cost changes:
  the benchmark family draws Gorez-Klan's P1 and P2, which have no dead time, and the papers'
  reproductions and the recorded results score them this way.  It is stricter than the limit (a
  stable loop may violate it), never looser.

A feasible design whose cost is capped is simulated only until that is certain: the IAE terms
are non-negative integrals, so once ``w_load J_load + w_setpoint J_setpoint`` over the horizon
simulated so far exceeds ``FEASIBLE_CAP - w_experiment J_experiment`` (an
:class:`~envs.analysis.performance.IAEBound`), the cost is ``FEASIBLE_CAP`` whatever follows.  The
:class:`Score` then says ``iae_lower_bound=True``: its IAE and load/set-point cost terms are
those of the horizon simulated, lower bounds of the full ones.  The cost is the same as with the
full simulation, bit for bit.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, fields
from typing import Any

from envs.analysis.loop_analysis import plant_margins
from envs.systems.controllers import Controller
from envs.analysis.performance import IAEBound, iae
from envs.systems.plants import Plant
from envs.analysis.robustness import Margins
from envs.threads import single_threaded
from envs.validation import require_number

__all__ = [
    "Constraints", "CostWeights", "Score", "score", "constraint_violations", "violation_cost", "FEASIBLE_CAP",
    "UNSTABLE_GRADE", "VIOLATION_BAND", "VIOLATION_COSTS", "ZERO_DELAY_CONVENTIONS",
]

FEASIBLE_CAP = 20.0
UNSTABLE_GRADE = 5.0
"""The grade of an unstable loop in the ``"graded"`` map."""
VIOLATION_BAND = 5.0
"""The width of the ``"bounded"`` map's band of violating costs above ``FEASIBLE_CAP + 1``; an unstable
loop costs its top, ``FEASIBLE_CAP + 1 + VIOLATION_BAND``, the same as in the ``"graded"`` map."""
VIOLATION_COSTS = ("graded", "bounded")
ZERO_DELAY_CONVENTIONS = ("limit", "residence-time")
"""The ways of judging the delay margin of a plant without dead time (module docstring)."""


@dataclass(frozen=True)
class Constraints:
    """Robustness constraints on the true loop; ``None`` disables one.

    Attributes
    ----------
    max_sensitivity : float or None
        ``Ms <= max_sensitivity`` (default 2.0).
    min_relative_delay_margin : float or None
        ``DM/L >= min_relative_delay_margin`` (default 0.2), ``L`` the true dead time.
    min_gain_margin, min_phase_margin_deg : float or None
        Optional classical margins (default off).
    violation_cost : {"graded", "bounded"}
        How a violating design is charged (:func:`violation_cost`; the environments set it from
        their ``violation_cost`` argument).
    zero_delay : {"limit", "residence-time"} or None
        How the delay margin of a plant without dead time is judged (module docstring).  None:
        the caller's convention, ``"limit"`` for :func:`score`, ``"residence-time"`` for the
        environments.
    """

    max_sensitivity: float | None = 2.0
    min_relative_delay_margin: float | None = 0.2
    min_gain_margin: float | None = None
    min_phase_margin_deg: float | None = None
    violation_cost: str = "graded"
    zero_delay: str | None = None

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            if name == "violation_cost":
                if value not in VIOLATION_COSTS:
                    raise ValueError(f"constraints.violation_cost must be one of {', '.join(VIOLATION_COSTS)}, got {value!r}")
            elif name == "zero_delay":
                if value is not None and value not in ZERO_DELAY_CONVENTIONS:
                    raise ValueError(f"constraints.zero_delay must be one of {', '.join(ZERO_DELAY_CONVENTIONS)}, got {value!r}")
            elif value is not None:
                require_number(value, f"constraints.{name}", positive=True)


@dataclass(frozen=True)
class CostWeights:
    """Weights of the dimensionless cost terms (see the module docstring); each >= 0.

    ``experiment`` is the price of one ``T_ar`` of experiment time, ``production`` that of one unit
    of ``D_exp/T_ar`` (a unit output deviation held for one ``T_ar``: a ``production`` of 1 prices a
    disturbed ``T_ar`` like the set-point IAE of a loop that takes one ``T_ar`` to respond).
    """

    load: float = 1.0
    setpoint: float = 1.0
    experiment: float = 0.01
    production: float = 0.0

    def __post_init__(self) -> None:
        for name, value in asdict(self).items():
            require_number(value, f"weights.{name}", nonnegative=True)


@dataclass(frozen=True)
class Score:
    """The cost of one design on the true plant, with every figure behind it.

    ``iae_lower_bound`` is True when the design's cost is capped and its simulation stopped as soon
    as that was certain: ``iae_load``, ``iae_setpoint``, ``load_cost`` and ``setpoint_cost`` are
    then lower bounds (the figures of the horizon simulated), not the full IAE; the full IAE is that
    of :func:`envs.analysis.loop_analysis.analyze`.
    """

    cost: float
    feasible: bool
    violations: dict[str, float]
    stable: bool
    ms: float
    gain_margin: float
    phase_margin_deg: float
    delay_margin: float
    relative_delay_margin: float
    iae_load: float
    iae_setpoint: float
    load_cost: float
    setpoint_cost: float
    experiment_cost: float
    margins: Margins = field(repr=False)
    iae_lower_bound: bool = False

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready figures (``None`` for infinite or undefined values)."""
        out = {f.name: getattr(self, f.name) for f in fields(self) if f.name != "margins"}  # asdict would copy margins
        out["violations"] = dict(self.violations)
        return {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in out.items()}


def constraint_violations(margins: Margins, relative_delay_margin: float, constraints: Constraints) -> dict[str, float]:
    """Relative violation of each active constraint (only those that are violated); ``{"stability":
    UNSTABLE_GRADE}`` for an unstable loop.  ``relative_delay_margin`` is the delay margin over the
    dead time it is judged against."""
    if not margins.stable:
        return {"stability": UNSTABLE_GRADE}
    c, found = constraints, {}
    if c.max_sensitivity is not None:
        found["max_sensitivity"] = margins.ms / c.max_sensitivity - 1
    if c.min_relative_delay_margin is not None:
        found["min_relative_delay_margin"] = 1 - relative_delay_margin / c.min_relative_delay_margin
    if c.min_gain_margin is not None:
        found["min_gain_margin"] = 1 - margins.gain_margin / c.min_gain_margin
    if c.min_phase_margin_deg is not None:
        found["min_phase_margin_deg"] = 1 - margins.phase_margin_deg / c.min_phase_margin_deg
    return {k: float(v) for k, v in found.items() if v > 0}


def violation_cost(violations: dict[str, float], stable: bool, kind: str = "graded") -> float:
    """The cost of a design with these (non-empty) ``violations`` (:func:`constraint_violations`); see
    the module docstring for the two maps, ``kind`` ``"graded"`` or ``"bounded"``."""
    if kind == "graded":
        return FEASIBLE_CAP + 1 + sum(violations.values())
    if not stable:
        return FEASIBLE_CAP + 1 + VIOLATION_BAND
    grade = sum(violations.values())
    return FEASIBLE_CAP + 1 + VIOLATION_BAND * grade / (1 + grade)


def _relative_delay_margin(delay_margin: float, plant: Plant, zero_delay: str | None) -> float:
    """``DM/L``; without dead time ``DM/T_ar`` (``"residence-time"``) or the limit ``L -> 0``: ``inf`` for
    ``DM > 0``, else 0 (module docstring)."""
    if plant.dead_time > 0:
        return delay_margin / plant.dead_time
    if zero_delay == "residence-time":
        return delay_margin / plant.residence_time
    return math.inf if delay_margin > 0 else 0.0


@single_threaded
def score(
    plant: Plant,
    controller: Controller,
    *,
    experiment_time: float = 0.0,
    experiment_deviation: float = 0.0,
    constraints: Constraints = Constraints(),
    weights: CostWeights = CostWeights(),
) -> Score:
    """The cost of ``controller`` on the true ``plant`` (see the module docstring).

    ``experiment_time`` and ``experiment_deviation`` (``D_exp``) are those of the experiments that
    identified the design's model; ``experiment_cost`` prices both.

    An infeasible design is not simulated (its cost does not depend on the IAE); its IAE is
    reported as ``inf`` if the loop is unstable and ``nan`` otherwise.  A capped feasible design
    is simulated only until its cap is certain (``iae_lower_bound``, see the module docstring).
    """
    scale = plant.residence_time
    margins = plant_margins(plant, controller)
    relative_dm = _relative_delay_margin(margins.delay_margin, plant, constraints.zero_delay)
    violations = constraint_violations(margins, relative_dm, constraints)
    experiment_cost = weights.experiment * experiment_time / scale
    if weights.production != 0.0:  # without a price of production the v0 cost, bit for bit
        experiment_cost += weights.production * experiment_deviation / scale
    if violations:
        undefined = math.inf if not margins.stable else math.nan
        return Score(
            violation_cost(violations, margins.stable, constraints.violation_cost), False, violations, margins.stable, margins.ms,
            margins.gain_margin, margins.phase_margin_deg, margins.delay_margin, relative_dm,
            undefined, undefined, undefined, undefined, experiment_cost, margins,
        )  # fmt: skip
    load_scale = abs(plant.gain) * scale * (scale if plant.integrating else 1.0)
    bound = IAEBound(weights.load / load_scale, weights.setpoint / scale, FEASIBLE_CAP - experiment_cost)
    performance = iae(plant, controller, bound=bound)
    load_cost = weights.load * performance.load / load_scale
    setpoint_cost = weights.setpoint * performance.setpoint / scale
    cost = min(load_cost + setpoint_cost + experiment_cost, FEASIBLE_CAP)
    return Score(
        cost, True, {}, True, margins.ms, margins.gain_margin, margins.phase_margin_deg, margins.delay_margin,
        relative_dm, performance.load, performance.setpoint, load_cost, setpoint_cost, experiment_cost, margins,
        performance.lower_bound,
    )  # fmt: skip
