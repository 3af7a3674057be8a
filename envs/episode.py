"""What an episode knows about its plant: the experiments run so far, and the features they give.

The numerics behind the environments of :mod:`envs.tuning_env`, free of Gymnasium.  An episode
collects :class:`Evidence` (the latest result of each experiment type, counts, time spent); the
agent sees :func:`features` of it; the design reads :func:`identification` of it.

Experiments (amplitudes relative to a unit change of the output, so that the
noise-to-signal ratio is ``noise_std/amplitude`` whatever the plant's gain):

=====================  ============================================================================
``closed-loop-step``   set-point step of height ``a`` with the commissioning controller: ``K_n``,
                       ``T_ar`` (Ingimundarson eq. 10), ``tau``, ``theta`` and the SOPDT model
                       (Gorez-Klan eq. 2-8 .. 2-10, appendix B)
``open-loop-step``     input step ``a/K_n``: ``T_n`` (eq. 11), ``L_n``, ``T_f_bar`` (eq. 22)
``open-loop-ramp``     input ramp of rate ``a/(K_n T_ar)`` for ``T_ar``: ``T_n`` (eq. 12)
``pulse``              (integrating plants) pulse ``a/(K_n tau_p)`` of length ``tau_p = L_n/3``:
                       ``A`` (eq. 46)
``relay``              relay of amplitude ``a/|K_n|``, hysteresis ``3 sigma``: ultimate gain and
                       period (Astrom-Hagglund; beyond the papers' procedure)
=====================  ============================================================================

``sigma`` is the noise level.  With ``options.measured`` (the v3 environments) it is estimated from
the records, as on a real loop, where nobody is told the noise level: the median absolute fourth
difference of the latest usable closed-loop step's measured output over ``0.6745 sqrt(70)``
(:func:`~envs.identification.steady_state.noise_level`; the median absolute deviation estimator
of the finest-scale differences, as Donoho and Johnstone's wavelet estimate, with fourth
differences so that the step response's own curvature does not count).  With a quantizing sensor
(the environments' ``quantization``) most fourth differences of the readings are 0, and the estimate
is :func:`~envs.identification.quantized_noise.quantized_noise_level`, which knows the resolution
(:func:`measured_noise`).  Without it (v0-v2), the environment's configured ``noise_std``.

Every experiment but the first needs ``K_n`` and ``T_ar``; choosing one before a closed-loop step
has identified them runs the closed-loop step instead.  Each type keeps its latest result.  An
experiment whose true output leaves ``[-excursion_limit, excursion_limit]`` is stopped there: its time
is charged and its result discarded: stopped and penalized.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from envs.identification.closed_loop_experiment import ClosedLoopStepResult, closed_loop_step
from envs.identification.open_loop_pulse import open_loop_pulse
from envs.identification.open_loop_ramp import open_loop_ramp
from envs.identification.open_loop_step import open_loop_step
from envs.systems.plants import Plant
from envs.identification.prbs_experiment import open_loop_prbs
from envs.identification.procedure import PULSE_LENGTH, Identification, ProcedureFailed, experiment_deviation, identify
from envs.identification.relay import relay_feedback
from envs.identification.quantized_noise import quantized_noise_level
from envs.identification.steady_state import noise_level
from envs.episode_features import FEATURES, LEAST_SQUARES_FEATURES, LOG_CLIP, MEASURED_FEATURES, feature_names, features
from envs.episode_fits import latest_model, least_squares_identification, with_fit
from envs.evidence import INTEGRATING_EXPERIMENTS, LEAST_SQUARES_EXPERIMENTS, STABLE_EXPERIMENTS, Evidence, RecordFit
from envs.episode_options import DEFAULT_OPTIONS, EpisodeOptions
from envs.structures import STRUCTURES

__all__ = [
    "STABLE_EXPERIMENTS",
    "INTEGRATING_EXPERIMENTS",
    "LEAST_SQUARES_EXPERIMENTS",
    "FEATURES",
    "LEAST_SQUARES_FEATURES",
    "MEASURED_FEATURES",
    "LOG_CLIP",
    "RecordFit",
    "IdentificationFailed",
    "RELAY_HYSTERESIS",
    "Evidence",
    "evidence_from_identification",
    "measured_noise",
    "start_fixed",
    "failed_start",
    "run_experiment",
    "features",
    "feature_names",
    "identification",
]

RELAY_HYSTERESIS = 3.0  # in units of the noise level sigma
DISTURBED_ATTEMPTS = 3
"""With disturbances, the closed-loop steps a commit (or the fixed mode's start) runs at most until one
identifies a usable model (a drift or a load can spoil one; each is charged)."""


def evidence_from_identification(
    identification: Identification, options: EpisodeOptions = DEFAULT_OPTIONS, amplitude: float = 1.0
) -> Evidence:
    """The evidence of the fixed procedure (:func:`envs.identification.procedure.identify`, at ``amplitude``)."""
    evidence = Evidence.empty(identification.integrating, options)
    second = "pulse" if identification.integrating else "open-loop-step"
    counts = tuple(int(name in ("closed-loop-step", second)) for name in evidence.experiments)
    results = {"closed-loop-step": identification.closed_loop, second: identification.open_loop}
    sigma = measured_noise(identification.closed_loop.output, options) if options.measured else options.noise_std
    measured = {"noise_estimate": sigma} if options.measured else {}
    return replace(
        evidence, counts=counts, results=results, experiment_time=identification.experiment_time,
        noise_ratio=sigma / amplitude, experiment_deviation=identification.experiment_deviation, **measured,
    )  # fmt: skip


def measured_noise(output: np.ndarray, options: EpisodeOptions) -> float:
    """The noise level a measured observation reads from a record: :func:`~envs.identification.steady_state.noise_level`,
    or with a quantizing sensor (``options.quantization`` not 0) the estimate that knows its resolution
    (:func:`~envs.identification.quantized_noise.quantized_noise_level`)."""
    if options.quantization:
        return quantized_noise_level(output, options.quantization)
    return noise_level(output)


def start_fixed(
    plant: Plant, rng: np.random.Generator, options: EpisodeOptions = DEFAULT_OPTIONS, structure: str | None = None
) -> tuple[Identification, Evidence]:
    """The fixed mode's start: the fixed procedure (:func:`~envs.identification.procedure.identify`, at the
    options' amplitude, with their disturbances) and its evidence; with ``identification="least-squares"``,
    its open-loop step's record fitted too and read by the design (:func:`identification`).

    With ``structure``, an identification without the model of its design (:attr:`envs.structures.Structure.model`) raises
    :class:`IdentificationFailed`, as a procedure whose closed-loop steps failed raises
    :class:`~envs.identification.procedure.ProcedureFailed`."""
    amplitude, noise_std = options.seed_amplitude, options.noise_std
    if options.disturbances.active or amplitude != 1.0 or options.production or options.quantization:
        attempts = DISTURBED_ATTEMPTS if options.disturbances.active else 1
        found = identify(plant, rng, noise_std, amplitude=amplitude, disturbances=options.disturbances, attempts=attempts,
                         deviation=options.production, quantization=options.quantization)
    else:
        found = identify(plant, rng, noise_std)  # the v0 call
    evidence = evidence_from_identification(found, options, amplitude)
    if options.least_squares:
        evidence = with_fit(evidence, "open-loop-step", found.open_loop, amplitude)
        found = least_squares_identification(found, evidence)
    if structure is not None:
        _require_design_model(found, evidence, structure)
    return found, evidence


def failed_start(failure: ProcedureFailed, integrating: bool, options: EpisodeOptions) -> Evidence:
    """The evidence of a fixed-mode start whose fixed procedure identified nothing
    (:func:`start_fixed` raised ``failure``): its closed-loop steps, charged and failed."""
    evidence = Evidence.empty(integrating, options)
    counts = tuple(failure.attempts * (name == "closed-loop-step") for name in evidence.experiments)
    return replace(evidence, counts=counts, aborted=failure.attempts, experiment_time=failure.experiment_time,
                   experiment_deviation=failure.experiment_deviation)


def _usable(result: ClosedLoopStepResult) -> bool:
    gain, scale = result.gain, result.residence_time
    return bool(np.isfinite(gain) and gain != 0 and np.isfinite(scale) and scale > 0 and not result.aborted)


def _run(kind: str, plant: Plant, rng: np.random.Generator, amplitude: float, evidence: Evidence, noise_std: float, limit: float):
    # Each experiment gets the episode's disturbances and quantization only when there are any, so
    # that the v0 calls stay exactly what they were.
    extra = {"disturbances": evidence.options.disturbances} if evidence.options.disturbances.active else {}
    if evidence.options.quantization:
        extra["quantization"] = evidence.options.quantization
    if kind == "closed-loop-step":
        return closed_loop_step(plant, rng, amplitude=amplitude, noise_std=noise_std, excursion_limit=limit, **extra)
    first = evidence.closed_loop
    gain, scale = first.gain, first.residence_time
    height = amplitude / gain  # the output rises by about ``amplitude``, whatever the sign of the gain
    if kind == "open-loop-step":
        return open_loop_step(plant, rng, height, scale, gain, noise_std=noise_std, excursion_limit=limit, **extra)
    if kind == "open-loop-ramp":
        return open_loop_ramp(plant, rng, height / scale, scale, gain, noise_std=noise_std, excursion_limit=limit, **extra)
    if kind == "prbs":
        order = evidence.options.order
        return open_loop_prbs(plant, rng, height, scale, noise_std=noise_std, excursion_limit=limit, order=order, **extra)
    if kind == "pulse":
        model = first.integrating_model
        duration = PULSE_LENGTH * model.dead_time
        return open_loop_pulse(
            plant, rng, height / duration, duration, model.gain, model.dead_time,
            noise_std=noise_std, excursion_limit=limit, **extra,
        )  # fmt: skip
    sigma = evidence.noise_estimate if evidence.options.measured else noise_std
    return relay_feedback(
        plant, rng, abs(height), hysteresis=RELAY_HYSTERESIS * sigma, noise_std=noise_std, excursion_limit=limit,
        **extra,
    )  # fmt: skip


def run_experiment(
    evidence: Evidence,
    kind: str,
    plant: Plant,
    rng: np.random.Generator,
    amplitude: float,
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
    excursion_limit : float
        The output limit that stops the experiment.  The measurement noise is the options'
        (:attr:`envs.episode_options.EpisodeOptions.noise_std`).
    """
    if kind not in evidence.experiments:
        raise ValueError(f"unknown experiment {kind!r}; valid: {', '.join(evidence.experiments)}")
    if evidence.closed_loop is None:
        kind = "closed-loop-step"
    noise_std = evidence.options.noise_std
    result = _run(kind, plant, rng, amplitude, evidence, noise_std, excursion_limit)
    counts = tuple(c + (name == kind) for name, c in zip(evidence.experiments, evidence.counts))
    usable = not result.aborted and (kind != "closed-loop-step" or _usable(result))
    changes: dict = {"counts": counts, "experiment_time": evidence.experiment_time + result.duration}
    if evidence.options.production:
        changes["experiment_deviation"] = evidence.experiment_deviation + experiment_deviation(result)
    if usable:
        changes["results"] = {**evidence.results, kind: result}
        if kind == "closed-loop-step" and evidence.options.measured:
            changes["noise_estimate"] = measured_noise(result.output, evidence.options)
            changes["noise_ratio"] = changes["noise_estimate"] / amplitude
        elif kind == "closed-loop-step":
            changes["noise_ratio"] = noise_std / amplitude
    else:
        changes["aborted"] = evidence.aborted + 1
    evidence = replace(evidence, **changes)
    if usable and evidence.options.least_squares:
        evidence = latest_model(evidence, kind, result, amplitude)
    return evidence


class IdentificationFailed(ValueError):
    """The experiments identified nothing the design can read: no closed-loop step a usable gain and
    residence time, or no experiment the model of the design (:attr:`envs.structures.Structure.model`); ``evidence``
    holds the runs (charged, and the one that failed counted in ``aborted``)."""

    def __init__(self, evidence: Evidence, reason: str = "the closed-loop step identified no usable gain and residence time") -> None:
        super().__init__(reason)
        self.evidence = evidence


def _require_design_model(found: Identification, evidence: Evidence, structure: str) -> None:
    """Raise :class:`IdentificationFailed` if ``found`` has no model for ``structure``'s design
    (:attr:`envs.structures.Structure.model`): an FOPDT model comes from an open-loop step or ramp that
    settled, which a drift or a load can prevent (the experiment is then counted as failed)."""
    model = STRUCTURES[structure].model
    if getattr(found, model) is None:
        failed = replace(evidence, aborted=evidence.aborted + 1)
        raise IdentificationFailed(failed, f"the experiments identified no {model} model for the design")


def identification(
    evidence: Evidence, structure: str, plant: Plant, rng: np.random.Generator, amplitude: float | None = None
) -> tuple[Identification, Evidence]:
    """The identified data the design reads, completing the fixed procedure where it is missing.

    Every design needs the closed-loop step; one that reads the FOPDT model (the FPPI) also needs
    ``T_n``, from the open-loop step or else the ramp.  A missing experiment is run (at ``amplitude``; by default 1, or the
    amplitude limit if smaller; charged like any other).
    Returns the evidence actually used too, as ``(identification, evidence)``.  With disturbances,
    up to :data:`DISTURBED_ATTEMPTS` closed-loop steps are run until one is usable.  With
    ``identification="least-squares"`` the latest least-squares fit's model replaces the FOPDT (FPPI)
    or SOPDT (PID) model, and the FPPI needs no other open-loop experiment when there is one.

    Raises
    ------
    IdentificationFailed
        If no closed-loop step identifies a usable gain and residence time (a ``ValueError``; its
        ``evidence`` has the failed runs).
    """
    amplitude = evidence.options.seed_amplitude if amplitude is None else amplitude
    attempts = DISTURBED_ATTEMPTS if evidence.options.disturbances.active else 1
    for _ in range(attempts):
        if evidence.closed_loop is not None:
            break
        evidence = run_experiment(evidence, "closed-loop-step", plant, rng, amplitude, math.inf)
    if evidence.closed_loop is None:
        raise IdentificationFailed(evidence)
    step, ramp = evidence.results.get("open-loop-step"), evidence.results.get("open-loop-ramp")
    fitted = evidence.fit is not None
    if STRUCTURES[structure].model == "fopdt" and not fitted and (step is None or step.model is None) and (ramp is None or ramp.model is None):
        evidence = run_experiment(evidence, "open-loop-step", plant, rng, amplitude, math.inf)
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
        experiment_deviation=evidence.experiment_deviation,
    )
    if evidence.options.least_squares:
        found = least_squares_identification(found, evidence)
    _require_design_model(found, evidence, structure)
    return found, evidence
