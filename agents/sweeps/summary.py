"""The summary of a sweep: ``DIR/summary.{md,csv,json}``, learning curves and performance profiles.

Per environment, every agent group (a training config over its seeds; a group of ``learned-rule``
fits is one of learned rules: kind ``learned-rule``, role ``learned rule``) is compared with the rules
and the oracle on the same held-out plants and episode seeds, from the ``per_plant.csv`` files of
the evaluations (:mod:`agents.sweeps.run`).  The figures are those of :mod:`agents.evaluation.seed_statistics`
(Agarwal et al. 2021): mean and IQM over (seed, plant) with two-way bootstrap 95% intervals (seeds
and plants resampled whole; :mod:`agents.evaluation.seed_statistics` says why not stratified by plant), the
violation rate, the normalized score ``oracle/cost`` (IQM and optimality gap), the probability of
improvement over every rule and the paired difference to the best rule (the rule of lowest mean
cost on these plants).  A rule or the oracle has one cost per plant: its intervals resample the
plants only.  The tables show the agents, the best rule, the paper rule (the best of the
papers' rules of the environment's own structure: ``deadtime evaluate``'s ``best_rule``, the baseline of
its gap closure) and the oracle; ``summary.json`` and ``summary.csv`` hold every rule.

``summary.json``::

    {"sweep": NAME, "failed": {TRIAL: ERROR}, "envs": [{"env", "plants", "best_rule", "paper_rule",
      "policies": [{"name", "kind", "seeds", "mean_cost", "iqm_cost", "ci95": {...},
                    "violation_rate", "normalized_iqm", "optimality_gap",
                    "prob_improvement": {"RULE": p, ...}, "diff_to_best_rule": [est, lo, hi],
                    "per_seed_mean_cost": [...]}]}]}
"""

from __future__ import annotations

import csv
import functools
import io
import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from agents.evaluation.policies import ROLES, TRAINED
from agents.evaluation.seed_statistics import SeedStatistics, seed_statistics
from agents.files.reader import FileProblem, exists, read_csv, read_json
from agents.files.writer import atomic_write_all
from agents.sweeps.config import SweepConfig, Trial, evaluation_directory
from agents.sweeps.sessions import interrupted_sessions

__all__ = ["per_plant_costs", "summary_texts", "write_summary"]

ORACLES = ("oracle", "oracle-full")


def per_plant_costs(directory: Path) -> dict[str, dict[tuple, float]]:
    """``{policy: {(index, plant, seed): cost}}`` of an evaluation's ``per_plant.csv``.

    Raises
    ------
    FileProblem
        Naming the file (and the line): missing, cut, empty, not a table (:func:`agents.files.reader.read_csv`),
        a cost that is not a finite number >= 0, a plant given twice for one policy, or a policy that
        lacks plants the others have.
    """
    path = directory / "per_plant.csv"
    if not exists(path):
        raise FileProblem(f"{path}: missing (the evaluation did not finish; run the sweep again with --resume)")
    again = "delete the file and run the sweep again with --resume to evaluate again"
    costs: dict[str, dict[tuple, float]] = {}
    for line, row in enumerate(read_csv(path, ("index", "plant", "seed", "policy", "cost")), start=2):
        try:
            cost = float(row["cost"])
            where = (int(row["index"]), row["plant"], int(row["seed"]))
        except ValueError:
            cost, where = math.nan, None
        if where is None or not (math.isfinite(cost) and cost >= 0):
            raise FileProblem(f"{path}, line {line}: not a finite cost >= 0 of a plant ({row['cost'][:40]!r}); {again}")
        if where in costs.setdefault(row["policy"], {}):
            raise FileProblem(f"{path}, line {line}: plant {where[0]} of policy {row['policy'][:40]!r} a second time; {again}")
        costs[row["policy"]][where] = cost
    plants = set().union(*map(set, costs.values()))
    for policy, found in costs.items():
        if len(found) != len(plants):
            raise FileProblem(f"{path}: policy {policy[:40]!r} lacks {len(plants) - len(found)} of the {len(plants)} plants "
                              f"the others have (a row missing); {again}")
    return costs


