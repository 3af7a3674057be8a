"""Invariants of the oracle (baselines/oracle.py).

* Feasibility is never missed: if some parameter of a dense brute-force grid (200 log-spaced points
  over the range) satisfies every constraint, the oracle's optimum does too, and no grid point is
  cheaper than it by more than the grid's own resolution allows (checked: never cheaper at all on
  these plants).
* Gain and time-scale invariance: ``P(s) -> k P(a s)`` leaves the relative parameter and the cost
  of the full-information oracle unchanged.
* Full information vs identification: what is true is *not* "the exact model is never worse".  With
  noise-free experiments the identified models are the exact ones to within 0.5-1.5 % (see
  tests/unit/baselines/test_oracle.py), and the two oracles agree once the experiment cost is excluded (to
  the 2 % below); with noisy experiments either may win, since the exact SOPDT/FOPDT is not the
  best model for a fixed-structure design.  Only the experiment cost is guaranteed to favour full
  information (it is zero).
"""

import numpy as np
import pytest

from baselines.oracle import PARAMETER_RANGES, design, exact_models, full_information_oracle, oracle, relative_scale
from envs.systems.families import sample_plants
from envs.systems.plants import Plant
from envs.identification.procedure import identify
from envs.analysis.scoring import CostWeights, score

NO_EXPERIMENT = CostWeights(experiment=0.0)


def _random_cases(n: int):
    cases = []
    for family in ("fopdt", "sopdt", "lag-chain", "integrating"):
        for i, plant in enumerate(sample_plants(family, n, 11)):
            for structure in (["msp"] if plant.integrating else ["pid", "fppi"]):
                cases.append(pytest.param(plant, structure, id=f"{family}-{i}-{structure}"))
    return cases


@pytest.mark.slow
@pytest.mark.parametrize("plant, structure", _random_cases(2))
def test_oracle_finds_a_feasible_design_whenever_a_dense_grid_does(plant, structure):
    identification = identify(plant, np.random.default_rng(0))
    models = {"pid": identification.sopdt, "fppi": identification.fopdt, "msp": identification.integrating_model}
    model = models[structure]
    best = oracle(plant, identification, structure)
    unit = relative_scale(structure, model)
    dense = [
        score(plant, design(structure, model, relative * unit), experiment_time=identification.experiment_time)
        for relative in np.geomspace(*PARAMETER_RANGES[structure], 200)
    ]
    if any(s.feasible for s in dense):
        assert best.feasible, best.violations
    assert best.cost <= min(s.cost for s in dense) + 1e-9


@pytest.mark.parametrize(
    "plant, structure",
    [
        (Plant.from_time_constants(1.0, [3.0, 1.0], 2.0), "pid"),
        (Plant.from_time_constants(1.0, [3.0, 1.0], 2.0), "fppi"),
        (Plant.from_time_constants(1.0, [1.0], 4.0, integrating=True), "msp"),
    ],
)
def test_full_information_oracle_is_invariant_to_gain_and_time_scale(plant, structure):
    gain, scale = -4.0, 6.0
    num = gain * np.asarray(plant.num) * scale ** np.arange(len(plant.num))[::-1]
    den = np.asarray(plant.den) * scale ** np.arange(len(plant.den))[::-1]
    scaled = Plant(tuple(num), tuple(den), plant.dead_time * scale)
    reference = full_information_oracle(plant, structure, grid=15)
    other = full_information_oracle(scaled, structure, grid=15)
    assert other.relative_parameter == pytest.approx(reference.relative_parameter, rel=1e-6)
    assert other.cost == pytest.approx(reference.cost, rel=1e-6)
    assert other.binding == reference.binding


@pytest.mark.parametrize("family", ["fopdt", "sopdt", "integrating"])
def test_noise_free_identified_and_full_information_oracles_agree_without_experiment_cost(family):
    plant = sample_plants(family, 1, 5)[0]
    identification = identify(plant, np.random.default_rng(0))
    structure = "msp" if plant.integrating else "fppi"
    identified = oracle(plant, identification, structure, weights=NO_EXPERIMENT, grid=15)
    full = full_information_oracle(plant, structure, weights=NO_EXPERIMENT, grid=15)
    assert identified.feasible and full.feasible
    assert full.cost == pytest.approx(identified.cost, rel=2e-2)
    charged = oracle(plant, identification, structure, grid=15)
    assert charged.score.experiment_cost > 0 == full.score.experiment_cost
    assert exact_models(plant) is not None
