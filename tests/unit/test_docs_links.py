"""Links in README.md and docs/ lead somewhere.

Every Markdown link or image ``[text](target)`` of ``README.md`` and ``docs/**/*.md`` whose target is
not a URL names a file or folder that exists, relative to the page; a ``#fragment`` names a heading
of the target page (GitHub's anchors: lower case, punctuation dropped, spaces as hyphens).  Every
repository path quoted in backticks (``docs/...``, ``results/...``, ``configs/...``, ``tests/...``,
``envs/...``, ``agents/...``, ``baselines/...`` with a file extension) exists too.
"""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
LINK = re.compile(r"!?\[[^\]]*\]\(([^)\s]+)\)")
QUOTED_PATH = re.compile(r"`((?:docs|results|configs|tests|envs|agents|baselines)/[\w./-]+\.(?:md|py|yaml|json|png|csv))`")


def _pages() -> list[Path]:
    return [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md"))]


def _anchors(page: Path) -> set[str]:
    """GitHub's anchors of the headings of ``page``."""
    anchors = set()
    for line in page.read_text().splitlines():
        if line.startswith("#"):
            title = line.lstrip("#").strip().lower()
            title = re.sub(r"[^\w\- ]", "", title)
            anchors.add(title.replace(" ", "-"))
    return anchors


def _without_code_blocks(text: str) -> str:
    return re.sub(r"```.*?```", "", text, flags=re.DOTALL)


@pytest.mark.parametrize("page", _pages(), ids=lambda page: str(page.relative_to(REPO)))
def test_links_lead_to_existing_files_and_headings(page: Path) -> None:
    broken = []
    for target in LINK.findall(_without_code_blocks(page.read_text())):
        if re.match(r"[a-z]+:", target):
            continue
        path, _, fragment = target.partition("#")
        resolved = (page.parent / path).resolve() if path else page
        if not resolved.exists():
            broken.append(f"{target}: no such file")
        elif fragment and (resolved.is_dir() or fragment not in _anchors(resolved)):
            broken.append(f"{target}: no heading #{fragment}")
    assert broken == []


RETIRED = "## Retired studies"
"""The section of docs/results.md whose paths are in git history, at the commit of their row."""


@pytest.mark.parametrize("page", _pages(), ids=lambda page: str(page.relative_to(REPO)))
def test_quoted_repository_paths_exist(page: Path) -> None:
    text = page.read_text().split(RETIRED)[0]
    missing = [path for path in QUOTED_PATH.findall(text) if not (REPO / path).exists()]
    assert missing == []


def _at(commit: str, path: str) -> bool:
    return subprocess.run(["git", "cat-file", "-e", f"{commit}:{path}"], cwd=REPO, capture_output=True).returncode == 0


def test_the_retired_studies_are_in_the_history_at_their_commits() -> None:
    """docs/results.md's retired studies: no longer a ``deadtime study`` subcommand, and at the commit of
    its row both the study's module and its output (``{a,b}`` spelled out) are there for ``git show``."""
    from agents.commands.study import STUDIES

    if subprocess.run(["git", "rev-parse", "HEAD"], cwd=REPO, capture_output=True).returncode:
        pytest.skip("not a git checkout")
    section = (REPO / "docs" / "results.md").read_text().split(RETIRED)[1]
    rows = [line.split(" | ") for line in section.splitlines() if line.startswith("| `deadtime study ")]
    assert len(rows) >= 12
    for command, _, output, commit in rows:
        name, commit = command.split()[-1].rstrip("`"), commit.strip("`| ")
        if not _at(commit, "README.md"):
            pytest.skip(f"commit {commit} not in this clone")
        assert name not in STUDIES and _at(commit, f"agents/studies/{name.replace('-', '_')}.py"), name
        for quoted in re.findall(r"`([^`]+)`", output):
            head, _, rest = quoted.partition("{")
            choices, _, tail = rest.partition("}")
            paths = [head + choice + tail for choice in choices.split(",")] if rest else [quoted]
            assert all(_at(commit, path) for path in paths), (name, quoted, commit)


def test_the_anchors_are_github_s() -> None:
    assert "the-answers-of-v1-v4" in _anchors(REPO / "docs" / "protocol.md")
    assert "terms" in _anchors(REPO / "docs" / "results.md")


def test_the_readme_stays_a_five_minute_read() -> None:
    """README.md is the way in: what it is, install, two quick starts, the environments, the headline
    results and links, in at most 250 lines; the rest belongs to docs/."""
    lines = (REPO / "README.md").read_text().splitlines()
    assert len(lines) <= 250, f"README.md has {len(lines)} lines; move detail to docs/"


def test_no_docs_page_is_over_300_lines() -> None:
    """A docs page is a method page (what a mode, policy or statistic is: short, current) or a page of
    the exploration log (docs/exploration/); either stays readable in one sitting."""
    long = {str(page.relative_to(REPO)): n for page in (REPO / "docs").rglob("*.md") if (n := len(page.read_text().splitlines())) > 300}
    assert long == {}


def test_every_docs_page_is_in_the_index() -> None:
    """docs/README.md links every page of docs/, so that a reader finds each concept from one place."""
    index = (REPO / "docs" / "README.md").read_text()
    pages = [str(page.relative_to(REPO / "docs")) for page in (REPO / "docs").rglob("*.md") if page.name != "README.md"
             or page.parent != REPO / "docs"]
    assert [page for page in pages if f"]({page})" not in index] == []


def test_the_docs_stay_within_3000_lines() -> None:
    """One page per concept a user needs, the history in git: docs/ holds at most 3,000 lines of Markdown."""
    assert sum(len(page.read_text().splitlines()) for page in (REPO / "docs").rglob("*.md")) <= 3000
