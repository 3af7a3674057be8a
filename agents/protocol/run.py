"""``deadtime protocol run``: a protocol's regimes, each trained, chosen on validation and tested once.

A frontier protocol (a ``frontier`` section: every policy a family by its risk knob) runs by
:mod:`agents.protocol.frontier_run` instead, through the same start, lock, workers and resumption.

For each regime, in the protocol's order (or the ones named), until its ``summary.json`` exists:

1. every candidate learner is trained with every seed of the protocol (:mod:`agents.protocol.training`,
   resumable per seed);
2. the declared rules, plans, the fixed procedure and every candidate's seeds are scored on the
   validation stream (:func:`agents.evaluation.evaluate.evaluate`, whose per-plant cache resumes an
   interrupted evaluation);
3. the best rule, the best plan and the primaries (fixed, plan, sequential) are chosen on it (:mod:`agents.protocol.selection`)
   and written to ``OUT/REGIME/selection.json``;
4. only then the test stream, and the papers' benchmark batch beside it, are scored for the chosen
   policies and the oracle; ``OUT/REGIME/test_per_plant.csv.gz`` holds every per-plant result (the
   benchmark rows are labelled so, and never enter the statistics of the random plants), and
   ``OUT/REGIME/summary.json`` the regime's unadjusted comparisons and violations.

Steps 1, 2 and 4 are independent tasks (:mod:`agents.protocol.tasks`: a fit per learner and seed, an
evaluation per chunk of a stream's plants), run for every regime at once, in this process or on Ray
(:mod:`agents.protocol.workers`): the fits, then the validation chunks, the choices, then the test
chunks.  The tables are assembled in the stream's order and depend on no worker's order, so a run on
a cluster writes the bytes a serial run writes.  An interrupted run resumes (``resume``): each finished
fit is read back and each chunk's evaluation is served from its cache.

The folder's ``protocol.json`` records the protocol's path, sha256, the commit it started at and the
sha256 of each training config its learners name (each regime's ``selection.json`` and ``summary.json``
the commit they were computed at); a run into a folder of another protocol's sha256, or with a training
config changed since the run started, is refused in one line, and so is a protocol whose test
entropy is not registered to its own sha256 (:func:`agents.protocol.streams.check_test_seed`).  The
trained models (``OUT/work/runs``, or the folder given as ``fits``, which several protocols may share)
and the evaluations' caches stay in ``OUT/work`` (not results: never committed).
"""

from __future__ import annotations

import csv
import dataclasses
import gzip
import hashlib
import io
import os
import subprocess
import sys
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from agents.files.reader import read_csv, read_json
from agents.protocol.config import PRIMARIES, Protocol, Regime, structure_and_family
from agents.protocol.selection import choose_primary, least_mean
from agents.protocol.statistics import paired_difference, plant_means, plant_violations
from agents.protocol.streams import check_test_seed, plant_stream
from agents.protocol.tasks import CHUNK_PLANTS, Chunk, Fit, chunks, merge_chunks

__all__ = ["PER_PLANT", "SUMMARY", "ProtocolRefused", "read_per_plant", "run_protocol", "start"]

PER_PLANT = "test_per_plant.csv.gz"
SUMMARY = "summary.json"
_COLUMNS = ("subset", "plant", "policy", "seed", "cost", "feasible")


class ProtocolRefused(ValueError):
    """A run that would evaluate a test stream under another protocol."""


def _commit() -> str:
    """The checked-out commit (``unknown`` outside a git work tree), with ``-dirty`` if files changed."""
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], capture_output=True, text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True, text=True,
                               check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return f"{head}-dirty" if dirty else head


def _config_digests(protocol: Protocol) -> dict[str, str]:
    """The sha256 of every training config the protocol's learners name, by path."""
    configs = sorted({learner.config for regime in protocol.regimes for mode in PRIMARIES
                      for learner in regime.candidates(mode)})
    return {path: hashlib.sha256(Path(path).read_bytes()).hexdigest() for path in configs}


