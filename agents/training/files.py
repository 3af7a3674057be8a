"""Atomic files of ``deadtime train``: a write either completes or leaves the previous file whole.

Every file is written to a temporary file in the same directory, flushed to disk and moved into
place with ``os.replace``, so an interruption (Ctrl-C, SIGKILL, a full disk) never leaves a
half-written file under the final name.  :func:`file_digest` is the checksum recorded for each
checkpoint file, by which a file damaged later (truncated, overwritten) is recognized.
:func:`read_record` reads back a JSON record of a run (``run.json``, a sweep's ``sessions.json``)
before any work starts, so that a damaged one is named at once (:class:`DamagedFileError`) rather
than failing the run when it is rewritten at the end.
"""

from __future__ import annotations

import hashlib
import json
import os
import secrets
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import IO, Any

__all__ = ["DamagedFileError", "atomic_write", "atomic_write_all", "file_digest", "read_record", "write_json", "write_text"]


class DamagedFileError(ValueError):
    """A file of a run that is missing, truncated or unreadable; the message names it."""


def atomic_write(path: str | Path, write: Callable[[IO[bytes]], None]) -> Path:
    """Write ``path`` through ``write(file)`` on a temporary file in the same directory, then ``os.replace``."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    temporary = path.parent / f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
    try:
        with open(temporary, "xb") as handle:  # honours the umask, unlike mkstemp's 0600
            write(handle)
            handle.flush()
            os.fsync(handle.fileno())
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    return path


def atomic_write_all(writers: Mapping[Path, Callable[[IO[bytes]], None]]) -> list[Path]:
    """Write every file of ``writers`` (path to ``write(file)``) to a temporary file, then move them all
    into place: an error or an interruption while writing leaves every previous file as it was."""
    temporaries: dict[Path, Path] = {}
    try:
        for path, write in writers.items():
            path.parent.mkdir(parents=True, exist_ok=True)
            temporaries[path] = path.parent / f".{path.name}.{os.getpid()}.{secrets.token_hex(4)}.tmp"
            with open(temporaries[path], "xb") as handle:
                write(handle)
                handle.flush()
                os.fsync(handle.fileno())
        for path, temporary in temporaries.items():
            os.replace(temporary, path)
    finally:
        for temporary in temporaries.values():
            temporary.unlink(missing_ok=True)
    return list(writers)


def write_text(path: str | Path, text: str) -> Path:
    """Write a UTF-8 text file atomically."""
    return atomic_write(path, lambda handle: handle.write(text.encode()))


def write_json(path: str | Path, data: Any) -> Path:
    """``json.dump`` atomically (indented, trailing newline)."""
    return write_text(path, json.dumps(data, indent=2) + "\n")


def file_digest(path: str | Path) -> str:
    """The SHA-256 of a file's bytes, as hex."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def read_record(path: str | Path, kind: type[dict] | type[list]) -> Any:
    """The JSON object (``kind`` dict) or array (``kind`` list) of ``path``, or None if there is no file.

    Raises
    ------
    DamagedFileError
        If the file cannot be read, is not valid JSON or not of ``kind``, naming it and what to do.
    """
    path = Path(path)
    if not path.exists():
        return None
    advice = "restore it, or move it away to start its record afresh"
    try:
        data = json.loads(path.read_text())
    except OSError as error:
        raise DamagedFileError(f"{path} cannot be read ({error.strerror or error})") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as error:
        raise DamagedFileError(f"{path} is damaged, not valid JSON ({error}); {advice}") from None
    except RecursionError:
        raise DamagedFileError(f"{path} is damaged, nested too deeply; {advice}") from None
    if not isinstance(data, kind):
        raise DamagedFileError(f"{path} is damaged: a JSON {'object' if kind is dict else 'array'} was expected, "
                               f"got {type(data).__name__}; {advice}")
    return data
