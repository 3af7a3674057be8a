"""The value of adaptivity: what choosing the second experiment after the first one can gain at most.

    deadtime study headroom [--protocol configs/protocols/v1.yaml] [--plants 2000] [--replicates 4]
                            [--out results/exploratory/sequential]

A plan fixes both experiment amplitudes before the first measurement (the closed-loop step at ``A1``,
then the open-loop step, or the pulse on integrating plants, at ``A2``; :class:`baselines.procedures.PlanRule`).
A sequential agent sees the first experiment's record before it chooses the second.  On each
validation plant of the protocol's agent-mode regimes, with the design held to the structure's base
rule (the residual action 0, the design the plans use):

1. the closed-loop step is run once at each ``A1`` of :data:`~agents.evaluation.plan_search.PLAN_GRID`
   (one noise draw: the "first outcome");
2. from that outcome, every continuation ``A2`` of the grid is run ``replicates`` times with fresh
   noise (the same draws for every ``A2``: common random numbers), identified, designed and scored
   on the true plant, free and priced production from the same records.

Per regime (the mean over plants of each plant's expected cost, over the continuation's noise):

* ``fixed procedure``: ``plan-1-1``;
* ``best single plan``: the plan of least mean cost;
* ``adaptive oracle``: ``A1`` common to all plants, ``A2`` chosen per plant *and first outcome* by
  the true expected cost, an oracle that knows the plant: no sequential policy that keeps the base
  rule's design does better (in expectation, up to the grid).  Its value is cross-fitted, so that
  the choice's own noise does not flatter it: the continuation is chosen on half the replicates and
  scored on the other half, both ways, averaged;
* ``headroom``: best single plan minus adaptive oracle, per plant, with its 95% Student-t interval
  over the plants, and the smallest difference the protocol's test resolves: with ``n`` test plants
  and ``m`` Holm comparisons, ``(z(1 - alpha/(2m)) + z(0.8)) sd / sqrt(n)`` (80% power at the
  strictest Holm level), ``sd`` the per-plant difference's standard deviation here.

Beside them, from the protocol's own validation run of the regime where it is committed
(``results/protocol_v*/REGIME/selection.json``): the plan-mode primary's and ``plan-1-1``'s
validation mean costs (the latter one draw per plant: it checks this study's estimate).

``--design oracle`` designs every episode with the per-episode oracle instead (a bound for any design
that reads the same model); ``--design learned`` with a learned design per second amplitude, beside
the sequential learners (:mod:`agents.studies.learned_headroom`).

No test plant is drawn.  Each structure and noise level's costs are kept in
``OUT/work/STRUCTURE-noiseNN.npz`` (resumable); ``OUT/headroom.md`` and ``OUT/headroom.json`` hold
the table.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np

from agents.evaluation.plan_search import PLAN_GRID

__all__ = ["DESIGNS", "GRID", "continuation_costs", "first_experiment", "headroom", "summarize"]

GRID: tuple[float, ...] = PLAN_GRID
"""The amplitudes of each experiment: the protocol's sixteen plans."""
DESIGNS: dict[str, str] = {
    "base": "the structure's base rule (the residual action 0), the design of the plans",
    "oracle": "the per-episode oracle (baselines.oracle) on the episode's identification: a bound for any learned design",
}
"""The designs a continuation can be scored with."""
POWER_Z = 0.8416212335729143
"""``z(0.8)``: the standard normal quantile of 80% power."""


def first_experiment(env: Any, rng: np.random.Generator, amplitude: float) -> Any:
    """The evidence of the episode after its closed-loop step at ``amplitude`` (env reset in plan mode)."""
    from envs.episode import run_experiment

    return run_experiment(env.evidence, "closed-loop-step", env.plant, rng, amplitude, env.excursion_limit)


