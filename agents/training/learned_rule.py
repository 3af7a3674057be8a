"""``deadtime train`` with ``algorithm: learned-rule``: fit the learned rule (:mod:`baselines.learned_rule`).

::

    deadtime train --config configs/learned_rule.yaml --env DeadTime/FPPI-v0 [--out DIR] [--resume] [key=value ...]

The learned rule (:mod:`baselines.learned_rule`) is a regression from the observation to the
oracle's action, with a safety margin.  A fit, in the run directory:

1. **Training plants** (``training_plants``): plant ``k`` is drawn by the environment's own
   generator, ``env.reset(seed=TRAINING_SEED + seed * MAX_TRAINING_PLANTS + k)`` (so each config
   ``seed`` draws other plants, and plant ``k`` does not depend on how many are drawn).  An integer
   seed makes a ``numpy.random.default_rng`` stream, which never gives the fixed validation or test
   sets (:mod:`envs.systems.plant_sets`).  Each is labelled by the oracle of its identified model
   (:func:`agents.evaluation.oracle_info.oracle_info`): its relative parameter, mapped into the
   environment's action by the environment's own ``action_from_parameter``.  The config's ``labels``
   chooses the oracle's search: ``reference`` (the default, every committed fit) or ``fast``
   (:mod:`baselines.fast_search`, the same labels within the oracle's tolerance at a fraction of the
   time), whose records also hold the feasibility boundary (``boundary_parameter``, the least
   conservative feasible parameter, and its ``boundary_action``).  The labels are cached in
   ``dataset/training-<first>.json``, :data:`CHUNK` plants a file, each written atomically when
   complete: an interrupted fit resumes (``--resume``) from the files written, so at most one file
   of oracle searches is lost.
2. **Regressions**: each model kind of ``models`` is fitted to all training plants; with
   ``margin_scale: spread`` also the two quantile trees that scale the margin per plant
   (:func:`baselines.learned_rule.fit_spread`).
3. **Model and margin** on the validation plants (``validation_plants`` of the fixed validation
   set, played as ``deadtime train`` validates an agent: :mod:`agents.training.validation`): every
   kind with every margin of ``margins``; the lowest mean cost wins (:func:`baselines.learned_rule.select`),
   among the candidates whose violation rate is certified to be at most ``violation_target`` with
   ``violation_confidence`` when a target is set (Learn then Test; ``baselines.learned_rule``,
   "Certified margins").
   The plants played are recorded in ``validation_plants.json``.  No test plant is ever drawn.
4. ``learned_rule.skops`` and its manifest ``learned_rule.json``
   (:mod:`agents.training.learned_rule_policy`), ``evaluations.json`` (the chosen rule's validation,
   as an agent run's), ``run.json`` and ``config.yaml``.  ``deadtime evaluate --policies
   learned=DIR`` plays it.

Only the environment's interface is used (``observation_space``, ``action_space``,
``action_from_parameter``, ``parameter_from_action``) and the oracle, so any environment id with a
one-component action works; an action of more components (agent mode) is refused in one line.  The
conservative side of the action (larger ``mu`` or ``T_r``) is read from ``parameter_from_action``
in every training episode and must not change.

``--resume`` continues from the cached labels; ``training_plants`` (more plants: the first ones are
the same), ``validation_plants``, ``margins``, ``margin_scale``, ``models``, ``quantile``, ``violation_target``,
``violation_confidence``, ``output_dir`` and ``progress_bar`` may differ from the saved config (the model is then fitted again), the environment and the seed may not.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import sys
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from agents.files.lock import folder_lock
from agents.files.reader import FileProblem, read_json, read_record
from agents.files.writer import write_json, write_text
from agents.training.interrupts import StopRequest
from agents.training.learned_rule_config import MAX_TRAINING_PLANTS, LearnedRuleConfig, check_environment

if TYPE_CHECKING:
    from agents.training.train import TrainResult

__all__ = ["CHUNK", "TRAINING_SEED", "cached_labels", "certification_line", "check_environment", "fit", "label_direction",
           "labels_kept", "run_directory", "training_seed"]

TRAINING_SEED = 10_000_000
"""Reset seed of training plant ``k`` of config seed ``s``: ``TRAINING_SEED + s * MAX_TRAINING_PLANTS + k``
(apart from the validation episodes' ``3_000_000 + k`` and ``deadtime evaluate``'s ``seed + i``)."""

CHUNK = 50
"""Training plants per cached file of labels."""

_RESUMABLE_CHANGES = {"training_plants", "validation_plants", "margins", "margin_scale", "models", "quantile", "violation_target",
                      "violation_confidence", "output_dir", "progress_bar"}


def training_seed(seed: int, index: int) -> int:
    """The reset seed of training plant ``index`` of config seed ``seed``."""
    return TRAINING_SEED + seed * MAX_TRAINING_PLANTS + index


def run_directory(config: LearnedRuleConfig) -> Path:
    """The run directory of a config."""
    return Path(config.output_dir or Path("runs") / config.run_name)


# ----------------------------------------------------------------------------------- labels
def _direction(unwrapped: Any, low: float, high: float) -> float:
    """``+1`` if the parameter grows with the action in this episode, ``-1`` if it falls, ``0`` if both ends
    of the action give the same parameter (the robustness action where no target is met in the range)."""
    return float(np.sign(unwrapped.parameter_from_action(high) - unwrapped.parameter_from_action(low)))


def _label(env: Any, seed: int, index: int, search: str = "reference") -> dict[str, Any]:
    """One training plant drawn by the environment and its oracle's action (by the oracle's ``search``;
    the fast one also gives the feasibility boundary, as ``boundary_parameter`` and ``boundary_action``,
    None where no parameter is feasible)."""
    from agents.evaluation.oracle_info import oracle_info
    from envs.interface import tuning_env_of

    observation, _ = env.reset(seed=seed)
    unwrapped = tuning_env_of(env)
    found = oracle_info(unwrapped, search)
    low, high = float(env.action_space.low[0]), float(env.action_space.high[0])
    record = {"index": index, "seed": seed, "plant": unwrapped.plant.to_dict(),
              "observation": np.asarray(observation, dtype=float).tolist(), "oracle_parameter": found["oracle_parameter"],
              "oracle_cost": found["oracle_cost"], "action": _action(unwrapped, found["oracle_parameter"]),
              "direction": _direction(unwrapped, low, high)}
    if search == "fast":
        boundary = found["boundary_parameter"]
        record["boundary_parameter"] = boundary
        record["boundary_action"] = None if boundary is None else _action(unwrapped, boundary)
    return record


def _action(unwrapped: Any, parameter: float) -> float:
    """The environment's action of a relative parameter."""
    return float(np.asarray(unwrapped.action_from_parameter(parameter), dtype=float).reshape(-1)[0])


