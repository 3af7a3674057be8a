"""Where a selector keeps the textbook rule and where it overrides it, on a protocol's validation plants.

    deadtime study selector-choices PROTOCOL RUN_DIR REGIME... [--out DIR]

Reads the validation evaluation a protocol run left in ``RUN_DIR/work/REGIME/validation/per_plant.csv``
(every seed of every candidate and every rule, on the protocol's validation stream; no test plant) and
draws the stream's plants again (:func:`agents.protocol.streams.plant_stream`) for their normalized
dead time ``L/T_ar`` (the dead time over the true residence time).  The selector's rows carry each
plant's ``choice`` (:mod:`agents.training.selector_policy`); the fixed-mode selector's are read, since
it pays the same experiments as the rules beside it (a plan-mode selector runs other experiments).

Per regime and dead-time band (fifths of ``[0, 1]``): the plants, the share of (plant, seed) choices
given to each candidate, the share of plants where each rule candidate violates the constraints, the
judgement (on the plants where the regime's best rule violates, the share of choices that leave it;
where it is safe, the share that keep it), and the selector's own share of violating choices and mean
cost beside the best rule's.  The plot shows,
per regime, the share given to each candidate against the dead-time band, with each rule's violation
rate: a selector that judges well keeps a rule where it is safe and leaves it where it violates.
``--out DIR`` writes ``DIR/choices.md``, ``DIR/choices.json`` and ``DIR/choices.png``.
"""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any

import numpy as np

from agents.files.writer import write_figure, write_text

__all__ = ["BANDS", "choices", "regime_choices"]

BANDS: tuple[float, ...] = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0)
"""The edges of the normalized dead-time bands."""


def _rows(path: Path) -> list[dict[str, str]]:
    if not path.is_file():
        raise ValueError(f"{path} is missing: run the protocol's regime first (deadtime protocol run ... --regime NAME)")
    with path.open(newline="") as handle:
        return [row for row in csv.DictReader(handle) if row["subset"] == "test"]


def regime_choices(protocol: Any, run_dir: Path, name: str) -> dict[str, Any]:
    """One regime's bands (module docstring)."""
    from agents.protocol.streams import plant_stream

    selection = json.loads((run_dir / name / "selection.json").read_text())
    rows = _rows(run_dir / "work" / name / "validation" / "per_plant.csv")
    # the fixed-mode selector only: it pays the experiments the rules pay (a plan-mode selector runs others)
    selectors = sorted({row["policy"] for row in rows if row.get("choice") and row["policy"].startswith("fixed.")})
    if not selectors:
        raise ValueError(f"regime {name}: no fixed-mode selector among the validation rows")
    chosen = {row["choice"] for row in rows if row["policy"] in selectors}
    best_rule = selection["chosen"]["best-rule"]
    # the best rule first, the other rules, the learned design last: one order (and colour) in every regime
    candidates = sorted(chosen, key=lambda c: (c != best_rule, c == "learned", c))
    plants = plant_stream(selection["family"], protocol.validation.entropy, selection["validation_plants"])
    fraction = np.array([plant.dead_time / plant.residence_time for plant in plants])
    band = np.clip(np.digitize(fraction, BANDS[1:-1]), 0, len(BANDS) - 2)
    index = {policy: {} for policy in {*selectors, *candidates, best_rule}}
    for row in rows:
        if row["policy"] in index:
            index[row["policy"]][int(row["index"])] = row
    # the best rule's violations are shown also where it is not among the selector's candidates
    rules = [c for c in dict.fromkeys([best_rule, *candidates]) if c != "learned" and index.get(c)]
    bands = []
    for b in range(len(BANDS) - 1):
        members = [k for k in range(len(plants)) if band[k] == b]
        picks = [index[s][k] for s in selectors for k in members]
        entry = {"band": f"{BANDS[b]:.1f}-{BANDS[b + 1]:.1f}", "plants": len(members)}
        if members:
            entry["shares"] = {c: sum(1 for p in picks if p["choice"] == c) / len(picks) for c in candidates}
            entry["rule_violations"] = {c: float(np.mean([index[c][k]["feasible"] != "True" for k in members]))
                                        for c in rules}
            entry["selector_violations"] = float(np.mean([p["feasible"] != "True" for p in picks]))
            unsafe = {k for k in members if index[best_rule][k]["feasible"] != "True"}
            left = [p["choice"] != best_rule for s in selectors for k in members if k in unsafe for p in [index[s][k]]]
            kept = [p["choice"] == best_rule for s in selectors for k in members if k not in unsafe for p in [index[s][k]]]
            entry["overridden_where_best_rule_violates"] = float(np.mean(left)) if left else None
            entry["kept_where_best_rule_is_safe"] = float(np.mean(kept)) if kept else None
            entry["selector_cost"] = float(np.mean([float(p["cost"]) for p in picks]))
            entry["best_rule_cost"] = float(np.mean([float(index[best_rule][k]["cost"]) for k in members]))
        bands.append(entry)
    return {"regime": name, "env": selection["env"], "best_rule": best_rule, "candidates": candidates, "rules": rules,
            "seeds": len(selectors), "plants": len(plants), "bands": bands}


