"""Closed loops of a plant and a controller: assembly, frequency responses, time responses.

The loop is ``y = G e^{-L s} (u + l)``, ``u = C_ff r - C_fb (y + n)``: load ``l`` at the plant
input, set point ``r``, measurement noise ``n``.  For simulation the plant's dead time is placed at
its output (an equivalent position for a linear loop), so that every delayed signal is the output
of a strictly proper block and the first-order-hold reconstruction of
:mod:`envs.simulation.delay_systems` is accurate; inputs ``[r, l, n]`` are held over each sample (exact).
"""

from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from envs.systems.controllers import Controller, packed_block
from envs.systems.plants import Plant
from envs.simulation.delay_systems import DelaySystem
from envs.simulation.discretization import discretize
from envs.simulation.runs import simulate

__all__ = [
    "closed_loop",
    "loop_rows",
    "loop_response",
    "ClosedLoopResponse",
    "closed_loop_response",
    "simulation_step",
    "sample_time",
    "INPUTS",
    "OUTPUTS",
]

INPUTS = ("setpoint", "load", "noise")
OUTPUTS = ("output", "control", "error")


def loop_response(plant: Plant, controller: Controller, omega: np.ndarray) -> np.ndarray:
    """Exact loop transfer ``L(i omega) = P(i omega) C_fb(i omega)``."""
    return plant.frequency_response(omega) * controller.feedback_response(omega)


def closed_loop(plant: Plant, controller: Controller) -> DelaySystem:
    """The closed loop as a :class:`DelaySystem` with inputs ``[r, l, n]`` and outputs ``[y, u, e]``.

    ``e = r - y`` is the control error on the true (noise-free) output.
    """
    return closed_loop_of_block(plant, controller.block())


def closed_loop_of_block(plant: Plant, cb) -> DelaySystem:
    """:func:`closed_loop` from the controller's ``block()``, for a caller that already has it."""
    derivatives, outputs, delayed, delays = _rows(plant, cb)
    n, m = derivatives.shape[0], derivatives.shape[0] + 3  # the columns of x, d = [r, l, n] and v

    def matrices(rows: np.ndarray) -> tuple[np.ndarray, ...]:
        return rows[:, :n], rows[:, n:m], rows[:, m:]  # the views of np.hsplit(rows, (n, m))

    return DelaySystem(*matrices(derivatives), *matrices(outputs), *matrices(delayed), delays)


def loop_rows(plant: Plant, controller: Controller) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The matrices of :func:`closed_loop` as rows over ``[x, d, v]``, unsplit (for compiled code).

    Returns ``([A, B1, B2], [C1, D11, D12], [C2, D21, D22], delays)``, C-contiguous float arrays.
    With a plant dead time, the controller's block comes as one array
    (:func:`~envs.systems.controllers.packed_block`) and the rows of :func:`_delayed_plant_rows` are filled
    in by the same kernel: the same numbers, in about a third of the time (the ten matrices of
    ``block()``, their conversions and the fifteen arguments each cost about a microsecond).
    """
    delay = plant.simulation_dead_time
    if delay > 0:
        ps, f = plant.state_space(), _contiguous
        flat, n_c, n_vc = packed_block(controller)
        return _fill_from_packed_block(f(ps.A), f(ps.B), f(ps.C), float(ps.D[0, 0]), float(delay), flat, n_c, n_vc)
    return _rows(plant, controller.block())


def _rows(plant: Plant, cb) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`loop_rows` from the controller's ``block()``.

    Without a plant dead time the plant output ``y = C_p x_p + D_p (u + l)`` enters the controller
    directly, so the loop can have an algebraic part, solved here; with one, the rows are those of
    :func:`_delayed_plant_rows`.  A negligible dead time counts as none (:attr:`Plant.simulation_dead_time`).
    """
    ps = plant.state_space()
    if plant.simulation_dead_time > 0:
        return _delayed_plant_rows(ps, plant.simulation_dead_time, cb)
    n_p, n_c = ps.A.shape[0], cb.n_states
    n_x = n_p + n_c
    # Each signal is a row of coefficients over [x_p, x_c, r, l, n, v_c] (see SystemBuilder).
    basis = np.eye(n_x + 3 + cb.delays.size)
    xp, xc, vc = basis[:n_p], basis[n_p:n_x], basis[n_x + 3 :]
    r, load, noise = basis[n_x], basis[n_x + 1], basis[n_x + 2]
    zero = np.zeros(basis.shape[0])

    def controller_rows(y_measured: np.ndarray, M: np.ndarray, N: np.ndarray, P: np.ndarray) -> np.ndarray:
        """Rows of ``M x_c + N [r, y_m] + P v_c`` for a controller matrix triple."""
        return M @ xc + np.outer(N[:, 0], r) + np.outer(N[:, 1], y_measured) + P @ vc

    plant_free = (ps.C @ xp).ravel()  # C_p x_p
    d_p = float(ps.D[0, 0])
    # u = a + k_y * y_m where a collects everything but the measured output.
    u_base = controller_rows(zero, cb.C1, cb.D11, cb.D12).ravel()
    k_y = float(cb.D11[0, 1])
    # y = C_p x_p + D_p (u + l), u = u_base + k_y (y + n): solve the algebraic loop.
    denominator = 1.0 - k_y * d_p
    if abs(denominator) < 1e-12:
        raise ValueError("the loop has an ill-posed algebraic loop (1 - D_c D_p = 0)")
    y = (plant_free + d_p * (u_base + k_y * noise + load)) / denominator
    u = u_base + k_y * (y + noise)
    plant_input = u + load
    derivatives = np.vstack([ps.A @ xp + np.outer(ps.B[:, 0], plant_input), controller_rows(y + noise, cb.A, cb.B1, cb.B2)])
    delayed = controller_rows(y + noise, cb.C2, cb.D21, cb.D22)
    delays = np.array(cb.delays, dtype=float)
    outputs = np.vstack([y, u, r - y])
    return derivatives, outputs, np.ascontiguousarray(delayed, dtype=float), delays


