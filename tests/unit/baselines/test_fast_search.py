"""The oracle's fast search (baselines/fast_search.py) against its reference search and a dense grid.

Agreement: on training plants of each structure's v3 environment (fixed mode, identified as an
episode identifies them), the fast search's optimum costs at most what the reference's does plus
:data:`COST_TOLERANCE`, the reference's own error: against a dense search (the reference search on a
300-point grid), on 100 plants of each structure, the reference's cost exceeded the dense one by at
most 1.13e-3 (PID; 1.8e-4 to 4.7e-4 for the others), the fast search's by at most 6.2e-5
(docs/performance.md, "Labels").  Where the fast search is cheaper by more than the tolerance, the
two found the same optimum, the fast search more precisely (a steep cost at the boundary): their
parameters are within twice the reference's refinement tolerance.  Feasibility agrees on every
plant, the binding constraint on nearly every one, and the optimum's figures are those of
:func:`envs.analysis.scoring.score` bit for bit.

Boundary: the fast search's feasibility boundary against an independent bisection: feasibility by
:func:`envs.analysis.scoring.score` on a dense log grid, then plain bisection between the last
infeasible and the first feasible point.

The default run takes :data:`FAST_PLANTS` plants per structure; the slow one :data:`SLOW_PLANTS`.
"""

from __future__ import annotations

import math

import gymnasium
import numpy as np
import pytest

import envs  # noqa: F401  (registers the ids)
from baselines.fast_search import BOUNDARY_TOLERANCE, REFERENCE_ERROR
from baselines.oracle import PARAMETER_RANGES, REFINEMENT_TOLERANCE, design, oracle, relative_scale
from envs.analysis.scoring import score
from envs.interface import episode_of
from envs.structures import STRUCTURES as MODELS

STRUCTURES = ("PID", "FPPI", "MSP", "PI")
FAST_PLANTS = 40
SLOW_PLANTS = 300
COST_TOLERANCE = REFERENCE_ERROR
"""The reference search's largest measured error against the dense search, 1.13e-3, rounded up (module docstring)."""
BINDING_SHARE = 0.97
"""The least share of plants whose binding constraint the two searches name alike (measured: 0.99-1.0)."""
SEED = 20_000_000


def _episodes(structure: str, plants: int):
    """``(plant, identification, structure, constraints, weights)`` of ``plants`` fixed-mode v3 episodes."""
    env = gymnasium.make(f"DeadTime/{structure}-v3", experiments="fixed")
    episode = episode_of(env)
    for k in range(plants):
        env.reset(seed=SEED + k)
        yield episode.plant, episode.identification, episode.structure, episode.constraints, episode.weights
    env.close()


def _compare(structure: str, plants: int) -> None:
    same_binding = 0
    for plant, identification, name, constraints, weights in _episodes(structure, plants):
        kwargs = {"constraints": constraints, "weights": weights}
        reference = oracle(plant, identification, name, **kwargs)
        fast = oracle(plant, identification, name, search="fast", **kwargs)
        assert fast.feasible == reference.feasible
        assert fast.cost <= reference.cost + COST_TOLERANCE, (fast.cost, reference.cost)
        if fast.cost < reference.cost - COST_TOLERANCE:  # the same optimum, found more precisely (a steep cliff)
            assert abs(math.log(fast.relative_parameter / reference.relative_parameter)) <= 2 * REFINEMENT_TOLERANCE
        rescored = score(plant, design(name, _model(identification, name), fast.parameter),
                         experiment_time=identification.experiment_time,
                         experiment_deviation=identification.experiment_deviation, **kwargs)
        assert fast.score == rescored  # the figures of score() itself, bit for bit
        if fast.feasible:
            assert fast.feasibility_boundary <= fast.relative_parameter * (1 + 1e-12)
        same_binding += fast.binding == reference.binding
    assert same_binding >= BINDING_SHARE * plants


def _model(identification, name: str):
    return MODELS[name].model_of(identification)


@pytest.mark.parametrize("structure", STRUCTURES)
def test_fast_search_agrees_with_reference(structure: str) -> None:
    _compare(structure, FAST_PLANTS)


@pytest.mark.slow
@pytest.mark.parametrize("structure", STRUCTURES)
def test_fast_search_agrees_with_reference_on_many_plants(structure: str) -> None:
    _compare(structure, SLOW_PLANTS)


def _dense_boundary(plant, identification, name, constraints, weights, points: int = 400) -> float | None:
    """The least conservative feasible log parameter by a dense grid, then bisection (``score`` only)."""
    model = _model(identification, name)
    unit = relative_scale(name, model)

    def feasible(x: float) -> bool:
        return score(plant, design(name, model, math.exp(x) * unit), constraints=constraints, weights=weights).feasible

    low, high = (math.log(v) for v in PARAMETER_RANGES[name])
    grid = np.linspace(low, high, points)
    first = next((i for i, x in enumerate(grid) if feasible(float(x))), None)
    if first is None or first == 0:
        return None if first is None else low
    bad, good = float(grid[first - 1]), float(grid[first])
    while good - bad > BOUNDARY_TOLERANCE / 10:
        middle = 0.5 * (bad + good)
        bad, good = (bad, middle) if feasible(middle) else (middle, good)
    return good


@pytest.mark.parametrize("structure", STRUCTURES)
def test_boundary_agrees_with_dense_bisection(structure: str) -> None:
    for plant, identification, name, constraints, weights in _episodes(structure, 6):
        fast = oracle(plant, identification, name, search="fast", constraints=constraints, weights=weights)
        dense = _dense_boundary(plant, identification, name, constraints, weights)
        if dense is None:
            assert fast.feasibility_boundary is None
            continue
        # the root finder's tolerance, plus at most as much again for its step to the feasible side
        assert abs(math.log(fast.feasibility_boundary) - dense) <= 2 * BOUNDARY_TOLERANCE, (fast.feasibility_boundary, dense)


def test_reference_search_is_the_default_and_has_no_boundary() -> None:
    plant, identification, name, constraints, weights = next(_episodes("PID", 1))
    assert oracle(plant, identification, name).feasibility_boundary is None


def test_unknown_search_is_refused() -> None:
    plant, identification, name, _, _ = next(_episodes("PID", 1))
    with pytest.raises(ValueError, match="search must be one of reference, fast"):
        oracle(plant, identification, name, search="grid")


def test_no_feasible_parameter_falls_back_to_the_reference_search() -> None:
    """A constraint that no design meets: the fast search runs the reference search (its least-violating
    parameter), and there is no boundary."""
    from envs.analysis.scoring import Constraints

    plant, identification, name, _, weights = next(_episodes("PID", 1))
    impossible = Constraints(max_sensitivity=1.0001, violation_cost="bounded")
    fast = oracle(plant, identification, name, search="fast", constraints=impossible, weights=weights)
    reference = oracle(plant, identification, name, constraints=impossible, weights=weights)
    assert not fast.feasible and fast.feasibility_boundary is None
    assert (fast.relative_parameter, fast.cost) == (reference.relative_parameter, reference.cost)
    assert fast.evaluations > reference.evaluations
