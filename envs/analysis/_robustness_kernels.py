"""The robustness analysis of :mod:`envs.analysis.robustness`, compiled with numba, for a plant-controller loop.

:func:`envs.analysis.robustness.loop_margins` takes any vectorized ``omega -> L(i omega)``; for the loops of
deadtime-gym most of its time is numpy's overhead on small arrays (the low- and high-frequency
searches, the grid and its refinement, the winding number, the root and peak searches), not
arithmetic.  A plant-controller loop is a ratio of quasi-polynomials (:mod:`envs.analysis.loop_transfer`)
that compiled code evaluates at one frequency (:func:`transfer_at`, 50-110 ns on the bench loops,
accurate to rounding at every frequency: see :mod:`envs.analysis.loop_transfer`); this module runs the same
algorithm on it, point by point, in numba.

Design:

* The same steps, constants and conventions as :func:`envs.analysis.robustness.loop_margins`; each
  function here names the one it reproduces.  The vectorized original treats every bracket, peak
  and grid interval independently, so sequential loops compute the same iterates.  Equivalent
  reformulations where the original's form is costly in scalar code: the refinement tests
  ``|arg(z_1/z_0)| > MAX_ARG_STEP`` as a cone condition on ``z_1 conj(z_0)`` (no arctangent);
  the winding number counts the crossings of the negative real axis by the polyline of ``1 + L``
  (the sum of its angle steps, with two arctangents instead of one per interval); an interval
  left unrefined by one pass is not tested again; ``10^y`` is ``e^{y ln 10}``.
* Work skipped where its result is provably not used, and nothing else (the figures are those of
  the full computation bit for bit, ``tests/unit/envs/analysis/test_robustness.py``): the low-frequency decades
  are evaluated as needed; a high-frequency decade's sweep stops once the decade certainly fails;
  ``log |L|`` is taken only at the ends of gain brackets (elsewhere only its sign, that of
  ``|L| - 1``, enters); ``|L|`` and ``|1 + L|`` on the grid are computed once; each side's summed
  coefficients are formed once per loop (:func:`_prepare`), and a side of one term reuses their
  polynomial's value for its term.  The loop arrives as one packed array
  (:func:`packed_margins`), which numba unboxes quicker than a tuple of arrays.
* The compiled pieces live in three modules of this package: the loop at a frequency and the grids
  (:mod:`envs.analysis._frequency_response_kernels`), the searches, grid, refinement and winding number
  (this module), the crossovers, peaks and margins (:mod:`envs.analysis._crossing_kernels`); the
  cache of all three is dropped together when any kernel module of the package changes
  (:mod:`envs._kernel_cache`).  The constants of :mod:`envs.analysis.robustness` are passed in
  (:data:`SETTINGS`), never read as globals of another package.
* The figures agree with :func:`envs.analysis.robustness.loop_margins` on the same loop to rounding: the
  values of ``L`` differ in the last bits (and :func:`transfer_at` is the more
  accurate at low frequencies), so a stability verdict or a crossover count could differ only for
  a loop on the boundary; ``tests/unit/fast_paths/test_fast_paths.py`` compares both on a few hundred loops.
  :func:`envs.analysis.robustness.assemble_margins` builds the :class:`~envs.analysis.robustness.Margins` of both.
* Compilation: 11 functions (and 11 small ones inlined into them), compiled once and cached on
  disk by numba (docs/performance.md for the times).  Scalar loops instead of numpy functions (``sort``,
  fancy indexing, ``max``), each of which would add its own compilation; no call of a compiled
  function on a literal argument (which numba would compile once more for that literal).
"""

from __future__ import annotations

import math

import numba
import numpy as np

from envs.analysis._crossing_kernels import _crossovers, _gain_margin, _peaks, _phase_and_delay_margins
from envs.analysis._crossing_kernels import _chandrupatla  # noqa: F401  (its tests reach it from here)
from envs.analysis._frequency_response_kernels import _logspace, _magnitude, _prepare, _values, transfer_at
from envs.analysis._frequency_response_kernels import _evaluate  # noqa: F401  (its tests reach it from here)
from envs.analysis.loop_transfer import QuasiRational
from envs.analysis.robustness import (
    MAX_ARG_STEP,
    MAX_POINTS,
    MAX_ROOT_ITERATIONS,
    PEAK_POINTS,
    PEAK_SPACING,
    POINTS_PER_DECADE,
    ROOT_XTOL,
    Margins,
    assemble_margins,
)

