"""The v3 environments: a bounded, ordered violation cost, an observation made of the records only,
and no action that raises.

* Cost order: over random designs on random plants, every feasible cost < every stable violating
  cost <= every unstable cost, all bounded by ``FEASIBLE_CAP + 1 + VIOLATION_BAND``.
* Records only: with the experiments' noise made independent of the configured ``noise_std`` (a
  patched noise source), environments configured with different ``noise_std`` see the same records
  and must give the same observations and rewards; v2, which reads the configured level, does not.
* The noise estimate against the true level over 1000 closed-loop records.
* A commit that identifies nothing is a failed experiment, never an exception.
"""

from __future__ import annotations

import math

import gymnasium as gym
import numpy as np
import pytest

import envs  # noqa: F401
from envs.analysis.scoring import FEASIBLE_CAP, VIOLATION_BAND, Constraints, score, violation_cost
from envs.structures import PARAMETER_RANGES, design, relative_scale
from envs.identification import closed_loop_experiment, open_loop_pulse, open_loop_ramp, open_loop_step, prbs_experiment, relay
from envs.identification.closed_loop_experiment import closed_loop_step
from envs.identification.procedure import identify
from envs.identification.steady_state import noise_level
from envs.systems.families import sample_plant
from envs.tuning_env import AMPLITUDE_RANGE, NO_DESIGN_COST
from envs.interface import episode_of, tuning_env_of

TOP = FEASIBLE_CAP + 1 + VIOLATION_BAND
STRUCTURES = ("PID", "FPPI", "MSP")


# ----------------------------------------------------------------------------- the violation cost
def test_violation_cost_is_bounded_monotone_and_above_every_feasible_cost():
    grades = np.concatenate([[1e-12], np.logspace(-6, 6, 200), [1e300]])
    costs = [violation_cost({"max_sensitivity": g}, True, "bounded") for g in grades]
    assert all(FEASIBLE_CAP + 1 < c < TOP for c in costs[:-1])
    assert all(b > a for a, b in zip(costs[:-2], costs[1:-1]))  # strictly monotone where resolvable
    assert violation_cost({"stability": 5.0}, False, "bounded") == TOP
    assert violation_cost({"max_sensitivity": 1.0}, True, "bounded") == pytest.approx(FEASIBLE_CAP + 1 + VIOLATION_BAND / 2)
    assert violation_cost({"a": 2.0, "b": 0.5}, True, "graded") == FEASIBLE_CAP + 1 + 2.5  # the v0-v2 map


def _design_costs(structure: str, family: str, plants: int, seed: int) -> dict[str, list[float]]:
    """Costs of designs across the whole parameter range on plants identified without noise."""
    rng = np.random.default_rng(seed)
    found: dict[str, list[float]] = {"feasible": [], "violating": [], "unstable": []}
    constraints = Constraints(violation_cost="bounded")
    low, high = PARAMETER_RANGES[structure]
    for _ in range(plants):
        plant = sample_plant(family, rng)
        identification = identify(plant, rng, 0.0)
        model = {"pid": identification.sopdt, "fppi": identification.fopdt, "msp": identification.integrating_model}[structure]
        for relative in np.geomspace(low, high, 9):
            result = score(plant, design(structure, model, relative * relative_scale(structure, model)), constraints=constraints)
            kind = "feasible" if result.feasible else ("violating" if result.stable else "unstable")
            found[kind].append(result.cost)
    return found


@pytest.mark.parametrize("structure, family", [("pid", "stable"), ("fppi", "stable"), ("msp", "integrating")])
def test_cost_order_holds_over_random_designs(structure, family):
    found = _design_costs(structure, family, plants=12, seed=3)
    assert all(found.values()), {k: len(v) for k, v in found.items()}  # every kind is drawn
    assert max(found["feasible"]) <= FEASIBLE_CAP < min(found["violating"])
    assert max(found["violating"]) < TOP
    assert all(c == TOP for c in found["unstable"])
    assert max(max(v) for v in found.values() if v) <= TOP


# ----------------------------------------------------------------------------- records only
@pytest.fixture
def fixed_noise(monkeypatch):
    """Every experiment's noise at level 0.05 whatever ``noise_std`` it is given (the same records)."""
    for module in (closed_loop_experiment, open_loop_step, open_loop_ramp, open_loop_pulse, prbs_experiment, relay):
        original = module.measurement_noise

        def patched(rng, noise_std, *args, _original=original, **kwargs):
            return _original(rng, 0.05, *args, **kwargs)

        monkeypatch.setattr(module, "measurement_noise", patched)


def _amplitude_action(amplitude: float) -> float:
    low, high = (math.log10(v) for v in AMPLITUDE_RANGE)
    return 2.0 * (math.log10(amplitude) - low) / (high - low) - 1.0


