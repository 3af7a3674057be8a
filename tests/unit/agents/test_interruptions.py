"""Ending a command on SIGINT or SIGTERM (:mod:`agents.interruptions`): one line, status 130 or 143,
every child ended, and a second signal never shows a traceback."""

from __future__ import annotations

import io
import os
import signal
import subprocess
import sys
import time
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from agents import cli
from agents.interruptions import Terminated, descendants, end_children, interrupted

REPO = Path(__file__).resolve().parents[3]


def _run_raising(monkeypatch: pytest.MonkeyPatch, error: BaseException, during_cleanup=None) -> tuple[int, str]:
    """``deadtime analyze`` whose run raises ``error``; ``during_cleanup`` runs where children are ended."""

    def run(args):
        raise error

    monkeypatch.setattr(cli, "_parser", lambda: (cli._Parser(prog="deadtime"), {"analyze": run}))
    monkeypatch.setattr(cli._Parser, "parse_args", lambda self, argv: type("Args", (), {"command": "analyze"})())
    if during_cleanup is not None:
        import agents.interruptions as interruptions

        monkeypatch.setattr(interruptions, "end_children", lambda earlier: during_cleanup())
    err = io.StringIO()
    with redirect_stdout(io.StringIO()), redirect_stderr(err):
        status = cli.main([])
    return status, err.getvalue()


def _numba_like() -> SystemError:
    """What a compiled call raises when Ctrl-C arrives inside it: a SystemError on the KeyboardInterrupt."""
    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise SystemError("CPUDispatcher(<function _packed_analysis>) returned a result with an exception set")  # noqa: B904
    except SystemError as error:
        return error


@pytest.mark.parametrize(("error", "status", "line"), [
    (KeyboardInterrupt(), 130, "\ndeadtime analyze: interrupted\n"),
    (Terminated(), 143, "\ndeadtime analyze: terminated\n"),
    (_numba_like(), 130, "\ndeadtime analyze: interrupted\n"),
], ids=["ctrl-c", "sigterm", "ctrl-c-inside-a-compiled-call"])
def test_an_interruption_is_one_line(monkeypatch: pytest.MonkeyPatch, error: BaseException, status: int, line: str) -> None:
    assert _run_raising(monkeypatch, error) == (status, line)


def test_a_second_ctrl_c_while_ending_shows_no_traceback(monkeypatch: pytest.MonkeyPatch) -> None:
    """The second SIGINT arrives while the children are being ended: it is ignored, the status stays 130."""
    assert _run_raising(monkeypatch, KeyboardInterrupt(), lambda: os.kill(os.getpid(), signal.SIGINT)) == (
        130, "\ndeadtime analyze: interrupted\n")
    assert signal.getsignal(signal.SIGINT) is signal.default_int_handler or signal.getsignal(signal.SIGINT) == signal.SIG_IGN


def test_other_errors_are_not_taken_for_interruptions() -> None:
    assert not interrupted(RuntimeError("x")) and interrupted(_numba_like())
    try:
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt:
            raise RuntimeError("torch archive writer failed") from None
    except RuntimeError as error:
        assert interrupted(error)  # from None hides the traceback, not the context


def test_end_children_ends_new_children_only(tmp_path: Path) -> None:
    older = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    try:
        earlier = descendants()
        newer = subprocess.Popen([sys.executable, "-c", "import signal, time; signal.signal(signal.SIGTERM, signal.SIG_IGN); "
                                  "print('ready', flush=True); time.sleep(60)"], stdout=subprocess.PIPE, text=True)
        assert newer.stdout.readline() == "ready\n"  # it ignores SIGTERM from now: killed after the grace period
        end_children(earlier, grace_s=0.5)
        assert newer.wait(timeout=60) == -signal.SIGKILL  # killed when end_children returned (60 s: a hang guard)
        assert older.poll() is None
    finally:
        older.kill()
        older.wait()


@pytest.mark.slow
def test_sigterm_to_evaluate_with_workers_leaves_no_process(tmp_path: Path) -> None:
    """SIGTERM to ``deadtime evaluate --workers 2`` while its pool starts: status 143, one line, and no
    process of the run (the workers, multiprocessing's resource tracker) left once they had 60 s to end
    (a hang guard)."""
    out = tmp_path / "out"
    command = [sys.executable, "-m", "agents.cli", "evaluate", "--env", "DeadTime/PID-v3", "--policies", "all-rules,oracle",
               "--n", "20", "--workers", "2", "--no-plots", "--out", str(out)]
    driver = subprocess.Popen(command, cwd=REPO, stderr=subprocess.PIPE, stdout=subprocess.DEVNULL, text=True)
    deadline = time.monotonic() + 120
    while len(descendants(driver.pid)) < 3 and time.monotonic() < deadline:  # the tracker and two workers
        time.sleep(0.05)
    children = descendants(driver.pid)
    assert len(children) >= 3
    driver.send_signal(signal.SIGTERM)
    sent = time.monotonic()
    _, err = driver.communicate(timeout=60)
    assert driver.returncode == 143, err[-2000:]
    assert err.rstrip().splitlines()[-1] == "deadtime evaluate: terminated" and "Traceback" not in err
    while time.monotonic() < sent + 60 and any(Path(f"/proc/{pid}").exists() for pid in children):
        time.sleep(0.1)
    assert not [pid for pid in children if Path(f"/proc/{pid}").exists()]
