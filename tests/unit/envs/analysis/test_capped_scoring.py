"""Scoring stops simulating once the cost is capped (envs.analysis.scoring, envs.analysis.performance.IAEBound).

The IAE is an integral of ``|e| >= 0``, so a run whose weighted IAE so far already exceeds the
budget ``FEASIBLE_CAP - w_experiment J_experiment`` costs exactly ``FEASIBLE_CAP``.  The checks:

* the cost and every figure but the IAE terms are those of the full simulation, bit for bit, on a
  grid of designs from fast to very sluggish (half of them capped), with experiment costs and
  weights that move the budget;
* a stopped run reports lower bounds (``lower_bound``/``iae_lower_bound``), never above the full
  IAE, and stops at a shorter horizon than the full run;
* a bound that is not reached changes nothing.
"""

from __future__ import annotations

import math

import pytest

from envs.systems.controllers import FPPI, MSP, PID, SeriesPID
from envs.analysis.performance import IAEBound, iae
from envs.systems.plants import Plant
from envs.analysis.scoring import FEASIBLE_CAP, CostWeights, score

PLANTS = {
    "fopdt": Plant.from_time_constants(1.0, [1.0], 0.5),
    "lag-chain": Plant.from_time_constants(-2.0, [0.5] * 4, 0.3),
    "integrating": Plant.from_time_constants(0.5, [0.4], 1.0, integrating=True),
}


def _designs(name: str) -> list:
    """From well tuned to very sluggish: the slow ones settle late and are capped."""
    if name == "fopdt":
        return [PID(kp, ti) for kp in (0.6, 0.1, 0.03, 0.01) for ti in (1.0, 3.0)] + [
            SeriesPID(0.05, 1.0, 0.3), FPPI(1.0, 1.0, 0.5, 0.5, 0.5), FPPI(1.0, 1.0, 0.5, 40.0, 40.0)
        ]
    if name == "lag-chain":
        return [PID(-kp, ti) for kp in (0.3, 0.05, 0.01) for ti in (2.0, 5.0)]
    return [MSP(0.5, 1.6, tr) for tr in (1.0, 3.0, 10.0, 50.0)] + [MSP(0.5, 1.4, 3.0, True), PID(0.2, 30.0), PID(0.02, 300.0)]


def _full_cost(plant, controller, experiment_time, weights):
    """The cost as computed before the early stop: the full IAE, then the cap."""
    full = iae(plant, controller)
    scale = plant.residence_time
    load_scale = abs(plant.gain) * scale * (scale if plant.integrating else 1.0)
    load_cost = weights.load * full.load / load_scale
    setpoint_cost = weights.setpoint * full.setpoint / scale
    experiment_cost = weights.experiment * experiment_time / scale
    return min(load_cost + setpoint_cost + experiment_cost, FEASIBLE_CAP), full


@pytest.mark.parametrize("experiment_time, weights", [
    (0.0, CostWeights()),
    (300.0, CostWeights()),
    (0.0, CostWeights(load=0.0, setpoint=2.0)),
    (5000.0, CostWeights(experiment=0.01)),  # the experiment alone exceeds the cap: budget < 0
], ids=["default", "experiment-cost", "setpoint-only", "budget-negative"])
@pytest.mark.parametrize("name", PLANTS)
def test_capped_cost_is_that_of_the_full_simulation(name, experiment_time, weights):
    plant = PLANTS[name]
    capped = 0
    for controller in _designs(name):
        result = score(plant, controller, experiment_time=experiment_time, weights=weights)
        if not result.feasible:
            continue
        expected, full = _full_cost(plant, controller, experiment_time, weights)
        assert result.cost == expected  # bit for bit
        if result.iae_lower_bound:
            capped += 1
            assert result.cost == FEASIBLE_CAP
            assert result.iae_load <= full.load * (1 + 1e-12) or math.isinf(full.load)
            assert result.iae_setpoint <= full.setpoint * (1 + 1e-12) or math.isinf(full.setpoint)
        else:
            assert (result.iae_load, result.iae_setpoint) == (full.load, full.setpoint)
        assert result.to_dict()["iae_lower_bound"] is result.iae_lower_bound
    if name == "fopdt" and experiment_time == 0.0 and weights == CostWeights():
        assert capped >= 3  # the grid does exercise the early stop


def test_stopped_run_reports_lower_bounds():
    plant, controller = PLANTS["fopdt"], PID(0.02, 1.0)
    full = iae(plant, controller)
    bound = IAEBound(1.0, 1.0, 5.0)
    stopped = iae(plant, controller, bound=bound)
    assert full.settled and not full.lower_bound
    assert stopped.lower_bound and not stopped.settled
    assert stopped.horizon < full.horizon and stopped.dt == full.dt
    assert stopped.load < full.load and stopped.setpoint <= full.setpoint
    assert bound.exceeded(stopped.load, stopped.setpoint)


@pytest.mark.parametrize("budget", [math.inf, 1e6])
def test_bound_not_reached_changes_nothing(budget):
    for name, plant in PLANTS.items():
        for controller in _designs(name)[:4]:
            assert iae(plant, controller, bound=IAEBound(1.0, 1.0, budget)) == iae(plant, controller)


def test_bound_test_keeps_a_margin_and_ignores_nan():
    bound = IAEBound(1.0, 0.0, 10.0)
    assert not bound.exceeded(10.0, 1.0)
    assert not bound.exceeded(10.0 * (1 + 1e-12), 0.0)  # inside the rounding margin
    assert bound.exceeded(10.0 * (1 + 1e-8), 0.0)
    assert not bound.exceeded(1.0, math.inf)  # 0 * inf = nan: never a reason to stop


def test_to_dict_is_asdict_without_margins():
    """``Score.to_dict`` skips ``asdict``'s deep copy of the margins; the figures are the same."""
    from dataclasses import asdict

    result = score(PLANTS["fopdt"], PID(0.02, 1.0))
    expected = {k: v for k, v in asdict(result).items() if k != "margins"}
    expected = {k: (None if isinstance(v, float) and not math.isfinite(v) else v) for k, v in expected.items()}
    assert result.to_dict() == expected and list(result.to_dict()) == list(expected)
    assert result.to_dict()["violations"] is not result.violations
