"""Analytic PI/PID tuning rules of the literature, as plain functions of an identified model.

Each rule takes the model it was published for -- :class:`~envs.identification.models.FOPDTModel`
``K e^{-L s}/(T s + 1)``, :class:`~envs.identification.models.SOPDTModel`
``K e^{-L s}/((T_1 s + 1)(T_2 s + 1))``, :class:`~envs.identification.models.IntegratingModel`
``K_v e^{-L s}/(s (T s + 1))`` -- or the ultimate gain and period of :func:`ultimate_point`, and
returns the controller in the form the rule defines:

* :class:`~envs.systems.controllers.PID`, ideal ``K_c (1 + 1/(T_i s) + T_d s)`` (Marlin eq. 8.27), for
  the rules tabulated in that form.  None of them prescribes a derivative filter; the filter
  ``T_d s/(1 + T_d s/n)`` with ``n = DERIVATIVE_FILTER = 10`` is added.
* :class:`~envs.systems.controllers.SeriesPID`, ``K_c (1 + 1/(T_i s)) (1 + T_d s)``, for Haalman's and
  Skogestad's rules, which cancel the model's lags with the series zeros; the filter
  ``1/(1 + T_d s/n)`` is added.  A series PID converts to the ideal form exactly only without
  filter (:func:`series_to_ideal`), so series rules are returned as :class:`SeriesPID` rather
  than converted approximately.

PI rules return :class:`PID` with ``td = 0`` (the ideal and series PI coincide).  ``a = K L/T``
is the normalized reaction-curve gain: the maximum slope ``R = K/T`` of the unit step response
times the dead time.  For an integrating model the reaction curve is the ramp asymptote
``K_v (t - L - T)``, so ``R = K_v`` and the apparent dead time is ``L + T``
(:func:`reaction_curve`); the rules that need only ``a`` and ``L`` (Ziegler-Nichols step,
Chien-Hrones-Reswick load, AMIGO) apply to integrating models through it.  A negative process
gain gives a negative ``kp`` (reverse action) in every rule.

Names, citations and model types: :data:`baselines.rules.pid_registry.RULES`.  Marlin's own tuning
correlations (Ciancone, ch. 9, Figures 9.5 and 9.9) are graphs without formulas and are not here.

References
----------
.. [ZN] J. G. Ziegler, N. B. Nichols, "Optimum settings for automatic controllers", Trans. ASME
   64 (1942) 759-768.
.. [MA] T. E. Marlin, "Process Control", McGraw-Hill (seed 001): eq. 8.27 (PID), Table 10.4
   (Ziegler-Nichols closed loop, ultimate gain), Table 10.5 (Ziegler-Nichols open loop,
   process reaction curve).
.. [CC] G. H. Cohen, G. A. Coon, "Theoretical consideration of retarded control", Trans. ASME 75
   (1953) 827-834.
.. [CHR] K. L. Chien, J. A. Hrones, J. B. Reswick, "On the automatic control of generalized
   passive systems", Trans. ASME 74 (1952) 175-185; table as in [AH95] ch. 4.
.. [HA] A. Haalman, "Adjusting controllers for a deadtime process", Control Engineering 12(7)
   (1965) 71-73.
.. [AH95] K. J. Astrom, T. Hagglund, "PID Controllers: Theory, Design, and Tuning", 2nd ed.,
   ISA 1995.
.. [AH04] K. J. Astrom, T. Hagglund, "Revisiting the Ziegler-Nichols step response method for
   PID control", J. Process Control 14 (2004) 635-650.
.. [AH06] K. J. Astrom, T. Hagglund, "Advanced PID Control", ISA 2006, ch. 7.
.. [SK] S. Skogestad, "Simple analytic rules for model reduction and PID controller tuning",
   J. Process Control 13 (2003) 291-309.
.. [GS] C. Grimholt, S. Skogestad, "Optimal PI-control and verification of the SIMC tuning
   rule", IFAC Conference on Advances in PID Control (PID'12), Brescia 2012, section 5.
.. [RMS] D. E. Rivera, M. Morari, S. Skogestad, "Internal model control. 4. PID controller
   design", Ind. Eng. Chem. Process Des. Dev. 25 (1986) 252-265, Table II.
.. [CF] I.-L. Chien, P. S. Fruehauf, "Consider IMC tuning to improve controller performance",
   Chem. Eng. Prog. 86(10) (1990) 33-41.
"""

