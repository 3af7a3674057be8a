"""A frontier protocol's run (a protocol file with a ``frontier`` section): every policy a family by its risk knob.

For each regime, until its ``summary.json`` exists:

1. every candidate learner is trained with every seed of the protocol (the fits of :mod:`agents.protocol.training`);
2. on the validation stream, every family (each declared rule as ``RULE@S``, each learner's seeds at
   the knob) at every knob of the grid, and the oracle, are scored, one task per (family, knob, seed,
   chunk of plants) (:class:`agents.protocol.members.Member`; a rule family's knobs on one chunk share
   one task, :class:`~agents.protocol.members.Knobs`, and one identification per plant); the per-plant per-seed table
   ``OUT/work/REGIME/validation_per_plant.csv.gz`` is assembled in the stream's order;
3. the choices are made on it alone and written to ``OUT/REGIME/selection.json`` (:func:`frontier_choices`):
   per family its mean cost and risk over the knob, where risk is the share of validation plants on
   which one seed's design violates, per seed then averaged over the seeds (the union over the seeds
   beside it); at each declared risk level ``r`` each family's knob of least mean cost among those of
   risk at most ``r`` (none: the family cannot reach ``r``), and the best rule family and best learned
   family at ``r`` (least mean cost); the best rule as shipped (least mean cost at ``s = 0``) and the
   best learned family at that rule's risk;
4. only then the chosen (family, knob) policies and the oracle are scored on the test stream, into
   ``OUT/REGIME/test_per_plant.csv.gz`` (one row per plant, a cost and a feasibility column per policy and
   seed: :func:`write_table`), and
   ``OUT/REGIME/summary.json`` is written.

``OUT/protocol_results.json`` (:func:`frontier_results`, also ``deadtime protocol report``) is made
from the selections and the test tables: per regime the frontiers, the comparisons per risk level,
each policy's test risk with its exact intervals, the share of the rule-to-oracle gap closed, and Holm
over the declared family of comparisons, each (regime, first, second) counted once.

Every task depends on the protocol and the regime only, and the tables are written in the order of the
families, knobs, seeds and plants, so that a run on a Ray cluster writes the bytes a serial run writes;
an interrupted run resumes from the fits, the tasks' tables and their per-plant caches.
"""

from __future__ import annotations

import dataclasses
import gzip
import sys
from collections.abc import Callable
from contextlib import AbstractContextManager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from agents.files.reader import read_csv, read_json
from agents.protocol.config import Protocol, Regime, structure_and_family
from agents.protocol.members import Member, batched, member_label
from agents.protocol.tasks import Fit

__all__ = ["VALIDATION_TABLE", "frontier_choices", "frontier_results", "read_table", "run_frontier"]

VALIDATION_TABLE = "validation_per_plant.csv.gz"
TEST_TABLE = "test_per_plant.csv.gz"
SELECTION = "selection.json"
SUMMARY = "summary.json"
RESULTS = "protocol_results.json"
ORACLE = "oracle"


@dataclass(frozen=True)
class FamilySpec:
    """A family of a regime: ``kind`` ``rule`` (one member, the rule's name) or ``learned`` (per seed its fit)."""

    name: str
    kind: str
    members: tuple[tuple[str, str], ...]


def _say(line: str) -> None:
    print(f"deadtime protocol: {line}", file=sys.stderr, flush=True)


def _level(r: float) -> str:
    return f"{100 * r:g}%"


# ------------------------------------------------------------------------------------ the tasks
def families(protocol: Protocol, regime: Regime, fits: Path) -> list[FamilySpec]:
    """The regime's rule families (its ``rules``, else the protocol's, expanded) then its learned families."""
    from agents.evaluation.policies import parse_policies

    structure, _ = structure_and_family(regime)
    names = regime.rules or protocol.frontier.rules
    rules = [spec.name for spec in parse_policies(",".join(names), structure) if spec.kind == "rule"]
    found = [FamilySpec(rule, "rule", (("", rule),)) for rule in dict.fromkeys(rules)]
    plain = dataclasses.replace(regime, env_kwargs=dict(regime.env_kwargs))  # picklable, for a Ray task
    for learner in regime.learners():
        found.append(FamilySpec(learner.label, "learned", tuple(
            (str(seed), str(Fit(str(fits), plain, learner, seed).directory())) for seed in protocol.seeds)))
    found += [FamilySpec(name, "learned", (("", name),)) for name in regime.pretrained]  # one model: the shipped file
    return found


