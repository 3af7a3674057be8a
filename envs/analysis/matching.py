"""The design parameter that makes a loop meet a robustness target: a 1-D root find.

``robustness(loop on a model; parameter) = target``, solved on a log-scale bracket of the
parameter (:func:`match_parameter`), for ``Ms`` or the delay margin.  The robustness-matched rules
of :mod:`baselines.rules.matched` (Grimholt and Skogestad 2018) are this root find on the
identified model; the ``action="robustness"`` coordinate of the environments
(:mod:`envs.base_design`) lets the agent choose the target.

**Monotonicity, and which root.**  ``Ms`` decreases (the delay margin increases) with ``mu``,
``T_r``, ``tau_c`` and ``lambda`` on every model tried, but nothing guarantees it on a model with
an error (the FPPI on an SOPDT model) or the MSP's ``Ms``.  :func:`match_parameter` scans the
bracket on a log grid and takes the *least aggressive* root: the crossing above which every grid
point meets the target (an unstable loop counts as missing it).  If the target is met even at the
aggressive end of the bracket, that end is the parameter; if it is missed even at the least
aggressive end, :func:`match_parameter` raises a ``ValueError`` naming the figure reached.

References
----------
.. [GS] P. Grimholt, S. Skogestad, "Optimal PI and PID control of first-order plus delay processes
   and evaluation of the original and improved SIMC rules", J. Process Control 70 (2018) 36-46.
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers", Lund
   2000, section 3 (delay margin).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import numpy as np
from scipy.optimize import brentq

from envs.analysis.loop_analysis import plant_margins
from envs.analysis.robustness import Margins
from envs.systems.controllers import Controller
from envs.systems.plants import Plant

__all__ = ["Figure", "GRID_POINTS", "MatchedParameter", "loop_figure", "match_parameter"]

Figure = Literal["ms", "delay_margin"]

GRID_POINTS = 41
"""Points of the log grid over the bracket on which :func:`match_parameter` looks for the least
aggressive crossing (about 7 per decade over the widest bracket, 6 decades)."""

@dataclass(frozen=True)
class MatchedParameter:
    """The result of :func:`match_parameter`.

    Attributes
    ----------
    parameter : float
        The design parameter (``mu``, ``T_r``, ``tau_c`` or ``lambda``).
    value : float
        The figure reached on the model loop at ``parameter`` (``Ms``, or delay margin over the
        scale of :func:`match_parameter`).
    target : float
    bracket : tuple of float
        ``(aggressive end, least aggressive end)`` searched.
    at_bracket_end : bool
        True when the target was met at the aggressive end already, so that ``parameter`` is that
        end and ``value`` is on the safe side of ``target`` rather than equal to it.
    """

    parameter: float
    value: float
    target: float
    bracket: tuple[float, float]
    at_bracket_end: bool = False


def loop_figure(plant: Plant, controller: Controller, figure: Figure, scale: float = 1.0) -> float:
    """``Ms`` (``inf`` if unstable) or delay margin over ``scale`` (0 if unstable) of the loop."""
    margins: Margins = plant_margins(plant, controller)
    if figure == "ms":
        return float(margins.ms) if margins.stable else math.inf
    return float(margins.delay_margin) / scale if margins.stable else 0.0


def match_parameter(
    design: Callable[[float], Controller],
    plant: Plant,
    figure: Figure,
    target: float,
    bracket: tuple[float, float],
    *,
    scale: float = 1.0,
    name: str = "the rule",
) -> MatchedParameter:
    """The least aggressive parameter in ``bracket`` whose loop on ``plant`` has ``figure = target``.

    ``design(p)`` is the controller for parameter ``p``; a larger ``p`` is the less aggressive
    design.  The target is *missed* where ``Ms > target`` (or the delay margin over ``scale`` is
    below ``target``), or the loop is unstable.  The bracket is scanned on a log grid of
    :data:`GRID_POINTS`; between the largest grid point that misses and the next one,
    :func:`scipy.optimize.brentq` on ``log p`` solves ``figure = target`` (an unstable point
    counts as a miss of size 10).

    Parameters
    ----------
    design : callable
        ``p -> Controller``.
    plant : Plant
        The model as a plant.
    figure : {"ms", "delay_margin"}
    target : float
        ``Ms`` target ``> 1``, or delay margin target ``> 0`` in units of ``scale``.
    bracket : (float, float)
        ``0 < low < high``.
    scale : float
        Unit of the delay margin (``L_n``).
    name : str
        The rule, for messages.

    Returns
    -------
    MatchedParameter

    Raises
    ------
    ValueError
        If the target is missed at the least aggressive end ``high`` (the message gives the
        figure reached there), or for an invalid bracket.

    References
    ----------
    Grimholt and Skogestad 2018 (``Ms``-matched SIMC); Ingimundarson 2000, section 3 (delay margin).
    """
    low, high = (float(b) for b in bracket)
    if not (math.isfinite(low) and math.isfinite(high) and 0 < low < high):
        raise ValueError(f"{name}: the bracket must be 0 < low < high, got {bracket!r}")

    def miss(log_p: float) -> float:
        value = loop_figure(plant, design(math.exp(log_p)), figure, scale)
        excess = value - target if figure == "ms" else target - value
        return min(excess, 10.0)

    logs = np.linspace(math.log(low), math.log(high), GRID_POINTS)
    misses = np.array([miss(x) for x in logs])
    what = "Ms" if figure == "ms" else "delay margin/L_n"
    if misses[-1] > 0:
        reached = loop_figure(plant, design(high), figure, scale)
        raise ValueError(
            f"{name}: the model loop misses {what} = {target:g} even at the least aggressive end of the bracket "
            f"({high:.4g}), where {what} = {reached:.4g}"
        )
    missed = np.flatnonzero(misses > 0)
    if missed.size == 0:
        return MatchedParameter(low, loop_figure(plant, design(low), figure, scale), target, (low, high), True)
    i = int(missed[-1])
    root = brentq(miss, logs[i], logs[i + 1], xtol=1e-12, rtol=4 * np.finfo(float).eps)
    parameter = math.exp(root)
    return MatchedParameter(parameter, loop_figure(plant, design(parameter), figure, scale), target, (low, high))
