"""Robustness of a loop from its exact frequency response (dead times included, no Pade).

For a loop transfer ``L(s)`` whose open-loop poles in the closed right half plane are ``k``
integrators at the origin (true for every plant and controller of deadtime-gym: plants are stable
or integrating, and the controllers' only such poles are integral actions -- the dead-time
compensators' characteristic quasi-polynomials ``(T_r s+1)(T_f s+1) - e^{-L_n s}`` and
``T_r s + 1 - e^{-L_n s}`` have no other root with ``Re s >= 0``), the Nyquist criterion on the
contour indented to the right of the origin gives the number of closed-loop poles in the right
half plane::

    Z = (k pi - 2 Delta) / (2 pi),   Delta = change of arg(1 + L(i w)) for w from 0+ to infinity.

``Delta`` is measured on a logarithmic grid refined until ``arg(1 + L)`` moves by less than a
fixed angle between neighbouring points.  On the same refined grid: the gain crossovers
``|L| = 1`` and phase crossovers ``Im L = 0, Re L < 0`` (located with ``brentq``), the maximum
sensitivity ``Ms = max |1/(1+L)|`` and ``Mt = max |L/(1+L)|`` (local refinement with a bounded
scalar search), and the delay margin ``DM = min_i phi_i/w_i`` over every gain crossover, with the
phase margin ``phi_i`` taken in ``[0, 2 pi)`` (Ingimundarson section 3, after Landau et al.).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
import scipy.optimize

__all__ = ["Margins", "loop_margins", "frequency_grid", "fppi_uncertainty_bound", "msp_uncertainty_bound"]

LoopFunction = Callable[[np.ndarray], np.ndarray]

MAX_ARG_STEP = 0.2  # rad between neighbouring grid points
MAX_POINTS = 50_000
POINTS_PER_DECADE = 60


@dataclass(frozen=True)
class Margins:
    """Stability and robustness figures of a loop ``L``.

    Frequencies are in rad per time unit of the plant.  ``gain_margin`` is the smallest factor
    ``> 1`` by which the loop gain can grow before a phase crossover reaches ``-1`` (``inf`` if
    none); ``phase_margin_deg`` is the smallest phase margin over the gain crossovers (``inf``
    without crossover); ``delay_margin`` is ``0`` for an unstable loop.
    """

    stable: bool
    unstable_poles: int
    ms: float
    ms_frequency: float
    mt: float
    mt_frequency: float
    gain_margin: float
    phase_crossover_frequency: float
    phase_margin_deg: float
    gain_crossover_frequency: float
    delay_margin: float
    delay_margin_frequency: float
    gain_crossovers: tuple[float, ...]
    phase_crossovers: tuple[float, ...]


def _low_frequency(loop: LoopFunction, integrators: int, start: float) -> float:
    """Decrease ``start`` until ``L(s) s^k`` has converged to its value at ``s = 0``."""
    w = start
    for _ in range(40):
        a = loop(np.array([w]))[0] * (1j * w) ** integrators
        b = loop(np.array([w / 10]))[0] * (1j * w / 10) ** integrators
        if abs(a - b) <= 1e-3 * max(abs(b), 1e-300):
            return w / 10
        w /= 10
    return w


def _high_frequency(loop: LoopFunction, start: float) -> tuple[float, bool]:
    """Increase ``start`` until ``|L|`` has reached its limit at infinity.

    That is, until ``|L| < 0.02`` over a whole decade, or (a biproper loop) ``|L|`` varies by less
    than 1% over a decade.  Returns the frequency and whether ``|L(i inf)| < 1``: a loop whose
    gain stays ``>= 1`` at infinity with a dead time has infinitely many unstable closed-loop poles.
    """
    w = start
    for _ in range(14):
        magnitude = np.abs(loop(np.logspace(np.log10(w), np.log10(w) + 1, 64)))
        top = float(np.max(magnitude))
        if top < 0.02 or top - float(np.min(magnitude)) < 0.01 * top:
            return w, top < 1.0
        w *= 10
    return w, top < 1.0


def frequency_grid(loop: LoopFunction, integrators: int, time_scale: float) -> tuple[np.ndarray, bool]:
    """A log grid from where ``L`` has its low-frequency asymptote to where ``|L|`` has its limit.

    Also returns whether ``|L(i inf)| < 1`` (see :func:`_high_frequency`).
    """
    low = _low_frequency(loop, integrators, 1e-3 / time_scale)
    high, tame = _high_frequency(loop, 10.0 / time_scale)
    count = int(np.ceil(np.log10(high / low) * POINTS_PER_DECADE)) + 1
    return np.logspace(np.log10(low), np.log10(high), count), tame


def _refine(loop: LoopFunction, omega: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Insert geometric midpoints where ``arg(1+L)`` or, for ``|L| > 0.2``, ``arg L`` jumps."""
    for _ in range(30):
        if omega.size > MAX_POINTS:
            break
        g = 1 + values
        jump_closed = np.abs(np.angle(g[1:] / g[:-1]))
        big = np.maximum(np.abs(values[1:]), np.abs(values[:-1])) > 0.2
        jump_open = np.where(big, np.abs(np.angle(values[1:] / values[:-1])), 0.0)
        bad = np.flatnonzero(((jump_closed > MAX_ARG_STEP) | (jump_open > MAX_ARG_STEP)) & (omega[1:] / omega[:-1] > 1 + 1e-9))
        if bad.size == 0:
            break
        mids = np.sqrt(omega[bad] * omega[bad + 1])
        omega = np.insert(omega, bad + 1, mids)
        values = np.insert(values, bad + 1, loop(mids))
    return omega, values


