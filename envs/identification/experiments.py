"""Identification experiments on a true plant: simulated, with measurement noise, and timed.

This module is the public entry point; the experiments live in cohesive modules and are
re-exported here:

* :mod:`envs.identification.closed_loop_experiment`: experiment 1 (its run:
  :mod:`~envs.identification.closed_loop_run`);
* :mod:`envs.identification.open_loop_step`, :mod:`~envs.identification.open_loop_ramp`,
  :mod:`~envs.identification.open_loop_pulse`: experiments 2-4 (their shared run:
  :mod:`~envs.identification.open_loop_run`);
* :mod:`envs.identification.relay`: experiment 5 (its time stepping:
  :mod:`~envs.identification.relay_simulation`; its limit cycle: :mod:`~envs.identification.relay_cycle`);
* :mod:`envs.identification.commissioning`: the commissioning PI and the maximum sensitivity;
* :mod:`envs.identification.steady_state`: steady-state detection and noise estimation;
* :mod:`envs.identification.experiment_base`: validation, sampling, noise, runs and :class:`ExperimentResult`.

Each experiment is a function ``(plant, rng, ..., noise_std=0.0, dt=None, excursion_limit=None)``
that returns a frozen result holding the sampled signals, the identified quantities, and the
experiment's duration in time units and in units of the plant's time scale ``T_ar``:

1. :func:`closed_loop_step`: set-point step with the plant's commissioning PI
   (:func:`commissioning_pi`), run to steady state; ``K`` (``K_v``), ``T_ar`` (Ingimundarson eq. 10),
   ``T_a`` (Gorez-Klan appendix B), ``tau``, ``theta`` and the SOPDT model (eq. 2-7 .. 2-10).
2. :func:`open_loop_step`: ``T_n`` from the area over ``[0, T_ar]`` (Ingimundarson eq. 11), then on
   to steady state for ``T_f_bar`` (eq. 22) and the process reaction curve (Marlin 6.3).
3. :func:`open_loop_ramp`: ``T_n`` by eq. 12.
4. :func:`open_loop_pulse` (integrating plants): the area ``A`` of eq. 46.
5. :func:`relay_feedback`: ultimate period and gain by the describing function.

Conventions
-----------
* The plant starts at rest; signals are deviation variables and the experiment starts at
  ``t = 0``.  ``control`` is the plant input ``u``, ``output`` the *measured* output
  ``y + n`` and ``true_output`` the noise-free ``y``.
* Measurement noise ``n`` is white, Gaussian, with standard deviation ``noise_std`` per sample of
  ``dt``, held over the sample.  The default ``dt`` is ``T/SAMPLES_PER_RESIDENCE_TIME`` with
  ``T = plant.step_time_scale()`` (``T_ar`` of the true plant when positive), so the noise
  bandwidth is fixed relative to the plant and the results are time-scale invariant.
  Each experiment draws its noise from a child stream seeded from ``rng`` (always the same amount
  taken from ``rng``), as its samples are simulated: a seed gives the same noise whatever the noise
  level, and the noise of an experiment does not depend on how long the earlier ones ran (see
  :mod:`envs.identification.experiment_base`).
* Steady state is detected causally (:func:`steady_state_index`): the first time the mean of the
  last window is within ``CONFIDENCE`` standard errors of its target (or of the previous window)
  and the fitted slope is insignificant; without noise, the tolerance floor is
  ``STEADY_STATE_TOLERANCE`` times the change of the signal.  The window is one ``T_ar``: the
  plant's time scale ``T`` in experiment 1, the identified ``T_ar`` (``L_n``) afterwards.
* ``excursion_limit``: if the true output ever leaves ``[-limit, limit]`` the experiment stops
  there, ``aborted`` is True and the quantities that need the missing data are NaN or None.

References
----------
.. [GK] R. Gorez, P. Klan, "Simple models for process control", section 2 and appendix B.
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000, sections 2, 4.1 and 5.1.
.. [MA] T. Marlin, "Process Control", section 6.3.
.. [AH] K. J. Astrom, T. Hagglund, "Automatic tuning of simple regulators with specifications on
   phase and amplitude margins", Automatica 20 (1984): relay feedback.
"""

from envs.identification.closed_loop_experiment import ClosedLoopStepResult, closed_loop_step
from envs.identification.commissioning import COMMISSIONING_MAX_SENSITIVITY, commissioning_pi, max_sensitivity
from envs.identification.experiment_base import MAX_DURATION, SAMPLES_PER_RESIDENCE_TIME, ExperimentResult
from envs.identification.open_loop_pulse import OpenLoopPulseResult, open_loop_pulse
from envs.identification.open_loop_ramp import OpenLoopRampResult, open_loop_ramp
from envs.identification.open_loop_step import OpenLoopStepResult, open_loop_step
from envs.identification.relay import RelayResult, relay_feedback
from envs.identification.steady_state import CONFIDENCE, STEADY_STATE_TOLERANCE, steady_state_index, steady_state_mask

__all__ = [
    "SAMPLES_PER_RESIDENCE_TIME",
    "MAX_DURATION",
    "STEADY_STATE_TOLERANCE",
    "CONFIDENCE",
    "COMMISSIONING_MAX_SENSITIVITY",
    "commissioning_pi",
    "max_sensitivity",
    "steady_state_index",
    "steady_state_mask",
    "ExperimentResult",
    "ClosedLoopStepResult",
    "OpenLoopStepResult",
    "OpenLoopRampResult",
    "OpenLoopPulseResult",
    "RelayResult",
    "closed_loop_step",
    "open_loop_step",
    "open_loop_ramp",
    "open_loop_pulse",
    "relay_feedback",
]
