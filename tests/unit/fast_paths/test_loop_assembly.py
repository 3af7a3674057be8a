"""The assembly of closed loops and controller blocks against the row algebra it replaced.

:func:`envs.simulation.loops.closed_loop` writes the loop of a plant with a dead time out as block matrices,
the PID blocks build scipy's controller canonical form directly, and the FPPI and MSP blocks do
their row algebra in one compiled call.  The experiments simulate these matrices too, so they must
be the same numbers as before, bit for bit: the references below are the previous implementations
(:class:`envs.simulation.delay_systems.SystemBuilder` rows and ``scipy.signal.tf2ss``), written out.
"""

from __future__ import annotations

import numpy as np
import pytest
import scipy.signal

from envs.systems.controllers import FPPI, MSP, PID, SeriesPID, packed_block
from envs.simulation.loops import _rows, closed_loop, closed_loop_of_block, loop_rows, sample_time
from envs.systems.plants import Plant
from envs.simulation.delay_systems import DelaySystem, SystemBuilder

FIELDS = ("A", "B1", "B2", "C1", "D11", "D12", "C2", "D21", "D22", "delays")


def _reference_rational_block(num, den) -> DelaySystem:
    A, B, C, D = scipy.signal.tf2ss(num, den)
    n = len(np.trim_zeros(np.asarray(den, dtype=float), "f")) - 1
    b = SystemBuilder(n_states=n, n_inputs=2, n_delays=0)
    error = b.input(0) - b.input(1)
    states = [b.state(i) for i in range(n)]
    derivatives = [sum((A[i, k] * states[k] for k in range(n)), b.zero()) + B[i, 0] * error for i in range(n)]
    output = sum((C[0, k] * states[k] for k in range(n)), b.zero()) + D[0, 0] * error
    return b.build(derivatives, [output], [], [])


def _reference_closed_loop(plant: Plant, cb: DelaySystem) -> DelaySystem:
    ps = plant.state_space()
    n_p, n_c = ps.A.shape[0], cb.n_states
    plant_delayed = plant.dead_time > 0
    n_vp = 1 if plant_delayed else 0
    n_vc = cb.delays.size
    b = SystemBuilder(n_states=n_p + n_c, n_inputs=3, n_delays=n_vp + n_vc)
    xp = np.array([b.state(i) for i in range(n_p)]).reshape(n_p, b.size)
    xc = np.array([b.state(n_p + i) for i in range(n_c)]).reshape(n_c, b.size)
    r, load, noise = b.input(0), b.input(1), b.input(2)
    vc = np.array([b.delayed(n_vp + i) for i in range(n_vc)]).reshape(n_vc, b.size)

    def controller_rows(y_measured, M, N, P):
        return M @ xc + np.outer(N[:, 0], r) + np.outer(N[:, 1], y_measured) + P @ vc

    plant_free = (ps.C @ xp).ravel()
    d_p = float(ps.D[0, 0])
    u_base = controller_rows(b.zero(), cb.C1, cb.D11, cb.D12).ravel()
    k_y = float(cb.D11[0, 1])
    if plant_delayed:
        y = b.delayed(0)
    else:
        y = (plant_free + d_p * (u_base + k_y * noise + load)) / (1.0 - k_y * d_p)
    u = u_base + k_y * (y + noise)
    plant_input = u + load
    derivatives = list(ps.A @ xp + np.outer(ps.B[:, 0], plant_input))
    derivatives += list(controller_rows(y + noise, cb.A, cb.B1, cb.B2))
    delayed = []
    if plant_delayed:
        delayed.append(plant_free + d_p * plant_input)
    delayed += list(controller_rows(y + noise, cb.C2, cb.D21, cb.D22))
    delays = ([plant.dead_time] if plant_delayed else []) + list(cb.delays)
    return b.build(derivatives, [y, u, r - y], delayed, delays)


def _same(actual: DelaySystem, expected: DelaySystem) -> None:
    for field in FIELDS:
        a, e = getattr(actual, field), getattr(expected, field)
        assert a.shape == e.shape, field
        np.testing.assert_array_equal(a, e, err_msg=field)


PLANTS = {
    "fopdt": Plant.from_time_constants(1.7, [3.0], 1.4),
    "sopdt-negative": Plant.from_time_constants(-0.4, [2.0, 0.7], 0.3),
    "nmp-third-order": Plant(num=[-1.0, 1.0], den=[1.0, 3.0, 3.0, 1.0], dead_time=0.5),
    "biproper": Plant(num=[0.5, 1.0], den=[2.0, 1.0], dead_time=0.7),
    "integrating": Plant.from_time_constants(1.3, [0.4], 1.0, integrating=True),
    "static-gain": Plant([2.0], [1.0], 0.5),
    "no-dead-time": Plant.from_time_constants(1.0, [1.0, 0.2], 0.0),
    "biproper-no-dead-time": Plant(num=[0.5, 1.0], den=[1.0, 2.0], dead_time=0.0),
}
CONTROLLERS = {
    "pi": PID(0.8, 1.5),
    "pid": PID(1.2, 2.0, 0.4, 8.0),
    "p": PID(-0.4, None),
    "pd": PID(0.3, None, 0.5, 10.0),
    "series-pid": SeriesPID(0.7, 1.8, 0.5, 10.0),
    "series-pi": SeriesPID(2.0, 0.3),
    "tiny-gain-pi": SeriesPID(7.5e-11, 1.1e-10),
    "fppi": FPPI(1.0, 2.5, 1.0, 0.8, 0.8),
    "ppi": FPPI(-2.0, 1.0, 3.0, 2.0, 0.0),
    "fppi-no-dead-time": FPPI(1.0, 1.0, 0.0, 0.5, 0.5),
    "ppi-no-dead-time": FPPI(0.7, 2.0, 0.0, 1.5, 0.0),
    "msp": MSP(1.0, 3.0, 2.0),
    "msp-extension": MSP(2.0, 1.5, 2.0, True),
}


