"""Robustness-matched rules: the design parameter that makes the loop on the model meet a target.

The strongest classical practice is not a fixed rule but a matched one (Grimholt and Skogestad
[GS]): choose the rule's one free parameter so that the loop closed around the identified model
meets a robustness target.  Each rule here is a 1-D root find (:mod:`envs.analysis.matching`) of

    robustness(loop on the model; parameter) = target

on a log-scale bracket of the parameter (:func:`match_parameter`):

=====================  ================  ===========================  =========================  ===============
rule                   parameter         design                       target                     bracket
=====================  ================  ===========================  =========================  ===============
``gorez-klan-msX``     ``mu``            :func:`envs.design.pid_design`   ``Ms = X``             ``[0.3, 300]``
``fppi-msX``           ``T_r``           :func:`envs.design.fppi_design`  ``Ms = X``             ``[0.08 L_n, 100 T_ar]`` (a)
``msp-dmX``            ``T_r``           :func:`envs.design.msp_design`   ``DM = X L_n``         ``[0.14 L_n, 100 L_n]``
``simc-pi-msX``        ``tau_c``         SIMC PI ([SK])               ``Ms = X``                 ``[0.001, 100] T_ar``
``imc-pid-msX``        ``lambda``        IMC PID ([RMS] Table II)     ``Ms = X``                 ``[0.001, 100] T_ar``
=====================  ================  ===========================  =========================  ===============

(a) ``L_n`` at least ``0.01 T_ar`` (:data:`envs.design.MIN_RELATIVE_DEAD_TIME`, as the PID's ``D_2``): a FOPDT
model of a plant with a strong lead can have ``L_n = 0``.

**The model loop.**  The plant of the loop is the identified model of :class:`RuleInputs`
(``inputs.model``): the given model (``deadtime tune --model``), or the SOPDT model of the fixed
procedure (Gorez-Klan eq. 2-8) for a stable plant and the two-parameter model (Ingimundarson eq. 2)
for an integrating one.  The controller is designed from the model its rule was written for (the
SOPDT model for ``mu``, the FOPDT model for the FPPI and SIMC, the two-parameter model for the
MSP), so an FPPI designed on the FOPDT model is checked on the SOPDT model: the figure then
includes that model error.  ``Ms`` and the delay margin are those of
:func:`envs.analysis.loop_analysis.plant_margins` (``deadtime analyze``).

**Why the delay margin for the MSP.**  The MSP's ``Ms`` is not monotone in ``T_r``: on its exact
model ``K e^{-5 s}/s`` it rises from 2.17 (``T_r = 0.01 L_n``) to 2.37 (``T_r = 0.5 L_n``) and then
falls to a floor of about 1.6 as ``T_r`` grows (the gain ``K_0 = 1/(2 L_n K_n)`` of eq. 36 is fixed),
so an ``Ms`` of 1.4 is unreachable and 1.8 needs ``T_r`` of about 5 ``L_n``.  The delay margin grows
monotonically with ``T_r`` (to about ``2 L_n``) and is the robustness measure of the paper's own
analysis (Ingimundarson section 3) and the constraint of ``MSP-v0`` (``DM >= 0.2 L``); targets
0.3, 0.5 and 0.7 ``L_n`` are met at ``T_r`` of 0.23, 0.35 and 1.14 ``L_n`` on the exact model.

**Monotonicity, and which root.**  ``Ms`` decreases (the delay margin increases) with ``mu``,
``T_r``, ``tau_c`` and ``lambda`` on every model tried, but nothing guarantees it on a model with
an error (the FPPI on an SOPDT model) or the MSP's ``Ms``.  :func:`match_parameter` scans the
bracket on a log grid and takes the *least aggressive* root: the crossing above which every grid
point meets the target (an unstable loop counts as missing it).  If the target is met even at the
aggressive end of the bracket, that end is the parameter (the loop is then more robust than
asked: the floors of ``T_r`` are the smallest the package allows, :data:`baselines.rules.tune.TR_FLOORS`);
if it is missed even at the least aggressive end, the rule refuses with a ``ValueError`` naming
the figure reached, as the other rules refuse inputs they are undefined for (``deadtime evaluate``
counts that as a failure).

References
----------
.. [GS] P. Grimholt, S. Skogestad, "Optimal PI and PID control of first-order plus delay processes
   and evaluation of the original and improved SIMC rules", J. Process Control 70 (2018) 36-46
   (SIMC with ``tau_c`` chosen for a given ``Ms`` is close to the IAE-optimal PI at equal ``Ms``).
.. [GK] R. Gorez, P. Klan, "Simple models for process control", section 3, eq. 3-11 .. 3-14.
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers", Lund
   2000, section 3 (delay margin), section 4 (FPPI, eq. 14-15), section 5 (MSP, eq. 36-38).
.. [SK] S. Skogestad, "Simple analytic rules for model reduction and PID controller tuning",
   J. Process Control 13 (2003) 291-309.
.. [RMS] D. E. Rivera, M. Morari, S. Skogestad, "Internal model control. 4. PID controller
   design", Ind. Eng. Chem. Process Des. Dev. 25 (1986) 252-265, Table II.
"""

from __future__ import annotations

from envs.analysis.matching import GRID_POINTS, Figure, MatchedParameter, loop_figure, match_parameter

__all__ = [
    "FPPI_TR_FLOOR",
    "GRID_POINTS",
    "MSP_TR_FLOOR",
    "Figure",
    "MatchedParameter",
    "loop_figure",
    "match_parameter",
]

FPPI_TR_FLOOR = 0.08
"""Aggressive end of the FPPI's ``T_r`` bracket, in ``L_n``: ``TR_FLOORS["fppi"]`` of
:mod:`baselines.rules.tune` (test: equal), below which ``deadtime tune`` refuses the design."""

MSP_TR_FLOOR = 0.14
"""Aggressive end of the MSP's ``T_r`` bracket, in ``L_n``: ``TR_FLOORS["msp"]`` (test: equal)."""
