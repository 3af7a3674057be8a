"""Exact sampled simulation of linear systems with dead times.

A :class:`DelaySystem` is a continuous-time LTI system with internal delays (the "LFT" form that
MATLAB's ``ss`` uses for internal delays)::

    x'(t)  = A x(t)  + B1 d(t)  + B2 v(t)
    z(t)   = C1 x(t) + D11 d(t) + D12 v(t)      (outputs)
    w(t)   = C2 x(t) + D21 d(t) + D22 v(t)      (signals sent through a delay)
    v_i(t) = w_i(t - delays_i)

``d`` are exogenous inputs, held constant over each sample interval (zero-order hold);
``z`` are the sampled outputs.  Open loops (a plant driven through its dead time by a piecewise
constant input) have no delayed channel: their input is delayed exactly, by splitting the dead
time into whole samples and a fractional part, and the zero-order-hold discretization is exact
(no Pade approximation).  In closed loops the delayed signals ``w`` are the outputs of strictly
proper blocks (the plant output and the internal model output of a dead-time compensator), which
are smooth; between samples they are reconstructed by linear interpolation (first-order hold) with
the fractional part of each delay handled exactly, and the state is propagated exactly for that
input (matrix exponential of an augmented system).  The error is of second order in the step and
is checked against fine-step simulations in the tests.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

__all__ = [
    "DelaySystem",
    "DiscreteDelaySystem",
    "SimulationResult",
    "discretize",
    "simulate",
    "delayed_zoh",
]

DIVERGENCE_LIMIT = 1e8


@dataclass(frozen=True)
class DelaySystem:
    """A continuous LTI system with internal delays (see the module docstring)."""

    A: np.ndarray
    B1: np.ndarray
    B2: np.ndarray
    C1: np.ndarray
    D11: np.ndarray
    D12: np.ndarray
    C2: np.ndarray
    D21: np.ndarray
    D22: np.ndarray
    delays: np.ndarray

    @property
    def n_states(self) -> int:
        return self.A.shape[0]

    @property
    def n_inputs(self) -> int:
        return self.B1.shape[1]

    @property
    def n_outputs(self) -> int:
        return self.C1.shape[0]

    def frequency_response(self, omega: np.ndarray) -> np.ndarray:
        """Exact transfer matrix from ``d`` to ``z`` at ``s = i omega``, shape ``(len(omega), nz, nd)``.

        ``H = P11 + P12 Delta (I - P22 Delta)^{-1} P21`` with ``Delta = diag(e^{-s delays})``.
        """
        omega = np.atleast_1d(np.asarray(omega, dtype=float))
        n = self.n_states
        nv = self.delays.size
        out = np.empty((omega.size, self.n_outputs, self.n_inputs), dtype=complex)
        for k, w in enumerate(omega):
            s = 1j * w
            resolvent = np.linalg.solve(s * np.eye(n) - self.A, np.hstack([self.B1, self.B2])) if n else np.zeros((0, self.n_inputs + nv))
            p11 = self.C1 @ resolvent[:, : self.n_inputs] + self.D11
            p12 = self.C1 @ resolvent[:, self.n_inputs :] + self.D12
            p21 = self.C2 @ resolvent[:, : self.n_inputs] + self.D21
            p22 = self.C2 @ resolvent[:, self.n_inputs :] + self.D22
            delta = np.diag(np.exp(-s * self.delays))
            out[k] = p11 + p12 @ delta @ np.linalg.solve(np.eye(nv) - p22 @ delta, p21) if nv else p11
        return out


@dataclass(frozen=True)
class DiscreteDelaySystem:
    """The exact one-step map of a :class:`DelaySystem` for the sample time ``dt``.

    ``x[j+1] = Phi x[j] + Gamma d[j] + sum_{i,k} R[:, i, k] w_i[j - m_i - 1 + k]`` (k = 0, 1, 2) and,
    at the sample instants, ``v_i[j] = a_i w_i[j - m_i - 1] + (1 - a_i) w_i[j - m_i]`` with
    ``a_i = f_i / dt``, where ``delays_i = m_i dt + f_i``, ``0 <= f_i < dt``.
    """

    system: DelaySystem
    dt: float
    Phi: np.ndarray
    Gamma: np.ndarray
    R: np.ndarray
    whole_samples: np.ndarray
    fraction: np.ndarray


def _integrals(A: np.ndarray, span: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``e^{A T}``, ``int_0^T e^{A s} ds`` and ``int_0^T e^{A s} (T - s) ds`` for ``T = span``."""
    n = A.shape[0]
    block = np.zeros((3 * n, 3 * n))
    block[:n, :n] = A * span
    block[:n, n : 2 * n] = np.eye(n) * span
    block[n : 2 * n, 2 * n :] = np.eye(n) * span
    e = scipy.linalg.expm(block)
    return e[:n, :n], e[:n, n : 2 * n], e[:n, 2 * n :]


