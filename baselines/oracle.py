"""The oracle: the design parameter that minimizes the episode cost on the TRUE plant.

For a true plant, a model of it and a controller structure, :func:`oracle` searches the one design
parameter of the papers' designs (:mod:`envs.design`: ``mu`` of the Gorez-Klan PID, ``T_r`` of the
FPPI or of the MSP) for the smallest cost of :func:`envs.analysis.scoring.score`, constraints
included.  A constraint violation costs more than every feasible design and is graded by how far it
violates, so the minimum of the cost is the constrained optimum when a feasible parameter exists,
and the least-violating parameter otherwise: one objective serves both cases.

Search
------
The cost is not convex (nor even continuous: it jumps at the constraint boundaries), so the search
is global, then local, in ``log`` of the relative parameter:

1. a log-spaced grid of ``grid`` points over :data:`PARAMETER_RANGES` (default 30, a ratio of about
   1.2 between neighbours for ``mu``, 1.37 for ``T_r/T_n``);
2. bounded Brent (``scipy.optimize.minimize_scalar``, golden section where the cost is not smooth)
   on the interval between the grid neighbours of the best grid point, to a relative tolerance of
   :data:`REFINEMENT_TOLERANCE` (at most :data:`REFINEMENT_EVALUATIONS` evaluations);
3. two probes at relative distance :data:`BINDING_PROBE` either side of the optimum, which decide
   the binding constraint.

``search="fast"`` (:mod:`baselines.fast_search`) finds the same optimum within the reference's
own error (:data:`baselines.fast_search.REFERENCE_ERROR` in cost, measured against a dense search)
with about half the scorings, most of them the robustness analysis alone: a coarse grid brackets the
feasibility boundary, a root finder refines it, the IAE ranks only feasible designs and stops once
a design is certainly worse; it also returns that boundary, the least conservative feasible parameter
(``OracleResult.feasibility_boundary``).  The reference stays the default.

Infeasible parameters are not simulated (:func:`~envs.analysis.scoring.score` skips the IAE), so they cost
only the frequency-domain analysis.  A search costs at most ``grid`` + :data:`REFINEMENT_EVALUATIONS`
+ 2 scorings; loops with many unstable closed-loop poles (the PID on Ingimundarson's stable P6) are
the slowest to analyse (the times measured are in docs/performance.md).

Binding constraint
------------------
A constraint *binds* when the optimum sits on the boundary of the feasible set: a probe at
relative distance :data:`BINDING_PROBE` (1 %) from the optimum violates it, so that moving the
parameter that way (towards the unconstrained optimum; otherwise the search would not have
stopped at the boundary) breaks it.  If both probes violate, the constraint of the larger violation
is named.  ``binding`` is ``"parameter_range"`` when the optimum is at an end of the range (within
the probe distance) and the probe inside the range is feasible, and ``None`` when the optimum is
interior.  The relative margin of every enabled constraint at the optimum is in
``OracleResult.margins`` (``1 - Ms/Ms_max``, ``DM_rel/DM_min - 1``, ...; ``>= 0`` when satisfied).
When no parameter of the range is feasible, ``feasible`` is False, ``binding`` is None and
``violations`` holds the violations of the least-violating parameter.

Full information
----------------
:func:`full_information_oracle` designs from the exact model of the plant instead of an identified
one, and is charged no experiment time (:func:`exact_models`):

* SOPDT (Gorez-Klan eq. 2-8): ``K`` and ``T_ar = -p1`` from the exact Taylor coefficients
  (eq. 2-3, 2-5), ``T_a = sqrt(2 p2 - T_ar^2)`` clipped to ``[0, T_ar]`` (eq. 2-6; ``p2`` is the
  first moment of ``1 - y/K``), ``tau = 1 - T_a/T_ar`` (eq. 2-7) and ``theta`` from eq. 2-9;
* FOPDT: ``T_n`` by Ingimundarson eq. 11 on the exact, noise-free open-loop unit-step response,
  ``T_n = e int_0^{T_ar} y dt/K`` (the integral by a matrix exponential), clipped as the identified
  model is (:func:`envs.identification.open_loop_areas.fopdt_from_area`).  This is the model the fixed procedure
  converges to with perfect measurements, so the full-information oracle isolates the effect of
  noise and finite experiments; ``T_n = T_a`` (moments) would change the model class as well.
* integrating: ``K_v`` exact and ``L_n = T_ar`` of the dynamics additional to the integrator
  (Ingimundarson eq. 2, section 2.1).

The full-information oracle is not always cheaper than the identified one: the exact model is not
the best model for a fixed-structure design (a noisy identification can land on a model whose
best design happens to suit the true plant better), so only the experiment cost is guaranteed to
favour it.  See ``tests/property/test_oracle_props.py``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import scipy.linalg
import scipy.optimize

from envs.systems.controllers import Controller
from envs.structures import PARAMETER_RANGES, STRUCTURES, design, relative_scale
from envs.identification.models import FOPDTModel, IntegratingModel, SOPDTModel
from envs.identification.moments import apparent_time_constant, sopdt_from_moments
from envs.identification.open_loop_areas import fopdt_from_area, step_time_constant
from envs.systems.plants import Plant
from envs.identification.procedure import Identification
from envs.analysis.scoring import Constraints, CostWeights, Score, score
from envs.threads import single_threaded
from envs.validation import require_number

__all__ = [
    "PARAMETER_RANGES",
    "STRUCTURES",
    "OracleResult",
    "ExactModels",
    "oracle",
    "full_information_oracle",
    "exact_models",
    "design",
    "relative_scale",
    "search_parameter",
    "SEARCHES",
]



SEARCHES = ("reference", "fast")
"""The searches of :func:`oracle`: the reference (module docstring, "Search") and :mod:`baselines.fast_search`."""
REFINEMENT_TOLERANCE = 1e-3  # relative (in log parameter)
REFINEMENT_EVALUATIONS = 14
BINDING_PROBE = 0.01  # relative distance of the probes that decide the binding constraint


@dataclass(frozen=True)
class OracleResult:
    """The best design parameter of one structure for one plant and model.

    Attributes
    ----------
    structure : {"pid", "fppi", "msp"}
    parameter : float
        ``mu`` (PID) or ``T_r`` in the plant's time units (FPPI, MSP).
    relative_parameter : float
        ``mu``, ``T_r/T_n`` or ``T_r/L_n`` (the agent's parameter, see :data:`PARAMETER_RANGES`).
    cost : float
        The episode cost at ``parameter`` (experiment cost included).
    score : Score
        Every figure at ``parameter``.
    feasible : bool
        Whether some parameter in the range satisfies every constraint.
    binding : str or None
        The binding constraint (see the module docstring), ``"parameter_range"``, or None.
    margins : dict of str to float
        Relative margin of each enabled constraint at the optimum (``>= 0`` when satisfied).
    violations : dict of str to float
        The violations at the optimum (empty when feasible).
    evaluations : int
        Number of designs scored (in whole or, by the fast search, in part).
    feasibility_boundary : float or None
        The least conservative feasible relative parameter (the aggressive end of the feasible set,
        :mod:`baselines.fast_search`); found by the fast search only (None from the reference search,
        and where no parameter is feasible).
    """

    structure: str
    parameter: float
    relative_parameter: float
    cost: float
    score: Score = field(repr=False)
    feasible: bool
    binding: str | None
    margins: dict[str, float]
    violations: dict[str, float]
    evaluations: int
    feasibility_boundary: float | None = None


@dataclass(frozen=True)
class ExactModels:
    """The models of a plant computed from its exact transfer function (no experiment)."""

    sopdt: SOPDTModel | None
    fopdt: FOPDTModel | None
    integrating_model: IntegratingModel | None


# --------------------------------------------------------------------------- designs
def _model_for(structure: str, models):
    """The model ``structure``'s design reads, from an identification or :class:`ExactModels`."""
    model = STRUCTURES[structure].model_of(models)
    if model is None:
        kind = "an integrating" if STRUCTURES[structure].integrating else "a self-regulating"
        raise ValueError(f"structure {structure!r} needs {kind} plant and its model; none was identified")
    return model


def _check_structure(structure: str) -> None:
    if structure not in STRUCTURES:
        raise ValueError(f"structure must be one of {', '.join(STRUCTURES)}; got {structure!r}")


# --------------------------------------------------------------------------- margins and binding
def _relative_margins(s: Score, constraints: Constraints) -> dict[str, float]:
    """``>= 0`` when satisfied; ``-inf`` for every constraint of an unstable loop."""
    c = constraints
    values = {
        "max_sensitivity": (c.max_sensitivity, lambda bound: 1 - s.ms / bound),
        "min_relative_delay_margin": (c.min_relative_delay_margin, lambda bound: s.relative_delay_margin / bound - 1),
        "min_gain_margin": (c.min_gain_margin, lambda bound: s.gain_margin / bound - 1),
        "min_phase_margin_deg": (c.min_phase_margin_deg, lambda bound: s.phase_margin_deg / bound - 1),
    }
    return {name: (float(f(bound)) if s.stable else -math.inf) for name, (bound, f) in values.items() if bound is not None}


def _binding(best: float, probes: list[tuple[float, Score]], bounds: tuple[float, float]) -> str | None:
    """See the module docstring, "Binding constraint" (``best`` and ``bounds`` in log parameter)."""
    violated = [s.violations for _, s in probes if not s.feasible]
    if violated:
        worst = max(violated, key=lambda v: max(v.values()))
        return max(worst, key=worst.get)
    if best - bounds[0] <= BINDING_PROBE or bounds[1] - best <= BINDING_PROBE:
        return "parameter_range"
    return None


# --------------------------------------------------------------------------- search
def search_parameter(
    cost_of: Callable[[float], Score], bounds: tuple[float, float], grid: int
) -> tuple[float, Score, list[tuple[float, Score]], int]:
    """Grid, bounded Brent around the best grid point, then the two binding probes (log parameter).

    ``cost_of(p)`` scores the relative parameter ``p`` (anything with ``cost``); ``bounds`` are the
    logs of the range.  Returns the best log parameter, its score, the probes and the number of
    parameters scored.  The oracle here and the process oracle (:mod:`baselines.process_oracle`)
    search with it."""
    cache: dict[float, Score] = {}

    def evaluate(x: float) -> Score:
        x = float(x)
        if x not in cache:
            cache[x] = cost_of(math.exp(x))
        return cache[x]

    points = np.linspace(bounds[0], bounds[1], grid)
    costs = [evaluate(x).cost for x in points]
    i = int(np.argmin(costs))
    low, high = points[max(i - 1, 0)], points[min(i + 1, grid - 1)]
    scipy.optimize.minimize_scalar(
        lambda x: evaluate(x).cost,
        bounds=(low, high),
        method="bounded",
        options={"xatol": REFINEMENT_TOLERANCE, "maxiter": REFINEMENT_EVALUATIONS},
    )
    best = min(cache, key=lambda x: (cache[x].cost, x))
    probes = [(x, evaluate(x)) for x in (best - BINDING_PROBE, best + BINDING_PROBE) if bounds[0] <= x <= bounds[1]]
    return best, cache[best], probes, len(cache)


def _oracle(
    plant: Plant,
    structure: str,
    model,
    experiment_time: float,
    constraints: Constraints,
    weights: CostWeights,
    grid: int,
    parameter_range: tuple[float, float] | None,
    experiment_deviation: float = 0.0,
    search: str = "reference",
) -> OracleResult:
    _check_structure(structure)
    if search not in SEARCHES:
        raise ValueError(f"search must be one of {', '.join(SEARCHES)}, got {search!r}")
    if int(grid) != grid or grid < 3:
        raise ValueError(f"grid must be an integer >= 3, got {grid!r}")
    low, high = parameter_range if parameter_range is not None else PARAMETER_RANGES[structure]
    low, high = require_number(low, "parameter_range[0]", positive=True), require_number(high, "parameter_range[1]", positive=True)
    if not low < high:
        raise ValueError(f"parameter_range must be increasing, got ({low!r}, {high!r})")
    unit = relative_scale(structure, model)

    def cost_of(relative: float) -> Score:
        controller = design(structure, model, relative * unit)
        return score(plant, controller, experiment_time=experiment_time, experiment_deviation=experiment_deviation,
                     constraints=constraints, weights=weights)

    bounds = (math.log(low), math.log(high))
    boundary, spent = None, 0
    if search == "fast":
        best, at_best, probes, spent, boundary = _fast(plant, structure, model, unit, experiment_time,
                                                       experiment_deviation, constraints, weights, bounds)
        evaluations = spent
    if search == "reference" or best is None:
        best, at_best, probes, evaluations = search_parameter(cost_of, bounds, int(grid))
        evaluations += spent
    relative = math.exp(best)
    return OracleResult(
        structure=structure,
        parameter=relative * unit,
        relative_parameter=relative,
        cost=at_best.cost,
        score=at_best,
        feasible=at_best.feasible,
        binding=_binding(best, probes, bounds) if at_best.feasible else None,
        margins=_relative_margins(at_best, constraints),
        violations=dict(at_best.violations),
        evaluations=evaluations,
        feasibility_boundary=None if boundary is None else math.exp(boundary),
    )


def _fast(plant, structure, model, unit, experiment_time, experiment_deviation, constraints, weights, bounds):
    """:func:`baselines.fast_search.fast_search`: ``(best, score, probes, evaluations, boundary)``, all
    None but the evaluations where no grid point is feasible."""
    from baselines.fast_search import Scorer, fast_search

    scorer = Scorer(plant, lambda relative: design(structure, model, relative * unit), experiment_time,
                    experiment_deviation, constraints, weights)
    found = fast_search(scorer, bounds, BINDING_PROBE, REFINEMENT_TOLERANCE, REFINEMENT_EVALUATIONS)
    if found.best is None:  # no grid point feasible: the reference search runs instead
        return None, None, None, scorer.evaluations, None
    probes = [(x, _ProbeScore(scorer, x)) for x in (found.best - BINDING_PROBE, found.best + BINDING_PROBE)
              if bounds[0] <= x <= bounds[1]]
    at_best = scorer.score(found.best)
    return found.best, at_best, probes, scorer.evaluations, found.boundary


class _ProbeScore:
    """What :func:`_binding` reads of a probe (feasibility and violations), from the robustness analysis alone."""

    def __init__(self, scorer, x: float) -> None:
        self.violations = scorer.violations(x)
        self.feasible = not self.violations


@single_threaded
def oracle(
    plant: Plant,
    identification: Identification,
    structure: str,
    *,
    constraints: Constraints = Constraints(),
    weights: CostWeights = CostWeights(),
    grid: int = 30,
    parameter_range: tuple[float, float] | None = None,
    search: str = "reference",
) -> OracleResult:
    """The best parameter of ``structure`` designed from the identified model, scored on ``plant``.

    Parameters
    ----------
    plant : Plant
        The true plant.
    identification : Identification
        The fixed procedure on ``plant`` (:func:`envs.identification.procedure.identify`): the PID uses its SOPDT
        model, the FPPI its FOPDT model, the MSP its two-parameter model; its experiment time and
        deviation are charged, as for the rules.
    structure : {"pid", "fppi", "msp"}
    constraints, weights
        As for :func:`envs.analysis.scoring.score`.
    grid : int
        Number of log-spaced grid points (>= 3) before the local refinement.
    parameter_range : (float, float), optional
        The range of the relative parameter; default :data:`PARAMETER_RANGES` ``[structure]``.
    search : {"reference", "fast"}
        The search (:data:`SEARCHES`): the grid, Brent and probes of the module docstring, or
        :mod:`baselines.fast_search` (about ten times fewer full scorings, the same optimum within
        the tolerance of docs/rules_and_oracle.md, and the feasibility boundary; ``grid`` unused).

    Returns
    -------
    OracleResult

    Raises
    ------
    ValueError
        If the structure is unknown or its model was not identified (PID and FPPI need a
        self-regulating plant, the MSP an integrating one), or for a bad grid or range.
    """
    _check_structure(structure)
    model = _model_for(structure, identification)
    return _oracle(plant, structure, model, identification.experiment_time, constraints, weights, grid, parameter_range,
                   identification.experiment_deviation, search)


@single_threaded
def full_information_oracle(
    plant: Plant,
    structure: str,
    *,
    constraints: Constraints = Constraints(),
    weights: CostWeights = CostWeights(),
    grid: int = 30,
    parameter_range: tuple[float, float] | None = None,
    search: str = "reference",
) -> OracleResult:
    """:func:`oracle` with the exact models of :func:`exact_models` and no experiment time."""
    _check_structure(structure)
    models = exact_models(plant)
    model = _model_for(structure, models)
    return _oracle(plant, structure, model, 0.0, constraints, weights, grid, parameter_range, search=search)


# --------------------------------------------------------------------------- exact models
def _step_area(plant: Plant, until: float) -> float:
    """``int_0^until y dt`` of the exact unit-step response (``y = 0`` before the dead time)."""
    span = until - plant.dead_time
    if span <= 0:
        return 0.0
    ss = plant.state_space()
    n = ss.A.shape[0]
    # z' = [A 0; C 0] z + [B; D] u: the last state is the integral of the undelayed output.
    augmented = np.zeros((n + 2, n + 2))
    augmented[:n, :n] = ss.A
    augmented[n, :n] = ss.C[0]
    augmented[:n, n + 1] = ss.B[:, 0]
    augmented[n, n + 1] = ss.D[0, 0]
    return float(scipy.linalg.expm(augmented * span)[n, n + 1])


def exact_models(plant: Plant) -> ExactModels:
    """The SOPDT, FOPDT (self-regulating) or two-parameter (integrating) model of the exact plant.

    See the module docstring, "Full information".
    """
    gain = plant.gain
    residence_time = plant.residence_time
    if plant.integrating:
        return ExactModels(None, None, IntegratingModel(gain=gain, dead_time=residence_time))
    _, p2 = plant.taylor_coefficients()
    t_a = apparent_time_constant(residence_time, p2)
    sopdt = sopdt_from_moments(gain, residence_time, 1.0 - t_a / residence_time)
    time_constant = step_time_constant(_step_area(plant, residence_time), 1.0, gain)
    return ExactModels(sopdt, fopdt_from_area(gain, residence_time, time_constant), None)
