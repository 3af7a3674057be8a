"""Ctrl-C or SIGTERM during a sweep's Tune experiment: the trials stopped, the sweep ended with status 130 or 143.

Tune stops an experiment gracefully on SIGUSR1 (saving its experiment state for ``Tuner.restore``)
but, on SIGINT, goes on to return as if the experiment had ended, so that the sweep would summarize
the trials that happened to finish.  :class:`TuneStop` takes SIGINT and SIGTERM during ``Tuner.fit``
itself: the first is recorded and passed on to Tune as SIGUSR1, the second raises ``KeyboardInterrupt``.
The driver then raises ``KeyboardInterrupt`` (:class:`agents.interruptions.Terminated` after SIGTERM)
after ``fit`` returns, and nothing final is written.
(Ray blocks SIGINT in the processes it starts, so Ctrl-C reaches the driver only.)
"""

from __future__ import annotations

import logging
import os
import signal
import threading
from types import FrameType
from typing import Any

__all__ = ["TuneStop"]

_TUNE_OWN_HANDLER = "TUNE_DISABLE_SIGINT_HANDLER"


class TuneStop:
    """A context manager around ``Tuner.fit``; ``requested`` is True once SIGINT or SIGTERM (``signum``) has arrived."""

    def __init__(self) -> None:
        self.requested = False
        self.signum: int | None = None
        self._previous: Any = None
        self._previous_term: Any = None
        self._environment: str | None = None

    def __enter__(self) -> TuneStop:
        if threading.current_thread() is threading.main_thread():
            self._environment = os.environ.get(_TUNE_OWN_HANDLER)
            os.environ[_TUNE_OWN_HANDLER] = "1"  # Tune then leaves SIGINT to this handler
            self._previous = signal.signal(signal.SIGINT, self._handle)
            self._previous_term = signal.signal(signal.SIGTERM, self._handle)
        return self

    def __exit__(self, *exc: object) -> None:
        if self._previous is None:
            return
        signal.signal(signal.SIGINT, self._previous)
        signal.signal(signal.SIGTERM, self._previous_term)
        if self._environment is None:
            os.environ.pop(_TUNE_OWN_HANDLER, None)
        else:
            os.environ[_TUNE_OWN_HANDLER] = self._environment
        self._previous = None

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        tune_listens = signal.getsignal(signal.SIGUSR1) not in (signal.SIG_DFL, signal.SIG_IGN, None)
        if self.requested or not tune_listens:
            raise KeyboardInterrupt
        self.requested, self.signum = True, signum
        logging.getLogger("ray.tune.tune").setLevel(logging.CRITICAL)  # its advice to call Tuner.restore: ours is --resume
        os.kill(os.getpid(), signal.SIGUSR1)
