"""Sweeps that differ only in their regime (``env_kwargs``), side by side (``deadtime regimes``, whose
command line is :mod:`agents.commands.regimes`).

Each argument is the output directory of a finished ``deadtime sweep`` whose file sets
``env_kwargs`` (:mod:`agents.sweeps.config`); the sweeps share their evaluation (plants, episode
seeds) and environment.  Sweeps of the same regime are merged: their agent groups side by side
(a follow-up with another training budget, say), their rules' and oracle's costs checked equal.  Per regime and environment, from the evaluations'
``per_plant.csv`` (the same held-out plants and episode seeds in every regime):

* every policy's mean cost with its 95% interval (:mod:`agents.evaluation.seed_statistics`: agents
  over seeds and plants, the rules and the oracle over plants);
* the paired differences of an agent group to other policies (``--compare A,B[,C...]``: ``mean(A) -
  mean(B)`` for each, ``B`` an agent group, a rule or a procedure of :mod:`baselines.procedures`; each
  group's seeds resampled on their own, the plants together; where an environment lacks ``A`` or a
  ``B``, as a follow-up sweep on some structures only, that difference is left out there) and of
  every agent group to every rule;
  a group *beats every rule* where each of those intervals lies below 0 (the procedures are not rules:
  they are compared by ``--compare``, and the best rule is the best of the rules);
* with ``--behaviour N``: what each agent group does, replayed on the first ``N`` validation plants
  (never the test plants) in its regime: the experiments it chooses and how many, their amplitudes,
  the experiments its commit completes, the experiment time and production deviation, and its design
  action (in the action's coordinate); in plan mode, the two amplitudes it plans per plant.  A learned
  rule (``learned_rule.json``) is replayed as an agent: in fixed mode it chooses no experiment, its
  plan (``env_kwargs.plan``) completes them.  Groups whose runs are not on disk (a committed summary)
  are left out of the behaviour.

Writes ``regimes.md``, ``regimes.json`` and ``regimes.png`` (cost against ``--x`` per policy, one panel
per value of the regimes' other arguments) into ``--out``.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from agents.files.reader import FileProblem, exists, load_yaml_file, read_json, stored_path

__all__ = ["behaviour", "compare_regimes", "figure_of", "markdown", "write_outputs"]

ORACLES = ("oracle", "oracle-full")


def write_outputs(out: Path, result: dict[str, Any], text: str) -> None:
    """``regimes.json``, ``regimes.md`` (``text``) and ``regimes.png`` into ``out``, all or none
    (:func:`agents.files.writer.atomic_write_all`: a full disk leaves the previous files, and no empty one)."""
    import matplotlib.pyplot as plt

    from agents.files.writer import atomic_write_all, figure_writer, text_writer

    figure = figure_of(result)
    try:
        atomic_write_all({out / "regimes.json": text_writer(json.dumps(result, indent=2) + "\n"),
                          out / "regimes.md": text_writer(text), out / "regimes.png": figure_writer(figure, 110)})
    finally:
        plt.close(figure)


# ------------------------------------------------------------------------------- reading
def _regime(directory: Path) -> tuple[str, dict[str, Any]]:
    """The sweep's name and ``env_kwargs``: from the copy of its file the sweep keeps, or from its
    ``summary.json`` (a committed sweep under ``results/`` keeps the summary, its file being in ``configs/sweeps/``)."""
    path, summary = directory / "sweep.yaml", directory / "summary.json"
    if path.is_file():
        data = load_yaml_file(path, (dict, type(None))) or {}
    elif exists(summary):
        path = stored_path(summary)
        record = read_json(summary)
        data = {"name": record.get("sweep"), "env_kwargs": record.get("env_kwargs")}
    else:
        raise ValueError(f"{directory}: not the output directory of a sweep (no sweep.yaml or summary.json)")
    if not data.get("env_kwargs"):
        raise FileProblem(f"{path}: sets no env_kwargs, so it is no regime")
    if not isinstance(data["env_kwargs"], dict):
        raise FileProblem(f"{path}: env_kwargs must be a mapping of environment arguments, got {data['env_kwargs']!r:.60}")
    return str(data.get("name", directory.name)), dict(data["env_kwargs"])


def _environment(directory: Path, env: Path) -> tuple[dict[str, np.ndarray], dict[str, np.ndarray], dict[str, list[Path]]]:
    """Rules and oracle ``{name: (plants,)}``, agent groups ``{label: (seeds, plants)}`` and each group's runs."""
    from agents.sweeps.summary import per_plant_costs

    baselines = per_plant_costs(env / "baselines")
    plants = sorted(next(iter(baselines.values())))
    rules = {name: np.array([costs[p] for p in plants]) for name, costs in baselines.items()}
    groups: dict[str, list[np.ndarray]] = {}
    runs: dict[str, list[Path]] = {}
    for trial in sorted(p for p in env.iterdir() if p.is_dir() and p.name != "baselines"):
        label = trial.name[: trial.name.rindex(f"-{env.name}-s")]
        costs = per_plant_costs(trial)["agent"]
        if sorted(costs) != plants:
            raise ValueError(f"{trial}: its plants differ from the baselines'")
        groups.setdefault(label, []).append(np.array([costs[p] for p in plants]))
        runs.setdefault(label, []).append(directory / "runs" / trial.name)
    return rules, {label: np.vstack(rows) for label, rows in groups.items()}, runs


