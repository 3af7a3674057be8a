"""Where a sweep runs: a new local Ray instance, or the cluster at ``--address``, joined in one line.

* **Local.**  Without an address, ``ray.init(address="local")`` always starts a new instance of this
  machine's CPUs: a plain ``ray.init()`` would join a cluster already running on the machine
  (another user's ``ray start``, say) without a word.
* **An address.**  An address where nothing listens is refused at once (``ray.init`` would retry
  for minutes).  A cluster started by ``ray start`` requires Ray's token authentication when a
  token exists on its head node (``~/.ray/auth_token``, ``RAY_AUTH_TOKEN`` or ``RAY_AUTH_TOKEN_PATH``):
  where ``RAY_AUTH_MODE`` is unset and this machine has a token, the driver presents it (as ``ray
  start`` itself does); a cluster without authentication accepts a driver that presents one.  The
  connection's own log (a line per retry of the driver's C++ client) is kept out of the terminal;
  a failure is one line, naming what to set when the cluster refused the token.
"""

from __future__ import annotations

import contextlib
import logging
import os
import signal
import socket
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any
from urllib.parse import urlsplit

from agents.runtime import THREAD_VARIABLES

__all__ = ["connect"]

_TOKEN_ADVICE = ("set RAY_AUTH_TOKEN to the cluster's token (`ray get-auth-token` on its head node prints it), "
                 "or RAY_AUTH_TOKEN_PATH to a file that holds it, and RAY_AUTH_MODE=token")


@contextlib.contextmanager
def _own_sigterm() -> Iterator[None]:
    """Keep the SIGTERM handler across ``ray.init``, which replaces it by ``sys.exit`` (ending the driver
    with Ray's native dump): SIGTERM ends a sweep as Ctrl-C does (:mod:`agents.interruptions`)."""
    main = threading.current_thread() is threading.main_thread()
    previous = signal.getsignal(signal.SIGTERM) if main else None
    try:
        yield
    finally:
        if main and previous is not None:
            signal.signal(signal.SIGTERM, previous)


def connect(ray: Any, address: str | None, cpus: int | None = None) -> None:
    """Start a local Ray instance (of ``cpus`` CPUs, default the machine's), or join the cluster at
    ``address``; one thread per task.

    Raises
    ------
    ValueError
        In one line, if the address is malformed or unreachable, the cluster refuses this driver, or
        Ray cannot start.
    """
    options = {"include_dashboard": False, "log_to_driver": False, "configure_logging": False,
               "runtime_env": {"env_vars": dict.fromkeys(THREAD_VARIABLES, "1")}}
    if ray.is_initialized():
        return
    if not address or address == "local":
        with _quiet_token_notice(), _own_sigterm():
            try:
                ray.init(address="local", **options, **({} if cpus is None else {"num_cpus": cpus}))
            except Exception as error:  # ray raises ConnectionError, RuntimeError or its own errors
                raise ValueError(f"a local Ray instance could not start ({_first_line(error)})") from None
        return
    _check_reachable(address)
    with _captured_stderr() as log, _quiet_token_notice(), _own_sigterm():
        presented = _present_token()
        try:
            ray.init(address=address, **options)
        except Exception as error:  # noqa: BLE001  (as above)
            raise ValueError(_refusal(address, error, log, presented)) from None


def _first_line(error: BaseException) -> str:
    text = str(error).strip().splitlines()
    return f"{type(error).__name__}: {text[0] if text else ''}"


def _refusal(address: str, error: BaseException, log: IO[bytes], presented: bool) -> str:
    """The one line of a failed connection: the token to set if the cluster refused the driver's."""
    log.seek(0)
    if b"InvalidAuthToken" in log.read() or "InvalidAuthToken" in str(error):
        given = "refused this driver's token" if presented else "this driver has no token"
        return f"--address {address}: the cluster requires token authentication and {given}; {_TOKEN_ADVICE}"
    return f"--address {address}: Ray could not connect ({_first_line(error)})"


def _check_reachable(address: str) -> None:
    """Refuse at once an address where nothing listens."""
    if address == "auto":
        return
    parts = urlsplit(address if "://" in address else f"//{address}")
    try:
        host, port = parts.hostname, parts.port
    except ValueError:
        host, port = None, None
    if not host or port is None:
        raise ValueError(f"--address {address}: expected HOST:PORT (or ray://HOST:PORT, or auto)")
    try:
        socket.create_connection((host, port), timeout=5.0).close()
    except OSError as error:
        raise ValueError(f"--address {address}: no Ray cluster answers at {host}:{port} ({error.strerror or error})") from None


def _present_token() -> bool:
    """Use token authentication if ``RAY_AUTH_MODE`` is unset and a token is found; whether it is used."""
    mode = os.environ.get("RAY_AUTH_MODE")
    if mode is not None:
        return mode.lower() == "token"
    try:
        from ray._private.authentication.authentication_token_setup import maybe_enable_token_auth_if_token_available
    except ImportError:  # another Ray version: the token's usual places
        found = any(os.environ.get(name) for name in ("RAY_AUTH_TOKEN", "RAY_AUTH_TOKEN_PATH"))
        if found or (Path.home() / ".ray" / "auth_token").is_file():
            os.environ["RAY_AUTH_MODE"] = "token"
            return True
        return False
    return bool(maybe_enable_token_auth_if_token_available(warn_if_disabled=False))


@contextlib.contextmanager
def _quiet_token_notice() -> Iterator[None]:
    """Ray's notice that token authentication is on (every local start prints it) kept off the terminal."""
    logger = logging.getLogger("ray._private.authentication.authentication_token_setup")
    level = logger.level
    logger.setLevel(logging.ERROR)
    try:
        yield
    finally:
        logger.setLevel(level)


@contextlib.contextmanager
def _captured_stderr() -> Iterator[IO[bytes]]:
    """File descriptor 2 into a temporary file (Ray's C++ client writes there directly), restored after."""
    with tempfile.TemporaryFile() as log:
        saved = os.dup(2)
        os.dup2(log.fileno(), 2)
        try:
            yield log
        finally:
            os.dup2(saved, 2)
            os.close(saved)
