"""Files are never written through a symbolic link planted in an output folder, and names that become
file names cannot leave their folder."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from agents.evaluation.cache import Cache
from agents.evaluation.result import PolicyResult
from agents.files.lock import LOCK_NAME, file_lock, folder_lock
from agents.files.names import plain_name
from agents.files.reader import FileProblem
from agents.files.writer import write_text


def _planted(tmp_path: Path, name: str) -> tuple[Path, Path]:
    """``OUT/name``, a link to ``tmp_path/outside/target`` (which holds ``kept``)."""
    outside = tmp_path / "outside"
    outside.mkdir()
    target = outside / "target"
    target.write_text("kept\n")
    out = tmp_path / "out"
    out.mkdir()
    link = out / name
    link.symlink_to(target)
    return link, target


def test_a_planted_lock_link_creates_and_locks_nothing_outside_the_folder(tmp_path):
    """A lock file planted as a link to a path outside ``--out``: refused, nothing created there."""
    outside = tmp_path / "outside"
    outside.mkdir()
    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_NAME).symlink_to(outside / "created")
    with pytest.raises(FileProblem, match="is a symbolic link"), folder_lock(out, "train"):
        pass
    assert not (outside / "created").exists() and list(outside.iterdir()) == []


def test_a_planted_link_beside_a_shared_file_is_refused(tmp_path):
    link, target = _planted(tmp_path, ".test_seeds.json.lock")
    with pytest.raises(FileProblem, match="is a symbolic link"), file_lock(link.with_name("test_seeds.json")):
        pass
    assert target.read_text() == "kept\n"


def test_the_evaluation_cache_is_never_appended_through_a_link(tmp_path):
    """A cache file planted as a link, before or while the cache is open: refused, its target unchanged."""
    link, target = _planted(tmp_path, "cache.jsonl")
    with pytest.raises(FileProblem, match="cache.jsonl is a symbolic link"):
        Cache(link)
    cache = Cache(tmp_path / "out" / "real.jsonl")
    os.replace(link, tmp_path / "out" / "real.jsonl")  # planted after the cache was opened
    result = PolicyResult(cost=1.0, feasible=True, failure=False, experiment_time=2.0)
    with pytest.raises(FileProblem, match="real.jsonl is a symbolic link"):
        cache.put("k", "simc-pi", result)
    assert target.read_text() == "kept\n"


def test_an_atomic_write_replaces_a_planted_link_and_leaves_its_target(tmp_path):
    link, target = _planted(tmp_path, "summary.json")
    write_text(link, "{}\n")
    assert not link.is_symlink() and link.read_text() == "{}\n" and target.read_text() == "kept\n"


@pytest.mark.parametrize("name", ["..", ".", "", "a/b", "a\\b", "/abs", "a\0b", "-x", "x ", "a\nb", 5, None, "x" * 300])
def test_a_name_that_is_not_a_plain_file_name_is_refused_in_one_line(name):
    with pytest.raises(ValueError, match="regimes.0..name must be a plain file name") as error:
        plain_name(name, "regimes[0].name")
    assert "\n" not in str(error.value)


@pytest.mark.parametrize("name", ["pid-noise10-time", "learned-plan-cert-3000", "a.b", "x_y"])
def test_plain_names_pass(name):
    assert plain_name(name, "label") == name


def test_a_study_writes_its_table_and_figure_in_place_of_planted_links(tmp_path, monkeypatch):
    """``transfer.md`` and ``transfer.png`` planted as links to a file outside ``--out``: each is replaced
    by a regular file, the link's target unchanged."""
    import agents.studies.transfer as study

    link, target = _planted(tmp_path, "transfer.md")
    figure = link.with_name("transfer.png")
    figure.symlink_to(target)
    rows = [{"condition": "c", "seed": seed, "policy": "rule-a", "run": "rule-a", "role": "rule", "cost": 1.0 + seed,
             "feasible": True, "predicted": 1.0, "note": None} for seed in (0, 1)]
    monkeypatch.setattr(study, "_one_run", lambda condition, seed, groups: [rows[seed]])
    table = study.transfer({}, 2, link.parent, conditions=("c",))
    for path in (link, figure):
        assert path.is_file() and not path.is_symlink()
    assert link.read_text() == table and figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n" and target.read_text() == "kept\n"


def test_a_figure_is_written_in_place_of_a_planted_link(tmp_path):
    from agents.studies.violation_cost_plot import violation_cost_plot

    link, target = _planted(tmp_path, "violation_cost.png")
    violation_cost_plot(link)
    assert link.is_file() and not link.is_symlink() and link.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert target.read_text() == "kept\n"