def _delayed_plant_rows(ps, delay: float, cb) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_rows` for a plant with a dead time, written out (the same numbers).

    The plant output is then the delayed signal ``v_p``, so the loop has no algebraic part: with
    ``u = C1c x_c + D11c [r, v_p + n] + D12c v_c`` and ``u_p = u + l``,

    * ``x_p' = A_p x_p + B_p u_p``,  ``x_c' = A_c x_c + B1c [r, v_p + n] + B2c v_c``;
    * outputs ``y = v_p``, ``u``, ``e = r - v_p``;
    * delayed signals ``w_p = C_p x_p + D_p u_p`` (delay ``L``) and
      ``w_c = C2c x_c + D21c [r, v_p + n] + D22c v_c``.

    Every coefficient is one entry or one product of the plant's and the controller's matrices;
    they are filled in by one compiled call (:func:`_fill_delayed_plant_rows`, a few microseconds
    instead of some forty numpy calls).
    """
    f = _contiguous
    return _fill_delayed_plant_rows(
        f(ps.A), f(ps.B), f(ps.C), float(ps.D[0, 0]), float(delay), f(cb.A), f(cb.B1), f(cb.B2), f(cb.C1), f(cb.D11),
        f(cb.D12), f(cb.C2), f(cb.D21), f(cb.D22), f(cb.delays),
    )  # fmt: skip


def _contiguous(array: np.ndarray) -> np.ndarray:
    """``array`` as C-contiguous floats (itself if it is): one compiled signature for every loop."""
    return np.ascontiguousarray(array, dtype=float)


@numba.njit(cache=True)
def _fill_delayed_plant_rows(A_p, B_p, C_p, d_p, delay, A_c, B1_c, B2_c, C1_c, D11_c, D12_c, C2_c, D21_c, D22_c, delays_c):  # pragma: no cover
    """The rows and delays of :func:`_delayed_plant_rows` (plant ``A_p, B_p, C_p, d_p``, controller block
    ``A_c .. D22_c``), the same products as with numpy."""
    n_p, n_c, n_vc = A_p.shape[0], A_c.shape[0], delays_c.size
    n_x = n_p + n_c
    size = n_x + 4 + n_vc
    outputs = np.zeros((3, size))  # y, u, e
    _controller_rows(outputs[1:2], C1_c, D11_c, D12_c, n_p)
    v_p = n_x + 3  # the columns are [x_p, x_c, r, l, n, v_p, v_c]
    outputs[0, v_p], outputs[2, n_x], outputs[2, v_p] = 1.0, 1.0, -1.0
    plant_input = outputs[1].copy()
    plant_input[n_x + 1] = 1.0  # u_p = u + l
    derivatives = np.zeros((n_x, size))
    for i in range(n_p):
        for j in range(size):
            derivatives[i, j] = A_p[i, j] if j < n_p else B_p[i, 0] * plant_input[j]  # A_p x_p + B_p u_p
    _controller_rows(derivatives[n_p:], A_c, B1_c, B2_c, n_p)
    delayed = np.zeros((1 + n_vc, size))
    for j in range(size):
        delayed[0, j] = C_p[0, j] if j < n_p else d_p * plant_input[j]  # C_p x_p + D_p u_p
    _controller_rows(delayed[1:], C2_c, D21_c, D22_c, n_p)
    delays = np.empty(1 + n_vc)
    delays[0] = delay
    for i in range(n_vc):
        delays[1 + i] = delays_c[i]
    return derivatives, outputs, delayed, delays


@numba.njit(cache=True)
def _fill_from_packed_block(A_p, B_p, C_p, d_p, delay, flat, n_c, n_vc):  # pragma: no cover - compiled
    """:func:`_fill_delayed_plant_rows` with the controller block as
    :func:`~envs.systems.controllers.packed_block` gives it (its matrices copied out, C-contiguous, so
    that the kernel is the one of :func:`_delayed_plant_rows`, with the same signature)."""
    shapes = ((n_c, n_c), (n_c, 2), (n_c, n_vc), (1, n_c), (1, 2), (1, n_vc), (n_vc, n_c), (n_vc, 2), (n_vc, n_vc))
    matrices, start = [], 0
    for rows, columns in shapes:
        matrices.append(flat[start : start + rows * columns].copy().reshape((rows, columns)))
        start += rows * columns
    A_c, B1_c, B2_c, C1_c, D11_c, D12_c, C2_c, D21_c, D22_c = matrices
    delays_c = flat[start : start + n_vc].copy()
    return _fill_delayed_plant_rows(A_p, B_p, C_p, d_p, delay, A_c, B1_c, B2_c, C1_c, D11_c, D12_c, C2_c, D21_c, D22_c, delays_c)


@numba.njit(cache=True)
def _controller_rows(rows, M, N, P, n_p):  # pragma: no cover - compiled
    """Fill ``rows`` (zero) with the coefficients of ``M x_c + N [r, v_p + n] + P v_c`` (explicit
    loops: they compile several times faster than numba's slice assignments)."""
    n_x = n_p + M.shape[1]
    for i in range(rows.shape[0]):
        for c in range(M.shape[1]):
            rows[i, n_p + c] = M[i, c]
        for c in range(P.shape[1]):
            rows[i, n_x + 4 + c] = P[i, c]
        rows[i, n_x], rows[i, n_x + 2], rows[i, n_x + 3] = N[i, 0], N[i, 1], N[i, 1]


def simulation_step(
    plant: Plant, controller: Controller, samples_per_residence_time: int = 50, *, system: DelaySystem | None = None
) -> float:
    """The sample time used for closed-loop simulation.

    ``T_ar / samples_per_residence_time`` (``T_ar`` of the true plant), reduced if needed so that
    every dead time in the loop spans at least one sample (a negligible plant dead time is none,
    :data:`envs.systems.plants.NEGLIGIBLE_DEAD_TIME`) (the recursion of
    :func:`envs.simulation.discretization.discretize` is explicit then).  ``system`` is the loop's
    :func:`closed_loop`, if already built.
    """
    return sample_time(plant, (closed_loop(plant, controller) if system is None else system).delays, samples_per_residence_time)


def sample_time(plant: Plant, delays: np.ndarray, samples_per_residence_time: int = 50) -> float:
    """:func:`simulation_step` of a loop of ``plant`` whose delays are ``delays``."""
    dt = plant.step_time_scale() / samples_per_residence_time
    return float(min(dt, delays.min())) if delays.size else dt


@dataclass(frozen=True)
class ClosedLoopResponse:
    """Sampled closed-loop signals: output ``y``, control ``u`` and error ``e = r - y``."""

    timepts: np.ndarray
    output: np.ndarray
    control: np.ndarray
    error: np.ndarray
    diverged: bool


def closed_loop_response(
    plant: Plant,
    controller: Controller,
    steps: int,
    dt: float,
    *,
    setpoint: np.ndarray | float = 0.0,
    load: np.ndarray | float = 0.0,
    noise: np.ndarray | float = 0.0,
) -> ClosedLoopResponse:
    """Simulate the loop for ``steps`` samples of ``dt`` from rest.

    ``setpoint``, ``load`` and ``noise`` are scalars (steps at ``t = 0``) or arrays of one value per
    sample, held over the sample interval.  A diverging loop stops early (``diverged=True``, the
    rest ``nan``); it is never an overflow.
    """
    steps = int(steps)
    inputs = np.empty((steps, 3))
    for k, signal in enumerate((setpoint, load, noise)):
        inputs[:, k] = np.broadcast_to(np.asarray(signal, dtype=float), (steps,))
    result = simulate(discretize(closed_loop(plant, controller), dt), inputs)
    y, u, e = result.outputs.T
    return ClosedLoopResponse(result.timepts, y, u, e, result.diverged)
