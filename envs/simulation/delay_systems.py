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

from dataclasses import dataclass
from typing import Sequence

import numba
import numpy as np
import scipy.linalg

from envs.simulation._run_kernels import _run, _run_one

__all__ = [
    "DelaySystem",
    "DiscreteDelaySystem",
    "SimulationResult",
    "discretize",
    "simulate",
    "simulate_batch",
    "open_loop_response",
    "SystemBuilder",
    "delayed_zoh",
]

MAX_RUN_SAMPLES = 2**17
"""The most samples of one simulated run (an experiment, or one IAE run of a loop): with the
default sample times an experiment's cap is 30,001 samples and an IAE run's longest horizon 64,001,
so only runs sampled far finer than their plant's time scale reach it (a relay experiment sampled
at ``L/20`` for ``L < 0.023 T_ar``, an experiment whose loop has a delay below ``1.2e-3 T_ar`` or an IAE
run of a loop with a delay below ``0.01 T_ar``, e.g. a predictor's model dead time).  Each such run stops at the bound and reports
what it has (an unconverged experiment, its time charged; an unsettled IAE), or, if even the
first horizon cannot be sampled within it, is not run (an IAE of ``inf``); a run's memory is a
few arrays of this length (about 1 MB each)."""

# States beyond this multiple of the largest input mean divergence.  Plant.state_space realizes G in
# normalized time, so states have the magnitude of the signals whatever the plant's time scale.
DIVERGENCE_LIMIT = 1e8


def divergence_limit(gain: float) -> float:
    """``DIVERGENCE_LIMIT`` for a loop around a plant of gain ``K``, raised by ``|K|/GAIN_FREE`` or ``1/(|K| GAIN_FREE)``
    outside ``GAIN_FREE^-1 <= |K| <= GAIN_FREE``.

    The states of a loop are of the size of its signals, and those scale with the gain: a unit load
    at the input of a plant of gain ``K`` moves its output by ``K``, a unit set-point step moves the
    control by ``1/K`` (a fixed limit would count stable loops with ``K = 1e8`` or ``1e-12`` as diverging).
    Within ``[1e-4, 1e4]`` the limit is ``DIVERGENCE_LIMIT`` itself, so every run there (diverging ones included,
    whose abort sample the tests hold) keeps its numbers.
    """
    gain = abs(gain)
    return DIVERGENCE_LIMIT * max(1.0, gain / GAIN_FREE, 1.0 / (gain * GAIN_FREE))


GAIN_FREE = 1e4
"""Gains ``|K|`` within ``[1/GAIN_FREE, GAIN_FREE]`` keep the fixed ``DIVERGENCE_LIMIT``."""


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

    def dc_gain(self) -> np.ndarray:
        """Steady-state gain from ``d`` to ``z`` (delays do not matter at ``s = 0``).

        Solves ``0 = A x + B1 d + B2 v``, ``v = C2 x + D21 d + D22 v``; raises
        ``numpy.linalg.LinAlgError`` if the system has a pole at the origin.
        """
        n, nv = self.n_states, self.delays.size
        lhs = np.empty((n + nv, n + nv))  # [[A, B2], [C2, D22 - I]]
        lhs[:n, :n], lhs[:n, n:], lhs[n:, :n], lhs[n:, n:] = self.A, self.B2, self.C2, self.D22 - np.eye(nv)
        state = np.linalg.solve(lhs, -np.concatenate([self.B1, self.D21]))
        return self.C1 @ state[:n] + self.D12 @ state[n:] + self.D11

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