def _share(value: float | None) -> str:
    return "-" if value is None else f"{value:.0%}"


def markdown(regimes: list[dict[str, Any]]) -> str:
    lines = []
    for regime in regimes:
        rules = regime["rules"]
        lines += [f"**{regime['regime']}** ({regime['env']}; {regime['plants']} validation plants x {regime['seeds']} seeds; "
                  f"best rule `{regime['best_rule']}`)", "",
                  "| L/T_ar | plants | " + " | ".join(f"`{c}` chosen" for c in regime["candidates"]) + " | "
                  + " | ".join(f"`{c}` violates" for c in rules) + " | best rule left where it violates | kept where safe | selector violates | selector cost | best rule cost |",
                  "|---" * (2 + len(regime["candidates"]) + len(rules) + 5) + "|"]
        for band in regime["bands"]:
            if not band["plants"]:
                continue
            lines.append(f"| {band['band']} | {band['plants']} | "
                         + " | ".join(f"{band['shares'][c]:.0%}" for c in regime["candidates"]) + " | "
                         + " | ".join(f"{band['rule_violations'].get(c, float('nan')):.1%}" for c in rules)
                         + f" | {_share(band['overridden_where_best_rule_violates'])} | {_share(band['kept_where_best_rule_is_safe'])}"
                         + f" | {band['selector_violations']:.1%} | {band['selector_cost']:.3g} | {band['best_rule_cost']:.3g} |")
        lines.append("")
    return "\n".join(lines)


def plot(regimes: list[dict[str, Any]], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    columns = min(3, len(regimes))
    rows = -(-len(regimes) // columns)
    figure, axes = plt.subplots(rows, columns, figsize=(4.5 * columns, 3.6 * rows), squeeze=False)
    for axis in axes.flat[len(regimes):]:
        axis.set_visible(False)
    for axis, regime in zip(axes.flat, regimes):
        bands = [b for b in regime["bands"] if b["plants"]]
        x = np.arange(len(bands))
        bottom = np.zeros(len(bands))
        rules = regime["rules"]
        for candidate in regime["candidates"]:
            share = np.array([b["shares"][candidate] for b in bands])
            colour = "C1" if candidate == "learned" else f"C{0 if candidate == regime['best_rule'] else 2 + rules.index(candidate)}"
            axis.bar(x, share, bottom=bottom, label=f"{candidate} chosen", alpha=0.8, color=colour)
            bottom += share
        for candidate in rules:
            axis.plot(x, [b["rule_violations"][candidate] for b in bands], "k--" if candidate == regime["best_rule"]
                      else "k:", marker="o", label=f"{candidate} violates")
        axis.set_xticks(x, [b["band"] for b in bands], fontsize=8)
        axis.set_xlabel("normalized dead time L/T_ar")
        axis.set_ylim(0, 1)
        axis.set_title(regime["regime"], fontsize=9)
        axis.legend(fontsize=6, loc="upper left")
    for axis in axes[:, 0]:
        axis.set_ylabel("share of choices / of plants violating")
    figure.tight_layout()
    write_figure(path, figure, 120, bbox_inches="tight")
    plt.close(figure)


def choices(protocol_path: Path, run_dir: Path, regimes: list[str], out: Path | None) -> str:
    """The table of every named regime; ``out`` writes ``choices.{md,json,png}``."""
    from agents.protocol.config import load_protocol

    protocol = load_protocol(protocol_path)
    found = [regime_choices(protocol, run_dir, protocol.regime(name).name) for name in regimes]
    table = markdown(found)
    if out is not None:
        out.mkdir(parents=True, exist_ok=True)
        write_text(out / "choices.md", table)
        write_text(out / "choices.json", json.dumps({"protocol": str(protocol_path), "regimes": found}, indent=1) + "\n")
        plot(found, out / "choices.png")
    return table
