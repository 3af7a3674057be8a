"""The loop transfer ``L(s) = P(s) C_fb(s)`` as a ratio of quasi-polynomials.

Every plant and feedback controller of deadtime-gym gives a loop transfer of the form::

    L(s) = sum_i a_i(s) e^{-alpha_i s} / sum_j b_j(s) e^{-beta_j s}

with polynomials ``a_i``, ``b_j`` and dead times ``alpha_i, beta_j >= 0``.  The plant is
``num_p(s) e^{-L s}/den_p(s)``; the controllers' feedback parts ``C_fb`` are, multiplied through
(symbols as in :mod:`envs.systems.controllers`):

* :class:`~envs.systems.controllers.PID`, :class:`~envs.systems.controllers.SeriesPID`: ``num_c(s)/den_c(s)``
  (the coefficients of their ``transfer_function``).
* :class:`~envs.systems.controllers.FPPI` (Ingimundarson section 4, eq. 13-16):
  ``C F/(1 + C G_n (1 - F e^{-L_n s}))`` with ``C = K (T_n s + 1)/(T_n s)``,
  ``G_n = K_n/(T_n s + 1)``, ``F = 1/(T_f s + 1)``; multiplied through by ``T_n s (T_f s + 1)``::

      C_fb = K (T_n s + 1) / [T_n s (T_f s + 1) + K K_n (T_f s + 1) - K K_n e^{-L_n s}].

* :class:`~envs.systems.controllers.MSP` (Ingimundarson section 5, eq. 35-38 and 51):
  ``F + K_r (1 + F P_n)/(1 + K_r G_n (1 - e^{-L_n s}))`` with ``G_n = K_n/s``,
  ``P_n = G_n e^{-L_n s}``, ``K_r = 1/(K_n T_r)``; multiplied through by
  ``K_n (T_r s + 1 - e^{-L_n s})``::

      C_fb = [F K_n (T_r s + 1) + s] / [K_n (T_r s + 1 - e^{-L_n s})],

  with ``F = K_0`` (eq. 36) or ``F = K_0 (T_d s + 1)/(T_d s/10 + 1)`` (eq. 51), whose
  denominator then multiplies both sides.

The integral actions of FPPI and MSP are roots at ``s = 0`` of the denominators above, not
factored out.  Near ``s = 0`` such a side is a difference of nearly equal terms; evaluated as
written (and as :func:`envs.simulation.loops.loop_response` does) it loses ``log10(1/(omega T))`` digits.
The compiled evaluation (:func:`envs.analysis._robustness_kernels.transfer_at`) writes each side as
``(sum_i a_i)(s) + sum_i a_i(s) (e^{-alpha_i s} - 1)``: the polynomial ``sum_i a_i`` is evaluated
from the summed coefficients (its root at the origin is then exact) and
``e^{-i x} - 1 = -2 sin(x/2)^2 - 2 i sin(x/2) cos(x/2)`` has no cancellation, so the value is
accurate to rounding at every frequency.

Coefficients are tuples of floats and the products are formed in Python loops (cheaper for the few
coefficients of a loop than ``numpy.polymul``, which builds ``poly1d`` objects).  For that reason the PID coefficients are formed here with the arithmetic of
the controllers' ``transfer_function`` (the tests check that they are equal).

The scoring's hot path takes the loop packed into one array (:func:`loop_packed`), which compiled
kernels form directly from the plant's coefficients and the controller's parameters (about three
times faster than :class:`QuasiRational` and :func:`packed`, measured when they were written).  They repeat the arithmetic of
the Python functions here operation by operation, in the same order, so the array is the same bit
for bit; the Python functions stay as the readable reference (and serve :func:`loop_transfer`).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np

from envs.analysis._loop_transfer_kernels import _FPPI, _MSP, _PID, _packed_loop
from envs.systems.controllers import FPPI, MSP, PID, Controller, SeriesPID
from envs.systems.plants import Plant

__all__ = ["QuasiRational", "feedback_transfer", "loop_packed", "loop_transfer", "packed"]

Polynomial = tuple[float, ...]  # coefficients in descending powers of s
Terms = tuple[tuple[Polynomial, float], ...]  # (a_i, alpha_i): sum_i a_i(s) e^{-alpha_i s}


def _multiply(a: Polynomial, b: Polynomial) -> Polynomial:
    """The product of two polynomials (``numpy.polymul``)."""
    product = [0.0] * (len(a) + len(b) - 1)
    for i, x in enumerate(a):
        for j, y in enumerate(b, i):
            product[j] += x * y
    return tuple(product)


def _add(a: Polynomial, b: Polynomial) -> Polynomial:
    """The sum of two polynomials (``numpy.polyadd``)."""
    if len(a) < len(b):
        a, b = b, a
    pad = len(a) - len(b)
    return a[:pad] + tuple(x + y for x, y in zip(a[pad:], b))


def _scale(factor: float, a: Polynomial) -> Polynomial:
    return tuple(factor * x for x in a)


def _rows(terms: Terms) -> tuple[np.ndarray, np.ndarray]:
    """One side as :func:`envs.analysis._robustness_kernels.transfer_at` takes it: the coefficient rows, padded with leading zeros to
    one width, and the dead times."""
    width = max(len(coefficients) for coefficients, _ in terms)
    rows = [(0.0,) * (width - len(coefficients)) + coefficients for coefficients, _ in terms]
    return np.array(rows, dtype=float), np.array([delay for _, delay in terms], dtype=float)


def packed(numerator: Terms, denominator: Terms) -> tuple[np.ndarray, tuple[int, int, int, int]]:
    """Both sides in one flat array, as :func:`envs.analysis._robustness_kernels.packed_margins` takes them:
    the rows of :func:`_rows` of the numerator, its dead times, then those of the denominator; and
    the shapes ``(numerator rows, width, denominator rows, width)``.  One array of Python floats
    built at once: each ``numpy.array`` call costs about a microsecond."""
    flat: list[float] = []
    shape: list[int] = []
    for terms in (numerator, denominator):
        width = max(len(coefficients) for coefficients, _ in terms)
        for coefficients, _ in terms:
            flat.extend((0.0,) * (width - len(coefficients)))
            flat.extend(coefficients)
        flat.extend(delay for _, delay in terms)
        shape += (len(terms), width)
    return np.array(flat, dtype=float), (shape[0], shape[1], shape[2], shape[3])


@dataclass(frozen=True)
class QuasiRational:
    """``sum_i a_i(s) e^{-alpha_i s} / sum_j b_j(s) e^{-beta_j s}``.

    Attributes
    ----------
    numerator, denominator : tuple of (coefficients, dead time)
        The terms ``(a_i, alpha_i)`` (``(b_j, beta_j)``): tuples of floats in descending powers of
        ``s``, and floats.
    """

    numerator: Terms
    denominator: Terms

    def response(self, omega: np.ndarray) -> np.ndarray:
        """``L(i omega)`` in numpy, each side evaluated as written (see the module docstring)."""
        s = 1j * np.asarray(omega, dtype=float)

        def side(terms: Terms) -> np.ndarray:
            return sum(np.polyval(coefficients, s) * np.exp(-s * delay) for coefficients, delay in terms)

        return side(self.numerator) / side(self.denominator)

    @cached_property
    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """``(rows, dead times)`` of the numerator, then of the denominator, as
        :func:`envs.analysis._robustness_kernels.transfer_at` takes them."""
        return _rows(self.numerator) + _rows(self.denominator)

    def packed(self) -> tuple[np.ndarray, tuple[int, int, int, int]]:
        """:func:`packed` of the two sides."""
        return packed(self.numerator, self.denominator)


def _pid(controller: PID | SeriesPID) -> QuasiRational:
    """``num_c/den_c``: the arithmetic of the controllers' ``transfer_function``."""
    kp, ti, td, n = controller.kp, controller.ti, controller.td, controller.n
    num, den = (1.0,), (1.0,)
    if ti is not None:  # 1 + 1/(ti s) = (ti s + 1)/(ti s)
        num, den = (ti, 1.0), (ti, 0.0)
    if td > 0 and isinstance(controller, PID):  # + td s/(1 + td s/n)
        filter_ = (td / n, 1.0)
        num, den = _add(_multiply(num, filter_), _multiply(den, (td, 0.0))), _multiply(den, filter_)
    elif td > 0:  # series: (1 + td s)/(1 + td s/n)
        num, den = _multiply(num, (td, 1.0)), _multiply(den, (td / n, 1.0))
    return QuasiRational(((_scale(kp, num), 0.0),), ((den, 0.0),))


