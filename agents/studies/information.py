"""Information or learning?  The learned rule with the true plant's parameters against the observation alone.

    deadtime study information RUN... [--plants N] [--out FILE]

Each ``RUN`` is a learned-rule fit (``deadtime train --config configs/learned_plan.yaml ...``), whose cached
training labels (``dataset/``) are reused.  Two regressions of the oracle's action, the same quantile
trees (``baselines.learned_rule.fit_regression``, ``quantile-boosting``, the fit's quantile and seed):

* **observed**: from the observation, as the learned rule;
* **privileged**: from the observation and the true plant's parameters, for analysis only (never in an
  environment's observation): ``log K``, ``log L``, ``log T_ar``, ``L / (L + T_ar)`` and the shape
  ``a_2 / T_ar^2`` (the second coefficient of the plant's Taylor series at ``s = 0``, ``Plant.taylor_coefficients``).

Each gets the fit's margins; the margin of least mean cost is chosen on the first half of ``N``
validation plants (default 600) and both are reported on the second half, with the oracle's cost on
those plants.  If the privileged rule closes most of the gap to the oracle and the observed one
cannot, the missing information is about the plant, not the learner.  The test plants are never drawn.

Per run, the per-plant costs of the second half go to ``FILE`` (JSON; default ``information.json``),
which a later call extends (a run already in it is not played again: interrupted, the study resumes).
Prints per environment, over its runs (seeds): each rule's mean cost, ``privileged - observed``
paired on the plants and the seeds (bootstrap 95% interval over both,
:func:`agents.evaluation.seed_statistics.paired_difference` of the per-seed differences), and the share
of the observed rule's gap to the oracle that the privileged rule closes; and each rule's gap split
into its part on the episodes it designs within the constraints and its part on those it violates
(cost ``>= VIOLATION_COST``), both per seed-plant pair, so that they add up to the gap.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np

from agents.files.reader import read_json


def privileged(plant) -> list[float]:
    """The true plant's parameters the privileged rule reads."""
    gain, dead_time, residence = abs(plant.gain), plant.dead_time, plant.residence_time
    _, second = plant.taylor_coefficients()
    return [math.log(gain), math.log(max(dead_time, 1e-9)), math.log(residence),
            dead_time / (dead_time + residence), second / residence**2]


def study(run: Path, count: int = 600) -> dict:
    """One run's study: the chosen margins and the per-plant costs of the second half."""
    from agents.evaluation.oracle_info import oracle_info
    from agents.training.config import load_config
    from agents.training.learned_rule import cached_labels, check_environment, label_direction
    from agents.training.validation import VALIDATION_SEED, validate_policy, validation_plants
    from baselines.learned_rule import fit_regression
    from envs.systems.plants import Plant

    config = load_config(run / "config.yaml")
    records = cached_labels(config, run)
    observations = np.array([r["observation"] for r in records])
    extra = np.array([privileged(Plant.from_dict(r["plant"])) for r in records])
    actions = np.array([r["action"] for r in records])
    env = check_environment(config)
    plants = validation_plants(env, count)
    choose, report = plants[: count // 2], plants[count // 2:]
    low, high = float(env.action_space.low[0]), float(env.action_space.high[0])
    direction = label_direction(records)
    models = {"observed": fit_regression("quantile-boosting", observations, actions, config.seed, config.quantile),
              "privileged": fit_regression("quantile-boosting", np.hstack([observations, extra]), actions, config.seed,
                                           config.quantile)}

    def rule(name: str, margin: float):
        def predict(observation: np.ndarray) -> np.ndarray:
            row = np.asarray(observation, dtype=float).reshape(1, -1)
            if name == "privileged":
                row = np.hstack([row, [privileged(env.unwrapped.plant)]])
            return np.clip(models[name].predict(row) + direction * margin, low, high).astype(np.float32).reshape(1)
        return predict

    def play(name: str, margin: float, subset: list) -> object:
        return validate_policy(rule(name, margin), env, len(subset), subset)

    found = {"env": config.env_id, "env_kwargs": dict(config.env_kwargs), "seed": config.seed, "plants": len(report)}
    for name in models:
        margin = min(config.margins, key=lambda m: (play(name, m, choose).mean_cost, -m))
        result = play(name, margin, report)
        found[name] = {"margin": margin, "costs": list(result.costs), "violations": round(result.violation_rate * len(report))}
    oracle = []
    for k, plant in enumerate(report):  # validate_policy's episode seeds: VALIDATION_SEED + index in the subset
        env.reset(seed=VALIDATION_SEED + k, options={"plant": plant})
        oracle.append(oracle_info(env.unwrapped)["oracle_cost"])
    found["oracle"] = {"costs": oracle}
    return found


def _split(costs: np.ndarray, oracle: np.ndarray) -> str:
    """``a + b``: the mean excess over the oracle from the feasible episodes and from the violating ones."""
    from agents.evaluation.seed_statistics import VIOLATION_COST

    excess, violating = costs - oracle, costs >= VIOLATION_COST
    return f"{np.where(violating, 0.0, excess).mean():.3f} + {np.where(violating, excess, 0.0).mean():.3f}"


def table(results: dict[str, dict]) -> str:
    """The Markdown table of the module docstring, one row per environment and regime."""
    from agents.evaluation.seed_statistics import paired_difference

    groups: dict[tuple[str, str], list[dict]] = {}
    for found in results.values():
        groups.setdefault((found["env"], json.dumps(found["env_kwargs"], sort_keys=True)), []).append(found)
    lines = ["| environment | seeds | plants | observed | privileged | oracle | privileged - observed [95%] | "
             "gap to the oracle closed | violations observed, privileged | gap observed: feasible + violating "
             "| gap privileged: feasible + violating |", "|---|---|---|---|---|---|---|---|---|---|---|"]
    for (env, _), runs in sorted(groups.items()):
        costs = {name: np.array([r[name]["costs"] for r in runs]) for name in ("observed", "privileged", "oracle")}
        means = {name: float(c.mean()) for name, c in costs.items()}
        difference = paired_difference(costs["privileged"] - costs["observed"], np.zeros((1, costs["oracle"].shape[1])))
        closed = (means["observed"] - means["privileged"]) / (means["observed"] - means["oracle"])
        lines.append(
            f"| `{env}` | {len(runs)} | {costs['oracle'].shape[1]} | {means['observed']:.3f} | {means['privileged']:.3f} | "
            f"{means['oracle']:.3f} | {difference[0]:.3g} [{difference[1]:.3g}, {difference[2]:.3g}] | {closed:.0%} | "
            f"{sum(r['observed']['violations'] for r in runs)}, {sum(r['privileged']['violations'] for r in runs)} "
            f"of {costs['oracle'].size} | {_split(costs['observed'], costs['oracle'])} | {_split(costs['privileged'], costs['oracle'])} |")
    return "\n".join(lines)


def information(runs: list[Path], plants: int = 600, out: Path = Path("information.json")) -> str:
    """The study of ``runs`` on ``plants`` validation plants, each run's costs kept in ``out`` (resumable);
    returns the table of the runs."""
    results = read_json(out, dict) if out.is_file() else {}
    for run in runs:
        if run.name not in results:
            results[run.name] = study(run, plants)
            partial = out.with_suffix(".partial")
            partial.write_text(json.dumps(results))
            os.replace(partial, out)
    return table({name: found for name, found in results.items() if name in {run.name for run in runs}})