def _crossings(fun: Callable[[float], float], omega: np.ndarray, samples: np.ndarray) -> list[float]:
    """Roots of ``fun`` in log frequency: grid points where ``samples`` is exactly zero, and a
    ``brentq`` root between neighbours of opposite sign (linear interpolation in the rare case
    where the scalar re-evaluation disagrees in sign with the vectorized samples)."""
    roots = [float(w) for w in omega[samples == 0]]
    for i in np.flatnonzero(samples[:-1] * samples[1:] < 0):
        a, b = math.log(omega[i]), math.log(omega[i + 1])
        fa, fb = fun(math.exp(a)), fun(math.exp(b))
        if fa * fb < 0:
            root = scipy.optimize.brentq(lambda x: fun(math.exp(x)), a, b, xtol=1e-13)
        else:
            root = a - samples[i] * (b - a) / (samples[i + 1] - samples[i])
        roots.append(math.exp(root))
    return sorted(roots)


def _peak(fun: Callable[[np.ndarray], np.ndarray], omega: np.ndarray, samples: np.ndarray) -> tuple[float, float]:
    """Refine the largest value of ``samples`` by a bounded search between the neighbours."""
    i = int(np.argmax(samples))
    lo, hi = math.log(omega[max(i - 1, 0)]), math.log(omega[min(i + 1, omega.size - 1)])
    if hi <= lo:
        return float(samples[i]), float(omega[i])
    result = scipy.optimize.minimize_scalar(
        lambda x: -float(fun(np.array([math.exp(x)]))[0]), bounds=(lo, hi), method="bounded", options={"xatol": 1e-10}
    )
    if -result.fun > samples[i]:
        return float(-result.fun), float(math.exp(result.x))
    return float(samples[i]), float(omega[i])


def _winding(values: np.ndarray, integrators: int) -> int:
    change = float(np.sum(np.angle((1 + values[1:]) / (1 + values[:-1]))))
    return int(round((integrators * math.pi - 2 * change) / (2 * math.pi)))