def _vector(costs: dict[tuple, float], plants: list[tuple], where: str) -> np.ndarray:
    if sorted(costs) != plants:
        raise ValueError(f"{where}: its plants differ from the baselines' (same evaluation n and seed needed)")
    return np.array([costs[p] for p in plants])


def _trained_kind(directory: Path) -> str:
    """``agent``, or ``learned-rule`` where the trial's evaluation played a learned rule (its role)."""
    try:
        policies = read_json(directory / "results.json", dict)["policies"]
    except (OSError, ValueError, KeyError, TypeError):
        return "agent"
    role = next((p.get("role") for p in policies if p.get("name") == "agent"), None)
    return next((kind for kind, text in ROLES.items() if text == role), "agent")


def _row(name: str, kind: str, stats: SeedStatistics) -> dict[str, Any]:
    """A policy's row; a rule or the oracle is one cost per plant (``seeds`` None, plants resampled only)."""
    trained = kind in TRAINED
    return {"name": name, "kind": kind, "seeds": stats.seeds if trained else None, "mean_cost": stats.mean_cost, "iqm_cost": stats.iqm_cost,
            "ci95": stats.ci95, "violation_rate": stats.violation_rate, "normalized_iqm": stats.normalized_iqm,
            "optimality_gap": stats.optimality_gap, "prob_improvement": stats.prob_improvement,
            "diff_to_best_rule": stats.diff_to_best_rule,
            "per_seed_mean_cost": stats.per_seed_mean_cost if trained else None}


def _environment(sweep: SweepConfig, env_id: str, trials: list[Trial], out: Path) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The environment's entry of ``summary.json``, and the normalized scores of the agents and best rule."""
    baselines = per_plant_costs(evaluation_directory(out, env_id, "baselines"))
    if "oracle" not in baselines:
        raise ValueError(f"sweep {sweep.name}: evaluation.policies must include 'oracle' (the normalized score needs it)")
    plants = sorted(baselines["oracle"])
    oracle = _vector(baselines["oracle"], plants, "oracle")
    from baselines.procedures import is_procedure

    procedures = {name: _vector(c, plants, name) for name, c in baselines.items() if is_procedure(name)}
    rules = {name: _vector(c, plants, name) for name, c in baselines.items() if name not in ORACLES and name not in procedures}
    if not rules:
        raise ValueError(f"sweep {sweep.name}: evaluation.policies must include at least one rule")
    best_rule = min(rules, key=lambda name: (float(rules[name].mean()), name))
    results = evaluation_directory(out, env_id, "baselines") / "results.json"
    own_rule = read_json(results, dict).get("best_rule") if exists(results) else None
    rows, normalized = [], {}

    def statistics(costs: np.ndarray) -> SeedStatistics:
        return seed_statistics(costs, oracle, {**rules, **procedures}, best_rule, resamples=sweep.evaluation.resamples,
                               seed=sweep.evaluation.seed)

    for label in dict.fromkeys(t.label for t in trials if t.env_id == env_id):
        group = [t for t in trials if t.env_id == env_id and t.label == label]
        matrix = np.array([_vector(per_plant_costs(evaluation_directory(out, env_id, t.name))["agent"], plants, t.name)
                           for t in group])
        rows.append(_row(label, _trained_kind(evaluation_directory(out, env_id, group[0].name)), statistics(matrix)))
        normalized[label] = (oracle / matrix).ravel()
    normalized[best_rule] = oracle / rules[best_rule]
    rows += [_row(name, "rule", statistics(cost[None, :])) for name, cost in rules.items()]
    rows += [_row(name, "procedure", statistics(cost[None, :])) for name, cost in procedures.items()]
    rows.append(_row("oracle", "oracle", statistics(oracle[None, :])))
    rows.sort(key=lambda row: (row["kind"] not in TRAINED, row["mean_cost"]))
    entry = {"env": env_id, "plants": len(plants), "best_rule": best_rule, "paper_rule": own_rule, "policies": rows}
    return entry, normalized