def continuation_costs(env: Any, evidence: Any, rng: np.random.Generator, first: float, second: float,
                       weights: list[Any], design: Any = "base") -> list[float]:
    """The episode's costs under each of ``weights`` after the second experiment at ``second``, as
    ``env.step`` in plan mode gives them (:meth:`envs.tuning_env.TuningEnv._run_plan`), designed by
    ``design`` (a name of :data:`DESIGNS`, or a policy read by :func:`policy_design`); an identification
    that fails ends the episode at ``NO_DESIGN_COST``."""
    from envs.analysis.scoring import score
    from envs.episode import IdentificationFailed, identification, run_experiment
    from envs.tuning_env import NO_DESIGN_COST

    plant = env.plant
    if evidence.closed_loop is not None:
        kind = "pulse" if env.integrating else "open-loop-step"
        evidence = run_experiment(evidence, kind, plant, rng, second, env.excursion_limit)
    try:
        env.identification, env.evidence = identification(evidence, env.structure, plant, rng, amplitude=first)
    except IdentificationFailed:
        return [NO_DESIGN_COST] * len(weights)
    env._base = None
    controller = env.design(_parameter(env, design))
    return [float(score(plant, controller, experiment_time=env.evidence.experiment_time,
                        experiment_deviation=env.evidence.experiment_deviation, constraints=env.constraints,
                        weights=w).cost) for w in weights]


def policy_design(policy: Any) -> Any:
    """A design read from the episode's observation by a policy (a learned rule, a trained agent)."""
    def design(env: Any) -> float:
        observation, _ = env._observation_and_features()
        action = np.asarray(policy.predict(observation, deterministic=True)[0], dtype=np.float64).reshape(-1)
        return env.parameter_from_action(float(action[-1]))
    return design


def _parameter(env: Any, design: Any) -> float:
    """The relative parameter ``design`` gives on the episode's identification."""
    if callable(design):
        return design(env)
    if design == "base":
        return env.parameter_from_action(0.0)
    from dataclasses import replace

    from baselines.oracle import oracle

    # the parameter does not change the experiments' price: one search serves every production weight
    found = oracle(env.plant, env.identification, env.structure, constraints=env.constraints,
                   weights=replace(env.weights, production=0.0))
    return found.relative_parameter


def plant_costs(env: Any, plant: Any, seed: int, replicates: int, weights: list[Any], design: Any = "base",
                firsts: tuple[float, ...] = GRID, designs: dict[float, Any] | None = None) -> np.ndarray:
    """Costs ``[A1, A2, replicate, weights]`` on one plant (module docstring): every first amplitude of
    ``firsts`` (its noise drawn with ``[seed, GRID index]``), every second of :data:`GRID`, or of
    ``designs`` (``{A2: design}``, one design per second amplitude) when given."""
    seconds = GRID if designs is None else tuple(designs)
    out = np.empty((len(firsts), len(seconds), replicates, len(weights)))
    from envs.episode import Evidence

    env.reset(seed=seed, options={"plant": plant})
    start = Evidence.empty(env.integrating, env.options)  # (a fixed-mode plan has run its experiments at reset)
    for i, first in enumerate(firsts):
        env.evidence = start
        after_first = first_experiment(env, np.random.default_rng([seed, GRID.index(first)]), first)
        for r in range(replicates):
            for m, second in enumerate(seconds):
                rng = np.random.default_rng([seed, GRID.index(first), r + 1])
                chosen = design if designs is None else designs[second]
                out[i, m, r] = continuation_costs(env, after_first, rng, first, second, weights, chosen)
    return out


def _weights(env_kwargs: list[dict[str, Any]]) -> list[Any]:
    """Each regime's cost weights (its ``weights`` argument over the defaults, as the environment reads it)."""
    from envs.analysis.scoring import CostWeights

    return [CostWeights(**dict(kwargs.get("weights", {}))) for kwargs in env_kwargs]


