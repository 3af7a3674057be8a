"""The control error of a discretized closed loop after unit load and set-point steps, compiled.

:func:`envs.performance.iae` needs, for each horizon, only the error ``e = r - y`` of two runs of
the same :class:`~envs.simulation.DiscreteDelaySystem` (inputs ``[r, l, n]``): a unit load step
and a unit set-point step, from rest.  :class:`StepErrorRuns` advances both runs together in one
compiled call (:func:`_advance`) and returns, for the samples so far, each run's
``integrated_absolute_error`` and that of its last tenth (the settling test of
:mod:`envs.performance`).

It computes the same numbers as the general path, bit for bit: the recursion is that of
:func:`envs.simulation.simulate` (same operations in the same order, with the terms of the inputs
that are zero skipped, which adds exact zeros there), the areas are those of
:func:`envs.performance.integrated_absolute_error`, and their sums use numpy's pairwise summation
(:func:`_pairwise_sum`), as ``np.sum`` does.  The tests check this.
"""

from __future__ import annotations

import numba
import numpy as np

from envs.simulation import DIVERGENCE_LIMIT, DiscreteDelaySystem

__all__ = ["StepErrorRuns", "RunSums"]

LOAD, SETPOINT = 1, 0  # the input columns of the closed loop (envs.loops.INPUTS)
ERROR = 2  # the output row of the closed loop (envs.loops.OUTPUTS)


class RunSums:
    """The integrated absolute errors of both runs up to ``steps`` samples.

    ``totals[k]`` and ``tails[k]`` (``k = 0`` load, ``1`` set point) are
    ``integrated_absolute_error(e_k[:steps], dt)`` and that of ``e_k[steps - max(steps // 10, 2):]``.
    """

    __slots__ = ("diverged", "totals", "tails")

    def __init__(self, diverged: bool, totals: tuple[float, float], tails: tuple[float, float]) -> None:
        self.diverged, self.totals, self.tails = diverged, totals, tails


class StepErrorRuns:
    """Both step runs of one loop over a growing horizon (see the module docstring).

    ``advance(steps)`` continues the runs from their saved state to ``steps`` samples; as for
    :class:`~envs.simulation.LoopRun`, a run that diverged stays stopped.
    """

    def __init__(self, discrete: DiscreteDelaySystem) -> None:
        s = discrete.system
        n, nv = s.n_states, s.delays.size
        self._dt = discrete.dt
        self._matrices = (
            np.ascontiguousarray(discrete.Phi), np.ascontiguousarray(discrete.Gamma[:, [LOAD, SETPOINT]]),
            np.ascontiguousarray(discrete.R.reshape(n, nv * 3)), np.ascontiguousarray(s.C1[ERROR]),
            np.array([s.D11[ERROR, LOAD], s.D11[ERROR, SETPOINT]]), np.ascontiguousarray(s.D12[ERROR]),
            np.ascontiguousarray(s.C2), np.ascontiguousarray(s.D21[:, [LOAD, SETPOINT]]),
            np.ascontiguousarray(s.D22), np.asarray(discrete.whole_samples, dtype=np.int64),
            discrete.fraction / discrete.dt,
        )  # fmt: skip
        size = 4
        while size < int(np.max(discrete.whole_samples, initial=0)) + 3:
            size *= 2
        self._x = np.zeros((n, 2))
        self._history = np.zeros((size, nv, 2))  # a ring buffer of the delayed signals w
        self._last = np.zeros(2)  # the last error of each run
        self._areas = np.zeros((2, 0))
        self._done = 0
        self._alive = True

    def advance(self, steps: int) -> RunSums:
        if steps > self._areas.shape[1] + 1:
            areas = np.zeros((2, max(steps - 1, 2 * self._areas.shape[1])))
            areas[:, : self._areas.shape[1]] = self._areas
            self._areas = areas
        if steps > self._done and self._alive:
            self._alive = _advance(
                *self._matrices, DIVERGENCE_LIMIT, self._x, self._history, self._last, self._areas, self._done, steps
            )
            self._done = steps
        if not self._alive:
            return RunSums(True, (np.inf, np.inf), (np.inf, np.inf))
        totals, tails = _sums(self._areas, steps, self._dt)
        return RunSums(False, (float(totals[0]), float(totals[1])), (float(tails[0]), float(tails[1])))


@numba.njit(cache=True)
def _advance(Phi, gamma, R, c_e, d_e, f_e, C2, d_w, D22, whole, a, limit, x, history, last, areas, start, stop):  # pragma: no cover
    """Samples ``start .. stop - 1`` of both runs (column 0: load, 1: set point); stores the areas
    of ``|e|`` between consecutive samples; returns False if a run diverged (stopped there).

    ``x[:, k]`` is the state of run ``k``, ``history[j mod size, i, k]`` its delayed signal ``w_i[j]``;
    ``gamma[:, k]``, ``d_e[k]``, ``d_w[:, k]`` are the columns of ``Gamma``, ``D11[e]``, ``D21`` for
    the input of run ``k``; ``c_e``, ``f_e`` the rows of ``C1``, ``D12`` for the error.  Every sum is
    in the order of :func:`envs.simulation._run_one`; the two runs share each coefficient load.
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
        load, setpoint = _pair(c_e, x, d_e, f_e, v)  # the error e[j] = C1[e] x + D11[e] d + D12[e] v
        if j > 0:
            areas[0, j - 1] = _area(last[0], load)
            areas[1, j - 1] = _area(last[1], setpoint)
        last[0], last[1] = load, setpoint
        for i in range(nv):  # w_i[j] = C2 x + D21 d + D22 v
            history[j & mask, i, 0], history[j & mask, i, 1] = _pair(C2[i], x, d_w[i], D22[i], v)
        for i in range(nv):  # w_i[j - m_i - 1 + m], m = 0, 1, 2
            for m in range(3):
                row = (j - whole[i] - 1 + m) & mask
                past[3 * i + m, 0], past[3 * i + m, 1] = history[row, i, 0], history[row, i, 1]
        bounded = True
        for r in range(n):  # x[j + 1] = Phi x + Gamma d + R past
            load, setpoint = _pair(Phi[r], x, gamma[r], R[r], past)
            x_next[r, 0], x_next[r, 1] = load, setpoint
            bounded = bounded and abs(load) < limit and abs(setpoint) < limit
        x[:, :] = x_next
        if not bounded:
            return False
    return True


@numba.njit(cache=True, inline="always")
def _pair(row, x, inputs, weights, signals):  # pragma: no cover - compiled
    """``row . x[:, k] + inputs[k] + weights . signals[:, k]`` for both runs ``k``, summed in that
    order (that of :func:`envs.simulation._affine`); the two runs share each coefficient load."""
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
def _area(a, b):  # pragma: no cover - compiled
    """``int |e|`` over one interval for linear ``e`` from ``a`` to ``b`` (over ``dt = 1``), as
    :func:`envs.performance.integrated_absolute_error` computes it."""
    if a * b >= 0:
        return 0.5 * (abs(a) + abs(b))
    return 0.5 * (a * a + b * b) / (abs(a) + abs(b))


@numba.njit(cache=True)
def _sums(areas, steps, dt):  # pragma: no cover - compiled
    """Totals and tails (see :class:`RunSums`) of both runs from the stored areas."""
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
