"""What a sequential agent does, replayed on validation plants: its experiments against the noise it measured.

    deadtime study sequential-replay RUN_DIR... [--plants 500] [--out DIR]

Each ``RUN_DIR`` is a trained agent of the discrete agent mode (``configs/sequential.yaml``); the runs
of one folder (``FOLDER/s0``, ``FOLDER/s1``, ...: the seeds of one learner) are pooled under its name.  Each is played
deterministically, with the environment's action masks, on the first ``--plants`` plants of the fixed
validation set (:func:`agents.training.validation.validation_plants`, reset seed ``3_000_000 + k`` as
``deadtime train`` validates), in its own environment and regime (its ``config.yaml``).  Per episode:
the actions in order (``info["action"]``, e.g. ``closed-loop-step@1``), the noise level the episode
measured (``sigma``, the environment's estimate from the closed-loop step's record, relative to a unit
output change: ``Evidence.noise_estimate`` of ``measured_observation``), the cost and whether the
design violates.

The table groups the episodes by the measured noise, in thirds (the terciles of the agent's own
episodes; relative to a unit output change): episodes, mean experiments the agent ran before its
commit (the commit completes the missing ones), the share of each experiment type among them, the median amplitude of the first experiment and of the second, the mean design level, mean
cost and the share violating.  The plot shows each episode's second amplitude against its measured
noise, one panel per agent.  ``--out DIR`` writes ``DIR/replay.md``, ``DIR/replay.json.gz`` (every
episode, read in place by :mod:`agents.compressed`) and ``DIR/replay.png``.  No test plant is drawn.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from agents.files.writer import write_bytes, write_figure, write_text
from envs.interface import tuning_env_of

__all__ = ["replay", "replay_agent", "summarize"]


def _episode(env: Any, policy: Any, plant: Any, seed: int) -> dict[str, Any]:
    from agents.evaluation.run import agent_action

    observation, _ = env.reset(seed=seed, options={"plant": plant})
    actions, done, info = [], False, {}
    while not done:
        action = agent_action(env, policy, observation)
        observation, _, done, _, info = env.step(action)
        actions.append(info["action"])
    # the noise level the episode measured (the latest usable closed-loop step's, the agent's own or
    # the one its commit completed): the environment's estimate, before its division by the amplitude
    estimate = getattr(env.evidence, "noise_estimate", math.nan)
    sigma = float(estimate) if math.isfinite(estimate) else None
    return {"seed": seed, "actions": actions, "sigma": sigma, "cost": float(info["cost"]),
            "feasible": bool(info.get("feasible", False))}


def replay_agent(run_dir: Path, plants: int) -> dict[str, Any]:
    """Every episode of one agent on the first ``plants`` validation plants."""
    from agents.environments import make_env
    from agents.training.policies import load_policy
    from agents.training.validation import VALIDATION_SEED, validation_plants

    policy = load_policy(run_dir)
    if policy.config is None:
        raise ValueError(f"{run_dir} has no config.yaml: the agent's environment is unknown")
    env = make_env(policy.config.env_id, policy.config.env_kwargs)
    if getattr(tuning_env_of(env), "discrete", None) is None:
        raise ValueError(f"{run_dir} was not trained on the discrete agent mode (env_kwargs.discrete_action)")
    chosen = validation_plants(env, plants)
    episodes = [_episode(tuning_env_of(env), policy, plant, VALIDATION_SEED + k) for k, plant in enumerate(chosen)]
    return {"run": str(run_dir), "env": policy.config.env_id, "env_kwargs": dict(policy.config.env_kwargs),
            "episodes": episodes}


def _runs(actions: list[str]) -> list[tuple[str, float]]:
    """The experiments of an episode before its commit: ``(type, amplitude)`` in order."""
    found = []
    for action in actions:
        kind, value = action.rsplit("@", 1)
        if kind == "commit":
            break
        if kind != "design":
            found.append((kind, float(value)))
    return found


def _design(actions: list[str]) -> float | None:
    kind, value = actions[-1].rsplit("@", 1)
    return float(value) if kind == "design" else None


def summarize(episodes: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The rows of the table: one per third of the measured noise (module docstring), then all episodes."""
    measured = [e["sigma"] for e in episodes if e["sigma"] is not None]
    edges = (0.0, *np.quantile(measured, [1 / 3, 2 / 3]), math.inf) if len(measured) >= 3 else (0.0, math.inf)
    rows = []
    for low, high in [*zip(edges[:-1], edges[1:]), (None, None)]:
        chosen = [e for e in episodes if low is None or (e["sigma"] is not None and low <= e["sigma"] < high)]
        if low is not None and not chosen:
            continue
        runs = [_runs(e["actions"]) for e in chosen]
        kinds = sorted({kind for r in runs for kind, _ in r})
        total = sum(len(r) for r in runs)
        designs = [d for d in (_design(e["actions"]) for e in chosen) if d is not None]
        rows.append({
            "noise": "all" if low is None else f"{low:.3g}-{high:.3g}",
            "episodes": len(chosen),
            "experiments": float(np.mean([len(r) for r in runs])) if runs else 0.0,
            "shares": {kind: sum(1 for r in runs for k, _ in r if k == kind) / total for kind in kinds} if total else {},
            "first_amplitude": float(np.median([r[0][1] for r in runs if r])) if any(runs) else None,
            "second_amplitude": float(np.median([r[1][1] for r in runs if len(r) > 1])) if any(len(r) > 1 for r in runs) else None,
            "design_level": float(np.mean(designs)) if designs else None,
            "cost": float(np.mean([e["cost"] for e in chosen])),
            "violating": float(np.mean([not e["feasible"] for e in chosen])),
        })
    return rows


