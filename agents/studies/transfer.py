"""Learners tuned in simulation, played on the TCLab emulator under several conditions, against every rule.

    deadtime study transfer GROUP=RUN_DIR,RUN_DIR,... [GROUP=learned-pid@0.01 ...] [--seeds 3] [--out DIR]

Each ``GROUP`` is a learner with one run per training seed (an agent, a learned design or a selector) (a protocol's primary, trained in simulation
only: ``OUT/work/runs/LABEL-ENV-HASH/s*`` of ``deadtime protocol run``), or a shipped learner at a risk by its
name (:mod:`agents.risk.pretrained`).  For each condition of
:data:`envs.process.tclab_conditions.CONDITIONS` and each emulator seed ``0 .. seeds-1``, the fixed
procedure runs once on the emulator (:func:`envs.process.procedure.identify_process`); every rule for
self-regulating plants, both process oracles and every run of every group design their controllers
from it and are tested on the emulator (:func:`agents.evaluation.process_policies.evaluate_policies`,
as ``deadtime process`` does).

Per condition and policy: the mean cost over the emulator seeds (a group: over its runs too), with a
95% Student-t interval over the emulator seeds (a group's per-seed value: its mean over its runs), the
share of designs infeasible on the identified model or stopped, the rank among every policy that is
not an oracle (the rules and the groups, by mean cost), and the **transfer gap**: the mean of the
measured cost minus the cost the simulation predicts for the same controller on the identified model
(:func:`envs.analysis.scoring.score` of the model as a plant: what the learner was trained to
minimize, had the model been the plant).  The table names the best rule and each group's rank and
gap to it; a group out of its training family's distribution says so
(:func:`agents.evaluation.process_policies.out_of_distribution`, the notes counted).  ``--out DIR``
writes ``DIR/transfer.md``, ``DIR/transfer.json.gz`` (every row, read in place by
:mod:`agents.compressed`) and ``DIR/transfer.png``.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from agents.files.writer import write_bytes, write_figure, write_text

__all__ = ["transfer"]


def _predicted(found: Any, controller: Any) -> float:
    """The cost the simulation predicts for ``controller`` on the identified model, no experiment charged."""
    from envs.analysis.scoring import score
    from envs.process.scoring import model_plant

    try:
        return float(score(model_plant(found), controller).cost)
    except ValueError:
        return math.nan


def _one_run(condition: Any, seed: int, groups: dict[str, list[str]]) -> list[dict[str, Any]]:
    """Every policy's row on one emulator run under ``condition``."""
    from agents.evaluation.policies import parse_policies
    from agents.evaluation.process_policies import evaluate_policies
    from agents.risk.pretrained import is_pretrained_name
    from envs.process.performance import RunProtocol
    from envs.process.procedure import identify_process
    from envs.process.tclab_conditions import emulator_factory
    from envs.process.tclab_process import TCLabProcess

    process = TCLabProcess(lab_factory=emulator_factory(condition))
    try:
        found = identify_process(process, seed=seed)
    except ValueError as error:  # the procedure found no model: a result of the condition, recorded
        process.close()
        return [{"condition": condition.name, "seed": seed, "policy": "identification", "run": "identification",
                 "role": "procedure", "cost": None, "feasible": False, "predicted": None, "note": str(error)}]
    protocol = RunProtocol.from_identification(found, process.load_step, seed=seed)
    shipped = {runs[0]: group for group, runs in groups.items() if len(runs) == 1 and is_pretrained_name(runs[0])}
    learners = ",".join([*shipped] + [f"{group}#{k}={run}" for group, runs in groups.items() if runs[0] not in shipped
                                      for k, run in enumerate(runs)])
    specs = parse_policies(",".join(filter(None, ["all-rules,oracle", learners])), "fppi")  # every rule for self-regulating plants
    rows = []
    for result in evaluate_policies(process, found, protocol, specs, fppi_oracle=True):
        score = result.score
        group = shipped.get(result.name) or (result.name.split("#")[0] if "#" in result.name else None)
        rows.append({"condition": condition.name, "seed": seed, "policy": group or result.name, "run": result.name,
                     "role": result.role, "cost": None if score is None else float(score.cost),
                     "feasible": bool(score is not None and score.feasible),
                     "predicted": None if result.controller is None else _predicted(found, result.controller),
                     "note": result.note})
    process.close()
    return rows


def _summary(rows: list[dict[str, Any]], groups: list[str]) -> list[dict[str, Any]]:
    """Per condition and policy: mean [95% over emulator seeds], infeasible share, transfer gap, rank."""
    from agents.protocol.statistics import t_interval

    out = []
    for condition in dict.fromkeys(row["condition"] for row in rows):
        mine = [row for row in rows if row["condition"] == condition and row["cost"] is not None]
        entries = []
        for policy in dict.fromkeys(row["policy"] for row in mine):
            own = [row for row in mine if row["policy"] == policy]
            seeds = sorted({row["seed"] for row in own})
            per_seed = np.array([np.mean([row["cost"] for row in own if row["seed"] == s]) for s in seeds])
            low, high = t_interval(per_seed)[1:3] if len(seeds) > 1 else (math.nan, math.nan)
            gaps = [row["cost"] - row["predicted"] for row in own if row["predicted"] is not None and math.isfinite(row["predicted"])]
            entries.append({"condition": condition, "policy": policy, "role": own[0]["role"] if policy not in groups else "learner",
                            "mean_cost": float(per_seed.mean()), "interval": [low, high],
                            "infeasible": float(np.mean([not row["feasible"] for row in own])),
                            "transfer_gap": float(np.mean(gaps)) if gaps else None,
                            "out_of_distribution": sum(1 for row in own if "out of distribution" in (row["note"] or "")),
                            "designs": len(own)})
        ranked = sorted((e for e in entries if e["role"] != "oracle"), key=lambda e: e["mean_cost"])
        for rank, entry in enumerate(ranked, start=1):
            entry["rank"], entry["ranked"] = rank, len(ranked)
        out.extend(entries)
    return out


