"""The committed results (``results/``) and the tree around them.

Every committed sweep with its per-plant tables recomputes its ``summary.md``, ``summary.csv`` and
``summary.json`` byte for byte from them (compressed, read in place) with this checkout's code and the
sweep file of ``configs/sweeps/`` (slow: a few seconds per sweep).  The top level of the repository is
the pipeline: configs in (``configs/``), code (``envs/``, ``baselines/``, ``agents/``), results out
(``results/``), with ``tests/`` and ``docs/``; every YAML file is a config.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

from agents.compressed import exists, read_json, read_text

REPO = Path(__file__).resolve().parents[2]
RESULTS = REPO / "results"
TOP_LEVEL = {"pyproject.toml", "Makefile", "README.md", "constraints.txt", ".ci", ".gitignore", "envs", "agents",
             "baselines", "configs", "tests", "docs", "results"}


def _tracked() -> list[str]:
    try:
        found = subprocess.run(["git", "ls-files"], cwd=REPO, capture_output=True, text=True, check=True).stdout.split("\n")
    except (OSError, subprocess.CalledProcessError):
        pytest.skip("not a git checkout")
    return [path for path in found if path]


def test_the_top_level_is_the_pipeline():
    assert {path.split("/")[0] for path in _tracked()} <= TOP_LEVEL


def test_every_yaml_file_is_a_config():
    assert [path for path in _tracked() if path.endswith((".yaml", ".yml")) and not path.startswith(("configs/", ".ci/"))] == []


def test_tests_hold_only_tests():
    """Under tests/ every Python file is a test module, a conftest or a helper a test imports (by its module
    name); research scripts are ``deadtime study`` commands (agents/studies/)."""
    sources = "\n".join(path.read_text() for path in (REPO / "tests").rglob("test_*.py"))
    others = [path for path in (REPO / "tests").rglob("*.py") if not path.name.startswith("test_") and path.name != "conftest.py"]
    assert [path for path in others if path.name != "__init__.py" and f"import {path.stem}" not in sources
            and f"{path.stem} import" not in sources] == []


def _recomputable() -> list[Path]:
    return sorted(path.parent for path in RESULTS.rglob("eval") if (path.parent / "summary.md").is_file())


@pytest.mark.slow
@pytest.mark.parametrize("folder", _recomputable(), ids=lambda path: str(path.relative_to(RESULTS)))
def test_the_committed_summary_is_its_per_plant_tables(folder: Path, monkeypatch):
    from agents.sweeps.config import load_sweep
    from agents.sweeps.summary import summary_texts

    monkeypatch.chdir(REPO)  # the sweep file names its training configs relative to the repository
    sweep = load_sweep(REPO / "configs" / "sweeps" / f"{folder.name}.yaml")
    committed = read_json(folder / "summary.json")
    trials = [trial for trial in sweep.trials() if trial.name not in committed["failed"]]
    texts = summary_texts(sweep, trials, folder, committed["failed"], read_json(folder / "sessions.json"))
    assert texts["summary.md"] == read_text(folder / "summary.md")
    assert texts["summary.csv"] == read_text(folder / "summary.csv")
    recomputed = json.loads(texts["summary.json"])
    if not all(exists(folder / "runs" / trial.name / "evaluations.json") for trial in trials):
        recomputed.pop("learning_curves"), committed.pop("learning_curves")  # validation histories not committed
    assert recomputed == committed


def test_the_recomputable_sweeps_are_the_current_ones():
    assert len(_recomputable()) >= 28 and not any("superseded" in path.parts for path in _recomputable())


def _folders() -> set[str]:
    superseded = RESULTS / "superseded"
    return ({path.name + "/" for path in RESULTS.iterdir() if path.is_dir() and path != superseded}
            | {f"superseded/{path.name}/" for path in superseded.iterdir() if path.is_dir()})


def test_every_results_folder_has_a_row_in_the_readme():
    """results/README.md: one row per study folder (``results/NAME/``, ``results/superseded/NAME/``), which
    links it; a new folder needs its row (question, environments, policies, seeds, test plants, commit,
    headline, current or superseded)."""
    rows = [line for line in (RESULTS / "README.md").read_text().splitlines() if line.startswith("| [")]
    linked = [line.split("](")[1].split(")")[0] for line in rows]
    assert sorted(linked) == sorted(_folders())
    assert all(line.rstrip(" |").endswith(("current", "superseded")) for line in rows)
    assert all(("superseded/" in target) == line.rstrip(" |").endswith("superseded") for target, line in zip(linked, rows))


def test_the_readme_headlines_are_their_folders_numbers():
    """Every ``value [low, high]`` of a row of results/README.md is printed in one of its folder's Markdown files."""
    import re

    interval = r"-?[\d.e+-]+ \[-?[\d.e+-]+, -?[\d.e+-]+\]"
    rows = [line for line in (RESULTS / "README.md").read_text().splitlines() if line.startswith("| [")]
    checked = 0
    for line in rows:
        folder = RESULTS / line.split("](")[1].split(")")[0]
        texts = "\n".join(path.read_text() for path in folder.rglob("*.md"))
        for quoted in re.findall(interval, line):
            assert quoted in texts, (folder.name, quoted)
            checked += 1
    assert checked >= 40


def test_the_readme_protocol_tables_are_the_committed_reports():
    """Every verdict row of the README's Results is a row of a committed protocol report (``results.md`` of
    ``deadtime protocol report``), and every row of those reports that compares a primary with a rule or
    with another primary is in the README (those with the fixed procedure and the best single plan are
    in the reports only)."""
    readme = (RESULTS.parent / "README.md").read_text()
    rows = {line for line in readme.splitlines() if line.startswith("| ") and line.endswith(("| better |", "| worse |", "| tie |"))}
    reports = {line for path in RESULTS.glob("protocol_v*/results.md") for line in path.read_text().splitlines()
               if line.startswith("| ") and line.endswith(("| better |", "| worse |", "| tie |"))}
    assert rows and rows <= reports
    assert {row for row in reports if "(fixed-procedure)" not in row and "(best-plan)" not in row} <= rows
