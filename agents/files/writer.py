"""The one writer of the files ``deadtime`` writes: a write either completes or leaves the previous file whole.

Every result file (a run's records and checkpoints, ``deadtime evaluate``'s tables, the outputs of
``deadtime regimes``, a sweep's summary, their figures) is written to a temporary file in the same directory, flushed to disk and moved into
place with ``os.replace`` (which replaces a symbolic link planted at the final name, never writing through
it), so an interruption (Ctrl-C, SIGKILL, a full disk) never leaves a
half-written file under the final name, and a write that fails (a full disk) leaves no empty file
and says which file it could not write (:class:`agents.files.reader.FileProblem`).
:func:`file_digest` is the checksum recorded for each checkpoint file and each file of the learned
rule's label cache, by which a file damaged later (truncated, overwritten, a digit flipped) is recognized.
"""

from __future__ import annotations

import csv
import functools
import hashlib
import io
import json
import os
import secrets
from collections.abc import Callable, Iterable, Mapping, Sequence
from pathlib import Path
from typing import IO, Any

from agents.files.reader import FileProblem

__all__ = ["atomic_write", "atomic_write_all", "csv_text", "figure_writer", "file_digest", "text_writer", "write_bytes",
           "write_csv", "write_figure", "write_json", "write_text"]


def _not_written(path: Path, error: OSError) -> FileProblem:
    return FileProblem(f"{path} could not be written ({error.strerror or error}); the previous file, if any, is unchanged")


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
    except OSError as error:
        temporary.unlink(missing_ok=True)
        raise _not_written(path, error) from None
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    return path


def atomic_write_all(writers: Mapping[Path, Callable[[IO[bytes]], None]]) -> list[Path]:
    """Write every file of ``writers`` (path to ``write(file)``) to a temporary file, then move them all
    into place: an error or an interruption while writing leaves every previous file as it was."""
    temporaries: dict[Path, Path] = {}
    path = Path()
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
    except OSError as error:
        raise _not_written(path, error) from None
    finally:
        for temporary in temporaries.values():
            temporary.unlink(missing_ok=True)
    return list(writers)


def text_writer(text: str) -> Callable[[IO[bytes]], None]:
    """A writer (for :func:`atomic_write` and :func:`atomic_write_all`) of the UTF-8 ``text``."""
    return lambda handle: handle.write(text.encode())


def figure_writer(figure: Any, dpi: int | str, **savefig_kwargs: Any) -> Callable[[IO[bytes]], None]:
    """A writer of a matplotlib ``figure`` as PNG (``dpi="figure"``: the figure's own); ``savefig_kwargs``
    (``bbox_inches="tight"``) go to ``figure.savefig``."""
    return functools.partial(figure.savefig, format="png", dpi=dpi, **savefig_kwargs)


def csv_text(rows: Iterable[Sequence[Any]]) -> str:
    """The CSV text of ``rows`` (the first is the header), as ``csv.writer`` writes it."""
    buffer = io.StringIO(newline="")
    csv.writer(buffer).writerows(rows)
    return buffer.getvalue()


def write_text(path: str | Path, text: str) -> Path:
    """Write a UTF-8 text file atomically."""
    return atomic_write(path, text_writer(text))


def write_bytes(path: str | Path, data: bytes) -> Path:
    """Write ``data`` atomically."""
    return atomic_write(path, lambda handle: handle.write(data))


def write_figure(path: str | Path, figure: Any, dpi: int | str, **savefig_kwargs: Any) -> Path:
    """Write a matplotlib ``figure`` as PNG atomically (:func:`figure_writer`)."""
    return atomic_write(path, figure_writer(figure, dpi, **savefig_kwargs))


def write_csv(path: str | Path, rows: Iterable[Sequence[Any]]) -> Path:
    """Write a CSV table atomically (:func:`csv_text`)."""
    return write_text(path, csv_text(rows))


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
