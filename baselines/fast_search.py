"""The oracle's fast search: the feasibility boundary bracketed and refined, the cost compared once.

:func:`baselines.oracle.search_parameter` (the reference) scores a 30-point log grid, refines the
best grid point by bounded Brent and probes either side: about 42 full scorings.  Most optima sit on
the boundary of the feasible set (the ``Ms`` or delay-margin cliff), and a scoring's two parts cost
differently: the robustness analysis decides feasibility, the IAE simulation only ranks feasible
designs.  :func:`fast_search` uses that, in ``log`` of the relative parameter ``x``:

1. **Bracket**: the robustness analysis alone on a coarse grid of :data:`BRACKET_POINTS` points, in
   one compiled call (:func:`envs.analysis.feasibility.feasibility_margins`: only the figures the
   constraints read, equal to the full analysis' bit for bit).  A design whose ``|S|`` exceeds the
   ``Ms`` bound on the analysis' unrefined frequency grid is infeasible whatever the rest of the
   analysis finds, which is then skipped (*screening*: the aggressive designs, often unstable, whose
   refined grids are the longest).  The signed margin ``m(x)`` (the least relative margin of the
   enabled constraints, :func:`margin_of`; ``>= 0`` exactly when the design is feasible) is
   continuous where the loop stays stable.
2. **Boundary**: where the least conservative feasible grid point has an infeasible aggressive
   neighbour, the root of ``m`` between them by Brent's root finder (``scipy.optimize.brentq``) to
   :data:`BOUNDARY_TOLERANCE` in ``x``, taken on its feasible side: the *feasibility boundary*, the
   least conservative feasible parameter (the range's aggressive end when that is feasible).  Where
   ``m`` jumps (a loss of stability) the root finder bisects.
3. **Cost**: the full cost at the boundary and at the feasible grid points from there on, each IAE
   simulation stopped as soon as its cost certainly exceeds the best so far
   (:class:`envs.analysis.performance.IAEBound`): a worse design costs only part of a simulation.
   The scan ends after :data:`PATIENCE` designs costlier than the best (a capped cost does not count).
4. **Refinement**: if the best design is the boundary and the design
   :data:`~baselines.oracle.BINDING_PROBE` inside it costs more, the optimum is on the boundary, which
   is refined to :data:`OPTIMUM_TOLERANCE` (the cost can be steep there).  Otherwise Brent's
   minimization from the bracket of the best design and its neighbours (an infeasible neighbour
   replaced by the boundary's root), or bounded Brent on them where they bracket no minimum, to the
   reference's tolerance.  The best design of every cost computed is the optimum.
5. The two binding probes of the reference decide the binding constraint (their feasibility only).

Where no grid point is feasible the reference search runs instead (its least-violating parameter).
The figures at the parameter returned are those of :func:`envs.analysis.scoring.score` bit for bit
(the same simulation, kept from the search, and the full analysis of that design).  The compiled
feasibility figures and the screening change no decision of the search: its results, the count of
designs analysed included, are those of the full analysis of every design.  Agreement with the reference and speed: docs/performance.md,
"Labels"; ``tests/unit/baselines/test_fast_search.py``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.optimize

from envs.analysis.feasibility import FeasibilityMargins, feasibility_margins
from envs.analysis.loop_analysis import plant_margins
from envs.analysis.performance import IAEBound, iae
from envs.analysis.scoring import (
    FEASIBLE_CAP,
    Constraints,
    CostWeights,
    Score,
    _relative_delay_margin,
    constraint_violations,
    score,
    violation_cost,
)
from envs.systems.plants import Plant

__all__ = ["BOUNDARY_TOLERANCE", "BRACKET_POINTS", "REFERENCE_ERROR", "FastSearch", "Scorer", "fast_search", "margin_of"]

BRACKET_POINTS = 8
"""Points of the coarse grid of the bracket (a ratio of about 2.7 between neighbours for ``mu``, 3.7 for ``T_r/T_n``)."""
RELATIVE_ROOT_TOLERANCE = 4 * float(np.finfo(float).eps)  # brentq's least
PATIENCE = 2
"""Feasible grid points costlier than the best so far (below the cap) after which the scan stops (the
cost rises towards the conservative end of the range)."""
BOUNDARY_TOLERANCE = 1e-3
"""Absolute tolerance in ``log`` parameter of the feasibility boundary (the reference's refinement
tolerance, :data:`baselines.oracle.REFINEMENT_TOLERANCE`)."""
OPTIMUM_TOLERANCE = 1e-4
"""The same where the boundary is the best design found: the cost can be steep there."""
REFERENCE_ERROR = 1.2e-3
"""The cost error of the reference search, measured against a dense search (the reference on a
300-point grid) on 100 training plants of each structure: at most 1.13e-3, rounded up.  The fast
search's cost is at most the reference's plus this (docs/performance.md, "Labels")."""
SCREEN_MARGIN = 1e-9
"""A bracket design is screened out where its ``|S|`` exceeds the ``Ms`` bound by this much relative
(far above rounding, so that ``Ms/bound - 1 > 0`` holds for its ``Ms``)."""
UNSTABLE_MARGIN = -1.0
"""The signed margin of an unstable loop (negative: only its sign enters the root finding)."""


def margin_of(margins: FeasibilityMargins, relative_delay_margin: float, constraints: Constraints) -> float:
    """The least relative margin of the enabled constraints (``>= 0`` exactly when feasible;
    :data:`UNSTABLE_MARGIN` for an unstable loop); ``inf`` when no constraint is enabled."""
    if not margins.stable:
        return UNSTABLE_MARGIN
    violations = constraint_violations(margins, relative_delay_margin, constraints)
    if violations:
        return -max(violations.values())
    c, found = constraints, [math.inf]
    if c.max_sensitivity is not None:
        found.append(1 - margins.ms / c.max_sensitivity)
    if c.min_relative_delay_margin is not None:
        found.append(relative_delay_margin / c.min_relative_delay_margin - 1)
    if c.min_gain_margin is not None:
        found.append(margins.gain_margin / c.min_gain_margin - 1)
    if c.min_phase_margin_deg is not None:
        found.append(margins.phase_margin_deg / c.min_phase_margin_deg - 1)
    return max(min(found), 0.0)


@dataclass
class Scorer:
    """Scores relative parameters of one plant and model: the robustness figures the constraints need
    (:meth:`margin`; :func:`envs.analysis.feasibility.feasibility_margins`, those of the full analysis
    bit for bit, many designs in one call by :meth:`analyse`), or the cost with its IAE stopped above a
    budget (:meth:`cost`).  The full analysis runs only for the figures of :meth:`score`."""

    plant: Plant
    controller_of: Callable[[float], object]
    experiment_time: float
    experiment_deviation: float
    constraints: Constraints
    weights: CostWeights

    def __post_init__(self) -> None:
        self.analysed: dict[float, tuple[object, FeasibilityMargins, float]] = {}
        self.screened: set[float] = set()  # designs found infeasible by screening, not analysed
        self.gain_margin = self.constraints.min_gain_margin is not None
        self.costs: dict[float, float] = {}
        self.performances: dict[float, tuple] = {}
        scale = self.plant.residence_time
        self.experiment_cost = self.weights.experiment * self.experiment_time / scale
        if self.weights.production != 0.0:
            self.experiment_cost += self.weights.production * self.experiment_deviation / scale
        self.load_scale = abs(self.plant.gain) * scale * (scale if self.plant.integrating else 1.0)
        self.iae_weights = (self.weights.load / self.load_scale, self.weights.setpoint / scale)

    def analyse(self, xs, screen: bool = False) -> None:
        """The robustness figures at every ``log`` parameter of ``xs`` not analysed yet, in one call;
        with ``screen``, a design whose ``Ms`` certainly exceeds the bound is only marked infeasible
        (:meth:`feasible` knows it; :func:`~envs.analysis.feasibility.feasibility_margins`)."""
        new = [float(x) for x in dict.fromkeys(xs) if float(x) not in self.analysed and not (screen and float(x) in self.screened)]
        if not new:
            return
        bound = self.constraints.max_sensitivity
        threshold = bound * (1 + SCREEN_MARGIN) if screen and bound is not None else math.inf
        controllers = [self.controller_of(math.exp(x)) for x in new]
        for x, controller, margins in zip(new, controllers, feasibility_margins(self.plant, controllers, self.gain_margin, threshold)):
            if margins is None:
                self.screened.add(x)
                continue
            relative_dm = _relative_delay_margin(margins.delay_margin, self.plant, self.constraints.zero_delay)
            self.analysed[x] = (controller, margins, relative_dm)

    def _analysis(self, x: float) -> tuple[object, FeasibilityMargins, float]:
        if x not in self.analysed:
            self.analyse([x])
        return self.analysed[x]

    def margin(self, x: float) -> float:
        """:func:`margin_of` at ``log`` parameter ``x``."""
        _, margins, relative_dm = self._analysis(float(x))
        return margin_of(margins, relative_dm, self.constraints)

    def feasible(self, x: float) -> bool:
        """Whether the design at ``x`` satisfies every constraint."""
        return float(x) not in self.screened and self.margin(x) >= 0.0

    def violations(self, x: float) -> dict[str, float]:
        """The violations at ``x`` (:func:`~envs.analysis.scoring.constraint_violations`)."""
        _, margins, relative_dm = self._analysis(float(x))
        return constraint_violations(margins, relative_dm, self.constraints)

    def cost(self, x: float, budget: float = math.inf) -> float:
        """The cost at ``x`` (that of :func:`~envs.analysis.scoring.score`), or a number above ``budget``
        once that is certain (the IAE run stops early; an infeasible design is not simulated)."""
        x = float(x)
        if x in self.costs:
            return self.costs[x]
        controller, margins, relative_dm = self._analysis(x)
        violations = constraint_violations(margins, relative_dm, self.constraints)
        if violations:
            self.costs[x] = violation_cost(violations, margins.stable, self.constraints.violation_cost)
            return self.costs[x]
        cap = FEASIBLE_CAP - self.experiment_cost
        limit = min(cap, budget - self.experiment_cost)
        performance = iae(self.plant, controller, bound=IAEBound(*self.iae_weights, limit))
        load_cost = self.weights.load * performance.load / self.load_scale
        setpoint_cost = self.weights.setpoint * performance.setpoint / self.plant.residence_time
        cost = min(load_cost + setpoint_cost + self.experiment_cost, FEASIBLE_CAP)  # as score() sums it
        if performance.lower_bound and limit < cap:
            return max(cost, budget)  # a lower bound above the budget: not kept (another budget may differ)
        self.costs[x] = cost
        self.performances[x] = (performance, load_cost, setpoint_cost)
        return cost

    def score(self, x: float) -> Score:
        """Every figure at ``x``: those of :func:`~envs.analysis.scoring.score`, from the analysis and the
        simulation already made where the cost at ``x`` is known (then not run again)."""
        x = float(x)
        controller, _, relative_dm = self._analysis(x)
        if x not in self.performances:
            return score(self.plant, controller, experiment_time=self.experiment_time,
                         experiment_deviation=self.experiment_deviation, constraints=self.constraints, weights=self.weights)
        performance, load_cost, setpoint_cost = self.performances[x]
        margins = plant_margins(self.plant, controller)  # every figure: Score holds them all
        return Score(self.costs[x], True, {}, True, margins.ms, margins.gain_margin, margins.phase_margin_deg,
                     margins.delay_margin, relative_dm, performance.load, performance.setpoint, load_cost, setpoint_cost,
                     self.experiment_cost, margins, performance.lower_bound)

    @property
    def evaluations(self) -> int:
        """Designs analysed (each analysis is one design scored, in part or whole; a screened one too)."""
        return len(self.screened | set(self.analysed))


@dataclass(frozen=True)
class FastSearch:
    """What :func:`fast_search` found (``log`` parameters); ``best is None`` where no grid point was
    feasible (the caller then runs the reference search)."""

    best: float | None
    boundary: float | None


def _boundary(scorer: Scorer, low: float, high: float, tolerance: float = BOUNDARY_TOLERANCE) -> float:
    """The root of the signed margin between an infeasible ``low`` and a feasible ``high``, on its
    feasible side (bisection where ``m`` jumps, e.g. at a loss of stability)."""
    root = scipy.optimize.brentq(scorer.margin, low, high, xtol=tolerance, rtol=RELATIVE_ROOT_TOLERANCE)
    step = tolerance
    while not scorer.feasible(root) and root < high:
        root = min(root + step, high)
        step *= 2
    return root


def _sharpened(scorer: Scorer, boundary: float, low: float) -> float:
    """The boundary refined to :data:`OPTIMUM_TOLERANCE` (the optimum is on it), from an infeasible
    point :data:`BOUNDARY_TOLERANCE` below it (or ``low``); the boundary itself where that is feasible."""
    below = max(boundary - 2 * BOUNDARY_TOLERANCE, low)
    if scorer.feasible(below):
        return boundary
    return _boundary(scorer, below, boundary, OPTIMUM_TOLERANCE)


def _refine(scorer: Scorer, left: float, middle: float, right: float, tolerance: float, evaluations: int) -> None:
    """Brent's minimization from the bracket ``left < middle < right`` (the middle the cheapest), or
    bounded Brent on ``[left, right]`` where the three do not bracket a minimum; its costs are kept
    in ``scorer``.  Brent's tolerance is relative, so it runs on ``x`` shifted to start at 1, with a
    tolerance that is at most ``tolerance`` in ``x`` across the bracket."""
    costs = [scorer.cost(x) for x in (left, middle, right)]
    if left < middle < right and costs[1] < min(costs[0], costs[2]):
        shift = 1.0 - left
        known = {x + shift: x for x in (left, middle, right)}  # the bracket's points, scored already
        scipy.optimize.minimize_scalar(lambda y: scorer.cost(known.get(y, y - shift)), bracket=tuple(known),
                                       method="brent", options={"xtol": tolerance / (right + shift),
                                                                "maxiter": evaluations})
    else:
        scipy.optimize.minimize_scalar(scorer.cost, bounds=(left, right), method="bounded",
                                       options={"xatol": tolerance, "maxiter": evaluations})


def fast_search(scorer: Scorer, bounds: tuple[float, float], probe: float, tolerance: float,
                evaluations: int) -> FastSearch:
    """Steps 1-4 of the module docstring on ``bounds`` (``log`` parameter); ``probe``, ``tolerance`` and
    ``evaluations`` are the reference's binding probe and Brent's tolerance and evaluation limit."""
    points = np.linspace(bounds[0], bounds[1], BRACKET_POINTS)
    scorer.analyse(points, screen=True)
    feasible = [scorer.feasible(x) for x in points]
    if not any(feasible):
        return FastSearch(None, None)
    first = feasible.index(True)
    scorer.analyse(points[max(first - 1, 0) : first])  # the root finder's infeasible end needs its margin
    boundary = float(points[0]) if first == 0 else _boundary(scorer, float(points[first - 1]), float(points[first]))
    candidates = [boundary] + [float(x) for x, ok in zip(points, feasible) if ok and x > boundary]
    best, best_cost = boundary, scorer.cost(boundary)
    worse = 0
    for x in candidates[1:]:
        cost = scorer.cost(x, best_cost)
        if cost < best_cost:
            best, best_cost, worse = x, cost, 0
        elif best_cost < FEASIBLE_CAP:  # a capped cost is flat: it says nothing of the way to a better one
            worse += 1
            if worse > PATIENCE:
                break
    # the feasible interval around the best candidate: its grid neighbours, the left one moved to the
    # boundary's root where it is infeasible
    i = int(np.searchsorted(points, best))  # points[i] >= best
    on_grid = points[i] == best
    left = boundary if best == boundary else float(points[i - 1])
    right = float(points[min(i + 1, len(points) - 1)]) if on_grid else float(points[i])
    low = float(points[max(i - 1, 0)])  # infeasible where left is a root
    if not scorer.feasible(left):
        left = _boundary(scorer, left, best)
        scorer.cost(left)
    inside = best + probe if best == left else best
    if best == left and not (inside < right and scorer.cost(inside, best_cost) < best_cost):
        sharp = _sharpened(scorer, left, low) if left > bounds[0] else left  # the optimum is on the boundary
        scorer.cost(sharp)
        boundary = sharp if left == boundary else boundary
    else:
        _refine(scorer, left, inside, right, tolerance, evaluations)
    best = min(scorer.costs, key=lambda x: (scorer.costs[x], x))
    return FastSearch(best, boundary)
