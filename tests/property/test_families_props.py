"""Invariants of the plant families over arbitrary seeds."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from envs.systems.families import (
    FAMILIES,
    FopdtConfig,
    IntegratingConfig,
    LagChainConfig,
    SopdtConfig,
    sample_plant,
    sample_plants,
)
from envs.systems.benchmark_batches import benchmark_plants

CONFIGS = {"fopdt": FopdtConfig(), "sopdt": SopdtConfig(), "lag-chain": LagChainConfig(),
           "integrating": IntegratingConfig()}
seeds = st.integers(min_value=0, max_value=2**63 - 1)


@settings(max_examples=200, deadline=None)
@given(family=st.sampled_from(sorted(CONFIGS)), seed=seeds)
def test_random_plant_is_valid_and_in_range(family, seed):
    config = CONFIGS[family]
    plant = sample_plant(family, np.random.default_rng(seed))
    assert plant.integrating == (family == "integrating")
    residence_time = plant.residence_time
    low, high = config.residence_time
    assert low * (1 - 1e-9) <= residence_time <= high * (1 + 1e-9)
    low, high = config.gain
    assert low * (1 - 1e-9) <= abs(plant.gain) <= high * (1 + 1e-9)
    low, high = config.dead_time_fraction
    assert low - 1e-9 <= plant.dead_time / residence_time <= high + 1e-9
    num, den = plant.rational_part
    assert np.all(np.roots(den).real < 0)  # stable apart from the integrator


@settings(max_examples=50, deadline=None)
@given(family=st.sampled_from(FAMILIES), seed=seeds)
def test_same_seed_same_plants(family, seed):
    assert sample_plants(family, 3, seed) == sample_plants(family, 3, seed)


@settings(max_examples=50, deadline=None)
@given(seed=seeds)
def test_benchmark_plant_is_one_of_the_batch(seed):
    assert sample_plant("benchmark", np.random.default_rng(seed)) in benchmark_plants().values()
