"""Plant families: determinism, documented ranges, and the benchmark batches of the papers.

Benchmark references: Gorez-Klan section 4 (eq. 4-15, 4-16 and the table of FOPDT/SOPDT
parameters), Ingimundarson section 4.4 (stable processes) and section 5.3 / Table 2 (integrating).
"""

import ast
from pathlib import Path

import numpy as np
import pytest

import envs.systems.families

from envs.systems.families import (
    FAMILIES,
    BenchmarkConfig,
    FopdtConfig,
    IntegratingConfig,
    LagChainConfig,
    SopdtConfig,
    sample_plant,
    sample_plants,
)
from envs.systems.benchmark_batches import benchmark_plants
from envs.systems.shapes import ShapeRanges
from envs.systems.plants import Plant

RANDOM_FAMILIES = ("fopdt", "sopdt", "lag-chain", "integrating")
DEFAULT_CONFIGS = {
    "fopdt": FopdtConfig(),
    "sopdt": SopdtConfig(),
    "lag-chain": LagChainConfig(),
    "integrating": IntegratingConfig(),
}
N = 300


def moment_fopdt(plant: Plant) -> tuple[float, float]:
    """``(T_a, D_a)`` by the method of moments: ``T_a^2 = 2 p2 - p1^2``, ``D_a = T_ar - T_a``
    (Gorez-Klan eq. 2-5, 2-6)."""
    p1, p2 = plant.taylor_coefficients()
    time_constant = np.sqrt(2 * p2 - p1**2)
    return time_constant, -p1 - time_constant


def test_families_names():
    assert FAMILIES == ("fopdt", "sopdt", "lag-chain", "integrating", "benchmark", "stable")


@pytest.mark.parametrize("family", FAMILIES)
def test_same_seed_same_plants(family):
    assert sample_plants(family, 20, seed=7) == sample_plants(family, 20, seed=7)


@pytest.mark.parametrize("family", FAMILIES)
def test_different_seeds_differ(family):
    assert sample_plants(family, 20, seed=7) != sample_plants(family, 20, seed=8)


def test_sample_plants_equals_repeated_sample_plant():
    rng = np.random.default_rng(3)
    assert sample_plants("lag-chain", 5, seed=3) == [sample_plant("lag-chain", rng) for _ in range(5)]


@pytest.mark.parametrize("family", RANDOM_FAMILIES)
def test_random_plants_in_documented_ranges(family):
    config = DEFAULT_CONFIGS[family]
    plants = sample_plants(family, N, seed=1)
    gains = np.array([p.gain for p in plants])
    residence = np.array([p.residence_time for p in plants])
    fraction = np.array([p.dead_time for p in plants]) / residence
    assert all(p.integrating == (family == "integrating") for p in plants)
    assert np.all((config.gain[0] * (1 - 1e-9) <= np.abs(gains)) & (np.abs(gains) <= config.gain[1] * (1 + 1e-9)))
    assert (gains > 0).any() and (gains < 0).any()
    assert np.all((config.residence_time[0] * (1 - 1e-9) <= residence) & (residence <= config.residence_time[1] * (1 + 1e-9)))
    assert np.all((config.dead_time_fraction[0] - 1e-9 <= fraction) & (fraction <= config.dead_time_fraction[1] + 1e-9))
    # log-uniform: both ends of the decades are visited
    assert np.abs(gains).min() < 0.3 and np.abs(gains).max() > 3
    assert residence.min() < 0.5 and residence.max() > 20


def test_fopdt_normalized_dead_time():
    for plant in sample_plants("fopdt", N, seed=2):
        assert plant.order == 1 and plant.num[:-1] == ()
        time_constant = plant.den[0] / plant.den[1]  # den = (1, 1/T)
        tau = plant.dead_time / (plant.dead_time + time_constant)
        assert 0.05 - 1e-12 <= tau <= 0.95 + 1e-12