from __future__ import annotations

import math

from baselines.rules import pid_forms
from baselines.rules.pid_forms import (
    ReactionCurve,
    UltimatePoint,
    _check_model,
    _fopdt,
    _positive_dead_time,
    half_rule,
    ideal_to_series,
    reaction_curve,
    series_to_ideal,
    ultimate_point,
)
from envs.design import simc_pi_gains  # the one SIMC PI formula, shared with the PI environment
from envs.systems.controllers import PID, SeriesPID
from envs.identification.models import FOPDTModel, IntegratingModel, SOPDTModel

__all__ = [
    "DERIVATIVE_FILTER",
    "IMC_PI_LAMBDA",
    "IMC_PID_LAMBDA",
    # re-exported from baselines.rules.pid_forms (all of it but the Model alias)
    *(name for name in pid_forms.__all__ if name != "Model"),
    "zn_step_pi",
    "zn_step_pid",
    "zn_ultimate_pi",
    "zn_ultimate_pid",
    "cohen_coon_pi",
    "cohen_coon_pid",
    "chr_pi",
    "chr_pid",
    "haalman_pid",
    "amigo_pi",
    "amigo_pid",
    "simc_pi",
    "simc_pid",
    "isimc_pi",
    "imc_pi",
    "imc_pid",
]

DERIVATIVE_FILTER = 10.0
"""``n`` of the derivative filter added to the rules, none of which defines one (textbook 8-20)."""


# --------------------------------------------------------------------------- Ziegler-Nichols
def zn_step_pi(model: FOPDTModel | IntegratingModel) -> PID:
    """Ziegler-Nichols reaction-curve (open-loop) PI: ``K_c = 0.9/a``, ``T_i = 3.3 L``.

    Marlin Table 10.5 (after [ZN], whose reset rate ``0.3/L`` is ``T_i = 3.33 L``); ideal form,
    Marlin eq. 8.29 (no conversion).  Marlin warns against it for small fractions of dead time:
    on its own FOPDT model ``Ms`` is about 3.4 at ``L/(L + T) = 0.1``.

    Parameters
    ----------
    model : FOPDTModel or IntegratingModel
        The reaction curve (:func:`reaction_curve`); ``L > 0``.

    Returns
    -------
    PID
        ``PID(kp=0.9/a, ti=3.3 L)``.
    """
    curve = reaction_curve(model, "zn_step_pi")
    return PID(kp=0.9 / curve.a, ti=3.3 * curve.dead_time)


def zn_step_pid(model: FOPDTModel | IntegratingModel, n: float = DERIVATIVE_FILTER) -> PID:
    """Ziegler-Nichols reaction-curve PID: ``K_c = 1.2/a``, ``T_i = 2 L``, ``T_d = L/2``.

    Marlin Table 10.5 / [ZN]; ideal form (Marlin eq. 8.27) with the derivative filter added.
    ``T_i = 4 T_d``: the same controller is exactly the series PID
    ``(K_c/2)(1 + 1/(L s))(1 + L s)`` without filter.

    Parameters
    ----------
    model : FOPDTModel or IntegratingModel
        The reaction curve (:func:`reaction_curve`); ``L > 0``.
    n : float
        Derivative filter ``T_d s/(1 + T_d s/n)``.

    Returns
    -------
    PID
    """
    curve = reaction_curve(model, "zn_step_pid")
    return PID(kp=1.2 / curve.a, ti=2.0 * curve.dead_time, td=0.5 * curve.dead_time, n=n)


