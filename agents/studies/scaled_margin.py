"""A constant margin against one that scales with the quantile trees' spread, on the validation plants.

    deadtime train --config configs/learned_plan.yaml --env DeadTime/PID-v3 --out /tmp/pid10 \\
        'env_kwargs.plan=[3, 0.1]' env_kwargs.noise_std=0.1 'env_kwargs.weights={production: 0}'
    deadtime study scaled-margin /tmp/pid10 500

Reads the fit's cached training labels (``dataset/``), fits the 0.9, and 0.1 quantile trees
(``baselines.learned_rule.fit_regression``) and plays, on the first ``N`` validation plants, the
action ``q90(x) + m`` (the learned rule's constant margin) and ``q90(x) + m * w(x) / mean(w)`` with
``w = q90 - q10`` (the spread, floored at 1e-3; its mean over the training plants), in the
conservative direction, for margins ``m`` from 0 to 1.  Prints ``scaled margin mean_cost violations``
per line: where the violations are not spread evenly over the plants, the scaled margin reaches a
violation count more cheaply (conformalized quantile regression scales its correction the same way:
Romano, Patterson and Candès, NeurIPS 2019).  The test plants are never drawn.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

MARGINS = (0.0, 0.05, 0.1, 0.15, 0.2, 0.25, 0.3, 0.4, 0.5, 0.7, 1.0)


def scaled_margin(run: Path, plants_count: int) -> None:
    from agents.training.config import load_config
    from agents.training.learned_rule import cached_labels, check_environment, label_direction
    from agents.training.validation import validate_policy, validation_plants
    from baselines.learned_rule import fit_regression

    config = load_config(run / "config.yaml")
    records = cached_labels(config, run)
    observations = np.array([r["observation"] for r in records])
    actions = np.array([r["action"] for r in records])
    env = check_environment(config)
    plants = validation_plants(env, plants_count)
    low, high = float(env.action_space.low[0]), float(env.action_space.high[0])
    direction = label_direction(records)
    upper = fit_regression("quantile-boosting", observations, actions, config.seed, 0.9)
    lower = fit_regression("quantile-boosting", observations, actions, config.seed, 0.1)
    mean_spread = float(np.mean(np.maximum(upper.predict(observations) - lower.predict(observations), 1e-3)))

    def rule(margin: float, scaled: bool):
        def predict(observation: np.ndarray) -> np.ndarray:
            row = np.asarray(observation, dtype=float).reshape(1, -1)
            shift = margin * (np.maximum(upper.predict(row) - lower.predict(row), 1e-3) / mean_spread if scaled else 1.0)
            return np.clip(upper.predict(row) + direction * shift, low, high).astype(np.float32).reshape(1)
        return predict

    for scaled in (False, True):
        for margin in MARGINS:
            result = validate_policy(rule(margin, scaled), env, plants_count, plants)
            print(scaled, margin, round(result.mean_cost, 3), round(result.violation_rate * plants_count), flush=True)