def _episodes(env_id: str, mode: str, noise_std: float, seeds: int = 4):
    """Observations and rewards of episodes that run every experiment type (the relay included)."""
    env = gym.make(env_id, experiments=mode, noise_std=noise_std)
    played = []
    for seed in range(seeds):
        observation, _ = env.reset(seed=seed)
        seen, done, step = [observation], False, 0
        while not done:
            action = np.full(env.action_space.shape, -1.0, dtype=np.float32)
            if mode == "agent":
                choices = len(tuning_env_of(env).experiment_names) + 1
                action[1 + (step % (choices - 1)) if step < choices - 1 else 0] = 1.0
                action[-2] = _amplitude_action(0.5)
            action[-1] = 0.1
            observation, reward, done, _, _ = env.step(action)
            seen.append(observation)
            step += 1
        played.append((np.array(seen), reward))
    return played


@pytest.mark.parametrize("structure", STRUCTURES)
@pytest.mark.parametrize("mode", ["fixed", "agent"])
def test_v3_observation_does_not_read_the_configured_noise(fixed_noise, structure, mode):
    quiet, loud = (_episodes(f"DeadTime/{structure}-v3", mode, noise) for noise in (0.01, 0.2))
    for (a, ra), (b, rb) in zip(quiet, loud):
        np.testing.assert_array_equal(a, b)
        assert ra == rb


def test_the_patched_noise_tells_v2_apart(fixed_noise):
    """The check above has teeth: v2 reads the configured noise level (its noise-ratio feature)."""
    quiet, loud = (_episodes("DeadTime/PID-v2", "fixed", noise, seeds=1) for noise in (0.01, 0.2))
    assert not np.array_equal(quiet[0][0], loud[0][0])


def test_noise_estimate_against_the_true_level_over_1000_records():
    """Bias and spread of :func:`noise_level` on closed-loop step records (the v3 feature's estimate).

    Measured: the ratio estimate/true has mean 1.004 and standard deviation 0.045 over 1000 records
    at 1-20% noise (the median absolute deviation estimator's spread at the ~1300-2700 samples of a
    record, and a small upward bias from the kinks of the response).  The bounds allow three times
    the spread's standard error on the mean, and twice the spread.
    """
    rng = np.random.default_rng(7)
    ratios = []
    for k in range(1000):
        plant = sample_plant("stable", rng)
        noise_std = (0.01, 0.05, 0.1, 0.2)[k % 4]
        record = closed_loop_step(plant, rng, amplitude=1.0, noise_std=noise_std)
        ratios.append(noise_level(record.output) / noise_std)
    ratios = np.array(ratios)
    bias, spread = ratios.mean() - 1.0, ratios.std()
    assert spread < 0.09, spread
    assert abs(bias) < 0.02 + 3 * spread / math.sqrt(ratios.size), bias


# ----------------------------------------------------------------------------- no action raises
@pytest.mark.parametrize("amplitude", [0.1, 0.3])
def test_a_commit_that_identifies_nothing_is_a_failed_experiment(amplitude):
    """MSP at 10% noise committing at once at a small amplitude: v2 raises on some plants, v3 never."""
    env = gym.make("DeadTime/MSP-v3", experiments="agent", noise_std=0.1)
    action = np.full(env.action_space.shape, -1.0, dtype=np.float32)
    action[0], action[-2] = 1.0, _amplitude_action(amplitude)
    failed = ended_without_design = 0
    for seed in range(60):
        env.reset(seed=seed)
        done = False
        while not done:
            _, reward, done, _, info = env.step(action)
            failed += info.get("identified") is False
        if "score" not in info:
            ended_without_design += 1
            assert reward == -NO_DESIGN_COST and info["cost"] == NO_DESIGN_COST
            assert info["features"]["failed_experiments"] > 0
    assert failed > 0  # the case is exercised
    v2 = gym.make("DeadTime/MSP-v2", experiments="agent", noise_std=0.1)
    action = np.full(v2.action_space.shape, -1.0, dtype=np.float32)
    action[0], action[-2] = 1.0, _amplitude_action(amplitude)
    with pytest.raises(ValueError, match="no usable gain"):
        for seed in range(60):
            v2.reset(seed=seed)
            done = False
            while not done:
                _, _, done, _, _ = v2.step(action)


def test_v3_is_the_latest_version_without_a_deprecation_warning(recwarn):
    gym.make("DeadTime/PID-v3")
    assert not [w for w in recwarn if "out of date" in str(w.message)]


def test_a_given_plant_whose_seeds_procedure_fails_ends_without_a_design():
    """Fixed mode, 10% noise: on this test plant the closed-loop step identifies no usable model.
    v2 raises at reset (a drawn plant is drawn again; a given one cannot be); v3 starts the episode,
    shows the failed step, and ends it without a design."""
    from envs.systems.plant_sets import plant_set

    plant = plant_set("integrating", "test", 50)[16]
    env = gym.make("DeadTime/MSP-v3", noise_std=0.1)
    _, info = env.reset(seed=16, options={"plant": plant})
    assert info["features"]["failed_experiments"] > 0 and episode_of(env).identification is None
    _, reward, terminated, _, info = env.step(np.zeros(1, dtype=np.float32))
    assert terminated and reward == -NO_DESIGN_COST and info["identified"] is False and info["experiment_time"] > 0
    with pytest.raises(ValueError, match="no usable model"):
        gym.make("DeadTime/MSP-v2", noise_std=0.1).reset(seed=16, options={"plant": plant})


