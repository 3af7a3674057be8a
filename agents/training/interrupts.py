"""Stopping ``deadtime train`` cleanly: SIGINT (Ctrl-C) and SIGTERM ask for a checkpoint, then a stop.

The first signal is only recorded; the checkpoint callback writes a checkpoint at the next rollout
boundary (the only point from which a run can be continued exactly) and training stops there.  A
second SIGINT or SIGTERM stops at once with ``KeyboardInterrupt``, keeping the last checkpoint
written before it.  A ``KeyboardInterrupt`` that leaves the block after SIGTERM leaves it as
:class:`agents.interruptions.Terminated`, so that the command ends with SIGTERM's status.
"""

from __future__ import annotations

import signal
import sys
import threading
from types import FrameType
from typing import Any

__all__ = ["StopRequest"]

SIGNALS = (signal.SIGINT, signal.SIGTERM)


class StopRequest:
    """A context manager that turns the first SIGINT/SIGTERM into a request (``signum``), the second into
    ``KeyboardInterrupt``.  Outside the main thread it installs nothing (signals cannot be caught there).

    Parameters
    ----------
    boundary : str
        Says when the checkpoint will be written, for the line printed when the signal arrives.
    """

    def __init__(self, boundary: str = "at the end of the current rollout") -> None:
        self.boundary = boundary
        self.signum: int | None = None
        self._previous: dict[int, Any] = {}

    @property
    def requested(self) -> bool:
        """True once a signal has arrived."""
        return self.signum is not None

    def __enter__(self) -> StopRequest:
        if threading.current_thread() is threading.main_thread():
            self._previous = {number: signal.signal(number, self._handle) for number in SIGNALS}
        return self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None, traceback: object) -> None:
        for number, handler in self._previous.items():
            signal.signal(number, handler)
        self._previous = {}
        if self.signum == signal.SIGTERM and isinstance(error, KeyboardInterrupt):
            from agents.interruptions import Terminated

            if not isinstance(error, Terminated):  # the stop was SIGTERM's: the command ends with its status
                raise Terminated from error

    def _handle(self, signum: int, frame: FrameType | None) -> None:
        if self.signum is not None:
            raise KeyboardInterrupt
        self.signum = signum
        print(f"\ndeadtime train: {signal.Signals(signum).name} received; writing a checkpoint {self.boundary}, "
              "then stopping (send it again to stop at once, keeping the previous checkpoint)", file=sys.stderr, flush=True)