def zn_ultimate_pi(ultimate_gain: float, ultimate_period: float) -> PID:
    """Ziegler-Nichols closed-loop PI: ``K_c = K_u/2.2``, ``T_i = T_u/1.2`` (Marlin Table 10.4).

    Ideal form, no conversion.

    Parameters
    ----------
    ultimate_gain, ultimate_period : float
        ``K_u`` (signed like the process gain) and ``T_u > 0``, e.g. from :func:`ultimate_point`.

    Returns
    -------
    PID
    """
    _check_ultimate(ultimate_gain, ultimate_period)
    return PID(kp=ultimate_gain / 2.2, ti=ultimate_period / 1.2)


def zn_ultimate_pid(ultimate_gain: float, ultimate_period: float, n: float = DERIVATIVE_FILTER) -> PID:
    """Ziegler-Nichols closed-loop PID: ``K_c = K_u/1.7``, ``T_i = T_u/2``, ``T_d = T_u/8``.

    Marlin Table 10.4 (``K_u/1.7``; [AH95] round it to ``0.6 K_u``); ideal form with the
    derivative filter added; ``T_i = 4 T_d`` (a double real zero).  On a FOPDT model with
    ``n = 10`` the loop is unstable for ``L/(L + T)`` above about 0.85: the filtered derivative's
    high-frequency gain ``K_c (1 + n)`` meets a plant that hardly rolls off.

    Parameters
    ----------
    ultimate_gain, ultimate_period : float
        ``K_u`` (signed like the process gain) and ``T_u > 0``, e.g. from :func:`ultimate_point`.
    n : float
        Derivative filter ``T_d s/(1 + T_d s/n)``.

    Returns
    -------
    PID
    """
    _check_ultimate(ultimate_gain, ultimate_period)
    return PID(kp=ultimate_gain / 1.7, ti=ultimate_period / 2.0, td=ultimate_period / 8.0, n=n)


def _check_ultimate(gain: float, period: float) -> None:
    if not (math.isfinite(gain) and gain != 0):
        raise ValueError(f"ultimate_gain must be finite and non-zero, got {gain!r}")
    if not (math.isfinite(period) and period > 0):
        raise ValueError(f"ultimate_period must be finite and > 0, got {period!r}")


# --------------------------------------------------------------------------- Cohen-Coon
def cohen_coon_pi(model: FOPDTModel) -> PID:
    """Cohen-Coon PI ([CC], as tabulated in [AH95] ch. 4 and O'Dwyer 2006), ideal form.

    With ``r = L/T``: ``K_c = (T/(K L)) (0.9 + r/12)``, ``T_i = L (30 + 3 r)/(9 + 20 r)``.

    Parameters
    ----------
    model : FOPDTModel
        ``T > 0``, ``L > 0``.

    Returns
    -------
    PID
    """
    gain, time_constant, dead_time = _fopdt(model, "cohen_coon_pi")
    r = dead_time / time_constant
    return PID(kp=(0.9 + r / 12.0) / (gain * r), ti=dead_time * (30.0 + 3.0 * r) / (9.0 + 20.0 * r))


def cohen_coon_pid(model: FOPDTModel, n: float = DERIVATIVE_FILTER) -> PID:
    """Cohen-Coon PID ([CC]), ideal form with the derivative filter added.

    With ``r = L/T``: ``K_c = (T/(K L)) (4/3 + r/4)``, ``T_i = L (32 + 6 r)/(13 + 8 r)``,
    ``T_d = 4 L/(11 + 2 r)``.

    Parameters
    ----------
    model : FOPDTModel
        ``T > 0``, ``L > 0``.
    n : float
        Derivative filter ``T_d s/(1 + T_d s/n)``.

    Returns
    -------
    PID
    """
    gain, time_constant, dead_time = _fopdt(model, "cohen_coon_pid")
    r = dead_time / time_constant
    return PID(
        kp=(4.0 / 3.0 + r / 4.0) / (gain * r),
        ti=dead_time * (32.0 + 6.0 * r) / (13.0 + 8.0 * r),
        td=4.0 * dead_time / (11.0 + 2.0 * r),
        n=n,
    )


