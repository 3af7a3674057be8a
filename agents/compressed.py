"""Result files stored plain or gzip-compressed, read by the same name.

The committed results (``results/``) keep their bulky tables and records compressed
(``per_plant.csv.gz``, ``results.json.gz``, ``summary.json.gz``, ...) so that a clone stays light.
Every reader of a sweep's files opens them through :func:`open_text` with the plain name: the plain
file when it exists, else the same name with ``.gz``.  :func:`compress_file` writes the ``.gz`` with
the modification time 0 and no file name in its header, so that the same text gives the same bytes
on every machine (``deadtime results compress DIR`` compresses a finished sweep's tables in place).
"""

from __future__ import annotations

import gzip
import io
import json
from pathlib import Path
from typing import IO, Any

__all__ = ["COMPRESSED_NAMES", "compress_file", "compressed_bytes", "exists", "open_text", "read_json", "read_text",
           "stored_path"]

# the files of a sweep stored compressed under results/: every CSV table, and these JSON records
COMPRESSED_NAMES = ("results.json", "summary.json", "learned_rule.json", "evaluations.json")


def stored_path(path: str | Path) -> Path:
    """``path`` if it exists, else ``path`` + ``.gz`` if that exists, else ``path`` (so that an error names it)."""
    path = Path(path)
    if path.exists() or path.suffix == ".gz":
        return path
    compressed = path.with_name(path.name + ".gz")
    return compressed if compressed.exists() else path


def exists(path: str | Path) -> bool:
    """Whether ``path`` or its ``.gz`` is a file."""
    return stored_path(path).is_file()


def open_text(path: str | Path) -> IO[str]:
    """``path`` opened for reading text (CSV: ``newline=""``), decompressed if stored as ``.gz``."""
    found = stored_path(path)
    if found.suffix == ".gz":
        return io.TextIOWrapper(gzip.open(found, "rb"), encoding="utf-8", newline="")
    return found.open(encoding="utf-8", newline="")


def read_text(path: str | Path) -> str:
    """The text of ``path`` or of its ``.gz``."""
    with open_text(path) as file:
        return file.read()


def read_json(path: str | Path) -> Any:
    """The JSON object of ``path`` or of its ``.gz``."""
    return json.loads(read_text(path))


def compressed_bytes(data: bytes) -> bytes:
    """``data`` gzip-compressed (level 9), with the modification time 0: the same data, the same bytes."""
    return gzip.compress(data, compresslevel=9, mtime=0)


def compress_file(path: str | Path) -> Path:
    """Replace ``path`` by ``path.gz`` (:func:`compressed_bytes`); returns the new path."""
    path = Path(path)
    target = path.with_name(path.name + ".gz")
    temporary = path.with_name(f".{target.name}.tmp")
    temporary.write_bytes(compressed_bytes(path.read_bytes()))
    temporary.replace(target)
    path.unlink()
    return target
