"""An independent fine-step reference for the responses and the IAE of a loop: RK4 with a delay buffer.

This is the yardstick of ``deadtime bench``'s accuracy figures (:func:`fine_step_iae`) and of the
tests that check the simulation, the IAE and the Nyquist verdict of :mod:`envs` against a time
simulation (:func:`fine_step_response`: ``y``, ``u`` and ``e`` on the fine grid); it is the
project's one fine-step simulator.  It shares no simulation code with
:mod:`envs` (only the :class:`~envs.systems.plants.Plant` and controller dataclasses, for their
parameters): the plant is realized with ``scipy.signal.tf2ss`` and the controllers' equations are
written out by hand from their block diagrams (Ingimundarson Fig. 4 and Fig. 10 for the FPPI and the
MSP).  Time is normalized by the plant's ``step_time_scale()`` ``T`` (``T_ar`` for stable plants) so
that the realization is well scaled; IAEs are converted back to the plant's time unit.

The loop ``y = P (u + l)``, ``u = C(r, y)`` is integrated by the classical Runge-Kutta method
(RK4) with step ``h`` while every signal sent through a dead time is kept in a history buffer
(method of steps).  The delayed value at any instant, including the half steps of RK4 and a
fractional number of steps back, is the four-point cubic Lagrange interpolation of that history
(the delayed signals are outputs of strictly proper blocks, hence smooth after ``t = 0``).  ``|e|``
is integrated by the trapezoidal rule on the fine grid, split at sign changes (:func:`absolute_area`).

With the default ``h = T/2000`` (smaller if a dead time spans fewer than 8 steps) the IAE changes by
less than about ``1e-7`` (relative) when ``h`` is halved on the bench's loops, four orders of
magnitude below the errors it measures.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba
import numpy as np
import scipy.signal

from envs.systems.controllers import FPPI, MSP, PID, Controller, SeriesPID
from envs.systems.plants import Plant

__all__ = ["MIN_DELAY_STEPS", "OUTPUTS", "STEPS_PER_TIME_SCALE", "FineIAE", "FineResponse", "absolute_area", "fine_step_iae", "fine_step_response"]

STEPS_PER_TIME_SCALE = 2000
MIN_DELAY_STEPS = 8
HORIZON = 40.0  # initial horizon in time scales; doubled until the tail is negligible
MAX_HORIZON = 1280.0
TAIL_SHARE = 1e-7


OUTPUTS = ("output", "control", "error")
"""The signals the reference records: the plant output ``y``, the control ``u``, the error ``e = r - y``."""


@dataclass(frozen=True)
class FineResponse:
    """Samples at ``timepts`` (plant time units) of a unit load step (column 0) and a unit set-point
    step (column 1), from rest: ``output`` ``y``, ``control`` ``u``, ``error`` ``e = r - y``, each of
    shape ``(timepts.size, 2)``."""

    timepts: np.ndarray
    output: np.ndarray
    control: np.ndarray
    error: np.ndarray


@dataclass(frozen=True)
class FineIAE:
    """Reference IAE for a unit load step and a unit set-point step (plant time units)."""

    load: float
    setpoint: float
    step: float
    horizon: float


def _scaled_plant(plant: Plant, scale: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(A, B, C)`` of ``G(sigma/T)`` realized by ``tf2ss`` (strictly proper plants only)."""
    num, den = np.asarray(plant.num, float), np.asarray(plant.den, float)
    if len(num) >= len(den):
        raise ValueError("the fine-step reference needs a strictly proper plant")
    # coefficient of s^k multiplied by T^-k: s = sigma / T
    num = num * scale ** -np.arange(len(num) - 1, -1, -1.0)
    den = den * scale ** -np.arange(len(den) - 1, -1, -1.0)
    A, B, C, _ = scipy.signal.tf2ss(num / den[0], den / den[0])
    return A, B[:, 0], C[0]


