"""The work of ``deadtime protocol run`` as independent tasks: the fits, and the evaluations of a stream in chunks.

A task is plain data (picklable; its paths relative to the working directory it runs in), run by :func:`run_task` in this process or on a worker
of a Ray cluster (:mod:`agents.protocol.workers`), and it writes only its own folder:

* :class:`Fit`: one seed of one learner in one regime (:func:`agents.protocol.training.train_learner`),
  into its run directory under the fits folder; resumable (a finished fit is read back); its CPU and wall
  seconds added to the run directory's ``timing.json``.
* :class:`agents.protocol.members.Member`: a frontier protocol's family at one knob and one seed on a
  chunk of a stream (:mod:`agents.protocol.frontier_run`), and :class:`~agents.protocol.members.Knobs`, a rule
  family's members at every knob on one chunk, on one identification per plant.
* :class:`Chunk`: plants ``first`` to ``first + len(plants)`` of a regime's validation or test stream,
  evaluated (:func:`agents.evaluation.evaluate.evaluate`) into ``WORK/REGIME/STAGE/chunk-KKKK``, whose
  per-plant cache resumes an interrupted chunk.  Its episode seeds are the stream's ``episode_seed + i``
  for stream plant ``i`` (the chunk is evaluated with the seed ``episode_seed + first``), and chunk 0 of a
  test stream also scores the benchmark batch (whose seeds depend on the stream's seed only), so that
  every plant is scored as one evaluation of the whole stream would score it.

What a task does depends on the protocol and the regime only, never on which worker runs it or when.
:func:`merge_chunks` then writes the stream's ``per_plant.csv`` (the plants relabelled and reindexed in
the stream's order, the benchmark rows last), which is the ``per_plant.csv`` of one evaluation of the
whole stream: the protocol's tables do not depend on the chunk size nor on the number of workers.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from agents.protocol.config import Learner, Regime

__all__ = ["CHUNK_PLANTS", "Chunk", "Fit", "chunks", "merge_chunks", "run_task"]

CHUNK_PLANTS = 250
"""Plants per evaluation task (the last chunk of a stream may hold fewer)."""


@dataclass(frozen=True)
class Fit:
    """One seed of one learner in one regime, trained into ``fits``."""

    fits: str
    regime: Regime
    learner: Learner
    seed: int

    @property
    def name(self) -> str:
        return f"fit {self.learner.label} seed {self.seed} ({self.regime.name})"

    def directory(self) -> Path:
        from agents.protocol.training import run_directory

        return run_directory(Path(self.fits), self.regime, self.learner, self.seed)


@dataclass(frozen=True)
class Chunk:
    """Plants ``first ...`` of a regime's stream (``stage`` validation or test) and the policies scored on them."""

    regime: str
    stage: str
    index: int
    first: int
    env: str
    env_kwargs: dict[str, Any]
    policies: tuple[str, ...]
    plants: tuple[dict[str, Any], ...]
    episode_seed: int
    benchmark: bool
    directory: str

    @property
    def name(self) -> str:
        return f"{self.stage} plants {self.first}-{self.first + len(self.plants) - 1} ({self.regime})"


def run_task(task: Any) -> str:
    """Run ``task`` (see the module docstring; a frontier's :class:`agents.protocol.members.Member` too);
    returns the folder it wrote."""
    from agents.protocol.members import Knobs, Member, score_knobs, score_member

    if isinstance(task, Member):
        return score_member(task)
    if isinstance(task, Knobs):
        return score_knobs(task)
    if isinstance(task, Fit):
        from agents.protocol.members import clock, timed
        from agents.protocol.training import train_learner

        started = clock()
        directory = train_learner(Path(task.fits), task.regime, task.learner, task.seed)
        timed(Path(directory), started, 0, 1)
        return str(directory)
    from agents.evaluation.evaluate import evaluate

    evaluate(task.env, ",".join(task.policies), len(task.plants), task.episode_seed + task.first, Path(task.directory),
             benchmark=task.benchmark, resamples=100, plots=False, plants=[dict(plant) for plant in task.plants],
             env_kwargs=dict(task.env_kwargs))
    return task.directory


def chunks(regime: Regime, stage: str, policies: list[str], plants: list[Any], episode_seed: int, directory: Path,
           benchmark: bool, size: int = CHUNK_PLANTS) -> list[Chunk]:
    """The chunks of ``plants`` (a stream, in order) into ``directory/chunk-KKKK``; the benchmark batch with chunk 0."""
    dicts = [plant.to_dict() for plant in plants]
    return [Chunk(regime.name, stage, k, first, regime.env, dict(regime.env_kwargs), tuple(policies),
                  tuple(dicts[first:first + size]), episode_seed, benchmark and k == 0,
                  str(directory / f"chunk-{k:04d}"))
            for k, first in enumerate(range(0, len(dicts), size))]


def _rows(path: Path) -> tuple[list[str], list[dict[str, str]]]:
    with path.open(newline="") as handle:
        reader = csv.DictReader(handle)
        return list(reader.fieldnames or []), list(reader)


def merge_chunks(parts: list[Chunk], path: Path) -> None:
    """Write ``path``, the ``per_plant.csv`` of one evaluation of the whole stream, from its chunks' tables."""
    from agents.files.writer import csv_text, write_text

    total = sum(len(part.plants) for part in parts)
    columns: dict[str, None] = {}
    test, benchmark = [], []
    for part in parts:
        names, rows = _rows(Path(part.directory) / "per_plant.csv")
        columns.update(dict.fromkeys(names))
        for row in rows:
            if row["subset"] == "test":
                local = int(row["index"])
                test.append({**row, "index": str(part.first + local), "plant": f"user-{part.first + local}"})
            else:  # the benchmark batch, after the chunk's test plants: after the stream's in one evaluation
                benchmark.append({**row, "index": str(int(row["index"]) - len(part.plants) + total)})
    order = list(columns)
    write_text(path, csv_text([order, *([row.get(c, "") for c in order] for row in test + benchmark)]))
