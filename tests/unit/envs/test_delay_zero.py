"""A plant given without dead time where the design needs one is refused in one line.

Measured before the check: ``reset(options={"plant": {"num": [1], "den": [10, 1], "delay": 0}})`` on
``DeadTime/PID-v3`` scored 23.25 (and ``(2 s + 1)/((s + 1)(3 s + 1))`` 23.34) where a delay of 1e-300,
1e-12 or 1e-3 scores 0.746 (0.874): a relative degree of 1 without dead time shows no dead time to
identify.  ``1/s`` without dead time raised ZeroDivisionError on ``DeadTime/MSP-v3``.  Delay-free plants
of relative degree 2 or more (``1/(s + 1)^2``, ``(1 - 2 s)/(s + 1)^2``, Gorez & Klan's P1 and P2 of the
benchmark) scored the same at 0 and 1e-300 and are still accepted (:func:`envs.validation.require_dead_time`).
No episode of any version changes: the check is on the forms a user gives (JSON, transfer functions,
family configs), not on :class:`envs.systems.plants.Plant` itself.
"""

from __future__ import annotations

import json

import control
import gymnasium as gym
import pytest
from in_process import error_line

import envs  # noqa: F401  (registers the ids)
from envs.systems.families import FopdtConfig, LagChainConfig
from envs.systems.plant_sets import benchmark_plants
from envs.systems.plants import Plant, as_plant

FIRST_ORDER = {"num": [1.0], "den": [10.0, 1.0], "delay": 0}
REFUSED = "plant.delay must be > 0 for a plant of relative degree 1"


@pytest.mark.parametrize("plant", [FIRST_ORDER, {"num": [2.0, 1.0], "den": [3.0, 4.0, 1.0], "delay": 0.0},
                                   {"num": [0.5, 1.0], "den": [2.0, 1.0], "delay": 0}])
def test_a_json_plant_without_dead_time_of_relative_degree_below_2_is_refused(plant):
    with pytest.raises(ValueError, match=r"plant\.delay must be > 0 for a plant of relative degree [01] "):
        Plant.from_dict(plant)


def test_reset_refuses_it_before_any_episode():
    env = gym.make("DeadTime/PID-v3")
    with pytest.raises(ValueError, match=REFUSED):
        env.reset(seed=0, options={"plant": FIRST_ORDER})
    env.reset(seed=0, options={"plant": {**FIRST_ORDER, "delay": 1e-300}})  # the limit of small delays: accepted


def test_an_integrator_without_dead_time_is_refused_on_the_msp():
    env = gym.make("DeadTime/MSP-v3")
    with pytest.raises(ValueError, match=REFUSED):
        env.reset(seed=0, options={"plant": {"num": [1.0], "den": [1.0, 0.0], "delay": 0}})


def test_a_transfer_function_without_dead_time_is_refused_unless_of_relative_degree_2():
    with pytest.raises(ValueError, match="plant: the dead time must be > 0 for a plant of relative degree 1"):
        as_plant(control.tf([1.0], [10.0, 1.0]))
    assert as_plant((control.tf([1.0], [10.0, 1.0]), 0.5)).dead_time == 0.5
    assert as_plant(control.tf([1.0], [1.0, 2.0, 1.0])).dead_time == 0.0


def test_the_benchmarks_delay_free_plants_are_still_accepted():
    delay_free = [p for p in benchmark_plants("stable").values() if p.dead_time == 0]
    assert len(delay_free) == 2 and all(p.relative_degree >= 2 for p in delay_free)
    for plant in delay_free:
        assert Plant.from_dict(plant.to_dict()) == plant


def test_a_family_without_dead_time_is_refused():
    with pytest.raises(ValueError, match="dead_time_fraction must be .* 0 < high < 1"):
        FopdtConfig(dead_time_fraction=(0.0, 0.0))
    LagChainConfig()  # its default (0.0, 0.8) draws a dead time


@pytest.mark.parametrize("command", ["analyze", "tune"])
def test_the_command_line_refuses_it_in_one_line(command):
    plant = json.dumps(FIRST_ORDER)
    argv = ["analyze", "--plant", plant, "--controller", json.dumps({"type": "pid", "kp": 1.2, "ti": 9, "td": 1.5, "n": 10})] \
        if command == "analyze" else ["tune", "--rule", "simc-pi", "--plant", plant]
    assert REFUSED in error_line(*argv)