def _chunk_path(run_dir: Path, first: int) -> Path:
    return run_dir / "dataset" / f"training-{first:06d}.json"


def _records_digest(records: list[dict[str, Any]]) -> str:
    """The SHA-256 of the records as canonical JSON (keys sorted): what a chunk file records of itself."""
    return hashlib.sha256(json.dumps(records, sort_keys=True).encode()).hexdigest()


def _write_chunk(path: Path, records: list[dict[str, Any]]) -> None:
    """A chunk file of the label cache: the records and their checksum (:func:`_records_digest`)."""
    write_json(path, {"sha256": _records_digest(records), "records": records})


def _cached_chunk(path: Path, seeds: list[int]) -> list[dict[str, Any]]:
    """The cached records of a file, if its checksum holds and they are the first of ``seeds``; a file
    damaged (a digit changed, cut, unreadable), or of other plants, is said so and labelled again."""
    if not path.is_file():
        return []
    try:
        data = read_json(path, dict)
        records = data["records"]
        if data["sha256"] != _records_digest(records):
            raise FileProblem(f"{path} is damaged: its records differ from their SHA-256")
        records = records[: len(seeds)]
        if [record["seed"] for record in records] == seeds[: len(records)]:
            return records
        problem = f"{path} holds other plants"
    except (FileProblem, KeyError, TypeError) as error:
        problem = str(error) if isinstance(error, FileProblem) else f"{path} is damaged: not a chunk of labels"
    print(f"deadtime train: {problem}; labelling its plants again", file=sys.stderr)
    return []


