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
its adjusted intervals are not final.  A declared comparison that a regime cannot make is listed by
it: ``not_applicable`` where the regime has no candidate of a primary it names (or the protocol no
plans), outside the family by design; ``not_made`` where the regime should make it and its
``selection.json`` chose no policy for a role (the family is then incomplete).

The run is checked before anything is read (:func:`check_run`): the folder's ``protocol.json`` must
record this protocol's sha256, and the registry its test seed, so that a protocol edited after its
run, or a folder of another protocol, is refused in one line.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from agents.files.reader import FileProblem, read_json
from agents.protocol.config import Protocol, Regime, comparison_problem
from agents.protocol.run import PER_PLANT, matrices, read_per_plant
from agents.protocol.statistics import holm, paired_difference, plant_violations, verdict
from agents.protocol.streams import check_test_seed

__all__ = ["check_run", "chosen_policies", "markdown", "forest_plot", "protocol_results", "read_table", "write_report"]


def _declared(protocol: Protocol) -> int:
    """The number of comparisons the protocol declares (the size of Holm's family)."""
    return sum(1 for regime in protocol.regimes for pair in protocol.comparisons
               if comparison_problem(protocol, regime, pair) is None)


def check_run(protocol: Protocol, out: Path) -> dict[str, Any]:
    """The record (``protocol.json``) of the run in ``out`` if it is this protocol's run.

    Raises
    ------
    ValueError
        One line: ``out`` holds no run, the run of another protocol (or of this file before it was
        edited), or the protocol's test seed is not registered to its sha256.
    """
    if not out.is_dir():
        raise ValueError(f"{out}: no such run folder")
    if not (out / "protocol.json").is_file():
        raise ValueError(f"{out} holds no protocol run (no protocol.json): run the protocol into it first")
    record = read_json(out / "protocol.json", dict)
    recorded = record.get("protocol_sha256")
    if recorded != protocol.sha256:
        raise ValueError(f"{out} holds the run of {record.get('protocol')!s} with sha256 {str(recorded)[:12]}, "
                         f"{protocol.path} has sha256 {protocol.sha256[:12]}: the protocol changed after its run, "
                         "or the folder is another protocol's")
    if not isinstance(record.get("commit"), str):
        raise ValueError(f"{out / 'protocol.json'}: commit must be a string, got {record.get('commit')!r}")
    check_test_seed(protocol.test.entropy, protocol.sha256, Path(protocol.path).with_name("test_seeds.json"))
    return record


def read_table(path: Path, subset: str = "test") -> tuple[list[str], dict[str, Any]]:
    """:func:`agents.protocol.run.matrices` of the per-plant table ``path``, any problem one line naming it."""
    try:
        return matrices(read_per_plant(path), subset)
    except FileProblem:
        raise
    except (ValueError, KeyError) as error:
        raise ValueError(f"{path}: {' '.join(str(error).split())}") from None


def chosen_policies(folder: Path, regime: Regime, table: dict[str, Any]) -> tuple[dict[str, Any], dict[str, str]]:
    """The regime's ``selection.json`` and its ``chosen`` roles, each naming a policy of the test ``table``.

    Raises
    ------
    ValueError
        One line naming the file: the selection is of another regime, or names a policy its test table lacks.
    """
    path = folder / "selection.json"
    selection = read_json(path, dict)
    chosen = selection.get("chosen")
    if selection.get("regime") != regime.name:
        raise ValueError(f"{path} is the selection of regime {selection.get('regime')!r}, not of {regime.name!r}")
    if not isinstance(chosen, dict) or not all(isinstance(k, str) and isinstance(v, str) for k, v in chosen.items()):
        raise ValueError(f"{path}: chosen must map roles to policy names, got {chosen!r}")
    for role, name in chosen.items():
        if name not in table:
            raise ValueError(f"{path} chooses {name!r} as {role}, which {folder / PER_PLANT} does not score")
    return selection, chosen


def protocol_results(protocol: Protocol, out: Path) -> dict[str, Any]:
    """The ``protocol_results.json`` object of the run in ``out`` (module docstring)."""
    record = check_run(protocol, out)
    regimes, differences, missing = [], [], []
    for regime in protocol.regimes:
        folder = out / regime.name
        if not (folder / PER_PLANT).exists():
            missing.append(regime.name)
            continue
        plants, table = read_table(folder / PER_PLANT)
        bench_plants, bench = read_table(folder / PER_PLANT, "benchmark")
        selection, chosen = chosen_policies(folder, regime, table)
        entry = {"name": regime.name, "env": regime.env, "env_kwargs": dict(regime.env_kwargs), "test_plants": len(plants),
                 "validation_plants": selection.get("validation_plants"), "rule_chosen_on": "validation", "chosen": chosen,
                 "comparisons": [], "not_applicable": [], "not_made": [], "violations": {},
                 "benchmark": {"plants": len(bench_plants), "pooled": False, "mean_cost": {}, "violating_plants": {}}}
        for name in dict.fromkeys(chosen.values()):
            entry["violations"][name] = plant_violations(table[name][1]).to_dict()
            if name in bench:
                entry["benchmark"]["mean_cost"][name] = float(bench[name][0].mean(axis=0).mean())
                entry["benchmark"]["violating_plants"][name] = plant_violations(bench[name][1]).violating
        for first, second in protocol.comparisons:
            problem = comparison_problem(protocol, regime, (first, second))
            absent = [role for role in (first, second) if role not in chosen]
            if problem:
                entry["not_applicable"].append({"roles": [first, second], "reason": problem})
            elif absent:
                entry["not_made"].append({"roles": [first, second],
                                          "reason": f"{folder / 'selection.json'} chooses no {absent[0]}"})
            else:
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
            "complete": declared > 0 and len(differences) == declared, "regimes_missing": missing,
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
    if results.get("regimes_missing"):
        note += f"\n\nNot yet tested: {', '.join(results['regimes_missing'])}."
    for regime in results["regimes"]:
        for item in regime.get("not_made", []):
            note += f"\n\nNot made: {regime['name']}, {item['roles'][0]} - {item['roles'][1]} ({item['reason']})."
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
    from agents.files.writer import atomic_write, figure_writer

    try:
        atomic_write(path, figure_writer(figure, 120))
    finally:
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
