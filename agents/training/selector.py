"""``deadtime train`` with ``algorithm: selector``: fit a per-plant choice among candidate designs.

::

    deadtime train --config configs/selector.yaml --env DeadTime/PID-v3 [--out DIR] [--seed N] [key=value ...]

A textbook rule is safe on most plants and cheap there; a learned design is safer where the rule
breaks the constraints.  A selector keeps each where it is good: per plant, from the observation
alone, it chooses one of its ``candidates`` (rules by name, and learned designs).  A fit, in the run
directory:

1. **The learned candidates.**  ``learned`` is fitted first, into ``RUN/learned``
   (:func:`agents.training.learned_rule.fit` of ``learned_config`` with ``learned_overrides``, on the
   selector's environment, arguments and seed); a ``NAME=PATH`` candidate is a finished learned-rule
   fit, of the same environment and arguments.
2. **Training plants** (``training_plants``): plant ``k`` is training plant ``TRAINING_OFFSET + k`` of the
   seed (:func:`agents.training.learned_rule.training_seed`), so that they are not those a learned
   design of the same seed was fitted on (its first ones): each episode is reset once, and every candidate
   designs on its identification and is scored on the true plant by the environment's
   ``score_controller`` (a rule as ``deadtime evaluate`` scores it, :func:`agents.evaluation.run.rule_result`;
   a learned design as its step would), so all pay the same experiments.
3. **Models**, per candidate, from the observation (``sklearn.ensemble.HistGradientBoostingClassifier``
   and ``HistGradientBoostingRegressor``, ``random_state`` the seed): the probability that it violates
   a constraint, and its cost on the plants where it does not.  The choice rule:
   :class:`agents.training.selector_policy.Selector`.
4. **The threshold**, on ``validation_plants`` of the fixed validation set (played as a learned
   rule's validation): each threshold of ``thresholds`` gives a choice per plant, its mean cost and its
   violating plants.  With a ``violation_target``, the thresholds are tested in the order given
   (fixed-sequence testing: a threshold is certified while the one-sided Clopper-Pearson bound of its
   violating plants, :func:`baselines.learned_rule.violation_bound`, stays at most the target, and the
   sequence stops at the first that fails), and the certified one of least mean cost is chosen; if
   none is certified, the one of fewest violations.  Without a target, the least mean cost.
5. ``selector.skops`` and its manifest ``selector.json`` (:mod:`agents.training.selector_policy`) with the
   validation table (per threshold: mean cost, violating plants, bound, the share of plants given to
   each candidate), ``evaluations.json``, ``run.json`` and ``config.yaml``.  ``deadtime evaluate
   --policies selector=DIR`` plays it.

No test plant is drawn.  A fit is not resumed in parts: ``--resume`` reads back a finished fit (and its
own learned design's), and fits again otherwise.
"""

from __future__ import annotations

import dataclasses
import sys
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from agents.files.lock import folder_lock
from agents.files.reader import read_json, read_record
from agents.files.writer import write_json, write_text
from agents.training.selector_config import LEARNED, SelectorConfig, validate_selector
from envs.interface import episode_of, tuning_env_of

if TYPE_CHECKING:
    from agents.training.train import TrainResult

__all__ = ["MIN_FEASIBLE", "TRAINING_OFFSET", "fit", "run_directory", "score_candidates", "threshold_table"]

TRAINING_OFFSET = 500_000
"""The index of the selector's first training plant among the seed's (a learned design's fit uses the first ones)."""

MIN_FEASIBLE = 20
"""The fewest plants on which a candidate does not violate for its cost to be regressed (else their mean)."""


def run_directory(config: SelectorConfig) -> Path:
    """The run directory of a config."""
    return Path(config.output_dir or Path("runs") / config.run_name)


