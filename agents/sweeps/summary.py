"""The summary of a sweep: ``DIR/summary.{md,csv,json}``, learning curves and performance profiles.

Per environment, every agent group (a training config over its seeds) is compared with the rules
and the oracle on the same held-out plants and episode seeds, from the ``per_plant.csv`` files of
the evaluations (:mod:`agents.sweeps.run`).  The figures are those of :mod:`agents.evaluation.seed_statistics`
(Agarwal et al. 2021): mean and IQM over (seed, plant) with stratified-bootstrap 95% intervals, the
violation rate, the normalized score ``oracle/cost`` (IQM and optimality gap), the probability of
improvement over every rule and the paired difference to the best rule (the rule of lowest mean
cost on these plants).  A rule or the oracle is deterministic given the plants: its row has no
interval (the intervals are over training seeds; the plants are the fixed benchmark).

``summary.json``::

    {"sweep": NAME, "failed": {TRIAL: ERROR}, "envs": [{"env", "plants", "best_rule",
      "policies": [{"name", "kind", "seeds", "mean_cost", "iqm_cost", "ci95": {...},
                    "violation_rate", "normalized_iqm", "optimality_gap",
                    "prob_improvement": {"RULE": p, ...}, "diff_to_best_rule": [est, lo, hi],
                    "per_seed_mean_cost": [...]}]}]}
"""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import numpy as np

from agents.evaluation.seed_statistics import SeedStatistics, iqm, optimality_gap, seed_statistics
from agents.sweeps.config import SweepConfig, Trial

__all__ = ["write_summary"]

ORACLES = ("oracle", "oracle-full")
VIOLATION_COST = 21.0  # a violating design costs 21 + grade (envs.analysis.scoring)


def _per_plant(directory: Path) -> dict[str, dict[tuple, float]]:
    """``{policy: {(index, plant, seed): cost}}`` of an evaluation's ``per_plant.csv``."""
    path = directory / "per_plant.csv"
    if not path.is_file():
        raise ValueError(f"{path}: missing (the evaluation did not finish; run the sweep again with --resume)")
    costs: dict[str, dict[tuple, float]] = {}
    with path.open(newline="") as file:
        for row in csv.DictReader(file):
            costs.setdefault(row["policy"], {})[(int(row["index"]), row["plant"], int(row["seed"]))] = float(row["cost"])
    return costs


def _vector(costs: dict[tuple, float], plants: list[tuple], where: str) -> np.ndarray:
    if sorted(costs) != plants:
        raise ValueError(f"{where}: its plants differ from the baselines' (same evaluation n and seed needed)")
    return np.array([costs[p] for p in plants])


def _deterministic_row(name: str, kind: str, cost: np.ndarray, oracle: np.ndarray, best: np.ndarray) -> dict[str, Any]:
    normalized = oracle / cost
    return {"name": name, "kind": kind, "seeds": None, "mean_cost": float(cost.mean()), "iqm_cost": iqm(cost),
            "ci95": None, "violation_rate": float(np.mean(cost >= VIOLATION_COST)),
            "normalized_iqm": iqm(normalized), "optimality_gap": optimality_gap(normalized),
            "prob_improvement": {}, "diff_to_best_rule": [float(np.mean(cost - best)), None, None],
            "per_seed_mean_cost": None}


def _agent_row(name: str, stats: SeedStatistics) -> dict[str, Any]:
    return {"name": name, "kind": "agent", "seeds": stats.seeds, "mean_cost": stats.mean_cost, "iqm_cost": stats.iqm_cost,
            "ci95": stats.ci95, "violation_rate": stats.violation_rate, "normalized_iqm": stats.normalized_iqm,
            "optimality_gap": stats.optimality_gap, "prob_improvement": stats.prob_improvement,
            "diff_to_best_rule": stats.diff_to_best_rule, "per_seed_mean_cost": stats.per_seed_mean_cost}


