"""Integrated absolute error (IAE) of a closed loop for unit load and set-point steps.

``IAE = int_0^inf |e(t)| dt`` with ``e = r - y`` (Marlin ch. 9, "integral of the absolute value
of the error"), for a unit step of the load at the plant input (``r = 0``) and for a unit step of
the set point, both at ``t = 0`` from rest.  Values are raw, in the plant's time and output units.

Time scale and tail handling.  The loop is simulated (:mod:`envs.loops`) with
``T_ar/50`` per sample (``T_ar`` of the true plant, smaller if a dead time is shorter), over an
initial horizon of ``HORIZON = 10`` residence times.  ``|e|`` is integrated by the trapezoidal rule,
splitting each interval where ``e`` changes sign at its linear zero.  A loop without integral action
for an input keeps a steady offset (its exact DC gain is computed first); its IAE is infinite.  The run counts as settled
when the IAE accumulated over the last tenth of the horizon is below ``1e-5`` of the total (the
decaying tail beyond the horizon is then of that order too); otherwise the horizon is doubled,
up to ``MAX_HORIZON`` residence times, and ``settled`` is False if that is not enough.  A
diverging or unstable loop has infinite IAE.  The initial horizon only decides where the
doubling starts: a run continues from its state (nothing is simulated twice), and a loop that
settles at 10 or 20 ``T_ar`` by the same test costs a quarter or half of the 2000 samples of the
40 ``T_ar`` used before.  On 216 stable loops (bench loops and random designs of the four
families) the two starts gave IAEs within ``8.1e-6`` relative, the order of ``SETTLED_SHARE``
(``tests/unit/test_performance.py``).

Stopping at a bound.  A caller that needs the IAE only below a threshold (the scoring, whose cost
is capped) passes an :class:`IAEBound`: a run that has not settled at a horizon, and whose weighted
IAE so far already exceeds the bound's budget, stops there.  As ``|e| >= 0``, the IAE of a longer
run can only be larger, so the values returned are lower bounds (``lower_bound=True``) and the
weighted IAE is certainly above the budget.  The test keeps a relative margin of
``BOUND_MARGIN`` so that the rounding of the sums cannot matter.

How it is computed.  The loop's one-step map comes from
:func:`~envs.compiled_discretization.discretize_compiled` (that of
:func:`~envs.simulation.discretize` to rounding: within ``1e-10`` relative in the IAE, measured
<= 1.1e-11); both step runs, the trapezoidal areas and their sums advance in one compiled call per
horizon (:class:`~envs.step_error_runs.StepErrorRuns`), which gives the numbers of
:func:`~envs.simulation.simulate` and :func:`integrated_absolute_error` on the same map bit for bit
(``tests/unit/test_resumable_runs.py`` keeps that general path as the reference).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from envs.controllers import Controller
from envs.plants import Plant
from envs.compiled_discretization import discretize_compiled
from envs.loops import closed_loop, simulation_step
from envs.simulation import DelaySystem, DiscreteDelaySystem
from envs.step_error_runs import RunSums, StepErrorRuns

__all__ = ["IAEBound", "IAEResult", "integrated_absolute_error", "iae", "iae_batch"]

HORIZON = 10.0
MAX_HORIZON = 1280.0
SETTLED_SHARE = 1e-5
OFFSET_TOLERANCE = 1e-9
BOUND_MARGIN = 1e-9


@dataclass(frozen=True)
class IAEBound:
    """Stop once ``load_weight IAE_load + setpoint_weight IAE_setpoint`` exceeds ``budget``.

    The weights are non-negative; the test is ``weighted > budget + BOUND_MARGIN |budget|`` at the
    end of each horizon of a run that has not settled (see the module docstring).
    """

    load_weight: float
    setpoint_weight: float
    budget: float

    def exceeded(self, load: float, setpoint: float) -> bool:
        """Whether IAEs of at least ``load`` and ``setpoint`` are certainly above the budget."""
        weighted = self.load_weight * load + self.setpoint_weight * setpoint
        return weighted > self.budget + BOUND_MARGIN * abs(self.budget)  # False for nan (0 inf)


@dataclass(frozen=True)
class IAEResult:
    """IAE for unit load and set-point steps; ``inf`` when the loop diverges.

    ``lower_bound`` is True when the run stopped at an :class:`IAEBound` before settling: ``load``
    and ``setpoint`` are then the IAE up to ``horizon`` only (lower bounds of the IAE; ``inf``
    where the error keeps an offset, which is exact).
    """

    load: float
    setpoint: float
    settled: bool
    horizon: float
    dt: float
    lower_bound: bool = False


def integrated_absolute_error(error: np.ndarray, dt: float) -> float:
    """Trapezoidal ``int |e| dt`` of samples ``e[j] = e(j dt)``, exact for piecewise-linear ``e``."""
    a, b = error[:-1], error[1:]
    same = a * b >= 0
    areas = np.where(same, 0.5 * (np.abs(a) + np.abs(b)), 0.5 * (a * a + b * b) / np.where(same, 1.0, np.abs(a) + np.abs(b)))
    return float(np.sum(areas) * dt)


def iae(
    plant: Plant, controller: Controller, *, samples_per_residence_time: int = 50, bound: IAEBound | None = None
) -> IAEResult:
    """IAE of the loop for a unit load step and a unit set-point step (see the module docstring).

    With ``bound``, a run that exceeds it stops early and returns lower bounds (``lower_bound``).
    """
    bounds = None if bound is None else [bound]
    return iae_batch([plant], [controller], samples_per_residence_time=samples_per_residence_time, bounds=bounds)[0]


def iae_batch(
    plants: Sequence[Plant],
    controllers: Sequence[Controller],
    *,
    samples_per_residence_time: int = 50,
    bounds: Sequence[IAEBound | None] | None = None,
) -> list[IAEResult]:
    """:func:`iae` for many loops (``bounds``: one per loop, or None); each is that of :func:`iae`."""
    if len(plants) != len(controllers):
        raise ValueError(f"got {len(plants)} plants but {len(controllers)} controllers")
    bounds = [None] * len(plants) if bounds is None else list(bounds)
    if len(bounds) != len(plants):
        raise ValueError(f"got {len(plants)} plants but {len(bounds)} bounds")
    return [_loop_iae(p, c, samples_per_residence_time, b) for p, c, b in zip(plants, controllers, bounds)]


def _loop_iae(plant: Plant, controller: Controller, samples_per_residence_time: int, bound: IAEBound | None) -> IAEResult:
    """:func:`iae` of one loop: both step runs over doubling horizons, each continuing the last."""
    system, discrete = discrete_loop(plant, controller, samples_per_residence_time)
    dt = discrete.dt
    runs = StepErrorRuns(discrete)
    offsets = _steady_offsets(system)
    scale = plant.step_time_scale()
    horizon = HORIZON
    while True:
        sums = runs.advance(int(math.ceil(horizon * scale / dt)) + 1)
        outcome = _outcome(sums, offsets, dt, horizon, bound)
        if outcome is not None:
            return outcome
        horizon *= 2


def discrete_loop(
    plant: Plant, controller: Controller, samples_per_residence_time: int = 50
) -> tuple[DelaySystem, DiscreteDelaySystem]:
    """The closed loop (:func:`~envs.loops.closed_loop`) and its one-step map at the IAE's sample time
    (:func:`~envs.compiled_discretization.discretize_compiled`, that of
    :func:`~envs.simulation.discretize` to rounding)."""
    system = closed_loop(plant, controller)
    dt = simulation_step(plant, controller, samples_per_residence_time, system=system)
    return system, discretize_compiled(system, dt)


def _outcome(
    sums: RunSums, offsets: tuple[bool, bool], dt: float, horizon: float, bound: IAEBound | None = None
) -> IAEResult | None:
    """The IAE of one loop from its runs' sums, or None if it has not settled within ``horizon``
    and may run longer (and has not exceeded ``bound``)."""
    if sums.diverged:
        return IAEResult(math.inf, math.inf, True, horizon, dt)
    values = [math.inf if offsets[k] else sums.totals[k] for k in (0, 1)]
    settled = all(_is_settled(sums.tails[k], sums.totals[k]) for k in (0, 1) if not offsets[k])
    if not settled and horizon < MAX_HORIZON:
        if bound is not None and bound.exceeded(*values):
            return IAEResult(values[0], values[1], False, horizon, dt, lower_bound=True)
        return None
    return IAEResult(values[0], values[1], settled, horizon, dt)


def _is_settled(tail: float, total: float) -> bool:
    """The settling test: the IAE over the last tenth is below ``SETTLED_SHARE`` of the whole."""
    return tail <= SETTLED_SHARE * max(total, 1e-300)


def _steady_offsets(system) -> tuple[bool, bool]:
    """Whether the error keeps a steady offset after a unit load and a unit set-point step.

    Such a loop (no integral action for that input) has an infinite IAE.  The final error is the
    closed loop's exact DC gain; a loop with a pole at the origin is left to the simulation.
    """
    try:
        gain = system.dc_gain()
    except np.linalg.LinAlgError:
        return False, False
    return abs(gain[2, 1]) > OFFSET_TOLERANCE, abs(gain[2, 0]) > OFFSET_TOLERANCE
