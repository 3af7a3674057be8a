"""``deadtime protocol run`` as a careless user or a scheduler meets it: a second run on one ``--out`` refused
in one line, SIGTERM ending with status 143 and the command that resumes, an empty ``--out`` refused."""

from __future__ import annotations

import os
import signal
import time
from collections.abc import Callable
from pathlib import Path

import pytest

from agents.cli import main
from agents.files.lock import folder_lock

def test_a_second_run_on_one_out_is_refused_in_one_line(tmp_path: Path, tiny_protocol: Callable[[Path], Path], capsys: pytest.CaptureFixture[str]) -> None:
    path, out = tiny_protocol(tmp_path), tmp_path / "out"
    with folder_lock(out, "protocol run"):  # the first run, holding --out
        assert main(["protocol", "run", str(path), "--out", str(out)]) == 2
    error = capsys.readouterr().err.strip()
    assert error.count("\n") == 0 and "in use by another deadtime protocol run" in error, error
    assert not out.exists()  # nothing written: the first run's folder, left as it was (here: removed with its lock)


def test_an_empty_out_is_refused_in_one_line_and_nothing_is_written(tmp_path: Path, tiny_protocol: Callable[[Path], Path], monkeypatch: pytest.MonkeyPatch,
                                                                      capsys: pytest.CaptureFixture[str]) -> None:
    path = tiny_protocol(tmp_path)
    work = tmp_path / "cwd"
    work.mkdir()
    monkeypatch.chdir(work)
    for action in (["run", str(path)], ["report", str(path)], ["every-rule", str(path)]):
        assert main(["protocol", *action, "--out", ""]) == 2
        error = capsys.readouterr().err.strip()
        assert error == "deadtime protocol: error: --out must name a directory, got the empty string", error
    assert list(work.iterdir()) == []


def _terminated_run(*args: object, **kwargs: object) -> list[str]:
    os.kill(os.getpid(), signal.SIGTERM)
    time.sleep(5.0)  # the signal's handler raises here
    raise AssertionError("SIGTERM did not end the run")


def test_sigterm_ends_a_run_with_143_and_the_command_that_resumes(tmp_path: Path, tiny_protocol: Callable[[Path], Path], monkeypatch: pytest.MonkeyPatch,
                                                                   capsys: pytest.CaptureFixture[str]) -> None:
    path, out = tiny_protocol(tmp_path), tmp_path / "out"
    monkeypatch.setattr("agents.protocol.run.run_protocol", _terminated_run)
    assert main(["protocol", "run", str(path), "--out", str(out), "--regime", "pid-noisy", "--workers", "0"]) == 143
    error = capsys.readouterr().err.strip()
    assert error.startswith("deadtime protocol: terminated;") and error.count("\n") == 0, error
    assert error.endswith(f"continue with: deadtime protocol run {path} --out {out} --regime pid-noisy --workers 0 --resume")


def test_sigterm_during_a_learned_rules_labels_is_sigterm_not_ctrl_c() -> None:
    """A fit stops between plants on the first signal and raises KeyboardInterrupt; after SIGTERM it leaves
    as :class:`agents.interruptions.Terminated`, so that the run ends with 143, not Ctrl-C's 130."""
    from agents.interruptions import Terminated
    from agents.training.interrupts import StopRequest

    with pytest.raises(Terminated):
        with StopRequest("of the labels after the current plant") as stop:
            os.kill(os.getpid(), signal.SIGTERM)
            while not stop.requested:
                time.sleep(0.01)
            raise KeyboardInterrupt
    with pytest.raises(KeyboardInterrupt) as caught:
        with StopRequest() as stop:
            os.kill(os.getpid(), signal.SIGINT)
            while not stop.requested:
                time.sleep(0.01)
            raise KeyboardInterrupt
    assert not isinstance(caught.value, Terminated)
