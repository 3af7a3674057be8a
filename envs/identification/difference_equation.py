"""The sampled FOPDT and SOPDT models as difference equations (ARX), fitted for one dead time.

Marlin's statistical model identification (*Process Control*, 2nd ed., section 6.4, eq. 6.7-6.17)
writes the first-order-with-dead-time model sampled with a zero-order hold as the difference
equation (eq. 6.8-6.9)::

    Y'_{i+1} = a Y'_i + b X'_{i-Gamma},   a = e^{-dt/tau},   b = K_p (1 - a),

with ``Gamma = theta/dt`` the dead time in whole samples, fits ``a`` and ``b`` by linear least squares
for a given ``Gamma`` (eq. 6.16-6.17: ``[a, b] = (U^T U)^{-1} U^T z``).  Back:
``K_p = b/(1 - a)``, ``tau = -dt/ln a`` and ``theta = Gamma dt`` (Example 6.5: ``theta = 9 (0.333) =
3 min``, ``tau = 0.333/0.0431 = 7.7 min``, ``K_p = 0.1143/(1 - 0.9578) = 2.7``).  With the input held
over each sample and a dead time of whole samples the difference equation is exact, so
``theta = Gamma dt`` (no half-sample correction).  "Other models could be derived in the same
manner" (section 6.4, Model Structure): the SOPDT model is the exact zero-order-hold form of
``K e^{-theta s}/((T_1 s + 1)(T_2 s + 1))``::

    y_{i+1} = a_1 y_i + a_2 y_{i-1} + b_1 u_{i-Gamma} + b_2 u_{i-Gamma-1},

whose poles ``p_j`` (roots of ``z^2 - a_1 z - a_2``) give ``T_j = -dt/ln p_j`` and whose gain is
``K = (b_1 + b_2)/(1 - a_1 - a_2)``.

For one ``Gamma``: :func:`arx_regression` (Marlin's least squares, eq. 6.16-6.17) and
:func:`instrumental_variables` (the simplified refined instrumental-variable estimator, SRIV);
:func:`arx_response` simulates the equation, :func:`fopdt_from_arx` and :func:`sopdt_from_arx`
go back to the continuous models.  The search over ``Gamma`` and the choice between the
estimators are :func:`~envs.identification.least_squares.least_squares_fit`'s.

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
from scipy.signal import lfilter

from envs.identification.models import FOPDTModel, SOPDTModel

__all__ = [
    "ARXFit",
    "arx_regression",
    "instrumental_variables",
    "fopdt_from_arx",
    "sopdt_from_arx",
    "arx_response",
]


MAX_ITERATIONS = 6
"""Iterations of the instrumental-variable estimator at most, each stopping at a relative change of
the coefficients below ``ITERATION_TOLERANCE``.  On a noisy step record the estimate after 3
iterations equals the converged one to about 1e-8 relative, far below its noise error (1e-3)."""
ITERATION_TOLERANCE = 1e-7


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
