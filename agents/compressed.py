"""Result files stored plain or gzip-compressed, read by the same name.

The committed results (``results/``) keep their bulky tables and records compressed
(``per_plant.csv.gz``, ``results.json.gz``, ``summary.json.gz``, ...) so that a clone stays light.
Every reader of a sweep's files reads them with the plain name (:mod:`agents.files.reader`, the one
reader, whose :func:`~agents.files.reader.read_text`, :func:`~agents.files.reader.read_json` and
:func:`~agents.files.reader.stored_path` this module gives on): the plain file when it exists, else
the same name with ``.gz``.  :func:`compress_file` writes the ``.gz`` with
the modification time 0 and no file name in its header, so that the same text gives the same bytes
on every machine (``deadtime results compress DIR`` compresses a finished sweep's tables in place).
"""

from __future__ import annotations

import gzip
import io
from pathlib import Path
from typing import IO

from agents.files.reader import exists, read_json, read_text, stored_path
from agents.files.writer import write_bytes

__all__ = ["COMPRESSED_NAMES", "compress_file", "compressed_bytes", "exists", "open_text", "read_json", "read_text",
           "stored_path"]

# the files of a sweep stored compressed under results/: every CSV table, and these JSON records
COMPRESSED_NAMES = ("results.json", "summary.json", "learned_rule.json", "evaluations.json")


def open_text(path: str | Path) -> IO[str]:
    """The text of ``path`` or of its ``.gz`` (:func:`agents.files.reader.read_text`), as a file (CSV: ``newline=""``)."""
    return io.StringIO(read_text(path), newline="")


def compressed_bytes(data: bytes) -> bytes:
    """``data`` gzip-compressed (level 9), with the modification time 0: the same data, the same bytes."""
    return gzip.compress(data, compresslevel=9, mtime=0)


def compress_file(path: str | Path) -> Path:
    """Replace ``path`` by ``path.gz`` (:func:`compressed_bytes`); returns the new path."""
    path = Path(path)
    target = path.with_name(path.name + ".gz")
    write_bytes(target, compressed_bytes(path.read_bytes()))
    path.unlink()
    return target
