"""The code's hash of a protocol run: recorded, and a run from other code refused in one line unless marked."""

from __future__ import annotations

import hashlib
import subprocess
from pathlib import Path

import pytest

from agents.protocol.code import CodeRefused, check_code, code_state


def _git(root: Path, *args: str) -> None:
    subprocess.run(["git", "-C", str(root), *args], check=True, capture_output=True)


@pytest.fixture
def checkout(tmp_path: Path) -> Path:
    """A git checkout of two hashed files, one file outside the hashed paths, committed."""
    _git(tmp_path, "init", "-q")
    (tmp_path / "agents").mkdir()
    (tmp_path / "agents" / "a.py").write_text("A = 1\n")
    (tmp_path / "pyproject.toml").write_text("[project]\n")
    (tmp_path / "README.md").write_text("readme\n")
    _git(tmp_path, "add", ".")
    _git(tmp_path, "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qm", "first")
    return tmp_path


def test_the_hash_is_that_of_the_tracked_files_contents_by_path(checkout: Path) -> None:
    """Recomputed independently: sha256 of ``path\\0sha256(contents)\\n`` over the hashed files in path order."""
    expected = hashlib.sha256()
    for path in ("agents/a.py", "pyproject.toml"):
        expected.update(f"{path}\0{hashlib.sha256((checkout / path).read_bytes()).hexdigest()}\n".encode())
    state = code_state(checkout)
    assert state["sha256"] == expected.hexdigest() and state["clean"]
    (checkout / "README.md").write_text("another readme\n")  # outside the hashed paths
    (checkout / "agents" / "untracked.py").write_text("B = 2\n")  # not tracked
    assert code_state(checkout) == state


def test_a_new_run_from_an_edited_tree_is_refused_in_one_line_unless_marked(checkout: Path) -> None:
    (checkout / "agents" / "a.py").write_text("A = 2\n")
    with pytest.raises(CodeRefused, match="differs from its commit") as refused:
        check_code(None, False, checkout)
    assert "\n" not in str(refused.value) and "--uncommitted-code" in str(refused.value)
    marked = check_code(None, True, checkout)
    assert marked["marked"] and not marked["clean"]


def test_a_resumed_run_from_another_commit_is_refused_unless_marked(checkout: Path) -> None:
    record = check_code(None, False, checkout)
    assert not record["marked"] and record["clean"]
    assert check_code(record, False, checkout) == record  # the same code: the record as it is
    (checkout / "agents" / "a.py").write_text("A = 3\n")
    _git(checkout, "-c", "user.name=t", "-c", "user.email=t@t", "commit", "-qam", "second")
    with pytest.raises(CodeRefused, match="is not the run's recorded") as refused:
        check_code(record, False, checkout)
    assert "\n" not in str(refused.value)
    continued = check_code(record, True, checkout)
    assert continued["marked"] and continued["continued_with"][0]["sha256"] != record["sha256"]


def test_outside_a_git_checkout_the_code_is_not_clean(tmp_path: Path) -> None:
    assert code_state(tmp_path) == {"commit": "unknown", "sha256": "unknown", "clean": False}
    with pytest.raises(CodeRefused):
        check_code(None, False, tmp_path)


def test_a_protocol_run_records_the_code_and_refuses_other_code_unless_marked(tmp_path, tiny_protocol, monkeypatch):
    """``start`` with the code's state given: a tree not clean refused, then marked; a resumed run on another hash
    refused, then recorded among the hashes it was continued with."""
    import json

    import agents.protocol.code as code
    from agents.protocol.config import load_protocol
    from agents.protocol.run import ProtocolRefused, start

    protocol = load_protocol(tiny_protocol(tmp_path))
    out = tmp_path / "out"
    monkeypatch.setattr(code, "code_state", lambda root=None: {"commit": "c1", "sha256": "h1", "clean": False})
    with pytest.raises(ProtocolRefused, match="differs from its commit c1") as refused:
        start(protocol, out, resume=False, uncommitted=False)
    assert "\n" not in str(refused.value) and not out.exists()
    start(protocol, out, resume=False, uncommitted=True)
    record = json.loads((out / "protocol.json").read_text())
    assert record["code"]["sha256"] == "h1" and record["code"]["marked"] and record["commit"] == "c1-dirty"
    monkeypatch.setattr(code, "code_state", lambda root=None: {"commit": "c2", "sha256": "h2", "clean": True})
    with pytest.raises(ProtocolRefused, match="is not the run's recorded h1"):
        start(protocol, out, resume=True, uncommitted=False)
    start(protocol, out, resume=True, uncommitted=True)
    record = json.loads((out / "protocol.json").read_text())
    assert record["code"]["sha256"] == "h1" and record["code"]["continued_with"][0]["sha256"] == "h2"
