"""The headroom with learned designs, and the sequential learners measured against it.

    deadtime study headroom --design learned --fits RUN_DIR... [--agents RUN_DIR...] [--training-plants N]

The adaptive oracle of :mod:`agents.studies.headroom` with a learned design per second amplitude: each
fit is a learned design of a fixed plan ``[A1, A2]`` (``configs/learned_plan.yaml``), the fits of one
environment, regime and ``A1`` are one group, and each continuation ``A2`` is designed by its own fit
(a design learned for that plan's observations).  On the protocol's validation plants (no test plant)
it reports the best single plan, the adaptive oracle and the headroom as the base-rule table does,
and beside them:

* ``--training-plants N``: the learned continuation (:mod:`agents.studies.continuation`);
* ``--agents``: sequential agents (one run per seed, e.g. MaskablePPO on the discrete agent mode),
  played on the same plants with the protocol's episode seeds, in their own environment: their mean
  cost [two-way bootstrap 95%], the interquartile mean of the per-seed means, the difference to the best
  single plan [95%, paired on the plants], the share of the headroom reached, and the plants where
  a seed's design violates (exact 95%).

Writes ``OUT/headroom_learned_design.{md,json}``; the learned designs' costs are kept in
``OUT/work/REGIME-learned.npz`` (reused while the fits and the plant and replicate counts are the same).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from agents.files.writer import atomic_write, write_text
from agents.protocol.statistics import t_interval
from agents.studies.continuation import CONTINUATION_ENTROPY, learned_continuation
from agents.studies.headroom import _protocol_reference, markdown, plant_costs, policy_design, summarize
from envs.interface import tuning_env_of

__all__ = ["agent_costs", "learned_headroom"]


def _agent_regime(run_dir: Path) -> tuple[str, float, float]:
    """``(env_id, noise, production)`` of a trained agent's run (its ``config.yaml``)."""
    from agents.training.config import load_config

    config = load_config(Path(run_dir) / "config.yaml")
    kwargs = config.env_kwargs
    return (config.env_id, float(kwargs.get("noise_std", 0.01)),
            float(dict(kwargs.get("weights") or {}).get("production", 0.05)))


def _share(share: float | None) -> str:
    """A share of the headroom: none where the learner costs more than the best single plan."""
    if share is None:
        return "-"
    if share > 1.0:  # cheaper than the adaptive oracle of the learned designs: another design, not the experiments
        return f"{share:.0%}: beyond it (its own design)"
    return "none (it costs more)" if share < -0.005 else f"{max(share, 0.0) + 0.0:.0%}"  # (no "-0%")


def _continuation_markdown(rows: list[dict[str, Any]]) -> str:
    found = [row for row in rows if "continuation" in row]
    if not found:
        return ""
    lines = ["", "| regime | seq-continuation (training plants) | thresholds (cross-fitted) | mean cost "
             "| minus the best single plan [95%] | share of the headroom reached | A2 chosen |", "|---|---|---|---|---|---|---|"]
    for row in found:
        c = row["continuation"]
        d, dl, dh = c["minus_best_plan"]
        share = c["share_of_headroom"]
        lines.append(f"| {row['regime']} | {c['training_plants']} | {', '.join(f'{t:g}' for t in c['thresholds'])} "
                     f"| {c['mean_cost']:.3g} | {d:.3g} [{dl:.3g}, {dh:.3g}] "
                     f"| {_share(share)} | {'/'.join(str(v) for v in c['choices'].values())} |")
    return "\n".join(lines) + "\n"


def _learners_markdown(rows: list[dict[str, Any]]) -> str:
    found = [row for row in rows if "learners" in row]
    if not found:
        return ""
    lines = ["", "| regime | learners (seeds) | mean cost [95%] | IQM of the per-seed means | minus the best single plan [95%] "
             "| share of the headroom reached | plants violating in any seed [95%] |", "|---|---|---|---|---|---|---|"]
    for row in found:
        learners = row["learners"]
        low, high = learners["mean_interval"]
        d, dl, dh = learners["minus_best_plan"]
        share = learners["share_of_headroom"]
        lines.append(f"| {row['regime']} | {learners['seeds']} | {learners['mean_cost']:.3g} [{low:.3g}, {high:.3g}] "
                     f"| {learners['iqm_of_seed_means']:.3g} | {d:.3g} [{dl:.3g}, {dh:.3g}] "
                     f"| {_share(share)} "
                     f"| {100 * learners['violations']['rate']:.2f}% [{100 * learners['violations']['interval'][0]:.2f}, "
                     f"{100 * learners['violations']['interval'][1]:.2f}]% |")
    return "\n".join(lines) + "\n"


