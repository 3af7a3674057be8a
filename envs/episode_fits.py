"""The least-squares fits of an episode's records (``identification="least-squares"``).

With the least-squares identification the design reads the model of the latest experiment that gives
one: a PRBS fitted by least squares, or the papers' experiments by their formulas
(:class:`envs.episode_options.EpisodeOptions`); the fixed mode fits its open-loop step's record.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import TYPE_CHECKING

from envs.evidence import Evidence, RecordFit
from envs.identification.models import FOPDTModel, SOPDTModel
from envs.identification.open_loop_areas import mismatch_time
from envs.identification.prbs_experiment import fit_record
from envs.identification.procedure import Identification

if TYPE_CHECKING:
    from envs.identification.open_loop_step import OpenLoopStepResult

__all__ = ["RecordFit", "latest_model", "with_fit", "least_squares_identification"]

_SEEDS_MODEL_EXPERIMENTS = {1: ("open-loop-step", "open-loop-ramp"), 2: ("closed-loop-step",)}
"""With ``identification="least-squares"`` in agent mode, the design reads the model of the latest
experiment that gives one: a PRBS (least squares), or these (the papers' formulas; by the order of
the design's model: the FPPI's FOPDT model, the PID's SOPDT model)."""


def latest_model(evidence: Evidence, kind: str, result, amplitude: float) -> Evidence:
    """Agent mode with least squares: the evidence after ``kind`` ran, the latest model experiment
    deciding the design's model (a PRBS sets the fit, an experiment of the papers' formulas clears it)."""
    if kind == "prbs":
        return with_fit(evidence, kind, result, amplitude)
    if kind in _SEEDS_MODEL_EXPERIMENTS[evidence.options.order]:
        return replace(evidence, fit=None)
    return evidence


def with_fit(evidence: Evidence, kind: str, result, amplitude: float) -> Evidence:
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


def least_squares_identification(found: Identification, evidence: Evidence) -> Identification:
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
