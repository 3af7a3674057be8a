"""The headroom study: its episodes are the plan mode's, and its oracle's value is cross-fitted."""

from __future__ import annotations

import copy

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401
from agents.studies.headroom import GRID, continuation_costs, first_experiment, summarize
from baselines.procedures import PlanRule
from envs.analysis.scoring import CostWeights
from envs.episode import Evidence
from envs.systems.plant_sets import plant_set
from envs.interface import tuning_env_of


@pytest.mark.parametrize("structure", ["PID", "FPPI", "MSP"])
@pytest.mark.parametrize("first, second", [(1.0, 1.0), (3.0, 0.1), (0.1, 3.0)])
def test_a_continuation_costs_what_the_plan_mode_episode_costs(structure: str, first: float, second: float) -> None:
    family = "integrating" if structure == "MSP" else "stable"
    tracking = tuning_env_of(gym.make(f"DeadTime/{structure}-v3", experiments="plan", noise_std=0.1, weights={"production": 1.0}))
    weights = [CostWeights(production=0.0), CostWeights(production=0.05)]
    for k, plant in enumerate(plant_set(family, "validation", 3)):
        tracking.reset(seed=k, options={"plant": plant})
        rng = copy.deepcopy(tracking.np_random)
        ours = continuation_costs(tracking, first_experiment(tracking, rng, first), rng, first, second, weights)
        for w, cost in zip(weights, ours):
            env = tuning_env_of(gym.make(f"DeadTime/{structure}-v3", experiments="plan", noise_std=0.1,
                                         weights={"production": w.production}))
            env.reset(seed=k, options={"plant": plant})
            rule = PlanRule(first, second)
            _, reward, done, _, _ = env.step(rule.predict(None)[0])
            if not done:
                _, reward, done, _, _ = env.step(rule.predict(None)[0])
            assert done and cost == -reward


def test_the_oracle_chooses_per_plant_and_is_scored_on_the_other_replicates() -> None:
    rng = np.random.default_rng(0)
    plants, n = 400, len(GRID)
    # plant k's best second amplitude is k % n, worth 1 less than the others; the best single plan is
    # then no better than the others, and the oracle gains 1 - (the noise's selection is cross-fitted away)
    truth = np.full((plants, n, n), 5.0)
    truth[np.arange(plants), :, np.arange(plants) % n] = 4.0
    costs = truth[..., None] + rng.normal(0.0, 0.2, (plants, n, n, 4))
    row = summarize(costs, test_plants=4000, comparisons=51)
    assert row["best_plan_cost"] == pytest.approx(4.75, abs=0.05)
    assert row["adaptive_cost"] == pytest.approx(4.0, abs=0.03)
    low, high = row["headroom_interval"]
    assert low < 0.75 < high
    assert sum(row["adaptive_second_choices"].values()) == 2 * plants


def test_pure_noise_gives_no_headroom_after_cross_fitting() -> None:
    rng = np.random.default_rng(1)
    costs = 5.0 + rng.normal(0.0, 1.0, (2000, len(GRID), len(GRID), 4))
    row = summarize(costs, test_plants=4000, comparisons=51)
    low, high = row["headroom_interval"]
    assert low < 0.0 < high + 0.1  # choosing among noise gains nothing on held-out replicates (a best-of-16 plan is flattered a little)


def test_one_replicate_is_refused() -> None:
    with pytest.raises(ValueError, match="at least 2 replicates"):
        summarize(np.zeros((10, len(GRID), len(GRID), 1)), 4000, 51)


@pytest.mark.parametrize("structure", ["PID", "MSP"])
def test_the_oracle_design_is_no_worse_than_the_base_rule_on_the_same_records(structure: str) -> None:
    family = "integrating" if structure == "MSP" else "stable"
    env = tuning_env_of(gym.make(f"DeadTime/{structure}-v3", experiments="plan", noise_std=0.1, weights={"production": 1.0}))
    weights = [CostWeights(production=0.0), CostWeights(production=0.05)]
    for k, plant in enumerate(plant_set(family, "validation", 3)):
        env.reset(seed=k, options={"plant": plant})
        start = env.evidence
        costs = {}
        for design in ("base", "oracle"):
            env.evidence = start
            rng = np.random.default_rng(k)
            costs[design] = continuation_costs(env, first_experiment(env, rng, 1.0), rng, 1.0, 1.0, weights, design)
        # the base rule's parameter lies in the oracle's range; the search stops within its relative
        # tolerance of the optimum (baselines.oracle.REFINEMENT_TOLERANCE), a cost change far below 0.1%
        assert all(o <= b * (1 + 1e-3) for o, b in zip(costs["oracle"], costs["base"]))
        assert costs["oracle"][1] >= costs["oracle"][0]  # production only adds its price


