"""The compiled one-step map (envs.compiled_discretization) against scipy and the reference path.

Cross-checks, all to rounding (the two paths do the same exact arithmetic in different orders):

* ``expm`` against ``scipy.linalg.expm`` on random matrices of the sizes and norms of the
  discretization blocks (measured <= 7.4e-12 relative to the largest entry, at norm ~300; the
  blocks of the loops have norms below ~40);
* ``discretize_compiled`` against :func:`envs.simulation.discretize` (scipy's ``expm`` of the
  ``3n x 3n`` block) on loops of every controller structure, with 0, 1 and 2 delays, whole and
  fractional: ``Phi``, ``Gamma``, ``R`` within ``1e-13`` of their largest entry (measured
  <= 2e-15), whole samples and fractions equal;
* the IAE with either discretization, within ``1e-10`` (measured <= 1.1e-11 on the bench loops:
  the 2000-step recursion amplifies the rounding of the map, most for the fastest loops).
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

import envs.performance
from envs.compiled_discretization import discretize_compiled, expm
from envs.controllers import FPPI, MSP, PID, SeriesPID
from envs.loops import closed_loop, simulation_step
from envs.performance import iae
from envs.plants import Plant
from envs.simulation import discretize

LOOPS = {
    "pi-fopdt": (Plant.from_time_constants(1.0, [1.0], 0.7), PID(0.8, 1.5)),
    "pid-no-dead-time": (Plant.from_time_constants(1.0, [1.0, 0.2], 0.0), PID(2.0, 1.0, 0.2, 10.0)),
    "series-pid-fast": (Plant.from_time_constants(-1.0, [0.15], 0.4), SeriesPID(-3.0, 0.2, 0.14, 10.0)),
    "fppi-two-delays": (Plant(num=[-1.0, 1.0], den=[1.0, 3.0, 3.0, 1.0], delay=0.5), FPPI(1.0, 2.5, 1.0, 0.8, 0.8)),
    "fppi-tiny-time-constants": (Plant.from_time_constants(0.22, [0.02, 0.01], 0.1), FPPI(0.22, 0.0225, 0.1036, 0.0112, 0.0112)),
    "fppi-whole-delay": (Plant.from_time_constants(1.0, [1.0], 1.0), FPPI(1.0, 1.0, 1.0, 0.5, 0.5)),
    "msp": (Plant.from_time_constants(1.0, [1.0], 2.0, integrating=True), MSP(1.0, 3.0, 2.0)),
    "msp-extension": (Plant.from_time_constants(2.0, [0.3, 0.3], 1.2, integrating=True), MSP(2.0, 1.5, 2.0, True)),
    "lag-chain": (Plant.from_time_constants(1.0, [0.5] * 5, 0.3), FPPI(1.0, 2.2, 0.9, 1.1, 1.1)),
}


@pytest.mark.parametrize("size", [1, 2, 5, 9, 14, 21])
@pytest.mark.parametrize("norm", [1e-3, 0.2, 1.0, 4.0, 40.0])
def test_expm_agrees_with_scipy(size, norm):
    rng = np.random.default_rng(size)
    A = rng.standard_normal((size, size))
    A *= norm / np.max(np.sum(np.abs(A), axis=0))
    expected = scipy.linalg.expm(A)
    assert np.max(np.abs(expm(A) - expected)) <= 1e-12 * np.max(np.abs(expected))


def test_expm_of_a_nilpotent_block_is_its_integral():
    """``e^{[[0, T], [0, 0]]} = [[1, T], [0, 1]]``: the integral blocks of the discretization."""
    np.testing.assert_allclose(expm(np.array([[0.0, 2.5], [0.0, 0.0]])), [[1.0, 2.5], [0.0, 1.0]], rtol=1e-15)


@pytest.mark.parametrize("name", LOOPS)
def test_discretize_compiled_agrees_with_discretize(name):
    plant, controller = LOOPS[name]
    system = closed_loop(plant, controller)
    for samples in (50, 13):
        dt = simulation_step(plant, controller, samples, system=system)
        reference, compiled = discretize(system, dt), discretize_compiled(system, dt)
        for field in ("Phi", "Gamma", "R"):
            expected, actual = getattr(reference, field), getattr(compiled, field)
            assert actual.shape == expected.shape
            assert np.max(np.abs(actual - expected), initial=0.0) <= 1e-13 * max(np.max(np.abs(expected), initial=0.0), 1e-300)
        np.testing.assert_array_equal(compiled.whole_samples, reference.whole_samples)
        np.testing.assert_array_equal(compiled.fraction, reference.fraction)
        assert compiled.dt == reference.dt and compiled.system is system


def test_discretize_compiled_refuses_what_discretize_refuses():
    system = closed_loop(*LOOPS["pi-fopdt"])
    for dt in (0.0, -1.0, np.inf, 0.8):  # 0.8 > the dead time 0.7
        with pytest.raises(ValueError) as expected:
            discretize(system, dt)
        with pytest.raises(ValueError, match=str(expected.value)[:20]):
            discretize_compiled(system, dt)


@pytest.mark.parametrize("name", LOOPS)
def test_iae_agrees_with_the_reference_discretization(name, monkeypatch):
    plant, controller = LOOPS[name]
    fast = iae(plant, controller)
    monkeypatch.setattr(envs.performance, "discretize_compiled", discretize)
    reference = iae(plant, controller)
    assert (fast.settled, fast.horizon, fast.dt) == (reference.settled, reference.horizon, reference.dt)
    np.testing.assert_allclose([fast.load, fast.setpoint], [reference.load, reference.setpoint], rtol=1e-10)
