"""``deadtime`` called in the test's own process, as a user would call it, its output captured:
``status, out, err = run_deadtime("evaluate", ...)``.  Imported by name (tests/conftest.py puts this
folder on ``sys.path``).
"""

from __future__ import annotations

import io
from contextlib import redirect_stderr, redirect_stdout

from agents.cli import main


def run_deadtime(*args: str) -> tuple[int, str, str]:
    """``deadtime ARGS``: its exit status (an argument error's too, which argparse raises as ``SystemExit``),
    standard output and standard error."""
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        try:
            status = main(list(args))
        except SystemExit as exit_:
            status = exit_.code
    return status, out.getvalue(), err.getvalue()


def error_line(*args: str) -> str:
    """The one line of ``deadtime ARGS`` that refuses its input (asserted: exit status 2, one line on
    standard error, no traceback)."""
    status, _, err = run_deadtime(*args)
    lines = err.strip().splitlines()
    assert status == 2 and len(lines) == 1 and "Traceback" not in err, (status, err[-2000:])
    return lines[0]