# ----------------------------------------------------------------------------------- candidates
def _learned_candidates(config: SelectorConfig, run_dir: Path, command: str | None) -> dict[str, Any]:
    """The learned designs among the candidates by name (the own one fitted, or read back, first)."""
    from agents.training.config import load_config
    from agents.training.learned_rule import fit as fit_learned_rule
    from agents.training.learned_rule_policy import load_learned_rule

    learned = {}
    for candidate in config.candidates:
        if candidate == LEARNED:
            overrides = [*config.learned_overrides, f"seed={config.seed}", f"output_dir={run_dir / LEARNED}",
                         f"progress_bar={str(config.progress_bar).lower()}"]
            own = load_config(config.learned_config, env_id=config.env_id, overrides=overrides)
            own = dataclasses.replace(own, env_kwargs={**dict(own.env_kwargs), **dict(config.env_kwargs)})
            fit_learned_rule(own, resume=True, command=command)
            learned[LEARNED] = load_learned_rule(run_dir / LEARNED)
        elif "=" in candidate:
            name, path = candidate.split("=", 1)
            policy = load_learned_rule(path.replace("{seed}", str(config.seed)))
            if (policy.env_id, dict(policy.env_kwargs)) != (config.env_id, dict(config.env_kwargs)):
                raise ValueError(f"candidates: {name} was fitted on {policy.env_id} {dict(policy.env_kwargs)}, "
                                 f"not the selector's {config.env_id} {dict(config.env_kwargs)}")
            learned[name] = policy
    return learned


def score_candidates(env: Any, names: tuple[str, ...], learned: dict[str, Any], episodes: list[tuple[int, Any]],
                     progress: Any = None) -> dict[str, np.ndarray]:
    """Per episode ``(reset seed, plant or None)``: the observation, and every candidate's cost and
    feasibility on one identification (module docstring, step 2)."""
    from agents.evaluation.run import rule_result

    observations, costs, feasible = [], [], []
    for seed, plant in episodes:
        observation, _ = env.reset(seed=seed, options=None if plant is None else {"plant": plant})
        episode = episode_of(env)
        row = []
        if episode.identification is None:  # the procedure failed: no candidate designs
            info = env.step(np.zeros(env.action_space.shape, dtype=np.float32))[4]
            row = [(float(info["cost"]), False)] * len(names)
        else:
            experiment_time = episode.evidence.experiment_time / episode.plant.residence_time
            for name in names:
                if name in learned:
                    row.append(_learned_score(env, learned[name], observation))
                else:
                    result = rule_result(env, name, experiment_time)
                    row.append((result.cost, result.feasible))
        observations.append(np.asarray(observation, dtype=float))
        costs.append([cost for cost, _ in row])
        feasible.append([ok for _, ok in row])
        if progress is not None:
            progress()
    return {"observation": np.array(observations), "cost": np.array(costs, dtype=float), "feasible": np.array(feasible, dtype=bool)}


def _learned_score(env: Any, policy: Any, observation: np.ndarray) -> tuple[float, bool]:
    """The cost and feasibility of a learned design's action, as its step would score it (float32, clipped)."""
    action = float(np.clip(np.asarray(policy.predict(observation)[0], dtype=np.float32).reshape(-1)[0], -1.0, 1.0))
    score = tuning_env_of(env).score_action(action)[2]
    return float(score.cost), bool(score.feasible)


# ----------------------------------------------------------------------------------- models and threshold
def fit_models(data: dict[str, np.ndarray], seed: int) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
    """Per candidate: the classifier of "violates" and the regression of the cost where it does not (module docstring, step 3)."""
    from sklearn.ensemble import HistGradientBoostingClassifier, HistGradientBoostingRegressor

    x, cost, feasible = data["observation"], data["cost"], data["feasible"]
    violation_models, cost_models = [], []
    for k in range(cost.shape[1]):
        violates = ~feasible[:, k]
        if violates.all() or not violates.any():
            violation_models.append(float(violates.mean()))
        else:
            violation_models.append(HistGradientBoostingClassifier(random_state=seed).fit(x, violates))
        ok = feasible[:, k]
        if ok.sum() >= MIN_FEASIBLE:
            cost_models.append(HistGradientBoostingRegressor(random_state=seed).fit(x[ok], cost[ok, k]))
        else:
            cost_models.append(float(cost[ok, k].mean()) if ok.any() else float(cost[:, k].mean()))
    return tuple(violation_models), tuple(cost_models)