def _controller_law(controller: Controller, scale: float):
    """``(n_states, delays, law)`` with ``law(xc, vc, r, y) -> (dxc, wc, u)`` in normalized time."""
    if isinstance(controller, (PID, SeriesPID)):
        kp, n = controller.kp, controller.n
        ti = None if controller.ti is None else controller.ti / scale
        td = controller.td / scale
        integral = ti is not None
        derivative = td > 0
        series = isinstance(controller, SeriesPID)

        def law(xc, vc, r, y):
            e = r - y
            dx, k = [], 0
            p = kp * e
            if integral:
                dx.append(e)
                p = p + kp * xc[0] / ti
                k = 1
            if not derivative:
                return dx, [], p
            if series:  # (1 + td s)/(1 + td s/n) = n - (n - 1)/(1 + td s/n) applied to the PI part
                dx.append((p - xc[k]) * n / td)
                return dx, [], n * p - (n - 1) * xc[k]
            dx.append((e - xc[k]) * n / td)  # td s/(1 + td s/n) e = n (e - x_f)
            return dx, [], p + kp * n * (e - xc[k])

        return int(integral) + int(derivative), [], law
    if isinstance(controller, FPPI):
        gain, tn, ln = controller.gain, controller.time_constant / scale, controller.dead_time / scale
        tr, tf = controller.tr / scale, controller.tf / scale
        k = tn / (gain * tr)
        delayed = ln > 0

        def law(xc, vc, r, y):
            integral, model = xc[0], xc[1]
            model_delayed = vc[0] if delayed else model
            correction = xc[2] if tf > 0 else y - model_delayed
            eps = r - model - correction
            u = k * (eps + integral / tn)
            dx = [eps, (gain * u - model) / tn]
            if tf > 0:
                dx.append((y - model_delayed - xc[2]) / tf)
            return dx, ([model] if delayed else []), u

        return (3 if tf > 0 else 2), ([ln] if delayed else []), law
    if isinstance(controller, MSP):
        gain, ln, tr = controller.gain * scale, controller.dead_time / scale, controller.tr / scale
        kr = 1 / (gain * tr)
        k0 = (0.6 if controller.extension else 0.5) / (ln * gain)
        lead = 0.4 * ln / 10

        def law(xc, vc, r, y):
            model = xc[0]
            e_d = y - vc[0]
            u_r = kr * (r - model - e_d)
            if controller.extension:  # (T_d s + 1)/(T_d s/10 + 1) = 10 - 9/(T_d s/10 + 1)
                return [gain * u_r, (e_d - xc[1]) / lead], [model], u_r - k0 * (10 * e_d - 9 * xc[1])
            return [gain * u_r], [model], u_r - k0 * e_d

        return (2 if controller.extension else 1), [ln], law
    raise ValueError(f"no fine-step reference for {type(controller).__name__}")


def _loop_matrices(plant: Plant, controller: Controller, scale: float):
    """Matrices of ``x' = A x + Bv v + Bd d``, ``w = Cw x``, ``z = Cz x + Zv v + Zd d`` (d = [r, l]).

    The outputs ``z`` are :data:`OUTPUTS`: the plant output ``y``, the control ``u`` and the error ``e = r - y``.
    """
    Ap, Bp, Cp = _scaled_plant(plant, scale)
    n_p = Ap.shape[0]
    n_c, controller_delays, law = _controller_law(controller, scale)
    plant_delayed = plant.dead_time > 0
    delays = ([plant.dead_time / scale] if plant_delayed else []) + list(controller_delays)
    n, nv = n_p + n_c, len(delays)

    def equations(z: np.ndarray):
        x, v, (r, load) = z[:n], z[n : n + nv], z[n + nv :]
        xp, xc = x[:n_p], x[n_p:]
        y_free = Cp @ xp
        y = v[0] if plant_delayed else y_free
        dxc, wc, u = law(xc, v[1:] if plant_delayed else v, r, y)
        dx = np.concatenate([Ap @ xp + Bp * (u + load), np.asarray(dxc, dtype=float).ravel()])
        w = np.asarray(([y_free] if plant_delayed else []) + list(wc), dtype=float).ravel()
        return dx, w, np.array([y, u, r - y], dtype=float)

    size = n + nv + 2
    columns = [equations(np.eye(size)[k]) for k in range(size)]  # linear: columns of the matrices
    M = np.column_stack([c[0] for c in columns]).reshape(n, size)
    W = np.column_stack([c[1] for c in columns]).reshape(nv, size)
    Z = np.column_stack([c[2] for c in columns])
    if np.any(W[:, n:]):
        raise ValueError("a delayed signal depends on the inputs or on other delayed signals")
    return M[:, :n], M[:, n : n + nv], M[:, n + nv :], W[:, :n], Z[:, :n], Z[:, n : n + nv], Z[:, n + nv :], np.array(delays)