def _fppi(controller: FPPI) -> QuasiRational:
    """``K (T_n s + 1) / [T_n s (T_f s + 1) + K K_n (T_f s + 1) - K K_n e^{-L_n s}]``."""
    k, tn, tf = controller.proportional_gain, controller.time_constant, controller.tf
    k_kn = k * controller.gain
    rational = (tn * tf, tn + k_kn * tf, k_kn)  # T_n s (T_f s + 1) + K K_n (T_f s + 1)
    return QuasiRational((((k * tn, k), 0.0),), ((rational, 0.0), ((-k_kn,), controller.dead_time)))


def _msp(controller: MSP) -> QuasiRational:
    """``[F K_n (T_r s + 1) + s] / [K_n (T_r s + 1 - e^{-L_n s})]``, ``F`` of eq. 36 or eq. 51
    (``K_0 f(s)/lead(s)``); both sides multiplied by ``lead``."""
    kn, td = controller.gain, controller.derivative_time
    f, lead = ((td, 1.0), (td / 10, 1.0)) if controller.extension else ((1.0,), (1.0,))
    predictor = (controller.tr, 1.0)
    numerator = _add(_scale(controller.k0 * kn, _multiply(f, predictor)), lead + (0.0,))  # ... + s lead
    denominator = ((_scale(kn, _multiply(predictor, lead)), 0.0), (_scale(-kn, lead), controller.dead_time))
    return QuasiRational(((numerator, 0.0),), denominator)


