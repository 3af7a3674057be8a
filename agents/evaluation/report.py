"""The tables of ``deadtime evaluate``: ``results.md``, ``results.csv``, ``results.json``, ``per_plant.csv``.

Policies are sorted by mean cost.  Roles mark the rows: ``oracle`` (and ``oracle-full``), the
``paper rule`` (lowest mean cost among the papers' rules of the environment's own structure, the
reference of the gap closure; ``results.json`` names it ``best_rule``) and ``agent``; other rules have the
role ``rule``.  The rules of the environment's own structure are always scored (the paper rule must
exist), and the paper rule is always shown, even if ``--policies`` did not list it (role ``paper rule
(reference)``).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

from agents.evaluation.stats import INTERVAL_FIELDS, PolicyStats

__all__ = ["SUBSET_TITLES", "markdown_table", "results_json", "summary_table", "write_tables"]

SUBSET_TITLES = {"all": "All plants", "test": "Random held-out test set", "benchmark": "The papers' benchmark batch"}
_COLUMNS = ("mean_cost", "median_cost", "violation_rate", "failure_rate", "experiment_time", "regret", "gap_closure")


def _number(x: float | None, digits: int = 3) -> str:
    if x is None or not math.isfinite(x):
        return "-"
    return f"{x:.{digits}g}" if abs(x) < 1000 else f"{x:.0f}"


def _percent(x: float | None) -> str:
    """A share as a percentage with one decimal (violation and failure rates, as the sweep summaries
    print them)."""
    return "-" if x is None or not math.isfinite(x) else f"{100 * x:.1f}%"


def _with_interval(value: float, interval: list[float] | None, cell=_number) -> str:
    if interval is None or not all(math.isfinite(v) for v in interval):
        return cell(value)
    return f"{cell(value)} [{cell(interval[0])}, {cell(interval[1])}]"


def markdown_table(stats: list[PolicyStats], roles: dict[str, str]) -> str:
    """One Markdown table, rows sorted by mean cost."""
    header = (
        "| policy | role | mean cost [95% CI] | median cost [95% CI] | violation rate [95% CI] | failures | "
        "experiment time (T_ar) | regret [95% CI] | gap closure [95% CI] |"
    )
    lines = [header, "|" + "---|" * 9]
    for s in sorted(stats, key=lambda s: (s.mean_cost, s.name)):
        role = roles.get(s.name, "rule")
        name = f"**{s.name}**" if role != "rule" else s.name
        lines.append(
            f"| {name} | {role} | {_with_interval(s.mean_cost, s.ci95.get('mean_cost'))} "
            f"| {_with_interval(s.median_cost, s.ci95.get('median_cost'))} "
            f"| {_with_interval(s.violation_rate, s.ci95.get('violation_rate'), _percent)} | {_percent(s.failure_rate)} "
            f"| {_number(s.experiment_time)} | {_with_interval(s.regret, s.ci95.get('regret'))} "
            f"| {_with_interval(s.gap_closure, s.ci95.get('gap_closure'))} |"
        )
    return "\n".join(lines)


def results_json(
    env_id: str, n: int, seed: int, subsets: dict[str, list[PolicyStats]], roles: dict[str, str], extra: dict[str, Any]
) -> dict[str, Any]:
    """The ``results.json`` object: the required keys, then ``roles``, ``subsets`` and ``extra``."""

    def rows(stats: list[PolicyStats]) -> list[dict[str, Any]]:
        return [
            {**s.to_dict(), "role": roles.get(s.name, "rule")} for s in sorted(stats, key=lambda s: (s.mean_cost, s.name))
        ]

    return {
        "env": env_id,
        "n": n,
        "seed": seed,
        "policies": rows(subsets["all"]),
        **extra,
        "subsets": {name: rows(stats) for name, stats in subsets.items() if name != "all"},
    }


def write_tables(
    out: Path,
    env_id: str,
    n: int,
    seed: int,
    subsets: dict[str, list[PolicyStats]],
    roles: dict[str, str],
    extra: dict[str, Any],
    per_plant: list[dict[str, Any]],
    notes: list[str],
) -> dict[str, Any]:
    """Write the four tables into ``out``, all or none (:func:`agents.files.writer.atomic_write_all`: a full
    disk leaves the previous tables, and no empty file); returns the ``results.json`` object."""
    from agents.files.writer import atomic_write_all, csv_text, text_writer

    result = results_json(env_id, n, seed, subsets, roles, extra)
    texts = {"results.json": json.dumps(result, indent=2) + "\n"}

    lines = [f"# `deadtime evaluate` on {env_id}", ""]
    lines += [f"- {key}: {value}" for key, value in extra.items() if not isinstance(value, (dict, list))]
    lines += [f"- seed: {seed}", f"- n (random test plants): {n}", ""]
    for name, stats in subsets.items():
        if name != "all" and len(subsets) <= 2:
            continue  # one subset only: it is the whole set
        lines += [f"## {SUBSET_TITLES.get(name, name)} ({stats[0].n} plants)", "", markdown_table(stats, roles), ""]
    lines += ["## Notes", ""] + [f"- {note}" for note in notes] + [""]
    texts["results.md"] = "\n".join(lines)

    rows = [["subset", "policy", "role", "n", *_COLUMNS, *(f"{k}_{e}" for k in INTERVAL_FIELDS for e in ("lo", "hi"))]]
    for name, stats in subsets.items():
        for s in sorted(stats, key=lambda s: (s.mean_cost, s.name)):
            values = [getattr(s, c) for c in _COLUMNS] + [v for k in INTERVAL_FIELDS for v in s.ci95.get(k, [math.nan] * 2)]
            rows.append([name, s.name, roles.get(s.name, "rule"), s.n, *values])
    texts["results.csv"] = csv_text(rows)
    if per_plant:
        columns = list(dict.fromkeys(column for row in per_plant for column in row))  # a selector's rows add "choice"
        texts["per_plant.csv"] = csv_text([columns, *([row.get(c, "") for c in columns] for row in per_plant)])
    atomic_write_all({out / name: text_writer(text) for name, text in texts.items()})
    return result


def summary_table(result: dict[str, Any]) -> str:
    """A compact plain-text table of ``results.json`` (all plants) for the terminal."""
    lines = [
        f"{result['env']}: {result.get('plants', result['n'])} plants, seed {result['seed']}, paper rule {result.get('best_rule')}",
        f"{'policy':24s} {'role':28s} {'mean':>8s} {'median':>8s} {'viol.':>6s} {'regret':>8s} {'gap cl.':>8s}",
    ]
    for p in result["policies"]:
        cells = [_number(p["mean_cost"]), _number(p["median_cost"]), _percent(p["violation_rate"]), _number(p["regret"]),
                 _number(p["gap_closure"])]
        lines.append(f"{p['name']:24s} {p['role']:28s} {cells[0]:>8s} {cells[1]:>8s} {cells[2]:>6s} {cells[3]:>8s} {cells[4]:>8s}")
    return "\n".join(lines)