def _costs(env_id: str, noise: float, regimes: list[Any], plants: list[Any], episode_seed: int, replicates: int,
           path: Path, design: str) -> np.ndarray:
    """The costs of every plant of one structure and noise level, ``[plant, A1, A2, replicate, regime]``,
    read from ``path`` if it holds them for these plants and replicates (resumable per plant block)."""
    import gymnasium as gym

    import envs  # noqa: F401  (registers the environments)

    if path.exists():
        found = np.load(path)
        if found["costs"].shape[0] >= len(plants) and found["costs"].shape[3] == replicates:
            return found["costs"][: len(plants)]
    env = gym.make(env_id, experiments="plan", noise_std=noise, weights={"production": 1.0}).unwrapped
    weights = _weights([dict(r.env_kwargs) for r in regimes])
    rows = []
    for k, plant in enumerate(plants):
        rows.append(plant_costs(env, plant, episode_seed + k, replicates, weights, design))
        if (k + 1) % 250 == 0:
            print(f"headroom {env_id} noise {noise:g}: {k + 1}/{len(plants)} plants", file=sys.stderr, flush=True)
    costs = np.stack(rows)
    path.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(path, costs=costs)
    return costs


def _cross_fitted(expected_a: np.ndarray, expected_b: np.ndarray) -> np.ndarray:
    """Per plant, the continuation chosen on one half of the replicates scored on the other, both ways."""
    index = np.arange(expected_a.shape[0])
    return 0.5 * (expected_b[index, expected_a.argmin(axis=1)] + expected_a[index, expected_b.argmin(axis=1)])


def summarize(costs: np.ndarray, test_plants: int, comparisons: int, alpha: float = 0.05,
              firsts: tuple[float, ...] = GRID, seconds: tuple[float, ...] = GRID) -> dict[str, Any]:
    """The table's row of one regime from its costs ``[plant, A1, A2, replicate]`` (module docstring),
    the amplitudes ``firsts`` and ``seconds`` along the two middle axes."""
    from scipy import stats

    from agents.protocol.statistics import t_interval
    from envs.analysis.scoring import FEASIBLE_CAP

    expected = costs.mean(axis=3)
    means = expected.mean(axis=0)
    i, m = np.unravel_index(np.argmin(means), means.shape)
    half = costs.shape[3] // 2
    if half < 1:
        raise ValueError("the adaptive oracle's cross-fitting needs at least 2 replicates")
    first_half, second_half = costs[..., :half].mean(axis=3), costs[..., half:].mean(axis=3)
    adaptive = np.stack([_cross_fitted(first_half[:, a], second_half[:, a]) for a in range(len(firsts))], axis=1)
    best_first = int(np.argmin(adaptive.mean(axis=0)))
    difference = expected[:, i, m] - adaptive[:, best_first]
    n, sd = len(difference), float(difference.std(ddof=1))
    mean, low, high, _ = t_interval(difference)
    resolvable = (stats.norm.ppf(1 - alpha / (2 * comparisons)) + POWER_Z) * sd / math.sqrt(test_plants)
    fixed = float(means[firsts.index(1.0), seconds.index(1.0)]) if 1.0 in firsts and 1.0 in seconds else None
    chosen = [int(c) for c in np.bincount(np.concatenate([second_half[:, best_first].argmin(axis=1),
                                                          first_half[:, best_first].argmin(axis=1)]),
                                          minlength=len(seconds))]
    return {
        "plants": n, "replicates": int(costs.shape[3]),
        "fixed_procedure": fixed,
        "best_plan": f"plan-{firsts[i]:g}-{seconds[m]:g}", "best_plan_cost": float(means[i, m]),
        "best_plan_violating_plants": int(np.sum((costs[:, i, m, :] > FEASIBLE_CAP).any(axis=1))),
        "adaptive_first": firsts[best_first], "adaptive_cost": float(adaptive[:, best_first].mean()),
        "adaptive_second_choices": dict(zip([f"{a:g}" for a in seconds], chosen)),
        "headroom": mean, "headroom_interval": [low, high],
        "difference_sd": sd, "resolvable": float(resolvable),
    }


def _protocol_reference(protocol_name: str, regime: str) -> dict[str, Any]:
    """The protocol's own validation figures of ``regime`` if its selection is committed."""
    path = Path("results") / f"protocol_{protocol_name}" / regime / "selection.json"
    if not path.exists():
        return {}
    selection = json.loads(path.read_text())
    chosen, costs = selection["chosen"], selection["validation_mean_cost"]
    plan = chosen.get("plan")
    return {"primary": plan, "primary_cost": costs.get(plan), "plan-1-1": costs.get("plan-1-1"),
            "best_plan": chosen.get("best-plan"), "best_plan_cost": costs.get(chosen.get("best-plan"))}


