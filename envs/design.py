"""The design step: one parameter and an identified model give the controller.

These are the four designs, shared by the environments, the rules and the oracle:

* :func:`pid_design`: Gorez-Klan's series PID on the SOPDT model, parameter ``mu`` (eq. 3-11);
  the derivative filter is ``T_d/N`` with ``N = DERIVATIVE_FILTER`` (a common industrial value;
  it keeps the high-frequency controller gain at ``N + 1`` times ``K_p``).
* :func:`fppi_design`: Hagglund's FPPI on the FOPDT model, parameter ``T_r``, with ``T_f = T_r``
  (Ingimundarson section 4.3: the optimum of eq. 23-24 has ``T_r = T_f``).
* :func:`msp_design`: the modified Smith predictor on the two-parameter model, parameter ``T_r``
  (section 5), optionally with the PD-type extension (eq. 51).
* :func:`pi_design`: Skogestad's SIMC PI on the FOPDT model, parameter ``tau_c`` (the closed-loop
  time constant; SIMC's own rule ``simc-pi`` takes ``tau_c = theta``).

The agent, the oracle and the environments use the *relative* parameter: ``mu``, ``T_r/T_n``,
``T_r/L_n`` or ``tau_c/theta``, searched over a range on a log scale; :mod:`envs.structures` holds,
per structure, the design, the unit of its parameter and the range.  The constants and eq. 28-29 of the base rules of
the residual action (:mod:`envs.base_design`) are here too.

Undefined PID
-------------
Eq. 3-11 sets ``K_i = 1/(mu K D_2)``, which is undefined when the moments give no dead time
(``tau = 0``, hence ``D_2 = T_ar theta^2 = 0``; 5 of 40 random lag-chain plants with a strong lead).
:func:`pid_design` floors the ``D_2`` of that formula at :data:`MIN_RELATIVE_DEAD_TIME` times the
model's ``T_ar``.  The floor changes no design whose ``D_2`` is above it, i.e. none whose moments
see a dead time of 1 % of ``T_ar`` or more (every family draws ``L/T_ar >= 0.05``); below it the
design is the one of a model with that small dead time, and ``mu`` keeps the role of eq. 3-12.
"""

from __future__ import annotations

import math

from envs.systems.controllers import FPPI, MSP, PID, SeriesPID
from envs.identification.models import FOPDTModel, IntegratingModel, SOPDTModel
from envs.validation import require_number

__all__ = [
    "DERIVATIVE_FILTER",
    "FPPI_DEAD_TIME_ERROR",
    "MIN_RELATIVE_DEAD_TIME",
    "MSP_RELATIVE_DEAD_TIME_ERROR",
    "PID_BASE_MU",
    "fppi_design",
    "fppi_time_constant",
    "msp_design",
    "pi_dead_time",
    "pi_design",
    "pid_design",
    "simc_pi_gains",
]

DERIVATIVE_FILTER = 10.0
MIN_RELATIVE_DEAD_TIME = 0.01  # floor of D_2/T_ar in eq. 3-11 (module docstring)
PID_BASE_MU = 2.0
"""``mu`` of the PID's base rule (Gorez-Klan section 3 table)."""

FPPI_DEAD_TIME_ERROR = 0.1
"""``Delta L/L_n`` assumed by eq. 34 (``fppi-eq34``; Ingimundarson section 4.2 leaves it to the user)."""

MSP_RELATIVE_DEAD_TIME_ERROR = 0.2
"""``delta_L`` of eq. 50 (``msp-eq50``; 0.2 gives ``T_r = L_n/2``)."""


def pid_design(model: SOPDTModel, mu: float, derivative_filter: float = DERIVATIVE_FILTER) -> SeriesPID:
    """Gorez-Klan PID: ``T_i = T_1``, ``T_d = T_2``, ``K_p = T_1/(mu K D_2)`` (eq. 3-11).

    ``D_2`` is floored at ``MIN_RELATIVE_DEAD_TIME * T_ar`` (module docstring, "Undefined PID").
    """
    dead_time = max(model.dead_time, MIN_RELATIVE_DEAD_TIME * model.residence_time)
    return SeriesPID.gorez_klan(model.gain, model.time_constants, dead_time, mu, derivative_filter)