__all__ = ["SETTINGS", "packed_margins", "quasi_rational_margins", "transfer_at"]

SETTINGS = (float(POINTS_PER_DECADE), MAX_ARG_STEP, MAX_POINTS, ROOT_XTOL, MAX_ROOT_ITERATIONS, PEAK_POINTS, PEAK_SPACING)
"""The constants of :mod:`envs.analysis.robustness`, in the order :func:`_analysis` unpacks them (a plain
tuple: numba's cache index would pickle a named tuple's class by its module's name)."""
SETTINGS_ARRAY = np.array(SETTINGS, dtype=float)
""":data:`SETTINGS` as :func:`_analysis` takes them (an array unboxes quicker than a tuple; the
integers are exact as floats)."""
HIGH_FREQUENCY_POINTS = 64  # per decade, as in envs.analysis.robustness._high_frequency
LOW_FREQUENCY_DECADES = 40  # as in envs.analysis.robustness._low_frequency

jit = numba.njit(cache=True, error_model="numpy")
inline = numba.njit(cache=True, error_model="numpy", inline="always")


def quasi_rational_margins(transfer: QuasiRational, integrators: int, time_scale: float = 1.0) -> Margins:
    """:func:`envs.analysis.robustness.loop_margins` of the loop ``L = transfer``, compiled.

    Parameters
    ----------
    transfer : QuasiRational
        The loop, e.g. :func:`envs.analysis.loop_transfer.loop_transfer` of a plant and a controller.
    integrators : int
        Number ``k`` of open-loop poles at the origin; ``L`` must have no other pole with
        ``Re s >= 0``.
    time_scale : float
        A characteristic time of the loop, where the grid starts.

    Examples
    --------
    The Gorez-Klan model loop ``e^{-s}/(mu s)`` with ``mu = 2`` (eq. 3-12 .. 3-14), as in
    :func:`envs.analysis.robustness.loop_margins`:

    >>> m = quasi_rational_margins(QuasiRational((((1.0,), 1.0),), (((2.0, 0.0), 0.0),)), integrators=1)
    >>> round(m.gain_margin, 6), round(m.phase_margin_deg, 4), round(m.delay_margin, 6)
    (3.141593, 61.3521, 2.141593)
    """
    return packed_margins(*transfer.packed(), integrators, time_scale)


def packed_margins(packed: np.ndarray, shape: tuple[int, int, int, int], integrators: int, time_scale: float = 1.0) -> Margins:
    """:func:`quasi_rational_margins` of the loop ``packed, shape = QuasiRational.packed()`` (one
    array and four sizes: arguments that a compiled function unboxes quicker than a tuple of arrays)."""
    figures = _packed_analysis(
        packed, *shape, int(integrators), float(time_scale), HIGH_FREQUENCY_POINTS, LOW_FREQUENCY_DECADES, SETTINGS_ARRAY
    )
    return assemble_margins(*figures)



@jit
def _packed_analysis(packed, numerator_rows, numerator_width, denominator_rows, denominator_width, integrators, time_scale, high_points, low_decades, settings):  # pragma: no cover
    """:func:`_analysis` of a loop given as :meth:`~envs.analysis.loop_transfer.QuasiRational.packed` gives it."""
    transfer = _unpacked(packed, numerator_rows, numerator_width, denominator_rows, denominator_width)
    return _analysis(transfer, integrators, time_scale, high_points, low_decades, settings)


@jit
def _unpacked(packed, numerator_rows, numerator_width, denominator_rows, denominator_width):  # pragma: no cover
    """The loop of :meth:`~envs.analysis.loop_transfer.QuasiRational.packed` as :func:`_prepare` gives it."""
    size = numerator_rows * numerator_width
    numerator, numerator_delays = packed[:size].copy().reshape((numerator_rows, numerator_width)), packed[size : size + numerator_rows].copy()
    start = size + numerator_rows
    size = denominator_rows * denominator_width
    denominator = packed[start : start + size].copy().reshape((denominator_rows, denominator_width))
    denominator_delays = packed[start + size : start + size + denominator_rows].copy()
    return _prepare(numerator, numerator_delays, denominator, denominator_delays)


