"""Rules for the closed-loop time constant ``T_r`` of the dead-time compensators.

Each rule is a plain function of identified quantities that returns the controller it designs:

============================  ==============================================  ===================
rule                          ``T_r``                                         controller
============================  ==============================================  ===================
:func:`fppi_eq28_29`          ``max(sqrt(T_f_bar T_n), T_f_bar)``             :class:`FPPI`
:func:`fppi_eq34`             eq. 28/29 with ``T_f_bar + Delta L``            :class:`FPPI`
:func:`ppi_default`           ``T_n`` (``kappa = 1``, Hagglund's PPI)          :class:`FPPI`
:func:`msp_eq43`              ``2 L_n beta/(K_n L_n - beta)``, ``beta = A``   :class:`MSP`
:func:`msp_eq50`              ``L_n 2 delta_L/(1 - delta_L)``                 :class:`MSP`
:func:`msp_matausek_micic`    ``T_n``                                         :class:`MSP`
============================  ==============================================  ===================

The FPPI rules set the robustness filter ``T_f = T_r`` (Ingimundarson section 4.1: at the optimum
of eq. 24 under eq. 23 ``T_r = T_f``; section 4.3: "``T_f`` should be equal to ``T_n/kappa``").
Inputs are the identified FOPDT model ``K_n e^{-L_n s}/(T_n s + 1)`` (Ingimundarson eq. 1, from
eq. 10 and 11), the mismatch time ``T_f_bar`` (eq. 22), the two-parameter model
``K_n e^{-L_n s}/s`` (eq. 2) and the pulse area ``A`` (eq. 46).  Gains may be negative; the rules
use ``|K_n|`` where a gain meets an (always positive) area.

References
----------
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000, sections 4 and 5.
.. [HA] T. Hagglund, "An industrial dead-time compensating PI controller", Control Engineering
   Practice 4 (1996), 749-756 (the PPI, ``kappa = 1``).
.. [MM] M. Matausek, A. Micic, "A modified Smith predictor for controlling a process with an
   integrator and long dead-time", IEEE TAC 41 (1996) (``T_r = T_n``).
"""

from __future__ import annotations

import math

from envs.design import fppi_time_constant  # eq. 28 and 29, shared with the residual action's base
from envs.systems.controllers import FPPI, MSP
from envs.validation import require_number

__all__ = [
    "fppi_time_constant",
    "fppi_kappa_eq34",
    "fppi_eq28_29",
    "fppi_eq34",
    "ppi_default",
    "msp_time_constant",
    "msp_eq43",
    "msp_eq50",
    "msp_matausek_micic",
]


# --------------------------------------------------------------------------- FPPI (stable plants)
def fppi_kappa_eq34(time_constant: float, mismatch_time: float, dead_time_error: float = 0.0) -> float:
    """``kappa = T_n/T_r`` with ``T_r`` from eq. 28/29 on ``T_f_bar + Delta L`` (eq. 34).

    Eq. 34 is printed as ``kappa = sqrt((T_f_bar + Delta L)/T_n)``, the reciprocal of what its
    derivation gives: ``kappa = T_n/T_r`` (eq. 15) with ``T_r = sqrt((T_f_bar + Delta L) T_n)``
    (eq. 28 after "adding the expected dead-time variation to T_f_bar", section 4.2) is
    ``sqrt(T_n/(T_f_bar + Delta L))``, and Table 1 follows the latter (process 1:
    ``sqrt(10.4/0.27) = 6.2`` as printed, the printed form would give 0.16).  When eq. 29 is the
    active constraint (``T_f_bar + Delta L > T_n``), ``kappa = T_n/(T_f_bar + Delta L)``.

    Parameters
    ----------
    time_constant : float
        ``T_n > 0``.
    mismatch_time : float
        ``T_f_bar >= 0`` (eq. 22).
    dead_time_error : float
        The dead-time variation ``Delta L >= 0`` to be tolerated; ``T_f_bar + Delta L`` must be
        ``> 0``.

    Examples
    --------
    >>> round(fppi_kappa_eq34(10.4, 0.27), 2), round(fppi_kappa_eq34(4.0, 0.0, 1.0), 2)
    (6.21, 2.0)
    """
    time_constant = require_number(time_constant, "time_constant", positive=True)
    return time_constant / fppi_time_constant(time_constant, _bound(mismatch_time, dead_time_error))


