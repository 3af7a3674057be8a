"""The README, the docs and the command line's help texts speak of the product, not of its history.

The texts checked: ``README.md``, every ``docs/**/*.md``, and the help of ``deadtime --help`` and of
every subcommand's ``--help`` (``agents.cli.COMMANDS``).  Committed summaries under ``sweeps/*/``
are not checked: their provenance (commits, sessions, dates) belongs to them.

The patterns, case-insensitive, each a sign of a development diary rather than a description:

* ``issue 16``, ``issues 13.6``: a numbered issue of the project's tracker;
* ``#12``: a numbered reference (an issue or a pull request), not a Markdown heading or anchor;
* ``the seeds'``: the papers' procedure named by an internal nickname (the papers are named by
  their authors, the procedure "the fixed procedure");
* ``(corrected 2026-12-01)``, ``(fixed 2026-12)``: a dated correction;
* ``was wrong``: a correction of an earlier text;
* ``December 2026``: a month and year, a date of the diary;
* ``2026-12-01``: an ISO date;
* ``this session``: a working session;
* ``commit 0e32e8f``, ``at `0e32e8f```: a commit hash (hashes stay in the committed summaries'
  provenance, ``sweeps/*/sessions.json``);
* ``development machine``, ``the other machine``: the machine a figure was taken on;
* ``SPEC``: the internal specification document.
"""

from __future__ import annotations

import io
import re
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from agents.cli import COMMANDS, main

REPO = Path(__file__).resolve().parents[2]
MONTHS = "January|February|March|April|May|June|July|August|September|October|November|December"
HASH = r"(?=[0-9a-f]*\d)(?=[0-9a-f]*[a-f])[0-9a-f]{7,40}"
PATTERNS: dict[str, str] = {
    "numbered issue": r"\bissues? \d+(\.\d+)*\b",
    "numbered reference": r"(?<![\w/&#])#\d+\b",
    "the seeds' procedure": r"\bthe seeds'",
    "dated correction": r"\((corrected|fixed|updated|changed|revised)[^)]*\b(19|20)\d{2}\b",
    "correction of an earlier text": r"\bwas wrong\b",
    "month and year": rf"\b({MONTHS}) (19|20)\d{{2}}\b",
    "ISO date": r"\b(19|20)\d{2}-(0[1-9]|1[0-2])-([012]\d|3[01])\b",
    "working session": r"\bthis session\b",
    "commit hash": rf"\bcommit `?{HASH}\b|\bat `{HASH}`",
    "machine of a figure": r"\b(development|the other) machine\b",
    "internal specification": r"\bSPEC\b",
}


def offences(text: str) -> list[str]:
    """``name: excerpt`` for every match of :data:`PATTERNS` in ``text`` (whitespace normalized)."""
    flat = " ".join(text.split())
    found = []
    for name, pattern in PATTERNS.items():
        flags = 0 if name == "internal specification" else re.IGNORECASE
        for match in re.finditer(pattern, flat, flags):
            found.append(f"{name}: ...{flat[max(match.start() - 40, 0):match.end() + 40]}...")
    return found


def _documents() -> list[Path]:
    return [REPO / "README.md", *sorted((REPO / "docs").rglob("*.md"))]


@pytest.mark.parametrize("path", _documents(), ids=lambda path: str(path.relative_to(REPO)))
def test_documents_speak_of_the_product(path: Path) -> None:
    assert offences(path.read_text()) == []


def _help(*args: str) -> str:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err), pytest.raises(SystemExit) as exit_:
        main([*args, "--help"])
    assert exit_.value.code == 0, err.getvalue()
    return out.getvalue()


@pytest.mark.parametrize("command", ["", *COMMANDS])
def test_help_texts_speak_of_the_product(command: str) -> None:
    text = _help(*([command] if command else []))
    assert "usage: deadtime" in text
    assert offences(text) == []


@pytest.mark.parametrize("text, name", [
    ("as issue 16.2 asked", "numbered issue"), ("see #12", "numbered reference"),
    ("the seeds' procedure", "the seeds' procedure"), ("(corrected 2026-12-01)", "dated correction"),
    ("the table was wrong", "correction of an earlier text"), ("in December 2026", "month and year"),
    ("measured in this session", "working session"), ("at commit 0e32e8f", "commit hash"),
    ("bench at `aca0505`", "commit hash"), ("on the 2-core development machine", "machine of a figure"),
])
def test_each_pattern_finds_what_it_names(text: str, name: str) -> None:
    assert any(found.startswith(name + ":") for found in offences(text))


@pytest.mark.parametrize("text", [
    "## Results", "[terms](results.md#terms)", "`seeds` is the argument's value", "the 10 training seeds",
    "SeedSequence(20261122, spawn_key=(split, family))", "torch==2.13.0", "Grimholt and Skogestad 2018",
])
def test_product_text_passes(text: str) -> None:
    assert offences(text) == []
