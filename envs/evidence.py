"""What an episode has measured so far: :class:`Evidence`, the latest result of each experiment type.

:mod:`envs.episode` runs the experiments and identifies from the evidence; :mod:`envs.episode_features`
turns it into the observation's features; :mod:`envs.episode_fits` adds the least-squares fits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from envs.episode_options import DEFAULT_OPTIONS, EpisodeOptions
from envs.identification.closed_loop_experiment import ClosedLoopStepResult
from envs.identification.least_squares import LeastSquaresFit

__all__ = ["STABLE_EXPERIMENTS", "INTEGRATING_EXPERIMENTS", "LEAST_SQUARES_EXPERIMENTS", "RecordFit", "Evidence"]

STABLE_EXPERIMENTS: tuple[str, ...] = ("closed-loop-step", "open-loop-step", "open-loop-ramp", "relay")
INTEGRATING_EXPERIMENTS: tuple[str, ...] = ("closed-loop-step", "pulse", "relay")
LEAST_SQUARES_EXPERIMENTS: tuple[str, ...] = (*STABLE_EXPERIMENTS, "prbs")
"""The experiment types with ``identification="least-squares"`` (self-regulating plants only)."""


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
