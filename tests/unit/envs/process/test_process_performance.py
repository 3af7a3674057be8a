"""A controller's tests on a process: against the exact loop, and the NaN case.

On a :class:`PlantProcess` the set-point and load IAE of the process path equal
``deadtime analyze``'s (:func:`envs.analysis.loop_analysis.analyze`, the continuous loop simulated
exactly) for the same plant and controller.  The process path runs the controller as a discrete
law, its output held over each sample: an extra delay of about half a sample (and the derivative's
sample mean), so the difference is first order in the sample time.  Measured on the four loops
below (PIDs, ``Ms`` 1.48 to 1.98, and FPPIs, whose predictor's dead time is interpolated between
samples): at ``T_ar/200`` 0.02% to 1.02%, at ``T_ar/500`` 0.002% to 0.41%; the test samples at
``T_ar/500`` with the 1% tolerance, and checks that the deviation shrinks at least as a first-order
error from ``T_ar/200`` to ``T_ar/500`` (by more than 2 times; 2.5 for first order).

A process whose measurement becomes NaN in the middle of a test stops that test there; the
performance says which test and when, and its IAE is NaN.
"""

from __future__ import annotations

import math

import pytest

from envs.analysis.loop_analysis import analyze
from envs.process.performance import RunProtocol, closed_loop_performance
from envs.process.plant_process import PlantProcess
from envs.systems.controllers import FPPI, PID, SeriesPID
from envs.systems.plants import Plant

LOOPS = {
    "fopdt-pid": (Plant.from_time_constants(1.0, [10.0], 5.0), PID(kp=1.2, ti=9.0, td=1.5, n=10)),
    "fopdt-pi": (Plant.from_time_constants(2.0, [10.0], 5.0), PID(kp=0.5, ti=10.0)),
    "lag-chain-series": (Plant.from_time_constants(1.0, [4.0, 2.0, 1.0], 2.5), SeriesPID(kp=0.8, ti=4.0, td=2.0, n=10)),
    "negative-gain": (Plant.from_time_constants(-3.0, [1.0, 1.0, 1.0, 1.0], 0.3), PID(kp=-0.3, ti=2.5, td=0.6, n=8)),
    "fopdt-fppi": (Plant.from_time_constants(1.0, [10.0], 5.0), FPPI(1.0, 10.0, 5.0, 4.0, 4.0)),
    "fopdt-ppi-model-error": (Plant.from_time_constants(1.0, [10.0], 5.0), FPPI(1.1, 9.0, 5.7, 3.0, 0.0)),
    "lag-chain-fppi": (Plant.from_time_constants(2.0, [4.0, 2.0, 1.0], 2.5), FPPI(2.0, 5.5, 4.0, 3.0, 3.0)),
}


def _deviations(plant: Plant, controller, samples_per_residence_time: int) -> tuple[float, float]:
    analysis = analyze(plant, controller)
    process = PlantProcess(plant, sample_time=plant.residence_time / samples_per_residence_time)
    protocol = RunProtocol(seed=0, operating_input=0.0, operating_output=0.0, settle_time=process.sample_time,
                           setpoint_step=1.0, load_step=1.0, residence_time=plant.residence_time)
    performance = closed_loop_performance(process, controller, protocol)
    assert performance.stopped is None and performance.noise_floor == 0.0
    return (performance.iae_setpoint / analysis.iae_setpoint - 1.0, performance.iae_load / analysis.iae_load - 1.0)


@pytest.mark.parametrize("name", LOOPS)
def test_the_plant_process_reproduces_analyze_within_one_percent(name):
    plant, controller = LOOPS[name]
    fine = _deviations(plant, controller, 500)
    assert all(abs(d) < 0.01 for d in fine), fine
    coarse = _deviations(plant, controller, 200)
    for small, large in zip(fine, coarse):
        if abs(large) > 1e-4:  # a PI's load IAE is K/K_i exactly in both: nothing to converge
            assert large / small > 2.0, (small, large)


class _NaNAfter(PlantProcess):
    """Measures NaN from sample ``after`` after each reset on."""

    def __init__(self, plant: Plant, after: int) -> None:
        self.after, self.samples = after, 0
        super().__init__(plant)

    def reset(self, seed: int) -> None:
        super().reset(seed)
        self.samples = 0

    def apply(self, control: float, load: float = 0.0) -> None:
        super().apply(control, load)
        self.samples += 1

    def measure(self) -> float:
        return math.nan if self.samples >= self.after else super().measure()


def test_a_nan_mid_test_stops_it_and_says_so():
    plant, controller = LOOPS["fopdt-pi"]
    process = _NaNAfter(plant, after=700)
    protocol = RunProtocol(seed=0, operating_input=0.0, operating_output=0.0, settle_time=10 * process.sample_time,
                           setpoint_step=1.0, load_step=1.0, residence_time=plant.residence_time)
    performance = closed_loop_performance(process, controller, protocol)
    assert math.isnan(performance.iae_setpoint) and math.isnan(performance.iae_load)
    assert performance.stopped.startswith("set-point test: the process returned nan at t = 51.75; load test:")
    assert performance.setpoint_run.output.size == 690  # the samples before it are kept
