"""Rules for the design parameter ``mu`` of the Gorez-Klan PID (Gorez-Klan section 3).

The PID of eq. 3-11 (:func:`envs.design.pid_design`) cancels the SOPDT model's time constants,
so that the model loop is ``e^{-D_2 s}/(mu D_2 s)`` (eq. 3-12) whatever the model.  Its margins
depend on ``mu`` alone (eq. 3-13, 3-14):

* gain margin ``mu/mu_u = mu pi/2`` (``mu_u = 2/pi``, eq. 3-13);
* phase margin ``pi/2 - 1/mu`` rad (eq. 3-14), at the crossover ``omega_co = 1/(mu D_2)``.

So a ``mu`` rule is a number, or the inverse of one of these two relations:

===========================  ==========================================  =========================
rule                         ``mu``                                      source
===========================  ==========================================  =========================
:func:`mu_table`             1.3, 1.5, 2 or 3 (any ``mu > 0``)           section 3, table
:func:`mu_for_gain_margin`   ``2 A_m/pi``                                eq. 3-13
:func:`mu_for_phase_margin`  ``1/(pi/2 - phi_m)``, ``phi_m`` in rad      eq. 3-14
===========================  ==========================================  =========================

The margins hold on the model loop; on the true loop section 3 claims only bounds (gain margin
above ``mu``, phase margin above ``arccos(1/mu)``), see ``deadtime reproduce gorez-klan-mu``.

References
----------
.. [GK] R. Gorez, P. Klan, "Simple models for process control", section 3 "Design of a PID
   controller", eq. 3-11 .. 3-14 and the table "Robustness with proposed controller settings".
"""

from __future__ import annotations

import math

from envs.validation import require_number

__all__ = ["MU_TABLE", "gain_margin", "mu_for_gain_margin", "mu_for_phase_margin", "mu_table", "phase_margin_deg"]

MU_TABLE: tuple[float, ...] = (1.3, 1.5, 2.0, 3.0)
"""The ``mu`` values of Gorez-Klan's section-3 table (printed gain margins 2, 2.4, 3.1, 4.7 and
phase margins 46, 52, 61, 71 degrees)."""


def mu_table(value: float) -> float:
    """A fixed ``mu``, as the section-3 table gives them: 1.3, 1.5, 2 or 3 (:data:`MU_TABLE`).

    The table spans "fast responses with a high overshoot (1.3 < mu < 2) to over-damped slow
    responses (2 < mu < 3)" (section 3).  The registry's table rules are the four columns
    (``gorez-klan-mu-1.3`` .. ``-3``); this function accepts any ``mu > 0``, since a fixed ``mu``
    outside the table (e.g. the ``mu`` of about 4 that a plant with ``tau`` near 0.3 needs) is the same kind of rule.

    Parameters
    ----------
    value : float
        ``mu > 0``.

    Returns
    -------
    float
        ``value`` as a float.

    Raises
    ------
    ValueError
        If ``value`` is not a finite number ``> 0``.

    References
    ----------
    Gorez-Klan section 3, eq. 3-11, table "Robustness with proposed controller settings".

    Examples
    --------
    >>> [mu_table(m) for m in MU_TABLE]
    [1.3, 1.5, 2.0, 3.0]
    """
    return require_number(value, "mu", positive=True)


def mu_for_gain_margin(gain_margin: float) -> float:
    """The ``mu`` whose model loop has gain margin ``A_m``: ``mu = 2 A_m/pi`` (eq. 3-13).

    Parameters
    ----------
    gain_margin : float
        ``A_m > 0``.  Values ``<= 1`` give an unstable model loop (``mu <= mu_u = 2/pi``) and are
        refused.

    Returns
    -------
    float
        ``mu > 2/pi``.

    Raises
    ------
    ValueError
        If ``gain_margin`` is not a finite number ``> 1``.

    References
    ----------
    Gorez-Klan eq. 3-13: ``omega_u = pi/(2 D_2)``, ``mu_u = 2/pi``, gain margin ``mu/mu_u``.

    Examples
    --------
    >>> round(mu_for_gain_margin(math.pi), 12)
    2.0
    """
    gain_margin = require_number(gain_margin, "gain_margin")
    if not gain_margin > 1.0:
        raise ValueError(f"gain_margin must be > 1 (a stable loop), got {gain_margin!r}")
    return 2.0 * gain_margin / math.pi


def mu_for_phase_margin(phase_margin_deg: float) -> float:
    """The ``mu`` whose model loop has phase margin ``phi_m``: ``mu = 1/(pi/2 - phi_m)`` (eq. 3-14).

    Parameters
    ----------
    phase_margin_deg : float
        ``phi_m`` in degrees, ``0 < phi_m < 90`` (the model loop's phase margin tends to 90
        degrees as ``mu`` grows and reaches 0 at ``mu = 2/pi``).

    Returns
    -------
    float
        ``mu > 2/pi``.

    Raises
    ------
    ValueError
        Unless ``0 < phase_margin_deg < 90``.

    References
    ----------
    Gorez-Klan eq. 3-14: ``omega_co = 1/(mu D_2)``, ``Phi_M = pi/2 - 1/mu`` rad.

    Examples
    --------
    >>> round(mu_for_phase_margin(60), 6)  # 6/pi
    1.909859
    """
    phase_margin_deg = require_number(phase_margin_deg, "phase_margin_deg")
    if not 0.0 < phase_margin_deg < 90.0:
        raise ValueError(f"phase_margin_deg must be in (0, 90) for eq. 3-14, got {phase_margin_deg!r}")
    return 1.0 / (0.5 * math.pi - math.radians(phase_margin_deg))


def gain_margin(mu: float) -> float:
    """Gain margin ``mu pi/2`` of the model loop ``e^{-D_2 s}/(mu D_2 s)`` (eq. 3-13).

    Examples
    --------
    >>> round(gain_margin(2), 1)
    3.1
    """
    return require_number(mu, "mu", positive=True) * 0.5 * math.pi


def phase_margin_deg(mu: float) -> float:
    """Phase margin ``pi/2 - 1/mu`` of the model loop, in degrees (eq. 3-14).

    Examples
    --------
    >>> round(phase_margin_deg(2))
    61
    """
    return math.degrees(0.5 * math.pi - 1.0 / require_number(mu, "mu", positive=True))
