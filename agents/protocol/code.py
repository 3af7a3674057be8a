"""The code a protocol run is scored by: its commit and the SHA-256 of its tracked source files.

The hashed files are those git tracks under :data:`HASHED` in the checkout the package is imported
from (not the working directory: a run may write anywhere); the hash is
``sha256("path\\0sha256(contents)\\n" ...)`` over them in path order, of the files as they are on disk.
It is the same for every checkout of one commit, and differs as soon as one of those files changes
(a commit or an edit not committed).  The commit's own hash (the same files as committed) tells an
edited tree from a clean one.

:func:`check_code` is the rule of ``deadtime protocol run``: a new run starts only from a clean tree,
and a run resumes only from a tree of the recorded hash; otherwise it is refused in one line, unless
``uncommitted`` marks the results (``protocol.json`` then lists every hash the run was continued with,
and ``code_marked`` is true).  Outside a git checkout the commit is ``unknown`` and the tree counts
as not clean.
"""

from __future__ import annotations

import hashlib
import subprocess
from pathlib import Path
from typing import Any

__all__ = ["HASHED", "CodeRefused", "check_code", "code_state"]

HASHED: tuple[str, ...] = ("envs", "agents", "baselines", "configs", "pyproject.toml", "constraints.txt")
"""The tracked paths whose contents are the code's hash."""

ROOT = Path(__file__).resolve().parents[2]
"""The checkout the package is imported from."""


class CodeRefused(ValueError):
    """A run whose code is not the code its results record."""


def _git(root: Path, *args: str, text: bool = True) -> Any:
    return subprocess.run(["git", "-C", str(root), *args], capture_output=True, text=text, check=True).stdout


def _digest(entries: list[tuple[str, bytes]]) -> str:
    total = hashlib.sha256()
    for path, data in entries:
        total.update(f"{path}\0{hashlib.sha256(data).hexdigest()}\n".encode())
    return total.hexdigest()


def _committed(root: Path, head: str, paths: list[str]) -> list[tuple[str, bytes]]:
    """The contents of ``paths`` as committed at ``head`` (one ``git cat-file --batch``)."""
    requests = "".join(f"{head}:{path}\n" for path in paths).encode()
    output = subprocess.run(["git", "-C", str(root), "cat-file", "--batch"], input=requests, capture_output=True,
                            check=True).stdout
    entries, position = [], 0
    for path in paths:
        header_end = output.index(b"\n", position)
        header = output[position:header_end].split()
        if len(header) != 3:  # "<object> missing": added since the commit
            position = header_end + 1
            continue
        size = int(header[2])
        entries.append((path, output[header_end + 1:header_end + 1 + size]))
        position = header_end + 1 + size + 1
    return entries


def code_state(root: Path = ROOT) -> dict[str, Any]:
    """``{"commit", "sha256", "clean"}`` of the checkout at ``root`` (module docstring)."""
    try:
        head = _git(root, "rev-parse", "HEAD").strip()
        paths = sorted(_git(root, "ls-files", "-z", "--", *HASHED).split("\0"))
    except (OSError, subprocess.CalledProcessError):
        return {"commit": "unknown", "sha256": "unknown", "clean": False}
    paths = [path for path in paths if path]
    on_disk = [(path, (root / path).read_bytes()) for path in paths if (root / path).is_file()]
    sha256 = _digest(on_disk)
    return {"commit": head, "sha256": sha256, "clean": sha256 == _digest(_committed(root, head, paths))}


def check_code(record: dict[str, Any] | None, uncommitted: bool, root: Path = ROOT) -> dict[str, Any]:
    """The ``code`` entry of a run's ``protocol.json``: the new run's (``record`` None) or ``record`` continued.

    Raises
    ------
    CodeRefused
        One line: a new run from a tree with changes not committed, or a resumed run from a tree whose
        hash is not the recorded one, without ``uncommitted``.
    """
    state = code_state(root)
    flag = "or pass --uncommitted-code to mark the results as scored by code not committed"
    if record is None:
        if not state["clean"] and not uncommitted:
            raise CodeRefused(f"the code in {root} differs from its commit {state['commit'][:12]} (changes not committed "
                              f"under {', '.join(HASHED)}): commit them, {flag}")
        return {**state, "marked": not state["clean"], "continued_with": []}
    if state["sha256"] == record.get("sha256"):
        return record
    if not uncommitted:
        raise CodeRefused(f"the code's hash {state['sha256'][:12]} (commit {state['commit'][:12]}) is not the run's "
                          f"recorded {str(record.get('sha256'))[:12]} (commit {str(record.get('commit'))[:12]}): check "
                          f"out the recorded commit, {flag}")
    return {**record, "marked": True, "continued_with": [*record.get("continued_with", []), state]}
