"""The features an episode observes: what its :class:`~envs.episode.Evidence` gives, as numbers.

:func:`features` is the observation's first part (the environments append the design features and the
design step: :mod:`envs.observation`); :func:`feature_names` names its entries.
"""

from __future__ import annotations

import math
import sys
from typing import TYPE_CHECKING

import numpy as np

from envs.evidence import Evidence

if TYPE_CHECKING:
    from envs.identification.open_loop_pulse import OpenLoopPulseResult
    from envs.identification.open_loop_ramp import OpenLoopRampResult
    from envs.identification.open_loop_step import OpenLoopStepResult
    from envs.identification.relay import RelayResult

__all__ = ["FEATURES", "LEAST_SQUARES_FEATURES", "MEASURED_FEATURES", "LOG_CLIP", "features", "feature_names"]

LOG_CLIP = 5.0  # log10 features are clipped to [-LOG_CLIP, LOG_CLIP]

FEATURES: tuple[str, ...] = (
    "tau",
    "theta",
    "dead_time_fraction",
    "log_mismatch",
    "log_pulse_area",
    "log_noise_ratio",
    "log_relay_gain",
    "relay_period",
    "ramp_time_constant",
    "log_experiment_time",
)
"""Names of the identified features, in the order of :func:`features` (before the counts).

=======================  ==========================================================  ============
name                     value                                                       range
=======================  ==========================================================  ============
``tau``                  normalized dead time ``1 - T_a/T_ar`` (Gorez-Klan eq. 2-7)  [0, 1]
``theta``                ``theta`` of the SOPDT model (eq. 2-10)                     [0, 1]
``dead_time_fraction``   ``L_n/T_ar`` from the open-loop step (eq. 11)               [0, 1]
``log_mismatch``         ``log10(T_f_bar/T_n)`` (eq. 22)                             [-5, 5]
``log_pulse_area``       ``log10(A/(K_n L_n))`` (eq. 46; integrating plants)         [-5, 5]
``log_noise_ratio``      ``log10(sigma/a)`` of the closed-loop step                  [-5, 5]
``log_relay_gain``       ``log10(K_u |K_n|)`` from the relay                         [-5, 5]
``relay_period``         ``P_u/T_ar`` from the relay, clipped                        [0, 5]
``ramp_time_constant``   ``T_n/T_ar`` from the ramp (eq. 12)                         [0, 1]
``log_experiment_time``  ``log10(1 + t_exp/T_ar)``, ``T_ar`` identified              [0, 5]
=======================  ==========================================================  ============

A feature whose experiment has not run (or failed) is 0; the counts that follow tell which ran.
"""

MEASURED_FEATURES: tuple[str, ...] = ("failed_experiments",)
"""With ``options.measured`` (v3), the last entry of :func:`features`: the experiments that gave
nothing usable (stopped at the excursion limit, or a closed-loop step without a usable gain and
``T_ar``) over the budget."""

LEAST_SQUARES_FEATURES: tuple[str, ...] = ("ls_time_constant", "ls_dead_time", "log_ls_residual")
"""With ``identification="least-squares"``, three features follow :data:`FEATURES`: of the latest
least-squares fit (:mod:`envs.identification.least_squares`) that gave a model, its time constant
(``T_1 + T_2`` for the SOPDT model) and its dead time over the identified ``T_ar`` (clipped to
[0, 5]), and ``log10`` of the standard deviation of its simulation error over the experiment's
amplitude ``a`` ([-5, 5]); 0 before such a fit."""


def _log(value: float) -> float:
    if not (math.isfinite(value) and value > 0):
        return -LOG_CLIP if value == 0 else 0.0
    return _clip(math.log10(value), -LOG_CLIP, LOG_CLIP)


def _clip(value: float, low: float, high: float) -> float:
    """``float(numpy.clip(value, low, high))`` of a number (NaN stays NaN)."""
    return min(max(float(value), low), high)


def _finite(value: float) -> float:
    """``float(numpy.nan_to_num(value))`` of a number: NaN is 0, an infinity the largest float of its sign."""
    value = float(value)
    if math.isfinite(value):
        return value
    return 0.0 if math.isnan(value) else math.copysign(sys.float_info.max, value)


def _names(evidence: Evidence) -> tuple[str, ...]:
    """:data:`FEATURES`, and :data:`LEAST_SQUARES_FEATURES` with the least-squares identification."""
    return (*FEATURES, *LEAST_SQUARES_FEATURES) if evidence.options.least_squares else FEATURES


def _fit_features(evidence: Evidence, scale: float) -> dict[str, float]:
    found = evidence.fit
    if found is None:
        return {}
    model = found.fit.model
    lag = sum(model.time_constants) if hasattr(model, "time_constants") else model.time_constant
    return {
        "ls_time_constant": _clip(lag / scale, 0.0, LOG_CLIP),
        "ls_dead_time": _clip(model.dead_time / scale, 0.0, LOG_CLIP),
        "log_ls_residual": _log(found.fit.noise_std / found.amplitude),
    }


def _identified(evidence: Evidence) -> dict[str, float]:
    out = dict.fromkeys(_names(evidence), 0.0)
    first = evidence.closed_loop
    if first is None:
        return out
    scale = first.residence_time
    out.update(tau=first.normalized_dead_time, theta=first.theta, log_noise_ratio=_log(evidence.noise_ratio))
    out["log_experiment_time"] = _clip(math.log10(1.0 + evidence.experiment_time / scale), 0.0, LOG_CLIP)
    step: OpenLoopStepResult | None = evidence.results.get("open-loop-step")
    if step is not None and step.model is not None:
        out["dead_time_fraction"] = step.dead_time / scale
        out["log_mismatch"] = _log(step.mismatch_time / step.time_constant) if step.time_constant > 0 else LOG_CLIP
    ramp: OpenLoopRampResult | None = evidence.results.get("open-loop-ramp")
    if ramp is not None:
        out["ramp_time_constant"] = ramp.time_constant / scale
    pulse: OpenLoopPulseResult | None = evidence.results.get("pulse")
    if pulse is not None:
        out["log_pulse_area"] = _log(pulse.area / (abs(first.gain) * first.residence_time))
    relay: RelayResult | None = evidence.results.get("relay")
    if relay is not None and relay.converged:
        out["log_relay_gain"] = _log(relay.ultimate_gain * abs(first.gain))
        out["relay_period"] = _clip(relay.ultimate_period / scale, 0.0, LOG_CLIP)
    out.update(_fit_features(evidence, scale))
    return {k: _finite(v) for k, v in out.items()}


def features(evidence: Evidence, budget: int) -> np.ndarray:
    """The observation: :data:`FEATURES` (and :data:`LEAST_SQUARES_FEATURES` with the least-squares
    identification), then each type's count over ``budget``, then runs over ``budget``."""
    identified = _identified(evidence)
    counts = [c / budget for c in evidence.counts]
    failed = [evidence.aborted / budget] if evidence.options.measured else []
    return np.array([*identified.values(), *counts, evidence.runs / budget, *failed], dtype=np.float64)


def feature_names(evidence: Evidence) -> tuple[str, ...]:
    """Names of the entries of :func:`features`."""
    measured = MEASURED_FEATURES if evidence.options.measured else ()
    return (*_names(evidence), *(f"count_{name}" for name in evidence.experiments), "budget_used", *measured)
