"""Shared test helpers: an independent fine-step simulator for linear loops with dead times.

The reference shares no code with :mod:`envs.simulation.delay_systems`, :mod:`envs.systems.controllers` or
:mod:`envs.simulation.loops`: the loop equations below are written out by hand from the block diagrams
(plants as chains of first-order lags, the controllers as in Ingimundarson Fig. 4 and Fig. 10),
and are integrated with the classical explicit Runge-Kutta method (RK4) on a fine grid while the
delayed signals are kept in a history buffer (method of steps).  Every dead time must be a whole
number of fine steps; the delayed signals at the half steps of RK4 are interpolated with the
four-point cubic Lagrange formula.

Accuracy (measured when the tests were written): at ``h = T_ar/300`` the reference IAE of the
loops used in the tests changes by less than ``3e-6`` (relative) when ``h`` is halved, so it is
two orders of magnitude below the tolerances it is used with.
"""

from __future__ import annotations

from dataclasses import dataclass
from types import SimpleNamespace
from typing import Callable

import numpy as np
import pytest

# equations(x, v, d) -> (dx, w, z) for states x (n, k), delayed signals v (nv, k) and inputs
# d (nd, k), k independent runs side by side; w are the signals sent into the dead times
# (v_i(t) = w_i(t - delay_i)) and z the outputs.  Must be linear in (x, v, d).
Equations = Callable[[np.ndarray, np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]]


@dataclass(frozen=True)
class ReferenceRun:
    """Outputs ``z[j, o, k]`` of run ``k`` at ``timepts[j] = j h``."""

    timepts: np.ndarray
    outputs: np.ndarray


def delay_ode_reference(
    equations: Equations,
    n_states: int,
    delays: list[float],
    inputs: np.ndarray,
    t_end: float,
    h: float,
) -> ReferenceRun:
    """RK4 with a delay buffer, from rest, for inputs that step at ``t = 0`` and then stay constant.

    Parameters
    ----------
    equations : callable
        The loop's linear equations (see ``Equations`` above); ``w`` must not depend on ``v``
        (the delayed signals are outputs of strictly proper blocks).
    inputs : ndarray, shape (nd, k)
        Constant input values of the ``k`` runs for ``t >= 0``.
    h : float
        Step; every delay must be a whole number ``m >= 2`` of steps.
    """
    inputs = np.asarray(inputs, dtype=float)
    nd, runs = inputs.shape
    nv = len(delays)
    whole = np.array([round(L / h) for L in delays], dtype=int)
    assert np.allclose(whole * h, delays, rtol=0, atol=1e-9 * h), "delays must be whole fine steps"
    assert np.all(whole >= 2), "delays must span at least two fine steps"
    # Matrices of the linear equations, read off by evaluating them on unit vectors.
    size = n_states + nv + nd
    unit = np.eye(size)
    dx, w, z = equations(unit[:n_states], unit[n_states : n_states + nv], unit[n_states + nv :])
    dx, w, z = (np.asarray(a, dtype=float).reshape(-1, size) for a in (dx, w, z))
    split = (n_states, n_states + nv)
    A, Bv, Bd = np.hsplit(dx, split)
    Cw, Wv, Wd = np.hsplit(w, split)
    Cz, Zv, Zd = np.hsplit(z, split)
    assert not np.any(Wv) and not np.any(Wd), "delayed signals must be state outputs"

    # One RK4 step of the linear equations is affine in (x, v(t_j), v(t_j + h/2), v(t_j + h)):
    # x_next = M x + P [v0; vh; v1] + q.  Read M, P, q off the RK4 formulas applied to unit vectors.
    def rk4(x, v0, vh, v1, forcing):
        k1 = A @ x + Bv @ v0 + forcing
        k2 = A @ (x + 0.5 * h * k1) + Bv @ vh + forcing
        k3 = A @ (x + 0.5 * h * k2) + Bv @ vh + forcing
        k4 = A @ (x + h * k3) + Bv @ v1 + forcing
        return x + (h / 6) * (k1 + 2 * k2 + 2 * k3 + k4)

    M = rk4(np.eye(n_states), np.zeros((nv, n_states)), np.zeros((nv, n_states)), np.zeros((nv, n_states)), 0.0)
    P = np.hstack([
        rk4(np.zeros((n_states, nv)), *(np.eye(nv) if i == k else np.zeros((nv, nv)) for i in range(3)), 0.0)
        for k in range(3)
    ])
    q = rk4(np.zeros((n_states, runs)), *(np.zeros((nv, runs)),) * 3, Bd @ inputs)
    # v_i(t_j + c h) from w_i at the fine steps j - m_i - 1 .. j - m_i + 2: rows c = 0, 1/2, 1.
    weights = np.array([[0.0, 1.0, 0.0, 0.0], [-1.0, 9.0, 9.0, -1.0], [0.0, 0.0, 1.0, 0.0]])
    weights[1] /= 16

    steps = int(round(t_end / h))
    pad = int(whole.max()) + 2 if nv else 0
    history = np.zeros((pad + steps + 2, nv, runs))  # history[pad + j] = w(j h)
    window = (pad - whole)[:, None] + np.arange(-1, 3)[None, :]  # (nv, 4) for j = 0
    channels = np.arange(nv)[:, None]
    x = np.zeros((n_states, runs))
    out = np.empty((steps + 1, Cz.shape[0], runs))
    out[0] = Zd @ inputs
    for j in range(steps):
        v = np.einsum("cq,iqk->cik", weights, history[window + j, channels]).reshape(3 * nv, runs)
        x = M @ x + P @ v + q
        history[pad + j + 1] = Cw @ x
        out[j + 1] = Cz @ x + Zv @ v[2 * nv :] + Zd @ inputs
    return ReferenceRun(timepts=np.arange(steps + 1) * h, outputs=out)


