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
``|L| = 1`` and phase crossovers ``Im L = 0, Re L < 0`` (every sign change between neighbours,
located to ``1e-13`` in log frequency by a bracketing method run on all of them at once), the
maximum sensitivity ``Ms = max |1/(1+L)|`` and ``Mt = max |L/(1+L)|`` (local refinement by
repeated sampling around the best grid point), and the delay margin ``DM = min_i phi_i/w_i`` over
every gain crossover, with the phase margin ``phi_i`` taken in ``[0, 2 pi)`` (Ingimundarson
section 3, after Landau et al.).

Every step evaluates ``L`` on arrays of frequencies, never point by point: the cost of an analysis
is a few dozen vectorized evaluations.  :func:`loop_margins` takes any such ``L``; for a loop of a
plant and a controller of deadtime-gym, :func:`envs.analysis.loop_analysis.plant_margins` runs the same algorithm
compiled (:mod:`envs.analysis._robustness_kernels`), and the tests hold the two to rounding.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

__all__ = ["Margins", "loop_margins", "frequency_grid", "fppi_uncertainty_bound", "msp_uncertainty_bound"]

LoopFunction = Callable[[np.ndarray], np.ndarray]
BracketFunction = Callable[[np.ndarray, np.ndarray], np.ndarray]

MAX_ARG_STEP = 0.2  # rad between neighbouring grid points
MAX_POINTS = 50_000
POINTS_PER_DECADE = 60
ROOT_XTOL = 1e-13  # absolute, in log frequency
MAX_ROOT_ITERATIONS = 100
PEAK_POINTS = 65
LOW_FREQUENCY_CHUNK = 4  # decades evaluated at once when looking for the low-frequency asymptote
PEAK_SPACING = 1e-5  # sample spacing around a peak (log frequency) at which its parabola is used


@dataclass(frozen=True)
class Margins:
    """Stability and robustness figures of a loop ``L``.

    Frequencies are in rad per time unit of the plant.  ``gain_margin`` is the smallest factor
    ``> 1`` by which the loop gain can grow before a phase crossover reaches ``-1`` (``inf`` if
    none); ``phase_margin_deg`` is the phase margin smallest in magnitude over the gain crossovers
    (python-control's ``stability_margins``; ``inf`` without crossover) and ``phase_margins_deg``
    that of every gain crossover, in the order of ``gain_crossovers`` (each in ``[-180, 180)``);
    ``delay_margin`` is ``0`` for an unstable loop.  ``unstable_poles`` is the number of
    closed-loop poles in the right half plane, or ``-1`` when it is infinite: ``|L(i w)|`` stays
    ``>= 1`` as ``w -> inf`` around a dead time (a neutral loop; :func:`_high_frequency`).
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
    phase_margins_deg: tuple[float, ...] = ()


def _low_frequency(loop: LoopFunction, integrators: int, start: float) -> float:
    """Decrease ``start`` decade by decade until ``L(s) s^k`` has converged to its value at ``s = 0``.

    ``L`` is evaluated ``LOW_FREQUENCY_CHUNK`` decades at a time.
    """
    omega = [start]
    for _ in range(40):
        omega.append(omega[-1] / 10)
    omega = np.array(omega)
    scaled = np.empty(0, dtype=complex)
    for k in range(40):
        if k + 1 >= scaled.size:
            chunk = omega[scaled.size : scaled.size + LOW_FREQUENCY_CHUNK + 1]
            scaled = np.concatenate([scaled, loop(chunk) * (1j * chunk) ** integrators])
        if abs(scaled[k] - scaled[k + 1]) <= 1e-3 * max(abs(scaled[k + 1]), 1e-300):
            return float(omega[k + 1])
    return float(omega[40])


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


def _bracketed_roots(fun: BracketFunction, a: np.ndarray, b: np.ndarray, fa: np.ndarray, fb: np.ndarray) -> np.ndarray:
    """Roots of ``fun`` in every bracket ``[a_j, b_j]`` (``fa_j fb_j < 0``), all at once.

    ``fun(x, j)`` is the function of bracket ``j[i]`` at ``x[i]`` (brackets may hold different
    functions).

    Chandrupatla's method (inverse quadratic interpolation safeguarded by bisection; Scherer,
    "Computational Physics", section 6.1.7), vectorized over the brackets: one call of ``fun``
    per iteration for every bracket still open.  A bracket is closed when it is narrower than
    ``2 (ROOT_XTOL + 2 eps |x|)``; the result is its end with the smaller ``|fun|``.
    """
    root = np.full(a.shape, np.nan)
    index = np.arange(a.size)  # the open brackets; the arrays below hold only those
    x1, x2, x3, f1, f2, f3 = b, a, a, fb, fa, fa
    t = np.full(a.shape, 0.5)
    for _ in range(MAX_ROOT_ITERATIONS):
        if index.size == 0:
            return root
        xt = x1 + t * (x2 - x1)
        ft = fun(xt, index)
        same = np.sign(ft) == np.sign(f1)
        x3, f3 = np.where(same, x1, x2), np.where(same, f1, f2)
        x2, f2 = np.where(same, x2, x1), np.where(same, f2, f1)
        x1, f1 = xt, ft
        best = np.abs(f1) < np.abs(f2)
        xm, fm = np.where(best, x1, x2), np.where(best, f1, f2)
        tl = (2 * np.finfo(float).eps * np.abs(xm) + ROOT_XTOL) / np.abs(x2 - x1)
        done = (tl > 0.5) | (fm == 0)
        root[index[done]] = xm[done]
        index, x1, x2, x3, f1, f2, f3, tl = (v[~done] for v in (index, x1, x2, x3, f1, f2, f3, tl))
        xi = (x1 - x2) / (x3 - x2)
        phi = (f1 - f2) / (f3 - f2)
        quadratic = (phi**2 < xi) & ((1 - phi) ** 2 < 1 - xi)
        with np.errstate(divide="ignore", invalid="ignore"):
            iqi = f1 / (f2 - f1) * f3 / (f2 - f3) + (x3 - x1) / (x2 - x1) * f1 / (f3 - f1) * f2 / (f3 - f2)
        t = np.clip(np.where(quadratic, iqi, 0.5), tl, 1 - tl)
    root[index] = np.where(np.abs(f1) < np.abs(f2), x1, x2)
    return root


def _crossovers(loop: LoopFunction, omega: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Gain crossovers ``|L| = 1`` and phase crossovers ``Im L = 0`` (of either sign of ``Re L``).

    Each is a grid point where ``log |L|`` (``Im L``) is exactly zero, or the root in log frequency
    between neighbours where it changes sign; all roots are found together
    (:func:`_bracketed_roots`, one evaluation of ``L`` per iteration).  Both are sorted.
    """
    log_magnitude, imaginary = np.log(np.abs(values)), values.imag
    brackets = [np.flatnonzero(f[:-1] * f[1:] < 0) for f in (log_magnitude, imaginary)]
    i = np.concatenate(brackets)
    samples = np.concatenate([log_magnitude, imaginary])
    offset = np.repeat([0, omega.size], [b.size for b in brackets])
    is_gain = np.arange(i.size) < brackets[0].size

    def fun(x: np.ndarray, j: np.ndarray) -> np.ndarray:
        at = loop(np.exp(x))
        with np.errstate(divide="ignore"):
            return np.where(is_gain[j], np.log(np.abs(at)), at.imag)

    roots = np.exp(_bracketed_roots(fun, np.log(omega[i]), np.log(omega[i + 1]), samples[offset + i], samples[offset + i + 1]))
    gains = np.sort(np.concatenate([omega[log_magnitude == 0], roots[is_gain]]))
    phase = np.sort(np.concatenate([omega[imaginary == 0], roots[~is_gain]]))
    return gains, phase


