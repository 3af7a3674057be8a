"""What an episode knows about its plant: the experiments run so far, and the features they give.

The numerics behind the environments of :mod:`envs.tuning_env`, free of Gymnasium.  An episode
collects :class:`Evidence` (the latest result of each experiment type, counts, time spent); the
agent sees :func:`features` of it; the design reads :func:`identification` of it.

Experiments (SPEC "Experiments"; amplitudes relative to a unit change of the output, so that the
noise-to-signal ratio is ``noise_std/amplitude`` whatever the plant's gain):

=====================  ============================================================================
``closed-loop-step``   set-point step of height ``a`` with the commissioning controller: ``K_n``,
                       ``T_ar`` (Ingimundarson eq. 10), ``tau``, ``theta`` and the SOPDT model
                       (Gorez-Klan eq. 2-8 .. 2-10, appendix B)
``open-loop-step``     input step ``a/K_n``: ``T_n`` (eq. 11), ``L_n``, ``T_f_bar`` (eq. 22)
``open-loop-ramp``     input ramp of rate ``a/(K_n T_ar)`` for ``T_ar``: ``T_n`` (eq. 12)
``pulse``              (integrating plants) pulse ``a/(K_n tau_p)`` of length ``tau_p = L_n/3``:
                       ``A`` (eq. 46)
``relay``              relay of amplitude ``a/|K_n|``, hysteresis ``3 noise_std``: ultimate gain and
                       period (Astrom-Hagglund; beyond the seeds)
=====================  ============================================================================

Every experiment but the first needs ``K_n`` and ``T_ar``; choosing one before a closed-loop step
has identified them runs the closed-loop step instead.  Each type keeps its latest result.  An
experiment whose true output leaves ``[-excursion_limit, excursion_limit]`` is stopped there: its time
is charged and its result discarded (SPEC: "stopped and penalized").
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, replace

import numpy as np

from envs.identification.closed_loop_experiment import ClosedLoopStepResult, closed_loop_step
from envs.identification.open_loop_experiments import (
    OpenLoopPulseResult,
    OpenLoopRampResult,
    OpenLoopStepResult,
    open_loop_pulse,
    open_loop_ramp,
    open_loop_step,
)
from envs.systems.plants import Plant
from envs.identification.procedure import PULSE_LENGTH, Identification
from envs.identification.relay import RelayResult, relay_feedback

__all__ = [
    "STABLE_EXPERIMENTS",
    "INTEGRATING_EXPERIMENTS",
    "FEATURES",
    "RELAY_HYSTERESIS",
    "Evidence",
    "evidence_from_identification",
    "run_experiment",
    "features",
    "feature_names",
    "identification",
]

STABLE_EXPERIMENTS: tuple[str, ...] = ("closed-loop-step", "open-loop-step", "open-loop-ramp", "relay")
INTEGRATING_EXPERIMENTS: tuple[str, ...] = ("closed-loop-step", "pulse", "relay")
RELAY_HYSTERESIS = 3.0  # in units of noise_std
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
``log_noise_ratio``      ``log10(noise_std/a)`` of the closed-loop step              [-5, 5]
``log_relay_gain``       ``log10(K_u |K_n|)`` from the relay                         [-5, 5]
``relay_period``         ``P_u/T_ar`` from the relay, clipped                        [0, 5]
``ramp_time_constant``   ``T_n/T_ar`` from the ramp (eq. 12)                         [0, 1]
``log_experiment_time``  ``log10(1 + t_exp/T_ar)``, ``T_ar`` identified              [0, 5]
=======================  ==========================================================  ============

A feature whose experiment has not run (or failed) is 0; the counts that follow tell which ran.
"""


@dataclass(frozen=True)
class Evidence:
    """The experiments of one episode so far.

    Attributes
    ----------
    experiments : tuple of str
        The experiment types of the episode (:data:`STABLE_EXPERIMENTS` or
        :data:`INTEGRATING_EXPERIMENTS`).
    counts : tuple of int
        How many times each type ran (aborted runs included).
    results : dict of str to ExperimentResult
        The latest usable result of each type.
    experiment_time : float
        Total duration of every experiment run, in the plant's time units.
    aborted : int
        Number of experiments stopped at the excursion limit.
    noise_ratio : float
        ``noise_std/a`` of the latest closed-loop step (nan before one).
    """

    experiments: tuple[str, ...]
    counts: tuple[int, ...]
    results: dict
    experiment_time: float = 0.0
    aborted: int = 0
    noise_ratio: float = math.nan

    @classmethod
    def empty(cls, integrating: bool) -> Evidence:
        experiments = INTEGRATING_EXPERIMENTS if integrating else STABLE_EXPERIMENTS
        return cls(experiments, (0,) * len(experiments), {})

    @property
    def closed_loop(self) -> ClosedLoopStepResult | None:
        return self.results.get("closed-loop-step")

    @property
    def runs(self) -> int:
        return int(sum(self.counts))


def evidence_from_identification(identification: Identification, noise_std: float) -> Evidence:
    """The evidence of the seeds' procedure (:func:`envs.identification.procedure.identify`, amplitude 1)."""
    evidence = Evidence.empty(identification.integrating)
    second = "pulse" if identification.integrating else "open-loop-step"
    counts = tuple(int(name in ("closed-loop-step", second)) for name in evidence.experiments)
    results = {"closed-loop-step": identification.closed_loop, second: identification.open_loop}
    return replace(
        evidence, counts=counts, results=results, experiment_time=identification.experiment_time, noise_ratio=noise_std
    )