def training_data(env: Any, config: LearnedRuleConfig, run_dir: Path) -> tuple[list[dict[str, Any]], int]:
    """The labelled training plants (from the cache where there), and how many were labelled now."""
    from tqdm import tqdm

    records: list[dict[str, Any]] = []
    labelled = 0
    # SIGINT/SIGTERM are taken between plants (StopRequest): a KeyboardInterrupt raised inside a compiled
    # (numba) call surfaces as a SystemError, and the labels of the chunk so far would be lost.
    with StopRequest("of the labels after the current plant") as stop, \
            tqdm(total=config.training_plants, desc="oracle on training plants", unit="plant", file=sys.stderr,
                 disable=not config.progress_bar) as bar:
        for first in range(0, config.training_plants, CHUNK):
            indices = range(first, min(first + CHUNK, config.training_plants))
            seeds = [training_seed(config.seed, k) for k in indices]
            path = _chunk_path(run_dir, first)
            chunk = _cached_chunk(path, seeds)
            bar.update(len(chunk))
            if len(chunk) < len(seeds):
                for k, seed in list(zip(indices, seeds))[len(chunk):]:
                    chunk.append(_label(env, seed, k, config.labels))
                    labelled += 1
                    bar.update()
                    if stop.requested:
                        _write_chunk(path, chunk)
                        raise KeyboardInterrupt
                _write_chunk(path, chunk)
            records += chunk
    return records, labelled


def cached_labels(config: LearnedRuleConfig, run_dir: Path) -> list[dict[str, Any]]:
    """The labelled training plants of ``config`` that the run directory's ``dataset/`` holds, in order
    (of a finished fit: every one it was fitted on)."""
    records: list[dict[str, Any]] = []
    for first in range(0, config.training_plants, CHUNK):
        seeds = [training_seed(config.seed, k) for k in range(first, min(first + CHUNK, config.training_plants))]
        records += _cached_chunk(_chunk_path(run_dir, first), seeds)
    return records


def labels_kept(config: LearnedRuleConfig, run_dir: Path) -> int:
    """How many training plants' labels the run directory holds (for the line after an interruption)."""
    return len(cached_labels(config, run_dir))


# ----------------------------------------------------------------------------------- the fit
def label_direction(records: list[dict[str, Any]]) -> float:
    """The conservative direction of the action shared by the labelled episodes (those where it is defined)."""
    found = {record["direction"] for record in records} - {0.0}
    if len(found) != 1:
        raise ValueError("the environment's conservative direction of the action (from parameter_from_action) changes "
                         "between episodes; the learned rule's margin needs one direction")
    return float(found.pop())


class _Remembered:
    """A fitted regression that remembers its predictions by input, so that the margins of one model
    kind share them on the validation plants (the trees' prediction of one row costs milliseconds)."""

    def __init__(self, model: Any) -> None:
        self.model, self.seen = model, {}

    def predict(self, rows: np.ndarray) -> np.ndarray:
        key = (rows.shape, rows.tobytes())
        if key not in self.seen:
            self.seen[key] = self.model.predict(rows)
        return self.seen[key]


def _select(env: Any, config: LearnedRuleConfig, records: list[dict[str, Any]], run_dir: Path) -> tuple[Any, Any, Any]:
    """Fit every model kind, then choose kind and margin on the validation plants: ``(selection, validation, plants)``."""
    from agents.training.validation import VALIDATION_SEED, validate_policy, validation_plants
    from baselines.learned_rule import LearnedRule, Validated, fit_regression, fit_spread, select

    observations = np.array([record["observation"] for record in records])
    actions = np.array([record["action"] for record in records])
    low, high = float(env.action_space.low[0]), float(env.action_space.high[0])
    direction = label_direction(records)
    spread = None
    if config.margin_scale == "spread":
        fitted = fit_spread(observations, actions, config.seed, config.quantile)
        spread = dataclasses.replace(fitted, upper=_Remembered(fitted.upper), lower=_Remembered(fitted.lower))
    rules = [LearnedRule(kind, _Remembered(fit_regression(kind, observations, actions, config.seed, config.quantile)), 0.0,
                         direction, low, high, observations.shape[1], spread) for kind in config.models]
    plants = validation_plants(env, config.validation_plants)
    if plants is not None:
        write_json(run_dir / "validation_plants.json",
                   [{"seed": VALIDATION_SEED + k, "plant": plant.to_dict()} for k, plant in enumerate(plants)])
    results: dict[tuple[str, float], Any] = {}

    def validate(rule: Any) -> Validated:
        result = validate_policy(rule.predict, env, config.validation_plants, plants, len(records))
        results[(rule.kind, rule.margin)] = result
        if result.violation_rate is None and config.violation_target is not None:
            raise ValueError(f"violation_target: {config.env_id} reports no feasibility (info['feasible']) to certify")
        violations = round((result.violation_rate or 0.0) * len(result.costs))
        return Validated(result.mean_cost, violations, len(result.costs))

    selection = select(rules, config.margins, validate, violation_target=config.violation_target,
                       confidence=config.violation_confidence)
    chosen = dataclasses.replace(selection.rule, model=selection.rule.model.model, spread=None if spread is None else
                                 dataclasses.replace(spread, upper=spread.upper.model, lower=spread.lower.model))
    return dataclasses.replace(selection, rule=chosen), results[(chosen.kind, chosen.margin)], plants


