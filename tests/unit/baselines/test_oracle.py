"""The oracle of baselines/oracle.py: never worse than a rule, its result, the exact models, bad input.

The oracle minimizes the same cost (:func:`envs.analysis.scoring.score`, experiment time included) over the
same one-parameter design family as the rules, so on the same plant and model no rule may beat it.
This holds for every rule checked, also for the rules whose parameter falls outside
:data:`PARAMETER_RANGES` (e.g. eq. 28/29 on plants with a tiny mismatch time): a parameter outside
the range is never better than the range's best on these plants.  The benchmark sweep is marked
slow; a few plants run always.
"""

import math

import numpy as np
import pytest

from baselines.rules.dtc import fppi_eq28_29, fppi_eq34, msp_eq43, msp_eq50, ppi_default
from baselines.oracle import (
    PARAMETER_RANGES,
    REFINEMENT_EVALUATIONS,
    design,
    exact_models,
    full_information_oracle,
    oracle,
    relative_scale,
)
from envs.design import MIN_RELATIVE_DEAD_TIME, pid_design
from envs.systems.families import sample_plants
from envs.systems.benchmark_batches import benchmark_plants
from envs.systems.plants import Plant
from envs.identification.procedure import identify
from envs.analysis.scoring import FEASIBLE_CAP, Constraints, score

PLANTS = benchmark_plants()
FAST = ["gorez-klan-P1", "ingimundarson-stable-P4", "ingimundarson-integrating-P1", "ingimundarson-integrating-P7"]
SLOW = [name for name in PLANTS if name not in FAST]
CONSTRAINT_NAMES = {"max_sensitivity", "min_relative_delay_margin", "min_gain_margin", "min_phase_margin_deg"}


def structures(plant: Plant) -> list[str]:
    return ["msp"] if plant.integrating else ["pid", "fppi"]


def rule_controllers(identification, structure: str) -> dict:
    """The papers' fixed rules on the identified quantities (Gorez-Klan's ``mu`` table, Ingimundarson's
    PPI, eq. 28-29, 34, 43 and 50)."""
    if structure == "pid":
        return {f"mu={mu}": pid_design(identification.sopdt, mu) for mu in (1.3, 1.5, 2.0, 3.0)}
    if structure == "fppi":
        k, t, l = identification.fopdt.gain, identification.fopdt.time_constant, identification.fopdt.dead_time
        rules = {"ppi kappa=1": ppi_default(k, t, l), "eq34 dL=0.2Ln": fppi_eq34(k, t, l, identification.mismatch_time, 0.2 * l)}
        if identification.mismatch_time > 0:
            rules["eq28/29"] = fppi_eq28_29(k, t, l, identification.mismatch_time)
        return rules
    k, l = identification.integrating_model.gain, identification.integrating_model.dead_time
    rules = {"eq50 d=0.2": msp_eq50(k, l, 0.2), "eq50 d=0.5": msp_eq50(k, l, 0.5)}
    if identification.pulse_area < abs(k) * l:
        rules["eq43"] = msp_eq43(k, l, identification.pulse_area)
    # Matausek-Micic (T_r = T_n) needs the lag of the dynamics additional to the integrator, which
    # the fixed procedure does not identify: not compared.
    return rules


def rule_parameter(controller, structure: str) -> float:
    return getattr(controller, "tr", None)


@pytest.fixture(scope="module")
def results():
    cache = {}

    def get(name: str):
        if name not in cache:
            plant = PLANTS[name]
            identification = identify(plant, np.random.default_rng(0))
            cache[name] = (identification, {s: oracle(plant, identification, s) for s in structures(plant)})
        return cache[name]

    return get


def _check_not_worse_than_rules(name, results):
    plant = PLANTS[name]
    identification, found = results(name)
    for structure, best in found.items():
        model = {"pid": identification.sopdt, "fppi": identification.fopdt, "msp": identification.integrating_model}[structure]
        for rule, controller in rule_controllers(identification, structure).items():
            rule_score = score(plant, controller, experiment_time=identification.experiment_time)
            assert best.cost <= rule_score.cost + 1e-9, (structure, rule, best.relative_parameter, best.cost, rule_score.cost)
            if structure != "pid":
                relative = controller.tr / relative_scale(structure, model)
                low, high = PARAMETER_RANGES[structure]
                if not low <= relative <= high:  # noted, and still not better than the oracle
                    print(f"{name} {structure} {rule}: T_r relative {relative:.3g} outside the range")


@pytest.mark.parametrize("name", FAST)
def test_oracle_is_not_worse_than_any_rule(name, results):
    _check_not_worse_than_rules(name, results)


@pytest.mark.slow
@pytest.mark.parametrize("name", SLOW)
def test_oracle_is_not_worse_than_any_rule_on_every_benchmark_plant(name, results):
    _check_not_worse_than_rules(name, results)


