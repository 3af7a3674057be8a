"""Where a learned group's mean difference to a rule comes from: the rule's violating plants or the rest.

    deadtime study gap results/spread_own_plan_noise10_time --env PID-v3 \\
        --group learned-plan-spread-10000 --rule simc-pi

Reads a sweep's committed per-plant tables (``eval/<env>/<group>-<env>-s<seed>/per_plant.csv`` and
``eval/<env>/baselines/per_plant.csv``), takes the group's cost on each held-out plant as the mean over
its seeds, and splits the plants by whether the rule's design violates a constraint there.  For each
part: the number of plants, the group's mean difference to the rule per plant, its share of the
difference of the means over all plants (the parts add up to it), how many plants the group wins, and
the oracle's mean difference to the rule per plant (what a perfect design would gain there).  The mean
difference is the point estimate of the summaries' paired difference; the intervals stay theirs.
Prints a Markdown table.
"""

from __future__ import annotations

from collections import defaultdict
from pathlib import Path
from statistics import fmean

from agents.files.reader import read_csv


def _rows(path: Path) -> list[dict[str, str]]:
    return read_csv(path, ())


def group_costs(sweep: Path, env: str, group: str) -> dict[tuple[str, str], float]:
    """``(subset, plant) -> the group's cost there, averaged over its seeds``."""
    costs: dict[tuple[str, str], list[float]] = defaultdict(list)
    folders = sorted((sweep / "eval" / env).glob(f"{group}-{env}-s*"))
    if not folders:
        raise SystemExit(f"error: no evaluation of group {group!r} on {env} in {sweep}")
    for folder in folders:
        for row in _rows(folder / "per_plant.csv"):
            costs[(row["subset"], row["plant"])].append(float(row["cost"]))
    return {plant: fmean(values) for plant, values in costs.items()}


def baseline(sweep: Path, env: str, policy: str) -> dict[tuple[str, str], tuple[float, bool]]:
    """``(subset, plant) -> (cost, feasible)`` of a rule or the oracle."""
    rows = [row for row in _rows(sweep / "eval" / env / "baselines" / "per_plant.csv") if row["policy"] == policy]
    if not rows:
        raise SystemExit(f"error: no policy {policy!r} among the baselines of {env} in {sweep}")
    return {(row["subset"], row["plant"]): (float(row["cost"]), row["feasible"] == "True") for row in rows}


def decompose(sweep: Path, env: str, group: str, rule: str) -> list[dict[str, object]]:
    """One row per part (the rule violating, the rule feasible, all plants)."""
    agent, ruled, oracle = group_costs(sweep, env, group), baseline(sweep, env, rule), baseline(sweep, env, "oracle")
    plants = sorted(ruled)
    parts = {
        f"`{rule}` violates": [p for p in plants if not ruled[p][1]],
        f"`{rule}` feasible": [p for p in plants if ruled[p][1]],
        "all plants": plants,
    }
    table = []
    for name, members in parts.items():
        gaps = [agent[p] - ruled[p][0] for p in members]
        table.append({
            "part": name,
            "plants": len(members),
            "difference per plant": fmean(gaps) if gaps else 0.0,
            "share of the mean difference": sum(gaps) / len(plants),
            "group wins": sum(gap < 0 for gap in gaps),
            "oracle - rule per plant": fmean(oracle[p][0] - ruled[p][0] for p in members) if members else 0.0,
        })
    return table


def markdown(table: list[dict[str, object]]) -> str:
    """The parts as a Markdown table, three significant digits."""
    lines = ["| " + " | ".join(table[0]) + " |", "|" + "---|" * len(table[0])]
    for row in table:
        lines.append("| " + " | ".join(f"{v:.3g}" if isinstance(v, float) else str(v) for v in row.values()) + " |")
    return "\n".join(lines)
