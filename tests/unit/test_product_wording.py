"""The README, the docs and the command line's help texts speak of the product, not of its history.

The texts checked: ``README.md``, every ``docs/**/*.md``, and the help of ``deadtime --help`` and of
every subcommand's ``--help`` (``agents.cli.COMMANDS``).  Committed summaries under ``results/*/``
are not checked: their provenance (commits, sessions, dates) belongs to them.

The comments and docstrings of the Python sources under ``envs/``, ``baselines/``, ``agents/`` and
``tests/`` (this file excepted, which quotes the patterns) and the comments of ``configs/**/*.yaml``
(the sweep files of ``configs/sweeps/`` too) are checked for three of the patterns: a numbered issue, ``the seeds'`` and
``SPEC`` (:data:`SOURCE_PATTERNS`).  Strings the code prints are not: they are checked where they are
shown, in the help texts.

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
  provenance, ``results/*/sessions.json``);
* ``development machine``, ``the other machine``: the machine a figure was taken on;
* ``SPEC``: the internal specification document.
"""

from __future__ import annotations

import ast
import io
import re
import tokenize
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
    ('as SPEC "Design" asks', "internal specification"),
])
def test_each_pattern_finds_what_it_names(text: str, name: str) -> None:
    assert any(found.startswith(name + ":") for found in offences(text))


@pytest.mark.parametrize("text", [
    "## Results", "[terms](results.md#terms)", "`seeds` is the argument's value", "the 10 training seeds",
    "SeedSequence(20261122, spawn_key=(split, family))", "torch==2.13.0", "Grimholt and Skogestad 2018",
])
def test_product_text_passes(text: str) -> None:
    assert offences(text) == []


# ------------------------------------------------------------------ the sources' comments and docstrings

#: The patterns of :data:`PATTERNS` that the sources' comments and docstrings are checked for.
SOURCE_PATTERNS = ("numbered issue", "the seeds' procedure", "internal specification")
#: Files whose docstrings still match, edited on another branch: fixed on merge (then empty this set;
#: a pending file that passes fails as an unexpected pass, so that the set cannot go stale).
PENDING: set[str] = set()  # paths whose prose is known to fail, each an expected failure until fixed
THIS_FILE = Path(__file__).resolve()


def _sources() -> list[Path]:
    python = [path for package in ("envs", "baselines", "agents", "tests")
              for path in sorted((REPO / package).rglob("*.py")) if path.resolve() != THIS_FILE]
    yaml = sorted((REPO / "configs").rglob("*.yaml"))
    return [*python, *yaml]


def _blocks(lines: dict[int, str]) -> list[tuple[int, str]]:
    """``(first line, text)`` of each run of consecutive numbered lines, so that a phrase may wrap."""
    blocks: list[tuple[int, str]] = []
    previous = None
    for number in sorted(lines):
        if previous is not None and number == previous + 1:
            blocks[-1] = (blocks[-1][0], blocks[-1][1] + "\n" + lines[number])
        else:
            blocks.append((number, lines[number]))
        previous = number
    return blocks


def prose(path: Path) -> list[tuple[int, str]]:
    """``(line, text)`` of the comments and docstrings of a Python file, or the comments of a YAML file.

    Docstrings are the string statements of the source (a module's, class's or function's
    docstring, and the string after an assignment that documents it) and the strings assigned to
    ``__doc__`` or to a ``..._DOC`` name; other strings are what the code prints or compares,
    checked where they are shown (the help texts above).
    """
    text = path.read_text()
    if path.suffix == ".yaml":
        comments = {number: match.group(1) for number, line in enumerate(text.splitlines(), 1)
                    if (match := re.search(r"(?:^|\s)#(.*)$", line))}
        return _blocks(comments)
    comments = {token.start[0]: token.string.lstrip("#")
                for token in tokenize.generate_tokens(io.StringIO(text).readline)
                if token.type == tokenize.COMMENT}
    docstrings = []
    for node in ast.walk(ast.parse(text)):
        if isinstance(node, ast.Expr) and isinstance(node.value, ast.Constant) and isinstance(node.value.value, str):
            docstrings.append((node.lineno, node.value.value))
        elif isinstance(node, ast.Assign) and any(isinstance(target, ast.Name) and _is_doc(target.id)
                                                  for target in node.targets):
            docstrings += [(part.lineno, part.value) for part in ast.walk(node.value)
                           if isinstance(part, ast.Constant) and isinstance(part.value, str)]
    return sorted([*_blocks(comments), *docstrings])


def _is_doc(name: str) -> bool:
    """``__doc__ = ...`` or a shared piece of docstrings such as ``_SHARED_DOC``."""
    return name == "__doc__" or name.endswith("_DOC")


def source_offences(path: Path) -> list[str]:
    """``path:line: name: excerpt`` for every match of :data:`SOURCE_PATTERNS` in the file's prose."""
    where = path.relative_to(REPO)
    return [f"{where}:{line}: {found}" for line, text in prose(path) for found in offences(text)
            if found.split(":")[0] in SOURCE_PATTERNS]


def _source_cases() -> list:
    return [pytest.param(path, marks=pytest.mark.xfail(strict=True, reason="fixed on merge"))
            if str(path.relative_to(REPO)) in PENDING else path for path in _sources()]


@pytest.mark.parametrize("path", _source_cases(), ids=lambda path: str(path.relative_to(REPO)))
def test_comments_and_docstrings_speak_of_the_product(path: Path) -> None:
    assert source_offences(path) == []


def test_pending_files_exist() -> None:
    assert all((REPO / path).is_file() for path in PENDING)


def test_the_source_scan_reads_comments_and_docstrings_only(tmp_path: Path) -> None:
    python = tmp_path / "module.py"
    python.write_text('"""Module (issue 16)."""\nX = 1  # the\n# seeds\' procedure\n"""After X: SPEC."""\n'
                      '_SHARED_DOC = """v1 (issue 17)"""\n\n\ndef f():\n    """Issue 13.5."""\n'
                      '    print("issue 14 and the seeds\' SPEC")\n')
    yaml = tmp_path / "sweep.yaml"
    yaml.write_text("# Issue 17's study\nname: issue 18  # SPEC\n")
    names = [found.split(":")[0] for _, text in prose(python) for found in offences(text)]
    assert sorted(names) == sorted(["numbered issue"] * 3 + ["the seeds' procedure", "internal specification"])
    assert [line for line, text in prose(yaml) if offences(text)] == [1]
    assert [found.split(":")[0] for _, text in prose(yaml) for found in offences(text)] == [
        "numbered issue", "internal specification"]