def _channel_weights(s: float, fraction: np.ndarray, dt: float) -> np.ndarray:
    """Weights ``c[i, k]`` with ``v_i(j dt + s) = sum_k c[i, k] w_i[j - m_i - 1 + k]``."""
    c = np.zeros((fraction.size, 3))
    before = s <= fraction
    c[before, 0] = (fraction[before] - s) / dt
    c[before, 1] = (dt - fraction[before] + s) / dt
    after = ~before
    c[after, 1] = 1.0 - (s - fraction[after]) / dt
    c[after, 2] = (s - fraction[after]) / dt
    return c


def discretize(system: DelaySystem, dt: float) -> DiscreteDelaySystem:
    """Exact one-step map for piecewise-linear delayed signals and piecewise-constant inputs.

    Raises
    ------
    ValueError
        If ``dt`` is not positive or a delay is shorter than ``dt`` (the recursion is explicit only
        when every delay covers at least one sample).
    """
    if not dt > 0 or not np.isfinite(dt):
        raise ValueError(f"dt must be finite and > 0, got {dt!r}")
    delays = np.asarray(system.delays, dtype=float)
    if delays.size and np.min(delays) < dt * (1 - 1e-12):
        raise ValueError(f"every delay must be >= dt={dt:g}; got min delay {np.min(delays):g}")
    whole = np.floor(delays / dt + 1e-9).astype(int)
    fraction = delays - whole * dt
    fraction[fraction < 1e-9 * dt] = 0.0
    n, nv = system.n_states, delays.size
    breaks = np.unique(np.concatenate([[0.0, dt], fraction[(fraction > 0)]]))
    P = np.eye(n)
    Q = np.zeros((n, system.n_inputs))
    R = np.zeros((n, nv, 3))
    for a, b in zip(breaks[:-1], breaks[1:]):
        E, psi0, psi1 = _integrals(system.A, b - a) if n else (np.eye(0),) * 3
        ca, cb = _channel_weights(a, fraction, dt), _channel_weights(b, fraction, dt)
        slope = (cb - ca) / (b - a)
        P = E @ P
        Q = E @ Q + psi0 @ system.B1
        R = (
            np.einsum("ab,bik->aik", E, R)
            + np.einsum("ab,bi,ik->aik", psi0, system.B2, ca)
            + np.einsum("ab,bi,ik->aik", psi1, system.B2, slope)
        )
    return DiscreteDelaySystem(system, float(dt), P, Q, R, whole, fraction)


@dataclass(frozen=True)
class SimulationResult:
    """Sampled outputs ``z`` at ``timepts``; ``diverged`` if the state left every sane bound."""

    timepts: np.ndarray
    outputs: np.ndarray
    diverged: bool
    final_state: np.ndarray = field(repr=False)


def simulate(discrete: DiscreteDelaySystem, inputs: np.ndarray, x0: np.ndarray | None = None) -> SimulationResult:
    """Simulate from rest (or ``x0`` with a zero past of the delayed signals).

    Parameters
    ----------
    discrete : DiscreteDelaySystem
    inputs : ndarray, shape (n_steps, n_inputs)
        ``d[j]``, held over ``[j dt, (j+1) dt)``.

    Returns
    -------
    SimulationResult
        ``outputs[j] = z(j dt)``.  If any state exceeds ``1e8`` times the largest input the run
        stops, the remaining outputs are ``nan`` and ``diverged`` is True.
    """
    sys = discrete.system
    d = np.asarray(inputs, dtype=float).reshape(-1, sys.n_inputs)
    steps = d.shape[0]
    nv = sys.delays.size
    m = discrete.whole_samples
    a = discrete.fraction / discrete.dt
    offset = int(m.max()) + 1 if nv else 0
    history = np.zeros((offset + steps + 1, nv))
    x = np.zeros(sys.n_states) if x0 is None else np.asarray(x0, dtype=float).copy()
    z = np.full((steps, sys.n_outputs), np.nan)
    limit = DIVERGENCE_LIMIT * max(1.0, float(np.max(np.abs(d))) if d.size else 1.0)
    Phi, Gamma, R = discrete.Phi, discrete.Gamma, discrete.R.reshape(sys.n_states, nv * 3)
    channels = np.arange(nv)
    diverged = False
    for j in range(steps):
        base = offset + j - m - 1  # index of w_i[j - m_i - 1]
        past = history[base[:, None] + np.arange(3)[None, :], channels[:, None]] if nv else np.zeros((0, 3))
        v = a * past[:, 0] + (1 - a) * past[:, 1]
        z[j] = sys.C1 @ x + sys.D11 @ d[j] + sys.D12 @ v
        if nv:
            history[offset + j] = sys.C2 @ x + sys.D21 @ d[j] + sys.D22 @ v
            # w[j] is now known; w_i[j - m_i + 1] with m_i >= 1 is in the past.
            past = history[base[:, None] + np.arange(3)[None, :], channels[:, None]]
        x = Phi @ x + Gamma @ d[j] + (R @ past.ravel() if nv else 0.0)
        if not np.all(np.abs(x) < limit):
            diverged = True
            break
    timepts = np.arange(steps) * discrete.dt
    return SimulationResult(timepts=timepts, outputs=z, diverged=diverged, final_state=x)