def _fit_key(policy: Any) -> tuple[str, float, float, float]:
    kwargs = policy.env_kwargs
    plan = kwargs.get("plan")
    if plan is None or kwargs.get("experiments", "fixed") != "fixed":
        raise ValueError(f"{policy.path}: not a learned design of a fixed plan (env_kwargs.plan)")
    production = float(dict(kwargs.get("weights") or {}).get("production", 0.05))
    return policy.env_id, float(kwargs.get("noise_std", 0.01)), production, float(plan[0])


def _matching_regime(protocol: Any, env_id: str, noise: float, production: float) -> Any:
    for regime in protocol.regimes:
        kwargs = regime.env_kwargs
        if (regime.plan and regime.env == env_id and float(kwargs.get("noise_std", 0.01)) == noise
                and float(dict(kwargs.get("weights") or {}).get("production", 0.05)) == production):
            return regime
    raise ValueError(f"{protocol.path}: no agent-mode regime of {env_id} at noise {noise:g}, production {production:g}")


def agent_costs(run_dir: Path, plants: list[Any], episode_seed: int) -> tuple[np.ndarray, np.ndarray]:
    """A trained agent's cost and feasibility on each plant, reset with seed ``episode_seed + k`` as the
    protocol's evaluation resets it, in its own environment (its ``config.yaml``), with the environment's masks."""
    from agents.environments import make_env
    from agents.evaluation.run import agent_action
    from agents.training.policies import load_policy

    policy = load_policy(run_dir)
    env = tuning_env_of(make_env(policy.config.env_id, policy.config.env_kwargs))
    costs, feasible = [], []
    for k, plant in enumerate(plants):
        observation, _ = env.reset(seed=episode_seed + k, options={"plant": plant})
        done, info = False, {}
        while not done:
            observation, _, done, _, info = env.step(agent_action(env, policy, observation))
        costs.append(float(info["cost"]))
        feasible.append(bool(info.get("feasible", False)))
    return np.array(costs), np.array(feasible)


def _cached_agent_costs(run_dir: Path, plants: list[Any], episode_seed: int, work: Path) -> tuple[np.ndarray, np.ndarray]:
    """:func:`agent_costs`, kept in ``WORK/agents/HASH.npz`` (the run's model file, the plants, the seed)."""
    import hashlib

    from agents.training.policies import resolve_model_path

    model = resolve_model_path(run_dir)
    identity = json.dumps([str(model.resolve()), model.stat().st_size, model.stat().st_mtime_ns, len(plants), episode_seed])
    path = work / "agents" / f"{hashlib.sha256(identity.encode()).hexdigest()[:16]}.npz"
    if path.exists():
        found = np.load(path)
        return found["costs"], found["feasible"]
    costs, feasible = agent_costs(run_dir, plants, episode_seed)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic_write(path, lambda handle: np.savez_compressed(handle, costs=costs, feasible=feasible))
    return costs, feasible


def _learners(rows: np.ndarray, feasible: np.ndarray, best_plan: np.ndarray, headroom: float) -> dict[str, Any]:
    """The learners' costs ``(seeds, plants)`` against the best single plan's per-plant expected costs,
    and the plants where a seed's design violates."""
    from agents.protocol.statistics import plant_violations

    from agents.evaluation.seed_statistics import bootstrap_interval, iqm, paired_difference

    mean = float(rows.mean())
    difference = paired_difference(rows, best_plan[None, :])
    return {"seeds": int(rows.shape[0]), "mean_cost": mean,
            "mean_interval": bootstrap_interval(rows, lambda r, _: r.mean(axis=(-2, -1))),
            "iqm_of_seed_means": iqm(rows.mean(axis=1)), "per_seed_mean_cost": [float(v) for v in rows.mean(axis=1)],
            "minus_best_plan": difference,
            "share_of_headroom": None if headroom <= 0 else float(-difference[0] / headroom),
            "violations": plant_violations(feasible).to_dict()}