# --------------------------------------------------------------------------- Chien-Hrones-Reswick
# (objective, overshoot %) -> (K_c a, T_i factor, unit of T_i [, T_d/L]); [CHR] as in [AH95] ch. 4
_CHR_PI = {
    ("setpoint", 0): (0.35, 1.2, "T"),
    ("setpoint", 20): (0.6, 1.0, "T"),
    ("load", 0): (0.6, 4.0, "L"),
    ("load", 20): (0.7, 2.3, "L"),
}
_CHR_PID = {
    ("setpoint", 0): (0.6, 1.0, "T", 0.5),
    ("setpoint", 20): (0.95, 1.4, "T", 0.47),
    ("load", 0): (0.95, 2.4, "L", 0.42),
    ("load", 20): (1.2, 2.0, "L", 0.42),
}


def _chr_row(table: dict, model: FOPDTModel | IntegratingModel, objective: str, overshoot: int, rule: str) -> tuple:
    if (objective, overshoot) not in table:
        raise ValueError(
            f"{rule} needs objective in ('setpoint', 'load') and overshoot in (0, 20), got {objective!r}, {overshoot!r}"
        )
    curve = reaction_curve(model, rule)
    row = table[(objective, overshoot)]
    if row[2] == "T" and curve.time_constant is None:
        raise ValueError(f"{rule} for set point uses the time constant T: not defined for an integrating model")
    unit = curve.time_constant if row[2] == "T" else curve.dead_time
    return curve, row, unit


def chr_pi(model: FOPDTModel | IntegratingModel, objective: str = "load", overshoot: int = 0) -> PID:
    """Chien-Hrones-Reswick PI ([CHR], table as in [AH95] ch. 4), ideal form.

    ============  =========  ===========  ==========
    objective     overshoot  ``K_c a``    ``T_i``
    ============  =========  ===========  ==========
    set point     0 %        0.35         1.2 T
    set point     20 %       0.6          T
    load          0 %        0.6          4 L
    load          20 %       0.7          2.3 L
    ============  =========  ===========  ==========

    Parameters
    ----------
    model : FOPDTModel or IntegratingModel
        The load rules need only ``a`` and ``L`` (:func:`reaction_curve`) and so apply to
        integrating models; the set-point rules need ``T``.
    objective : {"load", "setpoint"}
    overshoot : {0, 20}
        Percent overshoot of the design.

    Returns
    -------
    PID
    """
    curve, (ka, ti, _), unit = _chr_row(_CHR_PI, model, objective, overshoot, "chr_pi")
    return PID(kp=ka / curve.a, ti=ti * unit)


def chr_pid(
    model: FOPDTModel | IntegratingModel, objective: str = "load", overshoot: int = 0, n: float = DERIVATIVE_FILTER
) -> PID:
    """Chien-Hrones-Reswick PID ([CHR], table as in [AH95] ch. 4), ideal form, filter added.

    ============  =========  ===========  ==========  ==========
    objective     overshoot  ``K_c a``    ``T_i``     ``T_d``
    ============  =========  ===========  ==========  ==========
    set point     0 %        0.6          T           0.5 L
    set point     20 %       0.95         1.4 T       0.47 L
    load          0 %        0.95         2.4 L       0.42 L
    load          20 %       1.2          2 L         0.42 L
    ============  =========  ===========  ==========  ==========

    Parameters
    ----------
    model : FOPDTModel or IntegratingModel
        As in :func:`chr_pi`.
    objective : {"load", "setpoint"}
    overshoot : {0, 20}
    n : float
        Derivative filter ``T_d s/(1 + T_d s/n)``.

    Returns
    -------
    PID
    """
    curve, (ka, ti, _, td), unit = _chr_row(_CHR_PID, model, objective, overshoot, "chr_pid")
    return PID(kp=ka / curve.a, ti=ti * unit, td=td * curve.dead_time, n=n)