def delayed_zoh(state_space, delay: float, dt: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Exact ZOH discretization of ``G(s) e^{-L s}`` for a piecewise-constant input.

    With ``L = m dt + f`` (``0 <= f < dt``), the delayed input over ``[j dt, (j+1) dt)`` equals
    ``u[j-m-1]`` on ``[0, f)`` and ``u[j-m]`` on ``[f, dt)``, so
    ``x[j+1] = Phi x[j] + Gamma1 u[j-m-1] + Gamma0 u[j-m]`` with
    ``Gamma0 = int_0^{dt-f} e^{A s} ds B`` and ``Gamma1 = e^{A (dt-f)} int_0^f e^{A s} ds B``
    (the modified z-transform).  Returns ``(Phi, Gamma0, Gamma1, m)``; the output at ``j dt`` is
    ``C x[j] + D u(j dt - L)``.
    """
    A, B = state_space.A, state_space.B
    m = int(np.floor(delay / dt + 1e-9))
    f = delay - m * dt
    if f < 1e-9 * dt:
        f = 0.0
    Phi, psi_full, _ = _integrals(A, dt)
    if f == 0.0:
        return Phi, psi_full @ B, np.zeros_like(B), m
    E_rest, psi_rest, _ = _integrals(A, dt - f)
    _, psi_f, _ = _integrals(A, f)
    return Phi, psi_rest @ B, E_rest @ psi_f @ B, m


def open_loop_response(state_space, delay: float, inputs: np.ndarray, dt: float) -> np.ndarray:
    """Exact sampled output of ``G(s) e^{-L s}`` (from rest) for a piecewise-constant input.

    ``inputs[j]`` is held over ``[j dt, (j+1) dt)``; returns ``y(j dt)`` for every ``j``
    (right-continuous at the input's switching instants).  Uses :func:`delayed_zoh`.
    """
    u = np.asarray(inputs, dtype=float).ravel()
    Phi, gamma0, gamma1, m = delayed_zoh(state_space, delay, dt)
    fractional = bool(np.any(gamma1))
    steps = u.size
    padded = np.concatenate([np.zeros(m + 1), u])  # padded[k + m + 1] = u[k]
    u_now = padded[1 : steps + 1]  # u[j - m]
    u_before = padded[:steps]  # u[j - m - 1]
    C = state_space.C.ravel()
    D = float(state_space.D.ravel()[0]) if state_space.D.size else 0.0
    g0, g1 = gamma0.ravel(), gamma1.ravel()
    x = np.zeros(state_space.A.shape[0])
    y = np.empty(steps)
    for j in range(steps):
        y[j] = C @ x + D * (u_before[j] if fractional else u_now[j])
        x = Phi @ x + g0 * u_now[j] + g1 * u_before[j]
    return y


class SystemBuilder:
    """Assemble a :class:`DelaySystem` from linear equations written as coefficient rows.

    Each signal is a row over the basis ``[x (n_states), d (n_inputs), v (n_delays)]``; the rows
    of the state derivatives, outputs and delayed signals fill the matrices.

    Examples
    --------
    A first-order lag ``x' = (d - x)/T`` observed through a delay ``L``:

    >>> b = SystemBuilder(n_states=1, n_inputs=1, n_delays=1)
    >>> sys = b.build(derivatives=[(b.input(0) - b.state(0)) / 2.0], outputs=[b.delayed(0)],
    ...               delayed_signals=[b.state(0)], delays=[1.5])
    >>> sys.A.tolist(), sys.delays.tolist()
    ([[-0.5]], [1.5])
    """

    def __init__(self, n_states: int, n_inputs: int, n_delays: int) -> None:
        self.n_states, self.n_inputs, self.n_delays = n_states, n_inputs, n_delays
        self.size = n_states + n_inputs + n_delays

    def _unit(self, index: int) -> np.ndarray:
        row = np.zeros(self.size)
        row[index] = 1.0
        return row

    def zero(self) -> np.ndarray:
        return np.zeros(self.size)

    def state(self, i: int) -> np.ndarray:
        return self._unit(i)

    def input(self, i: int) -> np.ndarray:
        return self._unit(self.n_states + i)

    def delayed(self, i: int) -> np.ndarray:
        return self._unit(self.n_states + self.n_inputs + i)

    def _split(self, rows: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        matrix = np.array(rows, dtype=float).reshape(len(rows), self.size)
        n, m = self.n_states, self.n_inputs
        return matrix[:, :n], matrix[:, n : n + m], matrix[:, n + m :]

    def build(self, derivatives, outputs, delayed_signals, delays) -> DelaySystem:
        A, B1, B2 = self._split(list(derivatives))
        C1, D11, D12 = self._split(list(outputs))
        C2, D21, D22 = self._split(list(delayed_signals))
        return DelaySystem(A, B1, B2, C1, D11, D12, C2, D21, D22, np.asarray(delays, dtype=float).ravel())