def test_sopdt_has_overdamped_and_underdamped_plants():
    plants = sample_plants("sopdt", 100, seed=4)
    assert all(p.order == 2 and len(p.num) == 1 for p in plants)
    complex_poles = [np.iscomplex(np.roots(p.den)).any() for p in plants]
    assert any(complex_poles) and not all(complex_poles)
    for plant in plants:  # zeta in (0.4, 1): den = s^2 + 2 zeta w s + w^2 (monic)
        zeta = plant.den[1] / (2 * np.sqrt(plant.den[2]))
        assert zeta >= 0.4 - 1e-9


def test_lag_chain_has_higher_order_and_non_minimum_phase_plants():
    plants = sample_plants("lag-chain", 200, seed=5)
    orders = {p.order for p in plants}
    assert min(orders) == 2 and max(orders) == 10
    right_half_plane_zero = [len(p.num) > 1 and np.roots(p.num).real.max() > 0 for p in plants]
    assert any(right_half_plane_zero)


def test_config_ranges_are_honoured():
    config = FopdtConfig(gain=(2.0, 2.0), negative_gain_probability=1.0, residence_time=(3.0, 3.0),
                         dead_time_fraction=(0.5, 0.5))
    for plant in sample_plants("fopdt", 10, seed=0, config=config):
        assert plant.gain == pytest.approx(-2.0)
        assert plant.residence_time == pytest.approx(3.0)
        assert plant.dead_time == pytest.approx(1.5)


def test_config_selects_shapes():
    config = LagChainConfig(shapes=("lag-n",), shape_ranges=ShapeRanges(lag_orders=(4, 4)))
    assert {p.order for p in sample_plants("lag-chain", 10, seed=0, config=config)} == {4}


@pytest.mark.parametrize(
    "make, field",
    [
        (lambda: FopdtConfig(gain=(0.0, 1.0)), "gain"),
        (lambda: FopdtConfig(residence_time=(5.0, 1.0)), "residence_time"),
        (lambda: SopdtConfig(dead_time_fraction=(0.1, 1.0)), "dead_time_fraction"),
        (lambda: SopdtConfig(negative_gain_probability=1.5), "negative_gain_probability"),
        (lambda: FopdtConfig(shapes=("nmp",)), "shapes"),
        (lambda: ShapeRanges(geometric_ratio=(0.5, 1.5)), "geometric_ratio"),
        (lambda: ShapeRanges(lag_orders=(2.5, 4)), "lag_orders"),
        (lambda: BenchmarkConfig(kind="unstable"), "kind"),
    ],
)
def test_invalid_config_names_the_field(make, field):
    with pytest.raises(ValueError, match=field):
        make()


def test_unknown_family_lists_valid_ones():
    with pytest.raises(ValueError, match="'foptd'") as error:
        sample_plant("foptd", np.random.default_rng(0))
    assert all(name in str(error.value) for name in FAMILIES)


def test_config_of_another_family_is_refused():
    with pytest.raises(TypeError, match="SopdtConfig"):
        sample_plant("sopdt", np.random.default_rng(0), FopdtConfig())


# --------------------------------------------------------------------------- benchmark
def test_benchmark_names_and_kinds():
    stable, integrating = benchmark_plants("stable"), benchmark_plants("integrating")
    assert list(stable) == ["gorez-klan-P1", "gorez-klan-P2"] + [f"ingimundarson-stable-P{i}" for i in range(1, 8)]
    assert list(integrating) == [f"ingimundarson-integrating-P{i}" for i in range(1, 9)]
    assert benchmark_plants("all") == {**stable, **integrating}
    assert not any(p.integrating for p in stable.values()) and all(p.integrating for p in integrating.values())
    with pytest.raises(ValueError, match="kind"):
        benchmark_plants("unstable")