def _number(value: float | None) -> str:
    """A figure to three digits; below 1e-9 in size, 0 (two means of the same per-plant costs)."""
    if value is None:
        return "-"
    return "0" if abs(value) < 1e-9 else f"{value:.3g}"


def markdown(rows: list[dict[str, Any]], test_plants: int, comparisons: int) -> str:
    lines = [
        "| regime | fixed procedure | best single plan | adaptive oracle (A1; A2 chosen 0.1/0.3/1/3) | headroom [95%] "
        f"| smallest difference resolved (n={test_plants}, m={comparisons}) | protocol: plan-1-1 | protocol: plan primary |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for row in rows:
        low, high = row["headroom_interval"]
        choices = "/".join(str(c) for c in row["adaptive_second_choices"].values())
        reference = row.get("protocol", {})
        primary = reference.get("primary")
        lines.append(
            f"| {row['regime']} | {_number(row['fixed_procedure'])} | {row['best_plan_cost']:.3g} ({row['best_plan']}; "
            f"{row['best_plan_violating_plants']} violating) "
            f"| {row['adaptive_cost']:.3g} ({row['adaptive_first']:g}; {choices}) "
            f"| {_number(row['headroom'])} [{_number(low)}, {_number(high)}] | {_number(row['resolvable'])} | {_number(reference.get('plan-1-1'))} "
            f"| {_number(reference.get('primary_cost'))}{f' ({primary})' if primary else ''} |")
    return "\n".join(lines) + "\n"


def headroom(protocol_path: Path, plants: int, replicates: int, out: Path, design: str = "base") -> str:
    """Compute (or read) every agent-mode regime's costs and write ``OUT/headroom[_DESIGN].{md,json}``."""
    if design not in DESIGNS:
        raise ValueError(f"unknown design {design!r}; designs: {', '.join(DESIGNS)}")
    from agents.protocol.config import load_protocol
    from agents.protocol.streams import plant_stream
    from envs.structures import structure

    protocol = load_protocol(protocol_path)
    regimes = [r for r in protocol.regimes if r.plan]
    groups: dict[tuple[str, float], list[Any]] = {}
    for regime in regimes:
        groups.setdefault((regime.env, float(regime.env_kwargs.get("noise_std", 0.01))), []).append(regime)
    if plants > protocol.validation.plants:
        raise ValueError(f"--plants {plants} exceeds the protocol's {protocol.validation.plants} validation plants")
    comparisons = len(protocol.comparisons) * len(regimes) + sum(1 for r in protocol.regimes if not r.plan)
    rows = []
    for (env_id, noise), members in groups.items():
        name = f"{env_id.split('/')[-1].split('-')[0].lower()}-noise{round(noise * 100):02d}"
        stream = plant_stream(structure(name.split('-')[0]).family, protocol.validation.entropy, plants)
        costs = _costs(env_id, noise, members, stream, protocol.validation.episode_seed, replicates,
                       out / "work" / f"{name}{'' if design == 'base' else '-' + design}.npz", design)
        for j, regime in enumerate(members):
            row = {"regime": regime.name, **summarize(costs[..., j], protocol.test.plants, comparisons, protocol.alpha)}
            row["protocol"] = _protocol_reference(protocol.name, regime.name)
            rows.append(row)
    table = markdown(rows, protocol.test.plants, comparisons)
    out.mkdir(parents=True, exist_ok=True)
    stem = "headroom" if design == "base" else f"headroom_{design}_design"
    (out / f"{stem}.md").write_text(table)
    (out / f"{stem}.json").write_text(json.dumps({"protocol": str(protocol_path), "design": design, "plants": plants,
                                                  "replicates": replicates, "grid": list(GRID), "rows": rows}, indent=1) + "\n")
    return table
