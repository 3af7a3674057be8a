"""Closed loops of a plant and a controller: assembly, frequency responses, time responses.

The loop is ``y = G e^{-L s} (u + l)``, ``u = C_ff r - C_fb (y + n)``: load ``l`` at the plant
input, set point ``r``, measurement noise ``n``.  For simulation the plant's dead time is placed at
its output (an equivalent position for a linear loop), so that every delayed signal is the output
of a strictly proper block and the first-order-hold reconstruction of
:mod:`envs.simulation` is accurate; inputs ``[r, l, n]`` are held over each sample (exact).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from envs.controllers import Controller
from envs.plants import Plant
from envs.simulation import DelaySystem, SystemBuilder, discretize, simulate

__all__ = [
    "closed_loop",
    "loop_response",
    "ClosedLoopResponse",
    "closed_loop_response",
    "simulation_step",
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
    ps = plant.state_space()
    n_p, n_c = ps.A.shape[0], cb.n_states
    plant_delayed = plant.delay > 0
    n_vp = 1 if plant_delayed else 0
    n_vc = cb.delays.size
    b = SystemBuilder(n_states=n_p + n_c, n_inputs=3, n_delays=n_vp + n_vc)
    xp = np.array([b.state(i) for i in range(n_p)]).reshape(n_p, b.size)
    xc = np.array([b.state(n_p + i) for i in range(n_c)]).reshape(n_c, b.size)
    r, load, noise = b.input(0), b.input(1), b.input(2)
    vc = np.array([b.delayed(n_vp + i) for i in range(n_vc)]).reshape(n_vc, b.size)

    def controller_rows(y_measured: np.ndarray, M: np.ndarray, N: np.ndarray, P: np.ndarray) -> np.ndarray:
        """Rows of ``M x_c + N [r, y_m] + P v_c`` for a controller matrix triple."""
        return M @ xc + np.outer(N[:, 0], r) + np.outer(N[:, 1], y_measured) + P @ vc

    plant_free = (ps.C @ xp).ravel()  # C_p x_p
    d_p = float(ps.D[0, 0])
    # u = a + k_y * y_m where a collects everything but the measured output.
    u_base = controller_rows(b.zero(), cb.C1, cb.D11, cb.D12).ravel()
    k_y = float(cb.D11[0, 1])
    if plant_delayed:
        y = b.delayed(0)
    else:  # y = C_p x_p + D_p (u + l), u = u_base + k_y (y + n): solve the algebraic loop.
        denominator = 1.0 - k_y * d_p
        if abs(denominator) < 1e-12:
            raise ValueError("the loop has an ill-posed algebraic loop (1 - D_c D_p = 0)")
        y = (plant_free + d_p * (u_base + k_y * noise + load)) / denominator
    u = u_base + k_y * (y + noise)
    plant_input = u + load
    derivatives = list(ps.A @ xp + np.outer(ps.B[:, 0], plant_input))
    derivatives += list(controller_rows(y + noise, cb.A, cb.B1, cb.B2))
    delayed = []
    if plant_delayed:
        delayed.append(plant_free + d_p * plant_input)
    delayed += list(controller_rows(y + noise, cb.C2, cb.D21, cb.D22))
    delays = ([plant.delay] if plant_delayed else []) + list(cb.delays)
    return b.build(derivatives, [y, u, r - y], delayed, delays)


def simulation_step(
    plant: Plant, controller: Controller, samples_per_residence_time: int = 50, *, system: DelaySystem | None = None
) -> float:
    """The sample time used for closed-loop simulation.

    ``T_ar / samples_per_residence_time`` (``T_ar`` of the true plant), reduced if needed so that
    every dead time in the loop spans at least one sample (the recursion of
    :func:`envs.simulation.discretize` is explicit then).  ``system`` is the loop's
    :func:`closed_loop`, if already built.
    """
    delays = (closed_loop(plant, controller) if system is None else system).delays
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