@numba.njit(cache=True)
def _interpolate(history, channel, position):  # pragma: no cover - compiled
    """Cubic Lagrange value of ``history[:, channel]`` at fractional index ``position`` (zero before 0)."""
    if position <= 0.0:
        return 0.0
    k = math.floor(position)
    s = position - k
    weights = (
        -s * (s - 1.0) * (s - 2.0) / 6.0,
        (s + 1.0) * (s - 1.0) * (s - 2.0) / 2.0,
        -(s + 1.0) * s * (s - 2.0) / 2.0,
        (s + 1.0) * s * (s - 1.0) / 6.0,
    )
    total = 0.0
    for q in range(4):
        index = k - 1 + q
        if index >= 0:
            total += weights[q] * history[index, channel]
    return total


@numba.njit(cache=True)
def _derivative(A, Bv, forcing, x, v, out):  # pragma: no cover - compiled
    """``out = A x + Bv v + forcing`` without temporaries."""
    for r in range(A.shape[0]):
        acc = forcing[r]
        for k in range(A.shape[1]):
            acc += A[r, k] * x[k]
        for k in range(Bv.shape[1]):
            acc += Bv[r, k] * v[k]
        out[r] = acc


@numba.njit(cache=True)
def _rk4_outputs(A, Bv, Bd, Cw, Cz, Zv, Zd, delay_steps, d, h, steps):  # pragma: no cover - compiled
    """The outputs ``z`` (rows of ``Cz``) at ``j h``, ``j = 0 .. steps``, from rest, for constant inputs ``d``."""
    n, nv, nz = A.shape[0], delay_steps.size, Cz.shape[0]
    history = np.zeros((steps + 2, nv))
    x = np.zeros(n)
    trial = np.zeros(n)
    k1, k2, k3, k4 = np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n)
    forcing = Bd @ d
    z_const = np.zeros(nz)
    for o in range(nz):
        for k in range(d.size):
            z_const[o] += Zd[o, k] * d[k]
    outputs = np.empty((steps + 1, nz))
    stage_v = np.zeros((3, nv))
    outputs[0] = z_const
    for j in range(steps):
        for i in range(nv):  # w_i(j h) from the current state
            acc = 0.0
            for k in range(n):
                acc += Cw[i, k] * x[k]
            history[j, i] = acc
        for c in range(3):
            for i in range(nv):
                stage_v[c, i] = _interpolate(history, i, j + 0.5 * c - delay_steps[i])
        _derivative(A, Bv, forcing, x, stage_v[0], k1)
        for k in range(n):
            trial[k] = x[k] + 0.5 * h * k1[k]
        _derivative(A, Bv, forcing, trial, stage_v[1], k2)
        for k in range(n):
            trial[k] = x[k] + 0.5 * h * k2[k]
        _derivative(A, Bv, forcing, trial, stage_v[1], k3)
        for k in range(n):
            trial[k] = x[k] + h * k3[k]
        _derivative(A, Bv, forcing, trial, stage_v[2], k4)
        big = False
        for k in range(n):
            x[k] += (h / 6.0) * (k1[k] + 2.0 * k2[k] + 2.0 * k3[k] + k4[k])
            big |= not abs(x[k]) < 1e12
        for o in range(nz):
            acc = z_const[o]
            for k in range(n):
                acc += Cz[o, k] * x[k]
            for i in range(nv):
                acc += Zv[o, i] * stage_v[2, i]
            outputs[j + 1, o] = acc
        if big:
            outputs[j + 1 :] = np.inf
            break
    return outputs


def absolute_area(values: np.ndarray, step: float) -> np.ndarray:
    """``int |e| dt`` of runs sampled every ``step`` along axis 0: the trapezoidal rule, each interval
    split where ``e`` changes sign (exact for piecewise linear ``e``); one area per column.

    >>> float(absolute_area(np.array([1.0, -1.0]), 1.0))  # two triangles of area 1/4
    0.5
    >>> absolute_area(np.array([[0.0, 2.0], [1.0, 2.0]]), 0.5).tolist()
    [0.25, 1.0]
    """
    a, b = values[:-1], values[1:]
    crossing = a * b < 0
    areas = np.where(crossing, (a * a + b * b) / (2 * np.where(crossing, np.abs(a) + np.abs(b), 1.0)), 0.5 * (np.abs(a) + np.abs(b)))
    return np.sum(areas, axis=0) * step