def fits_of(protocol: Protocol, regime: Regime, fits: Path) -> list[Fit]:
    plain = dataclasses.replace(regime, env_kwargs=dict(regime.env_kwargs))
    return [Fit(str(fits), plain, learner, seed) for learner in regime.learners() for seed in protocol.seeds]


def member_tasks(regime: Regime, stage: str, pairs: list[tuple[FamilySpec, float]], plants: list[Any], episode_seed: int,
                 directory: Path, size: int) -> list[Member]:
    """One task per (family, knob, seed, chunk of ``size`` plants), in that order, then the oracle's chunks."""
    dicts = [plant.to_dict() for plant in plants]
    starts = list(enumerate(range(0, len(dicts), size)))
    oracle = FamilySpec(ORACLE, ORACLE, (("", ORACLE),))
    tasks = []
    for family, knob in [*pairs, (oracle, 0.0)]:
        for seed, member in family.members:
            folder = directory / family.name / f"k{float(knob)!r}" / (f"s{seed}" if seed else "model" if family.kind == "learned" else "rule")
            tasks += [Member(regime.name, stage, family.name, family.kind, member, float(knob), seed, first, regime.env,
                             dict(regime.env_kwargs), tuple(dicts[first:first + size]), episode_seed,
                             str(folder / f"chunk-{k:04d}")) for k, first in starts]
    return tasks


def _column(label: str, seed: str) -> str:
    return f"{label}#{seed}" if seed else label


def write_table(tasks: list[Member], path: Path) -> None:
    """The per-plant per-seed table of ``tasks``' outputs (gzip CSV, reproducible bytes): one row per plant in the
    stream's order; a column ``cost:POLICY`` and ``feasible:POLICY`` (1 or 0) per policy and seed, in the tasks'
    order, ``POLICY`` being ``FAMILY@S#SEED`` for a learned family, ``FAMILY@S`` for a rule, ``oracle``."""
    from agents.files.writer import atomic_write, csv_text

    columns: dict[str, dict[int, tuple[str, str]]] = {}
    for task in tasks:
        label = ORACLE if task.kind == ORACLE else member_label(task.family, task.knob)
        found = columns.setdefault(_column(label, task.seed), {})
        for row in read_csv(Path(task.directory) / "per_plant.csv", ("index", "cost", "feasible")):
            found[int(row["index"])] = (f"{float(row['cost']):.7g}", "1" if row["feasible"] == "True" else "0")
    plants = sorted(next(iter(columns.values())))
    rows = [["plant", *(f"cost:{name}" for name in columns), *(f"feasible:{name}" for name in columns)]]
    for plant in plants:
        rows.append([str(plant), *(found[plant][0] for found in columns.values()), *(found[plant][1] for found in columns.values())])
    data = gzip.compress(csv_text(rows).encode(), compresslevel=9, mtime=0)
    atomic_write(path, lambda handle: handle.write(data))


