"""What the subcommands share: the one-line input error, JSON arguments, and printed values."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

__all__ = ["CommandError", "format_value", "load_json_argument"]


class CommandError(ValueError):
    """An error in the user's input, reported as one line."""


def load_json_argument(text: str, name: str) -> Any:
    """Parse ``text`` as JSON, or read it from a file if ``text`` is a path."""
    source = text
    if not text.lstrip().startswith(("{", "[")) and Path(text).is_file():
        source = Path(text).read_text()
    try:
        return json.loads(source)
    except json.JSONDecodeError as error:
        if source is text and not text.lstrip().startswith(("{", "[")):
            raise CommandError(f"{name}: no such file {text!r} (nor is it JSON)") from None
        raise CommandError(f"{name} is not valid JSON ({error.msg} at position {error.pos})") from None


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
