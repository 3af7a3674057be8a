"""The white noise level of a record read by a sensor of known resolution (a quantized record).

:func:`~envs.identification.steady_state.noise_level` (the median absolute fourth difference) reads 0
on a record whose noise is below the sensor's step ``q``: most fourth differences of the readings are
exactly 0.  :func:`quantized_noise_level` estimates the noise ``sigma`` of the measurement before the
quantizer from the readings and ``q``, in two regimes.

* Noise above half a step (``sigma >= q/2``): the quantization error is then all but independent of
  the measurement and uniform over one step (Widrow's quantization theorem; its bias on a variance is
  of the order ``exp(-2 pi^2 sigma^2/q^2)``, 0.7% at ``sigma = q/2``), so the fourth differences of the
  readings have the variance ``70 (sigma^2 + q^2/12)`` and ``sigma^2 = mean(d4^2)/70 - q^2/12``
  (Sheppard's correction).
* Noise below half a step: the readings flicker between neighbouring levels only where the signal is
  within a few ``sigma`` of a step's edge, and ``sigma`` is in how sharply.  The record is cut into
  blocks of :data:`BLOCK` samples; in each, the measurement is a quadratic ``eta(t)`` plus
  ``N(0, sigma^2)``, so a reading ``j`` (in steps, from the first) has the probability
  ``Phi((j + 1 - eta)/sigma) - Phi((j - eta)/sigma)`` (interval-censored regression; the offset of
  the steps is taken up by ``eta``, so floor and rounding sensors alike).  ``sigma`` maximizes the
  likelihood with each block's quadratic profiled out (Newton steps on the log-concave likelihood in
  its coefficients; a block on one level has its maximum in closed form, ``eta`` mid-step), over a
  log grid from ``q/100`` to ``q``, refined by a parabola.  A monotone crossing of a step is
  explained by the quadratic at any ``sigma``; a flicker is not.
* A record that does not reject ``sigma -> 0`` (the likelihood at ``q/100`` within ``1.92`` of the
  largest: no flicker at all, or a level that flickers to one side only, which tells the distance
  to the edge in units of ``sigma`` but not ``sigma``) gets the largest ``sigma`` it does not reject
  (the likelihood ``1.92`` below its largest, a 95% one-sided bound): about
  ``q/(2 Phi^-1(1 - 0.96/N))`` for ``N`` samples on one level (0.16 ``q`` for 1000 samples), never 0.

With ``q = 0`` the estimate is exactly :func:`~envs.identification.steady_state.noise_level`.  The measured
error on records of known noise (constant levels at random offsets, slow ramps, first-order step
responses) is in docs/environments/overview.md ("A sensor of finite resolution") and in the docstring
of its test, ``tests/unit/envs/identification/test_quantized_noise.py``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.special import log_ndtr

from envs.identification.steady_state import noise_level
from envs.validation import require_number

__all__ = ["BLOCK", "quantized_noise_level"]

BLOCK = 128
"""Samples per block of the flicker regime's likelihood (a quadratic per block)."""
DEGREE = 2
"""The degree of each block's polynomial: a slow ramp or the bend of a step response within a block."""
SHEPPARD_FLOOR = 0.5
"""The Sheppard estimate, in steps, above which it is returned (below it the likelihood decides)."""
REJECTION = 1.92
"""Half the 95% point of chi-square with one degree of freedom: the likelihood drop of the bound."""
_LOWEST, _HIGHEST = 0.01, 1.0  # the likelihood's search range of sigma, in steps
GRID = 24  # its points, a ratio of 1.22 apart
_HALF_LOG_2PI = 0.5 * math.log(2.0 * math.pi)


def quantized_noise_level(signal: np.ndarray, quantization: float) -> float:
    """The white noise ``sigma`` of the measurement behind ``signal``, read with the resolution
    ``quantization`` (module docstring); ``noise_level(signal)`` at ``quantization == 0`` (and for a
    record of fewer than 5 samples or with a value that is not finite).  A record whose values are
    not whole steps apart gets the Sheppard estimate whatever its level."""
    q = require_number(quantization, "quantization", nonnegative=True)
    if q == 0.0:
        return noise_level(signal)
    r = np.asarray(signal, dtype=float).ravel() / q
    if r.size < 5 or not np.all(np.isfinite(r)):
        return noise_level(signal)
    d4 = np.diff(r, 4)
    sheppard = float(np.mean(d4 * d4)) / 70.0 - 1.0 / 12.0
    levels = np.rint(r - r[0])
    if sheppard >= SHEPPARD_FLOOR**2 or np.max(np.abs(r - r[0] - levels)) > 1e-6:
        return q * math.sqrt(max(sheppard, 0.0))  # noise above half a step, or not readings of step q
    return q * _flicker_sigma(levels)