def _bound(mismatch_time: float, dead_time_error: float) -> float:
    mismatch_time = require_number(mismatch_time, "mismatch_time", nonnegative=True)
    dead_time_error = require_number(dead_time_error, "dead_time_error", nonnegative=True)
    total = mismatch_time + dead_time_error
    if total <= 0:
        raise ValueError("mismatch_time + dead_time_error must be > 0, got 0 (no model error gives no finite T_r)")
    return total


def fppi_eq28_29(gain: float, time_constant: float, dead_time: float, mismatch_time: float) -> FPPI:
    """The FPPI with ``T_r = T_f = max(sqrt(T_f_bar T_n), T_f_bar)`` (Ingimundarson eq. 28, 29).

    Parameters
    ----------
    gain, time_constant, dead_time : float
        The identified FOPDT model ``K_n``, ``T_n``, ``L_n`` (eq. 1, 10, 11).
    mismatch_time : float
        ``T_f_bar`` from the open-loop step (eq. 22), ``> 0``.

    Returns
    -------
    FPPI
        ``T_i = T_n``, ``kappa = T_n/T_r`` (eq. 14, 15), ``T_f = T_r`` (section 4.3).

    Examples
    --------
    >>> c = fppi_eq28_29(1.0, 10.4, 6.8, 0.27)
    >>> round(c.tr, 2), round(c.kappa, 1), c.tf == c.tr
    (1.68, 6.2, True)
    """
    tr = fppi_time_constant(time_constant, mismatch_time)
    return FPPI(gain=gain, time_constant=time_constant, dead_time=dead_time, tr=tr, tf=tr)


def fppi_eq34(gain: float, time_constant: float, dead_time: float, mismatch_time: float, dead_time_error: float) -> FPPI:
    """The FPPI tuned for an assumed dead-time error ``Delta L`` (Ingimundarson eq. 34, section 4.2).

    ``T_f_bar`` is increased by ``Delta L`` (the largest growth of the area of eq. 22 that a
    dead-time change ``Delta L`` can cause, per unit gain) before eq. 28/29; ``kappa`` is then that of
    :func:`fppi_kappa_eq34`.

    Examples
    --------
    >>> c = fppi_eq34(1.0, 2.0, 6.0, 0.1, 0.4)
    >>> round(c.tr, 4), round(c.kappa, 4)
    (1.0, 2.0)
    """
    return fppi_eq28_29(gain, time_constant, dead_time, _bound(mismatch_time, dead_time_error))


def ppi_default(gain: float, time_constant: float, dead_time: float, *, filtered: bool = True) -> FPPI:
    """Hagglund's PPI default ``kappa = 1``: ``T_r = T_n`` (Ingimundarson eq. 15, [HA]).

    The closed-loop pole is placed at the open-loop one.  ``filtered=True`` keeps the FPPI
    parameterization ``T_f = T_r`` (section 4.3); ``filtered=False`` is Hagglund's unfiltered PPI
    (``T_f = 0``).

    Examples
    --------
    >>> c = ppi_default(2.0, 3.0, 5.0)
    >>> c.tr, c.kappa, c.tf, ppi_default(2.0, 3.0, 5.0, filtered=False).tf
    (3.0, 1.0, 3.0, 0.0)
    """
    time_constant = require_number(time_constant, "time_constant", positive=True)
    return FPPI(gain=gain, time_constant=time_constant, dead_time=dead_time, tr=time_constant, tf=time_constant if filtered else 0.0)