def _usable(result: ClosedLoopStepResult) -> bool:
    gain, scale = result.gain, result.residence_time
    return bool(np.isfinite(gain) and gain != 0 and np.isfinite(scale) and scale > 0 and not result.aborted)


def _run(kind: str, plant: Plant, rng: np.random.Generator, amplitude: float, evidence: Evidence, noise_std: float, limit: float):
    if kind == "closed-loop-step":
        return closed_loop_step(plant, rng, amplitude=amplitude, noise_std=noise_std, excursion_limit=limit)
    first = evidence.closed_loop
    gain, scale = first.gain, first.residence_time
    height = amplitude / gain  # the output rises by about ``amplitude``, whatever the sign of the gain
    if kind == "open-loop-step":
        return open_loop_step(plant, rng, height, scale, gain, noise_std=noise_std, excursion_limit=limit)
    if kind == "open-loop-ramp":
        return open_loop_ramp(plant, rng, height / scale, scale, gain, noise_std=noise_std, excursion_limit=limit)
    if kind == "pulse":
        model = first.integrating_model
        duration = PULSE_LENGTH * model.dead_time
        return open_loop_pulse(
            plant, rng, height / duration, duration, model.gain, model.dead_time,
            noise_std=noise_std, excursion_limit=limit,
        )  # fmt: skip
    return relay_feedback(
        plant, rng, abs(height), hysteresis=RELAY_HYSTERESIS * noise_std, noise_std=noise_std, excursion_limit=limit
    )


def run_experiment(
    evidence: Evidence,
    kind: str,
    plant: Plant,
    rng: np.random.Generator,
    amplitude: float,
    noise_std: float,
    excursion_limit: float,
) -> Evidence:
    """Run one experiment on the true ``plant`` and return the evidence with its result.

    Parameters
    ----------
    kind : str
        One of ``evidence.experiments``; replaced by ``"closed-loop-step"`` while no closed-loop
        step has identified ``K_n`` and ``T_ar``.
    amplitude : float
        ``a > 0``, the intended change of the output (module docstring).
    noise_std, excursion_limit : float
        Measurement noise and the output limit that stops the experiment.
    """
    if kind not in evidence.experiments:
        raise ValueError(f"unknown experiment {kind!r}; valid: {', '.join(evidence.experiments)}")
    if evidence.closed_loop is None:
        kind = "closed-loop-step"
    result = _run(kind, plant, rng, amplitude, evidence, noise_std, excursion_limit)
    counts = tuple(c + (name == kind) for name, c in zip(evidence.experiments, evidence.counts))
    usable = not result.aborted and (kind != "closed-loop-step" or _usable(result))
    changes: dict = {"counts": counts, "experiment_time": evidence.experiment_time + result.duration}
    if usable:
        changes["results"] = {**evidence.results, kind: result}
        if kind == "closed-loop-step":
            changes["noise_ratio"] = noise_std / amplitude
    else:
        changes["aborted"] = evidence.aborted + 1
    return replace(evidence, **changes)


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


def _identified(evidence: Evidence) -> dict[str, float]:
    out = dict.fromkeys(FEATURES, 0.0)
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
    return {k: _finite(v) for k, v in out.items()}


def features(evidence: Evidence, budget: int) -> np.ndarray:
    """The observation: :data:`FEATURES`, then each type's count over ``budget``, then runs over ``budget``."""
    identified = _identified(evidence)
    counts = [c / budget for c in evidence.counts]
    return np.array([*identified.values(), *counts, evidence.runs / budget], dtype=np.float64)


def feature_names(evidence: Evidence) -> tuple[str, ...]:
    """Names of the entries of :func:`features`."""
    return (*FEATURES, *(f"count_{name}" for name in evidence.experiments), "budget_used")


def identification(evidence: Evidence, structure: str, plant: Plant, rng: np.random.Generator, noise_std: float) -> Identification:
    """The identified data the design reads, completing the seeds' procedure where it is missing.

    The PID and the MSP need the closed-loop step; the FPPI also needs ``T_n``, from the open-loop
    step or else the ramp.  A missing experiment is run (amplitude 1, charged like any other).
    Returns the evidence actually used too, as ``(identification, evidence)``.

    Raises
    ------
    ValueError
        If no closed-loop step identifies a usable gain and residence time.
    """
    if evidence.closed_loop is None:
        evidence = run_experiment(evidence, "closed-loop-step", plant, rng, 1.0, noise_std, math.inf)
    if evidence.closed_loop is None:
        raise ValueError("the closed-loop step identified no usable gain and residence time")
    step, ramp = evidence.results.get("open-loop-step"), evidence.results.get("open-loop-ramp")
    if structure == "fppi" and (step is None or step.model is None) and (ramp is None or ramp.model is None):
        evidence = run_experiment(evidence, "open-loop-step", plant, rng, 1.0, noise_std, math.inf)
        step = evidence.results.get("open-loop-step")
    first = evidence.closed_loop
    fopdt = step.model if step is not None and step.model is not None else (ramp.model if ramp is not None else None)
    pulse = evidence.results.get("pulse")
    found = Identification(
        integrating=first.integrating_model is not None,
        gain=first.gain,
        residence_time=first.residence_time,
        fopdt=fopdt,
        sopdt=first.sopdt,
        integrating_model=first.integrating_model,
        mismatch_time=step.mismatch_time if step is not None else math.nan,
        pulse_area=pulse.area if pulse is not None else math.nan,
        experiment_time=evidence.experiment_time,
        closed_loop=first,
        open_loop=step if step is not None else pulse,
    )
    return found, evidence
