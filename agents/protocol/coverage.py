"""``deadtime protocol coverage``: the actual coverage of the protocol's interval, by simulation.

The populations are the committed per-plant results of the studies (each sweep folder's evaluation
of ten seeds of a learner, and of the rules, on its random test plants; the benchmark batch left out):
per learner and comparison, the per-plant differences ``learner (mean over seeds) - second`` with the
second the best rule (least mean cost among the rules on those plants), the fixed procedure
``plan-1-1`` or the best single plan ``plan-best``.  Each population stands for the plant
distribution; its mean is the true difference.  A replicate draws ``n`` plants from it with
replacement (the protocol's test size) and computes the Student-t interval of the mean at the
nominal level; the coverage is the share of ``replicates`` intervals that contain the true mean, and
its Monte Carlo standard error ``sqrt(c (1 - c) / replicates)``.

Bounds, checked before any file is read: ``n`` in ``[2, MAX_TEST_PLANTS]`` (the protocol's test size at
most), ``replicates`` in ``[1, MAX_RESAMPLES]``, the Holm family's size ``m`` in ``[1, MAX_COMPARISONS]``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from scipy import stats

from agents.files.reader import read_csv
from agents.limits import MAX_RESAMPLES, MAX_TEST_PLANTS, require_at_most

__all__ = ["MAX_COMPARISONS", "coverage", "levels", "populations", "t_coverage"]

MAX_COMPARISONS = 10_000
"""Comparisons of one Holm family (``--comparisons``): the protocols declare tens."""

_NOT_RULES = ("oracle", "oracle-full", "amplitude-rule")


def _costs(path: Path) -> dict[str, dict[str, float]]:
    """``policy -> plant -> cost`` of the random test plants of an evaluation's ``per_plant.csv``."""
    found: dict[str, dict[str, float]] = {}
    for row in read_csv(path, ("subset", "policy", "plant", "cost")):
        if row["subset"] == "test":
            found.setdefault(row["policy"], {})[row["plant"]] = float(row["cost"])
    return found


def populations(sweeps: Path, structures: tuple[str, ...] = ("PID", "FPPI")) -> list[dict[str, Any]]:
    """Every (sweep, environment, learner, second) population of per-plant differences in the sweep
    folders under ``sweeps`` (their ``eval/ENV/*/per_plant.csv``, plain or ``.gz``)."""
    found = []
    for baselines in sorted(sweeps.glob("*/eval/*/baselines/per_plant.csv*")):
        env_dir = baselines.parent.parent
        if env_dir.name.split("-")[0] not in structures:
            continue
        rules = _costs(baselines)
        plants = sorted(next(iter(rules.values())))
        learners: dict[str, list[np.ndarray]] = {}
        for run in sorted(env_dir.glob("*-s[0-9]*/per_plant.csv*")):
            label = run.parent.name.rsplit("-s", 1)[0].removesuffix(f"-{env_dir.name}")
            costs = next(iter(_costs(run).values()))
            learners.setdefault(label, []).append(np.array([costs[p] for p in plants]))
        candidates = {name: np.array([c[p] for p in plants]) for name, c in rules.items()
                      if name not in _NOT_RULES and not name.startswith("plan-")}
        if not candidates:
            continue
        best = min(candidates, key=lambda name: candidates[name].mean())
        seconds = {"best rule": candidates[best]}
        for name in ("plan-1-1", "plan-best"):
            if name in rules:
                seconds[name] = np.array([rules[name][p] for p in plants])
        for label, seeds in learners.items():
            if len(seeds) < 2:
                continue
            mean = np.mean(seeds, axis=0)
            for second, costs in seconds.items():
                found.append({"sweep": env_dir.parent.parent.name, "env": env_dir.name, "learner": label,
                              "second": best if second == "best rule" else second, "differences": mean - costs})
    return found


def t_coverage(population: np.ndarray, n: int, replicates: int, level: float, rng: np.random.Generator,
               chunk: int = 200) -> float:
    """The share of ``replicates`` t intervals (``n`` plants drawn with replacement) containing the mean."""
    truth = float(population.mean())
    quantile = float(stats.t.ppf(0.5 + level / 2, n - 1))
    hits = 0
    for start in range(0, replicates, chunk):
        size = min(chunk, replicates - start)
        sample = population[rng.integers(0, population.size, size=(size, n))]
        mean, error = sample.mean(axis=1), sample.std(axis=1, ddof=1) / np.sqrt(n)
        hits += int(np.sum(np.abs(mean - truth) <= quantile * error))
    return hits / replicates


def _count(value: Any, name: str, least: int, limit: int) -> int:
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < least:
        raise ValueError(f"{name} must be an integer >= {least}, got {value!r}")
    require_at_most(value, limit, name)
    return int(value)


def levels(comparisons: int, alpha: float = 0.05) -> tuple[float, float]:
    """The levels checked: 95% and Holm's strictest, ``1 - alpha/m`` for ``m`` comparisons."""
    m = _count(comparisons, "--comparisons", 1, MAX_COMPARISONS)
    return 0.95, 1 - alpha / m


def coverage(sweeps: Path, n: int, replicates: int, levels: tuple[float, ...], seed: int = 0) -> dict[str, Any]:
    """The coverage of the t interval at each level on every population (module docstring)."""
    _count(n, "--n", 2, MAX_TEST_PLANTS)
    _count(replicates, "--replicates", 1, MAX_RESAMPLES)
    if not levels or not all(isinstance(level, float) and 0 < level < 1 for level in levels):
        raise ValueError(f"every level must be a number in (0, 1), got {levels!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise ValueError(f"--seed must be an integer >= 0, got {seed!r}")
    if not sweeps.is_dir():
        raise ValueError(f"--sweeps {sweeps}: no such folder")
    rng = np.random.default_rng(seed)
    rows = []
    for population in populations(sweeps):
        values = population.pop("differences")
        row = {**population, "plants": int(values.size), "mean": float(values.mean()), "sd": float(values.std(ddof=1))}
        for level in levels:
            c = t_coverage(values, n, replicates, level, rng)
            row[f"coverage_{level:g}"] = c
        rows.append(row)
    error = {f"{level:g}": float(np.sqrt(level * (1 - level) / replicates)) for level in levels}
    smallest = {f"{level:g}": min(row[f"coverage_{level:g}"] for row in rows) for level in levels} if rows else {}
    return {"method": "Student t over plants", "n": n, "replicates": replicates, "seed": seed,
            "monte_carlo_standard_error_at_nominal": error, "smallest_coverage": smallest, "populations": rows}
