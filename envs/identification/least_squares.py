"""Least-squares identification of FOPDT and SOPDT models from any sampled record (Marlin 6.4).

Marlin's statistical model identification (*Process Control*, 2nd ed., section 6.4, eq. 6.7-6.17)
writes the first-order-with-dead-time model sampled with a zero-order hold as the difference
equation (eq. 6.8-6.9)::

    Y'_{i+1} = a Y'_i + b X'_{i-Gamma},   a = e^{-dt/tau},   b = K_p (1 - a),

with ``Gamma = theta/dt`` the dead time in whole samples, fits ``a`` and ``b`` by linear least squares
for a given ``Gamma`` (eq. 6.16-6.17: ``[a, b] = (U^T U)^{-1} U^T z``), and chooses ``Gamma`` as the
value of smallest residual sum of squares divided by its degrees of freedom (the text after
eq. 6.17), searching every ``Gamma`` of a range because the criterion need not be monotone.  Back:
``K_p = b/(1 - a)``, ``tau = -dt/ln a`` and ``theta = Gamma dt`` (Example 6.5: ``theta = 9 (0.333) =
3 min``, ``tau = 0.333/0.0431 = 7.7 min``, ``K_p = 0.1143/(1 - 0.9578) = 2.7``).  With the input held
over each sample and a dead time of whole samples the difference equation is exact, so
``theta = Gamma dt`` (no half-sample correction).  "Other models could be derived in the same
manner" (section 6.4, Model Structure): the SOPDT model is the exact zero-order-hold form of
``K e^{-theta s}/((T_1 s + 1)(T_2 s + 1))``::

    y_{i+1} = a_1 y_i + a_2 y_{i-1} + b_1 u_{i-Gamma} + b_2 u_{i-Gamma-1},

whose poles ``p_j`` (roots of ``z^2 - a_1 z - a_2``) give ``T_j = -dt/ln p_j`` and whose gain is
``K = (b_1 + b_2)/(1 - a_1 - a_2)``.  The input need not be a step (a PRBS, a relay's record, any
piecewise-constant input), and the record need not reach steady state (section 6.4, action 2).

Two estimators of the coefficients for each ``Gamma`` (``method``):

* ``"least-squares"``: Marlin's regression on the measured data (eq. 6.17), ``Gamma`` by the
  smallest residual variance of the equation (eq. 6.11 over the degrees of freedom).  With
  measurement noise the regressor ``Y'_i`` is noisy and the estimate is biased ("errors in
  variables"; Marlin lists "the input variable is known without error" and independent errors
  among the assumptions of the method), and the bias grows as the sampling gets finer, because
  ``1 - a`` shrinks like ``dt/tau``: measured on ``e^{-0.5 s}/(s + 1)`` stepped by a unit output
  change, sampled at ``T_ar/200`` (the experiments' default), 1% noise makes ``tau`` 25% too small.
* ``"instrumental-variables"`` (default): the simplified refined instrumental-variable estimator
  (SRIV; Young 2011, ch. 7; Soderstrom and Stoica 1989, ch. 8), still one linear regression per
  iteration: the regressor ``y_i`` is replaced in the instruments by the noise-free output ``x_i``
  of the model of the previous iteration (so the instruments are uncorrelated with the noise and
  the estimate is consistent), and every signal is prefiltered by ``(1 - a_1 - ..)/A(q)`` of that
  model (which makes the equation error white for white measurement noise, and the estimate
  nearly as precise as an output-error fit).  Starts from the least-squares estimate; ``Gamma``
  is chosen by the smallest simulation error ``sum (y_i - x_i)^2`` of the fitted model (the
  output-error criterion, which reads the whole response and not only the samples where the
  delayed input switches), found by alternating between the model for a ``Gamma`` and the best
  ``Gamma`` for that model (:func:`_search`); the dead time is refined below one sample by the vertex of the parabola through the
  criterion at ``Gamma - 1, Gamma, Gamma + 1``, and the coefficients are fitted again with the
  input delayed by that fraction of a sample (linear interpolation between samples).  Measured
  on ``2.5 e^{-4s}/(12 s + 1)`` stepped by a unit output change, sampled at ``T_ar/200``, 1% noise,
  400 seeds: errors of ``K``, ``tau``, ``theta`` with standard deviations 0.05%, 0.30%, 0.53%
  (largest 0.15%, 0.84%, 1.6%), and differences to a continuous-time output-error fit by
  ``scipy.optimize.least_squares`` on the same records with standard deviations 0.001%, 0.011%,
  0.028% (the tests).

Conventions: ``control`` and ``output`` are deviation variables sampled every ``sample_time``,
zero before the record starts (the plant at rest at its operating point, as every experiment of
:mod:`envs.identification.experiments` starts), so every ``Gamma`` is fitted on the same rows
``i = 0 .. n-2`` (Marlin's table 6.2 starts with such a baseline); ``control[i]`` is held over
``[i dt, (i+1) dt)``.

References
----------
.. [MA] T. Marlin, "Process Control", 2nd ed., McGraw-Hill 2000, section 6.4, eq. 6.7-6.17,
   Example 6.5.
.. [YO] P. C. Young, "Recursive Estimation and Time-Series Analysis", 2nd ed., Springer 2011,
   ch. 7 (the refined and simplified refined instrumental variable methods, RIV and SRIV).
.. [SS] T. Soderstrom, P. Stoica, "System Identification", Prentice Hall 1989, ch. 8
   (instrumental variable methods).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.signal import correlate, lfilter

from envs.identification.models import FOPDTModel, SOPDTModel
from envs.validation import require_number

__all__ = [
    "METHODS",
    "ARXFit",
    "LeastSquaresFit",
    "arx_regression",
    "instrumental_variables",
    "least_squares_fit",
    "fopdt_from_arx",
    "sopdt_from_arx",
    "arx_response",
]

METHODS: tuple[str, ...] = ("instrumental-variables", "least-squares")
MAX_ITERATIONS = 6
"""Iterations of the instrumental-variable estimator at most, each stopping at a relative change of
the coefficients below ``ITERATION_TOLERANCE``.  On a noisy step record the estimate after 3
iterations equals the converged one to about 1e-8 relative, far below its noise error (1e-3)."""
ITERATION_TOLERANCE = 1e-7
COARSE_POINTS = 12
"""The search over ``Gamma`` starts from the best of about this many evenly spaced values by Marlin's
criterion (and fits all of them if a fit fails)."""
MAX_ROUNDS = 10
"""Rounds of the alternating search over ``Gamma`` at most (it repeats after 2 to 4 on the experiments' records)."""
MAX_FITS = 60
"""The search's budget: its local descent stops once this many dead times are fitted, and the best
of them is the result.  The environments' searches fit 13 to 27 (FPPI and PID ``-v3`` with
``identification="least-squares"``, fixed, plan and agent modes, 1% and 10% noise, 16 seeds each),
so the budget changes none of them; on a record whose criterion keeps falling over thousands of dead
times (an open-loop step that never settled under a load) the descent would fit one ``Gamma`` at a
time, for minutes.  A fit
reads at most :data:`~envs.simulation.delay_systems.MAX_RUN_SAMPLES` samples, so a search is
bounded too (about 60 fits of 0.1-0.5 s on the longest record)."""


@dataclass(frozen=True)
class ARXFit:
    """The regression for one dead time ``Gamma`` (one row of Marlin's table in Example 6.5).

    Attributes
    ----------
    delay : int
        ``Gamma``, the dead time in samples.
    coefficients : tuple of float
        ``(a, b)`` for order 1, ``(a_1, a_2, b_1, b_2)`` for order 2.
    residual_sum : float
        ``sum e_i^2``: of the equation error (eq. 6.11) for ``"least-squares"``, of the simulation
        error ``y_i - x_i`` for ``"instrumental-variables"``; ``inf`` where the fit failed (an
        unstable or singular model).
    degrees_of_freedom : int
        Data points minus parameters fitted.
    """

    delay: int
    coefficients: tuple[float, ...]
    residual_sum: float
    degrees_of_freedom: int

    @property
    def residual_variance(self) -> float:
        """``residual_sum/degrees_of_freedom``, Marlin's criterion for ``Gamma``."""
        return self.residual_sum / self.degrees_of_freedom


@dataclass(frozen=True)
class LeastSquaresFit:
    """A model fitted by :func:`least_squares_fit`.

    Attributes
    ----------
    order : int
        1 (FOPDT) or 2 (SOPDT).
    method : str
        One of :data:`METHODS`.
    sample_time : float
        ``dt`` of the record.
    delay : int
        ``Gamma`` chosen, in samples.
    dead_time : float
        ``theta``: ``Gamma dt`` (``"least-squares"``, Marlin), or ``(Gamma + delta) dt`` with the
        sub-sample ``delta`` in ``[-1/2, 1/2]`` (``"instrumental-variables"``).
    coefficients : tuple of float
        The difference equation's coefficients of the model: at ``Gamma`` (``"least-squares"``), or
        at the sub-sample dead time, the input interpolated (``"instrumental-variables"``).
    model : FOPDTModel, SOPDTModel or None
        The continuous model; None if the coefficients have no such model (a pole outside
        ``(0, 1)``, complex poles for order 2, a zero gain).
    residual_variance : float
        The criterion at ``Gamma`` (see :class:`ARXFit`).
    noise_std : float
        Standard deviation of the simulation error ``y_i - x_i`` of the model at ``Gamma`` (the
        measurement noise, if the model fits).
    candidates : tuple of ARXFit
        Every ``Gamma`` evaluated, in increasing order (Marlin's table in Example 6.5).
    """

    order: int
    method: str
    sample_time: float
    delay: int
    dead_time: float
    coefficients: tuple[float, ...]
    model: FOPDTModel | SOPDTModel | None
    residual_variance: float
    noise_std: float
    candidates: tuple[ARXFit, ...]

    @property
    def fopdt(self) -> FOPDTModel | None:
        """The model as an FOPDT model: itself (order 1), else None."""
        return self.model if isinstance(self.model, FOPDTModel) else None


# --------------------------------------------------------------------------- the regression
def _regressors(control: np.ndarray, output: np.ndarray, delay: int, order: int) -> tuple[np.ndarray, np.ndarray]:
    """``(U, z)`` of eq. 6.16 over the rows ``i = 0 .. n-2``: columns ``y_i .. y_{i-order+1}``, then
    ``u_{i-Gamma} .. u_{i-Gamma-order+1}``; ``z = y_{i+1}``; signals are zero before the record."""
    rows = output.size - 1
    U = np.zeros((rows, 2 * order))
    for k in range(order):
        U[k:, k] = output[: rows - k]
        shift = delay + k
        if shift < rows:
            U[shift:, order + k] = control[: rows - shift]
    return U, output[1:]


def arx_response(coefficients, control: np.ndarray, delay: int, size: int | None = None) -> np.ndarray:
    """The noise-free output ``x`` of the difference equation from rest for the input ``control``.

    ``x_{i+1} = a_1 x_i + .. + a_p x_{i-p+1} + b_1 u_{i-Gamma} + .. + b_p u_{i-Gamma-p+1}``, ``x_0 = 0``
    (``p = len(coefficients)/2``), at the ``size`` samples of the record (default ``control.size``).
    """
    c = np.asarray(coefficients, dtype=float)
    order = c.size // 2
    u = np.asarray(control, dtype=float)
    size = u.size if size is None else int(size)
    delayed = np.concatenate([np.zeros(delay), u])[:size]
    return lfilter(np.concatenate([[0.0], c[order:]]), np.concatenate([[1.0], -c[:order]]), delayed)


def arx_regression(control: np.ndarray, output: np.ndarray, delay: int, order: int = 1) -> ARXFit:
    """Marlin's least-squares fit of the difference equation for the dead time ``delay`` samples.

    Solves eq. 6.16-6.17, ``[a, b] = (U^T U)^{-1} U^T z`` (by ``numpy.linalg.lstsq``, the same
    solution computed stably); the residual is the equation error of eq. 6.11.
    """
    U, z = _regressors(control, output, delay, order)
    coefficients, *_ = np.linalg.lstsq(U, z, rcond=None)
    residual = z - U @ coefficients
    return ARXFit(delay, tuple(float(c) for c in coefficients), float(residual @ residual), z.size - U.shape[1])


def _stable_filter(coefficients: np.ndarray, order: int) -> np.ndarray | None:
    """``A(q) = 1 - a_1 q^-1 - ..``, if its roots are inside the unit circle and its DC gain is positive."""
    denominator = np.concatenate([[1.0], -coefficients[:order]])
    if not np.all(np.isfinite(denominator)) or denominator.sum() <= 0.0:
        return None
    if order > 1 and not np.all(np.abs(np.roots(denominator)) < 1.0):
        return None
    if order == 1 and not abs(denominator[1]) < 1.0:
        return None
    return denominator


def instrumental_variables(control: np.ndarray, output: np.ndarray, delay: int, order: int = 1) -> ARXFit:
    """The simplified refined instrumental-variable fit (SRIV) for the dead time ``delay`` samples.

    From the least-squares estimate (order 2: from the first-order fit with a second lag of a
    quarter of its time constant, see :func:`_second_order_start`), each iteration simulates the model's noise-free output ``x``
    (:func:`arx_response`), prefilters ``u``, ``y`` and ``x`` by ``A(1)/A(q)`` of that model and solves
    ``Z_f^T U_f c = Z_f^T z_f``, with ``U_f`` the regressors of the filtered data and ``Z_f`` the
    same with ``x`` in place of ``y`` (Young 2011, ch. 7).  The residual is the simulation error
    ``sum (y_i - x_i)^2`` of the final model; ``inf`` if a model is unstable (its ``A`` has a root
    outside the unit circle, or ``A(1) <= 0``) or the equations are singular.
    """
    u, y = np.asarray(control, dtype=float), np.asarray(output, dtype=float)
    start = arx_regression(u, y, delay, order)
    c = np.array(start.coefficients)
    if order == 2:
        c = _second_order_start(u, y, delay, c)
    failed = ARXFit(delay, tuple(float(v) for v in c), math.inf, start.degrees_of_freedom)
    for _ in range(MAX_ITERATIONS):
        denominator = _stable_filter(c, order)
        if denominator is None:
            return failed
        x = arx_response(c, u, delay, y.size)
        numerator = [denominator.sum()]
        uf, yf, xf = (lfilter(numerator, denominator, s) for s in (u, y, x))
        U, z = _regressors(uf, yf, delay, order)
        Z, _ = _regressors(uf, xf, delay, order)
        try:
            updated = np.linalg.solve(Z.T @ U, Z.T @ z)
        except np.linalg.LinAlgError:
            return failed
        change = np.max(np.abs(updated - c)) / max(np.max(np.abs(updated)), 1e-300)
        c = updated
        if not change > ITERATION_TOLERANCE:
            break
    if _stable_filter(c, order) is None:
        return ARXFit(delay, tuple(float(v) for v in c), math.inf, start.degrees_of_freedom)
    error = y - arx_response(c, u, delay, y.size)
    return ARXFit(delay, tuple(float(v) for v in c), float(error @ error), y.size - 2 * order)


def _second_order_start(u: np.ndarray, y: np.ndarray, delay: int, regression: np.ndarray) -> np.ndarray:
    """The start of the second-order iteration: the first-order instrumental-variable model ``(a, b)``
    with a second pole ``p = a^4`` (a lag of a quarter of its time constant) and the same gain,
    ``A = (1 - a q^-1)(1 - p q^-1)``, ``B = b (1 - p)``; the least-squares ``regression`` if that fit
    fails.  (With noise at fine sampling the second-order least-squares estimate is often unstable
    or oscillating, and the iteration cannot start from it.)"""
    first = instrumental_variables(u, y, delay, 1)
    if not math.isfinite(first.residual_sum):
        return regression
    a, b = first.coefficients
    p = a**4
    return np.array([a + p, -a * p, b * (1.0 - p), 0.0])


# --------------------------------------------------------------------------- back to the models
def fopdt_from_arx(a: float, b: float, sample_time: float, dead_time: float) -> FOPDTModel | None:
    """``K_p = b/(1 - a)``, ``tau = -dt/ln a`` (Marlin Example 6.5); None unless ``0 < a < 1`` and ``b != 0``."""
    if not (0.0 < a < 1.0) or b == 0.0 or not math.isfinite(b):
        return None
    return FOPDTModel(gain=b / (1.0 - a), time_constant=-sample_time / math.log(a), dead_time=max(dead_time, 0.0))


def sopdt_from_arx(coefficients, sample_time: float, dead_time: float) -> SOPDTModel | None:
    """The SOPDT model of ``(a_1, a_2, b_1, b_2)``: poles ``p_j`` of ``z^2 - a_1 z - a_2``,
    ``T_j = -dt/ln p_j`` (larger first), ``K = (b_1 + b_2)/(1 - a_1 - a_2)``.

    None unless both poles are real and in ``(0, 1)`` (a real pole at 0, or in ``(-1, 0)``, has no
    continuous counterpart; complex poles are an underdamped pair, not an SOPDT model of two lags)
    and the gain is finite and non-zero.
    """
    a1, a2, b1, b2 = (float(v) for v in coefficients)
    discriminant = a1 * a1 + 4.0 * a2
    if discriminant < 0.0 or not (1.0 - a1 - a2) > 0.0:
        return None
    root = math.sqrt(discriminant)
    poles = sorted(((a1 + root) / 2.0, (a1 - root) / 2.0), reverse=True)
    if not all(0.0 < p < 1.0 for p in poles):
        return None
    gain = (b1 + b2) / (1.0 - a1 - a2)
    if gain == 0.0 or not math.isfinite(gain):
        return None
    lags = tuple(-sample_time / math.log(p) for p in poles)
    return SOPDTModel(gain=gain, time_constants=lags, dead_time=max(dead_time, 0.0))


# --------------------------------------------------------------------------- the search over Gamma
def _delays(delays, size: int) -> np.ndarray:
    if delays is None:
        return np.arange(0, max(size // 2, 1))
    values = np.asarray(delays)
    if values.ndim != 1 or values.size == 0 or not np.issubdtype(values.dtype, np.integer):
        raise ValueError(f"delays must be a non-empty sequence of integers, got {delays!r}")
    if values.min() < 0 or values.max() > size - 3:
        raise ValueError(f"delays must lie in [0, {size - 3}] samples for a record of {size}, got {values.min()} .. {values.max()}")
    return np.unique(values)


def _delay_profile(coefficients, control: np.ndarray, output: np.ndarray, candidates: np.ndarray) -> np.ndarray:
    """``sum_i (y_i - x_i)^2`` for every dead time of ``candidates``, the coefficients fixed: ``x`` is the
    model's response without dead time shifted by ``Gamma``, so that the sum is
    ``sum y^2 - 2 sum_{i >= Gamma} y_i x_{i-Gamma} + sum_{j < n-Gamma} x_j^2`` (one correlation)."""
    n = output.size
    response = arx_response(coefficients, control, 0, n)
    cross = correlate(output, response, mode="full")[n - 1 + candidates]  # sum_j y[j + Gamma] x[j]
    energy = np.cumsum(response**2)[n - 1 - candidates]
    return output @ output - 2.0 * cross + energy


def _search(u: np.ndarray, y: np.ndarray, order: int, candidates: np.ndarray, exhaustive: bool) -> dict[int, ARXFit]:
    """The instrumental-variable fits visited in the search for the dead time of smallest simulation error.

    Exhaustive: every candidate.  Else alternating, from the dead time of Marlin's least-squares
    criterion on a grid of about :data:`COARSE_POINTS` values: the model for the current ``Gamma``
    (:func:`instrumental_variables`), then the ``Gamma`` of smallest simulation error of that model
    over every candidate (:func:`_delay_profile`), until it repeats; then the neighbours of the best
    fit until neither is better (a local descent on the criterion of the refitted models), within
    the budget of :data:`MAX_FITS` fits.  If a fit fails (an unstable model), every candidate of the
    grid is fitted instead.
    """
    fits: dict[int, ARXFit] = {}

    def fit(g: int) -> ARXFit:
        if g not in fits:
            fits[g] = instrumental_variables(u, y, g, order)
        return fits[g]

    if exhaustive or candidates.size <= 3:
        for g in candidates:
            fit(int(g))
        return fits
    grid = candidates[:: int(math.ceil(candidates.size / COARSE_POINTS))]
    current = min((fit(int(g)) for g in grid), key=lambda f: (f.residual_variance, f.delay)).delay
    for _ in range(MAX_ROUNDS):
        found = fit(current)
        if not math.isfinite(found.residual_sum):
            break
        following = int(candidates[int(np.argmin(_delay_profile(found.coefficients, u, y, candidates)))])
        if following in fits:
            break
        current = following
    allowed = set(candidates.tolist())
    while len(fits) < MAX_FITS:
        best = min(fits.values(), key=lambda f: (f.residual_variance, f.delay))
        for g in (best.delay - 1, best.delay + 1):
            if g in allowed:
                fit(g)
        if min(fits.values(), key=lambda f: (f.residual_variance, f.delay)) is best:
            return fits
    return fits


def _sub_sample(fits: dict[int, ARXFit], best: int) -> float:
    """Vertex of the parabola through the criterion at ``best - 1, best, best + 1`` (0 if missing)."""
    neighbours = [fits.get(best + k) for k in (-1, 0, 1)]
    if any(f is None or not math.isfinite(f.residual_sum) for f in neighbours):
        return 0.0
    low, middle, high = (f.residual_sum for f in neighbours)
    curvature = low - 2.0 * middle + high
    if not curvature > 0.0:
        return 0.0
    return min(max(0.5 * (low - high) / curvature, -0.5), 0.5)


def _interpolated(control: np.ndarray, samples: float) -> np.ndarray:
    """The input delayed by the fraction ``f`` of ``samples`` beyond its whole samples, linearly:
    ``(1 - f) u_k + f u_{k-1}`` (the whole samples are the regression's ``Gamma``)."""
    fraction = samples - math.floor(samples)
    return (1.0 - fraction) * control + fraction * np.concatenate([[0.0], control[:-1]])


def _at_sub_sample_delay(u, y, order: int, best: ARXFit, delta: float, dt: float) -> tuple[ARXFit, float]:
    """The fit at the dead time ``(Gamma + delta) dt``: the input delayed by ``floor(Gamma + delta)``
    whole samples and the rest by :func:`_interpolated`, refitted (the coefficients at ``Gamma`` would
    absorb the missing fraction of a sample into the time constant: 2.7% of ``tau`` for half a sample
    at ``dt = tau/20``, noise free).  Kept only if its simulation error is not larger."""
    samples = best.delay + delta
    whole = math.floor(samples)
    if samples == whole or whole < 0:
        return best, best.delay * dt
    refit = instrumental_variables(_interpolated(u, samples), y, whole, order)
    if not refit.residual_sum <= best.residual_sum:
        return best, best.delay * dt
    return refit, samples * dt


def _check_record(control, output, sample_time: float) -> tuple[np.ndarray, np.ndarray, float]:
    u = np.asarray(control, dtype=float).ravel()
    y = np.asarray(output, dtype=float).ravel()
    if u.shape != y.shape:
        raise ValueError(f"control and output must have the same length, got {u.size} and {y.size}")
    if y.size < 8:
        raise ValueError(f"the record must hold at least 8 samples, got {y.size}")
    if not (np.isfinite(u).all() and np.isfinite(y).all()):
        raise ValueError("control and output must be finite")
    if not np.any(u):
        raise ValueError("control must not be zero throughout (the record has no excitation)")
    return u, y, require_number(sample_time, "sample_time", positive=True)


def least_squares_fit(
    control: np.ndarray,
    output: np.ndarray,
    sample_time: float,
    *,
    order: int = 1,
    delays=None,
    method: str = "instrumental-variables",
    exhaustive: bool = False,
) -> LeastSquaresFit:
    """Fit an FOPDT (``order=1``) or SOPDT (``order=2``) model to a sampled record (Marlin 6.4).

    Parameters
    ----------
    control, output : array_like
        Input ``u`` and measured output ``y`` in deviation variables, one value per sample, zero
        before the record (module docstring); any input shape (step, PRBS, relay).
    sample_time : float
        ``dt > 0``.
    order : {1, 2}
    delays : sequence of int, optional
        The dead times ``Gamma`` (in samples) to search; default ``0 .. n/2 - 1``.
    method : {"instrumental-variables", "least-squares"}
        See the module docstring.  ``"least-squares"`` is Marlin's method exactly: every ``Gamma`` of
        ``delays``, the smallest equation-error variance, ``theta = Gamma dt``.
    exhaustive : bool
        ``"instrumental-variables"`` only: fit every ``Gamma`` of ``delays`` instead of the
        alternating search (:func:`_search`); ``candidates`` then holds them all.

    Returns
    -------
    LeastSquaresFit

    Raises
    ------
    ValueError
        For an unknown ``method`` or ``order``, a record too short, non-finite or without
        excitation, or ``delays`` out of range.

    Examples
    --------
    Marlin's Example 6.5 (the stirred tank ``2.7 e^{-3s}/(7.7 s + 1)``, sampled at 0.333 min):

    >>> import numpy as np
    >>> from envs.systems.plants import Plant
    >>> from envs.simulation.delay_systems import open_loop_response
    >>> plant = Plant(num=(2.7,), den=(7.7, 1.0), dead_time=3.0)
    >>> u = np.full(150, 5.0)
    >>> y = open_loop_response(plant.state_space(), plant.dead_time, u, 0.333)
    >>> fit = least_squares_fit(u, y, 0.333, method="least-squares", delays=range(6, 12))
    >>> fit.delay, round(fit.coefficients[1], 4), round(fit.model.gain, 1), round(fit.model.time_constant, 1)
    (9, 0.1142, 2.7, 7.7)
    """
    if method not in METHODS:
        raise ValueError(f"method must be one of {', '.join(METHODS)}, got {method!r}")
    if order not in (1, 2) or isinstance(order, bool):
        raise ValueError(f"order must be 1 or 2, got {order!r}")
    u, y, dt = _check_record(control, output, sample_time)
    candidates = _delays(delays, y.size)
    if method == "least-squares":
        fits = {int(g): arx_regression(u, y, int(g), order) for g in candidates}
    else:
        fits = _search(u, y, order, candidates, exhaustive)
    best = min(fits.values(), key=lambda f: (f.residual_variance, f.delay))
    final, dead_time = best, best.delay * dt
    if method == "instrumental-variables":
        final, dead_time = _at_sub_sample_delay(u, y, order, best, _sub_sample(fits, best.delay), dt)
    c = final.coefficients
    model = fopdt_from_arx(c[0], c[1], dt, dead_time) if order == 1 else sopdt_from_arx(c, dt, dead_time)
    error = y - arx_response(c, u if final is best else _interpolated(u, dead_time / dt), final.delay, y.size)
    return LeastSquaresFit(
        order=order, method=method, sample_time=dt, delay=best.delay, dead_time=dead_time, coefficients=c,
        model=model, residual_variance=best.residual_variance, noise_std=float(np.std(error)),
        candidates=tuple(fits[g] for g in sorted(fits)),
    )  # fmt: skip