# --------------------------------------------------------------------------- Haalman
def _as_sopdt(model: SOPDTModel | FOPDTModel) -> SOPDTModel:
    """A FOPDT model as the SOPDT model with ``T_2 = 0``; an SOPDT model unchanged."""
    if isinstance(model, FOPDTModel):
        return SOPDTModel(gain=model.gain, time_constants=(model.time_constant, 0.0), dead_time=model.dead_time)
    return model


def haalman_pid(model: SOPDTModel | FOPDTModel, n: float = DERIVATIVE_FILTER) -> SeriesPID:
    """Haalman's PID ([HA]; [AH95] ch. 4), series form on the SOPDT model, no conversion.

    ``T_i = T_1``, ``T_d = T_2`` cancel the lags and ``K_c = 2 T_1/(3 K L)`` makes the model loop
    ``2 e^{-L s}/(3 L s)`` (phase margin ``pi/2 - 2/3`` rad = 51.8 deg, gain margin ``3 pi/4``,
    ``Ms`` 1.9), up to the filter ``1/(1 + T_2 s/n)`` added here.  A FOPDT model (or
    ``T_2 = 0``) gives Haalman's PI, ``T_i = T``.  Equal to :meth:`SeriesPID.gorez_klan` with
    ``mu = 3/2``.

    Parameters
    ----------
    model : SOPDTModel or FOPDTModel
        ``T_1 > 0``, ``L > 0``.
    n : float
        Derivative filter ``(1 + T_d s)/(1 + T_d s/n)``.

    Returns
    -------
    SeriesPID
    """
    _check_model(model, "haalman_pid", (SOPDTModel, FOPDTModel))
    model = _as_sopdt(model)
    _positive_dead_time(model.dead_time, "haalman_pid")
    t1, t2 = sorted(model.time_constants, reverse=True)
    if t1 <= 0:
        raise ValueError("haalman_pid needs a time constant > 0 (a pure dead time gives integral-only control)")
    return SeriesPID(kp=2.0 * t1 / (3.0 * model.gain * model.dead_time), ti=t1, td=t2, n=n)


# --------------------------------------------------------------------------- AMIGO
def amigo_pi(model: FOPDTModel | IntegratingModel) -> PID:
    """AMIGO PI ([AH04]; [AH06] ch. 7), ideal form, designed for ``Ms = 1.4``.

    FOPDT: ``K_c = 0.15/K + (0.35 - L T/(L + T)^2) T/(K L)``,
    ``T_i = 0.35 L + 13 L T^2/(T^2 + 12 L T + 7 L^2)``.
    Integrating ``K_v e^{-L s}/s``: ``K_c = 0.35/(K_v L)``, ``T_i = 13.4 L`` ([AH06]; the FOPDT
    limit is ``13.35 L``).  AMIGO's set-point weight ``b`` is not used: the controllers of
    :mod:`envs.systems.controllers` act on the error.

    Parameters
    ----------
    model : FOPDTModel or IntegratingModel
        ``L > 0``; with an integrating model's lag ``L`` is the apparent dead time ``L + T``
        (:func:`reaction_curve`).

    Returns
    -------
    PID
    """
    if isinstance(model, IntegratingModel):
        curve = reaction_curve(model, "amigo_pi")
        return PID(kp=0.35 / curve.a, ti=13.4 * curve.dead_time)
    gain, t, dead = _fopdt(model, "amigo_pi", need_lag=False)
    kp = 0.15 / gain + (0.35 - dead * t / (dead + t) ** 2) * t / (gain * dead)
    return PID(kp=kp, ti=0.35 * dead + 13.0 * dead * t**2 / (t**2 + 12.0 * dead * t + 7.0 * dead**2))