@jit
def _analysis(transfer, integrators, time_scale, high_points, low_decades, settings):  # pragma: no cover - compiled
    """The body of :func:`envs.analysis.robustness.loop_margins`: the arguments of ``assemble_margins``
    (``transfer`` as :func:`_prepare` gives it, ``settings`` as :data:`SETTINGS_ARRAY`)."""
    root_xtol, peak_spacing = settings[3], settings[6]
    max_root_iterations, peak_points = int(settings[4]), int(settings[5])
    omega, values, tame = _loop_grid(transfer, integrators, time_scale, high_points, low_decades, settings)
    unstable = _winding(values, integrators)
    magnitudes, closed = _grid_magnitudes(values)

    gains, phase = _crossovers(transfer, omega, values, magnitudes, root_xtol, max_root_iterations)
    at_gains, at_phase = _values(transfer, gains), _values(transfer, phase)
    negative = 0  # the phase crossovers with Re L < 0, in place
    for i in range(phase.size):
        if at_phase[i].real < 0:
            phase[negative], at_phase[negative] = phase[i], at_phase[i]
            negative += 1
    phase, at_phase = phase[:negative], at_phase[:negative]
    peaks = _peaks(transfer, omega, magnitudes, closed, peak_points, peak_spacing)
    return unstable, tame, peaks, _gain_margin(phase, at_phase), _phase_and_delay_margins(gains, at_gains), gains, phase


@jit
def _loop_grid(transfer, integrators, time_scale, high_points, low_decades, settings):  # pragma: no cover - compiled
    """The refined grid of :func:`envs.analysis.robustness.loop_margins`: ``(omega, L(i omega), tame)``,
    ``tame`` as :func:`_high_frequency` gives it."""
    omega, values, tame = _initial_grid(transfer, integrators, time_scale, high_points, low_decades, settings)
    omega, values = _refine(transfer, omega, values, settings[1], int(settings[2]))
    return omega, values, tame


@jit
def _initial_grid(transfer, integrators, time_scale, high_points, low_decades, settings):  # pragma: no cover - compiled
    """The grid of :func:`envs.analysis.robustness.frequency_grid` before its refinement, with ``L`` on it
    and ``tame``: every point of it stays in the refined grid, with the same value."""
    low = _low_frequency(transfer, integrators, 1e-3 / time_scale, low_decades)
    high, tame = _high_frequency(transfer, 10.0 / time_scale, high_points)
    count = int(math.ceil(math.log10(high / low) * settings[0])) + 1
    omega = _logspace(math.log10(low), math.log10(high), count)
    return omega, _values(transfer, omega), tame


@jit
def _grid_magnitudes(values):  # pragma: no cover - compiled
    """``|L|`` and ``|1 + L|`` on the grid, computed once."""
    magnitudes, closed = np.empty(values.size), np.empty(values.size)
    for i in range(values.size):
        magnitudes[i], closed[i] = _magnitude(values[i]), _magnitude(1 + values[i])
    return magnitudes, closed


@jit
def _low_frequency(transfer, integrators, start, decades):  # pragma: no cover - compiled
    """:func:`envs.analysis.robustness._low_frequency`: the first decade below ``start`` where ``L s^k`` has
    converged.  Each decade is evaluated when it is needed."""
    omega, value = start, _scaled(transfer, integrators, start)
    for _ in range(decades):
        lower = omega / 10
        at_lower = _scaled(transfer, integrators, lower)
        if abs(value - at_lower) <= 1e-3 * max(abs(at_lower), 1e-300):
            return lower
        omega, value = lower, at_lower
    return omega


@inline
def _scaled(transfer, integrators, w):  # pragma: no cover - compiled
    """``L(i w) (i w)^k``, ``k = integrators``, one factor ``i w`` after the other."""
    value = transfer_at(transfer, w)
    for _ in range(integrators):
        value = complex(-value.imag * w, value.real * w)
    return value


