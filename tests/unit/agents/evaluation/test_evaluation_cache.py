"""The per-plant cache of ``deadtime evaluate`` (agents.evaluation.run.Cache) shared by concurrent runs.

Two evaluations on one ``--out`` must not write a cache line twice.  Two processes put the
same results, in opposite orders, into one file; every ``(key, policy)`` must be on file once and
read back equal.
"""

from __future__ import annotations

import json
import multiprocessing
from pathlib import Path

from agents.evaluation.run import Cache, PolicyResult

ENTRIES = [(f"plant-{i}", policy) for i in range(400) for policy in ("simc-pi", "oracle", "agent")]


def _fill(path: str, reverse: bool) -> None:
    cache = Cache(Path(path))
    for key, policy in reversed(ENTRIES) if reverse else ENTRIES:
        if cache.get(key, policy) is None:
            cache.put(key, policy, PolicyResult(float(len(key) + len(policy)), True, False, 1.0))


def test_two_runs_on_one_file_write_each_line_once(tmp_path):
    path = tmp_path / "cache.jsonl"
    context = multiprocessing.get_context("spawn")
    runs = [context.Process(target=_fill, args=(str(path), reverse)) for reverse in (False, True)]
    for run in runs:
        run.start()
    for run in runs:
        run.join(60)
        assert run.exitcode == 0
    lines = [json.loads(line) for line in path.read_text().splitlines()]
    assert sorted((e["key"], e["policy"]) for e in lines) == sorted(ENTRIES)
    assert Cache(path).entries == {(k, p): PolicyResult(float(len(k) + len(p)), True, False, 1.0) for k, p in ENTRIES}


def test_a_line_cut_short_is_skipped_and_cut_off_by_the_next_append(tmp_path):
    path = tmp_path / "cache.jsonl"
    path.write_text('{"key": "a", "policy": "p", "result": {"cost": 1.0, "feas')
    cache = Cache(path)
    assert cache.entries == {}
    cache.put("b", "p", PolicyResult(2.0, True, False, 1.0))
    assert Cache(path).entries == {("b", "p"): PolicyResult(2.0, True, False, 1.0)}
