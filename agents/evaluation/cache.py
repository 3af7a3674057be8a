"""The per-plant cache of ``deadtime evaluate``: results appended to ``cache.jsonl``, each line checked.

Each line is one result, ``{"key", "policy", "result", "sha256"}``, where ``sha256`` is the SHA-256 of
the canonical JSON of the other three (:func:`line_digest`).  A line is used only if it parses, its
checksum matches and its result is well formed (:meth:`agents.evaluation.result.PolicyResult.from_dict`);
any other line (edited, damaged, or written without a checksum) is not trusted: its result is
computed again and appended, and :meth:`Cache.note` says once how many lines were dropped.  A later
valid line of the same ``(key, policy)`` supersedes a damaged one, so a damaged line is reported by
the run that recomputes it, not by every run after it.

Several evaluations may share one file (two runs on one ``--out``): each append holds an exclusive
``fcntl.flock`` on the file, reads first what the others appended since this cache last read it,
and skips a result that is already there, so every ``(key, policy)`` is written once; a lookup that
misses reads the others' new lines too, so a result computed by one run is not recomputed by the
other once it is on file.  A line cut short by an interruption (the file does not end in a newline)
is cut off by the next append, under the lock.

The file is never read or written through a symbolic link: a link planted under its name (which
would append results to the file it points to) is refused in one line.
"""

from __future__ import annotations

import hashlib
import json
import os
from pathlib import Path
from typing import Any

from agents.evaluation.result import PolicyResult
from agents.files.reader import FileProblem, parse_json

__all__ = ["Cache", "line_digest"]


def line_digest(key: str, policy: str, result: dict[str, Any]) -> str:
    """The checksum of a cache line: SHA-256 of ``[key, policy, result]`` as canonical JSON."""
    return hashlib.sha256(json.dumps([key, policy, result], sort_keys=True).encode()).hexdigest()


def _parse(line: str) -> tuple[tuple[str, str] | None, PolicyResult | None]:
    """``((key, policy), result)`` of a line; the result None if the line is not to be trusted, the
    pair None too if not even it can be read."""
    try:
        entry = parse_json(line, "a line of the cache", dict)
        found = (entry["key"], entry["policy"])
    except (FileProblem, KeyError, TypeError):
        return None, None
    if not all(isinstance(part, str) for part in found):
        return None, None
    if entry.get("sha256") != line_digest(*found, entry.get("result")):
        return found, None
    try:
        return found, PolicyResult.from_dict(entry["result"])
    except (ValueError, TypeError):
        return found, None


class Cache:
    """Per-plant, per-policy results of a JSON-lines file (module docstring); ``path`` None keeps them
    in memory only."""

    def __init__(self, path: Path | None) -> None:
        self.path = path
        self.entries: dict[tuple[str, str], PolicyResult] = {}
        self._on_file: set[tuple[str, str]] = set()
        self._damaged: dict[tuple[str, str], int] = {}  # untrusted lines of each (key, policy)
        self._unreadable = 0  # lines of no readable (key, policy)
        self._recomputed: set[tuple[str, str]] = set()
        self._offset = 0  # bytes of the file read so far (whole lines only)
        if path is not None and path.is_symlink():
            raise FileProblem(_LINK.format(path=path))
        self._refresh()

    def _refresh(self, file: Any = None) -> None:
        """Read the whole lines appended to the file since the last read."""
        if self.path is None:
            return
        if file is None:
            if not self.path.is_file():
                return
            with self.path.open("rb") as handle:
                handle.seek(self._offset)
                data = handle.read()
        else:
            file.seek(self._offset)
            data = file.read()
        complete = data[: data.rfind(b"\n") + 1]
        self._offset += len(complete)
        for line in complete.decode("utf-8", errors="replace").splitlines():
            found, result = _parse(line)
            if found is None:
                self._unreadable += 1
            elif result is None:
                self._damaged[found] = self._damaged.get(found, 0) + 1
            else:
                self.entries[found] = result
                self._on_file.add(found)

    def get(self, key: str, policy: str) -> PolicyResult | None:
        """The cached result, or None (then the caller computes it and :meth:`put` s it)."""
        found = self.entries.get((key, policy))
        if found is None and self.path is not None:
            self._refresh()
            found = self.entries.get((key, policy))
        if found is None and (key, policy) in self._damaged:
            self._recomputed.add((key, policy))
        return found

    def put(self, key: str, policy: str, result: PolicyResult) -> None:
        """Store ``result``, appending its line unless another run already wrote it."""
        self.entries[(key, policy)] = result
        if self.path is None:
            return
        data = result.to_dict()
        line = json.dumps({"key": key, "policy": policy, "result": data, "sha256": line_digest(key, policy, data)}) + "\n"
        with _open_for_append(self.path) as file:
            _lock(file)
            self._refresh(file)
            if (key, policy) in self._on_file:
                return  # another run wrote it first
            file.truncate(self._offset)  # a line cut short by an interruption (every line is written under the lock)
            file.seek(self._offset)
            file.write(line.encode())
            file.flush()
            self._offset = file.tell()
            self._on_file.add((key, policy))

    def note(self) -> str | None:
        """One line naming the file and how many of its lines were dropped, or None if none were."""
        dropped = self._unreadable + sum(self._damaged[pair] for pair in self._recomputed)
        if not dropped:
            return None
        return (f"{self.path}: dropped {dropped} line(s) that failed the integrity check (checksum missing or wrong, "
                "or malformed); their results were computed again")


_LINK = "{path} is a symbolic link; deadtime does not write through links in its folders: remove it"


def _open_for_append(path: Path) -> Any:
    """``path`` opened to read and append (created if missing), never through a symbolic link."""
    try:
        descriptor = os.open(path, os.O_RDWR | os.O_CREAT | os.O_APPEND | getattr(os, "O_NOFOLLOW", 0), 0o644)
    except OSError as error:
        if path.is_symlink():
            raise FileProblem(_LINK.format(path=path)) from None
        raise FileProblem(f"{path} could not be written ({error.strerror or error})") from None
    return os.fdopen(descriptor, "a+b")


def _lock(file: Any) -> None:
    """An exclusive lock on ``file`` until it is closed (``fcntl.flock``; none where there is no fcntl)."""
    try:
        import fcntl
    except ImportError:  # pragma: no cover - not POSIX
        return
    fcntl.flock(file.fileno(), fcntl.LOCK_EX)
