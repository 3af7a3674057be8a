"""The tiny protocol (two regimes, two seeds, a few plants) on Ray: by ``--address`` on a ``ray start`` cluster,
and interrupted by SIGTERM then resumed on local workers, each writing the serial run's tables byte for byte."""

from __future__ import annotations

import json
import shlex
import signal
import subprocess
import sys
from pathlib import Path

import pytest
from ray_cluster import command_running, driver_environment

from agents.protocol.run import PER_PLANT, SUMMARY

REGIMES = ("pid-quiet", "pid-noisy")


def _command(protocol: Path, out: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "agents.cli", "protocol", "run", str(protocol), "--out", str(out), *extra]


def _without_commit(path: Path) -> dict:
    record = json.loads(path.read_text())
    record.pop("commit")
    return record


def _assert_same_run(expected: Path, found: Path) -> None:
    """The per-plant tables byte for byte; the choices and the summaries alike (but for the commit)."""
    for regime in REGIMES:
        assert (found / regime / PER_PLANT).read_bytes() == (expected / regime / PER_PLANT).read_bytes(), regime
        for name in ("selection.json", SUMMARY):
            assert _without_commit(found / regime / name) == _without_commit(expected / regime / name), (regime, name)


@pytest.mark.slow
def test_a_tiny_protocol_on_a_ray_cluster_by_address_writes_the_serial_tables(
        tiny_serial_run: tuple[Path, Path], ray_start_cluster: tuple[str, dict[str, str]], tmp_path: Path) -> None:
    """Fits and chunks of two plants as tasks on the cluster's two CPUs, in whatever order they finish:
    the serial run's per-plant tables, choices and summaries."""
    protocol, serial = tiny_serial_run
    address, environment = ray_start_cluster
    out = tmp_path / "on-cluster"
    done = subprocess.run(_command(protocol, out, "--address", address, "--chunk-plants", "2"), cwd=tmp_path,
                          env=environment, capture_output=True, text=True, timeout=1800)
    assert done.returncode == 0, done.stderr[-3000:]
    assert "InvalidAuthToken" not in done.stderr
    assert "validation plants 2-3 (pid-noisy) done" in done.stderr  # chunks, not one evaluation per stream
    assert len(list((out / "work" / "runs").glob("*/s*/learned_rule.json"))) == 8  # two learners, two seeds, two regimes
    _assert_same_run(serial, out)


@pytest.mark.slow
@pytest.mark.parametrize("workers", [[], ["--workers", "2"]], ids=["in-process", "local-ray"])
def test_a_run_ended_by_sigterm_during_a_fit_exits_143_and_resumes_to_the_serial_tables(
        tiny_serial_run: tuple[Path, Path], tmp_path: Path, workers: list[str]) -> None:
    """SIGTERM during a fit, in the command's process or while it waits on Ray: status 143 and the command
    that resumes (Ctrl-C's 130 and no word of it before); a second run on the same --out meanwhile refused
    in one line; the resumed run (on two local Ray workers) keeps the finished fit and writes the serial
    run's tables."""
    protocol, serial = tiny_serial_run
    out = tmp_path / "out"
    with command_running(_command(protocol, out, *workers), tmp_path) as first:
        seen = []
        for line in first.stderr:
            seen.append(line)
            if "done (1 of 8)" in line:  # the first fit is finished, the second one started
                break
        assert seen and "done (1 of 8)" in seen[-1], "".join(seen)[-2000:]
        kept = next((out / "work" / "runs").glob("*/s*/learned_rule.json"))
        stamp = kept.stat().st_mtime_ns

        second = subprocess.run(_command(protocol, out, "--resume"), cwd=tmp_path, env=driver_environment(), capture_output=True,
                                text=True, timeout=300)
        assert second.returncode == 2 and second.stderr.count("\n") == 1, second.stderr
        assert "in use by another deadtime protocol run" in second.stderr

        first.send_signal(signal.SIGTERM)
        rest = first.communicate(timeout=300)[1]
    assert first.returncode == 143, rest[-2000:]
    last = rest.strip().splitlines()[-1]
    assert last.startswith("deadtime protocol: terminated;"), rest[-2000:]
    resume = shlex.split(last.split("continue with: ")[1])
    assert resume == ["deadtime", "protocol", "run", str(protocol), "--out", str(out), *workers, "--resume"]

    on_ray = [] if workers else ["--workers", "2"]
    again = subprocess.run([sys.executable, "-m", "agents.cli", *resume[1:], *on_ray], cwd=tmp_path, env=driver_environment(),
                           capture_output=True, text=True, timeout=1800)
    assert again.returncode == 0, again.stderr[-3000:]
    assert kept.stat().st_mtime_ns == stamp  # the finished fit read back, not trained again
    _assert_same_run(serial, out)
