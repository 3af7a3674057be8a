"""The exact sampled response of an open loop ``G(s) e^{-L s}`` to a piecewise-constant input.

:func:`open_loop_response` from rest, :class:`OpenLoopRun` over a growing horizon (the same samples);
both discretize once by :func:`~envs.simulation.discretization.delayed_zoh` and run the compiled
recursion :func:`_open_loop_run` beside them.
"""

from __future__ import annotations

import numba
import numpy as np

from envs.simulation.discretization import delayed_zoh

__all__ = ["open_loop_response", "OpenLoopRun"]


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
    The delayed inputs are copied out of ``inputs`` as the horizon grows (at least doubling), not
    for the longest horizon at once: a run that settles early touches a few pages of a long cap.
    """

    def __init__(self, state_space, delay: float, inputs: np.ndarray, dt: float) -> None:
        self._u = np.asarray(inputs, dtype=float).ravel()
        Phi, gamma0, gamma1, self._m = delayed_zoh(state_space, delay, dt)
        self._fractional = bool(np.any(gamma1))
        self._C = np.array(state_space.C, dtype=float).ravel()
        self._D = float(state_space.D.ravel()[0]) if state_space.D.size else 0.0
        self._Phi, self._g0, self._g1 = np.ascontiguousarray(Phi), gamma0.ravel(), gamma1.ravel()
        self._x = np.zeros(Phi.shape[0])
        self._y = np.empty(self._u.size)
        self._done = self._copied = 0

    def _delayed_inputs(self, steps: int) -> None:
        """The delayed inputs of at least the first ``steps`` samples: slices of
        ``[0] * (m + 1) + inputs[:copied]``, the first samples of :func:`open_loop_response`'s ``padded``."""
        copied = min(max(steps, 2 * self._copied), self._u.size)
        padded = np.concatenate([np.zeros(self._m + 1), self._u[:copied]])  # padded[k + m + 1] = u[k]
        self._u_now, self._u_before = padded[1 : copied + 1], padded[:copied]
        self._direct = self._u_before if self._fractional else self._u_now
        self._copied = copied

    def response(self, steps: int) -> np.ndarray:
        if steps > self._done:
            if steps > self._copied:
                self._delayed_inputs(steps)
            _open_loop_run(self._Phi, self._g0, self._g1, self._C, self._D, self._u_now[:steps], self._u_before[:steps],
                           self._direct[:steps], self._x, self._y, self._done)  # fmt: skip
            self._done = steps
        return self._y[:steps]


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
