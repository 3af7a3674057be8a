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
differences so that the step response's own curvature does not count).  Without it (v0-v2), the
environment's configured ``noise_std``.

Every experiment but the first needs ``K_n`` and ``T_ar``; choosing one before a closed-loop step
has identified them runs the closed-loop step instead.  Each type keeps its latest result.  An
experiment whose true output leaves ``[-excursion_limit, excursion_limit]`` is stopped there: its time
is charged and its result discarded: stopped and penalized.
"""

from __future__ import annotations

import math
import sys
from dataclasses import dataclass, replace

import numpy as np

from envs.identification.closed_loop_experiment import ClosedLoopStepResult, closed_loop_step
from envs.identification.open_loop_pulse import OpenLoopPulseResult, open_loop_pulse
from envs.identification.open_loop_ramp import OpenLoopRampResult, open_loop_ramp
from envs.identification.open_loop_step import OpenLoopStepResult, open_loop_step
from envs.systems.plants import Plant
from envs.identification.least_squares import LeastSquaresFit
from envs.identification.models import FOPDTModel, SOPDTModel
from envs.identification.open_loop_areas import mismatch_time
from envs.identification.prbs_experiment import fit_record, open_loop_prbs
from envs.identification.procedure import PULSE_LENGTH, Identification, ProcedureFailed, experiment_deviation, identify
from envs.identification.relay import RelayResult, relay_feedback
from envs.identification.steady_state import noise_level
from envs.episode_options import DEFAULT_OPTIONS, EpisodeOptions
from envs.structures import STRUCTURES

__all__ = [
    "STABLE_EXPERIMENTS",
    "INTEGRATING_EXPERIMENTS",
    "LEAST_SQUARES_EXPERIMENTS",
    "FEATURES",
    "LEAST_SQUARES_FEATURES",
    "MEASURED_FEATURES",
    "IdentificationFailed",
    "RELAY_HYSTERESIS",
    "Evidence",
    "evidence_from_identification",
    "start_fixed",
    "failed_start",
    "run_experiment",
    "features",
    "feature_names",
    "identification",
]

STABLE_EXPERIMENTS: tuple[str, ...] = ("closed-loop-step", "open-loop-step", "open-loop-ramp", "relay")
INTEGRATING_EXPERIMENTS: tuple[str, ...] = ("closed-loop-step", "pulse", "relay")
LEAST_SQUARES_EXPERIMENTS: tuple[str, ...] = (*STABLE_EXPERIMENTS, "prbs")
"""The experiment types with ``identification="least-squares"`` (self-regulating plants only)."""
_SEEDS_MODEL_EXPERIMENTS = {1: ("open-loop-step", "open-loop-ramp"), 2: ("closed-loop-step",)}
"""With ``identification="least-squares"`` in agent mode, the design reads the model of the latest
experiment that gives one: a PRBS (least squares), or these (the papers' formulas; by the order of
the design's model: the FPPI's FOPDT model, the PID's SOPDT model)."""
RELAY_HYSTERESIS = 3.0  # in units of the noise level sigma
DISTURBED_ATTEMPTS = 3
"""With disturbances, the closed-loop steps a commit (or the fixed mode's start) runs at most until one
identifies a usable model (a drift or a load can spoil one; each is charged)."""
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


@dataclass(frozen=True)
class RecordFit:
    """A least-squares fit of one experiment's record.

    Attributes
    ----------
    experiment : str
        The experiment type whose record was fitted.
    fit : LeastSquaresFit
        The fit, whose ``model`` is not None.
    amplitude : float
        The experiment's amplitude ``a`` (intended change of the output).
    """

    experiment: str
    fit: LeastSquaresFit
    amplitude: float


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
        ``sigma/a`` of the latest usable closed-loop step (nan before one; module docstring).
    options : EpisodeOptions
        The episode's identification settings (:mod:`envs.episode_options`; default: the v0
        environments').
    fit : RecordFit or None
        With ``options.identification == "least-squares"``: the least-squares fit the design reads
        (fixed mode: of the fixed procedure's open-loop step; agent mode: of the latest PRBS, unless an
        experiment whose model the papers' formulas give ran after it).
    experiment_deviation : float
        ``int |y| dt`` of the true output over every experiment run (aborted ones included), the
        production they disturbed (:func:`envs.identification.procedure.experiment_deviation`);
        tracked only with ``options.production`` (else 0).
    noise_estimate : float
        With ``options.measured``: the noise level estimated from the latest usable closed-loop
        step's record (nan before one).
    """

    experiments: tuple[str, ...]
    counts: tuple[int, ...]
    results: dict
    experiment_time: float = 0.0
    aborted: int = 0
    noise_ratio: float = math.nan
    options: EpisodeOptions = DEFAULT_OPTIONS
    fit: RecordFit | None = None
    experiment_deviation: float = 0.0
    noise_estimate: float = math.nan

    @classmethod
    def empty(cls, integrating: bool, options: EpisodeOptions = DEFAULT_OPTIONS) -> Evidence:
        experiments = INTEGRATING_EXPERIMENTS if integrating else STABLE_EXPERIMENTS
        if options.least_squares and not integrating:
            experiments = LEAST_SQUARES_EXPERIMENTS
        if options.experiment_types is not None:
            experiments = options.experiment_types
        return cls(experiments, (0,) * len(experiments), {}, options=options)

    @property
    def closed_loop(self) -> ClosedLoopStepResult | None:
        return self.results.get("closed-loop-step")

    @property
    def runs(self) -> int:
        return int(sum(self.counts))


def evidence_from_identification(
    identification: Identification, options: EpisodeOptions = DEFAULT_OPTIONS, amplitude: float = 1.0
) -> Evidence:
    """The evidence of the fixed procedure (:func:`envs.identification.procedure.identify`, at ``amplitude``)."""
    evidence = Evidence.empty(identification.integrating, options)
    second = "pulse" if identification.integrating else "open-loop-step"
    counts = tuple(int(name in ("closed-loop-step", second)) for name in evidence.experiments)
    results = {"closed-loop-step": identification.closed_loop, second: identification.open_loop}
    sigma = noise_level(identification.closed_loop.output) if options.measured else options.noise_std
    measured = {"noise_estimate": sigma} if options.measured else {}
    return replace(
        evidence, counts=counts, results=results, experiment_time=identification.experiment_time,
        noise_ratio=sigma / amplitude, experiment_deviation=identification.experiment_deviation, **measured,
    )  # fmt: skip


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
    if options.disturbances.active or amplitude != 1.0 or options.production:
        attempts = DISTURBED_ATTEMPTS if options.disturbances.active else 1
        found = identify(plant, rng, noise_std, amplitude=amplitude, disturbances=options.disturbances, attempts=attempts,
                         deviation=options.production)
    else:
        found = identify(plant, rng, noise_std)  # the v0 call
    evidence = evidence_from_identification(found, options, amplitude)
    if options.least_squares:
        evidence = _with_fit(evidence, "open-loop-step", found.open_loop, amplitude)
        found = _least_squares_identification(found, evidence)
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


def _latest_model(evidence: Evidence, kind: str, result, amplitude: float) -> Evidence:
    """Agent mode with least squares: the evidence after ``kind`` ran, the latest model experiment
    deciding the design's model (a PRBS sets the fit, an experiment of the papers' formulas clears it)."""
    if kind == "prbs":
        return _with_fit(evidence, kind, result, amplitude)
    if kind in _SEEDS_MODEL_EXPERIMENTS[evidence.options.order]:
        return replace(evidence, fit=None)
    return evidence


def _with_fit(evidence: Evidence, kind: str, result, amplitude: float) -> Evidence:
    """The evidence with the least-squares fit of ``result``'s record (a PRBS's own fit, or the
    record fitted here), if it gives a model; else unchanged.

    An SOPDT fit without a model of two real lags (complex poles, a pole at or below 0: typical of
    a first-order record) falls back to the FOPDT fit, read as the SOPDT model with ``T_2 = 0``
    (Gorez-Klan eq. 2-2), as :meth:`baselines.rules.registry.RuleInputs.from_model` reads it.
    """
    if result.aborted:
        return evidence
    scale, order = evidence.closed_loop.residence_time, evidence.options.order
    fit = result.fit if kind == "prbs" else fit_record(result, scale, order)
    if order == 2 and (fit is None or fit.model is None):
        fit = fit_record(result, scale, 1)
    if fit is None or fit.model is None:
        return evidence
    return replace(evidence, fit=RecordFit(kind, fit, amplitude))


def _design_model(found: RecordFit, order: int):
    """The fit's model in the design's form: FOPDT (order 1), SOPDT (order 2; an FOPDT fit with ``T_2 = 0``)."""
    model = found.fit.model
    if order == 2 and isinstance(model, FOPDTModel):
        return SOPDTModel(gain=model.gain, time_constants=(model.time_constant, 0.0), dead_time=model.dead_time)
    return model


def _least_squares_identification(found: Identification, evidence: Evidence) -> Identification:
    """``found`` with the least-squares model in place of the papers' (FOPDT or SOPDT, by its order),
    and ``T_f_bar`` (eq. 22) of the open-loop step measured against it; unchanged without a fit."""
    if evidence.fit is None:
        return found
    model = _design_model(evidence.fit, evidence.options.order)
    if evidence.options.order == 2:
        return replace(found, sopdt=model)
    step: OpenLoopStepResult | None = evidence.results.get("open-loop-step")
    mismatch = math.nan
    if step is not None and step.settled:
        mismatch = mismatch_time(step.timepts, step.output / step.height, model)
    return replace(found, fopdt=model, mismatch_time=mismatch)


def _usable(result: ClosedLoopStepResult) -> bool:
    gain, scale = result.gain, result.residence_time
    return bool(np.isfinite(gain) and gain != 0 and np.isfinite(scale) and scale > 0 and not result.aborted)


def _run(kind: str, plant: Plant, rng: np.random.Generator, amplitude: float, evidence: Evidence, noise_std: float, limit: float):
    # Each experiment gets the episode's disturbances only when there are any, so that the v0
    # calls stay exactly what they were.
    extra = {"disturbances": evidence.options.disturbances} if evidence.options.disturbances.active else {}
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
            changes["noise_estimate"] = noise_level(result.output)
            changes["noise_ratio"] = changes["noise_estimate"] / amplitude
        elif kind == "closed-loop-step":
            changes["noise_ratio"] = noise_std / amplitude
    else:
        changes["aborted"] = evidence.aborted + 1
    evidence = replace(evidence, **changes)
    if usable and evidence.options.least_squares:
        evidence = _latest_model(evidence, kind, result, amplitude)
    return evidence


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
        found = _least_squares_identification(found, evidence)
    _require_design_model(found, evidence, structure)
    return found, evidence
