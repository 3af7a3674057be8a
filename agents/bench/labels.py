"""``deadtime bench``, the labels part: training labels per second, the fast search against the reference.

A label is what a learned-rule fit computes per training plant (:func:`agents.training.learned_rule`'s
``_label``): the environment's reset on the plant's seed (its draw and identification), then the
oracle's action on the true plant.  Both searches of the oracle (:data:`baselines.oracle.SEARCHES`)
label the same plants of :data:`ENV_ID` (the training plants of seed 0, as
``deadtime train --config configs/learned_plan.yaml --env DeadTime/PID-v3 'env_kwargs.plan=[1, 1]'``
draws them), in rounds, the reference then the fast search in each; a figure is the median over
the rounds of its value in one round.  Times are the process's CPU time (labels per core-second),
so a busy machine lengthens them only through the caches it shares.  Besides the labels per second and their ratio, the time of
the reset alone (the same for both searches: the episode is bit for bit that of the environment),
the ratio of the oracle's time alone (the label less the reset) and the bound the reset sets on the
ratio of whole labels (a reference label over its reset: what a search costing nothing would give).
"""

from __future__ import annotations

import statistics
import time
from typing import Any

__all__ = ["ENV_ID", "ENV_KWARGS", "label_figures"]

ENV_ID = "DeadTime/PID-v3"
ENV_KWARGS = {"experiments": "fixed", "plan": [1, 1]}


def _seconds(function, seeds: list[int]) -> float:
    """The process's CPU time of ``function`` over the seeds (single-threaded work on one core: a
    core's time, whatever else the machine runs)."""
    start = time.process_time()
    for k, seed in enumerate(seeds):
        function(seed, k)
    return time.process_time() - start


def label_figures(plants: int, rounds: int, progress=lambda message: None) -> dict[str, Any]:
    """The labels part's figures on ``plants`` training plants, over ``rounds`` rounds (module docstring)."""
    from agents.environments import make_env
    from agents.training.learned_rule import _label, training_seed

    env = make_env(ENV_ID, ENV_KWARGS)
    try:
        seeds = [training_seed(0, k) for k in range(plants)]
        for search in ("reference", "fast"):  # compile, untimed
            _label(env, seeds[0], 0, search)
        measured = []
        for r in range(rounds):
            progress(f"labels, round {r + 1}/{rounds}: {plants} training plants of {ENV_ID}, reference then fast search")
            one = {search: _seconds(lambda seed, k, s=search: _label(env, seed, k, s), seeds) for search in ("reference", "fast")}
            one["reset"] = _seconds(lambda seed, k: env.reset(seed=seed), seeds)
            measured.append(one)
    finally:
        env.close()

    def median(figure) -> float:
        return float(statistics.median(figure(m) for m in measured))

    return {
        "labels_env_id": ENV_ID,
        "labels_plants": plants,
        "labels_rounds": rounds,
        "labels_per_s_reference": median(lambda m: plants / m["reference"]),
        "labels_per_s_fast": median(lambda m: plants / m["fast"]),
        "labels_fast_vs_reference": median(lambda m: m["reference"] / m["fast"]),
        "labels_fast_vs_reference_rounds": [m["reference"] / m["fast"] for m in measured],
        "label_reset_ms": median(lambda m: 1e3 * m["reset"] / plants),
        "oracle_fast_vs_reference": median(lambda m: (m["reference"] - m["reset"]) / max(m["fast"] - m["reset"], 1e-9)),
        "labels_fast_vs_reference_bound": median(lambda m: m["reference"] / m["reset"]),
    }