def _environment(sweep: SweepConfig, env_id: str, trials: list[Trial], out: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The environment's entry of ``summary.json``, and the normalized scores of the agents and best rule."""
    from agents.sweeps.run import evaluation_directory

    baselines = _per_plant(evaluation_directory(out, env_id, "baselines"))
    if "oracle" not in baselines:
        raise ValueError(f"sweep {sweep.name}: evaluation.policies must include 'oracle' (the normalized score needs it)")
    plants = sorted(baselines["oracle"])
    oracle = _vector(baselines["oracle"], plants, "oracle")
    rules = {name: _vector(c, plants, name) for name, c in baselines.items() if name not in ORACLES}
    if not rules:
        raise ValueError(f"sweep {sweep.name}: evaluation.policies must include at least one rule")
    best_rule = min(rules, key=lambda name: (float(rules[name].mean()), name))
    rows, normalized = [], {}
    for label in dict.fromkeys(t.label for t in trials if t.env_id == env_id):
        group = [t for t in trials if t.env_id == env_id and t.label == label]
        matrix = np.array([_vector(_per_plant(evaluation_directory(out, env_id, t.name))["agent"], plants, t.name)
                           for t in group])
        stats = seed_statistics(matrix, oracle, rules, best_rule, resamples=sweep.evaluation.resamples,
                                seed=sweep.evaluation.seed)
        rows.append(_agent_row(label, stats))
        normalized[label] = (oracle / matrix).ravel()
    normalized[best_rule] = oracle / rules[best_rule]
    rows += [_deterministic_row(name, "rule", cost, oracle, rules[best_rule]) for name, cost in rules.items()]
    rows.append(_deterministic_row("oracle", "oracle", oracle, oracle, rules[best_rule]))
    rows.sort(key=lambda row: (row["kind"] != "agent", row["mean_cost"]))
    return {"env": env_id, "plants": len(plants), "best_rule": best_rule, "policies": rows}, normalized


def learning_curves(trials: list[Trial], out: Path) -> dict[str, dict[str, Any]]:
    """Validation cost against steps per ``label/env``: median and quartiles over the seeds."""
    curves: dict[str, dict[str, Any]] = {}
    for key in dict.fromkeys(f"{t.label}/{t.env_id}" for t in trials):
        per_seed = []
        for trial in (t for t in trials if f"{t.label}/{t.env_id}" == key):
            path = out / "runs" / trial.name / "evaluations.json"
            history = json.loads(path.read_text()) if path.is_file() else []
            per_seed.append({entry["num_timesteps"]: entry["mean_cost"] for entry in history})
        steps = sorted(set.intersection(*(set(s) for s in per_seed))) if per_seed else []
        values = np.array([[s[step] for step in steps] for s in per_seed]) if steps else np.empty((0, 0))
        curves[key] = {"steps": steps,
                       **{name: np.quantile(values, q, axis=0).tolist() if steps else []
                          for name, q in (("q25", 0.25), ("median", 0.5), ("q75", 0.75))}}
    return curves


def _json_ready(value: Any) -> Any:
    """Plain JSON values: numpy numbers as Python ones, ``nan`` and infinities as ``None``."""
    if isinstance(value, dict):
        return {key: _json_ready(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_json_ready(item) for item in value]
    if isinstance(value, np.generic):
        value = value.item()
    if isinstance(value, float) and not np.isfinite(value):
        return None
    return value


def _interval(row: dict[str, Any], key: str) -> str:
    ci = (row.get("ci95") or {}).get(key)
    return "" if ci is None else f" [{ci[0]:.3g}, {ci[1]:.3g}]"


def _markdown(summary: dict[str, Any]) -> str:
    sessions = summary["sessions"]
    lines = [f"# Sweep `{summary['sweep']}`", ""]
    if sessions:
        lines += [f"- wall time {summary['wall_time_s']:.0f} s in {len(sessions)} session(s) on {sessions[-1]['cpus']:g} CPUs, "
                  f"commit {sessions[-1]['commit']}", ""]
    for name, error in summary["failed"].items():
        lines.append(f"- trial `{name}` failed: {error}")
    for env in summary["envs"]:
        best = env["best_rule"]
        lines += ["", f"## {env['env']} ({env['plants']} held-out plants; best rule `{best}`)", "",
                  f"| policy | seeds | mean cost | IQM cost | violation rate | normalized IQM | optimality gap "
                  f"| P(better than {best}) | difference to {best} |", "|---|---|---|---|---|---|---|---|---|"]
        for row in env["policies"]:
            if row["kind"] == "rule" and row["name"] != best:
                continue
            diff = row["diff_to_best_rule"]
            diff_text = f"{diff[0]:.3g}" + ("" if diff[1] is None else f" [{diff[1]:.3g}, {diff[2]:.3g}]")
            probability = row["prob_improvement"].get(best)
            lines.append(
                f"| {row['name']} | {row['seeds'] or '-'} | {row['mean_cost']:.3g}{_interval(row, 'mean_cost')} "
                f"| {row['iqm_cost']:.3g}{_interval(row, 'iqm_cost')} | {row['violation_rate']:.1%} "
                f"| {row['normalized_iqm']:.3f}{_interval(row, 'normalized_iqm')} | {row['optimality_gap']:.3f} "
                f"| {'-' if probability is None else f'{probability:.2f}'} | {diff_text} |"
            )
    lines += ["", "Intervals: stratified bootstrap over training seeds within plants, 95% percentile "
              "(Agarwal et al. 2021); rules and the oracle are deterministic on these plants.", ""]
    return "\n".join(lines)


def _csv(summary: dict[str, Any], path: Path) -> None:
    with path.open("w", newline="") as file:
        writer = csv.writer(file)
        writer.writerow(["env", "policy", "kind", "seeds", "mean_cost", "mean_cost_lo", "mean_cost_hi", "iqm_cost",
                         "iqm_cost_lo", "iqm_cost_hi", "violation_rate", "normalized_iqm", "optimality_gap",
                         "prob_improvement_best_rule", "diff_to_best_rule", "diff_lo", "diff_hi"])
        for env in summary["envs"]:
            for row in env["policies"]:
                ci = row["ci95"] or {}
                writer.writerow([env["env"], row["name"], row["kind"], row["seeds"], row["mean_cost"],
                                 *(ci.get("mean_cost") or ["", ""]), row["iqm_cost"], *(ci.get("iqm_cost") or ["", ""]),
                                 row["violation_rate"], row["normalized_iqm"], row["optimality_gap"],
                                 row["prob_improvement"].get(env["best_rule"], ""),
                                 *["" if v is None else v for v in row["diff_to_best_rule"]]])


def _plots(summary: dict[str, Any], curves: dict[str, dict[str, Any]], profiles: list[dict[str, np.ndarray]], out: Path) -> None:
    """``learning_curves.png`` (median and quartiles over seeds) and ``performance_profiles.png``."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from agents.evaluation.seed_statistics import performance_profile

    envs = summary["envs"]
    figure, axes = plt.subplots(1, len(envs), figsize=(5 * len(envs), 3.6), squeeze=False)
    for axis, env in zip(axes[0], envs):
        for key, curve in curves.items():
            if key.endswith("/" + env["env"]) and curve["steps"]:
                line, = axis.plot(curve["steps"], curve["median"], label=f"{key.split('/')[0]} (median)")
                axis.fill_between(curve["steps"], curve["q25"], curve["q75"], alpha=0.25, color=line.get_color(),
                                  label="quartiles over seeds")
        axis.set(title=env["env"], xlabel="environment steps", ylabel="validation mean cost")
        axis.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(out / "learning_curves.png", dpi=120)
    plt.close(figure)

    taus = np.linspace(0.0, 1.0, 101)
    figure, axes = plt.subplots(1, len(envs), figsize=(5 * len(envs), 3.6), squeeze=False)
    for axis, env, scores in zip(axes[0], envs, profiles):
        for name, values in scores.items():
            style = "--" if name == env["best_rule"] else "-"
            axis.plot(taus, performance_profile(values, taus), style, label=name)
        axis.set(title=env["env"], xlabel="normalized score tau (oracle cost / cost)",
                 ylabel="fraction of runs with score >= tau", ylim=(0, 1.02))
        axis.legend(fontsize=7)
    figure.tight_layout()
    figure.savefig(out / "performance_profiles.png", dpi=120)
    plt.close(figure)


def write_summary(sweep: SweepConfig, trials: list[Trial], out: Path, failed: dict[str, str],
                  sessions: list[dict[str, Any]] = ()) -> dict[str, Any]:
    """Aggregate the evaluations in ``out`` and write ``summary.{md,csv,json}`` and the plots.

    ``sessions`` (the invocations of the sweep, :mod:`agents.sweeps.run`) give the wall time.
    """
    entries = [_environment(sweep, env, trials, out) for env in sweep.envs()]
    summary = {"sweep": sweep.name, "failed": failed, "envs": [entry for entry, _ in entries],
               "sessions": list(sessions), "wall_time_s": round(sum(s["wall_time_s"] for s in sessions), 1)}
    summary = _json_ready(summary)
    curves = learning_curves(trials, out)
    (out / "summary.json").write_text(json.dumps({**summary, "learning_curves": curves}, indent=2) + "\n")
    (out / "summary.md").write_text(_markdown(summary))
    _csv(summary, out / "summary.csv")
    _plots(summary, curves, [profile for _, profile in entries], out)
    return summary