def fit(config: LearnedRuleConfig, *, resume: bool = False, command: str | None = None) -> TrainResult:
    """Fit the learned rule of ``config`` in its run directory (module docstring); a
    :class:`agents.training.train.TrainResult` whose steps are the training plants and whose costs are
    the chosen rule's mean validation cost.

    Raises
    ------
    ValueError
        If the config is refused (naming the key), the run directory holds another run and
        ``resume`` is False, or ``resume`` is True with another environment or seed.
    """
    from agents.training.config import validate

    validate(config)
    run_dir = run_directory(config)
    with folder_lock(run_dir, "train"):  # before the folder is checked: a second fit on it is refused
        return _fit(config, run_dir, resume, command)


def _fit(config: LearnedRuleConfig, run_dir: Path, resume: bool, command: str | None) -> TrainResult:
    """:func:`fit` in ``run_dir``, whose lock is held."""
    from agents.training.train import TrainResult, announce_config, run_provenance

    finished = _existing_run(config, run_dir, resume)
    if finished is not None:
        print(f"{run_dir} already holds this learned rule (fit finished)")
        return finished
    provenance = run_provenance(command)
    text = announce_config(config, provenance)
    env = check_environment(config)
    try:
        run_dir.mkdir(parents=True, exist_ok=True)
        write_text(run_dir / "config.yaml", text)
        started, cpu_started = time.perf_counter(), time.process_time()
        records, labelled = training_data(env, config, run_dir)
        labels_done, cpu_labels_done = time.perf_counter(), time.process_time()
        selection, validation, _ = _select(env, config, records, run_dir)
    finally:
        env.close()
    seconds = {"labels": labels_done - started, "fit_and_selection": time.perf_counter() - labels_done,
               "labels_cpu": cpu_labels_done - cpu_started, "fit_and_selection_cpu": time.process_time() - cpu_labels_done}
    _write_outputs(config, run_dir, selection, validation, provenance, seconds, labelled)
    total = seconds["labels"] + seconds["fit_and_selection"]
    return TrainResult(run_dir=run_dir, num_timesteps=config.training_plants, session_steps=labelled, train_seconds=total,
                       steps_per_second=labelled / total if labelled else float("nan"),
                       best_cost=validation.mean_cost, final_cost=validation.mean_cost)


def _existing_run(config: LearnedRuleConfig, run_dir: Path, resume: bool) -> TrainResult | None:
    """Check (reading only) that the run directory fits; the finished result if it holds this very fit."""
    from agents.training.config import load_config
    from agents.training.train import TrainResult

    saved = run_dir / "config.yaml"
    if not resume:
        if saved.exists() or (run_dir / "dataset").exists():
            raise ValueError(f"{run_dir} already holds a run; pass --resume to continue it, or choose another --out")
        return None
    if not saved.is_file():
        return None
    previous = load_config(saved)
    changed = [f.name for f in dataclasses.fields(LearnedRuleConfig)
               if f.name not in _RESUMABLE_CHANGES and getattr(previous, f.name, None) != getattr(config, f.name)]
    if not isinstance(previous, LearnedRuleConfig) or changed:
        raise ValueError(f"cannot resume {run_dir}: the config differs from the saved one in {', '.join(changed) or 'algorithm'}")
    record = read_record(run_dir / "run.json", dict)
    if record is None or not (run_dir / "evaluations.json").is_file():
        return None
    evaluations = read_json(run_dir / "evaluations.json", list)
    saved_config = record.get("config")
    if isinstance(saved_config, dict):  # a fit from before the key had a constant margin
        saved_config = {"margin_scale": "constant", **saved_config}
    if isinstance(saved_config, dict):  # a fit from before the key labelled by the reference search
        saved_config = {"labels": "reference", **saved_config}
    if record.get("status") != "finished" or saved_config != {**config.to_dict(), "output_dir": None, "progress_bar": None}:
        return None
    cost = float(evaluations[-1]["mean_cost"])
    return TrainResult(run_dir=run_dir, num_timesteps=config.training_plants, session_steps=0, train_seconds=0.0,
                       steps_per_second=float("nan"), best_cost=cost, final_cost=cost)