def start(protocol: Protocol, out: Path, resume: bool, uncommitted: bool | None = None) -> dict[str, Any]:
    """Check that ``protocol`` may run into ``out`` and record it there (``protocol.json``).

    ``uncommitted`` (default: the environment variable ``DEADTIME_UNCOMMITTED_CODE`` set to 1) lets a run
    start from a tree with changes not committed, or resume from another code than the recorded one,
    and marks its ``protocol.json`` so (:mod:`agents.protocol.code`).

    Raises
    ------
    ProtocolRefused
        One line: the test seed is not registered to this protocol, ``out`` holds another protocol's
        run, or holds a run and ``resume`` is False, or a training config it names changed since the
        run started, or the code is not the recorded one (:func:`agents.protocol.code.check_code`).
    """
    from agents.protocol.code import CodeRefused, check_code

    if uncommitted is None:
        uncommitted = os.environ.get("DEADTIME_UNCOMMITTED_CODE") == "1"
    registry = Path(protocol.path).with_name("test_seeds.json")
    try:
        check_test_seed(protocol.test.entropy, protocol.sha256, registry)
    except ValueError as error:
        raise ProtocolRefused(str(error)) from None
    record_path = out / "protocol.json"
    if record_path.exists():
        record = read_json(record_path, dict)
        if record.get("protocol_sha256") != protocol.sha256:
            raise ProtocolRefused(f"{out} holds the run of protocol sha256 {str(record.get('protocol_sha256'))[:12]}, "
                                  f"{protocol.path} has {protocol.sha256[:12]}: a changed protocol takes a fresh test seed")
        if not resume:
            raise ProtocolRefused(f"{out} already holds this protocol's run: add --resume to continue it")
        changed = [path for path, digest in _config_digests(protocol).items()
                   if record.get("configs_sha256", {}).get(path) != digest]
        if changed:
            raise ProtocolRefused(f"{changed[0]} changed since the run in {out} started: its learners would not be the "
                                  "protocol's; restore it (the run's commit is in protocol.json)")
        try:
            code = check_code(record.get("code"), uncommitted)
        except CodeRefused as error:
            raise ProtocolRefused(str(error)) from None
        if code != record.get("code"):
            from agents.files.writer import write_json

            record = {**record, "code": code}
            write_json(record_path, record)
        return record
    from agents.files.writer import write_json

    try:
        code = check_code(None, uncommitted)
    except CodeRefused as error:
        raise ProtocolRefused(str(error)) from None
    out.mkdir(parents=True, exist_ok=True)
    record = {"protocol": protocol.path, "protocol_sha256": protocol.sha256, "commit": code["commit"] + ("" if code["clean"] else "-dirty"),
              "code": code, "test_entropy": protocol.test.entropy, "configs_sha256": _config_digests(protocol)}
    write_json(record_path, record)
    return record


# ------------------------------------------------------------------------------------ tables
def read_per_plant(path: Path, learners: dict[str, str] | None = None) -> list[dict[str, Any]]:
    """Rows ``(subset, plant, policy, seed, cost, feasible)`` of an evaluation's ``per_plant.csv`` or of a
    protocol's gzip table; ``learners`` maps an evaluation's policy names to ``(label, seed)`` text ``label@seed``."""
    rows = []
    for row in read_csv(path, ("subset", "plant", "policy", "cost", "feasible")):
        policy, seed = row["policy"], row.get("seed", "")
        if learners is not None:
            label, _, trained = learners.get(policy, f"{policy}@").partition("@")
            policy, seed = label, trained
        rows.append({"subset": row["subset"], "plant": row["plant"], "policy": policy, "seed": seed,
                     "cost": float(row["cost"]), "feasible": row["feasible"] == "True"})
    return rows


def _write_table(path: Path, rows: list[dict[str, Any]]) -> None:
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=_COLUMNS, lineterminator="\n")
    writer.writeheader()
    for row in rows:
        writer.writerow({**row, "cost": f"{row['cost']:.7g}"})
    from agents.files.writer import atomic_write

    data = gzip.compress(text.getvalue().encode(), compresslevel=9, mtime=0)
    atomic_write(path, lambda handle: handle.write(data))


