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

Here: the continuous system, :class:`SystemBuilder` that writes one from linear equations, and the
bounds of every run (:data:`MAX_RUN_SAMPLES`, :func:`divergence_limit`).  Their exact discretization
is :mod:`envs.simulation.discretization`; runs of the discrete systems, :mod:`envs.simulation.runs`
(compiled in :mod:`envs.simulation._run_kernels`); an open loop's response to a held input,
:mod:`envs.simulation.open_loop`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["DelaySystem", "SystemBuilder", "MAX_RUN_SAMPLES", "DIVERGENCE_LIMIT", "divergence_limit"]


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
