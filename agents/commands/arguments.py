"""What the subcommands share: the one-line input error, JSON arguments, and printed values.

A JSON argument is read by :func:`agents.files.reader.parse_json`: nested deeper than
:data:`agents.limits.MAX_NESTING` levels, a key given twice, or any text it cannot decode (a number of
more than 4300 digits among them) is refused in one line naming the option.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

__all__ = ["CommandError", "PLANT_COEFFICIENTS", "format_value", "load_json_argument", "require_directory"]

PLANT_COEFFICIENTS = 101
""":data:`envs.systems.plants.MAX_COEFFICIENTS`, quoted by the help texts without importing envs'
numerics when the command line is parsed (tests/unit/test_hostile_input.py checks that they agree)."""


class CommandError(ValueError):
    """An error in the user's input, reported as one line."""


def load_json_argument(text: str, name: str) -> Any:
    """Parse ``text`` as JSON, or read it from a file if ``text`` is a path (:mod:`agents.files.reader`:
    nesting, duplicate keys and size within bounds, one line naming the option or the file)."""
    from agents.files.reader import parse_json, read_text

    if not text.lstrip().startswith(("{", "[")) and Path(text).is_file():
        return parse_json(read_text(Path(text)), f"{name} {text}")
    try:
        return parse_json(text, name)
    except ValueError:
        if not text.lstrip().startswith(("{", "[")):
            raise CommandError(f"{name}: no such file {text!r} (nor is it JSON)") from None
        raise


def require_directory(text: str, name: str = "--out") -> Path:
    """The output directory ``text`` names; the empty string (which would write into the working
    directory) is refused."""
    if not text.strip():
        raise CommandError(f"{name} must name a directory, got the empty string")
    return Path(text)


def format_value(value: Any) -> str:
    """A value of an analysis as the human-readable output prints it.

    >>> format_value(0.123456789), format_value(None), format_value([1.0, 2.5]), format_value([])
    ('0.123457', '-', '1, 2.5', '-')
    """
    if isinstance(value, float):
        return f"{value:.6g}"
    if value is None:
        return "-"
    if isinstance(value, list):
        return ", ".join(format_value(v) for v in value) or "-"
    return str(value)
