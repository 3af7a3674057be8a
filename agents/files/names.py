"""Names that become file or folder names: one plain name each, never a path.

A regime's name is the folder of its results (``OUT/REGIME``), a learner's label part of its fit's
folder and of a policy's name in the evaluation's tables.  Such a name is refused unless it is a plain
file name: not empty, not ``.`` or ``..``, no ``/``, ``\\``, NUL or other control character, no
leading ``-`` (read as an option by the command line) and no leading or trailing space, at most
:data:`MAX_NAME` characters.  A name that passes cannot leave the folder it is joined to.
"""

from __future__ import annotations

from typing import Any

__all__ = ["MAX_NAME", "plain_name"]

MAX_NAME = 200
"""Characters of a plain name: below the 255 bytes of a file name, with room for a suffix."""


def plain_name(value: Any, where: str, also: str = "") -> str:
    """``value`` if it is a plain file name (module docstring) holding none of the characters ``also``.

    Raises
    ------
    ValueError
        One line naming ``where``, the value and what a name may not be.
    """
    problem = None
    if not isinstance(value, str) or not value:
        problem = "is empty" if value == "" else "is not a string"
    elif value in (".", ".."):
        problem = "is a folder reference"
    elif any(c in value for c in "/\\") or any(ord(c) < 32 or ord(c) == 127 for c in value):
        problem = "holds '/', '\\' or a control character"
    elif any(c in value for c in also):
        problem = f"holds one of {' '.join(repr(c) for c in also)}"
    elif value.startswith("-") or value != value.strip():
        problem = "starts with '-' or a space, or ends with a space"
    elif len(value) > MAX_NAME:
        problem = f"is longer than {MAX_NAME} characters"
    if problem:
        raise ValueError(f"{where} must be a plain file name (not '.' or '..', no '/', '\\', control character or "
                         f"leading '-'{''.join(f', no {c!r}' for c in also)}): {_shown(value)} {problem}")
    return value


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."