def matrices(rows: list[dict[str, Any]], subset: str) -> tuple[list[str], dict[str, tuple[np.ndarray, np.ndarray]]]:
    """The plants of ``subset`` in order, and per policy its ``(seeds, plants)`` costs and feasibility."""
    plants: dict[str, int] = {}
    grouped: dict[str, dict[str, dict[str, tuple[float, bool]]]] = {}
    for row in rows:
        if row["subset"] != subset:
            continue
        plants.setdefault(row["plant"], len(plants))
        grouped.setdefault(row["policy"], {}).setdefault(row["seed"], {})[row["plant"]] = (row["cost"], row["feasible"])
    order = list(plants)
    result = {}
    for policy, seeds in grouped.items():
        if any(len(values) != len(order) for values in seeds.values()):
            raise ValueError(f"policy {policy} is not scored on every {subset} plant")
        costs = np.array([[seeds[s][p][0] for p in order] for s in sorted(seeds, key=lambda s: (len(s), s))])
        feasible = np.array([[seeds[s][p][1] for p in order] for s in sorted(seeds, key=lambda s: (len(s), s))])
        result[policy] = (costs, feasible)
    return order, result


# ------------------------------------------------------------------------------------ one regime
def _evaluate(regime: Regime, policies: list[str], plants: list[Any], episode_seed: int, directory: Path,
              benchmark: bool) -> None:
    from agents.evaluation.evaluate import evaluate

    evaluate(regime.env, ",".join(policies), len(plants), episode_seed, directory, benchmark=benchmark, resamples=100,
             plots=False, plants=[plant.to_dict() for plant in plants], env_kwargs=dict(regime.env_kwargs))


def _learner_policies(protocol: Protocol, fits: Path, regime: Regime,
                      labels: list[tuple[str, str]]) -> tuple[list[str], dict[str, str], list[Fit]]:
    """``NAME=PATH`` policies of the learners' seeds, NAME -> ``label@seed``, and the fits they need."""
    plain = dataclasses.replace(regime, env_kwargs=dict(regime.env_kwargs))  # picklable, for a Ray task
    policies, names, needed = [], {}, []
    for mode, label in labels:
        learner = next(item for item in regime.candidates(mode) if item.label == label)
        for seed in protocol.seeds:
            fit = Fit(str(fits), plain, learner, seed)
            name = f"{mode}.{label}.s{seed}"
            policies.append(f"{name}={fit.directory()}")
            names[name] = f"{label}@{seed}"
            needed.append(fit)
    return policies, names, needed


def _baselines(protocol: Protocol) -> list[str]:
    selection = protocol.selection
    return list(dict.fromkeys([*selection.rules, *selection.plans, selection.fixed_procedure, "oracle"]))


def _rule_names(protocol: Protocol, structure: str) -> list[str]:
    """The rules that ``selection.rules`` expands to in ``structure``."""
    from agents.evaluation.policies import parse_policies

    return [spec.name for spec in parse_policies(",".join(protocol.selection.rules), structure) if spec.kind == "rule"]


def _base_rule(protocol: Protocol, structure: str) -> dict[str, str]:
    """``{"base-rule": name}`` where a comparison names the structure's own rule, else nothing."""
    if not any(second == "base-rule" for _, second in protocol.comparisons):
        return {}
    from envs.structures import structure as structure_of

    return {"base-rule": structure_of(structure).base_rule}


class _Stage(NamedTuple):
    """A regime's validation or test stream: its chunks, the fits they need, and the learners' names."""

    chunks: list[Chunk]
    fits: list[Fit]
    names: dict[str, str]
    directory: Path


def _validation(protocol: Protocol, work: Path, regime: Regime, fits: Path, size: int) -> _Stage:
    """Step 2's tasks: the declared rules, plans, procedure and every candidate's seeds on the validation stream."""
    labels = [(mode, learner.label) for mode in PRIMARIES for learner in regime.candidates(mode)]
    learners, names, needed = _learner_policies(protocol, fits, regime, labels)
    structure, family = structure_and_family(regime)
    plants = plant_stream(family, protocol.validation.entropy, protocol.validation.plants)
    policies = [*_baselines(protocol), *_base_rule(protocol, structure).values(), *learners]
    directory = work / regime.name / "validation"
    return _Stage(chunks(regime, "validation", policies, plants, protocol.validation.episode_seed, directory, False, size),
                  needed, names, directory)