@pytest.mark.parametrize("name", FAST)
def test_result_is_consistent(name, results):
    plant = PLANTS[name]
    identification, found = results(name)
    for structure, best in found.items():
        low, high = PARAMETER_RANGES[structure]
        assert low <= best.relative_parameter <= high
        model = {"pid": identification.sopdt, "fppi": identification.fopdt, "msp": identification.integrating_model}[structure]
        assert best.parameter == pytest.approx(best.relative_parameter * relative_scale(structure, model), rel=1e-12)
        again = score(plant, design(structure, model, best.parameter), experiment_time=identification.experiment_time)
        assert again.cost == pytest.approx(best.cost, rel=1e-9) and best.score.cost == best.cost
        assert best.feasible == best.score.feasible == (not best.violations)
        assert best.feasible  # every benchmark plant has a feasible design in the range
        assert best.binding is None or best.binding in CONSTRAINT_NAMES | {"parameter_range"}
        assert set(best.margins) == {"max_sensitivity", "min_relative_delay_margin"}
        assert min(best.margins.values()) >= 0
        if best.binding in CONSTRAINT_NAMES:  # active at the optimum, within the search's resolution
            assert best.margins[best.binding] < 0.03
        assert best.evaluations <= 30 + REFINEMENT_EVALUATIONS + 2


def test_a_constraint_binds_at_the_boundary_of_the_feasible_set(results):
    """Gorez-Klan P1 (no dead time) judged as the environments judge it, against its ``T_ar``: the best
    ``mu`` is the smallest with ``DM/T_ar >= 0.2``; below it, the margin breaks.  As the limit of small
    dead times (``score``'s default) the delay margin holds for every stable loop and binds nowhere."""
    plant = PLANTS["gorez-klan-P1"]
    identification, _ = results("gorez-klan-P1")
    environments = Constraints(zero_delay="residence-time")
    best = oracle(plant, identification, "pid", constraints=environments)
    assert best.binding == "min_relative_delay_margin"
    below = score(plant, pid_design(identification.sopdt, best.parameter * 0.98), constraints=environments)
    assert "min_relative_delay_margin" in below.violations
    assert results("gorez-klan-P1")[1]["pid"].binding != "min_relative_delay_margin"


def test_the_range_binds_when_the_optimum_is_outside_it(results):
    plant = PLANTS["gorez-klan-P1"]
    identification, found = results("gorez-klan-P1")
    assert found["pid"].relative_parameter < 3.0
    restricted = oracle(plant, identification, "pid", parameter_range=(3.0, 30.0), grid=9)
    assert restricted.binding == "parameter_range"
    assert restricted.relative_parameter == pytest.approx(3.0, rel=2e-3)
    assert restricted.cost >= found["pid"].cost


def test_no_feasible_parameter_reports_the_least_violation(results):
    plant = PLANTS["ingimundarson-stable-P4"]
    identification, _ = results("ingimundarson-stable-P4")
    impossible = Constraints(max_sensitivity=1.05, min_relative_delay_margin=0.2)
    best = oracle(plant, identification, "fppi", constraints=impossible, grid=9)
    assert not best.feasible and best.binding is None
    assert set(best.violations) == {"max_sensitivity"}
    assert best.cost == pytest.approx(FEASIBLE_CAP + 1 + best.violations["max_sensitivity"])
    assert best.margins["max_sensitivity"] < 0
    # the least violation on the range: no grid point of a fine scan violates less
    model = identification.fopdt
    for relative in np.geomspace(*PARAMETER_RANGES["fppi"], 40):
        other = score(plant, design("fppi", model, relative * model.time_constant), constraints=impossible)
        assert other.cost >= best.cost - 1e-9


# --------------------------------------------------------------------------- exact models
def test_exact_models_of_an_fopdt_plant_are_the_plant():
    plant = Plant.from_time_constants(-2.0, [3.0], 1.5)
    models = exact_models(plant)
    assert models.fopdt.gain == -2.0
    assert models.fopdt.time_constant == pytest.approx(3.0, rel=1e-9)
    assert models.fopdt.dead_time == pytest.approx(1.5, rel=1e-9)
    assert models.sopdt.residence_time == pytest.approx(4.5, rel=1e-12)
    assert models.integrating_model is None


def test_exact_integrating_model():
    plant = Plant.from_time_constants(0.3, [2.0], 4.0, integrating=True)
    models = exact_models(plant)
    assert models.sopdt is None and models.fopdt is None
    assert models.integrating_model.gain == pytest.approx(0.3, rel=1e-12)
    assert models.integrating_model.dead_time == pytest.approx(6.0, rel=1e-12)


