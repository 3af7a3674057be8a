"""A frontier protocol's compute, from its run: ``deadtime protocol budget PROTOCOL --out OUT [--fits DIR]``.

Every task of a run adds its CPU and wall seconds to a ``timing.json`` in its folder
(:func:`agents.protocol.members.timed`): a fit in its run directory, a family's knobs on a chunk of plants
in its first member's folder, ``OUT/work/REGIME/STAGE/FAMILY/kKNOB/(rule|model|sSEED)/chunk-KKKK``.  The
budget sums them per regime and part:

* ``fits``: per learner, its seeds' fits (the regime's :func:`agents.protocol.frontier_run.fits_of`), with
  the algorithm its ``run.json`` names;
* ``validation`` and ``test``: per kind of family, ``rules``, ``learners`` (trained seeds), ``shipped``
  (one shipped model) and ``oracle``; the member-episodes scored beside.

A fit shared with another regime (one config alike) counts in the first regime that declares it.  A task
interrupted before its end adds nothing for that session: the budget is of the finished work.  The wall
time on ``W`` workers is the CPU time over ``W`` (the tasks are independent; the last ones leave workers
idle, so a run takes somewhat longer).

:func:`budget_summary` gives one row per regime by the parts of a study: the labels and fits of the learned
rule (its labels, the oracle's action on each training and validation plant, are most of its fit), the
selector's fits (a learned rule of its own among them), the stable-baselines3 agents' training, the frontiers
(every family over its knob on the validation plants) and the test.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from agents.files.reader import read_record
from agents.protocol.config import Protocol
from agents.protocol.members import TIMING

__all__ = ["budget", "budget_summary", "budget_table"]

STAGES = ("validation", "test")
FIT_COLUMNS = {"learned-rule": "labels and learned-rule fits", "selector": "selector fits"}  # by a fit's algorithm
AGENT_COLUMN = "SB3 training"  # a fit of any other algorithm
STAGE_COLUMNS = {"validation": "frontiers (validation)", "test": "test"}
SUMMARY = (*FIT_COLUMNS.values(), AGENT_COLUMN, *STAGE_COLUMNS.values())


def _kind(path: Path, stage_folder: Path) -> str:
    """The kind of family of a task folder ``STAGE/FAMILY/kKNOB/MEMBER/chunk-KKKK``."""
    family, _, member = path.relative_to(stage_folder).parts[:3]
    if family == "oracle":
        return "oracle"
    return {"rule": "rules", "model": "shipped"}.get(member, "learners")


def _add(found: dict[str, Any], key: str, record: dict[str, Any]) -> None:
    entry = found.setdefault(key, {"cpu_seconds": 0.0, "wall_seconds": 0.0, "episodes": 0, "tasks": 0})
    entry["cpu_seconds"] += float(record.get("cpu_seconds", 0.0))
    entry["wall_seconds"] += float(record.get("wall_seconds", 0.0))
    entry["episodes"] += int(record.get("episodes", 0))
    entry["tasks"] += 1


def budget(protocol: Protocol, out: Path, fits: Path | None = None) -> dict[str, Any]:
    """Per regime, per part (``fits``, ``validation``, ``test``), per learner or kind: CPU and wall seconds, tasks and
    episodes, from the run's ``timing.json`` files (module docstring)."""
    from agents.protocol.frontier_run import fits_of

    fits = out / "work" / "runs" if fits is None else fits
    counted: set[Path] = set()
    regimes: dict[str, Any] = {}
    for regime in protocol.regimes:
        parts: dict[str, dict[str, Any]] = {"fits": {}, **{stage: {} for stage in STAGES}}
        for fit in fits_of(protocol, regime, fits):
            path = fit.directory() / TIMING
            record = read_record(path, dict)
            if record is not None and path not in counted:
                counted.add(path)
                _add(parts["fits"], fit.learner.label, record)
                run = read_record(fit.directory() / "run.json", dict) or {}
                parts["fits"][fit.learner.label]["algorithm"] = str(run.get("algorithm", ""))
        for stage in STAGES:
            folder = out / "work" / regime.name / stage
            for path in sorted(folder.rglob(TIMING)) if folder.is_dir() else []:
                record = read_record(path, dict)
                if record is not None:
                    _add(parts[stage], _kind(path.parent, folder), record)
        regimes[regime.name] = parts
    return {"protocol": protocol.path, "out": str(out), "fits": str(fits), "regimes": regimes}


def _summary_part(part: str, entry: dict[str, Any]) -> str:
    """The column of :data:`SUMMARY` a part's entry adds to: a fit by its algorithm (any but the learned rule and
    the selector is a stable-baselines3 agent's), a stage by its name."""
    if part == "fits":
        return FIT_COLUMNS.get(entry.get("algorithm", ""), AGENT_COLUMN)
    return STAGE_COLUMNS[part]


def _hours(seconds: float) -> str:
    return f"{seconds / 3600:.2f}"


def budget_table(found: dict[str, Any], workers: int = 2) -> str:
    """The budget as a markdown table: per regime and part, core-hours, and the total's wall hours on ``workers``."""
    lines = [f"| regime | part | what | tasks | episodes | CPU hours | wall hours on {workers} cores |", "|---|---|---|---:|---:|---:|---:|"]
    total = 0.0
    for name, parts in found["regimes"].items():
        for part, entries in parts.items():
            for what, entry in sorted(entries.items()):
                total += entry["cpu_seconds"]
                lines.append(f"| {name} | {part} | {what} | {entry['tasks']} | {entry['episodes']} | "
                             f"{_hours(entry['cpu_seconds'])} | {_hours(entry['cpu_seconds'] / workers)} |")
    lines.append(f"| all | | | | | {_hours(total)} | {_hours(total / workers)} |")
    return "\n".join(lines) + "\n"


def budget_summary(found: dict[str, Any], workers: int = 2) -> str:
    """One row per regime: CPU hours by the parts of :data:`SUMMARY`, the total, and its wall hours on ``workers``."""
    head = " | ".join(SUMMARY)
    lines = [f"| regime | {head} | CPU hours | wall hours on {workers} cores |", "|---|" + "---:|" * (len(SUMMARY) + 2)]
    totals = dict.fromkeys(SUMMARY, 0.0)
    for name, parts in found["regimes"].items():
        row = dict.fromkeys(SUMMARY, 0.0)
        for part, entries in parts.items():
            for entry in entries.values():
                row[_summary_part(part, entry)] += entry["cpu_seconds"]
        if not any(row.values()):
            continue
        totals = {key: totals[key] + row[key] for key in SUMMARY}
        cells = " | ".join(_hours(row[key]) for key in SUMMARY)
        lines.append(f"| {name} | {cells} | {_hours(sum(row.values()))} | {_hours(sum(row.values()) / workers)} |")
    cells = " | ".join(_hours(totals[key]) for key in SUMMARY)
    lines.append(f"| all | {cells} | {_hours(sum(totals.values()))} | {_hours(sum(totals.values()) / workers)} |")
    return "\n".join(lines) + "\n"
