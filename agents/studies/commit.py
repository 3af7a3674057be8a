"""Copy a finished sweep into ``results/``, small enough to commit and complete enough to recompute its
summary and ``deadtime regimes`` from (no models, no caches, no controllers):

    deadtime study commit runs/agent_mode_noise10_time results/exploratory/agent_mode_noise10_time

Copies ``sessions.json``, each trial's ``evaluations.json`` (its validation) and, for a learned rule, its
manifest ``learned_rule.json`` (kind, margin, validation costs and violations per margin, the
certificate; not the model it describes), and every evaluation's ``results.json`` and ``per_plant.csv``
(without the controllers' JSON and the error text; a trial's rows of its agent only, the rules' and the
oracle's being those of the baselines), then writes the summary from the copy with this checkout's code
(``summary.{md,csv,json}`` and plots).  The tables and records are written gzip-compressed
(:mod:`agents.compressed`; ``summary.md``, ``sessions.json`` and the plots stay plain), and the sweep
file is not copied: it belongs in ``configs/sweeps/`` under the folder's name.
"""

from __future__ import annotations

import csv
import io
from pathlib import Path

from agents.compressed import compress_file, compressed_bytes
from agents.files.reader import read_csv, read_json
from agents.files.writer import write_bytes
from agents.sweeps.config import load_sweep
from agents.sweeps.summary import write_summary

KEPT = ("index", "subset", "plant", "seed", "policy", "cost", "feasible", "failure", "experiment_time", "parameter")


def _per_plant(source: Path, agent_only: bool) -> bytes:
    table = io.StringIO(newline="")
    writer = csv.DictWriter(table, fieldnames=KEPT, extrasaction="ignore")
    writer.writeheader()
    writer.writerows(row for row in read_csv(source, ("policy",)) if not agent_only or row["policy"] == "agent")
    return table.getvalue().encode()


def _write(target: Path, data: bytes) -> None:
    target.parent.mkdir(parents=True, exist_ok=True)
    write_bytes(target.with_name(target.name + ".gz"), compressed_bytes(data))


def commit(source: Path, target: Path) -> None:
    """Copy the finished sweep ``source`` into ``target`` and write its summary there."""
    missing = [name for name in ("sweep.yaml", "sessions.json", "summary.json") if not (source / name).is_file()]
    if missing:  # refused before ``target`` is created
        raise ValueError(f"{source} is not a finished sweep's folder: it holds no {', '.join(missing)}")
    target.mkdir(parents=True, exist_ok=True)
    write_bytes(target / "sessions.json", (source / "sessions.json").read_bytes())
    for path in sorted((source / "runs").glob("*/evaluations.json")) + sorted((source / "runs").glob("*/learned_rule.json")):
        _write(target / "runs" / path.parent.name / path.name, path.read_bytes())
    for path in sorted((source / "eval").glob("*/*/per_plant.csv")):
        folder = target / path.parent.relative_to(source)
        _write(folder / "per_plant.csv", _per_plant(path, agent_only=path.parent.name != "baselines"))
        _write(folder / "results.json", (path.parent / "results.json").read_bytes())
    sweep = load_sweep(source / "sweep.yaml")
    failed = read_json(source / "summary.json").get("failed", {})
    trials = [t for t in sweep.trials() if t.name not in failed]
    write_summary(sweep, trials, target, failed, read_json(target / "sessions.json", list))
    for name in ("summary.csv", "summary.json"):
        compress_file(target / name)