# ------------------------------------------------------------------------------- statistics
def _interval(costs: np.ndarray, resamples: int) -> list[float]:
    from agents.evaluation.seed_statistics import bootstrap_interval

    return [float(costs.mean()), *bootstrap_interval(costs, lambda c, p: c.mean(axis=(-2, -1)), resamples=resamples)]


def _entry(rules: dict[str, np.ndarray], agents: dict[str, np.ndarray], compare: tuple[str, ...], resamples: int) -> dict[str, Any]:
    from agents.evaluation.seed_statistics import VIOLATION_COST, paired_difference

    from baselines.procedures import is_procedure

    policies = {name: _interval(v[None, :], resamples) for name, v in rules.items()}
    policies.update({label: _interval(m, resamples) for label, m in agents.items()})
    named = [name for name in rules if name not in ORACLES and not is_procedure(name)]
    best = min(named, key=lambda name: (rules[name].mean(), name))
    to_rules = {}
    for label, matrix in agents.items():
        differences = {name: paired_difference(matrix, rules[name][None, :], resamples=resamples) for name in named}
        worst = max(differences, key=lambda name: (differences[name][2], name))
        to_rules[label] = {"best_rule": differences[best], "least_beaten_rule": worst,
                           "least_beaten_difference": differences[worst],
                           "beats_every_rule": all(d[2] < 0 for d in differences.values())}
    entry = {"plants": int(next(iter(rules.values())).size), "best_rule": best, "mean_cost": policies,
             "violation_rate": {name: float(np.mean(np.asarray(v) >= VIOLATION_COST)) for name, v in {**rules, **agents}.items()},
             "agents_to_rules": to_rules}
    if compare:
        others = {**{name: v[None, :] for name, v in rules.items()}, **agents}
        entry["differences"] = [{"first": compare[0], "second": name,
                                 "estimate": paired_difference(agents[compare[0]], others[name], resamples=resamples)}
                                for name in compare[1:]]
    return entry


def _merged(directories: list[Path], x: str) -> dict[tuple[str, str], dict[str, Any]]:
    """The sweeps' evaluations per (regime, environment): sweeps of the same regime are merged (their
    agent groups side by side; their rules and oracle must be the same numbers, on the same plants)."""
    found: dict[tuple[str, str], dict[str, Any]] = {}
    for directory in directories:
        name, env_kwargs = _regime(directory)
        if x not in env_kwargs:
            raise ValueError(f"{directory}: env_kwargs has no {x!r} (it has {', '.join(env_kwargs)})")
        for env in sorted(p for p in (directory / "eval").iterdir() if p.is_dir()):
            rules, agents, runs = _environment(directory, env)
            key = (json.dumps(env_kwargs, sort_keys=True), env.name)
            if key not in found:
                found[key] = {"sweeps": [], "env_kwargs": env_kwargs, "rules": rules, "agents": {}, "runs": {}}
            entry = found[key]
            if sorted(entry["rules"]) != sorted(rules) or any(not np.array_equal(entry["rules"][n], rules[n]) for n in rules):
                raise ValueError(f"{directory}: its rules' costs differ from those of {entry['sweeps'][0]} in the same regime")
            taken = sorted(set(entry["agents"]) & set(agents))
            if taken:
                raise ValueError(f"{directory}: agent group {taken[0]!r} is also in {entry['sweeps'][0]}")
            entry["sweeps"].append(name)
            entry["agents"].update(agents)
            entry["runs"].update(runs)
    return found


