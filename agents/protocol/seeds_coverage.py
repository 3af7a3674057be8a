"""The coverage of the seeds-random interval (:func:`agents.frontier.statistics.crossed_interval`) on committed per-seed tables.

A protocol's per-plant table (``test_per_plant.csv.gz``, random test plants only) holds, for each
learner, one row per trained seed and plant, and for each rule one row per plant.  Per regime and per
learner of at least two seeds, the population is the (seeds x plants) matrix ``D`` of the learner's
cost minus the regime's chosen best rule's on each plant (the learner of a frontier protocol's table
against each rule policy of the table); its mean is the known true difference.  A replicate draws
the seeds (rows) and the plants (columns) of ``D`` with replacement, independently and in the table's
numbers (``k`` seeds, ``n`` plants), and computes the interval at the nominal level; the coverage is
the share of replicates whose interval holds the population's mean, with its Monte Carlo standard error
``sqrt(c (1 - c) / replicates)``.  Seeds drawn twice are the same trained model twice, as the
bootstrap population has only the ``k`` seeds trained: the check is of the interval where the spread
between seeds is that of the committed seeds.

``deadtime protocol seeds-coverage TABLE... --out FILE`` (docs/protocol.md).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from agents.files.reader import read_csv, read_json

__all__ = ["coverage_of", "populations", "seeds_coverage"]


def _rows(path: Path) -> dict[str, dict[str, dict[str, float]]]:
    """``policy -> seed -> plant -> cost`` of the table's random test plants."""
    found: dict[str, dict[str, dict[str, float]]] = {}
    for row in read_csv(path, ("plant", "policy", "seed", "cost")):
        if row.get("subset", "test") == "test":
            found.setdefault(row["policy"], {}).setdefault(row["seed"], {})[row["plant"]] = float(row["cost"])
    return found


def _frontier_rows(path: Path) -> dict[str, dict[str, dict[str, float]]] | None:
    """:func:`_rows` of a frontier protocol's table (one row per plant, ``cost:POLICY#SEED`` columns), None for another."""
    import csv
    import gzip

    opener = gzip.open if path.suffix == ".gz" else open
    with opener(path, "rt", newline="") as handle:
        reader = csv.reader(handle)
        header = next(reader)
        if header[:1] != ["plant"]:
            return None
        found: dict[str, dict[str, dict[str, float]]] = {}
        for row in reader:
            for name, value in zip(header, row):
                if name.startswith("cost:"):
                    policy, _, seed = name.removeprefix("cost:").partition("#")
                    found.setdefault(policy, {}).setdefault(seed, {})[row[0]] = float(value)
    return found


def populations(path: Path) -> list[dict[str, Any]]:
    """The (learner, rule) populations of one table (module docstring): ``D`` and its names."""
    table = _frontier_rows(path)
    table = _rows(path) if table is None else table
    summary = path.with_name("summary.json")
    if summary.exists() and "best-rule" in read_json(summary, dict).get("chosen", {}):
        rules = [read_json(summary, dict)["chosen"]["best-rule"]]
    elif path.with_name("selection.json").exists():  # a frontier protocol's table: its rule families' members
        kinds = {name: entry["kind"] for name, entry in read_json(path.with_name("selection.json"), dict)["frontiers"].items()}
        rules = [p for p in table if kinds.get(p.rpartition("@")[0]) == "rule"]
    else:  # a frontier table without its selection: every policy without seeds but the oracle
        rules = [p for p, seeds in table.items() if list(seeds) == [""] and p != "oracle"]
    found = []
    for learner, seeds in table.items():
        if len(seeds) < 2 or "" in seeds:
            continue
        plants = list(next(iter(seeds.values())))
        costs = np.array([[seeds[s][p] for p in plants] for s in sorted(seeds, key=lambda s: (len(s), s))])
        for rule in rules:
            second = np.array([table[rule][""][p] for p in plants])
            found.append({"table": str(path), "learner": learner, "rule": rule, "differences": costs - second[None, :]})
    return found


def coverage_of(d: np.ndarray, replicates: int, level: float, rng: np.random.Generator,
                seeds: int | None = None) -> tuple[float, float]:
    """The share of ``replicates`` crossed intervals (seeds and plants of ``d`` resampled; ``seeds`` of them, default
    ``d``'s own count) holding ``d``'s mean, and their mean width."""
    from agents.frontier.statistics import crossed_interval

    k, n = d.shape
    truth, hits, widths = float(d.mean()), 0, []
    for _ in range(replicates):
        sample = d[rng.integers(0, k, size=seeds or k)][:, rng.integers(0, n, size=n)]
        if np.ptp(sample) == 0.0:
            hits += bool(sample[0, 0] == truth)
            widths.append(0.0)
            continue
        found = crossed_interval(sample, level)
        hits += bool(found.low <= truth <= found.high)
        widths.append(found.high - found.low)
    return hits / replicates, float(np.mean(widths))


def seeds_coverage(tables: list[Path], replicates: int = 1000, level: float = 0.95, seed: int = 0,
                   seeds: int | None = None) -> dict[str, Any]:
    """The coverage on every population of ``tables`` (module docstring); ``seeds`` resampled per replicate (default:
    the table's own count; more: the coverage a protocol of that many seeds would have, the spread between seeds
    being the committed seeds')."""
    if not tables:
        raise ValueError("give at least one per-seed table (e.g. results/protocol_v3/*/test_per_plant.csv.gz)")
    for path in tables:
        if not Path(path).is_file():
            raise ValueError(f"{path}: no such table")
    if isinstance(replicates, bool) or not isinstance(replicates, int) or replicates < 1:
        raise ValueError(f"replicates must be an integer >= 1, got {replicates!r}")
    if seeds is not None and (isinstance(seeds, bool) or not isinstance(seeds, int) or seeds < 2):
        raise ValueError(f"seeds must be an integer >= 2, got {seeds!r}")
    rng = np.random.default_rng(seed)
    rows = []
    for path in tables:
        for population in populations(Path(path)):
            d = population.pop("differences")
            covered, width = coverage_of(d, replicates, level, rng, seeds)
            rows.append({**population, "seeds": int(d.shape[0]), "seeds_resampled": int(seeds or d.shape[0]), "plants": int(d.shape[1]), "mean": float(d.mean()),
                         "coverage": covered, "mean_width": width})
    covered = [row["coverage"] for row in rows]
    return {"method": "crossed random effects (t, Satterthwaite): seeds and plants random", "level": level,
            "population": "each table's (seeds x plants) learner-minus-rule matrix, its seeds and plants resampled",
            "replicates": replicates, "seed": seed,
            "monte_carlo_standard_error_at_nominal": float(np.sqrt(level * (1 - level) / replicates)),
            "populations_checked": len(rows), "smallest_coverage": min(covered) if rows else None,
            "median_coverage": float(np.median(covered)) if rows else None, "populations": rows}
