"""``DIR/sessions.json``: every invocation of a sweep, with its wall time, including the interrupted ones.

A session's entry is written when its trials are about to start and rewritten every
:data:`HEARTBEAT_S` seconds while it runs, so that a sweep ended by Ctrl-C, a kill or the end of a
machine's session still counts the time it spent: ``status`` is ``finished`` (it wrote the summary),
``interrupted`` (Ctrl-C, or an error: its wall time exact) or ``running`` (the process ended without a
word: its wall time counted to its last heartbeat, at most :data:`HEARTBEAT_S` short).  The next
session of the sweep records a ``running`` entry it finds as ``interrupted``.  Entries written before
sessions had a status are finished sessions.
"""

from __future__ import annotations

import math
import threading
import time
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

from agents.files.reader import DamagedFileError, read_record
from agents.files.writer import write_json
from agents.runtime import git_commit, versions

__all__ = ["HEARTBEAT_S", "SessionRecord", "interrupted_sessions", "read_sessions"]

HEARTBEAT_S = 60.0
"""Seconds between two rewrites of a running session's entry."""


def _now() -> str:
    return datetime.now(UTC).isoformat(timespec="seconds")


def read_sessions(path: Path) -> list[dict[str, Any]]:
    """The entries of ``sessions.json`` (none if there is no file), each checked: a mapping whose
    ``wall_time_s`` is a finite number >= 0 (the summary adds them).

    Raises
    ------
    DamagedFileError
        Naming the file and the entry.
    """
    sessions = read_record(path, list) or []
    for number, session in enumerate(sessions, start=1):
        wall = session.get("wall_time_s") if isinstance(session, dict) else None
        if isinstance(wall, bool) or not isinstance(wall, int | float) or not math.isfinite(wall) or wall < 0:
            raise DamagedFileError(f"{path} is damaged: entry {number} is not a session with a wall_time_s >= 0 "
                                   f"(got {wall!r:.40}); restore it, or move it away to start its record afresh")
    return sessions


def interrupted_sessions(sessions: list[dict[str, Any]]) -> int:
    """How many of ``sessions`` did not finish (every entry but a ``finished`` one, or one without a status)."""
    return sum(session.get("status", "finished") != "finished" for session in sessions)


class SessionRecord:
    """A context manager around one session of a sweep in ``out``.

    :meth:`finished` gives every entry with this session's marked finished, for the summary; :meth:`save`
    writes them once the summary is written.  Leaving the context before :meth:`save` (an exception,
    ``KeyboardInterrupt`` included) records the session as ``interrupted``.
    """

    def __init__(self, out: Path, resume: bool, cpus: float | None, *, started: float | None = None,
                 heartbeat_s: float = HEARTBEAT_S) -> None:
        self.path = out / "sessions.json"
        earlier = read_sessions(self.path)
        for session in earlier:
            if session.get("status") == "running":
                session["status"] = "interrupted"
        self._earlier = earlier
        self._started = time.perf_counter() if started is None else started  # a time.perf_counter()
        self._fixed = {"started": _now(), "resumed": resume, "cpus": cpus, "commit": git_commit(), "versions": versions()}
        self._final: dict[str, Any] | None = None  # this session's entry once finished
        self._saved = False
        self._heartbeat_s = heartbeat_s
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._beat, name="sessions.json", daemon=True)

    def __enter__(self) -> SessionRecord:
        self._write(self._entry("running"))
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop_beating()
        if not self._saved:
            self._write(self._entry("interrupted"))

    def finished(self) -> list[dict[str, Any]]:
        """Every entry, this session's finished with its wall time up to now."""
        self._stop_beating()
        self._final = self._entry("finished")
        return [*self._earlier, self._final]

    def save(self) -> None:
        """Write the entries of :meth:`finished` (after the summary: a finished session has written one)."""
        self._write(self._final)
        self._saved = True

    def _entry(self, status: str) -> dict[str, Any]:
        """This session's entry as of now."""
        return {**self._fixed, "finished": _now(), "status": status, "wall_time_s": round(time.perf_counter() - self._started, 1)}

    def _stop_beating(self) -> None:
        self._stop.set()
        self._thread.join()

    def _beat(self) -> None:
        while not self._stop.wait(self._heartbeat_s):
            self._write(self._entry("running"))

    def _write(self, entry: dict[str, Any]) -> None:
        """The file with ``entry`` last (the heartbeat writes only while it runs, the session only before or after)."""
        write_json(self.path, [*self._earlier, entry])