def _check_compare(merged: dict[tuple[str, str], dict[str, Any]], compare: tuple[str, ...]) -> None:
    """Refuse a ``--compare`` name that no regime has (a misspelling); a name that some environments
    lack (a follow-up sweep on some structures only) is compared where it is."""
    groups = {label for found in merged.values() for label in found["agents"]}
    names = groups | {name for found in merged.values() for name in found["rules"]}
    missing = [label for label in compare[:1] if label not in groups] + [name for name in compare[1:] if name not in names]
    if missing:
        raise ValueError(f"no agent group, rule or procedure {missing[0]!r} in any regime (groups: {', '.join(sorted(groups))})")


def compare_regimes(directories: list[Path], x: str, compare: tuple[str, ...] = (), plants: int = 0, resamples: int = 2000) -> dict[str, Any]:
    """The ``regimes.json`` object of the module docstring."""
    regimes = []
    merged = _merged(directories, x)
    _check_compare(merged, compare)
    for (_, env), found in merged.items():
        others = tuple(name for name in compare[1:] if name in found["agents"] or name in found["rules"])
        here = (compare[0], *others) if compare and compare[0] in found["agents"] else ()
        entry = _entry(found["rules"], found["agents"], here, resamples)
        if plants:
            entry["behaviour"] = {label: behaviour(group, found["env_kwargs"], plants) for label, group in found["runs"].items()
                                  if all(map(_replayable, group))}
        regimes.append({"sweep": " + ".join(found["sweeps"]), "env": env, "env_kwargs": found["env_kwargs"], **entry})
    regimes.sort(key=lambda r: (r["env"], json.dumps({k: v for k, v in r["env_kwargs"].items() if k != x}, sort_keys=True),
                                r["env_kwargs"][x]))
    return {"x": x, "regimes": regimes}


# ------------------------------------------------------------------------------- behaviour
def _replayable(run: Path) -> bool:
    """Whether ``run`` holds a model :func:`behaviour` can replay (a committed summary keeps none)."""
    from agents.training.learned_rule_policy import MODEL_FILE, PICKLE_FILE
    from agents.training.policies import MODEL_FILES

    return any((run / name).is_file() for name in (MODEL_FILE, PICKLE_FILE, *MODEL_FILES))