def amigo_pid(model: FOPDTModel | IntegratingModel, n: float = DERIVATIVE_FILTER) -> PID:
    """AMIGO PID ([AH04]; [AH06] ch. 7), ideal form with the derivative filter added.

    FOPDT: ``K_c = (0.2 + 0.45 T/L)/K``, ``T_i = L (0.4 L + 0.8 T)/(L + 0.1 T)``,
    ``T_d = 0.5 L T/(0.3 L + T)``.  Integrating: ``K_c = 0.45/(K_v L)``, ``T_i = 8 L``,
    ``T_d = 0.5 L``, the limits ``T -> infinity`` with ``K/T = K_v``.  Set-point weights are
    not used.

    Parameters
    ----------
    model : FOPDTModel or IntegratingModel
        As in :func:`amigo_pi`.
    n : float
        Derivative filter ``T_d s/(1 + T_d s/n)``.

    Returns
    -------
    PID
    """
    if isinstance(model, IntegratingModel):
        curve = reaction_curve(model, "amigo_pid")
        return PID(kp=0.45 / curve.a, ti=8.0 * curve.dead_time, td=0.5 * curve.dead_time, n=n)
    gain, t, dead = _fopdt(model, "amigo_pid", need_lag=False)
    return PID(
        kp=(0.2 + 0.45 * t / dead) / gain,
        ti=dead * (0.4 * dead + 0.8 * t) / (dead + 0.1 * t),
        td=0.5 * dead * t / (0.3 * dead + t),
        n=n,
    )


# --------------------------------------------------------------------------- SIMC
def _tau_c(tau_c: float | None, dead_time: float, rule: str) -> float:
    if tau_c is None and not dead_time > 0:
        raise ValueError(f"{rule} needs dead_time > 0 (its default tau_c is the dead time), got {dead_time!r}")
    value = dead_time if tau_c is None else float(tau_c)
    if not (math.isfinite(value) and value >= 0) or value + dead_time <= 0:
        raise ValueError(
            f"{rule} needs tau_c >= 0 with tau_c + dead_time > 0, got tau_c={tau_c!r}, dead_time={dead_time!r}"
        )
    return value


def _simc_integrating(gain: float, dead_time: float, tau_c: float | None, rule: str) -> tuple[float, float]:
    tc = _tau_c(tau_c, dead_time, rule)
    return 1.0 / (gain * (tc + dead_time)), 4.0 * (tc + dead_time)


def _simc_lag(gain: float, lag: float, dead_time: float, tau_c: float | None, rule: str) -> tuple[float, float]:
    """``K_c = lag/(k (tau_c + theta))``, ``tau_I = min(lag, 4 (tau_c + theta))`` of SIMC ([SK])."""
    return simc_pi_gains(gain, lag, dead_time, _tau_c(tau_c, dead_time, rule))


def simc_pi(model: FOPDTModel | SOPDTModel | IntegratingModel, tau_c: float | None = None) -> PID:
    """Skogestad's SIMC PI ([SK]), ``tau_c = theta`` ("tight" tuning) by default.

    FOPDT ``k e^{-theta s}/(tau_1 s + 1)``: ``K_c = tau_1/(k (tau_c + theta))``,
    ``tau_I = min(tau_1, 4 (tau_c + theta))``.  Integrating ``k' e^{-theta s}/s``:
    ``K_c = 1/(k' (tau_c + theta))``, ``tau_I = 4 (tau_c + theta)``.

    Parameters
    ----------
    model : FOPDTModel, SOPDTModel or IntegratingModel
        An SOPDT model is first reduced by the half rule (:func:`half_rule`); an integrating
        model's lag ``T`` goes to the effective dead time as ``theta + T/2`` (half rule, the
        integrator being the larger, infinite lag).  ``tau_1 > 0``.
    tau_c : float, optional
        Desired closed-loop time constant; default the (effective) dead time.

    Returns
    -------
    PID
    """
    if isinstance(model, SOPDTModel):
        model = half_rule(model)
    if isinstance(model, IntegratingModel):
        dead = model.dead_time + (model.time_constant or 0.0) / 2.0
        kp, ti = _simc_integrating(model.gain, dead, tau_c, "simc_pi")
        return PID(kp=kp, ti=ti)
    gain, t1, dead = _fopdt(model, "simc_pi", need_lag=False, need_dead_time=False)
    if t1 <= 0:
        raise ValueError("simc_pi on a pure dead time gives integral-only control; use isimc_pi")
    kp, ti = _simc_lag(gain, t1, dead, tau_c, "simc_pi")
    return PID(kp=kp, ti=ti)


