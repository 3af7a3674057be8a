"""Compiled kernels of the sampled runs: the loop recursion, the steady-state tests, and the
closed-loop step run that fuses them.

* :func:`_loop_sample` is one sample of the recursion of a
  :class:`~envs.simulation.discretization.DiscreteDelaySystem` (:func:`_run_one` and :func:`_run` run it over a
  horizon for :func:`envs.simulation.runs.simulate_batch` and :class:`envs.simulation.runs.LoopRun`);
* :func:`_add_sample` and :func:`_window_steady` are one sample of the running sums and one window
  of the tests of :func:`envs.identification.steady_state.steady_state_mask` (:func:`_extend_sums` and
  :func:`_tests` run them over new samples for :class:`envs.identification.steady_state.SteadyStateTest`);
* :func:`_closed_loop_run` runs the closed-loop step of :mod:`envs.identification.closed_loop_run` sample
  by sample (the loop, the measurement, the drive, both steady-state tests, the excursion
  and the divergence under the largest input so far) and stops at the first sample that settles or
  aborts.

They share one file because a compiled function may only call compiled functions of its own file:
numba's on-disk cache is per file and does not notice an edit to a function inlined from another
file.  Every sum is computed in one fixed order (that of the reference implementations, see each
docstring), so the results are bit for bit those of the vectorized code they replace.
"""

from __future__ import annotations

import math

import numba
import numpy as np

# The constants of the compiled tests are defined here (numba freezes them into the cache of this
# file) and re-exported by envs.identification.steady_state.
STEADY_STATE_TOLERANCE = 1e-5
"""Noise-free steady-state tolerance, relative to the change of the signal (a resolution)."""
CONFIDENCE = 3.0
"""Standard errors within which a window is "at" its target and "flat"."""

NO_EVENT, SETTLED, ABORTED = 0, 1, 2
"""Outcomes of :func:`_closed_loop_run`."""


# --------------------------------------------------------------------------- the loop recursion
@numba.njit(cache=True, inline="always")
def _loop_sample(Phi, Gamma, R, C1, D11, D12, C2, D21, D22, whole, a, d, r, limit, offset, j, z, x, x_next, v, past, history):  # pragma: no cover
    """Sample ``j`` of the recursion of :class:`~envs.simulation.discretization.DiscreteDelaySystem` for the input
    ``d[r]``: the outputs ``z[j]``, the delayed signals ``history[offset + j] = w[j]`` and the state
    ``x`` (from ``x[j]`` to ``x[j + 1]``, in place); returns False if a state reached ``limit`` (the
    state is updated all the same).

    ``history[offset + k, i]`` holds ``w_i[k]`` (zero for ``k < 0``, the system starts at rest);
    ``x_next``, ``v`` and ``past`` are scratch.  (Split into small inlined steps: numba compiled the
    same loops written as one inlined function twice as slow.)
    """
    _delayed_values(history, offset, j, whole, a, v)
    _affine_rows(C1, D11, D12, x, d, r, v, z, j)
    _affine_rows(C2, D21, D22, x, d, r, v, history, offset + j)
    _delayed_window(history, offset, j, whole, past)
    return _state_step(Phi, Gamma, R, x, d, r, past, x_next, limit)


@numba.njit(cache=True, inline="always")
def _delayed_values(history, offset, j, whole, a, v):  # pragma: no cover - compiled
    """``v_i[j] = a_i w_i[j - m_i - 1] + (1 - a_i) w_i[j - m_i]``."""
    for i in range(a.size):
        base = offset + j - whole[i] - 1
        v[i] = a[i] * history[base, i] + (1.0 - a[i]) * history[base + 1, i]


@numba.njit(cache=True, inline="always")
def _affine_rows(M1, M2, M3, x, d, r, v, out, row):  # pragma: no cover - compiled
    """``out[row, o] = M1[o] x + M2[o] d[r] + M3[o] v`` for every ``o``, each summed over ``x``, then
    ``d``, then ``v``, in index order, from ``0.0``."""
    for o in range(M1.shape[0]):
        acc = 0.0
        for k in range(x.size):
            acc += M1[o, k] * x[k]
        for k in range(d.shape[1]):
            acc += M2[o, k] * d[r, k]
        for k in range(v.size):
            acc += M3[o, k] * v[k]
        out[row, o] = acc


@numba.njit(cache=True, inline="always")
def _delayed_window(history, offset, j, whole, past):  # pragma: no cover - compiled
    """``past[3 i + k] = w_i[j - m_i - 1 + k]``, ``k = 0, 1, 2`` (``w[j]`` is known now)."""
    for i in range(whole.size):
        base = offset + j - whole[i] - 1
        for k in range(3):
            past[3 * i + k] = history[base + k, i]