def behaviour(runs: list[Path], env_kwargs: dict[str, Any], plants: int) -> dict[str, Any]:
    """What the agents of one group do on the first ``plants`` validation plants (episode seed = index).

    Per episode: the experiments the agent chose (its steps before the commit), those the commit
    completed (the fixed procedure's: at the commit's amplitude with ``design_step``, else 1 or the
    limit), the agent's amplitudes and the commit's, the plan's two amplitudes (the plan mode's first
    step, or the fixed mode's ``plan``), the experiment time and deviation in true ``T_ar`` and the
    design action; averaged over the episodes of every seed, with the spread of the per-seed means.
    """
    from agents.environments import make_env
    from agents.training.learned_rule_policy import is_learned_rule, load_learned_rule
    from agents.training.policies import load_policy
    from envs.interface import episode_of, tuning_env_of
    from envs.systems.plant_sets import plant_set

    chosen: Counter = Counter()
    amplitudes, commit_amplitudes, per_seed_counts, per_seed_time, actions, deviations, completed = [], [], [], [], [], [], []
    plans = []
    for path in runs:
        policy = load_learned_rule(path) if is_learned_rule(path) else load_policy(path)
        env = make_env(policy.env_id, {**dict(policy.env_kwargs or {}), **env_kwargs})
        counts, times = [], []
        base = tuning_env_of(env)
        for index, plant in enumerate(plant_set(base.family, "validation", plants)):
            observation, _ = env.reset(seed=index, options={"plant": plant})
            if base.plan is not None:  # the fixed mode with a plan: the same amplitudes on every plant
                plans.append(base.plan)
            steps = 0
            while True:
                action, _ = policy.predict(observation, deterministic=True)
                observation, _, terminated, _, info = env.step(action)
                if "amplitudes" in info:  # plan mode's first step: the plan the agent chose for this plant
                    plans.append(info["amplitudes"])
                if terminated:
                    break
                if "amplitudes" in info:
                    continue
                if "experiment" not in info:  # design_step: the commit completed the identification
                    commit_amplitudes.append(info["amplitude"])
                    continue
                steps += 1
                chosen[info["experiment"]] += 1
                amplitudes.append(info["amplitude"])
            evidence = episode_of(env).evidence
            totals = dict(zip(evidence.experiments, evidence.counts))
            completed.append(sum(totals.values()) - steps)
            counts.append(steps)
            times.append(info["experiment_time"])
            deviations.append(info.get("experiment_deviation", float("nan")))
            actions.append(float(np.asarray(action).reshape(-1)[-1]))
        per_seed_counts.append(float(np.mean(counts)))
        per_seed_time.append(float(np.mean(times)))
    total = sum(chosen.values())
    return {
        "seeds": len(runs), "plants": plants,
        "experiments_chosen": float(np.mean(per_seed_counts)),
        "experiments_chosen_range": [min(per_seed_counts), max(per_seed_counts)],
        "experiments_completed_by_commit": float(np.mean(completed)),
        "share_of_chosen": {kind: count / total for kind, count in chosen.most_common()} if total else {},
        "amplitude_quartiles": [float(q) for q in np.quantile(amplitudes, [0.25, 0.5, 0.75])] if amplitudes else [],
        "commit_amplitude_quartiles": [float(q) for q in np.quantile(commit_amplitudes, [0.25, 0.5, 0.75])] if commit_amplitudes else [],
        "experiment_time": float(np.mean(per_seed_time)),
        "experiment_time_range": [min(per_seed_time), max(per_seed_time)],
        "experiment_deviation": float(np.nanmean(deviations)) if np.isfinite(deviations).any() else None,
        "design_action_quartiles": [float(q) for q in np.quantile(actions, [0.25, 0.5, 0.75])],
        "plan_amplitude_quartiles": ([[float(q) for q in np.quantile(column, [0.25, 0.5, 0.75])] for column in np.asarray(plans).T]
                                     if plans else []),
    }


# ------------------------------------------------------------------------------- output
def _cell(values: list[float]) -> str:
    return f"{values[0]:.3g} [{values[1]:.3g}, {values[2]:.3g}]"


def _label(regime: dict[str, Any]) -> str:
    return ", ".join(f"{key}={json.dumps(value, sort_keys=True)}" for key, value in regime["env_kwargs"].items())