def simc_pid(
    model: SOPDTModel | FOPDTModel | IntegratingModel, tau_c: float | None = None, n: float = DERIVATIVE_FILTER
) -> SeriesPID:
    """Skogestad's SIMC PID ([SK]) in his series ("cascade") form, no conversion, filter added.

    SOPDT ``k e^{-theta s}/((tau_1 s + 1)(tau_2 s + 1))``, ``tau_1 >= tau_2``:
    ``K_c = tau_1/(k (tau_c + theta))``, ``tau_I = min(tau_1, 4 (tau_c + theta))``,
    ``tau_D = tau_2``.  Integrating with lag ``k' e^{-theta s}/(s (tau_2 s + 1))``:
    ``K_c = 1/(k' (tau_c + theta))``, ``tau_I = 4 (tau_c + theta)``, ``tau_D = tau_2``.
    [SK] recommend the derivative only if ``tau_2`` exceeds about ``theta``.

    Parameters
    ----------
    model : SOPDTModel, FOPDTModel or IntegratingModel
        A FOPDT model is the SOPDT model with ``tau_2 = 0`` (SIMC PI).
    tau_c : float, optional
        Desired closed-loop time constant; default the dead time ``theta``.
    n : float
        Derivative filter ``(1 + tau_D s)/(1 + tau_D s/n)``.

    Returns
    -------
    SeriesPID
    """
    _check_model(model, "simc_pid", (SOPDTModel, FOPDTModel, IntegratingModel))
    if isinstance(model, IntegratingModel):
        kp, ti = _simc_integrating(model.gain, model.dead_time, tau_c, "simc_pid")
        return SeriesPID(kp=kp, ti=ti, td=model.time_constant or 0.0, n=n)
    model = _as_sopdt(model)
    t1, t2 = sorted(model.time_constants, reverse=True)
    if t1 <= 0:
        raise ValueError("simc_pid on a pure dead time gives integral-only control")
    kp, ti = _simc_lag(model.gain, t1, model.dead_time, tau_c, "simc_pid")
    return SeriesPID(kp=kp, ti=ti, td=t2, n=n)


def isimc_pi(model: FOPDTModel | IntegratingModel, tau_c: float | None = None) -> PID:
    """Improved SIMC PI ([GS] section 5): SIMC with ``tau_1`` replaced by ``tau_1 + theta/3``.

    ``K_c = (tau_1 + theta/3)/(k (tau_c + theta))``,
    ``tau_I = min(tau_1 + theta/3, 4 (tau_c + theta))``; on a pure dead time it gives a PI
    (``K_c = 1/(6 k)``, ``tau_I = theta/3``) instead of SIMC's integral-only controller.

    Parameters
    ----------
    model : FOPDTModel or IntegratingModel
        For an integrating model (``tau_1`` infinite) the rule is SIMC (:func:`simc_pi`).
    tau_c : float, optional
        Desired closed-loop time constant; default the dead time ``theta``.

    Returns
    -------
    PID
    """
    if isinstance(model, IntegratingModel):
        return simc_pi(model, tau_c)
    gain, t1, dead = _fopdt(model, "isimc_pi", need_lag=False, need_dead_time=False)
    kp, ti = _simc_lag(gain, t1 + dead / 3.0, dead, tau_c, "isimc_pi")
    return PID(kp=kp, ti=ti)


# --------------------------------------------------------------------------- IMC / lambda
IMC_PI_LAMBDA = 1.7
"""Default ``lambda/L`` of :func:`imc_pi`: the lower bound [RMS] recommend for the PI."""
IMC_PID_LAMBDA = 0.8
"""Default ``lambda/L`` of :func:`imc_pid`: the lower bound [RMS] recommend for the PID."""


