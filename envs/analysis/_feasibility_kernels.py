"""The robustness figures that the constraints need, compiled and batched over many loops of one plant.

:func:`envs.analysis.loop_analysis.plant_margins` (:mod:`envs.analysis._robustness_kernels`) computes
every figure of :class:`~envs.analysis.robustness.Margins`; deciding whether a design is feasible needs
fewer: stability, ``Ms``, the delay margin and the phase margin (both from the gain crossovers) and,
only when it is constrained, the gain margin (from the phase crossovers).  :func:`_feasibility` runs
the same steps with the same kernels and skips the rest: the peak of ``Mt``, the phase crossovers
where the gain margin is free, and everything after the winding number for an unstable loop (no
figure of it enters a constraint).  The figures it returns are therefore those of the full analysis
bit for bit (``tests/unit/envs/analysis/test_feasibility.py``).

:func:`_batch` analyses many loops in one call (the designs of one plant over a grid of parameters):
the loops packed one after the other, as :meth:`~envs.analysis.loop_transfer.QuasiRational.packed`
packs one.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from envs.analysis._crossing_kernels import _peak, _phase_and_delay_margins, _roots, _gain_margin
from envs.analysis._frequency_response_kernels import _magnitude, _values
from envs.analysis._robustness_kernels import _grid_magnitudes, _initial_grid, _refine, _unpacked, _winding

jit = numba.njit(cache=True, error_model="numpy")

SCREENED = -2.0
"""``out[0]`` of a screened loop (:func:`_feasibility`)."""
FIGURES = 6
"""Columns of :func:`_batch`: unstable poles, tame (1 or 0), ``Ms``, gain margin, phase margin (rad), delay margin."""


@jit
def _feasibility(transfer, integrators, time_scale, high_points, low_decades, settings, gain_margin, screen, out):  # pragma: no cover
    """The figures of :data:`FIGURES` of one loop into ``out`` (those of
    :func:`envs.analysis._robustness_kernels._analysis`); ``nan`` for those not computed: every figure
    after the winding number of an unstable loop, the gain margin where ``gain_margin`` is false.

    Screening: where ``|S| = 1/|1 + L|`` exceeds ``screen`` at a point of the grid before its refinement
    (a point of the refined grid, so the full analysis' ``Ms``, the largest of ``|S|`` over that grid
    refined further, exceeds it too), ``out[0]`` is :data:`SCREENED` and nothing else is computed: with
    ``screen`` above the ``Ms`` bound the design is infeasible, stable or not.  ``inf`` screens nothing."""
    root_xtol, peak_spacing = settings[3], settings[6]
    max_root_iterations, peak_points = int(settings[4]), int(settings[5])
    out[:] = math.nan
    omega, values, tame = _initial_grid(transfer, integrators, time_scale, high_points, low_decades, settings)
    for i in range(values.size):
        if 1 / _magnitude(1 + values[i]) > screen:  # Ms above it, or an unstable loop
            out[0] = SCREENED
            return
    omega, values = _refine(transfer, omega, values, settings[1], int(settings[2]))
    unstable = _winding(values, integrators)
    out[0], out[1] = unstable, 1.0 if tame else 0.0
    if unstable != 0 or not tame:
        return
    magnitudes, closed = _grid_magnitudes(values)
    gains = _roots(transfer, omega, values, magnitudes, 0, root_xtol, max_root_iterations)
    phase_margin, _, delay_margin, _, _ = _phase_and_delay_margins(gains, _values(transfer, gains))
    out[2] = _peak(transfer, omega, magnitudes, closed, peak_points, peak_spacing, 0)[0]
    out[4], out[5] = phase_margin, delay_margin
    if gain_margin:
        phase = _roots(transfer, omega, values, magnitudes, 1, root_xtol, max_root_iterations)
        at_phase = _values(transfer, phase)
        negative = 0  # the phase crossovers with Re L < 0, in place
        for i in range(phase.size):
            if at_phase[i].real < 0:
                phase[negative], at_phase[negative] = phase[i], at_phase[i]
                negative += 1
        out[3] = _gain_margin(phase[:negative], at_phase[:negative])[0]


@jit
def _batch(packed, offsets, shapes, integrators, time_scale, high_points, low_decades, settings, gain_margin, screen):  # pragma: no cover
    """:func:`_feasibility` of loop ``j``, packed in ``packed[offsets[j]:offsets[j + 1]]`` with the
    sizes ``shapes[j]`` and ``integrators[j]`` poles at the origin, for every ``j``: an array of one row of :data:`FIGURES` per loop."""
    figures = np.empty((shapes.shape[0], FIGURES))
    for j in range(shapes.shape[0]):
        rows, width, denominator_rows, denominator_width = shapes[j, 0], shapes[j, 1], shapes[j, 2], shapes[j, 3]
        transfer = _unpacked(packed[offsets[j] : offsets[j + 1]], rows, width, denominator_rows, denominator_width)
        _feasibility(transfer, integrators[j], time_scale, high_points, low_decades, settings, gain_margin, screen, figures[j])
    return figures