# --------------------------------------------------------------------- hand-written loop equations
@dataclass(frozen=True)
class LagChain:
    """``K e^{-L s} / (s^i prod(1 + T_k s))`` realized as a chain: integrator first, then the lags."""

    gain: float
    lags: tuple[float, ...]
    delay: float
    integrating: bool = False

    @property
    def n_states(self) -> int:
        return len(self.lags) + int(self.integrating)

    def derivatives(self, x, u):
        """``(dx, y_free)``: state derivatives for input ``u`` and the output before the dead time."""
        dx, signal, k = [], self.gain * u, 0
        if self.integrating:
            dx.append(signal)
            signal, k = x[0], 1
        for lag in self.lags:
            dx.append((signal - x[k]) / lag)
            signal, k = x[k], k + 1
        return dx, signal


@dataclass(frozen=True)
class HandController:
    """``law(xc, vc, r, y_measured) -> (dxc, wc, u)`` with ``n_states`` states and dead times ``delays``."""

    n_states: int
    delays: tuple[float, ...]
    law: Callable


def pid(kp: float, ti: float, td: float = 0.0, n: float = 10.0) -> HandController:
    """``kp (e + (1/ti) int e + D)``, ``D = td s/(1 + td s/n) e = n (e - x_f)``, ``x_f' = (n/td)(e - x_f)``."""

    def law(xc, vc, r, y):
        e = r - y
        if td == 0:
            return [e], [], kp * (e + xc[0] / ti)
        return [e, (n / td) * (e - xc[1])], [], kp * (e + xc[0] / ti + n * (e - xc[1]))

    return HandController(1 if td == 0 else 2, (), law)


