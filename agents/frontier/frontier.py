"""A regime's frontier: per family, mean cost and risk over its knob on the validation plants (``deadtime frontier``).

Every (family, knob, seed) is one policy of :mod:`agents.evaluation`, scored on the same validation
plants with the same episode seeds (``seed + i`` for plant ``i``) by the evaluation's own per-plant
scoring and cache (:func:`agents.evaluation.evaluate.score_plants`), so that every comparison is
paired.  A rule family's members are the rules ``RULE@S`` (:mod:`baselines.rules.family`); a learned
family's are its seeds' policies at the knob (:mod:`agents.frontier.families`).

Per family and knob, over ``k`` seeds (a rule or a callable has one) and ``n`` plants:

* ``mean_cost``: the mean over seeds and plants;
* ``risk``: the share of plants on which one seed's design violates (a constraint broken on the true
  plant, or no design: a failure), per seed, then averaged over the seeds; ``risk_union`` beside it,
  the share of plants on which any seed's design violates.

At each risk level ``r`` of :data:`RISK_LEVELS` a family's knob is the one of least mean cost among
those of ``risk <= r`` (None where no knob reaches ``r``: the family cannot reach it); the best rule
family and the best learned family at ``r`` are the ones of least cost among those chosen.
"""

from __future__ import annotations

import math
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["DEFAULT_KNOBS", "RISK_LEVELS", "Family", "choose_knob", "frontier", "frontier_table"]

RISK_LEVELS: tuple[float, ...] = (0.005, 0.01, 0.02, 0.05)
"""The declared risk levels: shares of validation plants on which one trained model's design violates."""

DEFAULT_KNOBS: tuple[float, ...] = (-1.0, -0.5, -0.25, 0.0, 0.25, 0.5, 1.0, 1.5, 2.0)
"""The knob grid of ``deadtime frontier`` (``--knobs``): a parameter from ``e^-1 = 0.37`` to ``e^2 = 7.4`` times its own."""

RULE = "rule"


@dataclass(frozen=True)
class Family:
    """One policy's family: ``kind`` is ``"rule"`` (``members`` holds the rule's name), or a played kind
    (``"agent"``, ``"learned rule"``, ``"selector"``, ``"callable"``; ``members`` holds one loaded
    policy per seed and ``identities`` their cache identities, None for a callable: not cached)."""

    name: str
    kind: str
    members: tuple[Any, ...]
    identities: tuple[str | None, ...] = field(default=())


def _validation_plants(family: str, n: int) -> list[tuple[str, str, Any]]:
    from envs.systems.plant_sets import plant_set

    return [("validation", f"validation-{i}", plant) for i, plant in enumerate(plant_set(family, "validation", n))]


def frontier(env_id: str, families: Sequence[Family], knobs: Sequence[float] = DEFAULT_KNOBS, n: int = 200, seed: int = 0, *,
             env_kwargs: dict[str, Any] | None = None, workers: int = 1, out: Any = None,
             warn: Callable[[str], None] | None = None) -> dict[str, Any]:  # fmt: skip
    """Every family's frontier on ``n`` validation plants of ``env_id``'s regime (module docstring).

    Returns the ``frontier.json`` object: ``rows`` (family, kind, knob, mean cost, risk, union risk,
    seeds, plants), ``chosen`` (per family, per risk level, the knob or None), ``best`` (per risk level
    the best rule family and the best learned family), the oracle's mean cost and risk, and the setting.
    With ``out`` (a Path), the per-plant results are cached in ``out/cache.jsonl`` (created once every
    input is checked); the tables are :func:`agents.frontier.report.write_frontier`'s.

    Raises
    ------
    ValueError
        For an unknown environment, an empty or non-finite knob grid, ``n`` not from 2 to the limit, no
        family, or two of one name.
    """
    from agents.environments import make_env
    from envs.interface import tuning_env_of
    from agents.evaluation.evaluate import check_trained_on, env_regime, first_episode, played_env, score_plants
    from baselines.rules.family import member_name

    from agents.limits import MAX_TEST_PLANTS

    knobs = _checked_knobs(knobs)
    if isinstance(n, bool) or not isinstance(n, int) or not 2 <= n <= MAX_TEST_PLANTS:
        raise ValueError(f"n must be an integer from 2 to {MAX_TEST_PLANTS}, got {n!r}")
    if not families:
        raise ValueError("frontier needs at least one policy")
    names = [f.name for f in families]
    if len(set(names)) != len(names):
        raise ValueError(f"two families are named {next(x for x in names if names.count(x) > 1)!r}; name them with NAME=...")
    regime = env_regime(env_kwargs)
    env = make_env(env_id, {"experiments": "fixed", **regime})
    unwrapped = tuning_env_of(env)
    plants = _validation_plants(unwrapped.family, n)
    scoring = {"constraints": unwrapped.constraints, "weights": unwrapped.weights, **regime,
               "noise_std": unwrapped.options.noise_std}
    rules, agents, keys = [], {}, {}
    for family in families:
        for knob in knobs:
            if family.kind == RULE:
                name = member_name(family.members[0], knob)
                rules.append(name)
                keys[family.name, knob] = [name]
                continue
            keys[family.name, knob] = []
            for index, (policy, identity) in enumerate(zip(family.members, family.identities)):
                check_trained_on(policy, env_id, f"policy {family.name!r}")
                agents.update(_member(family, index, policy, identity, knob, env_id, scoring, keys, played_env))
    print(f"frontier {env_id}: {len(families)} families x {len(knobs)} knobs on {n} validation plants", file=sys.stderr, flush=True)
    first_episode(env, plants[0][2], seed)  # a regime argument only an episode reads is refused before anything is written
    cache = None
    if out is not None:  # created once every input is checked
        out.mkdir(parents=True, exist_ok=True)
        cache = out / "cache.jsonl"
    results, _, _ = score_plants(env, env_id, regime, regime, plants, seed, rules, agents, cache, False, workers,
                                  warn or (lambda line: print(line, file=sys.stderr)))
    return frontier_table(families, knobs, results, keys, {"env_id": env_id, "n": n, "seed": seed, "env_kwargs": regime})


