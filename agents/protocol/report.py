"""``deadtime protocol report``: ``protocol_results.json``, the verdict table and the forest plot.

Reads a run's folder (``protocol.json``, and per finished regime ``selection.json`` and the per-plant
table ``test_per_plant.csv.gz``), recomputes every declared comparison from the per-plant table,
adjusts all of them together by Holm (:func:`agents.protocol.statistics.holm`, the family being
every comparison of every regime the protocol declares), and writes into the folder:

* ``protocol_results.json``: ``protocol_sha256`` and ``commit`` at the top; per regime ``env``,
  ``env_kwargs``, ``test_plants``, ``rule_chosen_on`` (``"validation"``), ``benchmark`` (the papers'
  batch, its own section, never pooled), ``comparisons`` (``first``, ``second``, ``estimate``
  ``{mean, low, high}`` at 95%, ``adjusted`` ``{low, high}`` at the Holm-consistent level,
  ``adjustment`` ``"holm"``, ``percent_of_second``, ``share_better``, ``verdict``) and ``violations``
  per policy (``rate``, ``interval``, ``unit`` ``"plant"``);
* ``results.md``: the verdict table (structure and regime, primary, best rule, difference [adjusted
  95%], percent, violations [plant-clustered 95%], verdict);
* ``forest.png``: every comparison's difference with its adjusted interval.

With regimes still missing, the family is incomplete: the report says so (``complete: false``) and
its adjusted intervals are not final.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from agents.files.reader import read_json
from agents.protocol.config import PRIMARIES, Protocol
from agents.protocol.run import PER_PLANT, matrices, read_per_plant
from agents.protocol.statistics import holm, paired_difference, plant_violations, verdict

__all__ = ["markdown", "forest_plot", "protocol_results", "write_report"]


def _declared(protocol: Protocol) -> int:
    """The number of comparisons the protocol declares (the size of Holm's family)."""
    count = 0
    for regime in protocol.regimes:
        modes = {mode for mode in PRIMARIES if regime.candidates(mode)}
        seconds = {"best-rule", "base-rule", "fixed-procedure"} | ({"best-plan"} if protocol.selection.plans else set()) | modes
        count += sum(1 for first, second in protocol.comparisons if first in modes and second in seconds)
    return count


def protocol_results(protocol: Protocol, out: Path) -> dict[str, Any]:
    """The ``protocol_results.json`` object of the run in ``out`` (module docstring)."""
    record = read_json(out / "protocol.json", dict)
    regimes, differences = [], []
    for regime in protocol.regimes:
        folder = out / regime.name
        if not (folder / PER_PLANT).exists():
            continue
        selection = read_json(folder / "selection.json", dict)
        chosen = selection["chosen"]
        rows = read_per_plant(folder / PER_PLANT)
        plants, table = matrices(rows, "test")
        bench_plants, bench = matrices(rows, "benchmark")
        entry = {"name": regime.name, "env": regime.env, "env_kwargs": dict(regime.env_kwargs), "test_plants": len(plants),
                 "validation_plants": selection["validation_plants"], "rule_chosen_on": "validation", "chosen": chosen,
                 "comparisons": [], "violations": {}, "benchmark": {"plants": len(bench_plants), "pooled": False,
                                                                    "mean_cost": {}, "violating_plants": {}}}
        for name in dict.fromkeys(chosen.values()):
            entry["violations"][name] = plant_violations(table[name][1]).to_dict()
            if name in bench:
                entry["benchmark"]["mean_cost"][name] = float(bench[name][0].mean(axis=0).mean())
                entry["benchmark"]["violating_plants"][name] = plant_violations(bench[name][1]).violating
        for first, second in protocol.comparisons:
            if first in chosen and second in chosen:
                d = paired_difference(chosen[first], chosen[second], table[chosen[first]][0], table[chosen[second]][0])
                differences.append((entry, d, (first, second)))
        regimes.append(entry)
    adjusted, rejected, levels = holm([d.p_value for _, d, _ in differences], protocol.alpha)
    for (entry, d, roles), p, level in zip(differences, adjusted, levels):
        low, high = d.interval(float(level))
        entry["comparisons"].append({
            "first": d.first, "second": d.second, "roles": list(roles),
            "estimate": {"mean": d.mean, "low": d.low, "high": d.high},
            "adjusted": {"low": low, "high": high, "level": float(level), "p_value": float(p)},
            "adjustment": "holm", "percent_of_second": d.percent_of_second, "share_better": d.share_better,
            "verdict": verdict(low, high)})
    declared = _declared(protocol)
    return {"protocol_sha256": record["protocol_sha256"], "commit": record["commit"], "protocol": protocol.path,
            "alpha": protocol.alpha, "comparisons_declared": declared, "comparisons_done": len(differences),
            "complete": len(differences) == declared,
            "interval": "Student t over plants of the per-plant difference (a learner's cost: its mean over the "
                        "seeds); conditional on the trained models",
            "regimes": regimes}


def _interval(low: float, high: float) -> str:
    return f"[{low:.3g}, {high:.3g}]"


def markdown(results: dict[str, Any]) -> str:
    """The verdict table: one row per comparison of a primary against the best rule, then the others."""
    lines = ["| structure and regime | primary | compared with | difference [adjusted 95%] | percent | "
             "violations [plant-clustered 95%] | verdict |", "|---|---|---|---|---|---|---|"]
    for regime in results["regimes"]:
        for c in regime["comparisons"]:
            v = regime["violations"][c["first"]]
            lines.append(f"| {regime['name']} | `{c['first']}` ({c['roles'][0]}) | `{c['second']}` ({c['roles'][1]}) | "
                         f"{c['estimate']['mean']:+.3g} {_interval(c['adjusted']['low'], c['adjusted']['high'])} | "
                         f"{c['percent_of_second']:+.1f}% | {100 * v['rate']:.2f}% "
                         f"{_interval(100 * v['interval'][0], 100 * v['interval'][1])}% | {c['verdict']} |")
    note = "" if results["complete"] else (f"\n\nIncomplete: {results['comparisons_done']} of "
                                           f"{results['comparisons_declared']} declared comparisons; the adjustment is not final.")
    return "\n".join(lines) + note + "\n"


def forest_plot(results: dict[str, Any], path: Path) -> None:
    """Each comparison's mean difference with its adjusted interval."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = [(regime["name"], c) for regime in results["regimes"] for c in regime["comparisons"]]
    figure, axes = plt.subplots(figsize=(7, 0.3 * len(rows) + 1.2))
    for y, (name, c) in enumerate(reversed(rows)):
        low, high = c["adjusted"]["low"], c["adjusted"]["high"]
        color = {"better": "tab:green", "worse": "tab:red", "tie": "tab:gray"}[c["verdict"]]
        axes.plot([low, high], [y, y], color=color)
        axes.plot(c["estimate"]["mean"], y, "o", color=color)
    axes.axvline(0.0, color="black", linewidth=0.8)
    axes.set_yticks(range(len(rows)), [f"{name}: {c['roles'][0]} - {c['roles'][1]}" for name, c in reversed(rows)], fontsize=7)
    axes.set_xlabel("first - second, cost units\n(mean and Holm-adjusted interval; negative: the first is cheaper)", fontsize=8)
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)


def write_report(protocol: Protocol, out: Path) -> dict[str, Any]:
    """Write ``protocol_results.json``, ``results.md`` and ``forest.png`` into ``out``; returns the results."""
    from agents.files.writer import write_json, write_text

    results = protocol_results(protocol, out)
    write_json(out / "protocol_results.json", results)
    write_text(out / "results.md", markdown(results))
    if any(regime["comparisons"] for regime in results["regimes"]):
        forest_plot(results, out / "forest.png")
    return results