class _Policy:
    """A design read from the observation, as a learned rule reads it."""

    def predict(self, observation, deterministic=True):
        return np.array([0.4 * np.tanh(float(np.sum(observation)))]), None


@pytest.mark.parametrize("structure", ["PID", "MSP"])
def test_a_policy_designs_from_the_observation_the_fixed_plan_environment_shows(structure: str) -> None:
    from gymnasium.utils.seeding import np_random

    from agents.studies.headroom import plant_costs, policy_design

    family = "integrating" if structure == "MSP" else "stable"
    kwargs = {"noise_std": 0.1, "weights": {"production": 0.05}, "plan": [3.0, 0.3]}
    ours = tuning_env_of(gym.make(f"DeadTime/{structure}-v3", **kwargs))
    for k, plant in enumerate(plant_set(family, "validation", 3)):
        env = tuning_env_of(gym.make(f"DeadTime/{structure}-v3", **kwargs))
        observation, _ = env.reset(seed=k, options={"plant": plant})
        _, reward, _, _, _ = env.step(_Policy().predict(observation)[0])
        rng = np_random(k)[0]
        ours.reset(seed=k, options={"plant": plant})
        ours.evidence = Evidence.empty(ours.integrating, ours.options)
        cost = continuation_costs(ours, first_experiment(ours, rng, 3.0), rng, 3.0, 0.3,
                                  [CostWeights(production=0.05)], policy_design(_Policy()))
        assert cost == [-reward]
    # and through plant_costs, one design per second amplitude, each second's continuation its own
    costs = plant_costs(ours, plant, 7, 2, [CostWeights(production=0.05)], firsts=(3.0,),
                        designs={0.3: policy_design(_Policy()), 3.0: "base"})
    assert costs.shape == (1, 2, 2, 1) and np.isfinite(costs).all()


def test_the_learners_share_of_the_headroom_and_their_violating_plants() -> None:
    from agents.studies.learned_headroom import _learners

    best_plan = np.full(50, 4.0)
    rows = np.full((3, 50), 3.9)
    feasible = np.ones((3, 50), dtype=bool)
    feasible[1, 7] = feasible[2, 7] = feasible[0, 9] = False  # two plants violate in some seed
    found = _learners(rows, feasible, best_plan, headroom=0.2)
    assert found["minus_best_plan"][0] == pytest.approx(-0.1) and found["share_of_headroom"] == pytest.approx(0.5)
    assert found["violations"]["violating_plants"] == 2 and found["seeds"] == 3
    assert _learners(rows, feasible, best_plan, headroom=0.0)["share_of_headroom"] is None


def test_the_learned_continuation_is_scored_by_the_expected_cost_of_its_choice() -> None:
    from agents.studies.continuation import learned_continuation

    env = tuning_env_of(gym.make("DeadTime/FPPI-v3", noise_std=0.1, plan=[1.0, 1.0]))
    designs = {0.1: "base", 3.0: "base"}
    from agents.protocol.streams import plant_stream

    training, validation = plant_stream("stable", 99, 40), list(plant_set("stable", "validation", 12))
    expected = np.random.default_rng(0).uniform(1.0, 5.0, (12, 2))
    found = learned_continuation(env, designs, [CostWeights(production=0.05)], 1.0, training, validation, 5, expected)
    assert found["training_plants"] == 40 and sum(found["choices"].values()) == 12
    chosen = found["per_plant"]
    assert all(value in row for value, row in zip(chosen, expected))


def test_the_threshold_keeps_the_default_unless_the_predicted_gain_exceeds_it() -> None:
    from agents.studies.continuation import _cross_fitted_threshold, _threshold_choice

    predicted = np.array([[1.0, 1.05], [1.0, 2.0], [3.0, 1.0]])
    assert list(_threshold_choice(predicted, 0, 0.1)) == [0, 0, 1] and list(_threshold_choice(predicted, 0, np.inf)) == [0, 0, 0]
    # predictions that are right where they deviate: the cross-fitted threshold lets them deviate
    rng = np.random.default_rng(3)
    expected = rng.uniform(1.0, 2.0, (200, 3))
    choice, thresholds = _cross_fitted_threshold(expected.copy(), expected, 0)
    assert np.array_equal(choice, expected.argmin(axis=1)) and thresholds == [0.0, 0.0]
    # predictions that are noise: deviating costs, and the threshold stops it
    choice, thresholds = _cross_fitted_threshold(rng.uniform(0.0, 1.0, (200, 3)), expected + np.array([0.0, 1.0, 1.0]), 0)
    assert (choice == 0).all() and min(thresholds) >= 1.0  # the least threshold that never deviates (ties: the first)
