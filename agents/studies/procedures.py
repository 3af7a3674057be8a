"""The experiment procedures against the fixed procedure in the twelve regimes of the agent-mode study:
``DeadTime/{PID,FPPI,MSP}-v3``, noise 1% and 10%, production free and priced (0.05).

    deadtime study procedures runs/procedures results/procedures

For each regime, ``deadtime evaluate --policies plan-1-1,plan-best,amplitude-rule,all-rules,oracle
--n 50 --seed 0`` into ``<runs>/<env>-noise<N>-production<P>/`` (resumable: the evaluation caches
per plant); then ``<out>/procedures.md`` (each procedure's mean cost, and its paired difference to
``plan-1-1``, the fixed procedure, and to the best rule, with percentile bootstrap 95% intervals over
the plants, 2000 resamples, seed 0) and ``<out>/per_plant_costs.csv.gz`` (every policy's cost on every
plant of every regime).  ``plan-best`` is chosen on validation plants, never on these.
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np

from agents.compressed import compressed_bytes
from agents.files.reader import exists, read_csv, read_json

STRUCTURES = ("PID", "FPPI", "MSP")
NOISES = (0.01, 0.1)
PRODUCTION = (0.0, 0.05)
PROCEDURES = ("plan-1-1", "plan-best", "amplitude-rule")


def _regimes():
    for structure in STRUCTURES:
        for noise in NOISES:
            for production in PRODUCTION:
                yield structure, noise, production, f"{structure}-noise{noise:g}-production{production:g}"


def _costs(folder: Path) -> dict[str, dict[int, float]]:
    costs: dict[str, dict[int, float]] = {}
    for row in read_csv(folder / "per_plant.csv", ("index", "policy", "cost")):
        costs.setdefault(row["policy"], {})[int(row["index"])] = float(row["cost"])
    return costs


def _paired(a: dict[int, float], b: dict[int, float]) -> tuple[float, float, float]:
    plants = sorted(a)
    difference = np.array([a[i] - b[i] for i in plants])
    draws = np.random.default_rng(0).integers(0, difference.size, (2000, difference.size))
    means = difference[draws].mean(axis=1)
    return float(difference.mean()), float(np.quantile(means, 0.025)), float(np.quantile(means, 0.975))


def _text(value: tuple[float, float, float]) -> str:
    return f"{value[0]:+.3f} [{value[1]:+.3f}, {value[2]:+.3f}]"


def procedures(runs: Path, out: Path) -> None:
    lines = ["# Experiment procedures against the fixed procedure", "",
             "Mean cost on 59 held-out plants (50 test plants and the benchmark batch; MSP 58); differences paired on "
             "the plants, 95% percentile bootstrap intervals (negative: the procedure is better).  `plan-1-1` is the "
             "fixed procedure (the fixed procedure's experiments at amplitude 1) designing with the structure's base rule; every "
             "procedure designs with that rule.", "",
             "| regime | oracle | best rule | plan-1-1 | plan-best (plan) | amplitude-rule | plan-best - plan-1-1 | "
             "amplitude-rule - plan-1-1 | plan-best - best rule |", "|---|---|---|---|---|---|---|---|---|"]
    rows = []
    for structure, noise, production, label in _regimes():
        folder = runs / label
        kwargs = json.dumps({"noise_std": noise, "weights": {"production": production}})
        if not exists(folder / "results.json"):
            from agents.cli import main as cli

            status = cli(["evaluate", "--env", f"DeadTime/{structure}-v3", "--policies",
                          ",".join((*PROCEDURES, "all-rules", "oracle")), "--n", "50", "--seed", "0", "--env-kwargs", kwargs,
                          "--no-plots", "--out", str(folder)])
            if status:
                raise SystemExit(status)
        results = read_json(folder / "results.json")
        costs = _costs(folder)
        mean = {name: float(np.mean(list(c.values()))) for name, c in costs.items()}
        rules = [n for n in costs if n not in (*PROCEDURES, "oracle")]
        best = min(rules, key=lambda n: (mean[n], n))
        chosen = results.get("chosen_plan", "")
        lines.append(
            f"| {structure}-v3, noise {noise:g}, production {production:g} | {mean['oracle']:.3f} | `{best}` {mean[best]:.3f} | "
            f"{mean['plan-1-1']:.3f} | {mean['plan-best']:.3f} ({chosen}) | {mean['amplitude-rule']:.3f} | "
            f"{_text(_paired(costs['plan-best'], costs['plan-1-1']))} | {_text(_paired(costs['amplitude-rule'], costs['plan-1-1']))} | "
            f"{_text(_paired(costs['plan-best'], costs[best]))} |")
        rows += [{"regime": label, "policy": name, "plant": i, "cost": c} for name, by in costs.items() for i, c in sorted(by.items())]
    out.mkdir(parents=True, exist_ok=True)
    (out / "procedures.md").write_text("\n".join(lines) + "\n")
    table = io.StringIO(newline="")
    writer = csv.DictWriter(table, fieldnames=["regime", "policy", "plant", "cost"])
    writer.writeheader()
    writer.writerows(rows)
    (out / "per_plant_costs.csv.gz").write_bytes(compressed_bytes(table.getvalue().encode()))
    print("\n".join(lines))
