"""The learned continuation (``seq-continuation``): the second experiment's amplitude read from the first one's record.

After the closed-loop step at the regime's first amplitude, one gradient-boosted regressor per second
amplitude (``sklearn.ensemble.HistGradientBoostingRegressor``) predicts, from the observation's
features, the episode's cost with that amplitude's learned design (:mod:`agents.studies.headroom`);
the continuation takes the amplitude of least predicted cost only where it is predicted cheaper than
the best single plan's by more than a threshold: the stopping rule's form, another choice only if its
predicted gain exceeds what it risks.  The regressors learn on plants of their own stream
(:data:`CONTINUATION_ENTROPY`, one noise draw each); the threshold is chosen among :data:`THRESHOLDS`
on the validation plants, cross-fitted (on the even plants for the odd ones and back), so that no
plant's choice is made with its own cost.  ``deadtime study headroom --design learned
--training-plants N`` reports it beside the adaptive oracle it approximates.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from agents.files.writer import atomic_write
from agents.studies.headroom import GRID, continuation_costs, first_experiment

__all__ = ["CONTINUATION_ENTROPY", "THRESHOLDS", "continuation_training", "learned_continuation"]

CONTINUATION_ENTROPY = 20261205
"""The stream of the learned continuation's training plants (none of the protocols' streams)."""
CONTINUATION_EPISODE_SEED = 70_000_000


def _first_features(env: Any, plant: Any, seed: int, first: float) -> tuple[np.ndarray, Any]:
    """The observation's features after the closed-loop step at ``first`` (its noise as in :func:`plant_costs`)."""
    from envs.episode import Evidence, features

    env.reset(seed=seed, options={"plant": plant})
    env.evidence = Evidence.empty(env.integrating, env.options)
    after_first = first_experiment(env, np.random.default_rng([seed, GRID.index(first)]), first)
    return features(after_first, env.budget), after_first


def continuation_training(env: Any, plants: list[Any], episode_seed: int, first: float, designs: dict[float, Any],
                          weights: list[Any]) -> tuple[np.ndarray, np.ndarray]:
    """Features after the first experiment and each second amplitude's cost (one noise draw), per plant."""
    rows, labels = [], []
    for k, plant in enumerate(plants):
        seed = episode_seed + k
        x, after_first = _first_features(env, plant, seed, first)
        rows.append(x)
        labels.append([continuation_costs(env, after_first, np.random.default_rng([seed, GRID.index(first), 1]), first,
                                          second, weights, design)[0] for second, design in designs.items()])
    return np.array(rows), np.array(labels)


THRESHOLDS: tuple[float, ...] = (0.0, 0.05, 0.1, 0.2, 0.5, 1.0, 2.0, math.inf)
"""The predicted cost reductions tried as the learned continuation's threshold (inf: never deviate)."""


def _threshold_choice(predicted: np.ndarray, default: int, threshold: float) -> np.ndarray:
    """Per plant the amplitude of least predicted cost where it is predicted cheaper than ``default``
    by more than ``threshold``, else ``default``."""
    best = predicted.argmin(axis=1)
    reduction = predicted[:, default] - predicted[np.arange(len(predicted)), best]
    return np.where(reduction > threshold, best, default)


def _cross_fitted_threshold(predicted: np.ndarray, expected: np.ndarray, default: int) -> tuple[np.ndarray, list[float]]:
    """Each plant's choice under the threshold chosen on the other half of the plants (even and odd),
    and the two thresholds."""
    index = np.arange(len(predicted))
    choice, chosen = np.empty(len(predicted), dtype=int), []
    for fold in (0, 1):
        fit, use = index[index % 2 != fold], index[index % 2 == fold]
        value = [expected[fit, _threshold_choice(predicted[fit], default, t)].mean() for t in THRESHOLDS]
        threshold = THRESHOLDS[int(np.argmin(value))]
        chosen.append(threshold)
        choice[use] = _threshold_choice(predicted[use], default, threshold)
    return choice, chosen


def learned_continuation(env: Any, designs: dict[float, Any], weights: list[Any], first: float, training: list[Any],
                         validation: list[Any], validation_seed: int, expected: np.ndarray,
                         cache: Path | None = None, identity: str = "") -> dict[str, Any]:
    """``seq-continuation``: after the first experiment, the second amplitude of least predicted cost,
    read from its record by one gradient-boosted regressor per amplitude (trained on ``training`` plants
    of their own stream), taken only where it is predicted cheaper than the best single plan's by more
    than a threshold: the stopping rule's form (another choice only if its predicted gain exceeds what
    it risks).  The threshold is chosen on the validation plants, cross-fitted (chosen on the even
    plants for the odd ones and back); ``expected`` is each validation plant's expected cost per second
    amplitude (the headroom's), whose least mean gives the best single plan.  ``cache``: an ``.npz``
    that keeps the training data, reused while it holds as many plants and the same ``identity`` (the fits)."""
    from sklearn.ensemble import HistGradientBoostingRegressor

    found = np.load(cache) if cache is not None and cache.exists() else None
    if found is not None and len(found["x"]) == len(training) and str(found["identity"]) == identity:
        x, y = found["x"], found["y"]
    else:
        x, y = continuation_training(env, training, CONTINUATION_EPISODE_SEED, first, designs, weights)
        if cache is not None:
            cache.parent.mkdir(parents=True, exist_ok=True)
            atomic_write(cache, lambda handle: np.savez_compressed(handle, x=x, y=y, identity=identity))
    models = [HistGradientBoostingRegressor(random_state=0).fit(x, y[:, m]) for m in range(y.shape[1])]
    x_valid = np.array([_first_features(env, plant, validation_seed + k, first)[0] for k, plant in enumerate(validation)])
    predicted = np.column_stack([model.predict(x_valid) for model in models])
    choice, thresholds = _cross_fitted_threshold(predicted, expected, int(np.argmin(expected.mean(axis=0))))
    chosen = expected[np.arange(len(validation)), choice]
    return {"training_plants": len(training), "per_plant": chosen, "thresholds": thresholds,
            "choices": dict(zip([f"{a:g}" for a in designs], np.bincount(choice, minlength=len(designs)).tolist()))}
