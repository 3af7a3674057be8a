"""The rules' and the oracle's rows of two evaluations side by side: the same plants and seeds under
two versions' scores (docs/scoring.md, "v2 and v3 on the same plants").

    deadtime evaluate --env DeadTime/PID-v2 --policies all-rules,oracle --n 50 --seed 0 --out runs/PID-v2 --no-plots
    deadtime evaluate --env DeadTime/PID-v3 --policies all-rules,oracle --n 50 --seed 0 --out runs/PID-v3 --no-plots
    deadtime study rescore runs/PID-v2 runs/PID-v3

Prints a Markdown table: per policy, the mean cost with its bootstrap 95% interval (as ``deadtime
evaluate`` computes it) under each version, the paired difference to the oracle (mean and percentile
bootstrap 95% interval over the plants, 2000 resamples, seed 0) under each version, the width of that
interval under the second version over the first, the violation rate, and on how many plants the cost
changed.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from agents.files.reader import read_csv, read_json


def _rows(folder: Path) -> tuple[dict, dict]:
    results = read_json(folder / "results.json")
    policies = {p["name"]: p for p in results["policies"]}
    costs: dict[str, dict[int, float]] = {}
    for row in read_csv(folder / "per_plant.csv", ("index", "policy", "cost")):
        costs.setdefault(row["policy"], {})[int(row["index"])] = float(row["cost"])
    return policies, costs


def _difference(costs: dict[str, dict[int, float]], name: str) -> tuple[float, float, float]:
    """Mean of ``name - oracle`` over the plants and its percentile bootstrap 95% interval."""
    plants = sorted(costs["oracle"])
    differences = np.array([costs[name][i] - costs["oracle"][i] for i in plants])
    draws = np.random.default_rng(0).integers(0, differences.size, (2000, differences.size))
    means = differences[draws].mean(axis=1)
    return float(differences.mean()), float(np.quantile(means, 0.025)), float(np.quantile(means, 0.975))


def table(first: Path, second: Path) -> str:
    (a, a_costs), (b, b_costs) = _rows(first), _rows(second)
    lines = [f"| policy | mean cost, {first.name} | mean cost, {second.name} | - oracle, {first.name} | "
             f"- oracle, {second.name} | width ratio | violation rate | plants changed |", "|---|---|---|---|---|---|---|---|"]
    for name in sorted(a, key=lambda n: a[n]["mean_cost"]):
        if name not in b or name == "oracle":
            continue
        x, y = a[name], b[name]
        (xl, xh), (yl, yh) = x["ci95"]["mean_cost"], y["ci95"]["mean_cost"]
        (dx, dxl, dxh), (dy, dyl, dyh) = _difference(a_costs, name), _difference(b_costs, name)
        changed = sum(a_costs[name][i] != b_costs[name].get(i) for i in a_costs[name])
        ratio = (dyh - dyl) / (dxh - dxl) if dxh > dxl else float("nan")
        lines.append(f"| {name} | {x['mean_cost']:.3g} [{xl:.3g}, {xh:.3g}] | {y['mean_cost']:.3g} [{yl:.3g}, {yh:.3g}] | "
                     f"{dx:.3g} [{dxl:.3g}, {dxh:.3g}] | {dy:.3g} [{dyl:.3g}, {dyh:.3g}] | {ratio:.2f} | "
                     f"{100 * y['violation_rate']:.1f}% | {changed} of {len(a_costs[name])} |")
    oracle = max(abs(a_costs["oracle"][i] - b_costs["oracle"][i]) for i in a_costs["oracle"])
    lines.append(f"\nThe oracle's mean cost: {a['oracle']['mean_cost']:.4g} and {b['oracle']['mean_cost']:.4g}; "
                 f"its largest change on a plant {oracle:.2g}.")
    return "\n".join(lines)
