"""The learners on validation plants: realized risk against requested, and mean cost beside the rule families.

Per structure and regime (:data:`REGIMES`: the v3 environment's fixed-mode default, and 10% noise
with the experiments priced), plant ``i`` is the environment's own draw at reset seed
``default_rng([validation_entropy, structure index, 100 + regime index, i])`` (the config's validation
entropy: never a test stream).  On each plant, after the one reset (the fixed procedure's
identification), every design is scored as an episode's step scores it, without ending the episode
(:meth:`envs.tuning_env.DeadTimeTuningEnv.score_action` for the learner's action at each risk of
:data:`agents.risk.train.RISKS`; :func:`agents.evaluation.run.rule_result`, the evaluation's own, for
each rule family's member ``RULE@S`` of the knob grid): so all are paired on the same identification.
A design *violates* when its loop on the true plant breaks a constraint, or there is no design (a
failed identification).

The plants of the validation stream across regimes (those of the choice, :mod:`agents.risk.train`)
are played the same way in their own regimes, for the reliability per band of noise.

Per-plant rows are cached ``CHUNK`` plants a file (``EVAL/<STRUCTURE>/<regime>-<first>.json``).
"""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

__all__ = ["CHUNK", "REGIMES", "frontier_choice", "play_plants", "regime_seeds", "wilson"]

CHUNK = 100

REGIMES: dict[str, dict[str, Any]] = {"default": {}, "priced-10": {"noise_std": 0.1, "weights": {"production": 0.05}}}
"""The validation regimes: the v3 environment's fixed-mode default kwargs, and 10% noise with the experiments priced."""


def regime_seeds(entropy: int, structure: str, regime: str, n: int) -> list[int]:
    """The reset seeds of the first ``n`` validation plants of a regime (module docstring)."""
    from agents.risk.labels import STRUCTURES

    index = STRUCTURES.index(structure)
    return [int(np.random.default_rng([int(entropy), index, 100 + list(REGIMES).index(regime), i]).integers(2**62))
            for i in range(n)]


def _play_one(env: Any, seed: int, learner: Any, rules: list[str], knobs: tuple[float, ...], plant: Any = None) -> dict[str, Any]:
    from agents.evaluation.run import rule_result
    from agents.risk.train import RISKS
    from baselines.rules.family import member_name
    from envs.interface import episode_of, tuning_env_of

    options = None if plant is None else {"plant": plant}
    observation, _ = env.reset(seed=seed, options=options)
    unwrapped, episode = tuning_env_of(env), episode_of(env)
    row: dict[str, Any] = {"seed": seed, "learner": {}, "rules": {}}
    # the learner's actions as the step reads them (float32); none without a learner (the rules alone)
    actions = [] if learner is None else [float(np.float32(learner.design(observation, r)[0])) for r in RISKS]
    if episode.identification is None:  # a failed identification: every design fails as the step fails it
        info = env.step(np.zeros(env.action_space.shape, dtype=np.float32))[4]
        row["learner"] = {str(r): [float(info["cost"]), False] for r in RISKS[:len(actions)]}
        row["rules"] = {member_name(rule, k): [float(info["cost"]), False] for rule in rules for k in knobs}
        return row
    for risk, action in zip(RISKS, actions):
        _, _, score = unwrapped.score_action(action)
        row["learner"][str(risk)] = [float(score.cost), bool(score.feasible)]
    experiment_time = episode.evidence.experiment_time / episode.plant.residence_time
    for rule in rules:
        for knob in knobs:
            name = member_name(rule, knob)
            result = rule_result(env, name, experiment_time)
            row["rules"][name] = [float(result.cost), bool(result.feasible and not result.failure)]
    return row


def play_plants(folder: Path, env_id: str, env_kwargs: dict[str, Any], structure: str, stream: str, seeds: list[int],
                learner: Any, rules: list[str] = (), knobs: tuple[float, ...] = (0.0,), plants: list | None = None,
                log: Any = sys.stderr, part: tuple[int, int] = (0, 1), cached: bool = False) -> list[dict[str, Any]]:
    """Per plant of ``seeds`` (and ``plants``, else the environment's draws), the rows of the module docstring,
    from the cache ``folder/<structure>/<stream>-<first>.json`` where there; ``part = (i, k)`` plays only the
    chunks ``i, i + k, ...`` (``k`` processes share the work); ``cached`` plays nothing and returns the rows
    of the chunks cached."""
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
        if (first // CHUNK) % part[1] != part[0]:
            continue
        env = env or make_env(env_id, env_kwargs)
        chunk = [_play_one(env, seed, learner, list(rules), tuple(knobs), None if plants is None else plants[first + i])
                 for i, seed in enumerate(chunk_seeds)]
        write_json(path, chunk)
        print(f"{structure} {stream}: {first + len(chunk)}/{len(seeds)} plants played", file=log, flush=True)
        rows += chunk
    if env is not None:
        env.close()
    return rows


def frontier_choice(rows: list[dict[str, Any]], family: str, knobs: tuple[float, ...], risk: float) -> tuple[float, float, float] | None:
    """``(knob, mean cost, risk)`` of a rule family at declared ``risk``: its knob of least mean cost among
    those whose share of violating plants is at most ``risk`` (None where none is: it cannot reach it),
    as :mod:`agents.frontier.frontier` chooses."""
    from baselines.rules.family import member_name

    best = None
    for knob in knobs:
        name = member_name(family, knob)
        cost = float(np.mean([row["rules"][name][0] for row in rows]))
        share = float(np.mean([not row["rules"][name][1] for row in rows]))
        if share <= risk + 1e-12 and (best is None or cost < best[1]):
            best = (knob, cost, share)
    return best


def wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """The Wilson score interval of a share ``k/n``."""
    if n == 0:
        return (math.nan, math.nan)
    p = k / n
    centre, half = (p + z * z / (2 * n)) / (1 + z * z / n), z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))