@pytest.mark.parametrize("controller", [c for c in CONTROLLERS.values() if isinstance(c, (PID, SeriesPID))], ids=lambda c: repr(c))
def test_pid_blocks_equal_tf2ss_rows(controller):
    _same(controller.block(), _reference_rational_block(*controller.transfer_function()))


def _reference_fppi_block(c: FPPI) -> DelaySystem:
    filtered = c.tf > 0
    delayed = c.dead_time > 0
    b = SystemBuilder(n_states=3 if filtered else 2, n_inputs=2, n_delays=1 if delayed else 0)
    integral, model = b.state(0), b.state(1)
    r, y = b.input(0), b.input(1)
    model_delayed = b.delayed(0) if delayed else model
    correction = b.state(2) if filtered else y - model_delayed
    error = r - model - correction
    k, ti = c.proportional_gain, c.time_constant
    u = k * error + (k / ti) * integral
    derivatives = [error, (c.gain * u - model) / c.time_constant]
    if filtered:
        derivatives.append((y - model_delayed - b.state(2)) / c.tf)
    delayed_signals = [model] if delayed else []
    return b.build(derivatives, [u], delayed_signals, [c.dead_time] if delayed else [])


def _reference_msp_block(c: MSP) -> DelaySystem:
    b = SystemBuilder(n_states=2 if c.extension else 1, n_inputs=2, n_delays=1)
    model, r, y = b.state(0), b.input(0), b.input(1)
    disturbance = y - b.delayed(0)
    u_r = c.kr * (r - model - disturbance)
    derivatives = [c.gain * u_r]
    if c.extension:
        lead = c.derivative_time / 10
        derivatives.append((disturbance - b.state(1)) / lead)
        correction = c.k0 * (10 * disturbance - 9 * b.state(1))
    else:
        correction = c.k0 * disturbance
    return b.build(derivatives, [u_r - correction], [model], [c.dead_time])


@pytest.mark.parametrize("controller", [c for c in CONTROLLERS.values() if isinstance(c, (FPPI, MSP))], ids=lambda c: repr(c))
def test_fppi_and_msp_blocks_equal_builder_rows(controller):
    """The same bytes (signed zeros included) as the :class:`SystemBuilder` rows."""
    reference = (_reference_fppi_block if isinstance(controller, FPPI) else _reference_msp_block)(controller)
    block = controller.block()
    for field in FIELDS:
        actual, expected = getattr(block, field), getattr(reference, field)
        assert actual.shape == expected.shape and actual.tobytes() == np.ascontiguousarray(expected).tobytes(), field


@pytest.mark.parametrize("controller_name", CONTROLLERS)
@pytest.mark.parametrize("plant_name", PLANTS)
def test_closed_loop_equals_row_algebra(plant_name, controller_name):
    plant, controller = PLANTS[plant_name], CONTROLLERS[controller_name]
    block = controller.block()
    _same(closed_loop_of_block(plant, block), _reference_closed_loop(plant, block))
    _same(closed_loop(plant, controller), _reference_closed_loop(plant, block))


@pytest.mark.parametrize("controller_name", CONTROLLERS)
@pytest.mark.parametrize("plant_name", PLANTS)
def test_loop_rows_from_packed_block_equal_those_of_the_block(plant_name, controller_name):
    """loop_rows (the controller's block packed into one array) against the rows of its block()."""
    plant, controller = PLANTS[plant_name], CONTROLLERS[controller_name]
    flat, n_states, n_delays = packed_block(controller)
    block = controller.block()
    matrices = (block.A, block.B1, block.B2, block.C1, block.D11, block.D12, block.C2, block.D21, block.D22, block.delays)
    assert (n_states, n_delays) == (block.n_states, block.delays.size)
    assert flat.tobytes() == np.concatenate([np.ravel(m) for m in matrices]).tobytes()
    for actual, expected in zip(loop_rows(plant, controller), _rows(plant, block)):
        assert actual.shape == expected.shape and actual.flags.c_contiguous
        assert actual.tobytes() == expected.tobytes()


@pytest.mark.parametrize("delays", [[], [0.7], [0.02, 3.0], [1e-300, 2.0], [np.nan, 0.5], [0.5, np.nan], [0.0, 1.0], [-0.0, 0.3], [np.inf]])
def test_sample_time_equals_the_numpy_minimum(delays):
    """sample_time against float(min(dt, delays.min())) (nan and signed zeros too)."""
    plant = PLANTS["fopdt"]
    delays = np.array(delays, dtype=float)
    dt = plant.step_time_scale() / 50
    expected = float(min(dt, delays.min())) if delays.size else dt
    assert repr(sample_time(plant, delays)) == repr(expected)
