"""A learned design with a fallback to a rule, measured on validation plants only.

    deadtime study fallback RUN_DIR... [--rule simc-pi] [--safe 0.1] [--out DIR]

Each ``RUN_DIR`` is a learned-rule fit (``deadtime train --config configs/learned_plan.yaml ...``), one
per training seed of the same config: its environment, regime, plan, seed and validation plants are
read from its ``config.yaml``.  The rule designs on the same identification as the learned design
(the plan's experiments), so both pay the same experiments, and both are scored by the environment's
``score_controller`` on the true plant.

1. **Where the rule is safe.**  The rule is played on the fit's training plants (the same reset seeds,
   :func:`agents.training.learned_rule.training_seed`); a gradient-boosted classifier
   (``sklearn.ensemble.HistGradientBoostingClassifier``) learns from the observation whether its loop
   violates a constraint.  The rule counts as safe on a plant where that probability is below
   ``--safe`` (fixed before looking: 0.1).
2. **On the validation plants** (the fit's ``validation_plants`` of the fixed validation set, as
   ``deadtime train`` plays them): the learned design's and the rule's cost and feasibility on each.
   Compared, paired on these plants, with the learned design:

   * ``rule where safe``: the rule where it is predicted safe, else the learned design;
   * ``cheaper where safe``: where the rule is predicted safe, the rule if a second classifier
     predicts it cheaper than the learned design, else the learned design.  The second classifier
     learns from validation plants on which the rule is feasible, cross-fitted in two folds (even
     and odd plants): each plant's choice comes from the fold it is not in;
   * ``per-plant best``: the cheaper of the two where the rule is feasible, else the learned design
     (a bound no policy reaches: it reads the true plant).

Over the fits' seeds and the validation plants: mean cost, violation rate, the share of plants given to
the rule, and the paired difference to the learned design with its 95% percentile interval from a
two-way bootstrap of the sweeps' summaries (``agents.evaluation.seed_statistics.bootstrap_interval``:
seeds and plants resampled whole, 2000 resamples, seed 0), and the range of the per-seed
differences.  No test plant is drawn.  Prints a Markdown table; ``--out DIR`` writes it to
``DIR/fallback.md`` and the rows, each seed's too, with the fits and the settings to
``DIR/fallback.json``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from agents.evaluation.seed_statistics import bootstrap_interval
from agents.files.reader import load_yaml_file, read_json


def _rule(env: Any, name: str) -> tuple[float, bool]:
    from agents.evaluation.run import rule_result

    result = rule_result(env, name, 0.0)
    return result.cost, result.feasible


def rule_labels(env: Any, config: dict[str, Any], rule: str) -> tuple[np.ndarray, np.ndarray]:
    """The observations of the fit's training plants and whether the rule violates on each."""
    from agents.training.learned_rule import training_seed

    observations, violates = [], []
    for k in range(config["training_plants"]):
        observation, _ = env.reset(seed=training_seed(config["seed"], k))
        observations.append(observation)
        violates.append(not _rule(env, rule)[1])
    return np.asarray(observations), np.asarray(violates)


def validation_episodes(env: Any, policy: Any, n: int, rule: str) -> dict[str, np.ndarray]:
    """Per validation plant: the observation, the rule's and the learned design's cost and feasibility."""
    from agents.training.validation import VALIDATION_SEED, validation_plants

    rows = []
    for k, plant in enumerate(validation_plants(env, n)):
        observation, _ = env.reset(seed=VALIDATION_SEED + k, options={"plant": plant})
        rule_cost, rule_feasible = _rule(env, rule)  # scores a controller, the episode goes on
        action, _ = policy.predict(observation)
        info = env.step(action)[4]
        rows.append((observation, rule_cost, rule_feasible, info["cost"], info["feasible"]))
    observations, *columns = zip(*rows)
    names = ("rule_cost", "rule_feasible", "learned_cost", "learned_feasible")
    return {"observation": np.asarray(observations), **{name: np.asarray(column) for name, column in zip(names, columns)}}


def _classifier() -> Any:
    from sklearn.ensemble import HistGradientBoostingClassifier

    return HistGradientBoostingClassifier(random_state=0)


def rule_cheaper(episodes: dict[str, np.ndarray]) -> np.ndarray:
    """Per validation plant, whether the second classifier (fitted on the other fold's plants where the
    rule is feasible) predicts the rule cheaper than the learned design."""
    n = len(episodes["rule_cost"])
    folds = (np.arange(0, n, 2), np.arange(1, n, 2))
    cheaper = np.zeros(n, dtype=bool)
    for fit, predict in (folds, folds[::-1]):
        fit = fit[episodes["rule_feasible"][fit]]
        target = episodes["rule_cost"][fit] < episodes["learned_cost"][fit]
        model = _classifier().fit(episodes["observation"][fit], target)
        cheaper[predict] = model.predict_proba(episodes["observation"][predict])[:, 1] > 0.5
    return cheaper