def _normalized_loop(plant: Plant, controller: Controller) -> tuple[float, tuple[np.ndarray, ...], np.ndarray]:
    """``(T, matrices, delays / T)`` of the loop in time normalized by ``T = plant.step_time_scale()``."""
    scale = plant.step_time_scale()
    *matrices, delays = (np.ascontiguousarray(a, dtype=float) for a in _loop_matrices(plant, controller, scale))
    return scale, tuple(matrices), delays


def fine_step_response(plant: Plant, controller: Controller, t_end: float, step: float) -> FineResponse:
    """The loop's response to a unit load step and to a unit set-point step, from rest, on a fine grid.

    Parameters
    ----------
    plant, controller : Plant, Controller
        The loop ``y = P (u + l)``, ``u = C(r, y)``; a strictly proper plant, a PID, series PID, FPPI
        or MSP (the controllers' equations are written out by hand, see the module docstring).
    t_end : float
        Horizon (plant time units).
    step : float
        RK4 step ``h`` (plant time units); every dead time must span at least ``MIN_DELAY_STEPS``
        steps.  The error of the method is ``O(h^4)`` in the samples; the trapezoidal IAE of the
        samples (:func:`absolute_area`) is ``O(h^2)``.

    Returns
    -------
    FineResponse
        ``y``, ``u`` and ``e`` at ``timepts = j h``, ``j = 0 .. round(t_end / h)``; a run that
        diverges is ``inf`` from the step where a state passes ``1e12``.

    Raises
    ------
    ValueError
        If a dead time spans fewer than ``MIN_DELAY_STEPS`` steps, the plant is not strictly proper,
        or there is no hand-written law for the controller.
    """
    scale, matrices, delays = _normalized_loop(plant, controller)
    h = step / scale
    if delays.size and np.min(delays) < MIN_DELAY_STEPS * h * (1 - 1e-12):
        raise ValueError(f"step must be <= the shortest dead time / {MIN_DELAY_STEPS}, got {step} for "
                         f"{float(np.min(delays)) * scale}")
    steps = int(round(t_end / step))
    runs = [_rk4_outputs(*matrices, delays / h, d, h, steps) for d in (np.array([0.0, 1.0]), np.array([1.0, 0.0]))]
    y, u, e = (np.column_stack([run[:, k] for run in runs]) for k in range(len(OUTPUTS)))
    return FineResponse(timepts=np.arange(steps + 1) * step, output=y, control=u, error=e)


def fine_step_iae(plant: Plant, controller: Controller, *, steps_per_time_scale: int = STEPS_PER_TIME_SCALE) -> FineIAE:
    """Reference IAE of the loop for a unit load and a unit set-point step (see the module docstring).

    The horizon starts at ``HORIZON`` time scales and doubles until the last tenth of the run holds
    less than ``TAIL_SHARE`` of the IAE (at most ``MAX_HORIZON``).  A loop with a steady offset or
    a diverging loop gets ``inf``.
    """
    scale, matrices, delays = _normalized_loop(plant, controller)
    h = 1.0 / steps_per_time_scale
    if delays.size and np.min(delays) < MIN_DELAY_STEPS * h:
        h = float(np.min(delays)) / MIN_DELAY_STEPS
    horizon = HORIZON
    error_row = OUTPUTS.index("error")
    while True:
        steps = math.ceil(horizon / h)
        values = []
        settled = True
        for d in (np.array([0.0, 1.0]), np.array([1.0, 0.0])):
            error = _rk4_outputs(*matrices, delays / h, d, h, steps)[:, error_row]
            total = float(absolute_area(error, h))
            tail = float(absolute_area(error[-(steps // 10) :], h))
            values.append(total * scale)
            settled &= bool(np.isfinite(total)) and tail <= TAIL_SHARE * max(total, 1e-300)
            if not np.isfinite(total):
                values[-1] = math.inf
        if settled or horizon >= MAX_HORIZON or not all(np.isfinite(values)):
            return FineIAE(values[0], values[1], h * scale, horizon * scale)
        horizon *= 2