def _lambda(lam: float | None, default: float, dead_time: float, rule: str) -> float:
    if lam is None and not dead_time > 0:
        raise ValueError(f"{rule} needs dead_time > 0 (its default lambda is {default} times the dead time), got {dead_time!r}")
    value = default * dead_time if lam is None else float(lam)
    if not (math.isfinite(value) and value > 0):
        raise ValueError(
            f"{rule} needs lambda > 0 (default {default} L with L > 0), got lambda={lam!r}, dead_time={dead_time!r}"
        )
    return value


def imc_pi(model: FOPDTModel | IntegratingModel, lam: float | None = None) -> PID:
    """IMC ("lambda") PI, ideal form; ``lambda`` is the IMC filter time constant.

    FOPDT, [RMS] Table II "improved PI": ``K_c = (2 T + L)/(2 K lambda)``, ``T_i = T + L/2``.
    Integrating ``K_v e^{-L s}/s`` ([CF]: IMC with ``e^{-L s} ~ 1 - L s`` and the filter
    ``((2 lambda + L) s + 1)/(lambda s + 1)^2``, which makes ``1 - G q`` vanish twice at
    ``s = 0``): ``K_c = (2 lambda + L)/(K_v (lambda + L)^2)``, ``T_i = 2 lambda + L``.

    Parameters
    ----------
    model : FOPDTModel or IntegratingModel
        With an integrating model's lag, ``L`` is the apparent dead time ``L + T``
        (:func:`reaction_curve`).
    lam : float, optional
        ``lambda > 0``; default ``1.7 L`` (:data:`IMC_PI_LAMBDA`, [RMS]'s ``lambda/L > 1.7``).

    Returns
    -------
    PID
    """
    if isinstance(model, IntegratingModel):
        curve = reaction_curve(model, "imc_pi")
        dead = curve.dead_time
        lam = _lambda(lam, IMC_PI_LAMBDA, dead, "imc_pi")
        return PID(kp=(2.0 * lam + dead) / (model.gain * (lam + dead) ** 2), ti=2.0 * lam + dead)
    gain, t, dead = _fopdt(model, "imc_pi", need_lag=False, need_dead_time=False)
    lam = _lambda(lam, IMC_PI_LAMBDA, dead, "imc_pi")
    return PID(kp=(2.0 * t + dead) / (2.0 * gain * lam), ti=t + dead / 2.0)


def imc_pid(model: FOPDTModel, lam: float | None = None, n: float = DERIVATIVE_FILTER) -> PID:
    """IMC PID ([RMS] Table II, PID row), ideal form with the derivative filter added.

    With the first-order Pade ``e^{-L s} ~ (1 - L s/2)/(1 + L s/2)`` the IMC controller is the
    series PID ``T/(K (lambda + L/2)) (1 + 1/(T s))(1 + L s/2)``, i.e. exactly
    (:func:`series_to_ideal`) ``K_c = (2 T + L)/(K (2 lambda + L))``, ``T_i = T + L/2``,
    ``T_d = T L/(2 T + L)``.

    Parameters
    ----------
    model : FOPDTModel
    lam : float, optional
        ``lambda > 0``; default ``0.8 L`` (:data:`IMC_PID_LAMBDA`, [RMS]'s ``lambda/L > 0.8``).
    n : float
        Derivative filter ``T_d s/(1 + T_d s/n)``.

    Returns
    -------
    PID
    """
    gain, t, dead = _fopdt(model, "imc_pid", need_lag=False, need_dead_time=False)
    lam = _lambda(lam, IMC_PID_LAMBDA, dead, "imc_pid")
    return PID(
        kp=(2.0 * t + dead) / (gain * (2.0 * lam + dead)), ti=t + dead / 2.0, td=t * dead / (2.0 * t + dead), n=n
    )
