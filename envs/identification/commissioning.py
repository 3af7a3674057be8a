"""The commissioning PI: the plant's existing, conservative controller, and its maximum sensitivity.

:func:`commissioning_pi` is the controller the closed-loop step experiment
(:func:`envs.identification.experiments.closed_loop_step`) runs with by default: a lambda-type PI on the plant's
exact moment FOPDT (Gorez-Klan eq. 2-5, 2-6), or a P controller on an integrating plant, detuned to
a maximum sensitivity ``Ms`` (:func:`max_sensitivity`) of at most
``COMMISSIONING_MAX_SENSITIVITY``.

References
----------
.. [GK] R. Gorez, P. Klan, "Simple models for process control", section 2.
.. [IN] A. Ingimundarson, "Robust tuning procedures of dead-time compensating controllers",
   Lund 2000, section 2.3.
"""

from __future__ import annotations

import cmath
import math

import numba
import numpy as np

from envs.systems.controllers import PID, Controller
from envs.identification.experiment_base import check_plant
from envs.simulation.loops import loop_response
from envs.systems.plants import Plant
from envs.validation import require_number

__all__ = ["COMMISSIONING_MAX_SENSITIVITY", "commissioning_pi", "max_sensitivity"]

COMMISSIONING_MAX_SENSITIVITY = 1.4
"""Maximum sensitivity ``Ms`` the commissioning PI is detuned to, on the exact frequency response."""


def commissioning_pi(plant: Plant, max_sensitivity_target: float = COMMISSIONING_MAX_SENSITIVITY) -> PID:
    """The plant's existing, conservative controller, computed from the TRUE plant.

    Self-regulating plants: a lambda-type PI on the plant's exact moment FOPDT
    (``T_a``, ``D_a = T_ar - T_a``, Gorez-Klan eq. 2-5, 2-6):
    ``T_i = max(T_a, 0.1 T_ar)``, ``K_p = T_i/(K (lambda + D_a))`` with ``lambda = T_ar``, so the
    integral gain is ``1/(K (T_ar + D_a))``.

    Integrating plants (velocity gain ``K_v``, ``T_ar`` of the dynamics additional to the
    integrator): proportional only, ``K_p = 1/(3 K_v T_ar)`` (``ti=None``).  The plant's own
    integrator removes the set-point offset, which is all Ingimundarson section 2.3 needs; a PI
    around an integrator adds a slow closed-loop mode (time constant of about ``T_i``, e.g.
    ``8 T_ar`` for ``K_p = 1/(4 K_v T_ar)``, ``T_i = 8 T_ar``) that made the experiment three times
    longer (about 70 instead of 20 ``T_ar`` to settle to 1e-5) and the second moments of
    appendix B far worse conditioned (``g_2 = -T_i/(K_v K_p)``).

    The rule alone gives ``Ms`` of 1.0 to 1.55 on FOPDT plants and about 1.34 on integrating ones,
    but not on lightly damped or strongly inverse-response shapes.  So the gain is detuned by a
    factor ``c`` (``K_p -> c K_p``, ``T_i`` kept) chosen on a grid of 5% steps from ``c = 1e-3``
    upwards: the largest ``c <= 1`` such that every smaller grid value keeps
    ``Ms = max |1/(1 + L(i omega))|`` (exact frequency response, :func:`max_sensitivity` grid) at
    most ``max_sensitivity_target``.  Along that path from an almost open (stable) loop the Nyquist
    curve never comes near the critical point, so the result is stable.

    Raises
    ------
    ValueError
        If ``max_sensitivity_target <= 1``.
    """
    plant = check_plant(plant)
    target = require_number(max_sensitivity_target, "max_sensitivity_target")
    if target <= 1.0:
        raise ValueError(f"max_sensitivity_target must be > 1, got {target!r}")
    omega = _sensitivity_grid(plant)
    detuning = _DETUNING
    kp, reset_rate = (_integrating_rule if plant.integrating else _lambda_rule)(plant, detuning)
    loop = _pi_loop_on_grid(plant, omega, np.sign(kp[-1]), reset_rate)
    best = _first_violation_fast(loop, np.abs(kp), target) - 1
    if best < 0:  # pragma: no cover - a loop detuned 1000 times is far inside the target
        raise ValueError("no PI with the required maximum sensitivity found")
    return PID(kp=float(kp[best]), ti=1.0 / reset_rate if reset_rate > 0 else None)


def _pi_loop_on_grid(plant: Plant, omega: np.ndarray, sign: float, reset_rate: float) -> np.ndarray:
    """``sign * plant.frequency_response(omega) * (1 + reset_rate/(1j * omega))`` on a grid of positive
    frequencies, by one compiled pass (:func:`_pi_loop_kernel`) instead of some thirty numpy calls on
    complex arrays.  Equal to the numpy expression to rounding (the unit tests bound the difference);
    the PI chosen from it is the same (its gains are a grid, decided by a bound ``Ms`` is not near).
    """
    num, den = np.asarray(plant.num, dtype=float), np.asarray(plant.den, dtype=float)
    return _pi_loop_kernel(omega, num, den, float(plant.dead_time), float(sign), float(reset_rate))


