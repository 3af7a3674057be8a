"""Integrated absolute error (IAE) of a closed loop for unit load and set-point steps.

``IAE = int_0^inf |e(t)| dt`` with ``e = r - y`` (Marlin ch. 9, "integral of the absolute value
of the error"), for a unit step of the load at the plant input (``r = 0``) and for a unit step of
the set point, both at ``t = 0`` from rest.  Values are raw, in the plant's time and output units.

Time scale and tail handling.  The loop is simulated (:mod:`envs.simulation.loops`) with
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
(``tests/unit/envs/analysis/test_performance.py``).

Stopping at a bound.  A caller that needs the IAE only below a threshold (the scoring, whose cost
is capped) passes an :class:`IAEBound`: a run that has not settled at a horizon, and whose weighted
IAE so far already exceeds the bound's budget, stops there.  As ``|e| >= 0``, the IAE of a longer
run can only be larger, so the values returned are lower bounds (``lower_bound=True``) and the
weighted IAE is certainly above the budget.  The test keeps a relative margin of
``BOUND_MARGIN`` so that the rounding of the sums cannot matter.

How it is computed.  The loop is assembled as rows of coefficients (:func:`~envs.simulation.loops.loop_rows`),
and everything else is one compiled call (:func:`~envs.analysis._iae_kernels.step_iae`): the loop's one-step
map (that of :func:`~envs.simulation.discretization.discretize` to rounding: within ``1e-10`` relative in the IAE,
measured <= 1.1e-11), the steady offsets, both step runs over the horizons with the trapezoidal
areas, their sums and the tests above.  It gives the numbers of :func:`~envs.simulation.runs.simulate`
and :func:`integrated_absolute_error` on the same map bit for bit.  That general path is
``iae(..., method="reference")``: the loop as a :class:`~envs.simulation.delay_systems.DelaySystem`
(:func:`~envs.simulation.loops.closed_loop`), its map by :func:`~envs.simulation.discretization.discretize`,
both runs by :class:`~envs.simulation.runs.LoopRun`, the areas by
:func:`integrated_absolute_error` and the offsets by numpy's DC gain; it agrees with the compiled
path within the ``1e-10`` of the map above, and bit for bit on the compiled map
(``tests/unit/fast_paths/test_resumable_runs.py``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Sequence

import numpy as np

from envs.analysis._iae_kernels import step_iae
from envs.systems.controllers import Controller
from envs.simulation.delay_systems import MAX_RUN_SAMPLES, DelaySystem, divergence_limit
from envs.simulation.discretization import DiscreteDelaySystem, discretize
from envs.simulation.runs import LoopRun
from envs.simulation.loops import closed_loop, loop_rows, sample_time
from envs.systems.plants import Plant

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

    @property
    def threshold(self) -> float:
        """The budget with its rounding margin: the weighted IAE that is certainly above the budget."""
        return self.budget + BOUND_MARGIN * abs(self.budget)

    def exceeded(self, load: float, setpoint: float) -> bool:
        """Whether IAEs of at least ``load`` and ``setpoint`` are certainly above the budget (the
        test that :func:`~envs.analysis._iae_kernels.step_iae` applies)."""
        return self.load_weight * load + self.setpoint_weight * setpoint > self.threshold  # False for nan (0 inf)


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
    plant: Plant,
    controller: Controller,
    *,
    samples_per_residence_time: int = 50,
    bound: IAEBound | None = None,
    method: str = "compiled",
) -> IAEResult:
    """IAE of the loop for a unit load step and a unit set-point step (see the module docstring).

    With ``bound``, a run that exceeds it stops early and returns lower bounds (``lower_bound``).
    ``method`` is ``"compiled"`` (default: one call to
    :func:`~envs.analysis._iae_kernels.step_iae`) or ``"reference"`` (the general path of the module
    docstring, equal to the compiled one within ``1e-10`` relative, several times slower).
    """
    if method == "reference":
        return _reference_iae(plant, controller, samples_per_residence_time, bound)
    if method != "compiled":
        raise ValueError(f"method must be 'compiled' or 'reference', got {method!r}")
    return _loop_iae(plant, controller, samples_per_residence_time, bound)


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
    """:func:`iae` of one loop: its rows, its sample time, then one compiled call."""
    derivatives, outputs, delayed, delays = loop_rows(plant, controller)
    dt = sample_time(plant, delays, samples_per_residence_time)
    if not dt > 0 or not math.isfinite(dt):
        raise ValueError(f"dt must be finite and > 0, got {dt!r}")
    scale = plant.step_time_scale()
    first, longest = _bounded_horizons(scale, dt, delays)
    if first is None:  # not even the first horizon within MAX_RUN_SAMPLES: not run
        return IAEResult(math.inf, math.inf, False, 0.0, dt)
    weights = (0.0, 0.0, math.inf) if bound is None else (bound.load_weight, bound.setpoint_weight, bound.threshold)
    load, setpoint, settled, horizon, lower_bound = step_iae(
        derivatives, outputs, delayed, delays, dt, scale, first, longest, SETTLED_SHARE,
        OFFSET_TOLERANCE, divergence_limit(plant.gain), *weights,
    )  # fmt: skip
    return IAEResult(load, setpoint, settled, horizon, dt, lower_bound)


def _bounded_horizons(scale: float, dt: float, delays: np.ndarray) -> tuple[float | None, float]:
    """``(HORIZON, MAX_HORIZON)``, the longest shortened to ``MAX_RUN_SAMPLES`` samples (in units of
    ``scale``); ``(None, 0)`` if the first horizon or the longest delay does not fit in them.

    Unchanged (the same floats) for every loop sampled at ``T_ar/50``; only a loop with a delay
    below ``MAX_HORIZON T_ar/MAX_RUN_SAMPLES`` (about 0.01 ``T_ar``) gets a shorter longest horizon.
    """
    samples = scale / dt
    if HORIZON * samples > MAX_RUN_SAMPLES or (delays.size and float(delays.max()) / dt > MAX_RUN_SAMPLES):
        return None, 0.0
    if MAX_HORIZON * samples <= MAX_RUN_SAMPLES:
        return HORIZON, MAX_HORIZON
    longest = HORIZON
    while 2.0 * longest * samples <= MAX_RUN_SAMPLES:  # a horizon the doubling reaches
        longest *= 2.0
    return HORIZON, longest



def _reference_iae(
    plant: Plant,
    controller: Controller,
    samples_per_residence_time: int,
    bound: IAEBound | None,
    discretization: Callable[[DelaySystem, float], DiscreteDelaySystem] = discretize,
) -> IAEResult:
    """``iae(..., method="reference")``: the computation of :func:`_loop_iae` written with the
    package's general functions (the module docstring); ``discretization`` gives the one-step map
    (the tests pass the compiled one to hold the rest equal bit for bit)."""
    system = closed_loop(plant, controller)
    dt = sample_time(plant, system.delays, samples_per_residence_time)
    if not dt > 0 or not math.isfinite(dt):
        raise ValueError(f"dt must be finite and > 0, got {dt!r}")
    scale = plant.step_time_scale()
    horizon, longest = _bounded_horizons(scale, dt, system.delays)
    if horizon is None:
        return IAEResult(math.inf, math.inf, False, 0.0, dt)
    discrete, offsets = discretization(system, dt), _steady_offsets(system)
    runs, limit = (LoopRun(discrete), LoopRun(discrete)), divergence_limit(plant.gain)
    while True:
        steps = int(math.ceil(horizon * scale / dt)) + 1
        inputs = np.zeros((2, steps, 3))
        inputs[0, :, 1] = 1.0  # a unit load step
        inputs[1, :, 0] = 1.0  # a unit set-point step
        results = [run.advance(inputs[k], limit) for k, run in enumerate(runs)]
        if any(result.diverged for result in results):
            return IAEResult(math.inf, math.inf, True, horizon, dt)
        errors = [result.outputs[:, 2] for result in results]
        totals = [integrated_absolute_error(e, dt) for e in errors]
        tails = [integrated_absolute_error(e[-max(e.size // 10, 2) :], dt) for e in errors]
        load, setpoint = (math.inf if offsets[k] else totals[k] for k in (0, 1))
        settled = all(tails[k] <= SETTLED_SHARE * max(totals[k], 1e-300) for k in (0, 1) if not offsets[k])
        if settled or horizon >= longest:
            return IAEResult(load, setpoint, settled, horizon, dt)
        if bound is not None and bound.exceeded(load, setpoint):
            return IAEResult(load, setpoint, False, horizon, dt, lower_bound=True)
        horizon *= 2


def _steady_offsets(system: DelaySystem) -> tuple[bool, bool]:
    """Whether the error keeps an offset after a unit load and a unit set-point step, by numpy's DC
    gain (a loop with a pole at the origin is left to the simulation)."""
    try:
        gain = system.dc_gain()
    except np.linalg.LinAlgError:
        return False, False
    return abs(gain[2, 1]) > OFFSET_TOLERANCE, abs(gain[2, 0]) > OFFSET_TOLERANCE