@numba.njit(cache=True, inline="always")
def _state_step(Phi, Gamma, R, x, d, r, past, x_next, limit):  # pragma: no cover - compiled
    """``x <- Phi x + Gamma d[r] + R past`` (summed as in :func:`_affine_rows`); False if a state
    reached ``limit``."""
    bounded = True
    for o in range(x.size):
        acc = 0.0
        for k in range(x.size):
            acc += Phi[o, k] * x[k]
        for k in range(d.shape[1]):
            acc += Gamma[o, k] * d[r, k]
        for k in range(past.size):
            acc += R[o, k] * past[k]
        x_next[o] = acc
        bounded = bounded and abs(acc) < limit
    for o in range(x.size):  # an explicit loop: numba's slice assignment is slow for short vectors
        x[o] = x_next[o]
    return bounded


@numba.njit(cache=True)
def _run_one(Phi, Gamma, R, C1, D11, D12, C2, D21, D22, whole, a, d, limit, offset, z, x, history, start):  # pragma: no cover
    """One system from sample ``start`` to ``d.shape[0]`` (:func:`_loop_sample` for each): fills
    ``z[start:]`` and returns False if it diverged (stopped after that sample).  ``x`` (the state at
    ``start``, updated in place) and ``history`` (the delayed signals, at least
    ``offset + d.shape[0] + 1`` rows) carry the run between calls."""
    n, nv = Phi.shape[0], a.size
    x_next = np.zeros(n)
    v = np.zeros(nv)
    past = np.zeros(nv * 3)
    for j in range(start, d.shape[0]):
        if not _loop_sample(Phi, Gamma, R, C1, D11, D12, C2, D21, D22, whole, a, d, j, limit, offset, j, z, x,
                            x_next, v, past, history):  # fmt: skip
            return False
    return True


@numba.njit(cache=True)
def _run(Phi, Gamma, R, C1, D11, D12, C2, D21, D22, whole, a, d, limit):  # pragma: no cover - compiled
    """:func:`_run_one` over a stacked batch, each system from rest (``z`` is NaN after a divergence)."""
    B, steps, _ = d.shape
    nv = a.shape[1]
    offset = 1
    for b in range(B):
        for i in range(nv):
            offset = max(offset, whole[b, i] + 1)
    z = np.full((B, steps, C1.shape[1]), np.nan)
    alive = np.ones(B, dtype=np.bool_)
    for b in range(B):
        x = np.zeros(Phi.shape[1])
        history = np.zeros((offset + steps + 1, nv))
        alive[b] = _run_one(
            Phi[b], Gamma[b], R[b], C1[b], D11[b], D12[b], C2[b], D21[b], D22[b], whole[b], a[b], d[b], limit[b],
            offset, z[b], x, history, 0,
        )  # fmt: skip
    return z, alive


# --------------------------------------------------------------------------- the steady-state tests
@numba.njit(cache=True, inline="always")
def _add_sample(sums, y, k):  # pragma: no cover - compiled
    """Continue the running sums of ``y``, ``k y`` and the squared second difference to sample ``k``
    (``sums[:, k + 1]`` is the sum over samples ``0..k``), in the order of ``numpy.cumsum``."""
    value = y[k]
    curvature = (y[k] - y[k - 1]) - (y[k - 1] - y[k - 2]) if k >= 2 else 0.0
    sums[0, k + 1] = sums[0, k] + value
    sums[1, k + 1] = sums[1, k] + float(k) * value
    sums[2, k + 1] = sums[2, k] + curvature * curvature


@numba.njit(cache=True, inline="always")
def _window_steady(c, n, k, target, has_target, resolution):  # pragma: no cover - compiled
    """The tests of :func:`envs.identification.steady_state.steady_state_mask` for the window of ``n`` samples
    ending at ``k >= n - 1``, from the running sums ``c`` (each the same expression, in the same
    order, as the vectorized mask); a ``resolution`` (not 0) widens the test against the target by
    it: readings of a sensor of that step lie within it of the value."""
    total = c[0, k + 1] - c[0, k + 1 - n]
    mean = total / n
    centered = (c[1, k + 1] - c[1, k + 1 - n]) - (float(k) - (n - 1) / 2.0) * total
    change = centered / (n * (n * n - 1) / 12.0) * (n - 1)
    sigma = math.sqrt((c[2, k + 1] - c[2, k + 1 - n]) / n / 6.0)
    tol = STEADY_STATE_TOLERANCE * (abs(target) if has_target else abs(mean))
    ok = abs(change) <= CONFIDENCE * sigma * math.sqrt(12.0 / n) + tol
    if has_target:
        bound = CONFIDENCE * sigma / math.sqrt(n) + tol
        if resolution != 0.0:
            bound += resolution
        ok = ok and abs(mean - target) <= bound
    else:
        previous = (c[0, k + 1 - n] - c[0, k + 1 - 2 * n]) / n if k - n >= n - 1 else np.inf
        ok = ok and abs(mean - previous) <= CONFIDENCE * sigma * math.sqrt(2.0 / n) + tol
        ok = ok and abs(mean) > CONFIDENCE * sigma / math.sqrt(n) + tol
    return ok


