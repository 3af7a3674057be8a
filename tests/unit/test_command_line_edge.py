"""The command line lives at the edge (docs/architecture.md: one protocol for every subcommand).

argparse is imported only by :mod:`agents.cli` (the ``deadtime`` entry point) and the subcommand
modules of :mod:`agents.commands`; the libraries of ``envs``, ``baselines`` and ``agents`` take plain
arguments.  Every import statement counts, those inside functions too (read with :mod:`ast`).
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[2]
PACKAGES = ("envs", "baselines", "agents")
COMMAND_LINE = ("agents/cli.py", "agents/commands/")
"""The entry point and the subcommands: the only modules that may import argparse."""
EXCEPTIONS: dict[str, str] = {}
"""Other modules allowed to import argparse, each with the reason (none)."""


def _modules() -> list[Path]:
    return [path for package in PACKAGES for path in sorted((REPO / package).rglob("*.py"))]


def _imports_argparse(path: Path) -> bool:
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Import) and any(alias.name.split(".")[0] == "argparse" for alias in node.names):
            return True
        if isinstance(node, ast.ImportFrom) and node.level == 0 and (node.module or "").split(".")[0] == "argparse":
            return True
    return False


def test_argparse_only_at_the_command_line() -> None:
    found = []
    for path in _modules():
        name = path.relative_to(REPO).as_posix()
        if not name.startswith(COMMAND_LINE) and name not in EXCEPTIONS and _imports_argparse(path):
            found.append(name)
    assert not found, f"argparse imported outside agents/cli.py and agents/commands/: {', '.join(found)}"


def test_every_subcommand_is_a_command_module() -> None:
    from agents.cli import COMMANDS

    outside = {name: command.module for name, command in COMMANDS.items() if not command.module.startswith("agents.commands.")}
    assert not outside, f"subcommands outside agents.commands: {outside}"


@pytest.mark.parametrize("text", ["import argparse\n", "def f():\n    from argparse import Namespace\n",
                                  "import os, argparse as ap\n"])
def test_the_scan_finds_every_form_of_the_import(text: str, tmp_path: Path) -> None:
    path = tmp_path / "module.py"
    path.write_text(text)
    assert _imports_argparse(path)