@pytest.mark.parametrize(
    "name, time_constant, dead_time",
    [("gorez-klan-P1", 0.67, 0.33), ("gorez-klan-P2", 0.32, 0.68)],  # Gorez-Klan section 4 table
)
def test_gorez_klan_fopdt_moments(name, time_constant, dead_time):
    plant = benchmark_plants("stable")[name]
    assert plant.residence_time == pytest.approx(1.0, rel=1e-12)  # T_ar = 1 for both (section 4)
    assert plant.dead_time == 0.0 and plant.gain == pytest.approx(1.0)
    assert moment_fopdt(plant) == pytest.approx((time_constant, dead_time), abs=0.005)  # table: 2 decimals


def test_gorez_klan_p1_time_constants():
    t = 1 / (1 + 0.4 + 0.4**2 + 0.4**3)
    expected = np.poly([-1 / (t * 0.4**k) for k in range(4)])
    assert benchmark_plants()["gorez-klan-P1"].den == pytest.approx(tuple(expected))


# T_ar = sum of time constants - zero time constants + 5, computed by hand.  Table 1 of
# Ingimundarson lists T_n and L_n identified from simulated experiments, whose sums only roughly
# match (17.2, 8.2, 12.1, 10.1, 6.2, 10.2, 7.0), so the exact values are checked instead.
@pytest.mark.parametrize(
    "index, residence_time",
    [(1, 17.0), (2, 8.0), (3, 11.0), (4, 10.0), (5, 5 + 1 + 2 / 9), (6, 10.5), (7, 5 + 1 + 1 / 2 + 1 / 4 + 1 / 8)],
)
def test_ingimundarson_stable_residence_times(index, residence_time):
    plant = benchmark_plants("stable")[f"ingimundarson-stable-P{index}"]
    assert plant.dead_time == 5.0 and plant.gain == pytest.approx(1.0)
    assert plant.residence_time == pytest.approx(residence_time, rel=1e-12)


# Table 2, column L_n (two-parameter model K_n e^{-L_n s}/s).  The paper prints one decimal, so
# 0.05 would do, except for P7: 0.5/(s+1) + 0.05/(s+0.1) = (1 + 5.5 s)/((1 + s)(1 + 10 s)) gives
# L_n = 1 + 10 - 5.5 + 5 = 10.5 exactly, where the paper prints 10.6.  The exact value is used.
@pytest.mark.parametrize(
    "index, dead_time, paper",
    [(1, 6.0, 6.0), (2, 6.1, 6.1), (3, 8.0, 8.0), (4, 11.0, 11.0), (5, 10.0, 10.0), (6, 5 + 1 + 2 / 9, 6.2),
     (7, 10.5, 10.6), (8, 6.875, 6.9)],
)
def test_ingimundarson_integrating_dead_times(index, dead_time, paper):
    plant = benchmark_plants("integrating")[f"ingimundarson-integrating-P{index}"]
    assert plant.dead_time == 5.0 and plant.integrating
    assert plant.residence_time == pytest.approx(dead_time, rel=1e-12)
    assert round(plant.residence_time, 1) == paper or index == 7


def test_ingimundarson_integrating_p6_has_velocity_gain_one_ninth():
    # 1/((s+1)(s^2+2s+9)) is printed without the factor 9 of the stable P5
    assert benchmark_plants("integrating")["ingimundarson-integrating-P6"].gain == pytest.approx(1 / 9)


def test_benchmark_family_draws_from_the_batch():
    batch = list(benchmark_plants("integrating").values())
    plants = sample_plants("benchmark", 50, seed=0, config=BenchmarkConfig(kind="integrating"))
    assert all(p in batch for p in plants) and len(set(plants)) > 1


def test_families_imports_numpy_only():
    """envs/ numerics never import gymnasium, torch or control (docs/architecture.md)."""
    tree = ast.parse(Path(envs.systems.families.__file__).read_text())
    imported = {alias.name for node in ast.walk(tree) if isinstance(node, ast.Import) for alias in node.names}
    imported |= {node.module for node in ast.walk(tree) if isinstance(node, ast.ImportFrom)}
    assert {name.split(".")[0] for name in imported} <= {"__future__", "dataclasses", "typing", "numpy", "envs"}
