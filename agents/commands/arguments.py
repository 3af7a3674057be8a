"""What the subcommands share: the one-line input error, JSON arguments, and printed values.

A JSON argument nested deeper than :data:`agents.limits.MAX_NESTING` levels is refused (Python's JSON
decoder would otherwise reach its recursion limit), as is any text it cannot decode (a number of
more than 4300 digits among them), in one line naming the option.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from agents.limits import MAX_NESTING

__all__ = ["CommandError", "PLANT_COEFFICIENTS", "format_value", "load_json_argument", "require_directory"]

PLANT_COEFFICIENTS = 101
""":data:`envs.systems.plants.MAX_COEFFICIENTS`, quoted by the help texts without importing envs'
numerics when the command line is parsed (tests/unit/test_hostile_input.py checks that they agree)."""


class CommandError(ValueError):
    """An error in the user's input, reported as one line."""


def load_json_argument(text: str, name: str) -> Any:
    """Parse ``text`` as JSON, or read it from a file if ``text`` is a path."""
    source = text
    if not text.lstrip().startswith(("{", "[")) and Path(text).is_file():
        from agents.yaml_input import read_text

        source = read_text(Path(text))
    try:
        value = json.loads(source)
    except json.JSONDecodeError as error:
        if source is text and not text.lstrip().startswith(("{", "[")):
            raise CommandError(f"{name}: no such file {text!r} (nor is it JSON)") from None
        raise CommandError(f"{name} is not valid JSON ({error.msg} at position {error.pos})") from None
    except RecursionError:
        raise CommandError(f"{name} nests deeper than {MAX_NESTING} levels (agents/limits.py)") from None
    except ValueError as error:  # e.g. an integer of more digits than Python converts
        raise CommandError(f"{name} is not valid JSON ({' '.join(str(error).split())})") from None
    if _depth(value) > MAX_NESTING:
        raise CommandError(f"{name} nests deeper than {MAX_NESTING} levels (agents/limits.py)")
    return value


def _depth(value: Any) -> int:
    """Levels of lists and objects in a decoded JSON value (a scalar is 0), counted without recursion."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        item, level = stack.pop()
        children = item.values() if isinstance(item, dict) else item if isinstance(item, list) else None
        if children is not None:
            deepest = max(deepest, level)
            stack.extend((child, level + 1) for child in children)
    return deepest


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
