"""``sessions.json`` counts every session of a sweep, the interrupted and the killed ones too
(:mod:`agents.sweeps.sessions`); the summary's wall time is theirs."""

from __future__ import annotations

import json
import time
from pathlib import Path

import pytest

from agents.sweeps.sessions import SessionRecord, interrupted_sessions
from agents.sweeps.summary import _markdown


def _entries(out: Path) -> list[dict]:
    return json.loads((out / "sessions.json").read_text())


def test_a_running_session_is_on_record_before_it_ends_and_its_time_grows(tmp_path: Path) -> None:
    with SessionRecord(tmp_path, resume=False, cpus=2, heartbeat_s=0.05):
        assert [e["status"] for e in _entries(tmp_path)] == ["running"]
        deadline = time.monotonic() + 30
        while _entries(tmp_path)[0]["wall_time_s"] < 0.1 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert _entries(tmp_path)[0]["wall_time_s"] >= 0.1  # a heartbeat rewrote it


def test_an_interrupted_session_is_recorded_with_its_time_and_the_interrupt_goes_on(tmp_path: Path) -> None:
    started = time.perf_counter() - 5.0  # the session began 5 s ago (Ray's start is part of it)
    with pytest.raises(KeyboardInterrupt), SessionRecord(tmp_path, resume=False, cpus=2, started=started):
        raise KeyboardInterrupt
    (entry,) = _entries(tmp_path)
    assert entry["status"] == "interrupted" and entry["wall_time_s"] >= 5.0 and entry["resumed"] is False


def test_a_finished_session_follows_the_earlier_ones_and_a_killed_one_is_marked_interrupted(tmp_path: Path) -> None:
    old = {"finished": "2026-01-01T00:00:00+00:00", "resumed": False, "wall_time_s": 10.0, "cpus": 2, "commit": "a",
           "versions": {}}  # an entry written before sessions had a status: a finished session
    killed = {**old, "status": "running", "wall_time_s": 20.0}  # the process ended without a word
    (tmp_path / "sessions.json").write_text(json.dumps([old, killed]))
    with SessionRecord(tmp_path, resume=True, cpus=4) as session:
        entries = session.finished()
        assert [e.get("status") for e in _entries(tmp_path)] == [None, "interrupted", "running"]  # not saved yet
        session.save()
    assert _entries(tmp_path) == entries
    assert [e.get("status") for e in entries] == [None, "interrupted", "finished"]
    assert entries[-1]["resumed"] is True and entries[-1]["cpus"] == 4
    assert interrupted_sessions(entries) == 1


def test_a_session_whose_summary_fails_is_interrupted(tmp_path: Path) -> None:
    with pytest.raises(OSError), SessionRecord(tmp_path, resume=False, cpus=2) as session:
        session.finished()
        raise OSError("disk full")
    assert [e["status"] for e in _entries(tmp_path)] == ["interrupted"]


@pytest.mark.parametrize(("statuses", "line"), [
    ([None, "finished"], "- wall time 30 s in 2 session(s) on 2 CPUs, commit b"),
    (["interrupted", "finished"], "- wall time 30 s in 2 session(s) (1 interrupted) on 2 CPUs, commit b"),
])
def test_the_summary_says_how_many_sessions_were_interrupted(statuses: list, line: str) -> None:
    sessions = [{"wall_time_s": 10.0, "cpus": 2, "commit": "a"}, {"wall_time_s": 20.0, "cpus": 2, "commit": "b"}]
    for session, status in zip(sessions, statuses):
        if status is not None:
            session["status"] = status
    summary = {"sweep": "s", "sessions": sessions, "wall_time_s": 30.0, "failed": {}, "envs": []}
    assert line in _markdown(summary).splitlines()
