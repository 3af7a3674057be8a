"""Runs continued over growing horizons against the same runs restarted from the start.

The experiments and the IAE extend a simulation by doubling its horizon until it settles.  They
continue it from the saved state and delay buffer (:class:`envs.simulation.runs.LoopRun`,
:class:`envs.simulation.open_loop.OpenLoopRun`, the compiled closed-loop step of :mod:`envs.simulation._run_kernels`, which
stops at its first steady or aborting sample), and only the new samples are tested for steady state
(:func:`envs.identification.steady_state.steady_state_tail`, :class:`envs.identification.steady_state.SteadyStateTest`).  The recursions and the running sums are causal, so
the results must be those of restarting every horizon from rest, bit for bit: every comparison here
is exact.  The references are the methods the fast paths replaced, written out.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from envs.identification.closed_loop_run import _cumulative_integral, _run_closed_loop
from envs.analysis._iae_kernels import discretize_compiled
from envs.identification.commissioning import commissioning_pi
from envs.systems.controllers import FPPI, MSP, PID, SeriesPID
from envs.identification.experiment_base import excursion_index, run_until_settled
from envs.simulation.loops import closed_loop, closed_loop_of_block, loop_rows, simulation_step
from envs.identification.open_loop_run import _run_to_steady_state
from envs.analysis.performance import (
    OFFSET_TOLERANCE,
    IAEBound,
    _reference_iae,
    iae,
    iae_batch,
    integrated_absolute_error,
)
from envs.systems.plants import Plant
from envs.simulation.discretization import discretize
from envs.simulation.open_loop import OpenLoopRun, open_loop_response
from envs.simulation.runs import LoopRun, simulate, simulate_batch
from envs.identification.steady_state import (
    SteadyStateTest,
    steady_state_mask,
    steady_state_tail,
    window_samples,
)

LOOPS = {
    "pid-fopdt": (Plant.from_time_constants(1.0, [1.0], 0.7), PID(0.8, 1.5)),
    "fppi-nmp": (Plant(num=[-1.0, 1.0], den=[1.0, 3.0, 3.0, 1.0], dead_time=0.5), FPPI(1.0, 2.5, 1.0, 0.8, 0.8)),
    "msp-integrating": (Plant.from_time_constants(1.0, [1.0], 2.0, integrating=True), MSP(1.0, 3.0, 2.0)),
    "unstable-pid": (Plant.from_time_constants(2.0, [1.0], 1.0), PID(5.0, 0.5)),
}


def _equal(a: np.ndarray, b: np.ndarray) -> None:
    np.testing.assert_array_equal(np.asarray(a), np.asarray(b))


@pytest.mark.parametrize("name", LOOPS)
def test_loop_run_continued_equals_simulation_from_rest(name):
    plant, controller = LOOPS[name]
    system = closed_loop(plant, controller)
    discrete = discretize(system, simulation_step(plant, controller, 50, system=system))
    rng = np.random.default_rng(3)
    inputs = np.column_stack([np.ones(3000), np.zeros(3000), 0.01 * rng.standard_normal(3000)])
    inputs[1500:, 2] *= 40.0  # a larger input later raises the divergence limit
    run = LoopRun(discrete, 100)  # buffers grow
    for steps in (7, 100, 101, 700, 1600, 3000):
        continued = run.advance(inputs[:steps])
        restarted = simulate(discrete, inputs[:steps])
        _equal(continued.outputs, restarted.outputs)
        _equal(continued.timepts, restarted.timepts)
        assert continued.diverged == restarted.diverged
        if continued.diverged:  # a run stops at its first divergence (the callers stop there too)
            break
    assert continued.diverged == (name == "unstable-pid")


def test_open_loop_run_continued_equals_response_from_rest():
    plant = Plant(num=[-0.5, 1.0], den=[1.0, 2.2, 1.7, 0.5], dead_time=0.37)
    inputs = np.where(np.arange(2000) < 30, 2.0, 0.0)
    run = OpenLoopRun(plant.state_space(), plant.dead_time, inputs, 0.013)
    for steps in (5, 64, 65, 900, 2000):
        _equal(run.response(steps), open_loop_response(plant.state_space(), plant.dead_time, inputs[:steps], 0.013))


@pytest.mark.parametrize("target", [None, 1.0])
@pytest.mark.parametrize("first", [0, 1, 7, 50, 51, 333, 1999, 2000, 2500])
def test_steady_state_tail_equals_whole_mask(target, first):
    t = np.linspace(0.0, 20.0, 2000)
    y = 1.0 - np.exp(-t / 2.0) + 0.002 * np.random.default_rng(1).standard_normal(t.size)
    _equal(steady_state_tail(y, 50, first, target=target), steady_state_mask(t, y, 50, target=target)[first:])


def _closed_loop_from_rest(plant, controller, amplitude, noise, dt, window, excursion_limit):
    """The closed-loop run restarted: every horizon simulated and tested from the start (the compiled
    run and ``method="reference"`` both continue theirs)."""
    discrete = discretize(closed_loop(plant, controller), dt)

    def trial(steps):
        inputs = np.column_stack([np.full(steps, amplitude), np.zeros(steps), noise[:steps]])
        sim = simulate(discrete, inputs)
        y, u = sim.outputs[:, 0], sim.outputs[:, 1]
        measured = y + noise[:steps]
        finite = int(np.argmax(~np.isfinite(y))) if sim.diverged else steps
        abort = excursion_index(y[:finite], excursion_limit)
        if sim.diverged and abort is None:
            abort = max(finite - 1, 0)
        t = sim.timepts[:finite]
        drive = _cumulative_integral(t, u[:finite]) if plant.integrating else u[:finite]
        both = steady_state_mask(t, measured[:finite], window, target=amplitude) & steady_state_mask(t, drive, window)
        hits = np.flatnonzero(both)
        return sim.timepts, u, measured, y, abort, int(hits[0]) if hits.size else None

    return run_until_settled(trial, max(16 * window, 64), noise.size)


def _same_run(a, b) -> None:
    for field in ("timepts", "control", "output", "true_output"):
        _equal(getattr(a, field)[: a.end + 1], getattr(b, field)[: b.end + 1])
    assert (a.end, a.settled, a.aborted) == (b.end, b.settled, b.aborted)


@pytest.mark.parametrize("noise_std", [0.0, 0.02])
@pytest.mark.parametrize("name", LOOPS)
def test_closed_loop_run_equals_restarted_run(name, noise_std):
    plant, controller = LOOPS[name]
    if name == "pid-fopdt":
        controller = commissioning_pi(plant)
    dt = simulation_step(plant, controller, 200)
    window = window_samples(plant.step_time_scale(), dt)
    noise = noise_std * np.random.default_rng(5).standard_normal(6000)
    for limit in (None, 1.5):
        args = (plant, controller, 1.0, noise, dt, window, limit)
        restarted = _closed_loop_from_rest(*args)
        _same_run(_run_closed_loop(*args), restarted)
        _same_run(_run_closed_loop(*args, method="reference"), restarted)


@pytest.mark.parametrize("noise_std", [0.0, 0.02])
@pytest.mark.parametrize("start", [0, 300])
def test_open_loop_run_equals_restarted_run(noise_std, start):
    plant = Plant(num=[1.0], den=[2.0, 3.0, 1.0], dead_time=0.4)
    dt, window = 0.01, 120
    inputs = np.where(np.arange(8000) < 40, 1.5, 0.0) + 0.5
    noise = noise_std * np.random.default_rng(6).standard_normal(inputs.size)

    def trial(steps):
        y = open_loop_response(plant.state_space(), plant.dead_time, inputs[:steps], dt)
        t = np.arange(steps) * dt
        measured = y + noise[:steps]
        hits = np.flatnonzero(steady_state_mask(t, measured, window)[start:])
        return t, inputs[:steps], measured, y, None, int(hits[0]) + start if hits.size else None

    restarted = run_until_settled(trial, max(start + 6 * window, 16), inputs.size)
    _same_run(_run_to_steady_state(plant, inputs, noise, dt, window, start, None), restarted)
    assert restarted.settled


IAE_LOOPS = {
    **LOOPS,
    "slowly-settling-pi": (Plant.from_time_constants(1.0, [3.0, 1.0], 0.2), PID(0.3, 100.0)),
    "p-only-offset": (Plant.from_time_constants(1.0, [1.0], 0.5), PID(0.5, None)),
    "pd-integrating-load-offset": (Plant([1.0], [1.0, 0.0], 1.0), PID(0.3, None, 0.5, 10.0)),
    "no-dead-time-fppi": (Plant.from_time_constants(1.0, [2.0, 0.5], 0.0), FPPI(1.0, 2.3, 0.2, 1.0, 1.0)),
    "series-pid-fast-filter": (Plant.from_time_constants(-2.0, [1.0, 0.3], 0.4), SeriesPID(-0.8, 1.2, 0.3, 10.0)),
    "msp-extension": (Plant.from_time_constants(2.0, [0.3, 0.3], 1.2, integrating=True), MSP(2.0, 1.5, 2.0, True)),
}


@pytest.mark.parametrize("name", IAE_LOOPS)
def test_iae_equals_simulation_from_rest(name):
    """The compiled IAE (envs.analysis._iae_kernels), the runs continued over the horizons, gives the IAE of
    the general path (``iae(..., method="reference")``) on the same one-step map bit for bit."""
    plant, controller = IAE_LOOPS[name]
    assert iae(plant, controller) == _reference_iae(plant, controller, 50, None, discretization=discretize_compiled)


@pytest.mark.parametrize("name", IAE_LOOPS)
@pytest.mark.parametrize("budget", [None, 0.5, 5.0])
def test_iae_reference_method_equals_compiled(name, budget):
    """``method="reference"`` (the map of ``discretize``) against the compiled path: the maps agree to
    ``1e-12`` (tests/unit/fast_paths/test_iae_kernels.py), the IAE within ``1e-10`` relative (the module
    docstring of envs.analysis.performance; measured <= 1.1e-11); the horizons and verdicts exactly."""
    plant, controller = IAE_LOOPS[name]
    bound = None if budget is None else IAEBound(1.0, 1.0, budget)
    fast, reference = iae(plant, controller, bound=bound), iae(plant, controller, bound=bound, method="reference")
    assert (fast.settled, fast.horizon, fast.dt, fast.lower_bound) == (
        reference.settled, reference.horizon, reference.dt, reference.lower_bound,
    )  # fmt: skip
    assert fast.load == pytest.approx(reference.load, rel=1e-10)
    assert fast.setpoint == pytest.approx(reference.setpoint, rel=1e-10)


def test_iae_refuses_unknown_method():
    plant, controller = LOOPS["pid-fopdt"]
    with pytest.raises(ValueError, match="method must be"):
        iae(plant, controller, method="fast")


def test_iae_batch_equals_single_loops():
    plants = [p for p, _ in IAE_LOOPS.values()]
    controllers = [c for _, c in IAE_LOOPS.values()]
    assert OFFSET_TOLERANCE > 0
    fast = iae_batch(plants, controllers)
    assert fast == [iae(p, c) for p, c in zip(plants, controllers)]
    assert len({r.horizon for r in fast}) > 1
    assert any(math.isinf(r.load) for r in fast) and any(math.isfinite(r.load) for r in fast)


@pytest.mark.parametrize("target", [None, 1.0])
def test_steady_state_test_extended_equals_whole_mask(target):
    rng = np.random.default_rng(11)
    for _ in range(60):
        window = int(rng.integers(3, 120))
        size = int(rng.integers(2 * window, 2500))
        t = np.arange(size) * 0.01
        y = 1.0 - np.exp(-t / rng.uniform(0.1, 5.0)) + rng.uniform(0.0, 0.01) * rng.standard_normal(size)
        test = SteadyStateTest(window, target=target)
        cuts = sorted(set(rng.integers(1, size, 6).tolist() + [size]))
        extended = np.concatenate([test.extend(y[:cut]) for cut in cuts])
        _equal(extended, steady_state_mask(t, y, window, target=target))


@pytest.mark.parametrize("name", LOOPS)
def test_closed_loop_of_block_equals_closed_loop(name):
    plant, controller = LOOPS[name]
    built, reference = closed_loop_of_block(plant, controller.block()), closed_loop(plant, controller)
    for field in ("A", "B1", "B2", "C1", "D11", "D12", "C2", "D21", "D22", "delays"):
        _equal(getattr(built, field), getattr(reference, field))


@pytest.mark.parametrize("name", IAE_LOOPS)
def test_loop_rows_are_the_matrices_of_closed_loop(name):
    """The IAE's unsplit rows (C-contiguous, for the compiled call) hold the loop's matrices."""
    plant, controller = IAE_LOOPS[name]
    rows, reference = loop_rows(plant, controller), closed_loop(plant, controller)
    n = reference.n_states
    for matrix, fields in zip(rows[:3], (("A", "B1", "B2"), ("C1", "D11", "D12"), ("C2", "D21", "D22"))):
        assert matrix.flags.c_contiguous and matrix.dtype == np.float64
        for part, field in zip(np.hsplit(matrix, (n, n + 3)), fields):
            _equal(part, getattr(reference, field))
    _equal(rows[3], reference.delays)
