"""The committed results (``results/``) and the tree around them.

The protocols at the top of ``results/``, the current exploratory studies in ``results/exploratory/``,
the retired ones in git history at the commits results/README.md names, at most 24 MB tracked.  The top level of the repository is
the pipeline: configs in (``configs/``), code (``envs/``, ``baselines/``, ``agents/``), results out
(``results/``), with ``tests/`` and ``docs/``; every YAML file is a config.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest


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


def _folders() -> set[str]:
    exploratory = RESULTS / "exploratory"
    return ({path.name + "/" for path in RESULTS.iterdir() if path.is_dir() and path != exploratory}
            | {f"exploratory/{path.name}/" for path in exploratory.iterdir() if path.is_dir()})


def _rows() -> list[str]:
    return [line for line in (RESULTS / "README.md").read_text().splitlines() if line.startswith("| [")]


def test_the_protocols_are_at_the_top_and_the_studies_in_one_folder():
    assert {path.name for path in RESULTS.iterdir() if path.is_dir()} - {"exploratory"} <= {
        path.name for path in RESULTS.glob("protocol_*")}


def test_every_results_folder_has_a_row_in_the_readme():
    """results/README.md: one row per folder (``results/protocol_*/``, ``results/exploratory/NAME/``), which
    links it; a new folder needs its row (question, environments, policies, seeds, test plants, commit,
    headline, status)."""
    linked = [line.split("](")[1].split(")")[0] for line in _rows()]
    assert sorted(linked) == sorted(_folders())
    assert all(line.rstrip(" |").endswith("current") for line in _rows())


def test_the_results_stay_within_24_mb():
    """A clone stays light: the tracked files under results/ hold at most 24 MB (v1-v4 and the studies take
    about 19.6 MB, protocol v5 about 0.3 MB per regime and its report)."""
    assert sum((REPO / path).stat().st_size for path in _tracked() if path.startswith("results/")) <= 24_000_000


def test_every_retired_folder_is_in_the_history_at_its_commit():
    """The retired folders of results/README.md are gone from the tree and ``git show COMMIT:results/NAME``
    finds them at the commit of their row."""
    _tracked()  # skips outside a git checkout
    retired = [line.split(" | ") for line in (RESULTS / "README.md").read_text().splitlines() if line.startswith("| `")]
    assert len(retired) >= 40
    for name, _, commit in ((cells[0][3:-1], cells[1], cells[2].strip("`| ")) for cells in retired):
        assert not (RESULTS / name).exists(), name
        found = subprocess.run(["git", "cat-file", "-t", f"{commit}:results/{name}"], cwd=REPO, capture_output=True, text=True)
        if found.returncode and "Not a valid object name" in found.stderr and "does not exist" not in found.stderr:
            pytest.skip(f"commit {commit} not in this clone")
        assert found.stdout.strip() == "tree", (name, commit, found.stderr)


def test_the_readme_headlines_are_their_folders_numbers():
    """Every ``value [low, high]`` of a row of results/README.md is printed in one of its folder's Markdown files."""
    import re

    interval = r"-?[\d.e+-]+ \[-?[\d.e+-]+, -?[\d.e+-]+\]"
    checked = 0
    for line in _rows():
        folder = RESULTS / line.split("](")[1].split(")")[0]
        texts = "\n".join(path.read_text() for path in folder.rglob("*.md"))
        for quoted in re.findall(interval, line):
            assert quoted in texts, (folder.name, quoted)
            checked += 1
    assert checked >= 40


def _readme_results() -> str:
    """The README's Results section, its heading line first."""
    readme = (RESULTS.parent / "README.md").read_text()
    return readme[readme.index("## Results\n"):].split("\n## ")[0]


def test_the_readme_table_is_v5s_answer_table():
    """The README's Results table is the answer table of protocol v5's committed report (``results.md`` of
    ``deadtime protocol report``), every row of it, and docs/protocol.md links every protocol's report."""
    section = _readme_results()
    report = (RESULTS / "protocol_v5" / "results.md").read_text()
    answer = report[report.index("## The answer at"):].split("\n## ")[0]
    assert [line for line in section.splitlines() if line.startswith("|")] == [
        line for line in answer.splitlines() if line.startswith("|")]
    protocol = (RESULTS.parent / "docs" / "protocol.md").read_text()
    assert all(f"(../results/{path.parent.name}/results.md)" in protocol for path in RESULTS.glob("protocol_v*/results.md"))


def test_the_readme_results_are_one_answer_one_table_one_figure():
    """README's Results: at most 40 lines, one table of at most 8 columns, one figure; the rest in docs/protocol.md."""
    section = _readme_results().splitlines()[1:]
    tables = [line for line in section if line.startswith("|---")]
    assert len(section) <= 40 and len(tables) == 1 and tables[0].count("|") - 1 <= 8
    assert sum(line.startswith("![") for line in section) == 1
