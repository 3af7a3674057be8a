"""The violation rates of learned groups on the test plants, pooled over their seeds, with exact intervals:
the after-the-fact check of a certified margin (``baselines/learned_rule.py``, "Certified margins").

    deadtime study certificates results/certified_noise10_time results/agent_mode_noise10_time ...

Per sweep, environment and agent group (``<label>-<env>-s<seed>``): the test episodes of all seeds, how
many violated a constraint (``feasible`` false, failures included), the pooled rate with its two-sided
95% Clopper-Pearson interval (``scipy.stats.binomtest``), and how many seeds violated on any of their
test plants (on 50 plants a seed whose rate is exactly 1% shows a violation with probability 39.5%),
and on how many distinct test plants any seed violated; where the sweep folder holds the fits' manifests (``runs/*/learned_rule.json``), how many seeds' margins
were certified and the range of their margins.  The test plants
are the same for every seed, so the pooled count is not a sum of independent draws: the interval is a
description of the pooled rate, not a test of each seed's promise.  A plant that violates under every
seed counts ten times in the pool and once among the plants: read the two together (one plant of 50 is
consistent with a 1% rate).  Prints a Markdown table.
"""

from __future__ import annotations

import re
from collections import defaultdict
from pathlib import Path

from scipy.stats import binomtest

from agents.files.reader import exists, read_csv, read_json

GROUP = re.compile(r"^(?P<label>.+)-(?P<env>[A-Z]+-v\d+)-s(?P<seed>\d+)$")


def group_rows(sweep: Path) -> dict[tuple[str, str], list[list[dict[str, str]]]]:
    """``(env, label) -> [the agent's test rows of per_plant.csv, per seed]`` of a sweep's evaluations."""
    found: dict[tuple[str, str], list[list[dict[str, str]]]] = defaultdict(list)
    for folder in sorted(sweep.glob("eval/*/*/")):
        match = GROUP.match(folder.name)
        if not match or not exists(folder / "per_plant.csv"):
            continue
        rows = [row for row in read_csv(folder / "per_plant.csv", ("subset", "policy"))
                if row["subset"] == "test" and row["policy"] == "agent"]
        found[(match["env"], match["label"])].append(rows)
    return found


def _violates(row: dict[str, str]) -> bool:
    return row["feasible"] != "True"


def group_counts(sweep: Path) -> dict[tuple[str, str], list[tuple[int, int]]]:
    """``(env, label) -> [(violations, episodes) per seed]`` on the test plants of a sweep's evaluations."""
    return {group: [(sum(map(_violates, rows)), len(rows)) for rows in seeds] for group, seeds in group_rows(sweep).items()}


def violating_plants(seeds: list[list[dict[str, str]]]) -> str:
    """``"k of n"``: the distinct test plants on which any seed violated, of all test plants."""
    plants = {row["plant"] for rows in seeds for row in rows}
    return f"{len({row['plant'] for rows in seeds for row in rows if _violates(row)})} of {len(plants)}"


def certified(sweep: Path, env: str, label: str) -> str:
    """``"k of n (margins a-b)"`` from the fits' manifests, ``-`` where there are none or no target."""
    found = [read_json(run / "learned_rule.json") for run in sorted(sweep.glob(f"runs/{label}-{env}-s*/"))
             if exists(run / "learned_rule.json")]
    found = [m for m in found if m.get("certification")]
    if not found:
        return "-"
    margins = [m["margin"] for m in found]
    return (f"{sum(bool(m['certification']['certified']) for m in found)} of {len(found)} "
            f"(margins {min(margins):g}-{max(margins):g})")


def table(sweeps: list[Path]) -> str:
    lines = ["| sweep | env | group | seeds | test episodes | violations | rate [95% interval] | seeds with a violation "
             "| plants with a violation | seeds certified |", "|---|---|---|---|---|---|---|---|---|---|"]
    for sweep in sweeps:
        rows = group_rows(sweep)
        for (env, label), seeds in sorted(group_counts(sweep).items()):
            violations, episodes = sum(v for v, _ in seeds), sum(n for _, n in seeds)
            interval = binomtest(violations, episodes).proportion_ci(confidence_level=0.95, method="exact")
            above = sum(v > 0 for v, _ in seeds)
            lines.append(f"| {sweep.name} | {env} | {label} | {len(seeds)} | {episodes} | {violations} | {violations / episodes:.1%} "
                         f"[{interval.low:.1%}, {interval.high:.1%}] | {above} | {violating_plants(rows[(env, label)])} "
                         f"| {certified(sweep, env, label)} |")
    return "\n".join(lines)
