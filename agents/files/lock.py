"""A lock on an output folder for the whole of a run: a second run on the same folder is refused.

``deadtime train`` (and a learned rule's fit) and ``deadtime sweep`` hold :func:`folder_lock` on their
output folder from before they check what it holds until they end, so that two runs started
together on one ``--out`` cannot both find it free and overwrite each other.  The lock is
``fcntl.flock`` on ``FOLDER/.deadtime.lock``: the operating system releases it when the process ends,
however it ends (SIGKILL, a crash), so a stale lock never blocks a later run.  The file is removed
when the run ends; a lock taken on a file that another run removed meanwhile is taken again on the
new file.  Where there is no ``fcntl`` (Windows) the folder is not locked.

The lock file is opened without following a symbolic link: a link planted under its name (which would
create or lock a file elsewhere) is refused in one line.  :func:`file_lock` waits, instead of refusing,
for a short update of one shared file (the registry of test seeds), holding ``.NAME.lock`` beside it.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

from agents.files.reader import FileProblem

__all__ = ["LOCK_NAME", "FolderInUse", "file_lock", "folder_lock"]

LOCK_NAME = ".deadtime.lock"


class FolderInUse(FileProblem):
    """The output folder is held by another run."""


def _open(path: Path) -> int:
    """A descriptor of the lock file ``path`` (created if missing), never through a symbolic link."""
    try:
        return os.open(path, os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0), 0o644)
    except OSError as error:
        if path.is_symlink():
            raise FileProblem(f"{path} is a symbolic link; deadtime does not write through links in its folders: "
                              "remove it") from None
        raise FileProblem(f"{path} cannot be opened as a lock ({error.strerror or error})") from None


def _acquire(path: Path, command: str, wait: bool = False) -> int | None:
    """The descriptor of ``path`` locked exclusively, or None where there is no ``fcntl``."""
    try:
        import fcntl
    except ImportError:
        return None
    while True:
        descriptor = _open(path)
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
        except BlockingIOError:
            os.close(descriptor)
            raise FolderInUse(f"{path.parent} is in use by another deadtime {command} (it holds the lock {path.name}); "
                              "wait for that run to end, or choose another --out") from None
        try:
            same = os.stat(path).st_ino == os.fstat(descriptor).st_ino
        except FileNotFoundError:
            same = False
        if same:
            return descriptor
        os.close(descriptor)  # the run that held it removed the file meanwhile: lock the new one


@contextmanager
def folder_lock(directory: str | Path, command: str) -> Iterator[None]:
    """Hold the lock of ``directory`` (created if missing) while the ``with`` block runs.

    A folder this call created and the run left empty (a refused config) is removed at the end.

    Raises
    ------
    FolderInUse
        If another process holds it, naming the folder.
    """
    directory = Path(directory)
    created = not directory.exists()
    directory.mkdir(parents=True, exist_ok=True)
    path = directory / LOCK_NAME
    descriptor = _acquire(path, command)
    try:
        yield
    finally:
        if descriptor is not None:
            path.unlink(missing_ok=True)
            os.close(descriptor)
        if created:
            try:
                directory.rmdir()  # only if empty
            except OSError:
                pass


@contextmanager
def file_lock(path: str | Path) -> Iterator[None]:
    """Hold ``.NAME.lock`` beside the file ``path`` while the ``with`` block runs, waiting for another
    process that holds it (a read-modify-write of one shared file)."""
    path = Path(path)
    lock = path.with_name(f".{path.name}.lock")
    descriptor = _acquire(lock, "update", wait=True)
    try:
        yield
    finally:
        if descriptor is not None:
            lock.unlink(missing_ok=True)
            os.close(descriptor)