@numba.njit(cache=True)
def _pi_loop_kernel(omega, num, den, delay, sign, reset_rate):  # pragma: no cover - compiled
    """``sign * num(s)/den(s) e^{-s delay} (1 + reset_rate/s)`` at ``s = j omega`` (Horner's rule)."""
    out = np.empty(omega.size, dtype=np.complex128)
    for k in range(omega.size):
        s = complex(0.0, omega[k])
        n, d = 0j, 0j
        for c in num:
            n = n * s + c
        for c in den:
            d = d * s + c
        out[k] = sign * (n / d * cmath.exp(-s * delay)) * (1.0 + reset_rate / s)
    return out


def _first_violation(loop: np.ndarray, gains: np.ndarray, target: float) -> int:
    """Index of the first of the increasing ``gains`` ``k > 0`` with ``max_omega 1/|1 + k L| > target``
    (``gains.size`` if none), for a target ``> 1``.

    At each frequency, ``|1 + k L|^2 = 1 + 2 k Re L + k^2 |L|^2 < 1/target^2`` holds exactly for
    ``k`` strictly between the two roots of that quadratic (real and positive only where ``Re L < 0``);
    the answer is the first gain inside any of these intervals.  This is the decision of comparing
    every ``max_omega 1/|1 + k L|`` with the target, without the ``gains x omega`` table.
    """
    threshold = 1.0 - 1.0 / target**2
    left = loop[loop.real < 0]
    a, b = left.real, np.abs(left) ** 2
    discriminant = a * a - b * threshold
    inside = discriminant > 0
    a, b, root = a[inside], b[inside], np.sqrt(discriminant[inside])
    upper = (root - a) / b
    lower = threshold / (b * upper)  # the product of the roots is threshold/b (no cancellation)
    first = np.searchsorted(gains, lower, side="right")
    hit = first < gains.size
    hit[hit] = gains[first[hit]] < upper[hit]
    return int(first[hit].min()) if hit.any() else gains.size


def _first_violation_fast(loop: np.ndarray, gains: np.ndarray, target: float) -> int:
    """:func:`_first_violation` by one compiled pass over the loop (the same operations); a loop with a
    non-finite value is left to :func:`_first_violation`."""
    first = _first_violation_kernel(loop, gains, 1.0 - 1.0 / target**2)
    return _first_violation(loop, gains, target) if first < 0 else first


@numba.njit(cache=True)
def _first_violation_kernel(loop, gains, threshold):  # pragma: no cover - compiled
    """:func:`_first_violation` for a finite ``loop`` (else -1), frequency by frequency, with
    ``searchsorted(side="right")`` as a binary search."""
    best = gains.size
    for k in range(loop.size):
        re, im = loop[k].real, loop[k].imag
        if not re < 0:
            continue
        if not (abs(re) <= _LARGEST and abs(im) <= _LARGEST):
            return -1
        magnitude = abs(loop[k])
        b = magnitude * magnitude
        discriminant = re * re - b * threshold
        if not discriminant > 0:
            continue
        upper = (math.sqrt(discriminant) - re) / b
        lower = threshold / (b * upper)
        low, high = 0, gains.size  # the first gain > lower (NaN: none)
        while low < high:
            middle = (low + high) // 2
            if lower < gains[middle]:
                high = middle
            else:
                low = middle + 1
        if low < gains.size and gains[low] < upper and low < best:
            best = low
    return best


_LARGEST = float(np.finfo(float).max)  # |x| <= _LARGEST: x is finite


def _sensitivity_grid(plant: Plant) -> np.ndarray:
    return _UNIT_GRID / plant.step_time_scale()


_DETUNING = np.geomspace(1e-3, 1.0, 139)  # the detuning factors c of commissioning_pi, increasing
_UNIT_GRID = np.logspace(-4, 3, 2500)  # the frequencies of max_sensitivity, times T
_DETUNING.setflags(write=False)
_UNIT_GRID.setflags(write=False)


def max_sensitivity(plant: Plant, controller: Controller) -> float:
    """``Ms = max |1/(1 + L(i omega))|`` on 2500 log-spaced points over ``[1e-4, 1e3]/T``."""
    loop = loop_response(plant, controller, _sensitivity_grid(plant))
    return float(np.max(1.0 / np.abs(1.0 + loop)))


def _lambda_rule(plant: Plant, detuning: np.ndarray) -> tuple[np.ndarray, float]:
    p1, p2 = plant.taylor_coefficients()
    residence_time = -p1 if -p1 > 0 else plant.step_time_scale()
    apparent = min(math.sqrt(max(2.0 * p2 - residence_time**2, 0.0)), residence_time)
    ti = max(apparent, 0.1 * residence_time)
    kp = ti / (plant.gain * (2.0 * residence_time - apparent))
    return detuning * kp, 1.0 / ti


def _integrating_rule(plant: Plant, detuning: np.ndarray) -> tuple[np.ndarray, float]:
    return detuning / (3.0 * plant.gain * plant.step_time_scale()), 0.0