def _member(family: Family, index: int, policy: Any, identity: str | None, knob: float, env_id: str,
            scoring: dict[str, Any], keys: dict, played_env: Callable) -> dict[str, Any]:  # fmt: skip
    """One seed's policy at ``knob``, keyed for :func:`agents.evaluation.run.evaluate_plant`."""
    from agents.frontier.families import at_knob

    name = f"{family.name}#{index}@{knob!r}"
    kwargs = {**dict(getattr(policy, "env_kwargs", None) or {}), **scoring}
    env = played_env(policy, env_id, kwargs)
    keys[family.name, knob].append(name)
    return {name: (at_knob(name, policy, knob, env), env, None if identity is None else f"{identity}|knob={knob!r}")}


def _checked_knobs(knobs: Sequence[float]) -> list[float]:
    from baselines.rules.family import KNOB_LIMIT

    values = [float(k) for k in knobs]
    if not values or not all(math.isfinite(k) and abs(k) <= KNOB_LIMIT for k in values):
        raise ValueError(f"knobs must be finite numbers from -{KNOB_LIMIT:g} to {KNOB_LIMIT:g}, got {list(knobs)!r}")
    if 0.0 not in values:
        values.append(0.0)  # the shipped policy is always on its frontier
    return sorted(set(values))


def frontier_table(families: Sequence[Family], knobs: Sequence[float], results: list[dict[str, Any]],
                   keys: dict[tuple[str, float], list[str]], setting: dict[str, Any]) -> dict[str, Any]:  # fmt: skip
    """The frontier of per-plant ``results`` (one mapping of policy name to result per plant);
    ``keys[family, knob]`` names the policies (one per seed) of each family at each knob."""
    rows, costs = [], {}
    for family in families:
        for knob in knobs:
            cost = np.array([[found[name].cost for found in results] for name in keys[family.name, knob]])
            costs[family.name, knob] = cost
            violated = np.array([[not found[name].feasible for found in results] for name in keys[family.name, knob]])
            rows.append({"family": family.name, "kind": family.kind, "knob": knob, "mean_cost": float(cost.mean()),
                         "risk": float(violated.mean(axis=1).mean()), "risk_union": float(violated.any(axis=0).mean()),
                         "seeds": int(cost.shape[0]), "plants": int(cost.shape[1])})
    chosen = {f.name: {_level(r): choose_knob([row for row in rows if row["family"] == f.name], r) for r in RISK_LEVELS}
              for f in families}
    best = {_level(r): {group: _best(families, rows, chosen, r, group) for group in ("rule", "learned")} for r in RISK_LEVELS}
    for level in best.values():
        level["difference"] = _difference(level["learned"], level["rule"], costs)
    oracle = {"mean_cost": float(np.mean([found["oracle"].cost for found in results])),
              "risk": float(np.mean([not found["oracle"].feasible for found in results]))}
    return {**setting, "risk_levels": list(RISK_LEVELS), "knobs": list(knobs), "rows": rows, "chosen": chosen,
            "best": best, "oracle": oracle}


def _difference(learned: dict[str, Any] | None, rule: dict[str, Any] | None, costs: dict) -> dict[str, Any] | None:
    """The best learned family's mean cost minus the best rule family's, paired by plant, at their chosen knobs,
    with its 95% interval, seeds and plants random (:func:`agents.frontier.statistics.crossed_interval`; one
    seed: plants random, Student t)."""
    from scipy import stats

    from agents.frontier.statistics import crossed_interval

    if learned is None or rule is None:
        return None
    paired = costs[learned["family"], learned["knob"]] - costs[rule["family"], rule["knob"]].mean(axis=0)
    if paired.shape[1] < 2:
        return None
    if paired.shape[0] >= 2:
        return crossed_interval(paired).to_dict()
    mean, se = float(paired.mean()), float(paired.std(ddof=1) / np.sqrt(paired.shape[1]))
    half = float(stats.t.ppf(0.975, paired.shape[1] - 1)) * se
    return {"estimate": mean, "low": mean - half, "high": mean + half, "standard_error": se,
            "method": "plants random, one seed (t)"}


def _level(r: float) -> str:
    return f"{100 * r:g}%"


def choose_knob(rows: list[dict[str, Any]], r: float) -> float | None:
    """The knob of least mean cost among ``rows`` of risk at most ``r`` (ties: the more conservative), or None."""
    allowed = [row for row in rows if row["risk"] <= r + 1e-12]
    if not allowed:
        return None
    return min(allowed, key=lambda row: (row["mean_cost"], -row["knob"]))["knob"]


def _best(families: Sequence[Family], rows: list[dict[str, Any]], chosen: dict, r: float, group: str) -> dict[str, Any] | None:
    """The family of least cost at its knob chosen at ``r`` among the rule families (``group="rule"``) or the others."""
    candidates = []
    for family in families:
        knob = chosen[family.name][_level(r)]
        if knob is None or (family.kind == RULE) != (group == "rule"):
            continue
        row = next(row for row in rows if row["family"] == family.name and row["knob"] == knob)
        candidates.append({"family": family.name, "knob": knob, "mean_cost": row["mean_cost"], "risk": row["risk"]})
    return min(candidates, key=lambda c: c["mean_cost"]) if candidates else None