def select(protocol: Protocol, out: Path, regime: Regime, stage: _Stage) -> dict[str, Any]:
    """Step 3 of the module docstring, once the validation stream's chunks are scored; returns (and writes)
    ``selection.json``."""
    from agents.files.writer import write_json

    structure, family = structure_and_family(regime)
    merge_chunks(stage.chunks, stage.directory / "per_plant.csv")
    _, table = matrices(read_per_plant(stage.directory / "per_plant.csv", stage.names), "test")
    mean_of = {name: plant_means(table[name][0]) for name in table}
    base = _base_rule(protocol, structure)
    chosen: dict[str, Any] = {
        "best-rule": least_mean({name: mean_of[name] for name in _rule_names(protocol, structure)}),
        "fixed-procedure": protocol.selection.fixed_procedure,
        **base,
    }
    if protocol.selection.plans:
        chosen["best-plan"] = least_mean({name: mean_of[name] for name in protocol.selection.plans})
    candidates = {}
    target, confidence = protocol.selection.violation_target, protocol.selection.confidence
    for mode in PRIMARIES:
        modes = [learner.label for learner in regime.candidates(mode)]
        if modes:
            label, records = choose_primary({m: table[m][0] for m in modes}, {m: table[m][1] for m in modes}, target, confidence)
            chosen[mode] = label
            candidates[mode] = [record.to_dict() for record in records]
    selection = {"regime": regime.name, "commit": _commit(), "env": regime.env, "env_kwargs": dict(regime.env_kwargs), "family": family,
                 "validation_plants": protocol.validation.plants, "chosen_on": "validation", "chosen": chosen,
                 "candidates": candidates,
                 "validation_mean_cost": {name: float(values.mean()) for name, values in sorted(mean_of.items())}}
    write_json(out / regime.name / "selection.json", selection)
    return selection


