"""The two process adapters: the project's plants and the TCLab emulator.

* ``PlantProcess`` samples a plant with the exact simulation: an input held sample by sample gives
  the samples of :func:`envs.simulation.open_loop.open_loop_response` (the same zero-order-hold
  map; a fractional dead time included) to rounding; it starts at rest at its operating point; its
  noise is seeded.
* ``TCLabProcess`` gives the measurements of ``tclab.TCLabModel`` used directly with
  ``random.seed(seed)``, bit for bit, without touching Python's global generator and without
  printing; the same seed gives the same run.
* ``check_process`` names what is wrong with an object that is not a process.
"""

from __future__ import annotations

import contextlib
import io
import math
import random

import numpy as np
import pytest

from envs.process.plant_process import PlantProcess, PlantProcessOptions
from envs.process.protocol import check_process
from envs.process.runs import hold
from envs.process.tclab_process import TCLabProcess
from envs.simulation.open_loop import open_loop_response
from envs.systems.plants import Plant


@pytest.mark.parametrize("dead_time", [0.0, 2.0, 2.37])  # none, whole samples, a fractional part
def test_a_held_input_is_the_exact_open_loop_response(dead_time):
    plant = Plant.from_time_constants(2.0, [3.0, 1.0], dead_time, zero_time_constants=[0.5])
    process = PlantProcess(plant, sample_time=0.1)
    inputs = np.where(np.arange(300) < 150, 1.0, -0.5)
    outputs = []
    for u in inputs:
        outputs.append(process.measure())
        process.apply(u)
    expected = open_loop_response(plant.state_space(), dead_time, inputs, 0.1)
    np.testing.assert_allclose(outputs, expected, rtol=0, atol=1e-12)


def test_the_load_enters_at_the_plant_input_and_the_limits_clip():
    plant = Plant.from_time_constants(1.0, [2.0], 0.5)
    a, b = PlantProcess(plant, sample_time=0.1, input_limits=(-1.0, 1.0)), PlantProcess(plant, sample_time=0.1)
    for _ in range(100):
        a.apply(5.0, load=0.25)  # clipped to 1, plus the load
        b.apply(1.25)
    assert a.measure() == b.measure()


def test_the_plant_starts_at_rest_at_its_operating_point():
    plant = Plant.from_time_constants(2.5, [4.0, 1.0], 1.0)
    process = PlantProcess(plant, operating_input=3.0)
    record = hold(process, 3.0, 400)
    np.testing.assert_allclose(record.output, 7.5, rtol=1e-12)


def test_plant_noise_is_seeded_and_one_value_per_sample():
    process = PlantProcess(Plant.from_time_constants(1.0, [1.0], 0.2), noise_std=0.1)
    first = process.measure()
    assert process.measure() == first  # no time passed
    runs = []
    for seed in (3, 3, 4):
        process.reset(seed)
        runs.append(hold(process, 0.5, 50).output)
    assert np.array_equal(runs[0], runs[1]) and not np.array_equal(runs[0], runs[2])


def test_an_integrating_plant_only_rests_at_zero_input():
    with pytest.raises(ValueError, match="operating_input must be 0 for an integrating plant"):
        PlantProcess(Plant.from_time_constants(1.0, [1.0], 1.0, integrating=True), operating_input=1.0)


def test_plant_process_options_are_one_object_that_keywords_fill():
    plant = Plant.from_time_constants(1.0, [1.0], 0.2)
    options = PlantProcessOptions(sample_time=0.05, noise_std=0.1, operating_input=0.5, name="tank")
    given, filled = PlantProcess(plant, options), PlantProcess(plant, sample_time=0.05, noise_std=0.1, operating_input=0.5, name="tank")
    overridden = PlantProcess(plant, options, noise_std=0.0)
    assert (given.sample_time, given.noise_std, given.operating_input, given.name) == (0.05, 0.1, 0.5, "tank")
    assert np.array_equal(hold(given, 0.5, 40).output, hold(filled, 0.5, 40).output)
    assert overridden.noise_std == 0.0 and options.noise_std == 0.1
    with pytest.raises(TypeError, match="noise"):
        PlantProcess(plant, noise=0.1)


def _direct_tclab(seed: int, inputs: np.ndarray, loads: np.ndarray) -> np.ndarray:
    """``tclab.TCLabModel(synced=False)`` as its documentation uses it, noise by ``random.seed``."""
    import tclab

    with contextlib.redirect_stdout(io.StringIO()):
        lab = tclab.TCLabModel(synced=False)
    lab.tlast = 0.0
    random.seed(seed)
    measured = []
    for k, (u, load) in enumerate(zip(inputs, loads)):
        measured.append(lab.T1)
        lab.Q1(u)
        lab.Q2(load)
        lab.update(k + 1.0)
    return np.asarray(measured)


def test_tclab_measurements_are_the_emulators_bit_for_bit_and_leave_random_alone(capsys):
    inputs = np.where(np.arange(1500) < 700, 40.0, 120.0)  # 120 % is clipped by the emulator
    loads = np.where(np.arange(1500) < 1000, 0.0, 50.0)
    random.seed(12345)
    before = random.getstate()
    process = TCLabProcess()
    process.reset(7)
    measured = []
    for u, load in zip(inputs, loads):
        measured.append(process.measure())
        process.apply(u, load)
    process.close()
    assert random.getstate() == before  # neither drawn from nor reseeded
    assert capsys.readouterr().out == ""  # the emulator's prints are kept off the terminal
    direct = _direct_tclab(7, inputs, loads)
    assert np.array_equal(measured, direct)
    assert 21.0 - 0.33 <= measured[0] <= 21.0 and np.ptp(measured) > 20.0  # from ambient, heated
    steps = np.unique(np.round(np.diff(measured), 6))
    assert np.allclose(steps / 0.3223, np.round(steps / 0.3223), atol=1e-4)  # quantized by 0.3223 degC


def test_tclab_reset_repeats_the_run():
    process = TCLabProcess()
    runs = []
    for seed in (1, 1, 2):
        process.reset(seed)
        runs.append(hold(process, 30.0, 300).output)
    assert np.array_equal(runs[0], runs[1]) and not np.array_equal(runs[0], runs[2])


class _NotAProcess:
    name, sample_time, settling_time = "x", 1.0, 100.0
    setpoint_step = input_step = load_step = 1.0
    units = None

    def reset(self, seed): ...

    def measure(self): ...

    def apply(self, control, load=0.0): ...


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({}, "has no attribute 'input_limits'"),
        ({"input_limits": (0.0, 1.0), "operating_input": 2.0}, "operating_input 2 is outside the input limits"),
        ({"input_limits": (1.0, 0.0), "operating_input": 0.5}, "input_limits must be increasing"),
        ({"input_limits": (0.0, 1.0), "operating_input": 0.5, "sample_time": math.nan}, "sample_time must be finite"),
        ({"input_limits": (0.0, 1.0), "operating_input": 0.5, "settling_time": 10.0}, "at least 15 sample times"),
        ({"input_limits": (0.0, 1.0), "operating_input": 0.5, "load_step": 0.0}, "load_step must be non-zero"),
    ],
)
def test_check_process_names_what_is_wrong(change, message):
    process = _NotAProcess()
    for name, value in change.items():
        setattr(process, name, value)
    with pytest.raises(ValueError, match=message):
        check_process(process)
