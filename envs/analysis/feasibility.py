"""The robustness figures the constraints need, for many designs of one plant in one compiled call.

:func:`feasibility_margins` gives, for each controller, what :func:`envs.analysis.scoring.constraint_violations`
reads of :func:`envs.analysis.loop_analysis.plant_margins` (the reference: every figure of the loop):
stability, ``Ms``, the phase, delay and (when asked) gain margins.  It runs the same compiled
algorithm and skips the figures no constraint reads (:mod:`envs.analysis._feasibility_kernels`), so the
figures it returns equal those of :func:`~envs.analysis.loop_analysis.plant_margins` bit for bit, the
lower bound 1 on ``Ms`` included (``tests/unit/envs/analysis/test_feasibility.py`` holds them equal on a
few hundred designs of every structure).  The figures of an unstable loop other than ``stable`` are
those :func:`~envs.analysis.robustness.assemble_margins` gives it where no constraint reads them:
``Ms``, the gain and phase margins ``nan``, the delay margin 0.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from envs.analysis._feasibility_kernels import SCREENED, _batch
from envs.analysis._robustness_kernels import HIGH_FREQUENCY_POINTS, LOW_FREQUENCY_DECADES, SETTINGS_ARRAY
from envs.analysis.loop_analysis import _strictly_proper
from envs.analysis.loop_transfer import loop_packed
from envs.systems.controllers import Controller
from envs.systems.plants import Plant

__all__ = ["FeasibilityMargins", "feasibility_margins"]


@dataclass(frozen=True)
class FeasibilityMargins:
    """The figures of :class:`~envs.analysis.robustness.Margins` that the constraints read (same names).
    ``gain_margin`` is ``nan`` where it was not asked for."""

    stable: bool
    ms: float
    gain_margin: float
    phase_margin_deg: float
    delay_margin: float


def feasibility_margins(plant: Plant, controllers: Sequence[Controller], gain_margin: bool = False,
                        screen: float = math.inf) -> list[FeasibilityMargins | None]:
    """The figures of :class:`FeasibilityMargins` of ``L = P C`` for each controller ``C`` (one compiled
    call for all; the gain margin only where ``gain_margin``).

    ``screen``: None instead of the figures of a loop whose ``|S|`` exceeds ``screen`` on the analysis'
    frequency grid before its refinement, found before the rest of the analysis runs (so its ``Ms``
    exceeds ``screen``, or it is unstable: with ``screen`` above an ``Ms`` bound, an infeasible design;
    :func:`envs.analysis._feasibility_kernels._feasibility`)."""
    loops = [loop_packed(plant, controller) for controller in controllers]
    if not loops:
        return []
    packed = np.concatenate([flat for flat, _ in loops])
    offsets = np.cumsum([0] + [flat.size for flat, _ in loops])
    shapes = np.array([shape for _, shape in loops], dtype=np.int64)
    integrators = np.array([int(plant.integrating) + controller.integrators for controller in controllers], dtype=np.int64)
    figures = _batch(packed, offsets, shapes, integrators, float(plant.step_time_scale()), HIGH_FREQUENCY_POINTS,
                     LOW_FREQUENCY_DECADES, SETTINGS_ARRAY, bool(gain_margin), float(screen))
    least_ms = plant.dead_time > 0 or _strictly_proper(plant)  # plant_margins' lower bound on Ms
    return [_margins(row, least_ms) for row in figures]


def _margins(row: np.ndarray, least_ms: bool) -> FeasibilityMargins | None:
    unstable, tame, ms, gain_margin, phase_margin, delay_margin = (float(v) for v in row)
    if unstable == SCREENED:
        return None
    if not (unstable == 0 and tame == 1.0):
        return FeasibilityMargins(False, math.nan, math.nan, math.nan, 0.0)
    if ms < 1.0 and least_ms:
        ms = 1.0
    phase_margin_deg = math.degrees(phase_margin) if math.isfinite(phase_margin) else math.inf
    return FeasibilityMargins(True, ms, gain_margin, phase_margin_deg, delay_margin)
