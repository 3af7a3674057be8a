"""The compiled pieces of the IAE (envs.analysis._iae_kernels) against scipy, numpy and the reference path.

The whole compiled IAE (step runs continued over the horizons, areas, sums, settling test, steady
offsets) is checked against the general simulation, bit for bit, in
``tests/unit/fast_paths/test_resumable_runs.py``; here its pieces.  The summation equals ``np.sum`` bit for bit,
over every length class of numpy's pairwise algorithm (``< 8``, ``<= 128``, split in halves) and for
ranges that start anywhere.  The one-step map is cross-checked to rounding (the two paths do the
same exact arithmetic in different orders):

* ``expm`` against ``scipy.linalg.expm`` on random matrices of the sizes and norms of the
  discretization blocks (measured <= 7.4e-12 relative to the largest entry, at norm ~300; the
  blocks of the loops have norms below ~40);
* ``discretize_compiled`` against :func:`envs.simulation.discretization.discretize` (scipy's ``expm`` of the
  ``3n x 3n`` block) on loops of every controller structure, with 0, 1 and 2 delays, whole and
  fractional: ``Phi``, ``Gamma``, ``R`` within ``1e-13`` of their largest entry (measured
  <= 2e-15), whole samples and fractions equal;
* the IAE with either discretization, within ``1e-10`` (measured <= 1.1e-11 on the bench loops:
  the 2000-step recursion amplifies the rounding of the map, most for the fastest loops), the
  reference being the general path (:func:`~envs.simulation.runs.simulate_batch` and
  :func:`~envs.analysis.performance.integrated_absolute_error`) on :func:`~envs.simulation.discretization.discretize`'s map.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg

from envs.analysis._iae_kernels import _pairwise_sum, _steady_offsets, discretize_compiled, expm
from envs.systems.controllers import FPPI, MSP, PID, SeriesPID
from envs.simulation.loops import closed_loop, loop_rows, simulation_step
from envs.analysis.performance import SETTLED_SHARE, iae, integrated_absolute_error
from envs.systems.plants import Plant
from envs.simulation.delay_systems import DelaySystem
from envs.simulation.discretization import discretize
from envs.simulation.runs import simulate_batch

LOOPS = {
    "pi-fopdt": (Plant.from_time_constants(1.0, [1.0], 0.7), PID(0.8, 1.5)),
    "pid-no-dead-time": (Plant.from_time_constants(1.0, [1.0, 0.2], 0.0), PID(2.0, 1.0, 0.2, 10.0)),
    "series-pid-fast": (Plant.from_time_constants(-1.0, [0.15], 0.4), SeriesPID(-3.0, 0.2, 0.14, 10.0)),
    "fppi-two-delays": (Plant(num=[-1.0, 1.0], den=[1.0, 3.0, 3.0, 1.0], dead_time=0.5), FPPI(1.0, 2.5, 1.0, 0.8, 0.8)),
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


def _reference_iae(plant, controller, horizon):
    """``(load, setpoint, settled, dt)`` of the general path on :func:`discretize`'s map at ``horizon``
    (infinite IAE, counted as settled, if a run diverges)."""
    system = closed_loop(plant, controller)
    dt = simulation_step(plant, controller, 50, system=system)
    steps = int(np.ceil(horizon * plant.step_time_scale() / dt)) + 1
    inputs = np.zeros((2, steps, 3))
    inputs[0, :, 1] = 1.0  # load
    inputs[1, :, 0] = 1.0  # set point
    runs = simulate_batch([discretize(system, dt)] * 2, inputs)
    if any(run.diverged for run in runs):
        return np.inf, np.inf, True, dt
    errors = [run.outputs[:, 2] for run in runs]
    totals = [integrated_absolute_error(e, dt) for e in errors]
    tails = [integrated_absolute_error(e[-max(e.size // 10, 2) :], dt) for e in errors]
    return totals[0], totals[1], all(tail <= SETTLED_SHARE * total for tail, total in zip(tails, totals)), dt


@pytest.mark.parametrize("name", LOOPS)
def test_iae_agrees_with_the_reference_discretization(name):
    plant, controller = LOOPS[name]
    fast = iae(plant, controller)
    load, setpoint, settled, dt = _reference_iae(plant, controller, fast.horizon)
    assert (fast.settled, fast.dt) == (settled, dt)
    np.testing.assert_allclose([fast.load, fast.setpoint], [load, setpoint], rtol=1e-10)
    if fast.horizon > 10.0:  # not settled at the horizon before either
        assert not _reference_iae(plant, controller, fast.horizon / 2)[2]


@pytest.mark.parametrize("seed", range(3))
def test_pairwise_sum_equals_numpy_sum(seed):
    rng = np.random.default_rng(seed)
    lengths = list(range(0, 300)) + rng.integers(300, 70_000, 60).tolist()
    for n in lengths:
        values = rng.random(n) * 10.0 ** rng.uniform(-6, 6, n)
        assert _pairwise_sum(values, 0, n) == np.sum(values)
        start = int(rng.integers(0, max(n // 2, 1)))
        assert _pairwise_sum(values, start, n) == np.sum(values[start:])


def _numpy_offsets(system, tolerance=1e-9):
    try:
        gain = system.dc_gain()
    except np.linalg.LinAlgError:
        return False, False
    return bool(abs(gain[2, 1]) > tolerance), bool(abs(gain[2, 0]) > tolerance)


OFFSET_LOOPS = {
    **LOOPS,
    "p-only": (Plant.from_time_constants(1.0, [1.0], 0.5), PID(0.5, None)),
    "pd-integrating": (Plant([1.0], [1.0, 0.0], 1.0), PID(0.3, None, 0.5, 10.0)),
    "p-only-no-dead-time": (Plant.from_time_constants(2.0, [1.0, 0.5], 0.0), PID(1.5, None, 0.2, 10.0)),
}


@pytest.mark.parametrize("name", OFFSET_LOOPS)
def test_steady_offsets_agree_with_numpy_dc_gain(name):
    plant, controller = OFFSET_LOOPS[name]
    rows = loop_rows(plant, controller)
    assert _steady_offsets(*rows[:3], 1e-9) == _numpy_offsets(closed_loop(plant, controller))


def test_steady_offsets_of_a_loop_with_a_pole_at_the_origin_are_left_to_the_simulation():
    """A zero pivot, where ``numpy.linalg.solve`` raises ``LinAlgError``: no offset is decided."""
    derivatives = np.ascontiguousarray(np.hstack([np.zeros((2, 2)), np.ones((2, 3))]))  # A = 0: singular
    outputs = np.ascontiguousarray(np.hstack([np.ones((3, 2)), np.zeros((3, 3))]))
    delayed = np.zeros((0, 5))
    system = DelaySystem(
        derivatives[:, :2], derivatives[:, 2:], np.zeros((2, 0)), outputs[:, :2], outputs[:, 2:], np.zeros((3, 0)),
        np.zeros((0, 2)), np.zeros((0, 3)), np.zeros((0, 0)), np.zeros(0),
    )  # fmt: skip
    with pytest.raises(np.linalg.LinAlgError):
        system.dc_gain()
    assert _steady_offsets(derivatives, outputs, delayed, 1e-9) == (False, False)


def test_products_skipping_zero_entries_are_every_term_summed():
    """``_product`` skips the terms of a zero ``A[i, k]`` where ``B[k]`` is finite: the sums of every
    term in order, bit for bit (signs of zero included), and ``nan`` where ``B[k]`` is not finite."""
    from envs.analysis._iae_kernels import _product

    def every_term(A, B):
        out = [[0.0] * B.shape[1] for _ in range(A.shape[0])]
        for i in range(A.shape[0]):
            for k in range(A.shape[1]):
                for j in range(B.shape[1]):
                    out[i][j] += float(A[i, k]) * float(B[k, j])
        return np.array(out)

    rng = np.random.default_rng(5)
    for trial in range(40):
        n, m, p = rng.integers(1, 9, size=3)
        A, B = rng.normal(size=(n, m)), rng.normal(size=(m, p))
        A[rng.random((n, m)) < 0.5] = 0.0
        A[rng.random((n, m)) < 0.1] = -0.0
        B[rng.random((m, p)) < 0.3] = rng.choice([0.0, -0.0])
        if trial % 4 == 0:
            B[rng.integers(m), rng.integers(p)] = rng.choice([np.inf, -np.inf, np.nan])
        got, expected = _product(A, B), every_term(A, B)
        assert got.tobytes() == expected.tobytes() or np.array_equal(got, expected, equal_nan=True) and np.array_equal(np.signbit(got), np.signbit(expected))