def markdown(summary: list[dict[str, Any]], groups: list[str]) -> str:
    header = ["condition", "best rule", *(f"`{g}`: mean [95%], rank, - best rule, transfer gap, infeasible, out of distribution"
                                         for g in groups), "oracle (PID)", "oracle (FPPI)"]
    lines = ["| " + " | ".join(header) + " |", "|---" * len(header) + "|"]
    for condition in dict.fromkeys(e["condition"] for e in summary):
        mine = {e["policy"]: e for e in summary if e["condition"] == condition}
        rules = [e for e in mine.values() if e["role"] == "rule"]
        best = min(rules, key=lambda e: e["mean_cost"])
        cells = []
        for group in groups:
            g = mine.get(group)
            if g is None:
                cells.append("-")
                continue
            low, high = g["interval"]
            gap = "-" if g["transfer_gap"] is None else f"{g['transfer_gap']:+.3g}"
            cells.append(f"{g['mean_cost']:.3g} [{low:.3g}, {high:.3g}], {g['rank']} of {g['ranked']}, "
                         f"{g['mean_cost'] - best['mean_cost']:+.3g}, {gap}, {g['infeasible']:.0%}, "
                         f"{g['out_of_distribution']} of {g['designs']}")
        oracle = [f"{mine[name]['mean_cost']:.3g}" if name in mine else "-" for name in ("oracle", "oracle-fppi")]
        lines.append("| " + " | ".join([condition, f"`{best['policy']}` {best['mean_cost']:.3g}", *cells, *oracle]) + " |")
    return "\n".join(lines) + "\n"


def plot(summary: list[dict[str, Any]], groups: list[str], path: Path) -> None:
    """Per condition, each group's and the best rule's mean cost with its interval."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    conditions = list(dict.fromkeys(e["condition"] for e in summary))
    figure, axis = plt.subplots(figsize=(1.2 * len(conditions) + 3, 3.6))
    names = ["best rule", *groups]
    for j, name in enumerate(names):
        xs, ys, lows, highs = [], [], [], []
        for i, condition in enumerate(conditions):
            mine = [e for e in summary if e["condition"] == condition]
            entry = (min((e for e in mine if e["role"] == "rule"), key=lambda e: e["mean_cost"]) if name == "best rule"
                     else next((e for e in mine if e["policy"] == name), None))
            if entry is None:
                continue
            xs.append(i + 0.15 * (j - (len(names) - 1) / 2))
            ys.append(entry["mean_cost"])
            low = entry["interval"][0] if math.isfinite(entry["interval"][0]) else entry["mean_cost"]
            lows.append(entry["mean_cost"] - max(low, 0.1))  # a log axis: an interval below 0.1 is drawn to it
            highs.append(entry["interval"][1] - entry["mean_cost"] if math.isfinite(entry["interval"][1]) else 0.0)
        axis.errorbar(xs, ys, yerr=[lows, highs], fmt="o", capsize=3, label=name)
    axis.set_xticks(range(len(conditions)), conditions, rotation=30, ha="right", fontsize=8)
    axis.set_yscale("log")
    axis.set_ylabel("cost on the emulator (mean, 95%)")
    axis.legend(fontsize=7)
    write_figure(path, figure, 120, bbox_inches="tight")
    plt.close(figure)


def transfer(groups: dict[str, list[str]], seeds: int, out: Path | None, conditions: tuple[Any, ...] | None = None) -> str:
    """Run every condition (default :data:`~envs.process.tclab_conditions.CONDITIONS`) and emulator seed and
    return the table; ``out`` writes ``transfer.md``, ``transfer.json.gz`` and ``transfer.png``."""
    from agents.compressed import compressed_bytes
    from envs.process.tclab_conditions import CONDITIONS

    if seeds < 2:
        raise ValueError(f"--seeds must be at least 2 (an interval over the emulator seeds), got {seeds}")
    rows = [row for condition in (conditions or CONDITIONS) for seed in range(seeds) for row in _one_run(condition, seed, groups)]
    summary = _summary(rows, list(groups))
    table = markdown(summary, list(groups))
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        write_text(out / "transfer.md", table)
        data = json.dumps({"groups": groups, "seeds": seeds, "summary": summary, "rows": rows}) + "\n"
        write_bytes(out / "transfer.json.gz", compressed_bytes(data.encode()))
        plot(summary, list(groups), out / "transfer.png")
    return table