def threshold_table(selector: Any, data: dict[str, np.ndarray], thresholds: tuple[float, ...], target: float | None,
                    confidence: float) -> tuple[list[dict[str, Any]], int]:
    """Per threshold its row on the validation plants, and the index of the chosen row (module docstring, step 4)."""
    from agents.training.selector_policy import choose
    from baselines.learned_rule import violation_bound

    p, c = selector.predictions(data["observation"])
    rows, plants = [], len(data["cost"])
    for threshold in thresholds:
        chosen = choose(p, c, threshold)
        cost, feasible = data["cost"][np.arange(plants), chosen], data["feasible"][np.arange(plants), chosen]
        violations = int((~feasible).sum())
        rows.append({"threshold": threshold, "mean_cost": float(cost.mean()), "violating_plants": violations, "plants": plants,
                     "violation_bound": violation_bound(violations, plants, confidence),
                     "shares": {name: float(np.mean(chosen == k)) for k, name in enumerate(selector.names)}})
    if target is None:
        return rows, min(range(len(rows)), key=lambda i: rows[i]["mean_cost"])
    certified = []
    for i, row in enumerate(rows):  # fixed-sequence testing: stop at the first threshold not certified
        row["certified"] = row["violation_bound"] <= target and len(certified) == i
        if row["certified"]:
            certified.append(i)
    if certified:
        return rows, min(certified, key=lambda i: rows[i]["mean_cost"])
    return rows, min(range(len(rows)), key=lambda i: (rows[i]["violating_plants"], rows[i]["mean_cost"]))


# ----------------------------------------------------------------------------------- the fit
def fit(config: SelectorConfig, *, resume: bool = False, command: str | None = None) -> TrainResult:
    """Fit the selector of ``config`` in its run directory (module docstring); a
    :class:`agents.training.train.TrainResult` whose steps are the training plants and whose costs are
    the chosen threshold's mean validation cost.

    Raises
    ------
    ValueError
        If the config is refused (naming the key), or the run directory holds another run and
        ``resume`` is False.
    """
    validate_selector(config)
    run_dir = run_directory(config)
    with folder_lock(run_dir, "train"):
        return _fit(config, run_dir, resume, command)


