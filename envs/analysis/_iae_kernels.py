"""The IAE of a closed loop in one compiled call: its one-step map, both step runs, the horizons.

:func:`envs.analysis.performance.iae` assembles the loop (:func:`envs.simulation.loops.loop_rows`) and hands it to
:func:`step_iae`, which does the rest without returning to Python, so that the cost is the
arithmetic and not the glue around it:

1. the one-step map (:func:`~envs.analysis._discretization_kernels._discretize`, that of
   :func:`envs.simulation.discretization.discretize`, see that module);
2. whether the error keeps a steady offset after each step (:func:`_steady_offsets`, the loop's
   DC gain);
3. both step runs (a unit load step and a unit set-point step, from rest) over the horizons of
   :mod:`envs.analysis.performance`, each horizon continuing the last (:func:`_advance`), with the
   trapezoidal areas of ``|e|`` and their sums (:func:`_sums`), the settling test and the test
   of the :class:`~envs.analysis.performance.IAEBound` after each (:func:`_verdict`).

The one-step map is that of :mod:`envs.analysis._discretization_kernels` (:func:`discretize_compiled`,
:func:`expm`): compiled functions call compiled functions of other modules of this package, whose
cache :mod:`envs._kernel_cache` keeps fresh.

The runs.  They compute the numbers of the general path on the same map, bit for bit: the
recursion is that of :func:`envs.simulation.runs.simulate` (same operations in the same order, with the
terms of the inputs that are zero skipped, which adds exact zeros there), the areas are those of
:func:`envs.analysis.performance.integrated_absolute_error`, and their sums use numpy's pairwise summation
(:func:`_pairwise_sum`), as ``np.sum`` does.  The steady offsets are decided by a Gaussian
elimination (``_solve``, that of :func:`expm`) instead of ``numpy.linalg.solve`` (:meth:`~envs.simulation.delay_systems.DelaySystem.dc_gain`):
only the decision enters the result, and the gains are either zero to rounding (integral action,
``< 1e-14``) or of the order of one, far from the tolerance ``1e-9``.  The tests check all of this
against the general path (``tests/unit/fast_paths/test_resumable_runs.py``).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from envs.analysis._discretization_kernels import _discretize, _solve, discretize_compiled, expm
from envs.analysis._discretization_kernels import _product  # noqa: F401  (its tests import it from here)

__all__ = ["discretize_compiled", "expm", "step_iae"]

LOAD, SETPOINT = 1, 0  # the input columns of the closed loop (envs.simulation.loops.INPUTS)
ERROR = 2  # the output row of the closed loop (envs.simulation.loops.OUTPUTS)


@numba.njit(cache=True)
def step_iae(
    derivatives, outputs, delayed, delays, dt, scale, horizon, max_horizon, settled_share, offset_tolerance,
    divergence_limit, load_weight, setpoint_weight, threshold,
):  # pragma: no cover - compiled
    """The IAE of a loop for a unit load and a unit set-point step (see the module docstring).

    Parameters
    ----------
    derivatives, outputs, delayed : ndarray
        The loop's rows over ``[x, d, v]`` (:func:`envs.simulation.loops.loop_rows`): ``[A, B1, B2]``,
        ``[C1, D11, D12]``, ``[C2, D21, D22]``, C-contiguous; ``d = [r, l, n]``, ``z = [y, u, e]``.
    delays : ndarray
        The delays of ``v``, each at least ``dt``.
    dt, scale : float
        The sample time and the plant's time scale (horizons are multiples of ``scale``).
    horizon, max_horizon : float
        The first and the longest horizon, in units of ``scale`` (the horizon doubles in between).
    settled_share, offset_tolerance, divergence_limit : float
        The settling share, the largest DC gain that is no offset, the bound on the states.
    load_weight, setpoint_weight, threshold : float
        A run that has not settled stops at the first horizon where
        ``load_weight IAE_load + setpoint_weight IAE_setpoint > threshold`` (``inf``: never).

    Returns
    -------
    tuple
        ``(load, setpoint, settled, horizon, lower_bound)`` of :class:`~envs.analysis.performance.IAEResult`.
    """
    n = derivatives.shape[0]
    Phi, Gamma, R, whole, fraction = _discretize(
        derivatives[:, :n].copy(), derivatives[:, n : n + 3].copy(), derivatives[:, n + 3 :].copy(), delays, dt
    )
    offsets = _steady_offsets(derivatives, outputs, delayed, offset_tolerance)
    gamma, c_e, d_e, f_e, C2, d_w, D22 = _run_rows(Gamma, outputs, delayed, n)
    past_weights, a = R.reshape(n, 3 * delays.size), fraction / dt
    x, history, last = np.zeros((n, 2)), np.zeros((_ring_size(whole), delays.size, 2)), np.zeros(2)
    areas, done = np.zeros((2, 0)), 0
    while True:
        steps = int(math.ceil(horizon * scale / dt)) + 1
        areas = _room(areas, steps)
        alive = _advance(Phi, gamma, past_weights, c_e, d_e, f_e, C2, d_w, D22, whole, a, divergence_limit, x, history, last, areas, done, steps)
        if not alive:
            return math.inf, math.inf, True, horizon, False
        done = steps
        totals, tails = _sums(areas, steps, dt)
        finished, load, setpoint, settled, lower_bound = _verdict(
            totals, tails, offsets, horizon < max_horizon, settled_share, load_weight, setpoint_weight, threshold
        )
        if finished:
            return load, setpoint, settled, horizon, lower_bound
        horizon *= 2


@numba.njit(cache=True)
def _verdict(totals, tails, offsets, longer, settled_share, load_weight, setpoint_weight, threshold):  # pragma: no cover
    """``(finished, load, setpoint, settled, lower_bound)`` after a horizon: finished if both runs
    settled (the IAE over the last tenth is below ``settled_share`` of the whole; a run with an
    offset has an infinite IAE and is not tested), if no ``longer`` horizon may follow, or if the
    weighted IAE so far exceeds ``threshold`` (then ``lower_bound``)."""
    load = math.inf if offsets[0] else totals[0]
    setpoint = math.inf if offsets[1] else totals[1]
    settled = True
    for k in range(2):
        if not offsets[k] and not tails[k] <= settled_share * max(totals[k], 1e-300):
            settled = False
    if settled or not longer:
        return True, load, setpoint, settled, False
    exceeded = load_weight * load + setpoint_weight * setpoint > threshold  # False for nan (0 inf)
    return exceeded, load, setpoint, False, exceeded


@numba.njit(cache=True)
def _steady_offsets(derivatives, outputs, delayed, tolerance):  # pragma: no cover - compiled
    """Whether the error keeps a steady offset after a unit load and a unit set-point step.

    The closed loop's DC gain (:meth:`~envs.simulation.delay_systems.DelaySystem.dc_gain`): ``0 = A x + B1 d +
    B2 v``, ``v = C2 x + D21 d + D22 v``, ``e = C1 x + D11 d + D12 v``; an offset is a gain above
    ``tolerance``.  A loop with a pole at the origin (a zero pivot) is left to the simulation.
    """
    n, nv = derivatives.shape[0], delayed.shape[0]
    lhs, rhs = np.empty((n + nv, n + nv)), np.empty((n + nv, 2))  # [[A, B2], [C2, D22 - I]], -[B1; D21]
    for r in range(n + nv):
        row = derivatives[r] if r < n else delayed[r - n]
        for c in range(n + nv):
            lhs[r, c] = row[c] if c < n else row[c + 3]
        rhs[r, 0], rhs[r, 1] = -row[n + LOAD], -row[n + SETPOINT]
        if r >= n:
            lhs[r, r] -= 1.0
    if not _solve(lhs, rhs):
        return False, False
    gains = np.array([outputs[ERROR, n + LOAD], outputs[ERROR, n + SETPOINT]])
    for k in range(2):
        for c in range(n):
            gains[k] += outputs[ERROR, c] * rhs[c, k]
        for i in range(nv):
            gains[k] += outputs[ERROR, n + 3 + i] * rhs[n + i, k]
    return abs(gains[0]) > tolerance, abs(gains[1]) > tolerance


@numba.njit(cache=True)
def _run_rows(Gamma, outputs, delayed, n):  # pragma: no cover - compiled
    """The rows of the map and of the loop that the runs use, contiguous (see :func:`_advance`):
    ``gamma``, ``c_e``, ``d_e``, ``f_e``, ``C2``, ``d_w``, ``D22``."""
    nv = delayed.shape[0]
    gamma, d_w, d_e = np.empty((n, 2)), np.empty((nv, 2)), np.empty(2)
    c_e, f_e, C2, D22 = np.empty(n), np.empty(nv), np.empty((nv, n)), np.empty((nv, nv))
    for k, column in enumerate((LOAD, SETPOINT)):  # explicit loops: quicker to compile than slicing
        d_e[k] = outputs[ERROR, n + column]
        for r in range(n):
            gamma[r, k] = Gamma[r, column]
        for i in range(nv):
            d_w[i, k] = delayed[i, n + column]
    for c in range(n):
        c_e[c] = outputs[ERROR, c]
        for i in range(nv):
            C2[i, c] = delayed[i, c]
    for c in range(nv):
        f_e[c] = outputs[ERROR, n + 3 + c]
        for i in range(nv):
            D22[i, c] = delayed[i, n + 3 + c]
    return gamma, c_e, d_e, f_e, C2, d_w, D22


@numba.njit(cache=True)
def _ring_size(whole):  # pragma: no cover - compiled
    """The rows of the ring buffer of the delayed signals: a power of two above the longest delay."""
    size = 4
    while size < (np.max(whole) if whole.size else 0) + 3:
        size *= 2
    return size


@numba.njit(cache=True)
def _room(areas, steps):  # pragma: no cover - compiled
    """``areas``, or a copy grown (at least doubled) to hold the ``steps - 1`` areas of ``steps`` samples."""
    if steps <= areas.shape[1] + 1:
        return areas
    grown = np.zeros((2, max(steps - 1, 2 * areas.shape[1])))
    for k in range(2):
        for j in range(areas.shape[1]):
            grown[k, j] = areas[k, j]
    return grown


@numba.njit(cache=True)
def _advance(Phi, gamma, R, c_e, d_e, f_e, C2, d_w, D22, whole, a, limit, x, history, last, areas, start, stop):  # pragma: no cover
    """Samples ``start .. stop - 1`` of both runs (column 0: load, 1: set point); stores the areas
    of ``|e|`` between consecutive samples; returns False if a run diverged (stopped there).

    ``x[:, k]`` is the state of run ``k``, ``history[j mod size, i, k]`` its delayed signal ``w_i[j]``;
    ``gamma[:, k]``, ``d_e[k]``, ``d_w[:, k]`` are the columns of ``Gamma``, ``D11[e]``, ``D21`` for
    the input of run ``k``; ``c_e``, ``f_e`` the rows of ``C1``, ``D12`` for the error.  Every sum is
    in the order of :func:`envs.simulation._run_kernels._run_one`; the two runs share each coefficient load.
    """
    n, nv = Phi.shape[0], a.size
    mask = history.shape[0] - 1
    v = np.zeros((nv, 2))
    past = np.zeros((3 * nv, 2))
    x_next = np.zeros((n, 2))
    for j in range(start, stop):
        for i in range(nv):  # v_i[j] = a_i w_i[j - m_i - 1] + (1 - a_i) w_i[j - m_i]
            early, late = (j - whole[i] - 1) & mask, (j - whole[i]) & mask
            for k in range(2):
                v[i, k] = a[i] * history[early, i, k] + (1.0 - a[i]) * history[late, i, k]
        if nv > 0:  # e[j] = C1[e] x + D11[e] d + D12[e] v and w_0[j] = C2[0] x + D21[0] d + D22[0] v
            load, setpoint, w_load, w_setpoint = _two_pairs(c_e, C2[0], x, d_e, d_w[0], f_e, D22[0], v)
            history[j & mask, 0, 0], history[j & mask, 0, 1] = w_load, w_setpoint
        else:
            load, setpoint = _pair(c_e, x, d_e, f_e, v)
        if j > 0:
            areas[0, j - 1] = _area(last[0], load)
            areas[1, j - 1] = _area(last[1], setpoint)
        last[0], last[1] = load, setpoint
        for i in range(1, nv):  # w_i[j] = C2 x + D21 d + D22 v
            history[j & mask, i, 0], history[j & mask, i, 1] = _pair(C2[i], x, d_w[i], D22[i], v)
        for i in range(nv):  # w_i[j - m_i - 1 + m], m = 0, 1, 2
            for m in range(3):
                row = (j - whole[i] - 1 + m) & mask
                past[3 * i + m, 0], past[3 * i + m, 1] = history[row, i, 0], history[row, i, 1]
        for r in range(0, n - 1, 2):  # x[j + 1] = Phi x + Gamma d + R past, two rows at a time
            load, setpoint, next_load, next_setpoint = _two_pairs(Phi[r], Phi[r + 1], x, gamma[r], gamma[r + 1], R[r], R[r + 1], past)
            x_next[r, 0], x_next[r, 1], x_next[r + 1, 0], x_next[r + 1, 1] = load, setpoint, next_load, next_setpoint
        if n % 2:
            x_next[n - 1, 0], x_next[n - 1, 1] = _pair(Phi[n - 1], x, gamma[n - 1], R[n - 1], past)
        bounded = True
        for r in range(n):  # an explicit loop: numba's slice assignment costs ~15% of the whole here
            bounded = bounded and abs(x_next[r, 0]) < limit and abs(x_next[r, 1]) < limit
            x[r, 0], x[r, 1] = x_next[r, 0], x_next[r, 1]
        if not bounded:
            return False
    return True


@numba.njit(cache=True, inline="always")
def _pair(row, x, inputs, weights, signals):  # pragma: no cover - compiled
    """``row . x[:, k] + inputs[k] + weights . signals[:, k]`` for both runs ``k``, summed in that
    order (that of :func:`envs.simulation._run_kernels._affine_rows`); the two runs share each coefficient load."""
    load, setpoint = 0.0, 0.0
    for c in range(x.shape[0]):
        load += row[c] * x[c, 0]
        setpoint += row[c] * x[c, 1]
    load += inputs[0]
    setpoint += inputs[1]
    for c in range(signals.shape[0]):
        load += weights[c] * signals[c, 0]
        setpoint += weights[c] * signals[c, 1]
    return load, setpoint


@numba.njit(cache=True, inline="always")
def _two_pairs(row, other, x, inputs, other_inputs, weights, other_weights, signals):  # pragma: no cover - compiled
    """:func:`_pair` of two rows at once: ``(run 0, run 1)`` of ``row``, then of ``other``, each
    summed in the order of :func:`_pair`.  Four independent sums in one loop, so that the processor
    overlaps them instead of waiting on one addition after the other."""
    load, setpoint, other_load, other_setpoint = 0.0, 0.0, 0.0, 0.0
    for c in range(x.shape[0]):
        x_load, x_setpoint = x[c, 0], x[c, 1]
        load += row[c] * x_load
        setpoint += row[c] * x_setpoint
        other_load += other[c] * x_load
        other_setpoint += other[c] * x_setpoint
    load += inputs[0]
    setpoint += inputs[1]
    other_load += other_inputs[0]
    other_setpoint += other_inputs[1]
    for c in range(signals.shape[0]):
        s_load, s_setpoint = signals[c, 0], signals[c, 1]
        load += weights[c] * s_load
        setpoint += weights[c] * s_setpoint
        other_load += other_weights[c] * s_load
        other_setpoint += other_weights[c] * s_setpoint
    return load, setpoint, other_load, other_setpoint


@numba.njit(cache=True, inline="always")
def _area(a, b):  # pragma: no cover - compiled
    """``int |e|`` over one interval for linear ``e`` from ``a`` to ``b`` (over ``dt = 1``), as
    :func:`envs.analysis.performance.integrated_absolute_error` computes it."""
    if a * b >= 0:
        return 0.5 * (abs(a) + abs(b))
    return 0.5 * (a * a + b * b) / (abs(a) + abs(b))


@numba.njit(cache=True)
def _sums(areas, steps, dt):  # pragma: no cover - compiled
    """The IAE of both runs over ``steps`` samples from the stored areas, and that of their last
    tenth: ``integrated_absolute_error(e_k[:steps], dt)`` and that of ``e_k[steps - max(steps // 10, 2):]``."""
    tail = max(steps // 10, 2)
    totals, tails = np.zeros(2), np.zeros(2)
    for k in range(2):
        totals[k] = _pairwise_sum(areas[k], 0, steps - 1) * dt
        tails[k] = _pairwise_sum(areas[k], steps - tail, steps - 1) * dt
    return totals, tails


@numba.njit(cache=True)
def _pairwise_sum(values, start, stop):  # pragma: no cover - compiled
    """``np.sum(values[start:stop])`` with numpy's pairwise summation (the same rounding): a range of
    more than 128 values is split in halves (the first a multiple of 8 long) and their sums added;
    a shorter one is summed by :func:`_block_sum`.  The recursion is written out with a stack (a
    cached numba function must not call itself)."""
    lows, highs, stages = np.empty(64, np.int64), np.empty(64, np.int64), np.empty(64, np.int64)
    sums = np.empty(64)
    lows[0], highs[0], stages[0] = start, stop, 0
    top, done = 1, 0  # entries on the range stack, sums on the value stack
    while top > 0:
        low, high, stage = lows[top - 1], highs[top - 1], stages[top - 1]
        half = (high - low) // 2
        half -= half % 8
        if high - low <= 128:
            sums[done] = _block_sum(values, low, high)
            done += 1
            top -= 1
        elif stage < 2:  # push the left (stage 0), then the right half (stage 1)
            stages[top - 1] = stage + 1
            lows[top], highs[top], stages[top] = (low, low + half, 0) if stage == 0 else (low + half, high, 0)
            top += 1
        else:  # both halves summed: add them
            sums[done - 2] = sums[done - 2] + sums[done - 1]
            done -= 1
            top -= 1
    return sums[0]


@numba.njit(cache=True)
def _block_sum(values, start, stop):  # pragma: no cover - compiled
    """numpy's pairwise sum of at most 128 values: 8 accumulators, unless fewer than 8 values."""
    count = stop - start
    if count < 8:
        total = 0.0
        for i in range(start, stop):
            total += values[i]
        return total
    r = values[start : start + 8].copy()
    i = start + 8
    end = stop - count % 8
    while i < end:
        for k in range(8):
            r[k] += values[i + k]
        i += 8
    total = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while i < stop:
        total += values[i]
        i += 1
    return total
