"""The exact sampled one-step map of a system with dead times (see :mod:`envs.simulation.delay_systems`).

:func:`discretize` gives the :class:`DiscreteDelaySystem` of a :class:`~envs.simulation.delay_systems.DelaySystem`:
the state propagated exactly (matrix exponentials of an augmented system) for inputs held over each
sample and delayed signals interpolated linearly between samples, the fractional part of each delay
handled exactly.  :func:`delayed_zoh` is the open loop's case, ``G(s) e^{-L s}`` under a zero-order
hold (the modified z-transform).  Both have a readable reference (``method="reference"``: the Van
Loan block built per interval), the same bytes as the default.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.linalg

from envs.simulation.delay_systems import DelaySystem

__all__ = ["DiscreteDelaySystem", "discretize", "delayed_zoh"]


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