def _write_outputs(config: LearnedRuleConfig, run_dir: Path, selection: Any, validation: Any,
                   provenance: dict[str, Any], seconds: dict[str, float], labelled: int) -> None:
    """The model and its manifest, ``evaluations.json`` and ``run.json`` (written last: it marks the fit finished)."""
    from agents.training.learned_rule_policy import save_learned_rule

    rule = selection.rule
    chosen = {key: value for key, value in validation.to_dict().items() if key != "costs"}
    save_learned_rule(run_dir, rule, {
        "env_id": config.env_id, "env_kwargs": dict(config.env_kwargs), "seed": config.seed, "kind": rule.kind,
        "margin": rule.margin, "margin_scale": rule.margin_scale, "direction": rule.direction, "action_bounds": [rule.low, rule.high],
        "observation_size": rule.observation_size, "training_plants": config.training_plants,
        "validation_plants": config.validation_plants, "quantile": config.quantile, "commit": provenance["commit"],
        "validation": {"margins": list(selection.margins), "mean_cost": {k: list(v) for k, v in selection.costs.items()},
                       "violations": {k: list(v) for k, v in selection.violations.items()}, "chosen": chosen},
        "certification": _certification(selection),
    })
    write_json(run_dir / "evaluations.json", [chosen])
    write_json(run_dir / "run.json", {
        "algorithm": config.algorithm, "env_id": config.env_id, "seed": config.seed, "status": "finished",
        "num_timesteps": config.training_plants, "config": {**config.to_dict(), "output_dir": None, "progress_bar": None},
        "command": provenance["command"], "commit": provenance["commit"], "versions": provenance["versions"],
        "started": provenance["started"], "plants_labelled": labelled,
        "seconds": {key: round(value, 3) for key, value in seconds.items()},
        "finished_at": datetime.now(UTC).isoformat(timespec="seconds"),
    })


def _certification(selection: Any) -> dict[str, Any] | None:
    """The manifest's record of the violation certificate (None without a target)."""
    from baselines.learned_rule import kind_confidence, violation_bound

    if selection.violation_target is None:
        return None
    rule = selection.rule
    violations = selection.violations[rule.kind][selection.margins.index(rule.margin)]
    level = kind_confidence(selection.confidence, len(selection.costs))  # as select tested each kind
    return {"violation_target": selection.violation_target, "confidence": selection.confidence,
            "method": "learn-then-test, fixed sequence from the largest margin, Bonferroni over kinds",
            "certified": selection.is_certified, "violations": violations, "plants": selection.plants,
            "violation_bound": violation_bound(violations, selection.plants, level),
            "certified_margins": {k: [m for m, ok in zip(selection.margins, v) if ok] for k, v in selection.certified.items()}}


def certification_line(certification: dict[str, Any] | None) -> str:
    """One line on the certificate of a fitted rule ('' without a target)."""
    if not certification:
        return ""
    share = f"{certification['violations']} of {certification['plants']} validation plants violate"
    if certification["certified"]:
        return (f"certified: violation rate <= {certification['violation_target']:.3g} with confidence "
                f"{certification['confidence']:.3g} ({share})")
    return (f"NOT certified: no margin of the list has a violation rate <= {certification['violation_target']:.3g} with "
            f"confidence {certification['confidence']:.3g}; chosen the fewest violations ({share}); add larger margins or "
            f"more validation plants")