def _flicker_sigma(levels: np.ndarray) -> float:
    """The likelihood estimate (or the bound) of ``sigma``, in steps, from readings in steps."""
    head = levels.size % BLOCK  # the samples before the whole blocks (the last ends at the record's end)
    parts = [levels[head:].reshape(-1, BLOCK)] if levels.size >= BLOCK else []
    if head and (head >= BLOCK // 2 or np.all(levels[:head] == levels[0])):  # a few changing samples: left out
        parts.append(levels[None, :head])
    profile = _Likelihood(parts)
    grid = np.exp(np.linspace(math.log(_HIGHEST), math.log(_LOWEST), GRID))  # from above: warm starts
    values = np.array([profile(s) for s in grid])
    best = int(np.argmax(values))
    if values[-1] >= values[best] - REJECTION:  # the record does not reject sigma -> 0: the bound
        return _bound(profile, grid, values)
    if best == 0:
        return float(grid[0])
    x, y = np.log(grid[best - 1 : best + 2]), values[best - 1 : best + 2]  # the parabola through three points
    curvature = y[0] - 2.0 * y[1] + y[2]
    shift = 0.5 * (y[0] - y[2]) / curvature if curvature < 0 else 0.0
    return float(math.exp(x[1] + shift * (x[1] - x[0])))


def _bound(profile: _Likelihood, grid: np.ndarray, values: np.ndarray) -> float:
    """The largest ``sigma`` whose likelihood is within ``REJECTION`` of the grid's largest: bracketed
    on the grid, then bisected on the log scale."""
    level = float(values.max()) - REJECTION
    k = int(np.flatnonzero(values >= level).min())  # the grid descends: the largest sigma not rejected
    if k == 0:
        return float(grid[0])
    above, below = math.log(grid[k - 1]), math.log(grid[k])
    for _ in range(8):
        middle = 0.5 * (above + below)
        if profile(math.exp(middle)) >= level:
            below = middle
        else:
            above = middle
    return float(math.exp(0.5 * (above + below)))


class _Likelihood:
    """The profile log-likelihood of ``sigma`` of the record's blocks, each of the ``parts`` an array
    of blocks of one length: the blocks on one level in closed form, the others by :class:`_Profile`."""

    def __init__(self, parts: list[np.ndarray]) -> None:
        self.flat, self.active = 0, []
        for blocks in parts:
            flat = np.all(blocks == blocks[:, :1], axis=1)
            self.flat += int(flat.sum()) * blocks.shape[1]
            if not flat.all():
                self.active.append(_Profile(blocks[~flat]))

    def __call__(self, sigma: float) -> float:
        flat = self.flat * float(np.log1p(-2.0 * math.exp(float(log_ndtr(-0.5 / sigma))))) if self.flat else 0.0
        return flat + sum(profile(sigma) for profile in self.active)


class _Profile:
    """The log-likelihood of ``sigma`` (in steps) of blocks whose readings change, each block's
    polynomial at its maximum (Newton steps, warm-started from the previous call's coefficients)."""

    def __init__(self, active: np.ndarray) -> None:
        self.j = active
        n = active.shape[1]
        t = (np.arange(n) - 0.5 * (n - 1)) / max(0.5 * (n - 1), 1.0)
        self.basis = np.vander(t, min(DEGREE + 1, n), increasing=True)  # n x (DEGREE + 1): 1, t, t^2
        fit = np.linalg.lstsq(self.basis, active.T + 0.5, rcond=None)[0]  # the readings' polynomials
        self.coef = np.ascontiguousarray(fit.T)

    def __call__(self, sigma: float) -> float:
        coef, basis = self.coef, self.basis
        p = basis.shape[1]
        outer = (basis[:, :, None] * basis[:, None, :]).reshape(-1, p * p)  # n x p^2
        limit = 0.5 * max(sigma, 0.05)
        for _ in range(25):
            logp, g, h = _interval(self.j, coef @ basis.T, sigma)
            gradient = g @ basis  # blocks x p
            hessian = (h @ outer).reshape(-1, p, p)
            hessian -= (1e-10 * (1.0 + np.abs(h).sum(axis=1)))[:, None, None] * np.eye(p)
            step = -np.linalg.solve(hessian, gradient[:, :, None])[:, :, 0]
            coef = coef + np.clip(step, -limit, limit)
            if float(np.max(np.abs(step))) < 1e-5:
                break
        self.coef = coef
        return float(_interval(self.j, coef @ basis.T, sigma)[0].sum())


def _log_phi(x: np.ndarray) -> np.ndarray:
    return -0.5 * x * x - _HALF_LOG_2PI


def _interval(j: np.ndarray, eta: np.ndarray, sigma: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``log P``, ``d log P/d eta`` and ``d^2 log P/d eta^2`` of the readings ``j`` with
    ``P = Phi(a) - Phi(b)``, ``a = (j + 1 - eta)/sigma``, ``b = (j - eta)/sigma``, computed in logs
    from the side of the interval away from the mean (no cancellation, no underflow)."""
    a, b = (j + 1.0 - eta) / sigma, (j - eta) / sigma
    upper = b > 0.0  # the interval above the mean: P = Phi(-b) - Phi(-a)
    hi, lo = np.where(upper, -b, a), np.where(upper, -a, b)  # P = Phi(hi) - Phi(lo), hi > lo
    log_hi, log_lo = log_ndtr(hi), log_ndtr(lo)
    logp = log_hi + np.log1p(-np.exp(np.minimum(log_lo - log_hi, -1e-300)))
    ra, rb = np.exp(_log_phi(a) - logp), np.exp(_log_phi(b) - logp)  # phi(a)/P, phi(b)/P
    g = (rb - ra) / sigma
    h = (b * rb - a * ra) / (sigma * sigma) - g * g
    return logp, g, h
