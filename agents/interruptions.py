"""How a ``deadtime`` command ends on SIGINT (Ctrl-C) or SIGTERM: one line, every child ended, status 130 or 143.

A scheduler (Slurm, Kubernetes, ``timeout``) ends a job with SIGTERM; :func:`signals_as_interrupts`
makes SIGTERM end a command as Ctrl-C does (a :class:`Terminated`, a ``KeyboardInterrupt``), where
Python's default would end the process at once and leave its children (the workers of ``deadtime
evaluate --workers``, multiprocessing's resource tracker, a local Ray cluster) running.  A command that
stops at a boundary of its own (``deadtime train``: a checkpoint first) installs its handlers inside.

When the command has been interrupted, :func:`end_children` ends every process it started: the
descendants started since the command began are listed first (a local Ray cluster's workers would be
orphaned once it shuts down, and no longer found below this process), Ray is shut down, then those
still running get SIGTERM, and SIGKILL after :data:`GRACE_S` seconds.  While it does so, and while the one line is printed, further signals are
ignored, so that a second Ctrl-C never shows a traceback.  :func:`interrupted` recognizes an
interruption that a library turned into another exception on its way out (a ``SystemError`` of a
compiled numba call, an error of torch's archive writer): one whose chain holds a ``KeyboardInterrupt``.

Processes are found through ``/proc`` (Linux); elsewhere only ``multiprocessing``'s children are ended.
"""

from __future__ import annotations

import os
import signal
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from types import FrameType
from typing import Any

__all__ = ["GRACE_S", "Terminated", "descendants", "end_children", "process_stats", "ignore_interrupts", "ignore_interrupts_in_worker", "interrupted",
           "signals_as_interrupts", "terminated"]

GRACE_S = 2.0
"""Seconds a child has, after SIGTERM, to end by itself before SIGKILL."""


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised where the command is, as Ctrl-C raises ``KeyboardInterrupt``."""

    signum = signal.SIGTERM


def _raise_terminated(signum: int, frame: FrameType | None) -> None:
    raise Terminated


@contextmanager
def signals_as_interrupts() -> Iterator[None]:
    """SIGTERM raises :class:`Terminated` while the block runs (in the main thread; its handler restored after)."""
    try:
        previous = signal.signal(signal.SIGTERM, _raise_terminated)
    except ValueError:  # not the main thread
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextmanager
def ignore_interrupts() -> Iterator[None]:
    """SIGINT and SIGTERM ignored while the block runs (the cleanup after the first one), handlers restored after."""
    previous: dict[int, Any] = {}
    try:
        for number in (signal.SIGINT, signal.SIGTERM):
            previous[number] = signal.signal(number, signal.SIG_IGN)
    except ValueError:  # not the main thread
        pass
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)


def ignore_interrupts_in_worker() -> None:
    """The initializer of a pool's worker: SIGINT ignored (the terminal sends Ctrl-C to the whole process
    group; the main process ends the workers, which would otherwise each print a traceback)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def interrupted(error: BaseException) -> bool:
    """Whether ``error`` is, or was raised while handling, a ``KeyboardInterrupt`` (Ctrl-C or SIGTERM)."""
    return _in_chain(error, KeyboardInterrupt)


def terminated(error: BaseException) -> bool:
    """Whether ``error`` is, or was raised while handling, SIGTERM's :class:`Terminated`."""
    return _in_chain(error, Terminated)


def _in_chain(error: BaseException, kind: type[BaseException]) -> bool:
    """Whether ``error`` or an exception of its chain (causes and contexts) is a ``kind``."""
    seen: set[int] = set()
    current: BaseException | None = error
    while current is not None and id(current) not in seen:
        if isinstance(current, kind):
            return True
        seen.add(id(current))
        current = current.__cause__ or current.__context__
    return False


def process_stats() -> Iterator[tuple[int, list[str]]] | None:
    """``(pid, fields)`` of every process, ``fields`` its ``/proc/PID/stat`` after the command name (which may
    hold spaces: ``fields[0]`` the state, ``[1]`` the parent, ``[3]`` the session); None where there is no ``/proc``."""
    proc = Path("/proc")
    if not (proc / "self" / "stat").exists():
        return None

    def stats() -> Iterator[tuple[int, list[str]]]:
        for entry in proc.iterdir():
            if not entry.name.isdigit():
                continue
            try:
                stat = (entry / "stat").read_text()
            except OSError:  # ended meanwhile
                continue
            yield int(entry.name), stat[stat.rindex(")") + 2:].split()
    return stats()


def _parents() -> dict[int, int] | None:
    """``{pid: parent pid}`` of every live process, or None where there is no ``/proc``."""
    stats = process_stats()
    if stats is None:
        return None
    return {pid: int(fields[1]) for pid, fields in stats if fields[0] != "Z"}  # a zombie has ended already


def descendants(pid: int | None = None) -> set[int]:
    """The live processes below ``pid`` (default this one), children of children included."""
    pid = os.getpid() if pid is None else pid
    parents = _parents()
    if parents is None:
        import multiprocessing

        return {child.pid for child in multiprocessing.active_children() if child.pid is not None}
    found, frontier = set(), {pid}
    while frontier:
        frontier = {child for child, parent in parents.items() if parent in frontier} - found
        found |= frontier
    return found


def _shutdown_ray() -> None:
    ray = sys.modules.get("ray")
    if ray is None:
        return
    try:
        if ray.is_initialized():
            ray.shutdown()
    except Exception:  # noqa: BLE001  (a cluster already gone: its processes are ended below)
        pass


def _alive(pids: set[int]) -> set[int]:
    """Those of ``pids`` still running (a zombie has ended: its parent collects its status)."""
    alive = set()
    for pid in pids:
        try:
            stat = Path(f"/proc/{pid}/stat").read_text()
        except FileNotFoundError:
            continue
        except OSError:  # no /proc: ask the process
            try:
                os.kill(pid, 0)
            except (ProcessLookupError, PermissionError):
                continue
            alive.add(pid)
            continue
        if stat[stat.rindex(")") + 2:].split()[0] != "Z":
            alive.add(pid)
    return alive


def _signal(pids: set[int], number: int) -> None:
    for pid in pids:
        try:
            os.kill(pid, number)
        except (ProcessLookupError, PermissionError):
            pass


def end_children(earlier: set[int] = frozenset(), grace_s: float = GRACE_S) -> None:
    """End every process started below this one, except ``earlier`` (those running before the command
    began, and theirs): Ray shut down, then SIGTERM, then SIGKILL after ``grace_s`` seconds."""
    spare = set(earlier)
    for pid in earlier:
        spare |= descendants(pid)
    pids = descendants() - spare  # before Ray shuts down: its workers would be orphaned, no longer below this one
    _shutdown_ray()
    pids = _alive(pids)
    if not pids:
        return
    _signal(pids, signal.SIGTERM)
    deadline = time.monotonic() + grace_s
    while time.monotonic() < deadline:
        pids = _alive(pids)
        if not pids:
            return
        time.sleep(0.05)
    _signal(pids, signal.SIGKILL)
