"""A one-node Ray cluster of ``ray start --head`` for the tests that drive a command by ``--address``:
``with ray_head_node() as (address, environment): ...``.  Imported by name (tests/conftest.py puts this
folder on ``sys.path``); tests/unit/agents/conftest.py makes it the fixture ``ray_start_cluster``.
"""

from __future__ import annotations

import os
import secrets
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import pytest

from agents.interruptions import process_stats


def driver_environment() -> dict[str, str]:
    """The environment of a command run by a test: one BLAS thread, no Ray address inherited."""
    return {**os.environ, "OPENBLAS_NUM_THREADS": "1", "RAY_ADDRESS": ""}


@contextmanager
def command_running(command: list[str], cwd: Path) -> Iterator[subprocess.Popen[str]]:
    """``command`` started in ``cwd`` with :func:`driver_environment`, its standard error piped as text; killed
    on the way out if it is still running."""
    process = subprocess.Popen(command, cwd=cwd, env=driver_environment(), stderr=subprocess.PIPE, text=True)
    try:
        yield process
    finally:
        if process.poll() is None:
            process.kill()
            process.wait()


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _kill_session(session: int) -> None:
    """SIGKILL every process of the session ``ray start`` ran in (the head node's processes, which
    Ray starts in process groups of their own, so a process group is not enough)."""
    for pid, fields in process_stats() or ():
        if int(fields[3]) == session:
            try:
                os.kill(pid, signal.SIGKILL)
            except ProcessLookupError:
                pass


@contextmanager
def ray_head_node() -> Iterator[tuple[str, dict[str, str]]]:
    """A one-node cluster of ``ray start --head`` (two CPUs) on free ports in a temporary directory, with
    token authentication (a token in the temporary home, as ``ray start`` finds one); stopped at the end.
    The address, and the environment of a driver on this machine (the same home, RAY_AUTH_MODE unset).
    The test is skipped where ``ray start`` is unavailable."""
    ray = Path(sys.executable).with_name("ray")
    if not ray.is_file() or not Path("/proc").is_dir():
        pytest.skip(f"ray start is unavailable: no {ray}" if not ray.is_file() else "ray start is unavailable: no /proc")
    root = Path(tempfile.mkdtemp(prefix="dtray", dir="/tmp"))  # short: Ray's socket paths have a length limit
    (root / "home" / ".ray").mkdir(parents=True)
    (root / "home" / ".ray" / "auth_token").write_text(secrets.token_hex(32))
    environment = {key: value for key, value in driver_environment().items() if not key.startswith("RAY_AUTH")}
    environment["HOME"] = str(root / "home")
    port = _free_port()
    command = [str(ray), "start", "--head", "--block", f"--port={port}", f"--temp-dir={root / 'ray'}", "--num-cpus=2",
               "--include-dashboard=false", f"--dashboard-port={_free_port()}", f"--ray-client-server-port={_free_port()}",
               f"--dashboard-agent-listen-port={_free_port()}", "--disable-usage-stats"]
    head = subprocess.Popen(command, env=environment, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True)
    try:
        deadline, lines = time.monotonic() + 120, []
        while time.monotonic() < deadline:
            line = head.stdout.readline()
            lines.append(line)
            if "Ray runtime started" in line:
                break
            if not line and head.poll() is not None:
                pytest.skip(f"ray start is unavailable: it exited with status {head.returncode}: {''.join(lines)[-500:]}")
        else:
            pytest.skip("ray start is unavailable: the head node did not start within 120 s")
        assert "Token authentication is enabled" in "".join(lines)
        yield f"127.0.0.1:{port}", environment
    finally:
        _kill_session(head.pid)
        head.wait(timeout=30)
        shutil.rmtree(root, ignore_errors=True)