def _regime_summary(protocol: Protocol, selection: dict[str, Any], rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Per chosen policy its test mean and plant violations; the declared comparisons, unadjusted."""
    chosen = selection["chosen"]
    _, table = matrices(rows, "test")
    policies = {role: {"policy": name, "mean_cost": float(plant_means(table[name][0]).mean()),
                       "violations": plant_violations(table[name][1], 0.95).to_dict()}
                for role, name in chosen.items()}
    comparisons = []
    for first, second in protocol.comparisons:
        if first in chosen and second in chosen:
            d = paired_difference(chosen[first], chosen[second], table[chosen[first]][0], table[chosen[second]][0])
            comparisons.append({"first": d.first, "second": d.second, "roles": [first, second], "mean": d.mean,
                                "unadjusted": [d.low, d.high], "p_value": d.p_value, "percent_of_second": d.percent_of_second,
                                "share_better": d.share_better})
    plants, benchmark = matrices(rows, "benchmark")
    return {"regime": selection["regime"], "commit": _commit(), "env": selection["env"], "env_kwargs": selection["env_kwargs"],
            "test_plants": len(matrices(rows, "test")[0]), "rule_chosen_on": "validation", "chosen": chosen,
            "policies": policies, "comparisons": comparisons,
            "benchmark": {"plants": len(plants), "pooled": False,
                          "policies": {role: {"policy": name, "mean_cost": float(plant_means(benchmark[name][0]).mean()),
                                              "violating_plants": plant_violations(benchmark[name][1]).violating}
                                       for role, name in chosen.items() if name in benchmark}}}


def _test(protocol: Protocol, work: Path, regime: Regime, selection: dict[str, Any], fits: Path, size: int) -> _Stage:
    """Step 4's tasks: the chosen policies and the oracle on the test stream, the benchmark batch with its first chunk."""
    chosen = selection["chosen"]
    labels = [(mode, chosen[mode]) for mode in PRIMARIES if mode in chosen]
    learners, names, needed = _learner_policies(protocol, fits, regime, labels)
    baselines = list(dict.fromkeys([chosen[role] for role in ("best-rule", "base-rule", "fixed-procedure", "best-plan") if role in chosen]))
    plants = plant_stream(selection["family"], protocol.test.entropy, protocol.test.plants)
    directory = work / regime.name / "test"
    return _Stage(chunks(regime, "test", [*baselines, "oracle", *learners], plants, protocol.test.episode_seed, directory, True,
                         size), needed, names, directory)


def test_regime(protocol: Protocol, out: Path, selection: dict[str, Any], stage: _Stage) -> dict[str, Any]:
    """Step 4 of the module docstring, once the test stream's chunks are scored: the table and the summary."""
    from agents.files.writer import write_json

    merge_chunks(stage.chunks, stage.directory / "per_plant.csv")
    rows = read_per_plant(stage.directory / "per_plant.csv", stage.names)
    name = selection["regime"]
    _write_table(out / name / PER_PLANT, rows)
    summary = _regime_summary(protocol, selection, rows)
    write_json(out / name / SUMMARY, summary)
    return summary


def _unique(fits: list[Fit]) -> list[Fit]:
    """Each fit once, in the order first needed (two regimes may need the same run directory)."""
    found: dict[Path, Fit] = {}
    for fit in fits:
        found.setdefault(fit.directory(), fit)
    return list(found.values())


def run_protocol(protocol: Protocol, out: Path, *, resume: bool = False, regimes: list[str] | None = None,
                 validation_only: bool = False, fits: Path | None = None, workers: int = 1, address: str | None = None,
                 chunk: int = CHUNK_PLANTS, uncommitted: bool | None = None) -> list[str]:
    """Run the protocol's regimes (all, or those named) into ``out``; returns the names of the regimes done.

    ``validation_only`` stops each regime after its choices (``selection.json``), before its test stream;
    ``fits`` is the folder of the learners' fits (default ``out/work/runs``).  The fits, then the
    validation chunks, then the test chunks run as tasks (:mod:`agents.protocol.tasks`) on ``workers``
    local workers or the Ray cluster at ``address`` (:mod:`agents.protocol.workers`); ``chunk`` plants
    per evaluation task.  ``out`` is locked while the run lasts (:func:`agents.files.lock.folder_lock`).

    Raises
    ------
    ProtocolRefused, FolderInUse
        In one line, before anything is written (see :func:`start`; another run holds ``out``).
    """
    from agents.files.lock import folder_lock
    from agents.protocol.workers import workers as pool

    chosen = [protocol.regime(name) for name in regimes] if regimes else list(protocol.regimes)
    with folder_lock(out, "protocol run"):
        start(protocol, out, resume, uncommitted)
        work = out / "work"
        fits = fits or work / "runs"
        if protocol.frontier is not None:
            from agents.protocol.frontier_run import run_frontier

            run_frontier(protocol, out, chosen, fits, lambda: pool(workers, address), validation_only, chunk)
            return [regime.name for regime in chosen]
        pending = [regime for regime in chosen if not (out / regime.name / SUMMARY).exists()]
        if not pending:
            return [regime.name for regime in chosen]
        selected = {r.name: read_json(out / r.name / "selection.json", dict) for r in pending
                    if (out / r.name / "selection.json").exists()}
        with pool(workers, address) as run:
            stages = {r.name: _validation(protocol, work, r, fits, chunk) for r in pending if r.name not in selected}
            tested = {r.name: _test(protocol, work, r, selected[r.name], fits, chunk) for r in pending if r.name in selected}
            _say(f"{len(pending)} regime(s) to run: the fits, then the validation plants, then the test plants")
            run(_unique([fit for stage in [*stages.values(), *tested.values()] for fit in stage.fits]))  # every fit a test needs
            run([part for stage in stages.values() for part in stage.chunks])
            for regime in pending:
                if regime.name in stages:
                    selected[regime.name] = select(protocol, out, regime, stages[regime.name])
                    _say(f"{regime.name}: chosen on validation {selected[regime.name]['chosen']}")
            if not validation_only:
                tested.update({r.name: _test(protocol, work, r, selected[r.name], fits, chunk) for r in pending
                               if r.name not in tested})
                run([part for stage in tested.values() for part in stage.chunks])
                for regime in pending:
                    test_regime(protocol, out, selected[regime.name], tested[regime.name])
                    _say(f"{regime.name}: tested")
    return [regime.name for regime in chosen]


def _say(line: str) -> None:
    print(f"deadtime protocol: {line}", file=sys.stderr, flush=True)