def feedback_transfer(controller: Controller) -> QuasiRational:
    """The controller's ``C_fb(s)`` (see the module docstring)."""
    if isinstance(controller, PID | SeriesPID):
        return _pid(controller)
    if isinstance(controller, FPPI):
        return _fppi(controller)
    if isinstance(controller, MSP):
        return _msp(controller)
    raise TypeError(f"controller must be a PID, SeriesPID, FPPI or MSP, got {type(controller).__name__}")


def loop_transfer(plant: Plant, controller: Controller) -> QuasiRational:
    """``L(s) = P(s) C_fb(s)``, equal to :func:`envs.simulation.loops.loop_response` to rounding."""
    return QuasiRational(*_loop_terms(plant, controller))


def loop_packed(
    plant: Plant, controller: Controller, method: str = "compiled"
) -> tuple[np.ndarray, tuple[int, int, int, int]]:
    """``loop_transfer(plant, controller).packed()``.

    Parameters
    ----------
    plant, controller
        The loop ``P C_fb``.
    method : {"compiled", "reference"}
        ``"compiled"`` (default): one call to the kernels of
        :mod:`envs.analysis._loop_transfer_kernels`, which do the arithmetic of
        :func:`feedback_transfer`, :func:`_loop_terms` and :func:`packed` operation by operation, in
        the same order (products summed term by term as in :func:`_multiply`, no fused
        multiply-adds), at about a fifth of the cost.  ``"reference"``: those Python functions.  The
        two arrays are the same bit for bit (``tests/unit/envs/analysis/test_loop_transfer.py``).
    """
    if method == "reference":
        return packed(*_loop_terms(plant, controller))
    if method != "compiled":
        raise ValueError(f"method must be 'compiled' or 'reference', got {method!r}")
    if isinstance(controller, PID | SeriesPID):
        has_ti, ti = controller.ti is not None, 0.0 if controller.ti is None else float(controller.ti)
        kind, args = _PID, (float(controller.kp), ti, float(controller.td), float(controller.n), 0.0, has_ti, isinstance(controller, SeriesPID))
    elif isinstance(controller, FPPI):
        fppi = (controller.proportional_gain, float(controller.gain), float(controller.time_constant), float(controller.tf))
        kind, args = _FPPI, (*fppi, float(controller.dead_time), False, False)
    elif isinstance(controller, MSP):
        msp = (controller.k0, float(controller.gain), float(controller.tr), controller.derivative_time)
        kind, args = _MSP, (*msp, float(controller.dead_time), bool(controller.extension), False)
    else:
        return packed(*_loop_terms(plant, controller))  # raises the TypeError of feedback_transfer
    plant_coefficients = np.array(plant.num + plant.den, dtype=float)
    flat, rows, width, denominator_rows, denominator_width = _packed_loop(
        plant_coefficients, len(plant.num), float(plant.dead_time), kind, *args
    )
    return flat, (rows, width, denominator_rows, denominator_width)


def _loop_terms(plant: Plant, controller: Controller) -> tuple[Terms, Terms]:
    """The numerator and denominator terms of ``P C_fb``."""
    c = feedback_transfer(controller)
    return (
        tuple((_multiply(plant.num, a), plant.dead_time + alpha) for a, alpha in c.numerator),
        tuple((_multiply(plant.den, b), beta) for b, beta in c.denominator),
    )


