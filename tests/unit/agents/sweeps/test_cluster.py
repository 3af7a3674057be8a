"""Where a sweep runs (agents.sweeps.cluster): a new local instance, or a cluster joined in one line.

Ray's side is stood in for here (``ray.init`` replaced); the sweep on a real ``ray start`` cluster is
the slow test of ``test_sweep.py``.
"""

from __future__ import annotations

import io
import os
import socket
from contextlib import redirect_stderr, redirect_stdout
from pathlib import Path

import pytest

from agents.cli import main
from agents.sweeps.cluster import connect

REPO = Path(__file__).resolve().parents[4]
SMOKE = REPO / "configs" / "sweeps" / "smoke.yaml"


class FakeRay:
    """``ray`` with an ``init`` that records its address, or writes a retry log to fd 2 and fails."""

    def __init__(self, log: bytes = b"", error: Exception | None = None) -> None:
        self.log, self.error, self.addresses = log, error, []

    def is_initialized(self) -> bool:
        return False

    def init(self, address: str | None = None, **options) -> None:
        self.addresses.append(address)
        os.write(2, self.log)
        if self.error is not None:
            raise self.error


@pytest.fixture
def listening() -> str:
    """An address where something listens (so that the reachability check passes)."""
    server = socket.create_server(("127.0.0.1", 0))
    yield f"127.0.0.1:{server.getsockname()[1]}"
    server.close()


def test_without_an_address_a_new_local_instance_starts() -> None:
    ray = FakeRay()
    connect(ray, None)
    assert ray.addresses == ["local"]  # never a cluster already running on the machine


RETRIES = b"".join(b"[2026-01-01 W 1 1] gcs_client.cc:210: Failed to get cluster ID from GCS server: Unauthenticated: "
                   b"RPC error: InvalidAuthToken: Authentication token is missing or incorrect\n" for _ in range(20))


@pytest.mark.parametrize(
    ("mode", "log", "message"),
    [("token", RETRIES, "the cluster requires token authentication and refused this driver's token; set RAY_AUTH_TOKEN"),
     ("disabled", RETRIES, "the cluster requires token authentication and this driver has no token; set RAY_AUTH_TOKEN"),
     ("disabled", b"some other failure\n" * 20, "Ray could not connect (ConnectionError: Failed to connect")],
    ids=["token-refused", "no-token", "other"],
)
def test_a_refused_connection_is_one_line_and_its_log_stays_off_the_terminal(
        tmp_path: Path, capfd, monkeypatch, listening: str, mode: str, log: bytes, message: str) -> None:
    import ray

    monkeypatch.setenv("RAY_AUTH_MODE", mode)
    fake = FakeRay(log, ConnectionError(f"Failed to connect to Ray cluster at {listening}"))
    monkeypatch.setattr(ray, "init", fake.init)
    monkeypatch.setattr(ray, "is_initialized", fake.is_initialized)
    out, err = io.StringIO(), io.StringIO()
    with redirect_stdout(out), redirect_stderr(err):
        status = main(["sweep", "--config", str(SMOKE), "--out", str(tmp_path / "out"), "--address", listening])
    assert (status, out.getvalue()) == (2, "")
    assert err.getvalue().count("\n") == 1, err.getvalue()
    assert err.getvalue().startswith(f"deadtime sweep: error: --address {listening}: {message}"), err.getvalue()
    assert capfd.readouterr().err == ""  # fd 2: nothing of Ray's log
    assert fake.addresses == [listening]
    assert not (tmp_path / "out").exists()