def loop_margins(loop: LoopFunction, integrators: int, time_scale: float = 1.0) -> Margins:
    """Stability, Ms, Mt, gain, phase and delay margins of the loop ``L = loop(omega)``.

    Parameters
    ----------
    loop : callable
        ``omega -> L(i omega)``, vectorized, exact (dead times included).
    integrators : int
        Number ``k`` of open-loop poles at the origin; ``L`` must have no other pole with
        ``Re s >= 0``.
    time_scale : float
        A characteristic time of the loop (e.g. the plant's ``T_ar``), where the grid starts.

    Examples
    --------
    The Gorez-Klan model loop ``e^{-s}/(mu s)`` (eq. 3-12 .. 3-14) with ``mu = 2``:

    >>> m = loop_margins(lambda w: np.exp(-1j * w) / (2 * 1j * w), integrators=1)
    >>> round(m.gain_margin, 6), round(m.phase_margin_deg, 4), round(m.delay_margin, 6)
    (3.141593, 61.3521, 2.141593)
    """
    omega, tame = frequency_grid(loop, integrators, time_scale)
    values = loop(omega)
    omega, values = _refine(loop, omega, values)
    unstable = _winding(values, integrators)
    stable = unstable == 0 and tame

    magnitude = np.abs(values)
    gains = _crossings(lambda w: math.log(abs(loop(np.array([w]))[0])), omega, np.log(magnitude))
    imag_sign = values.imag
    phase = _crossings(lambda w: loop(np.array([w]))[0].imag, omega, imag_sign)
    phase = [w for w in phase if loop(np.array([w]))[0].real < 0]

    ms, ms_w = _peak(lambda w: 1 / np.abs(1 + loop(w)), omega, 1 / np.abs(1 + values))
    mt, mt_w = _peak(lambda w: np.abs(loop(w) / (1 + loop(w))), omega, np.abs(values / (1 + values)))

    margins_up = [(1 / abs(loop(np.array([w]))[0]), w) for w in phase]
    margins_up = [(g, w) for g, w in margins_up if g > 1]
    gain_margin, pc_w = min(margins_up) if margins_up else (math.inf, math.nan)

    phase_margin, gc_w, delay_margin, dm_w = math.inf, math.nan, math.inf, math.nan
    for w in gains:
        angle = float(np.angle(loop(np.array([w]))[0]))
        pm = (angle + math.pi + math.pi) % (2 * math.pi) - math.pi  # in [-pi, pi)
        if pm < phase_margin:
            phase_margin, gc_w = pm, w
        delay = ((angle + math.pi) % (2 * math.pi)) / w
        if delay < delay_margin:
            delay_margin, dm_w = delay, w
    if not stable:
        delay_margin = 0.0
    return Margins(
        stable=bool(stable),
        unstable_poles=max(unstable, 0) if tame else -1,
        ms=ms,
        ms_frequency=ms_w,
        mt=mt,
        mt_frequency=mt_w,
        gain_margin=float(gain_margin),
        phase_crossover_frequency=float(pc_w),
        phase_margin_deg=math.degrees(phase_margin) if math.isfinite(phase_margin) else math.inf,
        gain_crossover_frequency=float(gc_w),
        delay_margin=float(delay_margin),
        delay_margin_frequency=float(dm_w),
        gain_crossovers=tuple(gains),
        phase_crossovers=tuple(phase),
    )


def fppi_uncertainty_bound(omega: np.ndarray, gain: float, time_constant: float, tr: float, tf: float) -> np.ndarray:
    """``|Delta P|_FPPI = K_n |(i w T_r + 1)(i w T_f + 1)/(i w T_n + 1)|`` (Ingimundarson eq. 17)."""
    s = 1j * np.asarray(omega, dtype=float)
    return np.abs(gain * (tr * s + 1) * (tf * s + 1) / (time_constant * s + 1))


def msp_uncertainty_bound(omega: np.ndarray, gain: float, dead_time: float, tr: float) -> np.ndarray:
    """``|Delta P|_MSP = |K_n (i w T_r + 1)(2 L_n i w + e^{-i L_n w})| / |-(2 L_n + T_r) w^2 + i w|``
    (Ingimundarson eq. 40)."""
    w = np.asarray(omega, dtype=float)
    s = 1j * w
    numerator = gain * (tr * s + 1) * (2 * dead_time * s + np.exp(-s * dead_time))
    return np.abs(numerator) / np.abs(-(2 * dead_time + tr) * w**2 + s)