def learning_curves(trials: list[Trial], out: Path) -> dict[str, dict[str, Any]]:
    """Validation cost against steps per ``label/env``: median and quartiles over the seeds."""
    curves: dict[str, dict[str, Any]] = {}
    for key in dict.fromkeys(f"{t.label}/{t.env_id}" for t in trials):
        per_seed = []
        for trial in (t for t in trials if f"{t.label}/{t.env_id}" == key):
            path = out / "runs" / trial.name / "evaluations.json"
            history = read_json(path, list) if exists(path) else []
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
    if summary.get("env_kwargs"):
        lines += [f"- regime: every environment made with `{json.dumps(summary['env_kwargs'], sort_keys=True)}`"]
    if sessions:
        interrupted = interrupted_sessions(sessions)
        ended = f" ({interrupted} interrupted)" if interrupted else ""
        lines += [f"- wall time {summary['wall_time_s']:.0f} s in {len(sessions)} session(s){ended} on {sessions[-1]['cpus']:g} "
                  f"CPUs, commit {sessions[-1]['commit']}", ""]
    for name, error in summary["failed"].items():
        lines.append(f"- trial `{name}` failed: {error}")
    for env in summary["envs"]:
        best = env["best_rule"]
        own = env.get("paper_rule")
        lines += ["", f"## {env['env']} ({env['plants']} held-out plants; best rule `{best}`)", "",
                  f"| policy | role | seeds | mean cost | IQM cost | violation rate | normalized IQM | optimality gap "
                  f"| P(better than {best}) | difference to {best} |", "|---|---|---|---|---|---|---|---|---|---|"]
        for row in env["policies"]:
            if row["kind"] == "rule" and row["name"] not in (best, env.get("paper_rule")):
                continue
            diff = row["diff_to_best_rule"]
            diff_text = f"{diff[0]:.3g}" + ("" if diff[1] is None else f" [{diff[1]:.3g}, {diff[2]:.3g}]")
            probability = row["prob_improvement"].get(best)
            role = {**ROLES, "oracle": "oracle"}.get(row["kind"]) or " and ".join(
                label for label, name in (("best rule", best), ("paper rule", own)) if row["name"] == name)
            lines.append(
                f"| {row['name']} | {role} | {row['seeds'] or '-'} | {row['mean_cost']:.3g}{_interval(row, 'mean_cost')} "
                f"| {row['iqm_cost']:.3g}{_interval(row, 'iqm_cost')} | {row['violation_rate']:.1%} "
                f"| {row['normalized_iqm']:.3f}{_interval(row, 'normalized_iqm')} | {row['optimality_gap']:.3f} "
                f"| {'-' if probability is None else f'{probability:.2f}'} | {diff_text} |"
            )
    lines += ["", "Intervals: 95% percentile bootstrap, seeds and plants resampled whole and paired across "
              "policies (the agents' intervals cover training seeds and plants, the rules' and the oracle's "
              "plants only).", ""]
    return "\n".join(lines)


def _csv(summary: dict[str, Any]) -> str:
    file = io.StringIO(newline="")
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
    return file.getvalue()