def fppi(gain: float, time_constant: float, dead_time: float, tr: float, tf: float) -> HandController:
    """Ingimundarson Fig. 4: ``u = K (eps + int eps / T_n)``, ``eps = r - y_m - F (y - y_m(t - L_n))``,
    ``T_n y_m' = K_n u - y_m``, ``T_f x_f' = y - y_m(t - L_n) - x_f``, ``K = T_n/(K_n T_r)``."""
    k = time_constant / (gain * tr)

    def law(xc, vc, r, y):
        integral, model = xc[0], xc[1]
        correction = xc[2] if tf > 0 else y - vc[0]
        eps = r - model - correction
        u = k * (eps + integral / time_constant)
        dx = [eps, (gain * u - model) / time_constant]
        if tf > 0:
            dx.append((y - vc[0] - xc[2]) / tf)
        return dx, [model], u

    return HandController(3 if tf > 0 else 2, (dead_time,), law)


def msp(gain: float, dead_time: float, tr: float, extension: bool = False) -> HandController:
    """Ingimundarson Fig. 10: ``e_d = y - y_m(t - L_n)``, ``u_r = K_r (r - y_m - e_d)``, ``y_m' = K_n u_r``,
    ``u = u_r - F e_d`` with ``F = K_0`` (eq. 36) or ``K_0 (T_d s + 1)/(T_d s/10 + 1)`` (eq. 51)."""
    kr = 1 / (gain * tr)
    k0 = (0.6 if extension else 0.5) / (dead_time * gain)
    lead = 0.4 * dead_time / 10

    def law(xc, vc, r, y):
        model = xc[0]
        e_d = y - vc[0]
        u_r = kr * (r - model - e_d)
        if extension:  # (T_d s + 1)/(T_d s/10 + 1) = 10 - 9/(T_d s/10 + 1)
            return [gain * u_r, (e_d - xc[1]) / lead], [model], u_r - k0 * (10 * e_d - 9 * xc[1])
        return [gain * u_r], [model], u_r - k0 * e_d

    return HandController(2 if extension else 1, (dead_time,), law)


def loop_equations(plant: LagChain, controller: HandController) -> tuple[Equations, int, list[float]]:
    """Equations of ``y = P (u + l)``, ``u = controller(r, y + n)`` with outputs ``[y, u, r - y]``."""
    n_p = plant.n_states
    delayed_output = plant.delay > 0

    def equations(x, v, d):
        r, load, noise = d
        xp, xc = x[:n_p], x[n_p:]
        y = v[0] if delayed_output else xp[-1]
        dxc, wc, u = controller.law(xc, v[1:] if delayed_output else v, r, y + noise)
        dxp, y_free = plant.derivatives(xp, u + load)
        w = ([y_free] if delayed_output else []) + list(wc)
        return np.array(dxp + dxc), np.array(w).reshape(len(w), -1), np.array([y, u, r - y])

    delays = ([plant.delay] if delayed_output else []) + list(controller.delays)
    return equations, n_p + controller.n_states, delays


def step_runs(plant: LagChain, controller: HandController, t_end: float, h: float) -> ReferenceRun:
    """Two runs side by side: column 0 a unit load step, column 1 a unit set-point step."""
    equations, n_states, delays = loop_equations(plant, controller)
    inputs = np.array([[0.0, 1.0], [1.0, 0.0], [0.0, 0.0]])  # rows r, l, n
    return delay_ode_reference(equations, n_states, delays, inputs, t_end, h)


def absolute_area(values: np.ndarray, h: float) -> np.ndarray:
    """``int |e| dt`` of finely sampled runs (trapezoidal rule, along axis 0)."""
    return np.trapezoid(np.abs(values), dx=h, axis=0)


@pytest.fixture(scope="session")
def fine_step() -> SimpleNamespace:
    """The independent fine-step reference: simulator, hand-written plants and controllers."""
    return SimpleNamespace(
        simulate=delay_ode_reference,
        step_runs=step_runs,
        absolute_area=absolute_area,
        LagChain=LagChain,
        pid=pid,
        fppi=fppi,
        msp=msp,
        loop_equations=loop_equations,
    )
