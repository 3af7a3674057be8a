"""Stability of the dead-time compensators under a dead-time error (Ingimundarson Fig. 7 and 13).

With the process equal to the model except for its dead time ``L = L_n (1 + delta_L)``, and time
normalized by ``L_n`` (``T_r_bar = T_r/L_n``, ``omega_bar = omega L_n``), the loops are

* FPPI with ``T_f = T_r`` (eq. 31, 33): ``L(s) = e^{-(1+delta_L) s}/((T_r_bar s + 1)^2 - e^{-s})``;
* MSP (eq. 47, 49): ``L(s) = e^{-(1+delta_L) s} ((2 + T_r_bar) s + 1)/(2 s (T_r_bar s + 1 - e^{-s}))``.

Eq. 33 and 49 are printed with ``e^{+i omega_bar}`` in the denominator; normalizing eq. 31 and 47
(``e^{-L_n s}``) gives ``e^{-i omega_bar}``, which is used here.

Integrators.  ``(T s + 1)^2 - e^{-s}`` vanishes at ``s = 0`` with derivative ``2 T + 1 != 0``, and
nowhere else in ``Re s >= 0`` (there ``|T s + 1|^2 > 1 >= |e^{-s}|`` unless ``s = 0``), so loop (33) is
of type 1: its only closed-right-half-plane pole is a simple pole at the origin, which
:func:`envs.analysis.robustness.loop_margins` takes as ``integrators=1``.  Likewise ``T s + 1 - e^{-s}``
has a simple zero at the origin only, so loop (49), with its extra ``s``, has ``integrators=2``.

Delay errors.  A dead-time change multiplies ``L(i omega)`` by ``e^{-i omega delta_L}`` and leaves
``|L|`` unchanged, so a closed-loop pole can reach the imaginary axis only at a gain crossover
``omega_i`` of the nominal loop, when the phase there has turned to ``-pi``: for an increase at
``delta_L = ((arg L(i omega_i) + pi) mod 2 pi)/omega_i`` (the delay margin, section 3), for a
decrease at ``delta_L = -((-pi - arg L(i omega_i)) mod 2 pi)/omega_i``.  The nominal loop is stable,
so it stays stable on the interval between the nearest such values on each side
(:class:`DelayErrorMargins`).  :func:`bisect_delay_error` checks an end of that interval
independently (Nyquist stability of the perturbed loop by ``loop_margins``, bisection on
``delta_L``), and :func:`simulated_growth` by a time simulation of the controller on a plant with
the perturbed dead time.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache
from typing import Callable

import numpy as np

from envs.systems.controllers import FPPI, MSP
from envs.simulation.loops import closed_loop_response
from envs.systems.plants import Plant
from envs.analysis.robustness import loop_margins

__all__ = [
    "KINDS",
    "fppi_loop",
    "msp_loop",
    "DelayErrorMargins",
    "delay_error_margins",
    "stable_with_delay_error",
    "bisect_delay_error",
    "smallest_time_constant",
    "simulated_growth",
]

LoopFunction = Callable[[np.ndarray], np.ndarray]


def fppi_loop(tr: float, delta: float) -> LoopFunction:
    """Normalized FPPI loop with a dead-time error, eq. 33 (``e^{-i omega}`` in the denominator)."""

    def loop(omega: np.ndarray) -> np.ndarray:
        s = 1j * np.asarray(omega, dtype=float)
        return np.exp(-s * (1.0 + delta)) / ((tr * s + 1.0) ** 2 - np.exp(-s))

    return loop


def msp_loop(tr: float, delta: float) -> LoopFunction:
    """Normalized MSP loop with a dead-time error, eq. 49 (``e^{-i omega}`` in the denominator)."""

    def loop(omega: np.ndarray) -> np.ndarray:
        s = 1j * np.asarray(omega, dtype=float)
        return 0.5 * np.exp(-s * (1.0 + delta)) * ((2.0 + tr) * s + 1.0) / (s * (tr * s + 1.0 - np.exp(-s)))

    return loop


KINDS: dict[str, tuple[Callable[[float, float], LoopFunction], int]] = {"fppi": (fppi_loop, 1), "msp": (msp_loop, 2)}
"""Loop factory and number of integrators (poles at the origin) of each compensator."""


def _kind(kind: str) -> tuple[Callable[[float, float], LoopFunction], int]:
    if kind not in KINDS:
        raise ValueError(f"kind must be one of {', '.join(KINDS)}; got {kind!r}")
    return KINDS[kind]


@dataclass(frozen=True)
class DelayErrorMargins:
    """Where a dead-time error destabilizes the nominally stable loop, per gain crossover.

    Attributes
    ----------
    tr : float
        ``T_r_bar = T_r/L_n``.
    crossovers : tuple of float
        Gain crossover frequencies ``omega_bar_i`` of the nominal loop.
    increase, decrease : tuple of float
        The relative dead-time increase (decrease, as a positive number) that puts crossover ``i``
        on the critical point.
    """

    tr: float
    crossovers: tuple[float, ...]
    increase: tuple[float, ...]
    decrease: tuple[float, ...]

    def interval(self, max_frequency: float = math.inf) -> tuple[float, float]:
        """``(lower, upper)``: the loop is stable for ``lower < delta_L < upper``.

        ``lower`` is clipped at -1 (the dead time cannot be negative).  ``max_frequency`` keeps
        only the crossovers ``omega_bar_i <= max_frequency`` (to mimic a truncated frequency grid).
        """
        keep = [i for i, w in enumerate(self.crossovers) if w <= max_frequency]
        upper = min((self.increase[i] for i in keep), default=math.inf)
        lower = -min((self.decrease[i] for i in keep), default=math.inf)
        return max(lower, -1.0), upper


@lru_cache(maxsize=4096)
def delay_error_margins(kind: str, tr: float) -> DelayErrorMargins:
    """The :class:`DelayErrorMargins` of the FPPI (``kind="fppi"``) or MSP loop at ``T_r_bar = tr``.

    Raises
    ------
    ValueError
        If the nominal loop is not stable (it is for every ``tr > 0``).
    """
    factory, integrators = _kind(kind)
    nominal = factory(tr, 0.0)
    margins = loop_margins(nominal, integrators)
    if not margins.stable:
        raise ValueError(f"the nominal {kind} loop with T_r/L_n = {tr:g} is not stable")
    omega = np.array(margins.gain_crossovers, dtype=float)
    phase = np.angle(nominal(omega))
    increase = np.mod(phase + math.pi, 2 * math.pi) / omega
    decrease = np.mod(-math.pi - phase, 2 * math.pi) / omega
    return DelayErrorMargins(float(tr), tuple(omega.tolist()), tuple(increase.tolist()), tuple(decrease.tolist()))


def stable_with_delay_error(kind: str, tr: float, delta: float) -> bool:
    """Nyquist stability (``loop_margins``) of the loop with relative dead-time error ``delta``."""
    factory, integrators = _kind(kind)
    return loop_margins(factory(tr, delta), integrators).stable


def bisect_delay_error(kind: str, tr: float, direction: int, step: float = 0.01, tolerance: float = 1e-4) -> float:
    """The first ``delta_L`` from 0 in ``direction`` (+1 or -1) where the loop is unstable.

    Scans ``delta_L = direction * k * step`` until the loop is unstable (up to ``|delta_L| = 1``;
    returns ``direction`` if it never is), then bisects.  An independent check of
    :meth:`DelayErrorMargins.interval`; the scan step must be below the width of the interval.
    """
    previous = 0.0
    for k in range(1, int(round(1.0 / step)) + 1):
        delta = direction * k * step
        if not stable_with_delay_error(kind, tr, delta):
            low, high = previous, delta
            while abs(high - low) > tolerance:
                middle = 0.5 * (low + high)
                if stable_with_delay_error(kind, tr, middle):
                    low = middle
                else:
                    high = middle
            return 0.5 * (low + high)
        previous = delta
    return float(direction)


def smallest_time_constant(
    kind: str,
    condition: Callable[[tuple[float, float]], bool],
    grid: np.ndarray,
    tolerance: float = 1e-4,
    max_frequency: float = math.inf,
) -> float:
    """The smallest ``T_r_bar`` above which ``condition(interval)`` holds on the whole ``grid``.

    Finds the last grid point where the condition fails, then bisects between it and the next
    one (the condition is assumed to switch once in between).  Returns ``grid[0]`` if it never
    fails.  ``max_frequency`` as in :meth:`DelayErrorMargins.interval`.
    """

    def holds_at(tr: float) -> bool:
        return condition(delay_error_margins(kind, tr).interval(max_frequency))

    holds = [holds_at(float(t)) for t in grid]
    failing = [i for i, ok in enumerate(holds) if not ok]
    if not failing:
        return float(grid[0])
    if failing[-1] == len(grid) - 1:
        raise ValueError(f"the condition fails at the top of the grid, T_r/L_n = {grid[-1]:g}")
    low, high = float(grid[failing[-1]]), float(grid[failing[-1] + 1])
    while high - low > tolerance:
        middle = 0.5 * (low + high)
        if holds_at(middle):
            high = middle
        else:
            low = middle
    return high


def simulated_growth(kind: str, tr: float, delta: float, horizon: float = 40.0) -> float:
    """Time-domain check: ``max |e|`` over the last quarter over ``max |e|`` over the second quarter.

    The controller (FPPI with ``K_n = T_n = L_n = 1``, ``T_f = T_r``; or MSP with ``K_n = L_n = 1``) runs
    a unit set-point step on the plant ``e^{-(1+delta) s}/(s + 1)`` (FPPI; loop eq. 31 does not depend
    on ``T_n``) or ``e^{-(1+delta) s}/s`` (MSP), simulated exactly (:mod:`envs.simulation.loops`) with ``T_r/10``
    per sample over ``horizon`` dead times.  Below 1: decaying; above 1: growing; ``inf``: diverged.
    """
    if delta <= -1:
        raise ValueError(f"delta must be > -1, got {delta!r}")
    if kind == "fppi":
        controller = FPPI(gain=1.0, time_constant=1.0, dead_time=1.0, tr=tr, tf=tr)
        plant = Plant(num=(1.0,), den=(1.0, 1.0), dead_time=1.0 + delta)
    else:
        _kind(kind)
        controller = MSP(gain=1.0, dead_time=1.0, tr=tr)
        plant = Plant(num=(1.0,), den=(1.0, 0.0), dead_time=1.0 + delta)
    dt = min(tr / 10.0, 0.05, 1.0 + delta)
    steps = int(math.ceil(horizon / dt))
    response = closed_loop_response(plant, controller, steps, dt, setpoint=1.0)
    if response.diverged:
        return math.inf
    error = np.abs(response.error)
    quarter = steps // 4
    return float(np.max(error[-quarter:]) / np.max(error[quarter : 2 * quarter]))