def _integrals(A: np.ndarray, span: float, unit: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``e^{A T}``, ``int_0^T e^{A s} ds`` and ``int_0^T e^{A s} (T - s) ds`` for ``T = span``.

    They are blocks of the exponential of ``[[A, I, 0], [0, 0, I], [0, 0, 0]] T`` (``unit``, that
    matrix for ``T = 1``, if the caller has it: its product by ``T`` is the same block, bit for bit).
    """
    n = A.shape[0]
    e = scipy.linalg.expm((_unit_block(A) if unit is None else unit) * span)
    return e[:n, :n], e[:n, n : 2 * n], e[:n, 2 * n :]


def _unit_block(A: np.ndarray) -> np.ndarray:
    """``[[A, I, 0], [0, 0, I], [0, 0, 0]]`` (zeros elsewhere)."""
    n = A.shape[0]
    block = np.eye(3 * n, k=n)  # the two identity blocks: the ones at (i, i + n)
    block[:n, :n] = A
    return block


def _channel_weights(s: float, fraction: list[float], dt: float) -> list[list[float]]:
    """Weights ``c[i][k]`` with ``v_i(j dt + s) = sum_k c[i][k] w_i[j - m_i - 1 + k]``."""
    return [
        [(f - s) / dt, (dt - f + s) / dt, 0.0] if s <= f else [0.0, 1.0 - (s - f) / dt, (s - f) / dt]
        for f in fraction
    ]


def discretize(system: DelaySystem, dt: float, *, method: str = "fast") -> DiscreteDelaySystem:
    """Exact one-step map for piecewise-linear delayed signals and piecewise-constant inputs.

    Parameters
    ----------
    system : DelaySystem
    dt : float
        Sample time.
    method : {"fast", "reference"}
        ``"fast"`` (default): scalar channel weights, the breaks of the sample interval as a set and
        one unit block scaled per sub-interval (:func:`_integrals`).  ``"reference"``: the same map
        written first, with vectorized weights, ``np.unique`` of the breaks and the Van Loan block
        built per sub-interval (:func:`_reference_discretize`); the two give the same bytes
        (``tests/unit/envs/simulation/test_simulation.py``).

    Raises
    ------
    ValueError
        If ``dt`` is not positive or a delay is shorter than ``dt`` (the recursion is explicit only
        when every delay covers at least one sample), or ``method`` is unknown.
    """
    if method not in ("fast", "reference"):
        raise ValueError(f"method must be 'fast' or 'reference', got {method!r}")
    if not dt > 0 or not np.isfinite(dt):
        raise ValueError(f"dt must be finite and > 0, got {dt!r}")
    delays = np.asarray(system.delays, dtype=float)
    if delays.size and np.min(delays) < dt * (1 - 1e-12):
        raise ValueError(f"every delay must be >= dt={dt:g}; got min delay {np.min(delays):g}")
    if method == "reference":
        return _reference_discretize(system, dt)
    whole, fraction = _split_delays(delays, dt)
    n, nv = system.n_states, delays.size
    fractions = fraction.tolist()
    breaks = sorted({0.0, float(dt), *(f for f in fractions if f > 0)})  # the values of np.unique
    unit = _unit_block(system.A) if n else None
    weights = [_channel_weights(s, fractions, dt) for s in breaks]
    P = np.eye(n)
    Q = np.zeros((n, system.n_inputs))
    R = np.zeros((n, nv, 3))
    for m in range(len(breaks) - 1):
        a, b = breaks[m], breaks[m + 1]
        E, psi0, psi1 = _integrals(system.A, b - a, unit) if n else (np.eye(0),) * 3
        ca = np.array(weights[m], dtype=float).reshape(nv, 3)
        slope = np.array(  # (cb - ca)/(b - a), element by element
            [[(q - p) / (b - a) for p, q in zip(before, after)] for before, after in zip(weights[m], weights[m + 1])],
            dtype=float,
        ).reshape(nv, 3)
        P, Q, R = _propagate(system, P, Q, R, (E, psi0, psi1), ca, slope)
    return DiscreteDelaySystem(system, float(dt), P, Q, R, whole, fraction)


def _split_delays(delays: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """Each delay as whole samples plus a fractional part in ``[0, dt)`` (below ``1e-9 dt``: 0)."""
    whole = np.floor(delays / dt + 1e-9).astype(int)
    fraction = delays - whole * dt
    fraction[fraction < 1e-9 * dt] = 0.0
    return whole, fraction


def _propagate(system: DelaySystem, P: np.ndarray, Q: np.ndarray, R: np.ndarray, integrals: tuple,
               ca: np.ndarray, slope: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The one-step map ``(P, Q, R)`` carried over one sub-interval: ``integrals = (E, psi0, psi1)``
    of ``A`` over it, the delayed inputs linear with weights ``ca`` at its start and ``slope``."""
    E, psi0, psi1 = integrals
    P = E @ P
    Q = E @ Q + psi0 @ system.B1
    R = (
        np.einsum("ab,bik->aik", E, R)
        + np.einsum("ab,bi,ik->aik", psi0, system.B2, ca)
        + np.einsum("ab,bi,ik->aik", psi1, system.B2, slope)
    )
    return P, Q, R


def _reference_integrals(A: np.ndarray, span: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`_integrals` with the block ``[[A T, I T, 0], [0, 0, I T], [0, 0, 0]]`` built for ``T = span``."""
    n = A.shape[0]
    block = np.zeros((3 * n, 3 * n))
    block[:n, :n] = A * span
    block[:n, n : 2 * n] = np.eye(n) * span
    block[n : 2 * n, 2 * n :] = np.eye(n) * span
    e = scipy.linalg.expm(block)
    return e[:n, :n], e[:n, n : 2 * n], e[:n, 2 * n :]


def _reference_channel_weights(s: float, fraction: np.ndarray, dt: float) -> np.ndarray:
    """:func:`_channel_weights` as an array ``c[i, k]``, computed for all channels at once."""
    c = np.zeros((fraction.size, 3))
    before = s <= fraction
    c[before, 0] = (fraction[before] - s) / dt
    c[before, 1] = (dt - fraction[before] + s) / dt
    after = ~before
    c[after, 1] = 1.0 - (s - fraction[after]) / dt
    c[after, 2] = (s - fraction[after]) / dt
    return c


def _reference_discretize(system: DelaySystem, dt: float) -> DiscreteDelaySystem:
    """``discretize(..., method="reference")``: the map over the sub-intervals of ``[0, dt]`` between
    the delays' fractional parts, on each the exact propagation for a linear delayed input."""
    delays = np.asarray(system.delays, dtype=float)
    whole, fraction = _split_delays(delays, dt)
    n, nv = system.n_states, delays.size
    breaks = np.unique(np.concatenate([[0.0, dt], fraction[(fraction > 0)]]))
    P, Q, R = np.eye(n), np.zeros((n, system.n_inputs)), np.zeros((n, nv, 3))
    for a, b in zip(breaks[:-1], breaks[1:]):
        E, psi0, psi1 = _reference_integrals(system.A, b - a) if n else (np.eye(0),) * 3
        ca, cb = _reference_channel_weights(a, fraction, dt), _reference_channel_weights(b, fraction, dt)
        slope = (cb - ca) / (b - a)
        P, Q, R = _propagate(system, P, Q, R, (E, psi0, psi1), ca, slope)
    return DiscreteDelaySystem(system, float(dt), P, Q, R, whole, fraction)


@dataclass(frozen=True)
class SimulationResult:
    """Sampled outputs ``z`` at ``timepts``; ``diverged`` if the state left every sane bound."""

    timepts: np.ndarray
    outputs: np.ndarray
    diverged: bool


def simulate(discrete: DiscreteDelaySystem, inputs: np.ndarray) -> SimulationResult:
    """Simulate one system from rest; see :func:`simulate_batch`.

    Parameters
    ----------
    discrete : DiscreteDelaySystem
    inputs : ndarray, shape (n_steps, n_inputs)
        ``d[j]``, held over ``[j dt, (j+1) dt)``.
    """
    d = np.asarray(inputs, dtype=float).reshape(-1, discrete.system.n_inputs)
    return simulate_batch([discrete], d[None])[0]


def _stack(discretes: Sequence[DiscreteDelaySystem]) -> dict[str, np.ndarray]:
    """Zero-pad the systems to common state and delay-channel counts and stack them."""
    n = max(d.system.n_states for d in discretes)
    nv = max(d.system.delays.size for d in discretes)
    nd, nz = discretes[0].system.n_inputs, discretes[0].system.n_outputs
    if any(d.system.n_inputs != nd or d.system.n_outputs != nz for d in discretes):
        raise ValueError("batched systems must have the same numbers of inputs and outputs")
    B = len(discretes)
    out = {
        "Phi": np.zeros((B, n, n)), "Gamma": np.zeros((B, n, nd)), "R": np.zeros((B, n, nv, 3)),
        "C1": np.zeros((B, nz, n)), "D11": np.zeros((B, nz, nd)), "D12": np.zeros((B, nz, nv)),
        "C2": np.zeros((B, nv, n)), "D21": np.zeros((B, nv, nd)), "D22": np.zeros((B, nv, nv)),
        "whole": np.ones((B, nv), dtype=int), "a": np.zeros((B, nv)),
    }
    for b, dis in enumerate(discretes):
        s, k, v = dis.system, dis.system.n_states, dis.system.delays.size
        out["Phi"][b, :k, :k], out["Gamma"][b, :k], out["R"][b, :k, :v] = dis.Phi, dis.Gamma, dis.R
        out["C1"][b, :, :k], out["D11"][b], out["D12"][b, :, :v] = s.C1, s.D11, s.D12
        out["C2"][b, :v, :k], out["D21"][b, :v], out["D22"][b, :v, :v] = s.C2, s.D21, s.D22
        out["whole"][b, :v], out["a"][b, :v] = dis.whole_samples, dis.fraction / dis.dt
    out["R"] = out["R"].reshape(B, n, nv * 3)
    return out


def loop_arrays(discrete: DiscreteDelaySystem) -> tuple[np.ndarray, ...]:
    """The arrays of the compiled recursion (:func:`envs.simulation._run_kernels._loop_sample`) of one system:
    ``Phi, Gamma, R, C1, D11, D12, C2, D21, D22, whole, a`` with ``R`` of shape ``(n, 3 n_v)`` and
    ``a = fraction/dt``, the values of ``_stack([discrete])`` (contiguous, float64 and int64)."""
    s = discrete.system
    n, nv = s.n_states, s.delays.size
    floats = [discrete.Phi, discrete.Gamma, discrete.R.reshape(n, 3 * nv), s.C1, s.D11, s.D12, s.C2, s.D21, s.D22]
    arrays = [np.ascontiguousarray(m, dtype=np.float64) for m in floats]
    whole = np.ascontiguousarray(discrete.whole_samples, dtype=np.int64)
    return (*arrays, whole, discrete.fraction / discrete.dt)


def simulate_batch(discretes: Sequence[DiscreteDelaySystem], inputs: np.ndarray) -> list[SimulationResult]:
    """Simulate many systems at once, from rest, vectorized over the batch.

    Parameters
    ----------
    discretes : sequence of DiscreteDelaySystem
        Systems with the same numbers of inputs and outputs (state and delay counts may differ;
        each keeps its own sample time).
    inputs : ndarray, shape (n_systems, n_steps, n_inputs)
        ``d[b, j]``, held over ``[j dt_b, (j+1) dt_b)``.

    Returns
    -------
    list of SimulationResult
        ``outputs[j] = z(j dt)``.  A system whose state exceeds ``DIVERGENCE_LIMIT`` times its largest input
        is stopped: its remaining outputs are ``nan`` and ``diverged`` is True.
    """
    d = np.ascontiguousarray(inputs, dtype=float)
    M = _stack(discretes)
    limit = DIVERGENCE_LIMIT * np.maximum(1.0, np.max(np.abs(d), axis=(1, 2)) if d.size else 1.0)
    z, alive = _run(
        M["Phi"], M["Gamma"], M["R"], M["C1"], M["D11"], M["D12"], M["C2"], M["D21"], M["D22"],
        M["whole"], M["a"], d, limit,
    )
    steps = d.shape[1]
    return [
        SimulationResult(timepts=np.arange(steps) * dis.dt, outputs=z[b], diverged=not alive[b])
        for b, dis in enumerate(discretes)
    ]


def delayed_zoh(
    state_space, delay: float, dt: float, *, method: str = "fast"
) -> tuple[np.ndarray, np.ndarray, np.ndarray, int]:
    """Exact ZOH discretization of ``G(s) e^{-L s}`` for a piecewise-constant input.

    With ``L = m dt + f`` (``0 <= f < dt``), the delayed input over ``[j dt, (j+1) dt)`` equals
    ``u[j-m-1]`` on ``[0, f)`` and ``u[j-m]`` on ``[f, dt)``, so
    ``x[j+1] = Phi x[j] + Gamma1 u[j-m-1] + Gamma0 u[j-m]`` with
    ``Gamma0 = int_0^{dt-f} e^{A s} ds B`` and ``Gamma1 = e^{A (dt-f)} int_0^f e^{A s} ds B``
    (the modified z-transform).  Returns ``(Phi, Gamma0, Gamma1, m)``; the output at ``j dt`` is
    ``C x[j] + D u(j dt - L)``.  ``method`` is ``"fast"`` (default: one unit block scaled per
    interval) or ``"reference"`` (the Van Loan block built per interval,
    :func:`_reference_integrals`); the two give the same bytes.
    """
    if method not in ("fast", "reference"):
        raise ValueError(f"method must be 'fast' or 'reference', got {method!r}")
    A, B = state_space.A, state_space.B
    m = int(np.floor(delay / dt + 1e-9))
    f = delay - m * dt
    if f < 1e-9 * dt:
        f = 0.0
    if method == "reference":
        integrals = _reference_integrals
    else:
        unit = _unit_block(A)

        def integrals(A: np.ndarray, span: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
            return _integrals(A, span, unit)

    Phi, psi_full, _ = integrals(A, dt)
    if f == 0.0:
        return Phi, psi_full @ B, np.zeros_like(B), m
    E_rest, psi_rest, _ = integrals(A, dt - f)
    _, psi_f, _ = integrals(A, f)
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
    C = np.array(state_space.C, dtype=float).ravel()
    D = float(state_space.D.ravel()[0]) if state_space.D.size else 0.0
    g0, g1 = gamma0.ravel(), gamma1.ravel()
    direct = u_before if fractional else u_now
    y = np.empty(steps)
    _open_loop_run(np.ascontiguousarray(Phi), g0, g1, C, D, u_now, u_before, direct, np.zeros(Phi.shape[0]), y, 0)
    return y


class OpenLoopRun:
    """:func:`open_loop_response` over a growing horizon, continuing from the saved state.

    ``response(steps)`` returns the first ``steps`` outputs for ``inputs`` (the longest horizon), the
    same samples as ``open_loop_response(state_space, delay, inputs[:steps], dt)``: the recursion is
    causal, so it is only continued from the last horizon, and the discretization is done once.
    """

    def __init__(self, state_space, delay: float, inputs: np.ndarray, dt: float) -> None:
        u = np.asarray(inputs, dtype=float).ravel()
        Phi, gamma0, gamma1, m = delayed_zoh(state_space, delay, dt)
        fractional = bool(np.any(gamma1))
        padded = np.concatenate([np.zeros(m + 1), u])
        self._u_now, self._u_before = padded[1 : u.size + 1], padded[: u.size]
        self._direct = self._u_before if fractional else self._u_now
        self._C = np.array(state_space.C, dtype=float).ravel()
        self._D = float(state_space.D.ravel()[0]) if state_space.D.size else 0.0
        self._Phi, self._g0, self._g1 = np.ascontiguousarray(Phi), gamma0.ravel(), gamma1.ravel()
        self._x = np.zeros(Phi.shape[0])
        self._y = np.empty(u.size)
        self._done = 0

    def response(self, steps: int) -> np.ndarray:
        if steps > self._done:
            _open_loop_run(self._Phi, self._g0, self._g1, self._C, self._D, self._u_now[:steps], self._u_before[:steps],
                           self._direct[:steps], self._x, self._y, self._done)  # fmt: skip
            self._done = steps
        return self._y[:steps]


class LoopRun:
    """:func:`simulate` of one system over a growing horizon, continuing from the saved state and
    delay buffer.

    ``advance(inputs)`` returns the :class:`SimulationResult` of ``simulate(discrete, inputs)`` for a
    longer ``inputs`` each call (whose earlier rows are those of the previous calls), bit for bit:
    the recursion is causal, so only the new samples are computed.  As in :func:`simulate` the
    divergence limit is ``DIVERGENCE_LIMIT`` times the largest input so far; the earlier samples
    stayed below the earlier, smaller limit, hence below this one.  A run that diverged stays
    stopped (a restart with a larger limit would stop later): continue only runs that did not
    diverge.  ``capacity`` is the expected longest horizon (the buffers grow if a longer one comes).
    (The closed-loop step ran on it before its compiled run, :mod:`envs.simulation._run_kernels`; that run
    is ``closed_loop_step(..., method="reference")``.)
    """

    def __init__(self, discrete: DiscreteDelaySystem, capacity: int = 0) -> None:
        self._discrete = discrete
        self._M = {k: v[0] for k, v in _stack([discrete]).items()}
        self._offset = max([1] + [int(w) + 1 for w in self._M["whole"]])
        self._history = np.zeros((self._offset + 1, self._M["a"].size))
        self._x = np.zeros(self._M["Phi"].shape[0])
        self._z = np.full((0, discrete.system.n_outputs), np.nan)
        self._done = 0
        self._alive = True
        self._grow(capacity)

    def _grow(self, capacity: int) -> None:
        if capacity <= self._z.shape[0]:
            return
        z = np.full((capacity, self._z.shape[1]), np.nan)
        z[: self._z.shape[0]] = self._z
        history = np.zeros((self._offset + capacity + 1, self._history.shape[1]))
        history[: self._history.shape[0]] = self._history
        self._z, self._history = z, history

    def advance(self, inputs: np.ndarray, limit: float | None = None) -> SimulationResult:
        """The run up to ``len(inputs)`` samples; ``limit`` overrides the divergence limit (that of
        :func:`simulate` for ``inputs``), e.g. with that of a longer horizon simulated in parts."""
        d = np.ascontiguousarray(inputs, dtype=float).reshape(-1, self._discrete.system.n_inputs)
        steps = d.shape[0]
        self._grow(max(steps, 2 * self._z.shape[0]) if steps > self._z.shape[0] else 0)
        if steps > self._done and self._alive:
            if limit is None:
                limit = DIVERGENCE_LIMIT * max(1.0, float(np.max(np.abs(d))) if d.size else 1.0)
            M = self._M
            self._alive = _run_one(
                M["Phi"], M["Gamma"], M["R"], M["C1"], M["D11"], M["D12"], M["C2"], M["D21"], M["D22"], M["whole"],
                M["a"], d, limit, self._offset, self._z, self._x, self._history, self._done,
            )  # fmt: skip
        self._done = max(self._done, steps)
        return SimulationResult(
            timepts=np.arange(steps) * self._discrete.dt, outputs=self._z[:steps], diverged=not self._alive
        )


@numba.njit(cache=True)
def _open_loop_run(Phi, g0, g1, C, D, u_now, u_before, direct, x, y, start):  # pragma: no cover - compiled
    """The recursion of :func:`open_loop_response` from sample ``start``: ``y[j] = C x[j] + D direct[j]``,
    ``x[j+1] = Phi x[j] + g0 u_now[j] + g1 u_before[j]``; ``x`` is the state at ``start`` (updated in
    place, ``x[0] = 0`` from rest)."""
    n = Phi.shape[0]
    x_next = np.zeros(n)
    for j in range(start, u_now.size):
        acc = 0.0
        for k in range(n):
            acc += C[k] * x[k]
        y[j] = acc + D * direct[j]
        for r in range(n):
            acc = 0.0
            for k in range(n):
                acc += Phi[r, k] * x[k]
            x_next[r] = acc + g0[r] * u_now[j] + g1[r] * u_before[j]
        for r in range(n):  # an explicit loop: numba's slice assignment is slow for short vectors (-12%)
            x[r] = x_next[r]


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
