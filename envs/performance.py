"""Integrated absolute error (IAE) of a closed loop for unit load and set-point steps.

``IAE = int_0^inf |e(t)| dt`` with ``e = r - y`` (Marlin ch. 9, "integral of the absolute value
of the error"), for a unit step of the load at the plant input (``r = 0``) and for a unit step of
the set point, both at ``t = 0`` from rest.  Values are raw, in the plant's time and output units.

Time scale and tail handling.  The loop is simulated (:mod:`envs.loops`) with
``T_ar/50`` per sample (``T_ar`` of the true plant, smaller if a dead time is shorter), over an
initial horizon of ``HORIZON`` residence times.  ``|e|`` is integrated by the trapezoidal rule,
splitting each interval where ``e`` changes sign at its linear zero.  The run counts as settled
when the IAE accumulated over the last tenth of the horizon is below ``1e-5`` of the total (the
decaying tail beyond the horizon is then of that order too); otherwise the horizon is doubled,
up to ``MAX_HORIZON`` residence times, and ``settled`` is False if that is not enough.  A
diverging or unstable loop has infinite IAE.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from envs.controllers import Controller
from envs.loops import closed_loop, simulation_step
from envs.plants import Plant
from envs.simulation import DelaySystem, DiscreteDelaySystem, discretize, simulate

__all__ = ["IAEResult", "integrated_absolute_error", "iae"]

HORIZON = 40.0
MAX_HORIZON = 1280.0
SETTLED_SHARE = 1e-5


@dataclass(frozen=True)
class IAEResult:
    """IAE for unit load and set-point steps; ``inf`` when the loop diverges."""

    load: float
    setpoint: float
    settled: bool
    horizon: float
    dt: float


def integrated_absolute_error(error: np.ndarray, dt: float) -> float:
    """Trapezoidal ``int |e| dt`` of samples ``e[j] = e(j dt)``, exact for piecewise-linear ``e``."""
    a, b = error[:-1], error[1:]
    same = a * b >= 0
    areas = np.where(same, 0.5 * (np.abs(a) + np.abs(b)), 0.5 * (a * a + b * b) / np.where(same, 1.0, np.abs(a) + np.abs(b)))
    return float(np.sum(areas) * dt)


def _settled(error: np.ndarray, dt: float) -> bool:
    total = integrated_absolute_error(error, dt)
    tail = integrated_absolute_error(error[-max(error.size // 10, 2) :], dt)
    return tail <= SETTLED_SHARE * max(total, 1e-300)


def iae(plant: Plant, controller: Controller, *, samples_per_residence_time: int = 50, system: DelaySystem | None = None) -> IAEResult:
    """IAE of the loop for a unit load step and a unit set-point step (see the module docstring)."""
    system = closed_loop(plant, controller) if system is None else system
    dt = simulation_step(plant, controller, samples_per_residence_time)
    discrete = discretize(system, dt)
    scale = plant.step_time_scale()
    horizon = HORIZON
    while True:
        steps = int(math.ceil(horizon * scale / dt)) + 1
        values, settled = [], True
        for kind in ("load", "setpoint"):
            response = _error_response(discrete, steps, kind)
            if response is None:
                return IAEResult(math.inf, math.inf, True, horizon, dt)
            values.append(integrated_absolute_error(response, dt))
            settled &= _settled(response, dt)
        if settled or horizon >= MAX_HORIZON:
            return IAEResult(values[0], values[1], settled, horizon, dt)
        horizon *= 2


def _error_response(discrete: DiscreteDelaySystem, steps: int, kind: str) -> np.ndarray | None:
    """``e(j dt)`` for a unit step of ``kind`` ("load" or "setpoint"); None if the loop diverges."""
    inputs = np.zeros((steps, 3))
    inputs[:, 0 if kind == "setpoint" else 1] = 1.0
    result = simulate(discrete, inputs)
    if result.diverged:
        return None
    return result.outputs[:, 2]