# --------------------------------------------------------------------------- MSP (integrating plants)
def msp_time_constant(gain: float, dead_time: float, beta: float) -> float:
    """``T_r = 2 L_n beta/(K_n L_n - beta)`` (Ingimundarson eq. 43), with ``|K_n|``.

    Eq. 43 solves ``beta = K_n L_n T_r/(2 L_n + T_r)`` (eq. 42, the approximate minimum of the
    MSP's uncertainty bound eq. 40) for ``T_r``.  ``T_r`` grows without bound as ``beta`` approaches
    ``K_n L_n`` (section 5.4).

    Parameters
    ----------
    gain : float
        Velocity gain ``K_n`` of the two-parameter model (eq. 2), non-zero.
    dead_time : float
        ``L_n > 0``.
    beta : float
        The bound on the model error at intermediate frequencies: the pulse area ``A`` of eq. 46,
        plus ``|K_n| Delta L`` for an assumed dead-time variation (section 5.2); ``> 0``.

    Raises
    ------
    ValueError
        If ``beta >= |K_n| L_n``: eq. 43 then has no positive solution (the model error exceeds
        the lower bound ``K_n L_n T_r/(2 L_n + T_r) < K_n L_n`` of eq. 42 for every ``T_r``).

    Examples
    --------
    Table 2, process 3 (``A = 0.9``, ``L_n = 8``):

    >>> round(msp_time_constant(1.0, 8.0, 0.9), 2)
    2.03
    """
    gain = require_number(gain, "gain")
    if gain == 0:
        raise ValueError("gain must be non-zero, got 0.0")
    dead_time = require_number(dead_time, "dead_time", positive=True)
    beta = require_number(beta, "beta", positive=True)
    limit = abs(gain) * dead_time
    if beta >= limit:
        raise ValueError(
            f"beta = {beta:.6g} >= |K_n| L_n = {limit:.6g}: eq. 43 has no positive T_r "
            "(the model error is too large for the MSP's robustness bound eq. 42)"
        )
    return 2.0 * dead_time * beta / (limit - beta)


def msp_eq43(gain: float, dead_time: float, pulse_area: float, dead_time_error: float = 0.0, *, extension: bool = False) -> MSP:
    """The MSP with ``T_r`` from eq. 43 with ``beta = A + |K_n| Delta L`` (Ingimundarson 5.1, 5.2).

    Parameters
    ----------
    gain, dead_time : float
        The two-parameter model ``K_n``, ``L_n`` (eq. 2, from eq. 10).
    pulse_area : float
        ``A`` of eq. 46 (``int |y - y_n| dt/(h_p tau_p)`` of a pulse experiment).
    dead_time_error : float
        Assumed dead-time variation ``Delta L >= 0`` (section 5.2), default 0.
    extension : bool
        Use the PD-type filter of eq. 51.

    Raises
    ------
    ValueError
        If ``beta >= |K_n| L_n`` (see :func:`msp_time_constant`).

    Examples
    --------
    >>> round(msp_eq43(1.0, 6.0, 0.4).tr, 3)
    0.857
    """
    dead_time_error = require_number(dead_time_error, "dead_time_error", nonnegative=True)
    pulse_area = require_number(pulse_area, "pulse_area", nonnegative=True)
    beta = pulse_area + abs(require_number(gain, "gain")) * dead_time_error
    return MSP(gain=gain, dead_time=dead_time, tr=msp_time_constant(gain, dead_time, beta), extension=extension)


def msp_eq50(gain: float, dead_time: float, relative_dead_time_error: float, *, extension: bool = False) -> MSP:
    """The MSP with ``T_r/L_n = 2 delta_L/(1 - delta_L)`` (Ingimundarson eq. 50).

    Eq. 43 with ``beta = Delta L K_n`` and ``delta_L = Delta L/L_n``: the tuning for an assumed
    relative dead-time error alone.

    Raises
    ------
    ValueError
        Unless ``0 < delta_L < 1``.

    Examples
    --------
    >>> msp_eq50(1.0, 10.0, 0.2).tr
    5.0
    """
    delta = require_number(relative_dead_time_error, "relative_dead_time_error")
    if not 0.0 < delta < 1.0:
        raise ValueError(f"relative_dead_time_error must be in (0, 1) for eq. 50, got {delta!r}")
    dead_time = require_number(dead_time, "dead_time", positive=True)
    return MSP(gain=gain, dead_time=dead_time, tr=dead_time * 2.0 * delta / (1.0 - delta), extension=extension)


def msp_matausek_micic(gain: float, dead_time: float, time_constant: float, *, extension: bool = False) -> MSP:
    """The MSP with ``T_r = T_n`` (Matausek and Micic [MM], quoted in Ingimundarson section 5.3).

    ``T_n`` is the apparent time constant of the dynamics additional to the integrator (Table 2's
    ``T_n`` column).

    Examples
    --------
    >>> msp_matausek_micic(1.0, 8.0, 2.0).tr
    2.0
    """
    return MSP(gain=gain, dead_time=dead_time, tr=require_number(time_constant, "time_constant", positive=True), extension=extension)
