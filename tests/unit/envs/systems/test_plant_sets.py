"""Fixed plant sets (envs/systems/plant_sets.py) and the ``stable`` mixture family."""

from __future__ import annotations

import numpy as np
import pytest

from envs.systems.families import MixtureConfig, SopdtConfig, sample_plant, sample_plants
from envs.systems.plant_sets import benchmark_set, plant_set
from envs.tuning_env import PIDEnv


@pytest.mark.parametrize("family", ["stable", "integrating", "fopdt"])
def test_sets_are_fixed_and_prefix_stable(family):
    ten = plant_set(family, "test", 10)
    assert ten == plant_set(family, "test", 10)
    assert plant_set(family, "test", 4) == ten[:4]
    assert plant_set(family, "validation", 10) != ten


def test_test_set_is_never_drawn_in_training():
    """The environment draws with ``default_rng(seed)``; no integer seed reproduces the set's stream."""
    test = plant_set("stable", "test", 20) + plant_set("stable", "validation", 20)
    env = PIDEnv()
    for seed in range(40):
        env.reset(seed=seed)
        assert env.plant not in test
        assert sample_plants("stable", 1, seed)[0] not in test


def test_bad_arguments_are_named():
    with pytest.raises(ValueError, match="unknown plant set split 'train'"):
        plant_set("stable", "train", 3)
    with pytest.raises(ValueError, match="unknown plant family 'x'"):
        plant_set("x", "test", 3)
    with pytest.raises(ValueError, match="n must be an integer >= 0"):
        plant_set("stable", "test", -1)
    with pytest.raises(ValueError, match="unknown structure 'pd'"):
        benchmark_set("pd")


def test_benchmark_sets_by_structure():
    assert len(benchmark_set("pid")) == len(benchmark_set("fppi")) == len(benchmark_set("pi")) == 9
    integrating = benchmark_set("msp")
    assert len(integrating) == 8 and all(p.integrating for p in integrating.values())


def test_stable_mixture_draws_each_family():
    rng = np.random.default_rng(0)
    orders = {sample_plant("stable", rng).order for _ in range(60)}
    assert {1, 2} <= orders and max(orders) >= 3
    narrow = MixtureConfig(sopdt=SopdtConfig(gain=(2.0, 2.0), negative_gain_probability=0.0))
    plants = [sample_plant("stable", rng, narrow) for _ in range(60)]
    assert any(p.order == 2 and p.gain == pytest.approx(2.0) for p in plants)