PEAK_MEASURES = (lambda L: 1 / np.abs(1 + L), lambda L: np.abs(L / (1 + L)))  # Ms, Mt


def _peaks(loop: LoopFunction, omega: np.ndarray, values: np.ndarray) -> list[tuple[float, float]]:
    """``(Ms, frequency)`` and ``(Mt, frequency)``: each grid maximum refined between its neighbours.

    Each interval (in log frequency) is sampled at ``PEAK_POINTS`` points and narrowed to the
    neighbours of the best one, until the samples are closer than ``PEAK_SPACING``; the vertex of
    the parabola through the best sample and its neighbours is evaluated last.  All intervals share
    the evaluations of ``L``.  The peak value is then exact to rounding (it is flat at the peak);
    its frequency is as accurate as the flatness of the peak allows (about ``sqrt(eps)`` relative).
    """
    best, intervals = [], []
    for measure in PEAK_MEASURES:
        samples = measure(values)
        i = int(np.argmax(samples))
        best.append((float(samples[i]), float(omega[i])))
        intervals.append((math.log(omega[max(i - 1, 0)]), math.log(omega[min(i + 1, omega.size - 1)])))
    active, vertices = [k for k, (lo, hi) in enumerate(intervals) if hi > lo], {}
    while active:
        x = np.concatenate([np.linspace(*intervals[k], PEAK_POINTS) for k in active])
        at = loop(np.exp(x))
        for n, k in enumerate(active):
            part = slice(n * PEAK_POINTS, (n + 1) * PEAK_POINTS)
            xs, samples = x[part], PEAK_MEASURES[k](at[part])
            j = int(np.argmax(samples))
            if samples[j] > best[k][0]:
                best[k] = (float(samples[j]), float(math.exp(xs[j])))
            if xs[1] - xs[0] <= PEAK_SPACING:
                vertices[k] = _vertex(xs, samples, j)
            intervals[k] = (xs[max(j - 1, 0)], xs[min(j + 1, PEAK_POINTS - 1)])
        active = [k for k in active if k not in vertices]
    keys = [k for k, x in vertices.items() if x is not None]
    if keys:
        at = loop(np.exp(np.array([vertices[k] for k in keys])))
        for n, k in enumerate(keys):
            value = float(PEAK_MEASURES[k](at[n : n + 1])[0])
            if value > best[k][0]:
                best[k] = (value, math.exp(vertices[k]))
    return best


