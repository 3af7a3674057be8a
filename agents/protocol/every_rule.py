"""``deadtime protocol every-rule``: every declared rule on a regime's test plants, beside its primaries.

The declared comparisons name one rule, the best on the validation plants; a reader also asks how a
primary fares against each rule.  For a regime whose test stream is scored (its ``summary.json``
exists), this plays every rule that ``selection.rules`` expands to on the same test plants and
episodes (into ``OUT/work/REGIME/test-rules``, a resumable evaluation of the rules only), checks that
the rules the run scored already come out equal per plant, and writes ``OUT/REGIME/every_rule.json``:
per rule its mean test cost and violating plants (exact 95% interval, the plant as the unit), and per
primary the paired difference (primary - rule) with its unadjusted Student t 95% interval and the
share of plants where the primary is cheaper.  ``OUT/every_rule.md`` tabulates every regime done.

These differences are descriptive, outside the Holm family of the declared comparisons: no verdict is
read from them (with 20 rules, one unadjusted interval in twenty may miss by chance).

The run is checked first as ``deadtime protocol report`` checks it (:func:`agents.protocol.report.check_run`:
this protocol's sha256 in ``protocol.json`` and in the registry); a folder with no regime tested is
refused.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from agents.files.reader import read_json
from agents.protocol.config import PRIMARIES, Protocol, Regime, structure_and_family
from agents.protocol.report import check_run, chosen_policies, read_table
from agents.protocol.run import PER_PLANT, SUMMARY, _evaluate, _rule_names, matrices, read_per_plant
from agents.protocol.statistics import paired_difference, plant_means, plant_violations
from agents.protocol.streams import plant_stream

__all__ = ["every_rule", "write_every_rule"]

_AGREEMENT = 5e-7
"""Relative agreement of a rule's per-plant costs with the run's table, which prints 7 significant digits."""


def every_rule(protocol: Protocol, out: Path, regime: Regime) -> dict[str, Any]:
    """Score every rule on ``regime``'s test plants and write ``OUT/REGIME/every_rule.json``; returns it.

    Raises
    ------
    ValueError
        If the regime's test stream is not scored yet, or a rule the run scored comes out different.
    """
    from agents.files.writer import write_json

    folder = out / regime.name
    if not (folder / SUMMARY).exists():
        raise ValueError(f"{regime.name}: its test stream is not scored yet (no {folder / SUMMARY}); run the protocol first")
    order, table = read_table(folder / PER_PLANT)
    selection, chosen = chosen_policies(folder, regime, table)
    if not isinstance(selection.get("family"), str):
        raise ValueError(f"{folder / 'selection.json'}: family must be a plant family's name, got {selection.get('family')!r}")
    structure, _ = structure_and_family(regime)
    rules = _rule_names(protocol, structure)
    plants = plant_stream(selection["family"], protocol.test.entropy, protocol.test.plants)
    directory = out / "work" / regime.name / "test-rules"
    _evaluate(regime, rules, plants, protocol.test.episode_seed, directory, benchmark=False)
    rows = read_per_plant(directory / "per_plant.csv", {})  # {}: a rule has no training seed
    _, scored = matrices([row for row in rows if row["policy"] in rules], "test")
    for name in set(rules) & set(table):
        if not np.allclose(scored[name][0], table[name][0], rtol=_AGREEMENT, atol=0.0):
            raise ValueError(f"{regime.name}: {name} scores differently from the run's test table; is the checkout the run's?")
    primaries = {role: chosen[role] for role in PRIMARIES if role in chosen}
    entry = {"regime": regime.name, "test_plants": len(order), "adjustment": "none (descriptive)", "primaries": primaries,
             "rules": {}}
    for name in rules:
        costs, feasible = scored[name]
        row = {"mean_cost": float(plant_means(costs).mean()), "violations": plant_violations(feasible).to_dict(),
               "differences": {}}
        for role, policy in primaries.items():
            d = paired_difference(policy, name, table[policy][0], costs)
            row["differences"][role] = {"first": policy, "mean": d.mean, "low": d.low, "high": d.high,
                                        "share_better": d.share_better}
        entry["rules"][name] = row
    write_json(folder / "every_rule.json", entry)
    return entry


def markdown(entries: list[dict[str, Any]]) -> str:
    """One table per regime: each rule's mean, violations, and each primary minus the rule."""
    blocks = []
    for entry in entries:
        roles = list(entry["primaries"])
        lines = [f"**{entry['regime']}** ({entry['test_plants']} test plants; unadjusted 95% intervals, descriptive)", "",
                 "| rule | mean test cost | violating plants [95%] | "
                 + " | ".join(f"`{entry['primaries'][role]}` ({role}) - rule [95%]" for role in roles) + " |",
                 "|---|---|---|" + "---|" * len(roles)]
        for name, row in sorted(entry["rules"].items(), key=lambda item: item[1]["mean_cost"]):
            v = row["violations"]
            cells = [f"{d['mean']:+.3g} [{d['low']:.3g}, {d['high']:.3g}]" for d in (row["differences"][role] for role in roles)]
            lines.append(f"| `{name}` | {row['mean_cost']:.3g} | {100 * v['rate']:.2f}% "
                         f"[{100 * v['interval'][0]:.3g}, {100 * v['interval'][1]:.3g}]% | " + " | ".join(cells) + " |")
        blocks.append("\n".join(lines))
    return "\n\n".join(blocks) + "\n"


def write_every_rule(protocol: Protocol, out: Path, regimes: list[str] | None = None) -> list[dict[str, Any]]:
    """:func:`every_rule` for the regimes named (default: every regime whose test stream is scored), then
    ``OUT/every_rule.md`` over every regime that has its ``every_rule.json``."""
    from agents.files.writer import write_text

    check_run(protocol, out)
    chosen = [protocol.regime(name) for name in regimes] if regimes else [
        regime for regime in protocol.regimes if (out / regime.name / SUMMARY).exists()]
    if not chosen:
        raise ValueError(f"{out}: no regime of {protocol.path} is tested yet (no REGIME/{SUMMARY}); run the protocol first")
    for regime in chosen:
        every_rule(protocol, out, regime)
    entries = [read_json(out / regime.name / "every_rule.json", dict) for regime in protocol.regimes
               if (out / regime.name / "every_rule.json").exists()]
    write_text(out / "every_rule.md", markdown(entries))
    return entries