@numba.njit(cache=True)
def _extend_sums(sums, y, old, size):  # pragma: no cover - compiled
    """:func:`_add_sample` for the samples ``old .. size - 1``."""
    for k in range(old, size):
        _add_sample(sums, y, k)


@numba.njit(cache=True)
def _tests(c, n, first, size, target, has_target, resolution, out):  # pragma: no cover - compiled
    """:func:`_window_steady` for the windows ending at ``first .. size - 1`` (``out``)."""
    for k in range(first, size):
        out[k - first] = _window_steady(c, n, k, target, has_target, resolution)


# --------------------------------------------------------------------------- the closed-loop step run
@numba.njit(cache=True)
def _closed_loop_run(
    Phi, Gamma, R, C1, D11, D12, C2, D21, D22, whole, a, offset, reference, noise, quantum, divergence_limit, peak,
    x, history, z, measured, drive, sums, window, integrating, dt, excursion, has_excursion, begin, until,
):  # pragma: no cover - compiled  # fmt: skip
    """The closed-loop step of :func:`envs.identification.closed_loop_run._run_closed_loop` from sample
    ``begin`` (after the samples before it) until the first sample that settles or aborts, or to
    ``until - 1``; returns ``(SETTLED, k)``, ``(ABORTED, k)`` or ``(NO_EVENT, until - 1)``.

    Sample ``k`` of the loop (:func:`_loop_sample`, inputs ``[reference, 0, noise[k]]``, or
    ``[reference, noise[k]]`` if the caller dropped the columns of the zero input, outputs
    ``z[k] = [y, u]``) gives the measurement ``measured[k] = y + noise[k]`` (floored to a multiple of
    ``quantum`` if it is not 0: the sensor's reading, :func:`envs.identification.noise.sensor_reading`;
    the loop itself feeds back ``y + noise[k]``) and the drive (``u``, or
    its trapezoidal integral ``drive[k] = drive[k - 1] + (u[k] + u[k - 1])/2 (t[k] - t[k - 1])`` with
    ``t[k] = k dt`` if ``integrating``, the numbers of
    :func:`envs.identification.closed_loop_run._cumulative_integral`), whose running sums ``sums[0]`` and
    ``sums[1]`` give the steady-state tests of the windows ending at ``k`` (the measurement against
    ``reference``, within ``quantum`` more if it is not 0).

    Sample ``k`` aborts if its true output leaves ``[-excursion, excursion]`` (``has_excursion``) or
    if a component of the next state reaches ``divergence_limit * peak[0]``, ``peak[0]`` being the
    largest input so far, ``max(1, |reference|, |noise[0]|, .., |noise[k]|)`` (causal: the outcome
    of sample ``k`` depends on no later sample); otherwise it settles if both tests pass.  ``x``,
    ``history``, ``z``, ``measured``, ``drive``, ``sums`` and ``peak`` carry the run from one call to
    the next.
    """
    n, nv = Phi.shape[0], a.size
    x_next = np.zeros(n)
    v = np.zeros(nv)
    past = np.zeros(3 * nv)
    inputs = Gamma.shape[1]
    d = np.zeros((1, inputs))  # the input [reference, 0, noise[k]] of sample k, or [reference, noise[k]]
    d[0, 0] = reference
    largest = peak[0]
    limit = divergence_limit * largest
    for k in range(begin, until):
        d[0, inputs - 1] = noise[k]
        size = abs(noise[k])
        if size > largest:  # the limit grows with the largest input so far
            largest = size
            limit = divergence_limit * largest
            peak[0] = largest
        bounded = _loop_sample(Phi, Gamma, R, C1, D11, D12, C2, D21, D22, whole, a, d, 0, limit, offset, k, z, x,
                               x_next, v, past, history)  # fmt: skip
        y, u = z[k, 0], z[k, 1]
        measured[k] = y + noise[k]
        if quantum != 0.0:
            measured[k] -= measured[k] % quantum
        if not integrating:
            drive[k] = u
        elif k == 0:
            drive[k] = 0.0
        elif k == 1:  # not 0.0 + the area: the sum of numpy.cumsum, -0.0 if the area is (the tests are the same)
            drive[k] = 0.5 * (u + z[k - 1, 1]) * (float(k) * dt - float(k - 1) * dt)
        else:
            drive[k] = drive[k - 1] + 0.5 * (u + z[k - 1, 1]) * (float(k) * dt - float(k - 1) * dt)
        _add_sample(sums[0], measured, k)
        _add_sample(sums[1], drive, k)
        if not bounded or (has_excursion and not abs(y) <= excursion):
            return ABORTED, k
        if k >= window - 1 and _window_steady(sums[0], window, k, reference, True, quantum) and _window_steady(
            sums[1], window, k, 0.0, False, 0.0
        ):
            return SETTLED, k
    return NO_EVENT, until - 1
