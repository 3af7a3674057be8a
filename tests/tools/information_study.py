"""Information or learning?  The learned rule with the true plant's parameters against the observation alone.

    python tests/tools/information_study.py RUN [N]

``RUN`` is a learned-rule fit (``deadtime train --config configs/learned_plan.yaml ...``), whose cached
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
Prints one Markdown table.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np


def privileged(plant) -> list[float]:
    """The true plant's parameters the privileged rule reads."""
    gain, dead_time, residence = abs(plant.gain), plant.dead_time, plant.residence_time
    _, second = plant.taylor_coefficients()
    return [math.log(gain), math.log(max(dead_time, 1e-9)), math.log(residence),
            dead_time / (dead_time + residence), second / residence**2]


def main(run: Path, count: int = 600) -> str:
    from agents.evaluation.oracle_info import oracle_info
    from agents.training.config import load_config
    from agents.training.learned_rule import check_environment
    from agents.training.validation import VALIDATION_SEED, validate_policy, validation_plants
    from baselines.learned_rule import fit_regression
    from envs.systems.plants import Plant

    config = load_config(run / "config.yaml")
    records = [r for path in sorted((run / "dataset").glob("training-*.json")) for r in json.loads(path.read_text())]
    observations = np.array([r["observation"] for r in records])
    extra = np.array([privileged(Plant.from_dict(r["plant"])) for r in records])
    actions = np.array([r["action"] for r in records])
    env = check_environment(config)
    plants = validation_plants(env, count)
    choose, report = plants[: count // 2], plants[count // 2:]
    low, high = float(env.action_space.low[0]), float(env.action_space.high[0])
    direction = records[0]["direction"]
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

    lines = ["| rule | margin (chosen on the first half) | mean cost, second half | violations, second half |",
             "|---|---|---|---|"]
    for name in models:
        margin = min(config.margins, key=lambda m: (play(name, m, choose).mean_cost, -m))
        result = play(name, margin, report)
        lines.append(f"| {name} | {margin:g} | {result.mean_cost:.3f} | {round(result.violation_rate * len(report))} "
                     f"of {len(report)} |")
    oracle = []
    for k, plant in enumerate(report):  # validate_policy's episode seeds: VALIDATION_SEED + index in the subset
        env.reset(seed=VALIDATION_SEED + k, options={"plant": plant})
        oracle.append(oracle_info(env.unwrapped)["oracle_cost"])
    lines.append(f"| oracle | - | {np.mean(oracle):.3f} | - |")
    return "\n".join(lines)


if __name__ == "__main__":
    print(main(Path(sys.argv[1]), int(sys.argv[2]) if len(sys.argv) > 2 else 600))
