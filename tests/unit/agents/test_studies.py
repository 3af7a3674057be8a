"""``deadtime study NAME``: every study has its command line, and the command prints what its function returns."""

from __future__ import annotations

import io
from contextlib import redirect_stderr, redirect_stdout

import pytest

from agents.cli import main
from agents.commands.study import STUDIES


def run(*args: str) -> tuple[int, str, str]:
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            status = main(list(args))
        except SystemExit as exit:
            status = exit.code
    return status, out.getvalue(), err.getvalue()


@pytest.mark.parametrize("name", list(STUDIES))
def test_every_study_has_its_help(name: str) -> None:
    status, out, _ = run("study", name, "--help")
    assert status == 0 and out.startswith(f"usage: deadtime study {name}")


def test_an_unknown_study_is_one_line() -> None:
    status, _, err = run("study", "nothing")
    assert status == 2 and len(err.strip().splitlines()) == 1 and "invalid choice: 'nothing'" in err


def test_the_headline_command_prints_the_tables_of_the_committed_regimes() -> None:
    from agents.studies.headline import fixed_table, headline_table, own_plan_table

    assert run("study", "headline")[1] == headline_table() + "\n"
    assert run("study", "headline", "--own")[1] == own_plan_table() + "\n"
    assert run("study", "headline", "--fixed")[1] == fixed_table() + "\n"