@pytest.mark.parametrize("name", [n for n in PLANTS if not PLANTS[n].integrating])
def test_exact_models_are_the_limit_of_noise_free_identification(name):
    plant = PLANTS[name]
    identified, exact = identify(plant, np.random.default_rng(0)), exact_models(plant)
    # T_ar is identified to 1e-4 but the second moment (T_a, hence theta) only to 0.5-1.5 %
    # (measured; worst on the resonant P5): it comes from a closed-loop record through the
    # commissioning PI (eq. 10).
    tolerance = {"rel": 2e-2, "abs": 1e-3 * plant.residence_time}
    assert exact.sopdt.time_constants == pytest.approx(identified.sopdt.time_constants, **tolerance)
    assert exact.sopdt.dead_time == pytest.approx(identified.sopdt.dead_time, **tolerance)
    assert exact.fopdt.time_constant == pytest.approx(identified.fopdt.time_constant, rel=2e-3)


def test_full_information_oracle_charges_no_experiment():
    plant = PLANTS["gorez-klan-P1"]
    best = full_information_oracle(plant, "pid")
    assert best.score.experiment_cost == 0.0 and best.feasible


# --------------------------------------------------------------------------- bad input
def test_bad_structure_and_missing_model_are_refused(results):
    plant = PLANTS["gorez-klan-P1"]
    identification, _ = results("gorez-klan-P1")
    with pytest.raises(ValueError, match="structure must be one of"):
        oracle(plant, identification, "smith")
    with pytest.raises(ValueError, match="'msp' needs an integrating plant"):
        oracle(plant, identification, "msp")
    with pytest.raises(ValueError, match="'pid' needs a self-regulating plant"):
        full_information_oracle(PLANTS["ingimundarson-integrating-P1"], "pid")
    with pytest.raises(ValueError, match="grid must be an integer >= 3"):
        oracle(plant, identification, "pid", grid=2)
    with pytest.raises(ValueError, match="parameter_range must be increasing"):
        oracle(plant, identification, "pid", parameter_range=(3.0, 1.0))
    with pytest.raises(ValueError, match=r"parameter_range\[0\] must be > 0"):
        oracle(plant, identification, "pid", parameter_range=(0.0, 1.0))


def test_pid_on_a_model_without_dead_time_uses_the_floor():
    """A lag-chain plant with strong lead: the moments give ``tau = 0``, so ``D_2 = 0`` (about one in six
    lag-chain plants of seed 0).  The design floors ``D_2`` at ``MIN_RELATIVE_DEAD_TIME T_ar``, so the
    PID is defined and the oracle finds a feasible ``mu``."""
    plant = sample_plants("lag-chain", 1, 3)[0]
    identification = identify(plant, np.random.default_rng(0))
    model = identification.sopdt
    assert model.dead_time == 0
    controller = pid_design(model, 2.0)
    floor = MIN_RELATIVE_DEAD_TIME * model.residence_time
    assert controller.kp == pytest.approx(model.time_constants[0] / (2.0 * model.gain * floor), rel=1e-12)
    assert oracle(plant, identification, "pid", grid=15).feasible
    assert oracle(plant, identification, "fppi", grid=15).feasible


def test_random_plants_have_feasible_oracles():
    """One plant of each random family, noise-free identification: a feasible optimum inside the range."""
    for family in ("fopdt", "sopdt", "lag-chain", "integrating"):
        plant = sample_plants(family, 1, 4)[0]
        identification = identify(plant, np.random.default_rng(0))
        for structure in structures(plant):
            best = oracle(plant, identification, structure, grid=15)
            assert best.feasible, (family, structure, best.violations)
            assert math.isfinite(best.cost) and best.cost < FEASIBLE_CAP


RANDOM = [
    pytest.param(family, seed, id=f"{family}-{seed}")
    for family in ("fopdt", "sopdt", "lag-chain", "integrating")
    for seed in (3, 4)
]


@pytest.mark.slow
@pytest.mark.parametrize("family, seed", RANDOM)
def test_oracle_is_not_worse_than_any_rule_on_random_noisy_plants(family, seed):
    """The oracle ahead of every rule on random plants, with 1 % measurement noise in the experiments: the rules and
    the oracle see the same identified model, so no rule may beat the oracle."""
    plant = sample_plants(family, 1, seed)[0]
    identification = identify(plant, np.random.default_rng(seed), noise_std=0.01)
    for structure in structures(plant):
        try:
            best = oracle(plant, identification, structure)
        except ValueError as error:  # a PID model without dead time: refused, see above
            assert "dead" in str(error)
            continue
        for rule, controller in rule_controllers(identification, structure).items():
            rule_score = score(plant, controller, experiment_time=identification.experiment_time)
            assert best.cost <= rule_score.cost + 1e-9, (structure, rule, best.cost, rule_score.cost)