def fppi_design(model: FOPDTModel, tr: float) -> FPPI:
    """FPPI with ``T_i = T_n``, ``kappa = T_n/T_r`` and ``T_f = T_r`` (Ingimundarson eq. 14-15, 4.3)."""
    return FPPI(model.gain, model.time_constant, model.dead_time, tr, tr)


def msp_design(model: IntegratingModel, tr: float, extension: bool = False) -> MSP:
    """MSP with ``K_0 = 1/(2 L_n K_n)``, ``K_r = 1/(K_n T_r)`` (Ingimundarson eq. 36-38, or eq. 51)."""
    return MSP(model.gain, model.dead_time, tr, extension)


def fppi_time_constant(time_constant: float, mismatch_time: float) -> float:
    """``T_r = max(sqrt(T_f_bar T_n), T_f_bar)`` (Ingimundarson eq. 28 and 29).

    Parameters
    ----------
    time_constant : float
        ``T_n`` of the FOPDT model, ``> 0``.
    mismatch_time : float
        ``T_f_bar = int |y - y_n| dt / K_n`` (eq. 22), possibly increased by an assumed dead-time
        error (eq. 34), ``> 0``.

    Returns
    -------
    float
        The smallest ``T_r`` allowed by the design rules ``gamma kappa <= 1`` and ``gamma <= 1``
        (eq. 27, with ``gamma = T_f_bar/T_r`` and ``kappa = T_n/T_r``, Fig. 6).

    Raises
    ------
    ValueError
        If an argument is not a positive finite number.

    Examples
    --------
    Table 1, process 1 (``T_n = 10.4``, ``T_f_bar = 0.27``):

    >>> round(fppi_time_constant(10.4, 0.27), 2)
    1.68
    """
    time_constant = require_number(time_constant, "time_constant", positive=True)
    mismatch_time = require_number(mismatch_time, "mismatch_time", positive=True)
    return max(math.sqrt(mismatch_time * time_constant), mismatch_time)


def simc_pi_gains(gain: float, lag: float, dead_time: float, tau_c: float) -> tuple[float, float]:
    """``K_c = tau_1/(k (tau_c + theta))``, ``tau_I = min(tau_1, 4 (tau_c + theta))``: Skogestad's SIMC PI
    rule for ``k e^{-theta s}/(tau_1 s + 1)`` (S. Skogestad, "Simple analytic rules for model reduction
    and PID controller tuning", J. Process Control 13 (2003) 291-309, the SIMC PI settings).

    The one implementation of the formula: ``simc-pi`` (:func:`baselines.rules.pid.simc_pi`, which checks
    its arguments first) and the PI environment (:func:`pi_design`) call it.
    """
    return lag / (gain * (tau_c + dead_time)), min(lag, 4.0 * (tau_c + dead_time))


def pi_dead_time(model: FOPDTModel) -> float:
    """``theta`` of the PI design: the model's dead time, floored at ``MIN_RELATIVE_DEAD_TIME`` times its
    ``T_ar`` (as :func:`pid_design` floors ``D_2``), so that ``tau_c = theta`` is defined for a model
    without dead time.  The floor changes no design of a model whose ``L_n/T_ar`` is 0.01 or more."""
    return max(model.dead_time, MIN_RELATIVE_DEAD_TIME * model.residence_time)


def pi_design(model: FOPDTModel, tau_c: float) -> PID:
    """SIMC PI on the FOPDT model with closed-loop time constant ``tau_c`` (:func:`simc_pi_gains`,
    ``theta`` of :func:`pi_dead_time`); ``tau_c = theta`` is the rule ``simc-pi``."""
    kp, ti = simc_pi_gains(model.gain, model.time_constant, pi_dead_time(model), tau_c)
    return PID(kp=kp, ti=ti)