def _plots(summary: dict[str, Any], curves: dict[str, dict[str, Any]], profiles: list[dict[str, np.ndarray]]) -> dict[str, Any]:
    """The figures ``learning_curves.png`` (median and quartiles over seeds) and ``performance_profiles.png``,
    by file name."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from agents.evaluation.seed_statistics import performance_profile

    envs = summary["envs"]
    curves_figure, axes = plt.subplots(1, len(envs), figsize=(5 * len(envs), 3.6), squeeze=False)
    for axis, env in zip(axes[0], envs):
        for key, curve in curves.items():
            if key.endswith("/" + env["env"]) and curve["steps"]:
                line, = axis.plot(curve["steps"], curve["median"], label=f"{key.split('/')[0]} (median)")
                axis.fill_between(curve["steps"], curve["q25"], curve["q75"], alpha=0.25, color=line.get_color(),
                                  label="quartiles over seeds")
        axis.set(title=env["env"], xlabel="environment steps", ylabel="validation mean cost")
        axis.legend(fontsize=7)
    curves_figure.tight_layout()

    taus = np.linspace(0.0, 1.0, 101)
    profiles_figure, axes = plt.subplots(1, len(envs), figsize=(5 * len(envs), 3.6), squeeze=False)
    for axis, env, scores in zip(axes[0], envs, profiles):
        for name, values in scores.items():
            style = "--" if name == env["best_rule"] else "-"
            axis.plot(taus, performance_profile(values, taus), style, label=name)
        axis.set(title=env["env"], xlabel="normalized score tau (oracle cost / cost)",
                 ylabel="fraction of runs with score >= tau", ylim=(0, 1.02))
        axis.legend(fontsize=7)
    profiles_figure.tight_layout()
    return {"learning_curves.png": curves_figure, "performance_profiles.png": profiles_figure}


def write_summary(sweep: SweepConfig, trials: list[Trial], out: Path, failed: dict[str, str],
                  sessions: list[dict[str, Any]] = ()) -> dict[str, Any]:
    """Aggregate the evaluations in ``out`` and write ``summary.{md,csv,json}`` and the plots, all or none
(everything is computed first, then written to temporary files moved into place together).

    ``sessions`` (the invocations of the sweep, :mod:`agents.sweeps.sessions`) give the wall time.
    """
    summary, curves, profiles, texts = _summary(sweep, trials, out, failed, sessions)
    figures = _plots(summary, curves, profiles)
    writers = {out / name: functools.partial(_write_bytes, text.encode()) for name, text in texts.items()}
    writers.update({out / name: functools.partial(figure.savefig, format="png", dpi=120) for name, figure in figures.items()})
    try:
        atomic_write_all(writers)
    finally:
        import matplotlib.pyplot as plt

        for figure in figures.values():
            plt.close(figure)
    return summary


def summary_texts(sweep: SweepConfig, trials: list[Trial], out: Path, failed: dict[str, str],
                  sessions: list[dict[str, Any]] = ()) -> dict[str, str]:
    """The texts :func:`write_summary` writes (``summary.json``, ``summary.md``, ``summary.csv``), written nowhere:
    a committed sweep's summary recomputed from its evaluations (plain or compressed, :mod:`agents.compressed`)."""
    return _summary(sweep, trials, out, failed, sessions)[3]


def _summary(sweep: SweepConfig, trials: list[Trial], out: Path, failed: dict[str, str],
             sessions: list[dict[str, Any]]) -> tuple[dict[str, Any], dict[str, Any], list, dict[str, str]]:
    entries = [_environment(sweep, env, trials, out) for env in sweep.envs()]
    summary = {"sweep": sweep.name, **({"env_kwargs": dict(sweep.env_kwargs)} if sweep.env_kwargs else {}),
               "failed": failed, "envs": [entry for entry, _ in entries],
               "sessions": list(sessions), "wall_time_s": round(sum(s["wall_time_s"] for s in sessions), 1)}
    summary = _json_ready(summary)
    curves = learning_curves(trials, out)
    texts = {"summary.json": json.dumps({**summary, "learning_curves": curves}, indent=2) + "\n",
             "summary.md": _markdown(summary), "summary.csv": _csv(summary)}
    return summary, curves, [profile for _, profile in entries], texts


def _write_bytes(data: bytes, handle: Any) -> None:
    handle.write(data)