def policy_costs(episodes: dict[str, np.ndarray], safe: np.ndarray, cheaper: np.ndarray) -> dict[str, tuple]:
    """Per policy: ``(cost, feasible, given to the rule)`` on each validation plant."""
    rule_cost, rule_ok = episodes["rule_cost"], episodes["rule_feasible"]
    learned_cost, learned_ok = episodes["learned_cost"], episodes["learned_feasible"]
    uses = {"learned design": np.zeros_like(safe), "rule": np.ones_like(safe), "rule where safe": safe,
            "cheaper where safe": safe & cheaper, "per-plant best": rule_ok & (rule_cost < learned_cost)}
    return {name: (np.where(use, rule_cost, learned_cost), np.where(use, rule_ok, learned_ok), use) for name, use in uses.items()}


def _resampled_mean(resampled: np.ndarray, plants: np.ndarray) -> np.ndarray:
    return resampled.mean(axis=(-2, -1))


def compare(per_seed: list[dict[str, tuple]]) -> list[dict[str, Any]]:
    """One row per policy over the seeds: mean cost, violation rate, share given to the rule, difference to
    the learned design with its two-way interval and the range of the per-seed differences."""
    rows = []
    learned = np.array([costs["learned design"][0] for costs in per_seed])
    for name in per_seed[0]:
        cost, feasible, use = (np.array([costs[name][i] for costs in per_seed]) for i in range(3))
        differences = cost - learned
        by_seed = differences.mean(axis=1)
        rows.append({"policy": name, "mean_cost": float(cost.mean()), "violation_rate": float(1 - feasible.mean()),
                     "rule_share": float(use.mean()), "difference": float(differences.mean()),
                     "ci95": bootstrap_interval(differences, _resampled_mean),
                     "seed_range": [float(by_seed.min()), float(by_seed.max())]})
    return rows


def markdown(rows: list[dict[str, Any]], rule: str, seeds: int) -> str:
    lines = [f"| policy | mean cost | violations | plants given to `{rule}` | - learned design [95% interval] "
             f"| its range over the {seeds} seeds |", "|---|---|---|---|---|---|"]
    for row in rows:
        reference = row["policy"] == "learned design"
        difference = "-" if reference else f"{row['difference']:.3g} [{row['ci95'][0]:.3g}, {row['ci95'][1]:.3g}]"
        spread = "-" if reference else f"{row['seed_range'][0]:.3g} to {row['seed_range'][1]:.3g}"
        lines.append(f"| {row['policy']} | {row['mean_cost']:.3g} | {row['violation_rate']:.2%} | {row['rule_share']:.1%} "
                     f"| {difference} | {spread} |")
    return "\n".join(lines)


def pilot(run_dir: Path, rule: str, safe_below: float) -> tuple[dict[str, Any], dict[str, tuple]]:
    """One fit: its record (config, the fit's choice, the rule's violation rate on its training plants) and
    the policies' costs on its validation plants."""
    from agents.environments import make_env
    from agents.training.learned_rule_policy import load_learned_rule

    config = load_yaml_file(run_dir / "config.yaml", dict)
    fit = read_json(run_dir / "learned_rule.json", dict)
    env = make_env(config["env_id"], config["env_kwargs"])
    observations, violates = rule_labels(env, config, rule)
    episodes = validation_episodes(env, load_learned_rule(run_dir), config["validation_plants"], rule)
    env.close()
    safe = _classifier().fit(observations, violates).predict_proba(episodes["observation"])[:, 1] < safe_below
    record = {**{key: config[key] for key in ("env_id", "env_kwargs", "seed", "training_plants", "validation_plants")},
              **{key: fit[key] for key in ("kind", "margin", "margin_scale", "sha256")},
              "rule_violates_on_training_plants": float(violates.mean())}
    return record, policy_costs(episodes, safe, rule_cheaper(episodes))


def fallback(run_dirs: list[Path], rule: str = "simc-pi", safe: float = 0.1, out: Path | None = None) -> str:
    """The pilot over the fits ``run_dirs`` (one per seed): the Markdown table; with ``out``, also
    ``out/fallback.md`` and ``out/fallback.json`` (the rows, each seed's too, the fits and the settings)."""
    fits, per_seed = [], []
    for run_dir in run_dirs:
        record, costs = pilot(run_dir, rule, safe)
        fits.append({**record, "rows": compare([costs])})
        per_seed.append(costs)
    rows = compare(per_seed)
    table = markdown(rows, rule, len(per_seed))
    if out:
        out.mkdir(parents=True, exist_ok=True)
        record = {"rule": rule, "safe": safe, "rows": rows, "fits": fits}
        (out / "fallback.json").write_text(json.dumps(record, indent=2) + "\n")
        (out / "fallback.md").write_text(table + "\n")
    return table
