"""The learners on validation plants: realized risk against requested.

Per structure and regime (:data:`REGIMES`: the v3 environment's fixed-mode default, and 10% noise
with the experiments priced), plant ``i`` is the environment's own draw at reset seed
``default_rng([validation_entropy, structure index, 100 + regime index, i])`` (the config's validation
entropy: never a test stream).  On each plant, after the one reset (the fixed procedure's
identification), the learner's action at each risk of :data:`agents.risk.train.RISKS` is scored as an
episode's step scores it, without ending the episode (:meth:`envs.tuning_env.DeadTimeTuningEnv.score_action`):
so all are paired on the same identification.
A design *violates* when its loop on the true plant breaks a constraint, or there is no design (a
failed identification).  Each row also keeps, per risk, whether the learner reaches it on the plant
(:meth:`agents.risk.model.RiskLearner.reachable`), and the plant's floor (the share of its band's
calibration plants with no feasible design).

The plants of the validation stream across regimes (those of the choice, :mod:`agents.risk.train`)
are played the same way in their own regimes, for the reliability per band of noise.

Per-plant rows are cached ``CHUNK`` plants a file (``FOLDER/<STRUCTURE>/<regime>-<first>.json``).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["CHUNK", "REGIMES", "expected_misses", "outside_probability", "play_plant", "play_plants", "regime_seeds", "wilson"]

CHUNK = 100

REGIMES: dict[str, dict[str, Any]] = {"default": {}, "priced-10": {"noise_std": 0.1, "weights": {"production": 0.05}}}
"""The validation regimes: the v3 environment's fixed-mode default kwargs, and 10% noise with the experiments priced."""


def regime_seeds(entropy: int, structure: str, regime: str, n: int) -> list[int]:
    """The reset seeds of the first ``n`` validation plants of a regime (module docstring)."""
    from agents.risk.labels import STRUCTURES

    index = STRUCTURES.index(structure)
    return [int(np.random.default_rng([int(entropy), index, 100 + list(REGIMES).index(regime), i]).integers(2**62))
            for i in range(n)]


def play_plant(env: Any, seed: int, learner: Any) -> dict[str, Any]:
    """One plant's row: ``{"seed", "learner": {risk: [cost, feasible]}, "reached": {risk: bool}, "floor"}`` (module docstring)."""
    from agents.risk.train import RISKS
    from envs.interface import episode_of, tuning_env_of

    observation, _ = env.reset(seed=seed)
    # the learner's actions as the step reads them (float32)
    designs, reached = learner.designs(observation, RISKS)
    actions = [float(np.float32(a)) for a in designs[0]]
    reach = {"reached": {str(r): bool(k) for r, k in zip(RISKS, reached[0])}, "floor": float(learner.floor(observation)[0])}
    if episode_of(env).identification is None:  # a failed identification: every design fails as the step fails it
        info = env.step(np.zeros(env.action_space.shape, dtype=np.float32))[4]
        return {"seed": seed, "learner": {str(r): [float(info["cost"]), False] for r in RISKS}, **reach}
    scores = [tuning_env_of(env).score_action(action)[2] for action in actions]
    return {"seed": seed, "learner": {str(r): [float(score.cost), bool(score.feasible)] for r, score in zip(RISKS, scores)},
            **reach}


def play_plants(folder: Path, env_id: str, env_kwargs: dict[str, Any], structure: str, stream: str, seeds: list[int],
                learner: Any, log: Any = sys.stderr, cached: bool = False) -> list[dict[str, Any]]:
    """Per plant of ``seeds``, :func:`play_plant`'s row, from the cache ``folder/<structure>/<stream>-<first>.json``
    where there; ``cached`` plays nothing and returns the rows of the chunks cached."""
    from agents.environments import make_env
    from agents.files.reader import read_json
    from agents.files.writer import write_json

    rows: list[dict[str, Any]] = []
    env = None
    for first in range(0, len(seeds), CHUNK):
        path = folder / structure / f"{stream}-{first:06d}.json"
        chunk_seeds = seeds[first:first + CHUNK]
        if path.is_file():
            found = read_json(path, list)
            if [r["seed"] for r in found] == chunk_seeds:
                rows += found
                continue
        if cached:
            continue
        env = env or make_env(env_id, env_kwargs)
        chunk = [play_plant(env, seed, learner) for seed in chunk_seeds]
        write_json(path, chunk)
        print(f"{structure} {stream}: {first + len(chunk)}/{len(seeds)} plants played", file=log, flush=True)
        rows += chunk
    if env is not None:
        env.close()
    return rows


def wilson(k: int, n: int) -> tuple[float, float]:
    """The Wilson score 95% interval of a share ``k/n`` (scipy's ``binomtest(k, n).proportion_ci``)."""
    if n == 0:
        return (math.nan, math.nan)
    from scipy.stats import binomtest

    interval = binomtest(k, n).proportion_ci(0.95, method="wilson")
    return (float(interval.low), float(interval.high))


def outside_probability(n: int, risk: float) -> float:
    """The probability that the share of ``n`` plants of a learner calibrated exactly at ``risk`` falls outside
    ``[0.5 risk, 1.5 risk]`` (the binomial's, exact)."""
    from scipy.stats import binom

    low, high = math.ceil(0.5 * risk * n - 1e-9), math.floor(1.5 * risk * n + 1e-9)
    return float(1.0 - (binom.cdf(high, n, risk) - binom.cdf(low - 1, n, risk)))


def expected_misses(cells: list[tuple[int, float]]) -> float:
    """The expected count of cells ``(plants, risk)`` outside ``[0.5 r, 1.5 r]`` by sampling noise alone."""
    return float(sum(outside_probability(n, r) for n, r in cells))
