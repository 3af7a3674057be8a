"""Runs of discrete systems with dead times, from rest: one, a batch, or one over a growing horizon.

:func:`simulate` and :func:`simulate_batch` run the recursion of
:class:`~envs.simulation.discretization.DiscreteDelaySystem` over a horizon, :class:`LoopRun`
continues one run as the horizon grows (bit for bit the same samples); the recursion is compiled in
:mod:`envs.simulation._run_kernels`, to which :func:`loop_arrays` hands one system's arrays.  A run
stops where its state exceeds the divergence limit times its largest input
(:mod:`envs.simulation.delay_systems`).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from envs.simulation._run_kernels import _run, _run_one
from envs.simulation.delay_systems import DIVERGENCE_LIMIT
from envs.simulation.discretization import DiscreteDelaySystem

__all__ = ["SimulationResult", "simulate", "simulate_batch", "loop_arrays", "LoopRun"]


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