def _value(value: float | None) -> str:
    return "-" if value is None else f"{value:.3g}"


def markdown(agents: list[dict[str, Any]]) -> str:
    lines = ["| agent | measured noise | episodes | experiments | types run (share) | first amplitude (median) "
             "| second amplitude (median) | design level (mean) | mean cost | violating |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for agent in agents:
        name = Path(agent["run"]).name
        for row in summarize(agent["episodes"]):
            shares = ", ".join(f"{kind} {share:.0%}" for kind, share in row["shares"].items()) or "-"
            lines.append(f"| {name} | {row['noise']} | {row['episodes']} | {row['experiments']:.2f} | {shares} "
                         f"| {_value(row['first_amplitude'])} | {_value(row['second_amplitude'])} "
                         f"| {_value(row['design_level'])} | {row['cost']:.3g} | {row['violating']:.1%} |")
    return "\n".join(lines) + "\n"


def plot(agents: list[dict[str, Any]], path: Path) -> None:
    """Each episode's second amplitude against its measured noise, one panel per agent."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(1, len(agents), figsize=(4.0 * len(agents), 3.4), squeeze=False, sharey=True)
    rng = np.random.default_rng(0)
    for axis, agent in zip(axes[0], agents):
        points = [(e["sigma"], r[1][1], len(r)) for e in agent["episodes"]
                  for r in [_runs(e["actions"])] if e["sigma"] is not None and len(r) > 1]
        if points:
            sigma, amplitude, count = (np.array(v, dtype=float) for v in zip(*points))
            jitter = amplitude * 10.0 ** rng.uniform(-0.05, 0.05, len(amplitude))  # the levels are discrete
            shown = axis.scatter(sigma, jitter, c=count, s=8, cmap="viridis", vmin=1, vmax=4)
        axis.set_xscale("log")
        axis.set_yscale("log")
        axis.set_xlabel("measured noise sigma")
        axis.set_title(Path(agent["run"]).name, fontsize=9)
    axes[0][0].set_ylabel("second experiment's amplitude")
    if points:
        figure.colorbar(shown, ax=axes[0].tolist(), label="experiments before the commit")
    write_figure(path, figure, 120, bbox_inches="tight")
    plt.close(figure)


def _pooled(played: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The agents of one folder (their seeds) as one, named by the folder, episodes pooled."""
    groups: dict[str, dict[str, Any]] = {}
    for agent in played:
        run = Path(agent["run"])
        name = str(run.parent) if run.name.startswith("s") and run.name[1:].isdigit() else str(run)
        group = groups.setdefault(name, {**agent, "run": name, "runs": [], "episodes": []})
        group["runs"].append(agent["run"])
        group["episodes"] = group["episodes"] + agent["episodes"]
    return list(groups.values())


def replay(run_dirs: list[Path], plants: int, out: Path | None) -> str:
    """Replay every agent and return the table; ``out`` writes ``replay.{md,json,png}``."""
    from agents.compressed import compressed_bytes

    if isinstance(plants, bool) or not isinstance(plants, int) or plants < 1:
        raise ValueError(f"--plants must be a whole number of at least 1, got {plants!r}")
    agents = _pooled([replay_agent(run, plants) for run in run_dirs])
    table = markdown(agents)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        write_text(out / "replay.md", table)
        data = json.dumps({"plants": plants, "agents": agents}) + "\n"
        write_bytes(out / "replay.json.gz", compressed_bytes(data.encode()))
        plot(agents, out / "replay.png")
    return table
