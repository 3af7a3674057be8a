"""The figures of a designed loop: robustness (frequency domain) and IAE (time domain).

:func:`analyze` is what ``deadtime analyze`` prints and what the environments score: stability,
``Ms``, ``Mt``, gain, phase and delay margins of ``L = P C_fb`` on the exact frequency response
(the algorithm of :mod:`envs.analysis.robustness`, compiled in :mod:`envs.analysis._robustness_kernels` on the
loop's quasi-rational form of :mod:`envs.analysis.loop_transfer`), and the IAE for unit load and set-point steps (:mod:`envs.analysis.performance`).
An unstable loop is a result (``stable=False``, infinite IAE), not an error.

Stiff loops.  Both IAE methods of :mod:`envs.analysis.performance` lose accuracy as the loop's fastest
mode outruns the sample time, e.g. a PID's derivative filter ``T_d/n`` with a large ``n``.  With the
stiffness ``s = dt max |eig(A)|`` (:func:`loop_stiffness`; ``A`` the loop's state matrix, ``dt`` the
IAE's sample time), measured on 6 plants (FOPDT and SOPDT, ``L/T_ar`` 0.09 to 0.5) under PIDs with
``n`` from 10 to ``1e10`` (``tests/unit/envs/analysis/test_stiff_loops.py``): the compiled and the
reference IAE agree within ``6e-11`` relative up to ``s = 100``, ``3e-9`` at 733, ``8e-6`` at
``2.3e4``; beyond ``7e7`` the compiled IAE of a stable loop can be infinite.  The reference is not
the better one throughout: on ``e^{-0.1 s}/(s + 1)`` under a PI-D with ``K_p = 5``, ``T_i = 1``
(whose load IAE is ``T_i/K_p = 0.2`` exactly, the error keeping its sign) it is off by up to 4% for
``s`` between ``7e4`` and ``2.3e6``, where the compiled one is right to ``2e-10``.  So above
:data:`STIFF_LOOP` :func:`analyze` computes both and reports the IAE only where they agree within
:data:`STIFF_AGREEMENT`, and refuses the loop with one line where they do not, or above
:data:`MAX_STIFFNESS`.  (The environments' scoring calls the compiled IAE directly; its designs use
``n = 10``.)
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from envs.analysis._robustness_kernels import packed_margins
from envs.systems.controllers import Controller, controller_from_dict
from envs.analysis.loop_transfer import loop_packed
from envs.simulation.loops import closed_loop, sample_time
from envs.analysis.performance import IAEResult, iae
from envs.systems.plants import Plant, as_plant
from envs.analysis.robustness import Margins
from envs.threads import single_threaded

__all__ = ["LoopAnalysis", "MAX_STIFFNESS", "STIFF_AGREEMENT", "STIFF_LOOP", "analyze", "loop_stiffness", "plant_margins"]

STIFF_LOOP = 100.0
"""The stiffness above which :func:`analyze` checks the compiled IAE against the reference (module docstring)."""
STIFF_AGREEMENT = 1e-6
"""The agreement of the two IAE methods that :func:`analyze` asks of a stiff loop: relative to the IAE, or
to its unit in the cost (``|K| T_ar`` for the load, ``T_ar`` for the set point,
:mod:`envs.analysis.scoring`) where the IAE is smaller (a loop far faster than ``T_ar``)."""
MAX_STIFFNESS = 1e8
"""The stiffness above which :func:`analyze` refuses the loop (module docstring)."""


@dataclass(frozen=True)
class LoopAnalysis:
    """Robustness and performance of one plant-controller loop (raw units of the plant)."""

    margins: Margins
    performance: IAEResult

    @property
    def stable(self) -> bool:
        return self.margins.stable

    # The flat names of the JSON (``deadtime analyze --json``), as raw figures (``inf``/``nan``
    # where the JSON has ``null``): ``t.analysis.ms`` is ``t.analysis.margins.ms``.
    ms = property(lambda self: self.margins.ms, doc="``Ms``, :attr:`Margins.ms`.")
    mt = property(lambda self: self.margins.mt, doc="``Mt``, :attr:`Margins.mt`.")
    gain_margin = property(lambda self: self.margins.gain_margin, doc=":attr:`Margins.gain_margin`.")
    phase_margin_deg = property(lambda self: self.margins.phase_margin_deg, doc=":attr:`Margins.phase_margin_deg`.")
    delay_margin = property(lambda self: self.margins.delay_margin, doc=":attr:`Margins.delay_margin`.")
    iae_load = property(lambda self: self.performance.load, doc="IAE of the unit load step, :attr:`IAEResult.load`.")
    iae_setpoint = property(lambda self: self.performance.setpoint, doc="IAE of the unit set-point step.")

    def to_dict(self) -> dict[str, Any]:
        """The JSON object of ``deadtime analyze --json``; ``None`` where infinite or undefined.

        Margins and peaks of an unstable loop are undefined (``None``); its delay margin is 0.
        """
        m, p = self.margins, self.performance

        def finite(value: float) -> float | None:
            return float(value) if value is not None and math.isfinite(value) else None

        return {
            "stable": m.stable,
            "ms": finite(m.ms) if m.stable else None,
            "mt": finite(m.mt) if m.stable else None,
            "gain_margin": finite(m.gain_margin) if m.stable else None,
            "phase_margin_deg": finite(m.phase_margin_deg) if m.stable else None,
            "delay_margin": finite(m.delay_margin),
            "iae_load": finite(p.load),
            "iae_setpoint": finite(p.setpoint),
            "gain_crossover_frequency": finite(m.gain_crossover_frequency),
            "phase_crossover_frequency": finite(m.phase_crossover_frequency),
            "delay_margin_frequency": finite(m.delay_margin_frequency),
            "ms_frequency": finite(m.ms_frequency) if m.stable else None,
            "gain_crossovers": [float(w) for w in m.gain_crossovers],
            "phase_margins_deg": [float(p) for p in m.phase_margins_deg],
            "unstable_closed_loop_poles": m.unstable_poles,
            "iae_settled": p.settled,
        }


def plant_margins(plant: Plant, controller: Controller) -> Margins:
    """Robustness figures of ``L = P C_fb``: :func:`envs.analysis.robustness.loop_margins` compiled
    (:func:`envs.analysis._robustness_kernels.quasi_rational_margins` on :func:`envs.analysis.loop_transfer.loop_transfer`,
    through the packed form that skips the intermediate objects).

    The figures equal those of ``loop_margins(lambda w: loop_response(plant, controller, w), ...)``
    to rounding, at about a fifteenth of its cost, except that ``Ms`` is at least 1 where it must
    be: for a strictly proper plant ``S(i w) -> 1`` as ``w -> inf``, and with a dead time
    ``|S|`` comes as close to ``1/(1 - |L(i inf)|) >= 1`` as one likes, so ``sup |S| >= 1``.  The
    grid ends where ``|L| < 0.02`` (:func:`envs.analysis.robustness.frequency_grid`); a peak of ``|S|``
    beyond it, at most ``1/(1 - 0.02)``, is not searched, and a loop whose ``|S|`` stays below 1
    on the grid (e.g. ``0.5/s``, where it was reported as 0.99911) has ``Ms = 1`` at
    ``ms_frequency = inf``.  An ``Ms`` below ``1.0204`` is therefore exact to 2% only (python-control
    gives 1.00013 for a peak at ``|L| = 1.3e-4``).
    """
    integrators = int(plant.integrating) + controller.integrators
    margins = packed_margins(*loop_packed(plant, controller), integrators, plant.step_time_scale())
    if margins.ms < 1.0 and (plant.dead_time > 0 or _strictly_proper(plant)):
        return replace(margins, ms=1.0, ms_frequency=math.inf)
    return margins


def _strictly_proper(plant: Plant) -> bool:
    numerator = [c for c in plant.num]
    while numerator and numerator[0] == 0:
        numerator.pop(0)
    return len(numerator) < len(plant.den)


@single_threaded
def analyze(plant: Plant, controller: Controller) -> LoopAnalysis:
    """Robustness and IAE of the loop; the IAE of an unstable loop is infinite without simulating.

    ``plant`` may be given in any form :func:`envs.systems.plants.as_plant` takes, ``controller`` as
    its JSON object (:func:`envs.systems.controllers.controller_from_dict`).
    """
    plant = as_plant(plant)
    if isinstance(controller, dict):
        controller = controller_from_dict(controller)
    if not isinstance(controller, Controller):
        raise ValueError(f"controller must be a PID, SeriesPID, FPPI or MSP (or its JSON object), got {type(controller).__name__}")
    margins = plant_margins(plant, controller)
    if not margins.stable:
        return LoopAnalysis(margins, IAEResult(math.inf, math.inf, True, 0.0, math.nan))
    performance = iae(plant, controller)
    stiffness = loop_stiffness(plant, controller)
    if stiffness <= STIFF_LOOP:
        return LoopAnalysis(margins, performance)
    if stiffness > MAX_STIFFNESS:
        raise ValueError(f"the loop is too stiff for its IAE: its fastest mode is {stiffness:.3g} times the sample "
                         f"rate (at most {MAX_STIFFNESS:g}); use a smaller derivative filter n")
    reference = iae(plant, controller, method="reference")
    scale = plant.residence_time
    units = {"load": abs(plant.gain) * scale * (scale if plant.integrating else 1.0), "setpoint": scale}
    for name in ("load", "setpoint"):
        fast, slow = getattr(performance, name), getattr(reference, name)
        if not (fast == slow or abs(fast - slow) <= STIFF_AGREEMENT * max(abs(slow), units[name])):
            raise ValueError(f"the {name} IAE of this stiff loop is uncertain: {fast:.6g} (compiled) against {slow:.6g} "
                             f"(reference) at a stiffness of {stiffness:.3g}; use a smaller derivative filter n")
    return LoopAnalysis(margins, performance)


def loop_stiffness(plant: Plant, controller: Controller) -> float:
    """``dt max |eig(A)|`` of the loop: its fastest mode over the IAE's sample rate (module docstring)."""
    system = closed_loop(plant, controller)
    if system.A.size == 0:
        return 0.0
    return sample_time(plant, system.delays) * float(np.max(np.abs(np.linalg.eigvals(system.A))))