def _vertex(x: np.ndarray, samples: np.ndarray, j: int) -> float | None:
    """Abscissa of the parabola's vertex through samples ``j - 1, j, j + 1`` (equally spaced), or
    None if ``j`` is at an end or the three are not concave."""
    if j == 0 or j == x.size - 1:
        return None
    left, middle, right = samples[j - 1], samples[j], samples[j + 1]
    curvature = left - 2 * middle + right
    if not curvature < 0:
        return None
    return float(x[j] + 0.5 * (x[1] - x[0]) * (left - right) / curvature)


def _winding(values: np.ndarray, integrators: int) -> int:
    change = float(np.sum(np.angle((1 + values[1:]) / (1 + values[:-1]))))
    return int(round((integrators * math.pi - 2 * change) / (2 * math.pi)))


def _gain_margin(phase_crossovers: np.ndarray, values: np.ndarray) -> tuple[float, float]:
    """The smallest factor ``1/|L| > 1`` over the phase crossovers, and its frequency."""
    factors = 1 / np.abs(values)
    up = np.flatnonzero(factors > 1)
    if up.size == 0:
        return math.inf, math.nan
    j = up[np.argmin(factors[up])]
    return float(factors[j]), float(phase_crossovers[j])


def _phase_and_delay_margins(
    gain_crossovers: np.ndarray, values: np.ndarray
) -> tuple[float, float, float, float, np.ndarray]:
    """Phase margin and delay margin over the gain crossovers, each with its frequency, and the
    phase margin of every crossover (rad).

    The phase margin of crossover ``i`` is ``phi_i = (arg L(i w_i) mod 2 pi) - pi``, in
    ``[-pi, pi)``, and the one reported is the smallest in magnitude (the first of ties): the
    definition of python-control's ``stability_margins`` (``control/margins.py``: ``PM =
    remainder(angle(L), 360) - 180``, then the index of ``min |PM|``; ``returnall=True`` lists every
    ``PM``) and of MATLAB's ``margin``.  The delay margin is ``min_i ((arg L(i w_i) + pi) mod 2 pi)
    / w_i``, the phase taken in ``[0, 2 pi)`` (Ingimundarson section 3).  ``inf``, ``nan`` and no
    margins without crossover.
    """
    if gain_crossovers.size == 0:
        return math.inf, math.nan, math.inf, math.nan, np.empty(0)
    angle = np.angle(values)
    phase_margins = (angle + 2 * math.pi) % (2 * math.pi) - math.pi
    delays = ((angle + math.pi) % (2 * math.pi)) / gain_crossovers
    i, j = int(np.argmin(np.abs(phase_margins))), int(np.argmin(delays))
    return float(phase_margins[i]), float(gain_crossovers[i]), float(delays[j]), float(gain_crossovers[j]), phase_margins


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

    gains, phase = _crossovers(loop, omega, values)
    at_crossovers = loop(np.concatenate([gains, phase]))
    at_gains, at_phase = at_crossovers[: gains.size], at_crossovers[gains.size :]
    phase, at_phase = phase[at_phase.real < 0], at_phase[at_phase.real < 0]
    (ms, ms_w), (mt, mt_w) = _peaks(loop, omega, values)
    return assemble_margins(
        unstable, tame, (ms, ms_w, mt, mt_w), _gain_margin(phase, at_phase), _phase_and_delay_margins(gains, at_gains), gains, phase
    )


def assemble_margins(
    unstable: int,
    tame: bool,
    peaks: tuple[float, float, float, float],
    gain_margin: tuple[float, float],
    phase_and_delay_margins: tuple[float, float, float, float],
    gains: np.ndarray,
    phase: np.ndarray,
) -> Margins:
    """The :class:`Margins` from the figures of :func:`loop_margins` (shared with
    :mod:`envs.analysis._robustness_kernels`): ``unstable`` from :func:`_winding`, ``tame`` from
    :func:`_high_frequency`, ``peaks = (Ms, its frequency, Mt, its frequency)``, the results of
    :func:`_gain_margin` and :func:`_phase_and_delay_margins`, the gain crossovers and the phase
    crossovers with ``Re L < 0``.  The delay margin of an unstable loop is 0."""
    stable = unstable == 0 and tame
    ms, ms_w, mt, mt_w = peaks
    gm, pc_w = gain_margin
    phase_margin, gc_w, delay_margin, dm_w, phase_margins = phase_and_delay_margins
    return Margins(
        stable=bool(stable),
        unstable_poles=max(int(unstable), 0) if tame else -1,
        ms=float(ms),
        ms_frequency=float(ms_w),
        mt=float(mt),
        mt_frequency=float(mt_w),
        gain_margin=float(gm),
        phase_crossover_frequency=float(pc_w),
        phase_margin_deg=math.degrees(phase_margin) if math.isfinite(phase_margin) else math.inf,
        gain_crossover_frequency=float(gc_w),
        delay_margin=float(delay_margin) if stable else 0.0,
        delay_margin_frequency=float(dm_w),
        gain_crossovers=tuple(gains.tolist()),
        phase_crossovers=tuple(phase.tolist()),
        phase_margins_deg=tuple(np.degrees(phase_margins).tolist()),
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