def read_table(path: Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Per policy ``FAMILY@S`` (or ``oracle``) its ``(seeds, plants)`` costs and violations (seeds in the table's order)."""
    import csv
    import io

    with gzip.open(path, "rt", newline="") as handle:
        reader = csv.reader(io.StringIO(handle.read()))
        header = next(reader)
        values = np.array(list(reader), dtype=object)
    grouped: dict[str, list[tuple[np.ndarray, np.ndarray]]] = {}
    for i, name in enumerate(header):
        if name.startswith("cost:"):
            column = name.removeprefix("cost:")
            violated = values[:, header.index(f"feasible:{column}")] != "1"
            grouped.setdefault(column.rpartition("#")[0] or column, []).append((values[:, i].astype(float), violated))
    return {policy: (np.array([c for c, _ in seeds]), np.array([v for _, v in seeds])) for policy, seeds in grouped.items()}


# ------------------------------------------------------------------------------------ the choices
def _frontier(kind: str, knobs: tuple[float, ...], table: dict, name: str) -> dict[str, Any]:
    entry: dict[str, Any] = {"kind": kind, "knobs": list(knobs), "mean_cost": [], "risk": [], "risk_union": [],
                             "cost_per_seed": [], "risk_per_seed": []}
    for knob in knobs:
        costs, violated = table[member_label(name, knob)]
        entry["mean_cost"].append(float(costs.mean()))
        entry["risk"].append(float(violated.mean(axis=1).mean()))
        entry["risk_union"].append(float(violated.any(axis=0).mean()))
        entry["cost_per_seed"].append([float(c) for c in costs.mean(axis=1)])
        entry["risk_per_seed"].append([float(v) for v in violated.mean(axis=1)])
    return entry


def _point(frontiers: dict[str, Any], family: str, knob: float) -> dict[str, Any]:
    entry = frontiers[family]
    i = entry["knobs"].index(knob)
    return {"family": family, "knob": knob, "kind": entry["kind"], "mean_cost": entry["mean_cost"][i], "risk": entry["risk"][i]}


def _knob_at(entry: dict[str, Any], r: float) -> float | None:
    from agents.frontier.frontier import choose_knob

    rows = [{"knob": k, "mean_cost": c, "risk": v} for k, c, v in zip(entry["knobs"], entry["mean_cost"], entry["risk"])]
    return choose_knob(rows, r)


def _best_at(frontiers: dict[str, Any], r: float, kind: str) -> dict[str, Any] | None:
    """The family of ``kind`` of least validation cost at its knob chosen at ``r`` (None: none reaches ``r``)."""
    points = [_point(frontiers, name, knob) for name, entry in frontiers.items() if entry["kind"] == kind
              for knob in [_knob_at(entry, r)] if knob is not None]
    return min(points, key=lambda point: (point["mean_cost"], point["family"])) if points else None


def frontier_choices(protocol: Protocol, families_: list[FamilySpec], table: dict) -> dict[str, Any]:
    """The frontiers and the choices of step 3 (module docstring) from the validation table."""
    knobs = protocol.frontier.knobs
    frontiers = {f.name: _frontier(f.kind, knobs, table, f.name) for f in families_}
    levels = {_level(r): r for r in protocol.frontier.risk_levels}
    chosen = {name: {level: _knob_at(entry, r) for level, r in levels.items()} for name, entry in frontiers.items()}
    best = {level: {"rule": _best_at(frontiers, r, "rule"), "learned": _best_at(frontiers, r, "learned")}
            for level, r in levels.items()}
    cannot = {level: [name for name in frontiers if chosen[name][level] is None] for level in levels}
    rules = [name for name, entry in frontiers.items() if entry["kind"] == "rule"]
    shipped = min((_point(frontiers, name, 0.0) for name in rules), key=lambda p: (p["mean_cost"], p["family"])) if rules else None
    at_shipped = None if shipped is None else _best_at(frontiers, shipped["risk"], "learned")
    oracle_costs, oracle_violated = table[ORACLE]
    return {"frontiers": frontiers, "chosen": chosen, "cannot_reach": cannot, "best": best,
            "shipped_rule": shipped, "learned_at_shipped_rule_risk": at_shipped,
            "oracle": {"mean_cost": float(oracle_costs.mean()), "risk": float(oracle_violated.mean())}}


def comparisons_of(selection: dict[str, Any]) -> list[dict[str, Any]]:
    """The regime's declared comparisons: per risk level the best learned family against the best rule family,
    and the best learned family at the shipped rule's risk against that rule (where both exist)."""
    found = []
    for level, best in selection["best"].items():
        if best["learned"] is not None and best["rule"] is not None:
            found.append({"kind": "matched risk", "risk_level": level, "first": best["learned"], "second": best["rule"]})
    if selection["learned_at_shipped_rule_risk"] is not None:
        shipped = selection["shipped_rule"]
        found.append({"kind": "at the shipped rule's risk", "risk_level": shipped["risk"],
                      "first": selection["learned_at_shipped_rule_risk"], "second": shipped})
    return found


def _pairs(selection: dict[str, Any], specs: list[FamilySpec]) -> list[tuple[FamilySpec, float]]:
    """The distinct (family, knob) of the comparisons, in the families' then the knobs' order."""
    wanted = {(side["family"], side["knob"]) for c in comparisons_of(selection) for side in (c["first"], c["second"])}
    return [(spec, knob) for spec in specs for knob in sorted({k for f, k in wanted if f == spec.name})]


# ------------------------------------------------------------------------------------ the run
def _stream(protocol: Protocol, regime: Regime, stage: str) -> tuple[list[Any], int]:
    from agents.protocol.streams import plant_stream

    stream = protocol.validation if stage == "validation" else protocol.test
    _, family = structure_and_family(regime)
    return plant_stream(family, stream.entropy, stream.plants), stream.episode_seed


def _validation(protocol: Protocol, work: Path, regime: Regime, specs: list[FamilySpec], size: int) -> list[Member]:
    plants, episode_seed = _stream(protocol, regime, "validation")
    pairs = [(spec, knob) for spec in specs for knob in protocol.frontier.knobs]
    return member_tasks(regime, "validation", pairs, plants, episode_seed, work / regime.name / "validation", size)


def _test(protocol: Protocol, work: Path, regime: Regime, specs: list[FamilySpec], selection: dict, size: int) -> list[Member]:
    plants, episode_seed = _stream(protocol, regime, "test")
    return member_tasks(regime, "test", _pairs(selection, specs), plants, episode_seed, work / regime.name / "test", size)


def _select(protocol: Protocol, out: Path, regime: Regime, specs: list[FamilySpec], tasks: list[Member]) -> dict[str, Any]:
    from agents.files.writer import write_json

    path = out / "work" / regime.name / VALIDATION_TABLE
    write_table(tasks, path)
    record = read_json(out / "protocol.json", dict)
    _, family = structure_and_family(regime)
    selection = {"regime": regime.name, "commit": record.get("commit"), "code_sha256": record.get("code", {}).get("sha256"),
                 "env": regime.env, "env_kwargs": dict(regime.env_kwargs), "family": family,
                 "validation_plants": protocol.validation.plants, "seeds": list(protocol.seeds), "chosen_on": "validation",
                 "risk": "share of validation plants on which one seed's design violates, averaged over the seeds",
                 **frontier_choices(protocol, specs, read_table(path))}
    write_json(out / regime.name / SELECTION, selection)
    return selection


def _tested(protocol: Protocol, out: Path, regime: Regime, selection: dict[str, Any], tasks: list[Member]) -> None:
    from agents.files.writer import write_json

    write_table(tasks, out / regime.name / TEST_TABLE)
    write_json(out / regime.name / SUMMARY, regime_summary(selection, read_table(out / regime.name / TEST_TABLE)))


def run_frontier(protocol: Protocol, out: Path, chosen: list[Regime], fits: Path, pool: Callable[[], AbstractContextManager],
                 validation_only: bool, size: int) -> None:
    """Steps 1-4 of the module docstring for the regimes ``chosen`` not done; then ``protocol_results.json``."""
    work = out / "work"
    pending = [regime for regime in chosen if not (out / regime.name / SUMMARY).exists()]
    if pending:
        specs = {r.name: families(protocol, r, fits) for r in pending}
        selected = {r.name: read_json(out / r.name / SELECTION, dict) for r in pending if (out / r.name / SELECTION).exists()}
        with pool() as run:
            validation = {r.name: _validation(protocol, work, r, specs[r.name], size) for r in pending if r.name not in selected}
            _say(f"{len(pending)} regime(s) to run: the fits, then the frontiers on the validation plants, then the test plants")
            run([fit for r in pending for fit in fits_of(protocol, r, fits)])
            run(batched([task for tasks in validation.values() for task in tasks]))
            for regime in pending:
                if regime.name in validation:
                    selected[regime.name] = _select(protocol, out, regime, specs[regime.name], validation[regime.name])
                    best = {level: {kind: None if b is None else member_label(b["family"], b["knob"]) for kind, b in pair.items()}
                            for level, pair in selected[regime.name]["best"].items()}
                    _say(f"{regime.name}: chosen on validation {best}")
            if validation_only:
                return
            tests = {r.name: _test(protocol, work, r, specs[r.name], selected[r.name], size) for r in pending}
            run(batched([task for tasks in tests.values() for task in tasks]))
            for regime in pending:
                _tested(protocol, out, regime, selected[regime.name], tests[regime.name])
                _say(f"{regime.name}: tested")
    if all((out / regime.name / SUMMARY).exists() for regime in protocol.regimes):
        frontier_results(protocol, out)


# ------------------------------------------------------------------------------------ the test's statistics
def _risk(violated: np.ndarray) -> dict[str, Any]:
    """A policy's test risk: per seed, averaged, with the exact interval of the pooled episodes; and the union's."""
    from agents.protocol.statistics import clopper_pearson

    k, n = violated.shape
    union = int(violated.any(axis=0).sum())
    return {"risk": float(violated.mean(axis=1).mean()), "risk_per_seed": [float(v) for v in violated.mean(axis=1)],
            "risk_interval": list(clopper_pearson(int(violated.sum()), k * n)),
            "risk_union": union / n, "risk_union_interval": list(clopper_pearson(union, n)), "seeds": k, "plants": n}


RISK_INTERVALS = (
    "risk_interval: Clopper-Pearson (exact, 95%) on the violating episodes pooled over seeds and plants (k n trials): "
    "exact for the share of (seed, plant) episodes if they were independent trials; the seeds share their plants, so it "
    "is conditional on the seeds and narrower than an interval with plants random where seeds violate on the same plants. "
    "risk_union_interval: Clopper-Pearson (exact, 95%) on the plants where any seed violates (n trials): exact with the "
    "plants random, the trained seeds fixed.")


def _difference(first: tuple[np.ndarray, np.ndarray], second: tuple[np.ndarray, np.ndarray]) -> np.ndarray:
    """The (seeds x plants) paired differences ``first - second`` (a rule's one row is each seed's partner)."""
    return first[0] - second[0].mean(axis=0)[None, :]


def _gap_closed(first: np.ndarray, second: np.ndarray, oracle: np.ndarray, resamples: int = 1000) -> dict[str, Any]:
    """``(second - first) / (second - oracle)`` of the mean costs, and its two-way bootstrap percentile interval
    (seeds of ``first`` and plants resampled)."""
    k, n = first.shape
    rule, best = second.mean(axis=0), oracle.mean(axis=0)
    estimate = float((rule.mean() - first.mean()) / (rule.mean() - best.mean())) if rule.mean() != best.mean() else None
    rng = np.random.default_rng(0)
    seeds = rng.multinomial(k, np.full(k, 1.0 / k), size=resamples) / k
    plants = rng.multinomial(n, np.full(n, 1.0 / n), size=resamples) / n
    learner = np.einsum("bk,kn,bn->b", seeds, first, plants)
    gap = plants @ rule - plants @ best
    ratios = (plants @ rule - learner)[gap != 0] / gap[gap != 0]
    interval = [float(v) for v in np.percentile(ratios, [2.5, 97.5])] if ratios.size and estimate is not None else None
    return {"estimate": estimate, "interval": interval, "method": "two-way bootstrap percentile (seeds and plants resampled)"}


def regime_summary(selection: dict[str, Any], table: dict[str, tuple[np.ndarray, np.ndarray]]) -> dict[str, Any]:
    """The regime's test results: each chosen policy's mean cost and risk, the oracle's, the comparisons unadjusted."""
    from agents.frontier.statistics import seeds_or_plants_interval, seeds_or_plants_p_value

    policies = {label: {"mean_cost": float(costs.mean()), **_risk(violated)} for label, (costs, violated) in table.items()}
    comparisons = []
    for comparison in comparisons_of(selection):
        first = member_label(comparison["first"]["family"], comparison["first"]["knob"])
        second = member_label(comparison["second"]["family"], comparison["second"]["knob"])
        d = _difference(table[first], table[second])
        interval = seeds_or_plants_interval(d)
        comparisons.append({**comparison, "first_policy": first, "second_policy": second,
                            "difference": interval.to_dict(), "p_value": seeds_or_plants_p_value(d),
                            "percent_of_second": 100.0 * interval.estimate / float(table[second][0].mean()),
                            "gap_closed": _gap_closed(table[first][0], table[second][0], table[ORACLE][0])})
    return {"regime": selection["regime"], "env": selection["env"], "env_kwargs": selection["env_kwargs"],
            "test_plants": int(table[ORACLE][0].shape[1]), "chosen_on": "validation", "policies": policies,
            "comparisons": comparisons}


def frontier_results(protocol: Protocol, out: Path) -> dict[str, Any]:
    """``OUT/protocol_results.json`` from every regime's selection and test table (module docstring)."""
    from agents.files.writer import write_json
    from agents.frontier.statistics import seeds_or_plants_interval
    from agents.protocol.statistics import holm

    record = read_json(out / "protocol.json", dict)
    regimes, family = {}, []
    for regime in protocol.regimes:
        if not (out / regime.name / SUMMARY).exists():
            continue
        selection = read_json(out / regime.name / SELECTION, dict)
        table = read_table(out / regime.name / TEST_TABLE)
        summary = regime_summary(selection, table)
        seen: dict[tuple[str, str], dict[str, Any]] = {}
        for comparison in summary["comparisons"]:
            key = (comparison["first_policy"], comparison["second_policy"])
            if key in seen:  # the same pair at another risk level: one member of the Holm family
                seen[key]["answers"].append(comparison["risk_level"])
                comparison["holm"] = "counted once, with the comparison of the same pair above"
                continue
            comparison["answers"] = [comparison["risk_level"]]
            seen[key] = comparison
            family.append((regime.name, comparison, _difference(table[key[0]], table[key[1]])))
        regimes[regime.name] = {**{k: selection[k] for k in ("env", "env_kwargs", "family", "validation_plants", "seeds",
                                                             "frontiers", "chosen", "cannot_reach", "best", "shipped_rule",
                                                             "learned_at_shipped_rule_risk")},
                                "validation_oracle": selection["oracle"], "test_plants": summary["test_plants"],
                                "test": summary["policies"], "matched": summary["comparisons"]}
    if family:
        adjusted, rejected, levels = holm([c["p_value"] for _, c, _ in family], protocol.alpha)
        for (_, comparison, d), p, reject, level in zip(family, adjusted, rejected, levels):
            held = seeds_or_plants_interval(d, level=float(level))
            comparison.update({"holm_p_value": float(p), "holm_rejected": bool(reject), "holm_level": float(level),
                               "holm_interval": [held.low, held.high]})
    results = {"protocol": protocol.path, "protocol_sha256": protocol.sha256, "commit": record.get("commit"),
               "code": record.get("code"), "alpha": protocol.alpha, "risk_levels": list(protocol.frontier.risk_levels),
               "knobs": list(protocol.frontier.knobs), "comparisons_in_holm_family": len(family),
               "interval_method": "crossed random effects (t, Satterthwaite): seeds and plants random; for a shipped "
                                  "learner (one model) the paired t over the plants, the model fixed",
               "risk_intervals": RISK_INTERVALS, "regimes": regimes}
    write_json(out / RESULTS, results)
    return results
