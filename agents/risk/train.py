"""``deadtime pretrain``: label, choose, fit and write the risk-conditioned learners of ``configs/risk_learner.yaml``.

Per structure of the config:

1. the training and validation plants of the config's two streams, labelled by the oracle's fast
   search and cached in ``LABELS/<STRUCTURE>/`` (:mod:`agents.risk.labels`; an interrupted run
   continues from the files written);
2. every candidate of ``models`` x ``bands`` x ``quantized_band`` fitted on the training plants
   (:func:`agents.risk.model.fit_learner`) and played on the validation plants, where a design
   violates when it is bolder than the plant's feasibility boundary (or the plant has no feasible
   design).  Its violation share is checked at every risk of :data:`RISKS` in :data:`CELLS` groups of
   the validation plants (all; the unquantized plants, as the regimes of the report are, per quarter
   of their noise levels; the quantized ones), each over the plants whose level the learner reaches
   (:meth:`agents.risk.model.RiskLearner.reachable`; the others it says unreachable).  A cell's miss is
   its share's distance outside ``[0.5 r, 1.5 r]`` in binomial standard errors at ``r``, so that a cell of
   few plants is not failed by its sampling noise alone; the candidates whose largest miss is at most
   :data:`MISS` keep their place (where none does, those of the least miss); their calibration error
   is the mean over cells and risks of ``z^2``, ``z`` the share's distance from ``r`` in those standard
   errors (about 1 for a learner calibrated in every cell, larger for one calibrated only on average:
   bolder in some cells, more conservative in others).  Only the candidates whose every band holds at
   least :func:`least_band` calibration plants are tried (:func:`choose`); among those within
   :data:`ERROR_NOISE` of the least error (which the validation plants cannot tell apart) the one of
   most bands is chosen, with the quantized band before without: a finer Mondrian taxonomy has its
   guarantee in each band, a coarser one only on the average over its bands, and the least band
   already bounds what a band's calibration costs in variance;
3. the chosen candidate (deterministic given the config's seed) is written as ``MODELS/learned-<structure>.skops`` and its manifest ``.json``
   (:mod:`agents.risk.pretrained`), with the config, the commit and the choice's table.

The plants never come from a test stream: both entropies are the config's own.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from agents.risk.config import RiskLearnerConfig

__all__ = ["CELLS", "ERROR_NOISE", "MISS", "NOISE_FEATURE", "RISKS", "choose", "label_violations", "least_band", "pretrain",
           "pretrain_structure"]

RISKS = (0.005, 0.01, 0.02, 0.05)
"""The declared risk levels the choice checks (those of :data:`agents.frontier.frontier.RISK_LEVELS`)."""

NOISE_FEATURE = "log_noise_ratio"

CELLS = ("all", "noise quarter 1", "noise quarter 2", "noise quarter 3", "noise quarter 4", "quantized")
"""The validation cells of the choice (the quarters: of the unquantized plants' noise levels)."""

MISS = 2.5
"""The largest miss of a candidate kept, in standard errors (about 1% of a calibrated cell's checks fail by chance)."""

ERROR_NOISE = 0.3
"""The calibration errors the choice does not tell apart: the standard deviation of a mean of 24 squared standard
normal deviates, ``sqrt(2 / 24)``, the cells' overlap aside."""


def least_band(risk: float = min(RISKS)) -> int:
    """The fewest calibration plants a band needs for its realized risk at ``risk`` to have a standard deviation of
    at most ``risk / 4`` (so that about 95% of the bands' realized risks fall within ``[0.5 r, 1.5 r]``).

    Given its ``n`` calibration plants, a band's split-conformal design violates on new plants of the band with
    probability ``Beta(l, n + 1 - l)`` distributed over the draws of those plants, ``l = floor((n + 1) r)`` (Vovk
    2012, "Conditional validity of inductive conformal predictors", section 2; Angelopoulos and Bates 2021,
    "A gentle introduction to conformal prediction", section 3.2): mean about ``r``, variance about
    ``r (1 - r) / n``.  ``r (1 - r) / n <= r^2 / 16`` gives ``n >= 16 (1 - r) / r`` (3184 at 0.5%)."""
    return math.ceil(round(16 * (1 - risk) / risk, 6))


def choose(candidates: dict[tuple[str, int, bool], dict[str, Any]], smallest: dict[tuple[str, int, bool], int],
           least: int | None = None) -> tuple[str, int, bool]:
    """The chosen ``(model, bands, quantized band)`` of the candidates' validation rows (:func:`_validate`), given each
    candidate's fewest calibration plants in a band (``smallest``): only those with at least ``least`` (default
    :func:`least_band`) are tried, or where none has, those of the largest smallest band; of these, those whose miss is
    at most :data:`MISS` (or else the least missing); of these, the finest taxonomy whose calibration error is within
    :data:`ERROR_NOISE` of the least (module docstring, step 2)."""
    least = least_band() if least is None else least
    tried = [key for key in candidates if smallest[key] >= least] or \
        [key for key in candidates if smallest[key] == max(smallest.values())]
    pool = [key for key in tried if candidates[key]["miss"] <= MISS] or [min(tried, key=lambda key: candidates[key]["miss"])]
    error = min(candidates[key]["error"] for key in pool)
    close = [key for key in pool if candidates[key]["error"] <= error + ERROR_NOISE]
    return max(close, key=lambda key: (key[1], key[2], -candidates[key]["error"]))


def label_violations(learner: Any, data: dict[str, np.ndarray], risk: float) -> np.ndarray:
    """Per plant, whether the learner's design at ``risk`` is bolder than the labelled feasibility boundary
    (always where no design is feasible)."""
    boundary = np.where(np.isfinite(data["boundary"]), data["boundary"], np.inf)
    return learner.design(data["observation"], risk) < boundary


def _cells(data: dict[str, np.ndarray]) -> list[np.ndarray]:
    """The masks of :data:`CELLS` over the validation plants."""
    plain = data["quantization"] <= 0
    edges = np.quantile(data["noise_std"][plain], [0.25, 0.5, 0.75]) if plain.any() else np.zeros(3)
    quarter = np.searchsorted(edges, data["noise_std"], side="right")
    return [np.ones(len(plain), bool), *(plain & (quarter == q) for q in range(4)), ~plain]


def _miss(violations: int, plants: int, risk: float) -> float:
    """The share's distance outside ``[0.5 r, 1.5 r]`` in standard errors ``sqrt(r (1 - r) / plants)``."""
    if plants == 0:
        return 0.0
    share, error = violations / plants, (risk * (1 - risk) / plants) ** 0.5
    return max(share - 1.5 * risk, 0.5 * risk - share, 0.0) / error


def _validate(learner: Any, data: dict[str, np.ndarray]) -> dict[str, Any]:
    """Per risk and cell of :data:`CELLS`, ``[plants reached, violating]``; the largest miss; the calibration error;
    the mean design action."""
    cells = _cells(data)
    found, miss, designs, squares = {}, 0.0, [], []
    for risk in RISKS:
        violates = label_violations(learner, data, risk)
        reached = learner.reachable(data["observation"], risk)
        counts = [[int((cell & reached).sum()), int((cell & reached & violates).sum())] for cell in cells]
        found[str(risk)] = counts
        miss = max(miss, *(_miss(k, n, risk) for n, k in counts))
        squares += [(k - n * risk) ** 2 / (n * risk * (1 - risk)) for n, k in counts if n]
        designs.append(float(learner.design(data["observation"], risk).mean()))
    return {"cells": list(CELLS), "reached_and_violating": found, "miss": round(miss, 3),
            "error": round(float(np.mean(squares)) if squares else 0.0, 3), "mean_design": round(float(np.mean(designs)), 5)}


def _feature_ranges(observations: np.ndarray, names: tuple[str, ...]) -> dict[str, list[float]]:
    """The checked plant features' ranges over the training observations (as the process's out-of-distribution
    check bounds a training family's, :func:`agents.evaluation.process_policies.out_of_distribution`)."""
    from agents.evaluation.process_policies import CHECKED_FEATURES, RANGE_QUANTILES

    return {name: [float(q) for q in np.quantile(observations[:, names.index(name)], RANGE_QUANTILES)]
            for name in CHECKED_FEATURES if name in names}


def _noise_index(env_id: str, env_kwargs: dict[str, Any]) -> tuple[int, float, float, tuple[str, ...]]:
    from agents.environments import make_env
    from envs.interface import tuning_env_of

    env = make_env(env_id, env_kwargs)
    try:
        env.reset(seed=0)
        names = tuple(tuning_env_of(env).feature_names)
        return names.index(NOISE_FEATURE), float(env.action_space.low[0]), float(env.action_space.high[0]), names
    finally:
        env.close()


def pretrain_structure(config: RiskLearnerConfig, structure: str, labels: Path, models: Path, *,
                       commit: str | None = None, log: Any = sys.stderr) -> Path:
    """Steps 1-3 of the module docstring for one structure; the manifest's path."""
    from agents.risk.labels import label_stream, records_arrays
    from agents.risk.model import conformalized, fit_regressions
    from agents.risk.pretrained import model_paths
    from agents.training.model_files import save_model_file

    env_id = config.env_id(structure)
    started = time.perf_counter()
    streams = {}
    for stream, entropy, count in (("training", config.training_entropy, config.training_plants),
                                   ("validation", config.validation_entropy, config.validation_plants)):
        streams[stream] = records_arrays(label_stream(labels, env_id, structure, stream, entropy, count,
                                                      base_kwargs=config.env_kwargs, draw_kwargs=config.draw_kwargs(), log=log))
    labelled = time.perf_counter()
    noise, low, high, names = _noise_index(env_id, config.env_kwargs)
    directions = {float(d) for d in streams["training"]["direction"]} - {0.0}
    if directions != {1.0}:
        raise ValueError(f"{env_id}: a larger action is not the more conservative design in every training episode")
    candidates, learners = {}, {}
    for kind in config.models:
        regressions = fit_regressions(streams["training"], kind, config.seed, tuple(config.splits))
        for bands in config.bands:
            for apart in config.quantized_band:
                key = (kind, int(bands), bool(apart))
                learners[key] = conformalized(regressions, int(bands), noise, low, high, bool(apart))
                candidates[key] = {**_validate(learners[key], streams["validation"]), "smallest_band": min(learners[key].band_sizes())}
                print(f"{structure} {kind} bands={bands} quantized_band={apart}: {candidates[key]}", file=log, flush=True)
    kind, bands, apart = choose(candidates, {key: row["smallest_band"] for key, row in candidates.items()})
    learner = learners[(kind, bands, apart)]
    fitted = time.perf_counter()
    model_path, manifest_path = model_paths(structure, models)
    models.mkdir(parents=True, exist_ok=True)
    save_model_file(model_path, manifest_path, learner, {
        "kind": "risk learner", "structure": structure, "env_id": env_id, "env_kwargs": dict(config.env_kwargs),
        "model": kind, "bands": bands, "quantized_band": apart, "noise_feature": NOISE_FEATURE, "directions": sorted(directions),
        "feature_ranges": _feature_ranges(streams["training"]["observation"], names),
        "config": config.to_dict(), "commit": commit,
        "choice": [{"model": k, "bands": b, "quantized_band": q, **row} for (k, b, q), row in candidates.items()],
        "chosen": {"model": kind, "bands": bands, "quantized_band": apart}, "least_band": least_band(),
        "seconds": {"labels": round(labelled - started, 1), "fit_and_choice": round(fitted - labelled, 1)},
    })
    print(f"{structure}: {kind}, {bands} band(s){' and a quantized band' if apart else ''} -> {model_path} ({model_path.stat().st_size} bytes)", file=log, flush=True)
    return manifest_path


def pretrain(config: RiskLearnerConfig, labels: Path, models: Path, structures: tuple[str, ...] | None = None) -> list[Path]:
    """:func:`pretrain_structure` for each structure of ``structures`` (default the config's); the manifests' paths."""
    from agents.runtime import git_commit

    commit = git_commit()
    return [pretrain_structure(config, structure, labels, models, commit=commit) for structure in structures or config.structures]