def _fit(config: SelectorConfig, run_dir: Path, resume: bool, command: str | None) -> TrainResult:
    from tqdm import tqdm

    from agents.environments import make_env
    from agents.training.learned_rule import training_seed
    from agents.training.selector_policy import Selector, save_selector
    from agents.training.train import TrainResult, announce_config, run_provenance
    from agents.training.validation import VALIDATION_SEED, validation_plants

    finished = _finished(config, run_dir, resume)
    if finished is not None:
        print(f"{run_dir} already holds this selector (fit finished)")
        return finished
    provenance = run_provenance(command)
    text = announce_config(config, provenance)
    run_dir.mkdir(parents=True, exist_ok=True)
    write_text(run_dir / "config.yaml", text)
    started = time.perf_counter()
    learned = _learned_candidates(config, run_dir, command)
    names = config.candidate_names()
    env = make_env(config.env_id, config.env_kwargs)
    try:
        plants = validation_plants(env, config.validation_plants)
        episodes = {"training": [(training_seed(config.seed, TRAINING_OFFSET + k), None) for k in range(config.training_plants)],
                    "validation": [(VALIDATION_SEED + k, plant) for k, plant in enumerate(plants)]}
        data = {}
        for part, items in episodes.items():
            with tqdm(total=len(items), desc=f"candidates on {part} plants", unit="plant", file=sys.stderr,
                      disable=not config.progress_bar) as bar:
                data[part] = score_candidates(env, names, learned, items, bar.update)
    finally:
        env.close()
    violation_models, cost_models = fit_models(data["training"], config.seed)
    rules = tuple(None if name in learned else name for name in names)
    selector = Selector(names, rules, {name: policy.rule for name, policy in learned.items()}, violation_models, cost_models)
    rows, index = threshold_table(selector, data["validation"], config.thresholds, config.violation_target,
                                  config.violation_confidence)
    selector = dataclasses.replace(selector, threshold=rows[index]["threshold"])
    chosen = rows[index]
    save_selector(run_dir, selector, {
        "env_id": config.env_id, "env_kwargs": dict(config.env_kwargs), "seed": config.seed, "candidates": list(names),
        "threshold": chosen["threshold"], "training_plants": config.training_plants, "validation_plants": len(plants),
        "violation_target": config.violation_target, "confidence": config.violation_confidence,
        "certified": bool(chosen.get("certified", config.violation_target is None)), "validation": rows,
        "training": {"violation_rate": dict(zip(names, (1 - data["training"]["feasible"].mean(axis=0)).tolist())),
                     "mean_cost": dict(zip(names, data["training"]["cost"].mean(axis=0).tolist()))},
        "commit": provenance["commit"],
    })
    evaluation = {"num_timesteps": config.training_plants, "mean_cost": chosen["mean_cost"],
                  "violation_rate": chosen["violating_plants"] / chosen["plants"], "shares": chosen["shares"]}
    write_json(run_dir / "evaluations.json", [evaluation])
    seconds = time.perf_counter() - started
    write_json(run_dir / "run.json", {
        "algorithm": config.algorithm, "env_id": config.env_id, "seed": config.seed, "status": "finished",
        "num_timesteps": config.training_plants, "config": {**config.to_dict(), "output_dir": None, "progress_bar": None},
        "command": provenance["command"], "commit": provenance["commit"], "versions": provenance["versions"],
        "started": provenance["started"], "seconds": round(seconds, 3),
        "finished_at": datetime.now(UTC).isoformat(timespec="seconds"),
    })
    print(_summary_line(chosen, config))
    return TrainResult(run_dir=run_dir, num_timesteps=config.training_plants, session_steps=config.training_plants,
                       train_seconds=seconds, steps_per_second=config.training_plants / seconds,
                       best_cost=chosen["mean_cost"], final_cost=chosen["mean_cost"])


def _summary_line(row: dict[str, Any], config: SelectorConfig) -> str:
    shares = ", ".join(f"{name} {share:.0%}" for name, share in row["shares"].items())
    certified = "" if config.violation_target is None else (
        f"; {'certified' if row['certified'] else 'NOT certified'}: bound {row['violation_bound']:.3g} "
        f"on the share of violating plants (target {config.violation_target:g})")
    return (f"selector: threshold {row['threshold']:g}, validation mean cost {row['mean_cost']:.6g}, {row['violating_plants']} "
            f"of {row['plants']} plants violating{certified}; plants given to {shares}")


def _finished(config: SelectorConfig, run_dir: Path, resume: bool) -> TrainResult | None:
    """The finished result if ``run_dir`` holds this very fit (with ``resume``); refuses another run without it."""
    from agents.training.train import TrainResult

    if not resume:
        if (run_dir / "config.yaml").exists():
            raise ValueError(f"{run_dir} already holds a run; pass --resume to continue it, or choose another --out")
        return None
    record = read_record(run_dir / "run.json", dict)
    if (record is None or record.get("status") != "finished" or not (run_dir / "evaluations.json").is_file()
            or record.get("config") != {**config.to_dict(), "output_dir": None, "progress_bar": None}):
        return None
    cost = float(read_json(run_dir / "evaluations.json", list)[-1]["mean_cost"])
    return TrainResult(run_dir=run_dir, num_timesteps=config.training_plants, session_steps=0, train_seconds=0.0,
                       steps_per_second=float("nan"), best_cost=cost, final_cost=cost)