@jit
def _high_frequency(transfer, start, points):  # pragma: no cover - compiled
    """:func:`envs.analysis.robustness._high_frequency`: where ``|L|`` has its limit, and whether it is ``< 1``.

    A decade passes if ``max |L| < 0.02`` or ``max |L| - min |L| < 0.01 max |L|`` over its points.
    Its sweep stops as soon as it certainly fails (a ``nan``, or a point of ``|L| >= 0.02`` and one
    below ``0.98`` times the largest so far: a maximum can only grow and a minimum only fall, and
    the margin ``0.98`` against ``0.99`` is far above rounding), except in the last decade, whose
    maximum is returned: only a failure is decided early, so the result is that of every sweep.
    """
    w, top = start, math.nan
    for decade in range(14):
        first = math.log10(w)
        omega = _logspace(first, first + 1, points)
        top, bottom = -math.inf, math.inf  # numpy's max and min: nan if any is nan
        for i in range(points):
            m = _magnitude(transfer_at(transfer, omega[i]))
            top = m if m > top or math.isnan(m) else top
            bottom = m if m < bottom or math.isnan(m) else bottom
            if decade < 13 and (math.isnan(top) or (top >= 0.02 and bottom <= 0.98 * top)):
                break  # fails whatever follows
        if top < 0.02 or top - bottom < 0.01 * top:
            return w, top < 1.0
        w *= 10
    return w, top < 1.0


@inline
def _turns(to, start, limit):  # pragma: no cover - compiled
    """Whether ``|arg(to/start)| > atan(limit)``, without an arctangent: ``z = to conj(start)``
    has ``|arg z| <= atan(limit)`` iff ``Re z > 0`` and ``|Im z| <= limit Re z``."""
    re = to.real * start.real + to.imag * start.imag
    im = to.imag * start.real - to.real * start.imag
    return not (re > 0 and abs(im) <= limit * re)


@jit
def _refine(transfer, omega, values, max_arg_step, max_points):  # pragma: no cover - compiled
    """:func:`envs.analysis.robustness._refine`: geometric midpoints where ``arg(1+L)`` or, for ``|L| > 0.2``,
    ``arg L`` jumps by more than ``max_arg_step``.

    Only the intervals made by the previous pass are tested again (the others have not changed):
    the same grid as testing every interval every pass.
    """
    limit = math.tan(max_arg_step)
    bad = np.ones(omega.size - 1, dtype=np.bool_)  # the intervals to test
    for _ in range(30):
        n = omega.size
        if n > max_points:
            break
        added = 0
        for i in range(n - 1):
            if bad[i]:
                big = max(_magnitude(values[i + 1]), _magnitude(values[i])) > 0.2
                jumps = _turns(1 + values[i + 1], 1 + values[i], limit) or (big and _turns(values[i + 1], values[i], limit))
                bad[i] = jumps and omega[i + 1] / omega[i] > 1 + 1e-9
                added += bad[i]
        if added == 0:
            break
        mids, m = np.empty(added), 0
        for i in range(n - 1):
            if bad[i]:
                mids[m], m = math.sqrt(omega[i] * omega[i + 1]), m + 1
        at_mids = _values(transfer, mids)
        new_omega, new_values = np.empty(n + added), np.empty(n + added, dtype=np.complex128)
        new_bad = np.zeros(n + added - 1, dtype=np.bool_)
        j, m = 0, 0
        for i in range(n):
            new_omega[j], new_values[j] = omega[i], values[i]
            if i < n - 1 and bad[i]:
                new_omega[j + 1], new_values[j + 1] = mids[m], at_mids[m]
                new_bad[j], new_bad[j + 1] = True, True
                j, m = j + 1, m + 1
            j += 1
        omega, values, bad = new_omega, new_values, new_bad
    return omega, values


@jit
def _winding(values, integrators):  # pragma: no cover - compiled
    """:func:`envs.analysis.robustness._winding`.  The sum of ``arg(g_{i+1}/g_i)`` over the polyline
    ``g = 1 + L`` is ``arg g_N - arg g_0`` plus ``2 pi`` for every crossing of the negative real axis
    counterclockwise (minus for clockwise)."""
    count = 0
    for i in range(values.size - 1):
        x0, y0 = 1 + values[i].real, values[i].imag
        x1, y1 = 1 + values[i + 1].real, values[i + 1].imag
        if (y0 >= 0) != (y1 >= 0):
            cross = x0 * y1 - x1 * y0  # (y1 - y0) times the real part where the segment meets the axis
            if y1 < y0 and cross > 0:
                count += 1
            elif y1 > y0 and cross < 0:
                count -= 1
    first, last = 1 + values[0], 1 + values[-1]
    # + 0.0: a negative zero imaginary part is on the upper side, as in the count above
    change = math.atan2(last.imag + 0.0, last.real) - math.atan2(first.imag + 0.0, first.real) + 2 * math.pi * count
    return round((integrators * math.pi - 2 * change) / (2 * math.pi))