# ----------------------------------------------------------------------------- experiments and plans
def test_v3_agent_mode_offers_the_experiments_the_design_reads():
    from envs.episode_options import DESIGN_EXPERIMENTS

    for structure in STRUCTURES:
        env = gym.make(f"DeadTime/{structure}-v3", experiments="agent")
        assert tuning_env_of(env).experiment_names == DESIGN_EXPERIMENTS[structure.lower()]
        assert env.action_space.shape == (len(DESIGN_EXPERIMENTS[structure.lower()]) + 3,)


@pytest.mark.parametrize("structure", STRUCTURES)
@pytest.mark.parametrize("regime", [{"noise_std": 0.01}, {"noise_std": 0.1, "weights": {"production": 0.0}}])
def test_the_plan_of_unit_amplitudes_is_the_fixed_procedure_bit_for_bit(structure, regime):
    """Plan mode at amplitudes (1, 1), designing at the base rule (residual 0), gives the fixed mode's
    episode at the base rule: the same experiments, noise, identification and cost."""
    fixed = gym.make(f"DeadTime/{structure}-v3", **regime)
    plan = gym.make(f"DeadTime/{structure}-v3", experiments="plan", **regime)
    unit = _amplitude_action(1.0)
    for seed in range(6):
        fixed.reset(seed=seed)
        _, expected, *_ = fixed.step(np.zeros(1, dtype=np.float32))
        plan.reset(seed=seed)
        observation, reward, terminated, _, info = plan.step(np.array([unit, unit, 0.9], dtype=np.float32))
        assert (reward, terminated, observation[-1]) == (0.0, False, 1.0) and info["identified"]
        _, reward, terminated, _, _ = plan.step(np.array([-1.0, -1.0, 0.0], dtype=np.float32))
        assert terminated and reward == expected


def test_a_plan_sets_each_experiment_amplitude():
    env = gym.make("DeadTime/FPPI-v3", experiments="plan")
    env.reset(seed=0)
    _, _, _, _, info = env.step(np.array([_amplitude_action(0.3), _amplitude_action(3.0), 0.0], dtype=np.float32))
    first, second = episode_of(env).evidence.closed_loop, episode_of(env).evidence.results["open-loop-step"]
    assert info["amplitudes"] == pytest.approx((0.3, 3.0))
    assert first.amplitude == pytest.approx(0.3)
    assert second.height * first.gain == pytest.approx(3.0)


@pytest.mark.parametrize("structure", STRUCTURES)
def test_the_fixed_mode_with_a_plan_is_the_plan_mode_with_that_first_step(structure):
    regime = {"noise_std": 0.1}
    fixed = gym.make(f"DeadTime/{structure}-v3", plan=(3.0, 0.1), **regime)
    plan = gym.make(f"DeadTime/{structure}-v3", experiments="plan", **regime)
    for seed in range(5):
        first, _ = fixed.reset(seed=seed)
        _, expected, *_ = fixed.step(np.array([0.3], dtype=np.float32))
        plan.reset(seed=seed)
        shown, *_ = plan.step(np.array([_amplitude_action(3.0), _amplitude_action(0.1), 0.0], dtype=np.float32))
        _, reward, *_ = plan.step(np.array([0.0, 0.0, 0.3], dtype=np.float32))
        assert reward == expected
        np.testing.assert_array_equal(first, shown[:-1])  # the plan mode's observation adds the design-step flag


def test_a_bad_plan_is_one_line():
    for plan, message in (((1.0,), "two amplitudes"), ((1.0, 30.0), "must lie in"), ("11", "two amplitudes")):
        with pytest.raises(ValueError, match=message):
            gym.make("DeadTime/FPPI-v3", plan=plan)
    with pytest.raises(ValueError, match="fixed mode"):
        gym.make("DeadTime/FPPI-v3", experiments="agent", plan=(1.0, 1.0))


@pytest.mark.parametrize("action, message", [
    (np.array([True]), "real numbers"), (np.array([0.1 + 1j]), "real numbers"), (np.array(["0.1"]), "real numbers"),
    (np.zeros((1, 1)), "shape"), (np.zeros(2), "shape"), (np.array([np.nan]), "finite"),
])
def test_a_bad_action_is_one_line(action, message):
    env = gym.make("DeadTime/FPPI-v3")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=message):
        env.step(action)
    env.step(0.0)  # a number is a one-component action


@pytest.mark.parametrize("seed", [True, -1, 1.5, "1"])
def test_a_bad_seed_is_one_line(seed):
    with pytest.raises(ValueError, match="seed must be an integer >= 0 or None"):
        gym.make("DeadTime/FPPI-v3").reset(seed=seed)


@pytest.mark.parametrize("budget", [0, 1e9, 2.5, True, float("inf"), "4"])
def test_a_bad_budget_is_one_line(budget):
    with pytest.raises(ValueError, match="budget must be an integer from 1 to 100"):
        gym.make("DeadTime/FPPI-v3", experiments="agent", budget=budget)