def learned_headroom(protocol_path: Path, fits: list[Path], plants: int, replicates: int, out: Path,
                     agents: list[Path] = (), training_plants: int = 0) -> str:
    """The headroom with a learned design per second amplitude: ``fits`` are learned-rule fits of fixed
    plans ``[A1, A2]`` (``configs/learned_plan.yaml``), grouped by environment, regime and ``A1``; each
    continuation ``A2`` is designed by its own fit.  ``agents`` (sequential agents, one run per seed)
    are played on the same plants and reported against the best single plan, with the share of the
    headroom they reach.  Writes ``OUT/headroom_learned_design.{md,json}``."""
    import gymnasium as gym

    import envs  # noqa: F401
    from agents.protocol.config import load_protocol
    from agents.protocol.streams import plant_stream
    from agents.training.learned_rule_policy import load_learned_rule
    from envs.analysis.scoring import CostWeights

    protocol = load_protocol(protocol_path)
    groups: dict[tuple[str, float, float, float], dict[float, Any]] = {}
    for path in fits:
        policy = load_learned_rule(path)
        groups.setdefault(_fit_key(policy), {})[float(policy.env_kwargs["plan"][1])] = policy
    comparisons = len(protocol.comparisons) * sum(1 for r in protocol.regimes if r.plan) + sum(1 for r in protocol.regimes if not r.plan)
    rows = []
    for (env_id, noise, production, first), by_second in sorted(groups.items()):
        regime = _matching_regime(protocol, env_id, noise, production)
        seconds = tuple(sorted(by_second))
        kwargs = dict(next(iter(by_second.values())).env_kwargs)
        env = tuning_env_of(gym.make(env_id, **kwargs))
        weights = [CostWeights(**dict(regime.env_kwargs.get("weights", {})))]
        designs = {a: policy_design(by_second[a]) for a in seconds}
        family = env.kind.family
        stream = plant_stream(family, protocol.validation.entropy, plants)
        cache = out / "work" / f"{regime.name}-learned.npz"
        identity = json.dumps([str(by_second[a].path) for a in seconds])
        found = np.load(cache) if cache.exists() else None
        if found is not None and str(found["fits"]) == identity and found["costs"].shape[0] == plants \
                and found["costs"].shape[3] == replicates:
            costs = found["costs"]
        else:
            costs = np.stack([plant_costs(env, plant, protocol.validation.episode_seed + k, replicates, weights,
                                          firsts=(first,), designs=designs) for k, plant in enumerate(stream)])
            cache.parent.mkdir(parents=True, exist_ok=True)
            atomic_write(cache, lambda handle: np.savez_compressed(handle, costs=costs, fits=identity))
        row = {"regime": regime.name, "fits": {f"{a:g}": str(by_second[a].path.parent) for a in seconds},
               **summarize(costs[..., 0], protocol.test.plants, comparisons, protocol.alpha, (first,), seconds)}
        row["protocol"] = _protocol_reference(protocol.name, regime.name)
        i, m = np.unravel_index(np.argmin(costs[..., 0].mean(axis=(0, 3))), costs.shape[1:3])
        if training_plants:
            training = plant_stream(family, CONTINUATION_ENTROPY, training_plants)
            found = learned_continuation(env, designs, weights, first, training, stream, protocol.validation.episode_seed,
                                         costs[:, 0, :, :, 0].mean(axis=2), out / "work" / f"{regime.name}-continuation.npz",
                                         identity)
            difference = found.pop("per_plant") - costs[:, i, m, :, 0].mean(axis=1)
            row["continuation"] = {**found, "mean_cost": float(costs[:, i, m, :, 0].mean() + difference.mean()),
                                   "minus_best_plan": list(t_interval(difference)[:3]),
                                   "share_of_headroom": None if row["headroom"] <= 0 else float(-difference.mean() / row["headroom"])}
        mine = [run for run in agents if _agent_regime(run) == (env_id, noise, production)]
        if mine:
            played = [_cached_agent_costs(run, stream, protocol.validation.episode_seed, out / "work") for run in mine]
            row["learners"] = {"runs": [str(run) for run in mine],
                               **_learners(np.stack([c for c, _ in played]), np.stack([f for _, f in played]),
                                           costs[:, i, m, :, 0].mean(axis=1), row["headroom"])}
        rows.append(row)
        print(f"headroom {regime.name}, learned designs: {row['headroom']:.3g}", file=sys.stderr, flush=True)
    table = markdown(rows, protocol.test.plants, comparisons) + _continuation_markdown(rows) + _learners_markdown(rows)
    out.mkdir(parents=True, exist_ok=True)
    write_text(out / "headroom_learned_design.md", table)
    write_text(out / "headroom_learned_design.json", json.dumps(
        {"protocol": str(protocol_path), "design": "learned", "plants": plants, "replicates": replicates, "rows": rows},
        indent=1) + "\n")
    return table