def markdown(result: dict[str, Any]) -> str:
    """``regimes.md``: the regimes' table, every policy's mean cost per regime, and the behaviour."""
    regimes = result["regimes"]
    agents = list(dict.fromkeys(label for r in regimes for label in r["agents_to_rules"]))  # a group may miss a regime
    pairs = list(dict.fromkeys((d["first"], d["second"]) for r in regimes for d in r.get("differences", [])))
    head = ["regime", "env", "oracle", "best rule", *agents]
    head += [f"{first} - {second}" for first, second in pairs]
    head += [f"{label} - best rule" for label in agents] + [f"{label} beats every rule" for label in agents]
    lines = ["# Regimes", "", "Mean cost [95% interval]; differences are paired on the plants (negative: the first is better).", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in regimes:
        costs = r["mean_cost"]
        cells = [_label(r), r["env"], _cell(costs["oracle"]), f"`{r['best_rule']}` {_cell(costs[r['best_rule']])}"]
        cells += [_cell(costs[label]) if label in costs else "-" for label in agents]
        differences = {(d["first"], d["second"]): d["estimate"] for d in r.get("differences", [])}
        cells += [_cell(differences[pair]) if pair in differences else "-" for pair in pairs]
        found = r["agents_to_rules"]
        cells += [_cell(found[label]["best_rule"]) if label in found else "-" for label in agents]
        cells += ["-" if label not in found else "yes" if found[label]["beats_every_rule"] else
                  f"no (`{found[label]['least_beaten_rule']}`: {_cell(found[label]['least_beaten_difference'])})"
                  for label in agents]
        lines.append("| " + " | ".join(cells) + " |")
    names = sorted({name for r in regimes for name in r["mean_cost"]}, key=lambda n: (regimes[0]["mean_cost"].get(n, [0])[0], n))
    lines += ["", "## Every policy's mean cost", "", "| policy | " + " | ".join(_label(r) for r in regimes) + " |",
              "|" + "---|" * (len(regimes) + 1)]
    for name in names:
        lines.append(f"| {name} | " + " | ".join(f"{r['mean_cost'][name][0]:.3f}" if name in r["mean_cost"] else "-" for r in regimes) + " |")
    if any("behaviour" in r for r in regimes):
        lines += ["", "## What the agents do (validation plants)", "",
                  "| regime | env | agents | experiments chosen (seed range) | completed by the commit | share of the chosen | "
                  "amplitude quartiles | commit's amplitude quartiles | plan's amplitude quartiles (closed-loop step; second) | "
                  "experiment time T_ar (seed range) | D_exp/T_ar | design action quartiles |",
                  "|---|---|---|---|---|---|---|---|---|---|---|---|"]
        for r in regimes:
            for label, b in r.get("behaviour", {}).items():
                share = ", ".join(f"{k} {v:.0%}" for k, v in b["share_of_chosen"].items()) or "-"
                amplitude = ", ".join(f"{v:.2g}" for v in b["amplitude_quartiles"]) or "-"
                commit = ", ".join(f"{v:.2g}" for v in b["commit_amplitude_quartiles"]) or "-"
                plan = "; ".join(", ".join(f"{v:.2g}" for v in q) for q in b.get("plan_amplitude_quartiles", [])) or "-"
                deviation = "-" if b["experiment_deviation"] is None else f"{b['experiment_deviation']:.2f}"
                lines.append(
                    f"| {_label(r)} | {r['env']} | {label} | {b['experiments_chosen']:.2f} ({b['experiments_chosen_range'][0]:.2f}-"
                    f"{b['experiments_chosen_range'][1]:.2f}) | {b['experiments_completed_by_commit']:.2f} | {share} | {amplitude} | {commit} | {plan} | "
                    f"{b['experiment_time']:.1f} ({b['experiment_time_range'][0]:.1f}-{b['experiment_time_range'][1]:.1f}) | "
                    f"{deviation} | {', '.join(f'{v:+.2f}' for v in b['design_action_quartiles'])} |")
    return "\n".join(lines) + "\n"


def figure_of(result: dict[str, Any]) -> Any:
    """The figure of ``regimes.png``: cost against ``x`` per policy: the agents with their intervals, the
    oracle, the best rules; one panel per environment and setting of the other arguments."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = result["x"]
    panels: dict[str, list[dict[str, Any]]] = {}
    for r in result["regimes"]:
        rest = {k: v for k, v in r["env_kwargs"].items() if k != x}
        panels.setdefault(f"{r['env']} {json.dumps(rest, sort_keys=True)}", []).append(r)
    figure, axes = plt.subplots(1, len(panels), figsize=(6 * len(panels), 4.5), squeeze=False)
    for axis, (title, regimes) in zip(axes[0], panels.items()):
        xs = [r["env_kwargs"][x] for r in regimes]
        agents = list(regimes[0]["agents_to_rules"])
        shown = list(dict.fromkeys([*agents, "oracle", *(r["best_rule"] for r in regimes)]))
        for name in sorted({n for r in regimes for n in r["mean_cost"]} - set(shown)):
            axis.plot(xs, [r["mean_cost"].get(name, [np.nan])[0] for r in regimes], color="0.85", lw=0.8, zorder=1)
        for name in shown:
            values = np.array([r["mean_cost"].get(name, [np.nan] * 3) for r in regimes])
            style = "-o" if name in agents else ("--" if name == "oracle" else "-.")
            axis.errorbar(xs, values[:, 0], yerr=[values[:, 0] - values[:, 1], values[:, 2] - values[:, 0]], fmt=style,
                          capsize=3, label=name, zorder=3)
        low = min(r["mean_cost"]["oracle"][0] for r in regimes)
        high = max(max(r["mean_cost"][n][2] for n in shown if n in r["mean_cost"]) for r in regimes)
        axis.set(title=title, xlabel=x, ylabel="mean cost (95% interval)", ylim=(0.9 * low, 1.1 * high))
        axis.legend(fontsize=7)
    figure.tight_layout()
    return figure
