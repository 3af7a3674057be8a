"""Copy a finished sweep into the repository, small enough to commit and complete enough to recompute
its summary and ``deadtime regimes`` from (no models, no caches, no controllers):

    python tests/tools/commit_sweep.py runs/agent_mode_noise10_time results/agent_mode_noise10_time

Copies ``sweep.yaml``, ``sessions.json``, each trial's ``evaluations.json`` (its validation) and, for a
learned rule, its manifest ``learned_rule.json`` (kind, margin, validation costs and violations per
margin, the certificate; not the model it describes), and every
evaluation's ``results.json`` and ``per_plant.csv`` (without the controllers' JSON and the error text;
a trial's rows of its agent only, the rules' and the oracle's being those of the baselines),
then writes the summary from the copy with this checkout's code (``summary.{md,csv,json}`` and plots).
"""

from __future__ import annotations

import argparse
import csv
import json
import shutil
from pathlib import Path

from agents.sweeps.config import load_sweep
from agents.sweeps.summary import write_summary

KEPT = ("index", "subset", "plant", "seed", "policy", "cost", "feasible", "failure", "experiment_time", "parameter")


def _per_plant(source: Path, target: Path, agent_only: bool) -> None:
    with source.open(newline="") as read, target.open("w", newline="") as write:
        writer = csv.DictWriter(write, fieldnames=KEPT, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(row for row in csv.DictReader(read) if not agent_only or row["policy"] == "agent")


def copy(source: Path, target: Path) -> None:
    target.mkdir(parents=True, exist_ok=True)
    for name in ("sweep.yaml", "sessions.json"):
        shutil.copy2(source / name, target / name)
    for path in sorted((source / "runs").glob("*/evaluations.json")) + sorted((source / "runs").glob("*/learned_rule.json")):
        (target / "runs" / path.parent.name).mkdir(parents=True, exist_ok=True)
        shutil.copy2(path, target / "runs" / path.parent.name / path.name)
    for path in sorted((source / "eval").glob("*/*/per_plant.csv")):
        folder = target / path.parent.relative_to(source)
        folder.mkdir(parents=True, exist_ok=True)
        _per_plant(path, folder / "per_plant.csv", agent_only=path.parent.name != "baselines")
        shutil.copy2(path.parent / "results.json", folder / "results.json")
    sweep = load_sweep(target / "sweep.yaml")
    summary = json.loads((source / "summary.json").read_text())
    trials = [t for t in sweep.trials() if t.name not in summary.get("failed", {})]
    write_summary(sweep, trials, target, summary.get("failed", {}), json.loads((target / "sessions.json").read_text()))


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("source", type=Path, help="the finished sweep's output directory")
    parser.add_argument("target", type=Path, help="the directory to commit, under results/")
    args = parser.parse_args()
    copy(args.source, args.target)
