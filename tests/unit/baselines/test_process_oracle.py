"""The per-process oracle: the Gorez-Klan ``mu`` searched with process runs.

On a process the cost is known only by running it (:func:`envs.process.scoring.process_score`: the
set-point and load tests on the process, the constraints on the identified model).  The oracle's
search is the environments' (:func:`baselines.oracle.search_parameter`), so its optimum is at most
the cost of every ``mu`` of a grid (the search's own grid is 30 points; this one is offset from it)
and of every ``mu`` rule, and scoring its controller again gives its cost bit for bit (a process run
is deterministic for a seed).
"""

from __future__ import annotations

import numpy as np
import pytest

from baselines.process_oracle import process_oracle
from baselines.rules.registry import RULES, RuleInputs
from envs.design import pid_design
from envs.process.performance import RunProtocol
from envs.process.plant_process import PlantProcess
from envs.process.procedure import identify_process
from envs.process.scoring import process_score
from envs.systems.plants import Plant


@pytest.fixture(scope="module")
def setting():
    process = PlantProcess(Plant.from_time_constants(1.0, [8.0, 2.0], 3.0), noise_std=0.005, sample_time=0.1)
    found = identify_process(process, relay_test=False)
    return process, found, RunProtocol.from_identification(found, process.load_step)


def test_the_process_oracle_is_ahead_of_a_grid_and_of_the_mu_rules(setting):
    process, found, protocol = setting
    result = process_oracle(process, found, protocol)
    assert result.score.feasible and result.structure == "pid"
    again = process_score(process, result.controller, found, protocol)
    assert again.cost == result.score.cost
    model = found.identification.sopdt
    for mu in np.geomspace(0.35, 250.0, 9):
        assert result.score.cost <= process_score(process, pid_design(model, mu), found, protocol).cost
    inputs = RuleInputs.from_identification(found.identification)
    for name, rule in RULES.items():
        if name.startswith("gorez-klan"):
            assert result.score.cost <= process_score(process, rule(inputs), found, protocol).cost, name


def test_the_fppi_oracle_is_ahead_of_the_fppi_rules(setting):
    process, found, protocol = setting
    result = process_oracle(process, found, protocol, "fppi")
    assert result.controller.to_dict()["type"] == "fppi" and result.relative_parameter == result.parameter / found.identification.fopdt.time_constant
    inputs = RuleInputs.from_identification(found.identification)
    for name, rule in RULES.items():
        if rule.controller == "fppi":
            assert result.score.cost <= process_score(process, rule(inputs), found, protocol).cost, name


def test_the_process_oracle_refuses_what_it_cannot_search(setting):
    process, found, protocol = setting
    with pytest.raises(ValueError, match="structure must be one of pid, fppi"):
        process_oracle(process, found, protocol, "msp")
    with pytest.raises(ValueError, match="grid must be an integer >= 3"):
        process_oracle(process, found, protocol, grid=2)
